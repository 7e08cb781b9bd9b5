"""One env step in one jitted call: inputs, physics, readings and bookkeeping.

A step of every env id is four jitted pieces — :func:`begin_step` (clipped actions,
voltages, loads, resolve flags), the plant's per-spine control period
(:func:`spine_gym.physics.planar.control.step_spine` or the spatial core's ``step_spine``), the plant's probe
(:func:`.readout.planar_probe`, :func:`.readout.spatial_probe`) and the table-driven
writer (:func:`.readout.finish_rows`) — and this module runs them in one call from Python, so
a vector step pays numba's dispatch and argument unboxing once, not four times. Nothing is
computed here that the pieces do not compute: the rows are bit for bit those of the separate
calls (``scripts/rollout_digest.py`` gives the same digests).

The argument groups are plain tuples built once per batch (numba types a plain tuple of arrays on
its fast C path; :class:`.batch.TableBatch` holds them):

* ``drive``: ``(coef, forces, plan, resolve)``, as :func:`begin_step` takes them;
* ``plant``: the plant's arrays in the field order of :data:`PlanarPlant` / :data:`SpatialPlant`
  (the batch packs them by these names, the kernels unpack them by name);
* ``step``, ``mem``, ``spec``, ``out``: :data:`.readout.Step`, ``Memory``, ``Spec``, ``Out``.

Each kernel is one body compiled twice, so that the serial and the parallel loop cannot differ
(tests/envs/test_vector_env.py compares them bit for bit): ``*_serial`` loops over the spines serially,
the other runs that loop with ``prange`` on all numba threads. A spine's probe and bookkeeping
(:func:`.readout.planar_probe_row`, :func:`.readout.finish_row`) run inside the loop, right
after its physics, on its own row of scratch: rows are independent, and run after the loop they
were a serial tail that capped the 1 → 2 thread scaling at large N (~1 µs per spine). The
parallel loop deals the rows out one at a time (:mod:`spine_gym.physics._deal`): spines differ in
cost per control period by up to ~10×, and with fixed blocks of rows a step waits for the thread
that drew the expensive ones. Only ``begin_step`` (clipping, voltages, loads) stays before the
loop. Each returns False, changing nothing, if an action is not finite (the caller raises the
documented ValueError).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numba
import numpy as np

from ..physics._deal import counter, take
from ..physics._jit import jit, pjit
from ..physics.planar.control import step_spine
from ..physics.spatial.control import step_spine as step_spine_spatial
from . import readout as ro
from .drive import action_to_volts, clip_action

__all__ = [
    "begin_step",
    "cut_hot_wires",
    "PLANAR_PLANT",
    "PlanarPlant",
    "SPATIAL_PLANT",
    "SpatialPlant",
    "planar_step",
    "planar_step_serial",
    "spatial_step",
    "spatial_step_serial",
]

# the plants: per-spine (B, ...) arrays, then the solver options and the physics step
PlanarPlant = namedtuple("PlanarPlant", "states backup kps ks ohm wvol meas physics_dt n_sub")
SpatialPlant = namedtuple(
    "SpatialPlant", "states backup kps ks kws kms record_cols ohm wvol meas physics_dt n_sub"
)
PLANAR_PLANT = PlanarPlant._fields  # the names a batch packs its plant tuple by
SPATIAL_PLANT = SpatialPlant._fields


@jit
def begin_step(rows, actions, clipped, volts, coef, k, forces, plan, loads, resolve):
    """Inputs of one step: clip the actions, set the voltages and the loads of step k.

    Every row gets its clipped action ``clipped`` (B, W) (float64, from float32 or float64
    ``actions``) and its wire voltages ``volts = (clipped + 1) coef``
    (:func:`.drive.action_to_volts`); each environment of
    ``rows`` gets the vertex load of its step index ``k`` (the tip force ``forces[i, k]``, held at
    the last step after the episode's end) and ``resolve[i]``: solve the mechanics again (the load changed,
    ``plan``) within the episode. Returns False if an action is not finite (nothing is changed
    then; the caller raises).
    """
    b, w = clipped.shape
    for i in range(b):
        for q in range(w):
            if not math.isfinite(actions[i, q]):
                return False
    n_steps = forces.shape[1]
    for i in range(b):
        resolve[i] = False
        for q in range(w):
            a = np.float64(actions[i, q])
            clipped[i, q] = clip_action(a)
            volts[i, q] = action_to_volts(a, coef[q])
    for j in range(rows.shape[0]):
        i = rows[j]
        k0 = k[i]
        kk = min(k0, n_steps - 1)
        for q in range(loads.shape[2]):
            loads[i, 0, q] = forces[i, kk, q]
        resolve[i] = plan[i, kk] and k0 < n_steps
    return True


@jit
def cut_hot_wires(rows, volts, probe, temperature_col, cutoff):
    """The driver's thermal cut-off: a wire of ``rows`` whose temperature at the start of the step
    (``probe[i, temperature_col + w]``, the last reading of the plant's true state) is at or above
    ``cutoff`` [K] gets 0 V for this control period (``cutoff = +inf``: no cut-off, nothing changes).

    It acts on what is applied, after the policy: every controller and every policy meets the same
    plant. The commanded action is kept (it is the observation's previous action); the voltage,
    the power and the energy of the step are those delivered."""
    if cutoff == math.inf:
        return
    for j in range(rows.shape[0]):
        i = rows[j]
        for w in range(volts.shape[1]):
            if probe[i, temperature_col + w] >= cutoff:
                volts[i, w] = 0.0


def _planar_step(rows, actions, drive, plant, step, mem, spec, out):
    """One control period of the planar spines ``rows`` (int64, ascending); see the module docstring.

    Args:
        rows: (n,) environments to step.
        actions: (B, 2) float32 or float64 actions of every environment (clipped to [-1, 1]).
        drive, plant, step, mem, spec, out: the batch's tuples (module docstring).

    Returns:
        False if an action is not finite (nothing changed), else True.
    """
    st, m, sp = ro.Step(*step), ro.Memory(*mem), ro.Spec(*spec)
    coef, forces, plan, resolve = drive
    p = PlanarPlant(*plant)
    states, backup, kps, ks, meas, dt, n_sub = p.states, p.backup, p.kps, p.ks, p.meas, p.physics_dt, p.n_sub
    ohm, wvol = p.ohm, p.wvol
    if not begin_step(rows, actions, st.actions, st.volts, coef, m.k, forces, plan, st.loads, resolve):
        return False
    volts, loads, status, probe, probe_cols = st.volts, st.loads, st.status, st.probe, sp.probe_cols
    cut_hot_wires(rows, volts, probe, probe_cols[ro.PB_TEMP], sp.settings[ro.S_CUTOFF])
    scratch = np.empty((rows.shape[0], ro.row_scratch_size(sp, ro.Out(*out).row.shape[1])))  # a row each
    todo = counter()
    for _slot in numba.prange(rows.shape[0]):  # rows dealt out one at a time (physics._deal)
        j = take(todo, rows.shape[0])
        while j >= 0:
            i = rows[j]
            status[i] = step_spine(
                states[i],
                backup[i],
                kps[i],
                ks,
                volts[i, 0],
                volts[i, 1],
                loads[i],
                resolve[i],
                dt,
                n_sub,
                meas[i],
            )
            ro.planar_probe_row(i, meas, ohm, wvol, probe_cols, probe)
            ro.finish_row(i, step, mem, spec, out, False, scratch[j])
            j = take(todo, rows.shape[0])
    return True


def _spatial_step(rows, actions, drive, plant, step, mem, spec, out):
    """:func:`_planar_step` for spatial or chained spines (``actions`` (B, W)).

    A body of its own rather than one shared with :func:`_planar_step`: the plant tuples, the
    physics call and the probe differ in their numba types, and a body that took them as arguments
    would change what the parallel loop compiles to."""
    st, m, sp = ro.Step(*step), ro.Memory(*mem), ro.Spec(*spec)
    coef, forces, plan, resolve = drive
    p = SpatialPlant(*plant)
    states, backup, kps, ks, meas, dt, n_sub = p.states, p.backup, p.kps, p.ks, p.meas, p.physics_dt, p.n_sub
    kws, kms, record_cols, ohm, wvol = p.kws, p.kms, p.record_cols, p.ohm, p.wvol
    if not begin_step(rows, actions, st.actions, st.volts, coef, m.k, forces, plan, st.loads, resolve):
        return False
    volts, loads, status, probe, probe_cols = st.volts, st.loads, st.status, st.probe, sp.probe_cols
    cut_hot_wires(rows, volts, probe, probe_cols[ro.PB_TEMP], sp.settings[ro.S_CUTOFF])
    scratch = np.empty((rows.shape[0], ro.row_scratch_size(sp, ro.Out(*out).row.shape[1])))  # a row each
    todo = counter()
    for _slot in numba.prange(rows.shape[0]):  # rows dealt out one at a time (physics._deal)
        j = take(todo, rows.shape[0])
        while j >= 0:
            i = rows[j]
            status[i] = step_spine_spatial(
                states[i],
                backup[i],
                kps[i],
                ks,
                kws[i],
                kms[i],
                volts[i],
                loads[i],
                resolve[i],
                dt,
                n_sub,
                meas[i],
            )
            ro.spatial_probe_row(i, meas, record_cols, ohm, wvol, probe_cols, probe)
            ro.finish_row(i, step, mem, spec, out, False, scratch[j])
            j = take(todo, rows.shape[0])
    return True


planar_step = pjit(_planar_step)
planar_step_serial = jit(_planar_step)
spatial_step = pjit(_spatial_step)
spatial_step_serial = jit(_spatial_step)
