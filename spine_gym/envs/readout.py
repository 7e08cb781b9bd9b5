"""The jitted readout of one env step: sensors, observation, reward, info (no physics here).

After the plant's physics (:func:`spine_gym.physics.planar.control.step_spine` for the planar
spine, :func:`spine_gym.physics.spatial.control.step_spine` for the spatial ones) has advanced
the spines and recorded them (all in the one call of :mod:`.step_kernels`), a probe
(:func:`planar_probe`, :func:`spatial_probe`) converts each record into the common probe row
(degrees, millimetres, Ohm, joules), and :func:`finish_rows` turns it into what the environment
returns: the step's electrical energy from the model's Joule-heat
accumulators, the sensor delay line plus the noise drawn in Python, the step row of the env's
declarative table (:mod:`spine_gym.envs.table`: which quantity goes to which column and which are
observed comes in as integer maps), the observation (clipped to its bounds), the reward terms, the
over-temperature cost and the termination/truncation flags. The same code runs for every env id,
for the single env (one row) and the vector env (all rows), so both return the same numbers.
Outputs go into the batch's preallocated (B, ...) buffers at the rows stepped, so a step has no
NumPy temporaries; the groups of arrays are passed as plain tuples (:func:`finish`), which numba
types on its fast path, and the writer's helpers are inlined into it (``jit_inline``: a real call
with the namedtuples of arrays cost more than their work).

The formulas are documented in the env classes (Observation space, Rewards).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ..physics._jit import hot, jit, jit_inline
from ..physics.columns import OK
from ..physics.planar.record import OUT_ANGLE, OUT_RES_L, OUT_RES_R
from ..physics.planar.columns import X_QJL, X_QJR, X_TL, X_TR

# scalar settings passed as one float array (Spec.settings)
S_PERIOD, S_ERROR_SCALE, S_ENERGY_COEF, S_COST_WEIGHT, S_T_LIMIT, S_CUTOFF, N_SETTINGS = range(7)
# S_CUTOFF: the driver's thermal cut-off [K] (+inf: none), applied by step_kernels.cut_hot_wires


# ====================================================================== the table-driven writer
# One writer for every env (SmaSpine-v0, SmaSpine3D-v0, SmaSpineChain-v0): which quantity goes to
# which column, what is observed and what is a sensor channel comes from the env's declarative
# table (spine_gym.envs.table), passed in as the integer maps of ``Spec``.

# ids of the physics readings in the probe row (their columns: Spec.probe_cols[id]); the probe row
# of every env is [tip bending (2) deg | tip position (3) mm | module bending (2K) deg |
# temperature (W) K | resistance (W) Ohm | cumulative Joule heat of each wire group (W) J]
PB_TIPB, PB_TIPP, PB_MODB, PB_TEMP, PB_RES, PB_JOULE, N_PB = range(7)
# ids of the step quantities (their row columns: Spec.qcol[id], -1 if the env has none)
(
    Q_VOLT,  # (W) applied voltage [V]
    Q_POWER,  # (W) mean electrical power of the step [W]
    Q_ACTION,  # (W) the clipped action of the step (the "previous action" of the next one)
    Q_FORCE,  # (F) force on the top disk over the step [N]
    Q_TARGET,  # (d) target of the tracked entry at the end of the step
    Q_PREVIEW,  # (d) target preview_steps later
    Q_ERROR,  # (d) target − true tracked entry
    Q_RATE,  # (d) difference quotient of the measured tracked entry
    Q_ENERGY,  # electrical energy of the step [J]
    Q_COST,  # Σ over wires of max(0, T − T_limit) [K]
    Q_TIME,  # [s]
    Q_REWARD,
    Q_R_TRACK,
    Q_R_ENERGY,
    Q_MERROR,  # (d) target − measured tracked entry (what a controller on the sensors sees)
    Q_MPREVIEW,  # (d) target preview − measured tracked entry
    N_Q,
) = range(17)
C_PREVIEW, C_MAX_STEPS, N_COUNTS = range(3)  # integer settings (Spec.counts)

# the per-environment memory the writer updates (rows of (B, ...) arrays; part of a snapshot)
Memory = namedtuple("Memory", ["k", "joule", "hist", "prev_task", "prev_action"])
# what the step produced: the physics readings, the applied inputs and the noise ((B, ...) arrays)
Step = namedtuple("Step", ["probe", "status", "actions", "volts", "loads", "targets", "noise"])
# the env's maps (from its table) and settings
Spec = namedtuple(
    "Spec",
    ["qcol", "probe_cols", "chan_src", "chan_dst", "obs_cols", "task", "low", "high", "settings", "counts"],
)
# outputs, (B, ...) buffers written at the rows stepped: observations (B, OBS_DIM) float32, true
# step rows (B, width), flags (B,)
Out = namedtuple("Out", ["obs", "row", "terminated", "truncated"])


@jit_inline
def _put(row, col, value):
    if col >= 0:
        row[col] = value


@jit_inline
def _sensors(i, step, mem, spec, fresh, true, measured):
    """True channels from the probe row -> delay line -> measured = oldest + noise."""
    p = step.probe[i]
    delay = mem.hist.shape[1] - 1
    nc = spec.chan_src.shape[0]
    for c in range(nc):
        true[c] = p[spec.chan_src[c]]
    if fresh:  # the sensors read the initial state before t = 0
        for q in range(delay + 1):
            for c in range(nc):
                mem.hist[i, q, c] = true[c]
    else:
        for q in range(delay):
            for c in range(nc):
                mem.hist[i, q, c] = mem.hist[i, q + 1, c]
        for c in range(nc):
            mem.hist[i, delay, c] = true[c]
    for c in range(nc):
        measured[c] = mem.hist[i, 0, c] + step.noise[i, c]


@jit_inline
def _energy(i, step, mem, spec, fresh, row, period):
    """Electrical energy of the step from the model's cumulative Joule heat; per-wire power."""
    p = step.probe[i]
    jc = spec.probe_cols[PB_JOULE]
    pc = spec.qcol[Q_POWER]
    energy = 0.0
    for w in range(mem.joule.shape[1]):
        if fresh:
            mem.joule[i, w] = p[jc + w]
        e = p[jc + w] - mem.joule[i, w]
        mem.joule[i, w] = p[jc + w]
        energy += e
        if pc >= 0:
            row[pc + w] = e / period
    return energy


@jit_inline
def _tracking(i, kk, step, spec, row):
    """Target, preview and error of the tracked entry; returns |error| (Euclidean)."""
    last = step.targets.shape[1] - 1
    tcol, d = spec.task[0], spec.task[2]
    k0 = min(kk, last)
    k1 = min(kk + spec.counts[C_PREVIEW], last)
    sq = 0.0
    e0 = 0.0
    for q in range(d):
        target = step.targets[i, k0, q]
        e = target - row[tcol + q]
        if q == 0:
            e0 = e
        sq += e * e
        if spec.qcol[Q_TARGET] >= 0:
            row[spec.qcol[Q_TARGET] + q] = target
        if spec.qcol[Q_PREVIEW] >= 0:
            row[spec.qcol[Q_PREVIEW] + q] = step.targets[i, k1, q]
        if spec.qcol[Q_ERROR] >= 0:
            row[spec.qcol[Q_ERROR] + q] = e
    return abs(e0) if d == 1 else math.sqrt(sq)


@jit_inline
def _measured_errors(i, kk, step, spec, measured, row, meas_row):
    """Target − measured and preview − measured of the tracked entry (the same in the true and the
    measured row: both are what the sensors report)."""
    last = step.targets.shape[1] - 1
    tchan, d = spec.task[1], spec.task[2]
    k0 = min(kk, last)
    k1 = min(kk + spec.counts[C_PREVIEW], last)
    ce, cp = spec.qcol[Q_MERROR], spec.qcol[Q_MPREVIEW]
    for q in range(d):
        m = measured[tchan + q]
        if ce >= 0:
            row[ce + q] = step.targets[i, k0, q] - m
            meas_row[ce + q] = row[ce + q]
        if cp >= 0:
            row[cp + q] = step.targets[i, k1, q] - m
            meas_row[cp + q] = row[cp + q]


@jit
def finish_rows(rows, step, mem, spec, out, fresh):
    """Bookkeeping of the spines ``rows`` after a step (or at reset if ``fresh``).

    For each row: the step counter, the electrical energy of the step (from the model's Joule
    accumulators), the sensor channels through the delay line plus the noise drawn in Python, the
    step row of the env's table (true values), its measured copy (sensor columns measured, the
    rate from the measured tracked entry), the observation gathered from the measured copy and
    clipped to its bounds, the reward on the true state, the cost and the episode flags.
    ``fresh``: the episode starts (k = 0, no energy, zero reward terms and voltages, rate 0).

    Args:
        rows: (n,) int64 environments to finish.
        step: :data:`Step` (``actions``, ``volts`` (B, W); ``loads`` (B, N, F); ``targets``
            (B, n_grid, d); ``noise`` (B, C); ``probe`` (B, probe width); ``status`` (B,)).
        mem: :data:`Memory`, updated in place.
        spec: :data:`Spec` of the env's table.
        out: :data:`Out`, written at ``rows`` (other rows are left as they are).
    """
    width = out.row.shape[1]
    scratch = np.empty(row_scratch_size(spec, width))
    for j in range(rows.shape[0]):
        _finish_row(rows[j], step, mem, spec, out, fresh, scratch)


@jit_inline
def row_scratch_size(spec, width):
    """Floats of :func:`finish_row`'s scratch: the true and measured channels, a measured row."""
    return 2 * spec.chan_src.shape[0] + width


@hot
def finish_row(i, step, mem, spec, out, fresh, scratch):
    """:func:`finish_rows` of the one environment ``i`` with its own scratch (>= :func:`row_scratch_size`
    floats), the groups as plain tuples: rows are independent, so the parallel step kernels run it
    per row inside their ``prange`` loop. A real call without reference counting (``hot``): numba's
    parfor lowering cannot type this module's namedtuples inside a ``prange`` body (it looks their
    names up in the kernel's module), so they are built here."""
    _finish_row(i, Step(*step), Memory(*mem), Spec(*spec), Out(*out), fresh, scratch)


@jit_inline
def _finish_row(i, step, mem, spec, out, fresh, scratch):
    """The body of :func:`finish_row` on the groups as namedtuples."""
    st = spec.settings
    period = st[S_PERIOD]
    qc = spec.qcol
    tchan, d = spec.task[1], spec.task[2]
    nc = spec.chan_src.shape[0]
    nw = mem.joule.shape[1]
    true = scratch[:nc]
    measured = scratch[nc : 2 * nc]
    meas_row = scratch[2 * nc : 2 * nc + out.row.shape[1]]
    if fresh:
        mem.k[i] = 0
    else:
        mem.k[i] += 1
    kk = mem.k[i]
    row = out.row[i]
    energy = _energy(i, step, mem, spec, fresh, row, period)
    _sensors(i, step, mem, spec, fresh, true, measured)
    for c in range(nc):
        row[spec.chan_dst[c]] = true[c]
    err = _tracking(i, kk, step, spec, row)
    # cost on the true temperatures
    tc = spec.probe_cols[PB_TEMP]
    cost = 0.0
    for w in range(nw):
        cost += max(step.probe[i, tc + w] - st[S_T_LIMIT], 0.0)
    for w in range(nw):
        mem.prev_action[i, w] = step.actions[i, w]
        if qc[Q_ACTION] >= 0:
            row[qc[Q_ACTION] + w] = step.actions[i, w]
        if qc[Q_VOLT] >= 0:
            row[qc[Q_VOLT] + w] = 0.0 if fresh else step.volts[i, w]
    if qc[Q_FORCE] >= 0:
        for q in range(step.loads.shape[2]):
            row[qc[Q_FORCE] + q] = step.loads[i, 0, q]
    if fresh:
        r_track = 0.0
        r_energy = 0.0
        reward = 0.0
    else:
        r_track = -err / st[S_ERROR_SCALE]
        r_energy = -st[S_ENERGY_COEF] * energy
        reward = r_track + r_energy - st[S_COST_WEIGHT] * cost
    _put(row, qc[Q_ENERGY], energy)
    _put(row, qc[Q_COST], cost)
    _put(row, qc[Q_TIME], kk * period)
    _put(row, qc[Q_REWARD], reward)
    _put(row, qc[Q_R_TRACK], r_track)
    _put(row, qc[Q_R_ENERGY], r_energy)
    # the measured copy: sensor columns as measured, rate from the measured tracked entry
    for q in range(row.shape[0]):
        meas_row[q] = row[q]
    for c in range(nc):
        meas_row[spec.chan_dst[c]] = measured[c]
    for q in range(d):
        m = measured[tchan + q]
        rate = 0.0 if fresh else (m - mem.prev_task[i, q]) / period
        mem.prev_task[i, q] = m
        if qc[Q_RATE] >= 0:
            row[qc[Q_RATE] + q] = rate
            meas_row[qc[Q_RATE] + q] = rate
    if qc[Q_MERROR] >= 0 or qc[Q_MPREVIEW] >= 0:
        _measured_errors(i, kk, step, spec, measured, row, meas_row)
    for q in range(spec.obs_cols.shape[0]):
        v = meas_row[spec.obs_cols[q]]
        if v < spec.low[q]:
            v = spec.low[q]
        elif v > spec.high[q]:
            v = spec.high[q]
        out.obs[i, q] = v
    ok = step.status[i] == OK
    out.terminated[i] = not fresh and not ok
    out.truncated[i] = not fresh and kk >= spec.counts[C_MAX_STEPS] and ok


@jit
def finish(rows, step, mem, spec, out, fresh):
    """:func:`finish_rows` with its groups passed as plain tuples (numba types a plain tuple of
    arrays on its fast C path, a namedtuple through Python: ~2x the call overhead)."""
    finish_rows(rows, Step(*step), Memory(*mem), Spec(*spec), Out(*out), fresh)


@jit
def planar_probe(rows, meas, ohm, vol, probe_cols, probe):
    """Probe rows of planar spines from their ``batch.record`` rows (``ohm`` (B, 2) L0/A_w [1/m],
    ``vol`` (B, 2) wire volume of each side [m^3]); tip position and module bending stay 0."""
    for j in range(rows.shape[0]):
        planar_probe_row(rows[j], meas, ohm, vol, probe_cols, probe)


@hot
def planar_probe_row(i, meas, ohm, vol, probe_cols, probe):
    """:func:`planar_probe` of the one spine ``i`` (the parallel step kernels call it per row)."""
    tb, te, rs, jl = probe_cols[PB_TIPB], probe_cols[PB_TEMP], probe_cols[PB_RES], probe_cols[PB_JOULE]
    m = meas[i]
    p = probe[i]
    p[tb] = m[OUT_ANGLE] * (180.0 / math.pi)
    p[te] = m[X_TR]
    p[te + 1] = m[X_TL]
    p[rs] = m[OUT_RES_R] * ohm[i, 0]
    p[rs + 1] = m[OUT_RES_L] * ohm[i, 1]
    p[jl] = m[X_QJR] * vol[i, 0]
    p[jl + 1] = m[X_QJL] * vol[i, 1]


# columns of a spatial.record.record row the probe reads (SpatialPlant.record_cols)
R_MODB, R_TIPB, R_TIPP, R_RHO, R_TEMP, R_QJ, N_R = range(7)


@jit
def spatial_probe(rows, rec, record_cols, ohm, vol, probe_cols, probe):
    """Probe rows of spatial spines from their ``spatial.record.record`` rows (``ohm`` (B, W)
    L0/A_w of each wire [1/m], ``vol`` (B, W) wire volume of each group [m^3])."""
    for j in range(rows.shape[0]):
        spatial_probe_row(rows[j], rec, record_cols, ohm, vol, probe_cols, probe)


@hot
def spatial_probe_row(i, rec, record_cols, ohm, vol, probe_cols, probe):
    """:func:`spatial_probe` of the one spine ``i`` (the parallel step kernels call it per row)."""
    deg = 180.0 / math.pi
    nmb = probe_cols[PB_TEMP] - probe_cols[PB_MODB]
    nw = ohm.shape[1]
    r = rec[i]
    p = probe[i]
    for q in range(2):
        p[probe_cols[PB_TIPB] + q] = r[record_cols[R_TIPB] + q] * deg
    for q in range(3):
        p[probe_cols[PB_TIPP] + q] = r[record_cols[R_TIPP] + q] * 1000.0
    for q in range(nmb):
        p[probe_cols[PB_MODB] + q] = r[record_cols[R_MODB] + q] * deg
    for w in range(nw):
        p[probe_cols[PB_TEMP] + w] = r[record_cols[R_TEMP] + w]
        p[probe_cols[PB_RES] + w] = r[record_cols[R_RHO] + w] * ohm[i, w]
        p[probe_cols[PB_JOULE] + w] = r[record_cols[R_QJ] + w] * vol[i, w]


def probe_cols(n_wires: int, n_modules: int) -> np.ndarray:
    """Columns of the PB_* blocks in the probe row of a spine with W wire groups and K modules."""
    sizes = (2, 3, 2 * n_modules, n_wires, n_wires, n_wires)
    return np.concatenate(([0], np.cumsum(sizes))).astype(np.int64)
