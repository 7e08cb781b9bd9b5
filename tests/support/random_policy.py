"""The floor a shipped policy must clear: seeded uniform random actions."""

import numpy as np


class RandomPolicy:
    """Uniform random actions in [-1, 1] for ``n`` wires, seeded: the floor a shipped policy must clear."""

    def __init__(self, n: int):
        self.n, self.rng = n, np.random.default_rng(0)

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        return self.rng.uniform(-1, 1, (np.atleast_2d(obs).shape[0], self.n)).astype(np.float32), None
