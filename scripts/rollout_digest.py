"""SHA-256 digests of seeded rollouts of every env id: run on two commits to show a change of the
env layer changed no number (the 12 digests below must be equal before and
after). ``--v1`` adds the 9 ``-v1`` ids (3 families x 3 tiers) with the settings their ids
carry (no overrides): 36 more digests; ``--v2`` the 9 ``-v2`` ids likewise (36 more). Under these
random actions a wire reaches the ``-v2`` driver's cut-off (418 K) only in the ``SmaSpineChainHard-v2``
rollouts; ``tests/envs/test_thermal_cutoff.py`` checks the cut-off itself.

For each ``-v0`` id: the single env (with resets), the vector env in ``NEXT_STEP`` and ``SAME_STEP`` mode
(3 sub-envs, serial kernel) and the SB3 adapter, 200 seeded random steps with domain randomisation,
sensor noise on every channel, a 2-step sensor delay and tip forces; the digest covers every
observation, reward, flag and info (keys and values, with dtypes)::

    .venv/bin/python scripts/rollout_digest.py [--v1] [--v2]
"""

from __future__ import annotations

import hashlib
import sys

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode

import spine_gym  # noqa: F401 - registers the env ids
from spine_gym.envs.ids import ENV_SPECS
from spine_gym.envs.sb3 import SmaSpineSB3VecEnv

IDS = ("SmaSpine-v0", "SmaSpine3D-v0", "SmaSpineChain-v0")
KW = {
    "sensor_noise": {"angle": 0.3, "temperature": 1.0, "resistance": 0.01},
    "sensor_delay": 2,
    "domain_randomization": True,
    "episode_duration": 6.0,
    "tip_force_count": (1, 3),
}


def feed(h, x) -> None:
    """Hash ``x``: dicts by sorted key, sequences and object arrays element by element."""
    if isinstance(x, dict):
        for k in sorted(x):
            h.update(k.encode())
            feed(h, x[k])
    elif isinstance(x, list | tuple) or (isinstance(x, np.ndarray) and x.dtype == object):
        for v in x:
            feed(h, v)
    elif x is None:
        h.update(b"None")
    else:
        a = np.asarray(x)
        h.update(str(a.dtype).encode())
        h.update(np.ascontiguousarray(a).tobytes())


def digests(env_id: str, steps: int = 200, n: int = 3, seed: int = 7, kw: dict = KW) -> dict[str, str]:
    w = gym.make(env_id).action_space.shape[0]
    acts = np.random.default_rng(0).uniform(-1.2, 1.2, size=(steps, n, w)).astype(np.float32)
    out = {}
    h = hashlib.sha256()
    env = gym.make(env_id, **kw).unwrapped
    feed(h, env.reset(seed=seed))
    for a in acts[:, 0]:
        step = env.step(a)
        feed(h, step)
        if step[2] or step[3]:
            feed(h, env.reset())
    out["single"] = h.hexdigest()
    for mode in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
        h = hashlib.sha256()
        venv = gym.make_vec(env_id, num_envs=n, autoreset_mode=mode, parallel=False, **kw)
        feed(h, venv.reset(seed=seed))
        for a in acts:
            feed(h, venv.step(a))
        out[mode.value] = h.hexdigest()
    h = hashlib.sha256()
    sb3 = SmaSpineSB3VecEnv(n, seed=seed, env_id=env_id, parallel=False, **kw)
    feed(h, sb3.reset())
    feed(h, sb3.reset_infos)
    for a in acts:
        sb3.step_async(a)
        feed(h, list(sb3.step_wait()))
        feed(h, sb3.reset_infos)
    out["sb3"] = h.hexdigest()
    return out


if __name__ == "__main__":
    runs = [(env_id, KW) for env_id in IDS]
    for version in (1, 2):
        if f"--v{version}" in sys.argv[1:]:
            runs += [(s.id, {}) for s in ENV_SPECS.values() if s.version == version]
    for env_id, kw in runs:
        for kind, digest in digests(env_id, kw=kw).items():
            print(f"{env_id:22s} {kind:9s} {digest}", flush=True)
