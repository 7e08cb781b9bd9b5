"""Shared test set-up: one torch thread (on 2 cores a second one made PPO slower)."""

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

try:  # torch comes with the [rl] extra; the physics and env tests run without it
    import torch

    torch.set_num_threads(1)
except ImportError:  # pragma: no cover
    pass
