"""The envs' physics alone over a batch of spines: one control period of every active spine, the
loop the benchmarks time against the env ("the kernel alone").

No env calls these: the envs run their spines' control periods inside their own one-call step
(``spine_gym.envs.step_kernels``). Each loop is :func:`spine_gym.physics.planar.control.step_spine`
(or the spatial core's ``step_spine``) of every active row, dealt out to the threads one at a time
(``spine_gym.physics._deal``); ``*_serial`` is the same body compiled without ``prange``, so the
serial and the parallel loop run the same code. Compiled in the process that imports this module
(no on-disk cache: the package's stale-cache guard covers only its own kernels).
"""

from __future__ import annotations

import numba

from spine_gym.physics._deal import counter, take
from spine_gym.physics.planar.control import step_spine
from spine_gym.physics.spatial.control import step_spine as step_spine_spatial

__all__ = ["step_many", "step_many_serial", "step_many_spatial", "step_many_spatial_serial"]


def _step_many(states, backup, kps, ks, v_r, v_l, loads, resolve, active, dt, n_sub, status, meas):
    """``step_spine`` of every active spine (row i of each (B, ...) argument).

    Args:
        states: (B, S) model states, advanced in place.
        backup: (B, S) scratch.
        kps: (B, KP_SIZE) constants (one row per spine, for domain randomisation).
        ks: solver options.
        v_r, v_l: (B,) voltages held over the control period [V].
        loads: (B, N, 2) vertex forces held over the control period [N].
        resolve: (B,) bool, the loads differ from those of the last mechanical solve.
        active: (B,) bool, spines to advance (others are left untouched).
        dt: physics step [s]; the control period is ``n_sub * dt``.
        n_sub: physics steps per control period.
        status: (B,) int64 out; status code of the step (OK or the first failure).
        meas: (B, OUT_SIZE) out; the record row of each active spine after the step.
    """
    todo = counter()
    for _slot in numba.prange(states.shape[0]):  # rows dealt out one at a time
        i = take(todo, states.shape[0])
        while i >= 0:
            if active[i]:
                status[i] = step_spine(
                    states[i], backup[i], kps[i], ks, v_r[i], v_l[i], loads[i], resolve[i], dt, n_sub, meas[i]
                )
            i = take(todo, states.shape[0])


def _step_many_spatial(
    states, backup, kps, ks, kws, kms, volts, loads, resolve, active, dt, n_sub, status, rec
):
    """The spatial core's ``step_spine`` of every active spine (args as :func:`_step_many`, except
    ``kws`` (B, W, KW_SIZE), ``kms`` (B, K, KM_SIZE), ``volts`` (B, W) [V], ``loads`` (B, N, 3) and
    ``rec`` (B, record_size) out)."""
    todo = counter()
    for _slot in numba.prange(states.shape[0]):  # rows dealt out one at a time
        i = take(todo, states.shape[0])
        while i >= 0:
            if active[i]:
                status[i] = step_spine_spatial(
                    states[i], backup[i], kps[i], ks, kws[i], kms[i], volts[i], loads[i], resolve[i], dt,
                    n_sub, rec[i],
                )  # fmt: skip
            i = take(todo, states.shape[0])


step_many = numba.njit(nogil=True, parallel=True)(_step_many)
step_many_serial = numba.njit(nogil=True)(_step_many)
step_many_spatial = numba.njit(nogil=True, parallel=True)(_step_many_spatial)
step_many_spatial_serial = numba.njit(nogil=True)(_step_many_spatial)
