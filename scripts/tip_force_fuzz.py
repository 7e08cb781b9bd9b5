"""Seeded episodes of the spatial envs under 20-N tip forces in random directions: how each ends.

Both spatial ids, ``v_max=8`` V, uniformly random drive (seeded by the episode's seed), tip forces
of ``--force`` N (low end; the high end is 20 N) in directions uniform on the sphere, the env's
payload. Every episode that terminates is listed as (id, seed, step, status, the step's tip force
+ payload weight, the force before it, whether the last valid state is unstable under the step's
load, the bare tube's load ratio), and the status counts are printed. A solver-limit status
(``ERR_SHAPE``, ``ERR_ROOT``, ``ERR_SUBSTEPS``) means the solver gave up where no physical cause
was found (SPATIAL.md §8.11). With ``--out`` the failing steps' kernel inputs (state, tables,
voltages, loads) are pickled for a closer look::

    .venv/bin/python scripts/tip_force_fuzz.py --seeds 150
    .venv/bin/python scripts/tip_force_fuzz.py --seeds 150 --count 1 3
"""

from __future__ import annotations

import argparse
import pickle

import gymnasium as gym
import numpy as np

import spine_gym  # noqa: F401 - registers the env ids
from spine_gym.physics import columns as L
from spine_gym.physics.spatial.columns import F_XM, F_XP
from spine_gym.physics.spatial.stability import is_buckled, load_ratio
from spine_gym.physics.spatial.work import sizes, views, wire_block

IDS = ("SmaSpine3D-v0", "SmaSpineChain-v0")


def episode(env_id: str, seed: int, force_low: float, count: tuple[int, int]) -> dict:
    """One episode; the end of it, with the failing step's kernel inputs if it terminated."""
    env = gym.make(env_id, v_max=8.0, tip_force_range=(force_low, 20.0), tip_force_count=count).unwrapped
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    core = env._core
    for k in range(env.max_steps):
        before = core.states[0].copy()
        _, _, term, trunc, info = env.step(rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32))
        if trunc:
            return {"id": env_id, "seed": seed, "status": L.OK, "step": k}
        if term:
            return {
                "id": env_id, "seed": seed, "step": k, "status": int(info["status"]), "state": before,
                "kp": core.kps[0].copy(), "ks": core.ks.copy(), "kw": core.kws[0].copy(), "km": core.kms[0].copy(),
                "volts": core.volts[0].copy(), "loads": core.loads[0].copy(), "resolve": bool(core.resolve[0]),
                "dt": core.cfg.physics_dt, "force": core.forces[0, k].copy(),
                "prev": core.forces[0, k - 1].copy() if k else None,
            }  # fmt: skip
    raise AssertionError("an episode ends by truncation or termination")


def start_unstable(r: dict) -> bool:
    """Whether the last valid state's shape is unstable under the failing step's loads."""
    kw, km = r["kw"], r["km"]
    nw, nm, ns = sizes(kw, km)
    s = r["state"].copy()
    mw, omega, _ = views(s, nw, nm, ns)
    xp, xm = wire_block(s, F_XP, nw), wire_block(s, F_XM, nw)
    return bool(is_buckled(omega, mw, xp, xm, r["loads"], r["kp"], kw, km))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=25, help="seeds 0 … n-1 per id")
    ap.add_argument("--force", type=float, default=20.0, help="low end of tip_force_range [N] (high: 20)")
    ap.add_argument("--count", type=int, nargs=2, default=(0, 2), help="tip_force_count (low, high)")
    ap.add_argument("--out", help="pickle the failing steps' kernel inputs here")
    args = ap.parse_args()
    ends = []
    for env_id in IDS:
        for seed in range(args.seeds):
            r = episode(env_id, seed, args.force, tuple(args.count))
            ends.append(r)
            if r["status"] != L.OK:
                print(
                    f"{env_id:17s} seed {seed:4d} step {r['step']:3d} status {r['status']} "
                    f"F {np.round(r['force'], 2)} before {np.round(r['prev'], 2) if r['prev'] is not None else None} "
                    f"start unstable {start_unstable(r)} load ratio {load_ratio(r['loads'], r['kp'], r['km']):.2f}",
                    flush=True,
                )
    counts = {L.STATUS_TEXT[c].split(":")[0]: sum(r["status"] == c for r in ends) for c in sorted(L.STATUS_TEXT)}
    print(f"{len(ends)} episodes:", {k: v for k, v in counts.items() if v})
    if args.out:
        with open(args.out, "wb") as f:
            pickle.dump([r for r in ends if r["status"] != L.OK], f)


if __name__ == "__main__":
    main()
