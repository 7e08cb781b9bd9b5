"""The learners of Stable-Baselines3's JAX edition (``sbx-rl``, the ``jax`` extra), by their names in
:data:`spine_gym.agents.zoo_config.JAX_ALGOS`.

* ``crossq`` — ``sbx.CrossQ``: SAC without target networks, batch renormalisation in actor and
  critic, one gradient step per transition (Bhatt et al., ICLR 2024).
* ``droq`` — ``sbx.SAC`` in its DroQ configuration (dropout and layer norm in the critics, many
  gradient steps per transition; Hiraoka et al., ICLR 2022); the configuration is the
  hyperparameter file's (``spine_gym/agents/hyperparams/droq.yml``), the class is SBX's SAC.
* ``sbx_sac`` — ``sbx.SAC`` sized for a CPU core (small networks, several updates per jit-compiled
  call; ``spine_gym/agents/hyperparams/sbx_sac.yml``).
* ``sbx_tqc`` — ``sbx.TQC`` (distributional critics, the top quantiles of their target dropped;
  Kuznetsov et al., ICML 2020) with ``sbx_sac``'s networks and schedule
  (``spine_gym/agents/hyperparams/sbx_tqc.yml``).
* ``sbx_mbpo`` — model-based policy optimisation (Janner et al., NeurIPS 2019) on ``sbx.SAC``: a learnt
  ensemble dynamics model's short rollouts mixed into SAC's batches (:class:`spine_gym.agents.model_based.MBPO`,
  ``spine_gym/agents/hyperparams/sbx_mbpo.yml``).

Their models save, load and predict as SB3's do (SBX keeps SB3's interfaces), so training,
checkpoints, evaluation and the benchmark treat them like the torch algorithms;
:mod:`spine_gym.agents.export` reads their actors' JAX parameters.

JAX runs on one CPU thread unless ``XLA_FLAGS`` says otherwise (:data:`ONE_THREAD_XLA_FLAGS`, set
before JAX is first imported): the machines this runs on share their cores between runs.
"""

from __future__ import annotations

import importlib
import os
import sys

#: XLA's CPU backend on one thread (Eigen's thread pool off, one intra-op thread)
ONE_THREAD_XLA_FLAGS = "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"

_CLASSES = {"crossq": "CrossQ", "droq": "SAC", "sbx_sac": "SAC", "sbx_tqc": "TQC", "sbx_mbpo": "SAC"}  # algo -> class of the sbx package (sbx_mbpo: its subclass)


def jax_algo_class(algo: str) -> type:
    """The ``sbx`` class of ``algo`` (``crossq``: ``CrossQ``; ``droq``, ``sbx_sac``: ``SAC``; ``sbx_tqc``: ``TQC``; ``sbx_mbpo``: :class:`~spine_gym.agents.model_based.MBPO`, SAC's subclass); an ImportError naming
    the extra to install if ``sbx-rl`` is missing."""
    if algo not in _CLASSES:
        raise ValueError(f"algo must be one of {tuple(_CLASSES)}, got {algo!r}")
    if "jax" not in sys.modules:
        os.environ.setdefault("XLA_FLAGS", ONE_THREAD_XLA_FLAGS)
    try:
        import sbx
    except ImportError as e:
        raise ImportError(
            f"algo {algo!r} needs Stable-Baselines3's JAX edition: pip install 'spine_gym[jax]' ({e})"
        ) from e
    if algo == "sbx_mbpo":  # not imported with this module: it would load JAX before the thread flags are set
        return importlib.import_module(f"{__package__}.model_based").MBPO
    return getattr(sbx, _CLASSES[algo])
