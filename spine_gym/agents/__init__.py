"""Learned controllers for the spine envs (the Stable-Baselines3 side of spine_gym), one module per concept.

Command lines (each ``python -m spine_gym.agents.<name>``, and ``spine-gym <name>`` for most):

* :mod:`~spine_gym.agents.train` — RL-Zoo-style training (``--algo ppo``); :mod:`~spine_gym.agents.evaluate` —
  the fixed scenario suite for baselines and saved models (``--video``: :mod:`~spine_gym.agents.video`);
  :mod:`~spine_gym.agents.tune` — tuning the PID and bang-bang baselines; :mod:`~spine_gym.agents.benchmark` —
  RL algorithms x env ids at fixed budgets; :mod:`~spine_gym.agents.selection` — scoring candidate policies;
  :mod:`~spine_gym.agents.export` — a policy as ONNX, NumPy and C; :mod:`~spine_gym.agents.datasets` — Minari
  datasets of a controller; :mod:`~spine_gym.agents.behaviour_cloning` — a policy fitted to one.

Runtime (no command line):

* :mod:`~spine_gym.controllers.registry` — the one table of controllers (with the controllers); :mod:`~spine_gym.agents.runtime` — envs,
  controllers, saved policies, episodes; :mod:`~spine_gym.agents.scenarios`, :mod:`~spine_gym.agents.metrics`.
* :mod:`~spine_gym.agents.evaluation` — controllers on the scenario suite, its tables and files;
  :mod:`~spine_gym.agents.minari_datasets` — Minari datasets recorded and read.
* :mod:`~spine_gym.agents.observations` — the observation features (integral of the error, frame
  history); :mod:`~spine_gym.agents.residual`, :mod:`~spine_gym.agents.lagrangian` — the residual and
  energy-budget wrappers.
* :mod:`~spine_gym.agents.training` — how a training run is built; :mod:`~spine_gym.agents.vec_env` — its
  vector envs; :mod:`~spine_gym.agents.checkpoints` — resumable checkpoints;
  :mod:`~spine_gym.agents.entropy_coef` — a loaded SAC's entropy coefficient, learned or fixed;
  :mod:`~spine_gym.agents.benchmark_run` — one benchmark run and many.
* :mod:`~spine_gym.agents.zoo_config` — env ids, algorithms and the hyperparameter files
  (``spine_gym/agents/hyperparams/``).
* :mod:`~spine_gym.agents.numpy_policy`, :mod:`~spine_gym.agents.export_c` — an exported bundle without torch.

``spine_gym/agents/policies/`` holds the shipped policies with their ``VecNormalize`` statistics and the
exact commands that produced them. One-off studies that informed a decision are scripts in
``scripts/studies/``.
"""
