"""Statuses of the spatial core under 20-N tip forces in random directions (SPATIAL.md §8.11).

Seeded episodes of both spatial ids at ``v_max`` = 8 V with a random drive end either by truncation
or with the buckling status, never with a solver limit (ERR_SHAPE, ERR_ROOT, ERR_SUBSTEPS); and every
buckling end is checked to be real, independently of the solver's own decision: the failing
step's loads are past the bare tube's buckling screen, and either the last valid shape is unstable
under them (the load change buckles the spine), or, replaying the step sub-step by sub-step, the
failing sub-step's equilibrium path (continuation in the wires' fractions, solved by the composite
solve in small steps) ends where a wire that held the spine goes slack and the stability test with
that wire slack fails (a limit point), or the shape the step ends on fails the stability test.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import spine_gym  # noqa: F401  (registers the ids)
from spine_gym.physics import columns as L
from spine_gym.physics.spatial.columns import F_SIG, F_XM, F_XP, W_L0, W_LAMS
from spine_gym.physics.spatial.composite import composite, solve_mechanics
from spine_gym.physics.spatial.integrate import _load_rates, wire_constants
from spine_gym.physics.spatial.stability import (
    is_buckled,
    is_buckled_at,
    needs_stability_check,
    stability_work,
)
from spine_gym.physics.spatial.substep import _substep_coupled
from spine_gym.physics.spatial.work import (
    WK_JNUM,
    WK_KPW,
    WK_RT,
    WK_XS,
    make_work,
    sizes,
    views,
    wire_block,
    wire_blocks,
)

SOLVER_LIMITS = (L.ERR_SHAPE, L.ERR_ROOT, L.ERR_SUBSTEPS)
# (id, seed, tip_force_count): the first two ended with ERR_SHAPE before SPATIAL.md §8.11 (a 0.1-s
# first sub-step past which an equilibrium exists; a wire going slack under a 19.7-N load), the
# others are plain seeds
EPISODES = [
    ("SmaSpineChain-v0", 133, (1, 3)),
    ("SmaSpineChain-v0", 17, (0, 2)),
    *[("SmaSpine3D-v0", s, (1, 3)) for s in range(4)],
    *[("SmaSpineChain-v0", s, (1, 3)) for s in range(4)],
]


def run_episode(env_id, seed, count):
    """The episode (20-N forces, random drive); its end, with the failing step's kernel inputs."""
    env = gym.make(env_id, v_max=8.0, tip_force_range=(20.0, 20.0), tip_force_count=count).unwrapped
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    core = env._core
    for k in range(env.max_steps):
        before = core.states[0].copy()
        _, _, term, trunc, info = env.step(rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32))
        if trunc:
            return {"status": L.OK, "step": k}
        if term:
            assert info["status_text"] == L.STATUS_TEXT[info["status"]]
            return {
                "status": int(info["status"]), "step": k, "state": before, "kp": core.kps[0].copy(),
                "ks": core.ks.copy(), "kw": core.kws[0].copy(), "km": core.kms[0].copy(),
                "volts": core.volts[0].copy(), "loads": core.loads[0].copy(), "resolve": bool(core.resolve[0]),
                "dt": core.cfg.physics_dt,
            }  # fmt: skip
    raise AssertionError("the episode neither truncated nor terminated")


def parts(state, kw, km):
    """(M_w, ω, S, x+, x-, σ) views of a spatial state."""
    nw, nm, ns = sizes(kw, km)
    mw, omega, sens = views(state, nw, nm, ns)
    return mw, omega, sens, wire_block(state, F_XP, nw), wire_block(state, F_XM, nw), wire_block(
        state, F_SIG, nw
    )


def replay_substeps(r):
    """The failing step sub-step by sub-step (as ``spatial.integrate._span``): (state at the start of
    the sub-step that failed, its end fractions (x+, x-) per wire) or (the state the step ended on, None)."""
    kp, ks, kw, km, vf = r["kp"], r["ks"], r["kw"], r["km"], r["loads"]
    nw, nm, ns = sizes(kw, km)
    state = r["state"].copy()
    wk = make_work(nw, nm, ns)
    mw, omega, sens = views(state, nw, nm, ns)
    wb = wire_blocks(state, nw)
    if r["resolve"]:
        check = needs_stability_check(vf, kp, km)
        st, _ = solve_mechanics(mw, omega, sens, wb.xp, wb.xm, wb.eps, wb.sig, vf, kp, ks, kw, km, wk, check)
        assert st == L.OK, "the load change itself failed, yet the start was found stable"
    wire_constants(kp, kw, wk[WK_KPW])
    wk[WK_JNUM][:] = r["volts"] ** 2 / kw[:, W_L0] ** 2 / kw[:, W_LAMS]
    _load_rates(state, kp, kw, km, ns, wk[WK_RT], wk[WK_KPW])
    rem = r["dt"]
    while rem > 0.0:
        start = state.copy()
        st, h, _, _ = _substep_coupled(state, mw, omega, sens, wb, vf, kp, ks, kw, km, rem, r["dt"], wk)
        if st != L.OK:
            return start, wk[WK_XS].reshape(nw, 2).copy()
        rem -= h
    return state, None


def slack_limit_point(r, start, xs):
    """Continuation in the fractions from the failing sub-step's start to its end ``xs``: True if
    the equilibrium path ends (the composite solve fails beyond λ*) where a wire taut at the start
    is slack to 1e-3 of its starting stress and the stability test with that wire slack fails
    there, while the start, with the wire taut, passes it: a stable branch that ends at a kink."""
    kp, kw, km, vf = r["kp"], r["kw"], r["km"], r["loads"]
    nw, nm, ns = sizes(kw, km)
    ks = r["ks"]
    x0 = np.stack(parts(start, kw, km)[3:5], axis=1)
    sig0 = parts(start, kw, km)[5].copy()
    at_lam, lam, dl = start.copy(), 0.0, 0.05
    while dl > 1e-9 and lam < 1.0:
        trial = at_lam.copy()
        _, _, _, xp, xm, _ = parts(trial, kw, km)
        x = x0 + min(lam + dl, 1.0) * (xs - x0)
        xp[:], xm[:] = x[:, 0], x[:, 1]
        if composite(trial, vf, kp, ks, kw, km, make_work(nw, nm, ns))[0] == L.OK:
            at_lam, lam = trial, min(lam + dl, 1.0)
        else:
            dl *= 0.25
    if lam >= 1.0:
        return False  # the path reaches the sub-step's end: no limit point
    mw, omega, _, xp, xm, sig = parts(at_lam, kw, km)
    slack = (sig0 > 0.0) & (sig <= 1e-3 * sig0)
    if not slack.any():
        return False
    m0, w0, _, p0, q0, _ = parts(start.copy(), kw, km)
    start_stable = not is_buckled(w0, m0, p0, q0, vf, kp, kw, km)
    return start_stable and bool(is_buckled_at(omega, mw, xp, xm, vf, kp, kw, km, stability_work(nw, nm, ns), slack))


def buckling_is_real(r):
    """Independent evidence for a buckling end (module docstring)."""
    if not needs_stability_check(r["loads"], r["kp"], r["km"]):
        return False  # loads the bare tube carries in any shape cannot buckle the spine
    mw, omega, _, xp, xm, _ = parts(r["state"].copy(), r["kw"], r["km"])
    if is_buckled(omega, mw, xp, xm, r["loads"], r["kp"], r["kw"], r["km"]):
        return True  # the last valid shape is unstable under the new loads
    state, xs = replay_substeps(r)
    mw, omega, _, xp, xm, _ = parts(state, r["kw"], r["km"])
    if xs is None:  # every sub-step solved: the shape the step ends on must be unstable
        return bool(is_buckled(omega, mw, xp, xm, r["loads"], r["kp"], r["kw"], r["km"]))
    return slack_limit_point(r, state, xs)


@pytest.mark.parametrize(("env_id", "seed", "count"), EPISODES)
def test_20n_random_direction_forces_end_with_a_physical_status(env_id, seed, count):
    r = run_episode(env_id, seed, count)
    assert r["status"] not in SOLVER_LIMITS, L.STATUS_TEXT[r["status"]]
    assert r["status"] in (L.OK, L.ERR_BUCKLING)
    if r["status"] == L.ERR_BUCKLING:
        assert buckling_is_real(r)


def test_the_0p1_s_first_try_now_steps_to_a_stable_equilibrium():
    """Chain seed 133, step 442: the first sub-step tried h = 0.1 s and moved a wire's x+ by 0.91;
    the equilibrium of those fractions exists (continuation), so the step must succeed, retried
    shorter, and end on a stable shape."""
    env = gym.make("SmaSpineChain-v0", v_max=8.0, tip_force_range=(20.0, 20.0), tip_force_count=(1, 3)).unwrapped
    env.reset(seed=133)
    rng = np.random.default_rng(133)
    core = env._core
    for _ in range(443):
        _, _, term, _, info = env.step(rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32))
        assert not term, info.get("status_text")
    kw, km = core.kws[0], core.kms[0]
    mw, omega, _, xp, xm, _ = parts(core.states[0].copy(), kw, km)
    assert not is_buckled(omega, mw, xp, xm, core.loads[0], core.kps[0], kw, km)
