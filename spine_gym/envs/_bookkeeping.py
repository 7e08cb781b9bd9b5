"""Jitted bookkeeping of one env step: sensors, observation, reward, info (no physics here).

After :func:`spine_gym.physics.env_kernels.step_many` has advanced the spines and written
:func:`spine_gym.physics.batch.record` rows, :func:`finish_rows` turns each row into what the
environment returns: unit conversions (rad -> deg, resistivity -> Ohm), the step's electrical energy
from the model's Joule-heat accumulators, the sensor delay line plus the noise drawn in Python,
the observation vector (clipped to its bounds), the reward terms, the over-temperature cost and
the termination/truncation flags. It runs for the single env (one row) and the vector env (all
rows) alike, so both return the same numbers; doing it in one jitted call instead of ~40 small
NumPy operations keeps the per-step Python cost of the single env low.

The formulas are documented in :class:`spine_gym.envs.SmaSpineEnv` (Observation space, Rewards).
"""

from __future__ import annotations

import math

import numpy as np

from ..physics._jit import jit
from ..physics.batch import OUT_ANGLE, OUT_RES_L, OUT_RES_R
from ..physics.layout import OK, X_QJL, X_QJR, X_TL, X_TR

# columns of the info matrix written by finish_rows (pairs are adjacent so that they slice)
(
    I_VOLT_R,
    I_VOLT_L,
    I_POWER_R,
    I_POWER_L,
    I_TEMP_R,
    I_TEMP_L,
    I_RES_R,
    I_RES_L,
    I_FORCE_X,
    I_FORCE_Y,
    I_ANGLE,
    I_TARGET,
    I_ERROR,
    I_ENERGY,
    I_COST,
    I_TIME,
    I_REWARD,
    I_R_TRACK,
    I_R_ENERGY,
    N_INFO,
) = range(20)
N_CHANNELS = 5  # sensor channels: angle [deg], T_R, T_L [K], R_R, R_L [Ohm]
# scalar settings passed as one float array
S_PERIOD, S_ERROR_SCALE, S_ENERGY_COEF, S_COST_WEIGHT, S_T_LIMIT, N_SETTINGS = range(6)


@jit
def channels(meas_row, ohm_per_resistivity, out):
    """True sensor channels of a ``batch.record`` row: angle [deg], T_R, T_L [K], R_R, R_L [Ohm]."""
    out[0] = meas_row[OUT_ANGLE] * (180.0 / math.pi)
    out[1] = meas_row[X_TR]
    out[2] = meas_row[X_TL]
    out[3] = meas_row[OUT_RES_R] * ohm_per_resistivity
    out[4] = meas_row[OUT_RES_L] * ohm_per_resistivity


@jit
def assemble(obs_row, measured, rate, target, preview, prev_r, prev_l, low, high):
    """Observation entries (layout of ``core.OBS_NAMES``), clipped to [low, high]."""
    obs_row[0] = measured[0]
    obs_row[1] = target
    obs_row[2] = measured[1]
    obs_row[3] = measured[2]
    obs_row[4] = rate
    obs_row[5] = preview
    obs_row[6] = prev_r
    obs_row[7] = prev_l
    obs_row[8] = measured[3]
    obs_row[9] = measured[4]
    for q in range(obs_row.shape[0]):
        v = obs_row[q]
        if v < low[q]:
            v = low[q]
        elif v > high[q]:
            v = high[q]
        obs_row[q] = v


@jit
def finish_rows(
    rows,
    meas,
    k,
    joule,
    side_volume,
    ohm_per_resistivity,
    hist,
    noise,
    prev_measured_angle,
    prev_action,
    actions,
    volts,
    loads,
    status,
    targets,
    preview_steps,
    max_steps,
    low,
    high,
    settings,
    obs_out,
    info_out,
    terminated,
    truncated,
):
    """Bookkeeping of the step just taken by the spines ``rows`` (updates the per-env memory).

    Args:
        rows: (n,) int64 indices of the environments that stepped.
        meas: (B, OUT_SIZE) ``batch.record`` rows after the step.
        k: (B,) steps taken in the episode, incremented here.
        joule: (B, 2) cumulative Joule heat of each side at the last step [J], updated.
        side_volume: (B,) wire volume of one side [m^3]; ohm_per_resistivity: (B,) L0/A_w [1/m].
        hist: (B, delay + 1, N_CHANNELS) true channels, oldest first, shifted here.
        noise: (n, N_CHANNELS) sensor noise of this step (zeros when off).
        prev_measured_angle: (B,) measured angle of the last step [deg], updated.
        prev_action: (B, 2) last clipped action, updated; actions: (B, 2) clipped actions.
        volts: (B, 2) applied voltages [V]; loads: (B, N, 2) vertex forces of the step [N].
        status: (B,) status of the step; targets: (B, n_grid) θ*(t_k) [deg].
        preview_steps, max_steps: look-ahead of the preview entry, truncation step count.
        low, high: observation bounds; settings: S_* scalars.
        obs_out: (n, OBS_DIM) float32 out; info_out: (n, N_INFO) out (I_* columns);
        terminated, truncated: (n,) bool out.
    """
    period = settings[S_PERIOD]
    last = targets.shape[1] - 1
    delay = hist.shape[1] - 1
    true = np.empty(N_CHANNELS)
    measured = np.empty(N_CHANNELS)
    obs = np.empty(obs_out.shape[1])
    for j in range(rows.shape[0]):
        i = rows[j]
        k[i] += 1
        kk = k[i]
        m = meas[i]
        # electrical energy of the step from the model's Joule-heat accumulators
        jr = m[X_QJR] * side_volume[i]
        jl = m[X_QJL] * side_volume[i]
        e_r = jr - joule[i, 0]
        e_l = jl - joule[i, 1]
        joule[i, 0] = jr
        joule[i, 1] = jl
        energy = e_r + e_l
        # sensors: true channels -> delay line -> noise
        channels(m, ohm_per_resistivity[i], true)
        for q in range(delay):
            for c in range(N_CHANNELS):
                hist[i, q, c] = hist[i, q + 1, c]
        for c in range(N_CHANNELS):
            hist[i, delay, c] = true[c]
            measured[c] = hist[i, 0, c] + noise[j, c]
        rate = (measured[0] - prev_measured_angle[i]) / period
        prev_measured_angle[i] = measured[0]
        prev_action[i, 0] = actions[i, 0]
        prev_action[i, 1] = actions[i, 1]
        target = targets[i, min(kk, last)]
        preview = targets[i, min(kk + preview_steps, last)]
        assemble(obs, measured, rate, target, preview, actions[i, 0], actions[i, 1], low, high)
        for q in range(obs.shape[0]):
            obs_out[j, q] = obs[q]
        # reward on the true state
        error = target - true[0]
        cost = max(true[1] - settings[S_T_LIMIT], 0.0) + max(true[2] - settings[S_T_LIMIT], 0.0)
        r_track = -abs(error) / settings[S_ERROR_SCALE]
        r_energy = -settings[S_ENERGY_COEF] * energy
        reward = r_track + r_energy - settings[S_COST_WEIGHT] * cost
        row = info_out[j]
        row[I_VOLT_R] = volts[i, 0]
        row[I_VOLT_L] = volts[i, 1]
        row[I_POWER_R] = e_r / period
        row[I_POWER_L] = e_l / period
        row[I_TEMP_R] = true[1]
        row[I_TEMP_L] = true[2]
        row[I_RES_R] = true[3]
        row[I_RES_L] = true[4]
        row[I_FORCE_X] = loads[i, 0, 0]
        row[I_FORCE_Y] = loads[i, 0, 1]
        row[I_ANGLE] = true[0]
        row[I_TARGET] = target
        row[I_ERROR] = error
        row[I_ENERGY] = energy
        row[I_COST] = cost
        row[I_TIME] = kk * period
        row[I_REWARD] = reward
        row[I_R_TRACK] = r_track
        row[I_R_ENERGY] = r_energy
        terminated[j] = status[i] != OK
        truncated[j] = kk >= max_steps and status[i] == OK
