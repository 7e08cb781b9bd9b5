"""Learned controllers for ``SmaSpine-v0`` (the Stable-Baselines3 side of spine_gym).

* :mod:`agents.train` — RL-Zoo-style training CLI (``python -m agents.train --algo ppo``).
* :mod:`agents.evaluate` — the fixed scenario suite for baselines and saved models
  (``python -m agents.evaluate``).
* :mod:`agents.scenarios` — the named, seeded scenarios of that suite.
* :mod:`agents.video` — MP4 videos of evaluation episodes (``python -m agents.evaluate --video``).
* :mod:`agents.tune` — reproducible tuning of the PID and bang-bang baselines on training scenarios.
* :mod:`agents.common` — loading saved policies, env construction and hyperparameter files.
* :mod:`agents.export` — a trained policy as ONNX, NumPy arrays and C (``python -m agents.export``);
  :mod:`agents.numpy_policy` runs the bundle without torch, :mod:`agents.export_c` writes the C.

``agents/policies/`` holds the shipped PPO and SAC policies with their ``VecNormalize``
statistics and the exact commands that produced them.
"""
