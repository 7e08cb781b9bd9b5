"""Learned controllers for ``SmaSpine-v0`` (the Stable-Baselines3 side of spine_gym).

* :mod:`spine_gym.agents.train` — RL-Zoo-style training CLI (``python -m spine_gym.agents.train --algo ppo``).
* :mod:`spine_gym.agents.evaluate` — the fixed scenario suite for baselines and saved models
  (``python -m spine_gym.agents.evaluate``).
* :mod:`spine_gym.agents.scenarios` — the named, seeded scenarios of that suite.
* :mod:`spine_gym.agents.video` — MP4 videos of evaluation episodes (``python -m spine_gym.agents.evaluate --video``).
* :mod:`spine_gym.agents.tune` — reproducible tuning of the PID and bang-bang baselines on training scenarios.
* :mod:`spine_gym.agents.zoo_config` — env ids, algorithms and the hyperparameter files.
* :mod:`spine_gym.agents.runtime` — loading saved policies, building controllers, running episodes.
* :mod:`spine_gym.agents.export` — a trained policy as ONNX, NumPy arrays and C (``python -m spine_gym.agents.export``);
  :mod:`spine_gym.agents.numpy_policy` runs the bundle without torch, :mod:`spine_gym.agents.export_c` writes the C.

``spine_gym/agents/policies/`` holds the shipped PPO and SAC policies with their ``VecNormalize``
statistics and the exact commands that produced them.
"""
