"""``SmaSpine-v0``: track a bending angle with the two antagonistic SMA wires (Gymnasium env).

The class docstring of :class:`SmaSpineEnv` is the documentation page; its observation table is
generated from the env's declarative table (:meth:`.planar.PlanarConfig.table`). Everything else is
the one env layer of spine_gym (:class:`.spine_env.SpineEnv`, :class:`.spine_vector_env.SpineVectorEnv`)
over the planar configuration and batch (:mod:`.planar`); the spatial siblings are in
:mod:`.spatial_env`.
"""

from __future__ import annotations

from .planar import PlanarBatch, PlanarConfig
from .spine_env import SpineEnv
from .spine_vector_env import SpineVectorEnv

__all__ = ["SmaSpineEnv", "SmaSpineVectorEnv"]


class SmaSpineEnv(SpineEnv):
    """SMA-actuated robotic spine: bend it to a moving target angle by heating two wires.

    ## Description

    A flexible tube of 13 segments (0.455 m) carries a NiTi shape-memory-alloy wire on each side,
    14 mm off its axis. Current through a wire heats it; above ~340 K the wire turns to austenite,
    shortens and bends the spine toward its side (positive angles: toward the right wire). The
    physics is the thermo-mechanical model of ``docs/MODEL.md``: per wire a Müller-Achenbach-
    Seelecke phase model with Joule heating, latent heat and convection, coupled to a quasi-static
    segmented bending model, integrated with adaptive sub-steps. The task is to track a target
    bending angle θ*(t) while tip forces and a payload disturb the spine.

    What makes it hard: the response is slow (wire thermal time constant ~17 s) and hysteretic;
    a heated wire that cools keeps the spine bent for seconds and relaxes over ~25 s; the wire on
    the outside of a bend is stretched (detwinned) and does **not** pull back by itself, so to
    bend the other way you heat the other wire. After a 5-V heating pulse, 2.5 V holds ~36° (wire
    ~395 K) and 3 V ~45° (~430 K); 5 V held drives a wire to ~650 K and the spine to its ±63°
    limit in ~10 s.

    ## Action space

    ``Box(-1, 1, (2,), float32)``; volts = (clip(a, -1, 1) + 1) / 2 · ``v_max``.

    | index | wire  | -1  | +1        | unit |
    |-------|-------|-----|-----------|------|
    | 0     | right | 0 V | ``v_max`` | -    |
    | 1     | left  | 0 V | ``v_max`` | -    |

    Actions outside [-1, 1] are clipped (silently; the applied volts are ``info["voltage"]``). An
    action that is not a finite numeric array of shape (2,) raises ``ValueError``. The voltage is
    held over the control period (zero-order hold).

    ## Observation space

    ``Box(low, high, (10,), float32)``; entries outside the bounds are clipped to them.

    {obs_table}

    The resistance bound is 2 × the largest one-wire resistance over the nominal and randomised
    parameters (the table shows the baseline's, whose wire has 1.87 Ohm in martensite, 2.34 Ohm in
    austenite), plus 10 standard deviations of resistance noise. The angle, the temperatures and
    the resistances are sensor readings: they see ``sensor_delay`` control periods into the past
    and carry Gaussian ``sensor_noise`` if enabled; the angle rate differentiates the measured
    angle. Target, preview and previous actions are exact. Time t is the end of the step just
    taken (``info["time"]``). The table is generated from the env's declarative table
    (:meth:`spine_gym.envs.planar.PlanarConfig.table`); ``env.unwrapped.obs_index(key)`` gives the
    indices of an entry. The first four entries (angle, target, right and left temperature) are
    the env contract.

    ## Rewards

    After each step, with e = θ*(t) − θ(t) [deg] (true angle, not the noisy reading), E the
    electrical energy of the step [J] (both wires) and E_ref the largest possible one (both wires
    at ``v_max``, lowest resistance; 2.7 J at the defaults):

        r = −|e| / error_scale − energy_weight · E / E_ref − cost_weight · cost

    With the defaults (``error_scale`` = 10°, ``energy_weight`` = 0.5, ``cost_weight`` = 0) a step
    earns −0.1 per degree of error and at most −0.5 for energy: between about −11 (target 45° one
    way, spine 63° the other, both wires at 5 V) and 0; typical values are −4 to 0.
    ``info["reward_tracking"]`` and ``info["reward_energy"]`` hold the first two terms.

    **Cost** (safety-gymnasium convention, kept out of the reward by default):
    ``info["cost"]`` = Σ over both wires of max(0, T − ``temperature_limit``) [K] >= 0.

    ## Starting state

    A straight spine at ambient temperature T_E with the martensite fractions of the pre-strained
    wires (MODEL.md §3.10), solved under the episode's payload. Each reset draws from the env's
    seeded generator, in this order: a target profile (:meth:`TargetProfile.sample`: 1-3 setpoint
    steps, a ramp between two levels, or a sinusoid with period in ``sine_period_range``, all
    inside ``target_range``), a load schedule (:meth:`LoadSchedule.sample`: ``tip_force_count``
    tip-force events of magnitude in ``tip_force_range`` N, uniform direction in the global frame,
    uniform onset, length in ``tip_force_duration`` s; a payload in ``payload_range`` kg), and, if
    enabled, randomised model parameters. ``reset(options=...)`` pins any of them:

    * ``"target"``: a :class:`~spine_gym.envs.targets_planar.TargetProfile` (or a number: a constant target
      in degrees; pinned targets may use ±90°);
    * ``"loads"``: a :class:`~spine_gym.envs.loads.LoadSchedule`;
    * ``"params"``: a :class:`~spine_gym.ModelParams` (same ``n_seg``) instead of the randomised set.

    ## Episode end

    * **Truncation** when ``episode_duration`` (default 60 s = 600 steps) has elapsed; the
      registration's ``max_episode_steps=600`` matches the default. If you change
      ``episode_duration`` or ``control_period`` through ``gym.make``, also pass
      ``max_episode_steps=episode_duration / control_period`` (the TimeLimit wrapper of ``gym.make``
      truncates at the smaller of the two).
    * **Termination** only when the model fails (``info["status"]`` != 0, a
      ``spine_gym.physics.columns`` status code, ``info["status_text"]`` its meaning). The
      observation is then that of the last valid state (the failed step is rolled back, so nothing
      is ever NaN). With the default load ranges it did not happen in 2 × 128 randomised 60-s
      episodes of held full-voltage switching at ``v_max`` = 5 and 8 V.
    * **Buckling** is one such failure: ``layout.ERR_BUCKLING`` ("load beyond buckling"), decided
      from the stability of the equilibrium, not from the solver's convergence, so a straight
      spine is never held up by its exact but unstable straight shape. At the default design
      (:func:`spine_gym.buckling.critical_load`) the straight spine at reset, its wires at their
      stress-free length, holds a downward tip force below 5.59 N (a payload below 0.570 kg). A tip
      force up to 1.42 N is safe in every state, in any direction, even with both wires slack
      (Dunkerley's lower bound for the bare tube, which itself buckles at 1.48 N straight); the
      payload's weight counts against it. The default loads (<= 0.5 N plus <= 0.05 kg) stay below
      it; ``tip_force_range`` allows up to 20 N, and larger forces may end the episode this way.
      A payload the straight spine cannot carry makes ``reset`` raise ``ValueError``.
      A bent spine has no bifurcation under a vertical load: it bends further.

    ## Info

    ``voltage`` (2,) [V] applied [right, left]; ``angle_deg``; ``target_deg``; ``tracking_error_deg``
    (= target − angle); ``energy_J`` electrical energy of the step (both sides); ``power_W`` (2,) mean
    electrical power per side; ``cost``; ``temperature`` (2,) [K]; ``resistance`` (2,) [Ohm];
    ``time`` [s]; ``tip_force`` (2,) [N] total force on the top disk over the step (events + payload
    weight, global x/y); ``status`` (int, 0 = ok); ``reward_tracking``, ``reward_energy``; on a
    failed step (``status`` != 0) also ``status_text`` (str, what failed). ``reset`` returns the
    same keys (zero voltage, energy and reward terms).

    ## Arguments

    ```python
    gym.make("SmaSpine-v0", v_max=5.0, control_period=0.1, episode_duration=60.0, ...)
    ```

    * ``v_max`` [V] in (0, 8]: voltage of action +1. Default 5.
    * ``control_period`` [s]: time per step, a multiple of ``physics_dt``. Default 0.1.
    * ``physics_dt`` [s]: the model's output step inside a control period, in (0, control_period],
      a divisor of it. Default ``None``: the control period itself. The model's error-controlled
      sub-steps (MODEL.md §6.5) run inside each output step, so only the cost changes with it: an
      output step caps the sub-step, and nothing inside a control period is observed. Over the
      50-s hysteresis run the angle is within 0.23° of the fine-step reference at 0.1 s and 0.03°
      at 0.01 s, which takes ~8× the sub-steps (``tests/envs/test_env.py``).
    * ``episode_duration`` [s]: a multiple of ``control_period``. Default 60.
    * ``target_range`` [deg]: (low, high) within ±60 for sampled targets. Default (-45, 45): the
      spine holds ±36° with a wire at ~395 K and ±45° at ~430 K (about the default limit); ±60°
      needs ~4 V and wires far beyond it.
    * ``target_kinds``: subset of ``("steps", "ramp", "sine")``. ``sine_period_range`` [s]: (20, 60).
    * ``target_preview`` [s]: look-ahead of observation 5. Default 1.
    * ``tip_force_range`` [N] (low, high) or ``None`` (off), <= 20: default (0, 0.5).
      ``tip_force_count``: (0, 2) events per episode. ``tip_force_duration`` [s]: (1, 10).
    * ``payload_range`` [kg] (low, high) or ``None`` (off), <= 1: default (0, 0.05).
    * ``domain_randomization``: ``False`` (default), ``True`` (convection ×[0.75, 1.25], tube
      modulus ×[0.8, 1.2], ambient ±10 K, resistivities ×[0.95, 1.05]; see
      :func:`spine_gym.envs.default_randomization`) or a dict ``{ModelParams field: (low, high)}``
      of absolute ranges; drawn uniformly per episode. Or the path of a preset written by a fit
      (``spine_gym.calibrate``, e.g. ``"fit.json"``): each episode draws the fitted parameters
      from the fit's uncertainty (multivariate normal within the fit bounds; parameters the data
      could not identify uniformly within their bounds), and ``params`` defaults to the fitted
      preset (:class:`spine_gym.uncertainty.ParameterUncertainty`).
    * ``sensor_noise``: ``None`` (default) or ``{"angle": deg, "temperature": K, "resistance": Ohm}``
      standard deviations. ``sensor_delay``: whole control periods (default 0).
    * ``temperature_limit`` [K]: threshold of ``info["cost"]``. Default 423 (150 °C).
    * ``thermal_cutoff`` [K]: ``None`` (default, no cut-off) or the wire driver's thermal cut-off
      in (``T_E``, ``temperature_limit``]: a wire whose true temperature (not the sensor's) at the
      start of a control period is at or above it gets 0 V for that period, whatever the action
      (``info["voltage"]``, power and energy are those delivered; the observation's previous action
      stays the commanded one). 418 K in every ``-v2`` id.
    * ``error_scale`` [deg] (10), ``energy_weight`` (0.5), ``cost_weight`` [1/K] (0): reward terms.
    * ``observe_errors``: append target − measured tracked quantity and target preview − measured
      tracked quantity to the observation (default ``False``; ``True`` in every ``-v1`` id).
    * ``params``: :class:`spine_gym.ModelParams` (default: MODEL.md §7 baseline);
      ``solver``: :class:`spine_gym.SolverOptions`.
    * ``render_mode``: ``None`` or ``"rgb_array"`` (480×480 frame: the bent spine, wires coloured
      by temperature from blue (ambient) to red (``temperature_limit`` and above), target as a
      dashed arc, force on the top disk as an arrow, and a legend of these with the temperature
      limit).

    Bad arguments raise ``ValueError`` naming the argument and its allowed range.

    ## Vector environment

    ``gym.make_vec("SmaSpine-v0", num_envs=N)`` returns
    :class:`spine_gym.envs.planar_env.SmaSpineVectorEnv`: the loop over environments runs inside
    numba in parallel, on the same code as this class; row i equals this env seeded with seed + i.

    ## Version history

    * v0: initial release (spine_gym 0.1).
    * v1 (``SmaSpine-v1``; tiers ``SmaSpineEasy-v1``, ``SmaSpineHard-v1``): ``observe_errors=True`` (the
      observation ends with target − measured angle and preview − measured), reward ÷ 10
      (``error_scale`` 100°, ``energy_weight`` 0.05) so that returns are of order one; the
      tiers change only the task distribution (:mod:`spine_gym.envs.ids`). ``-v0`` is unchanged.
    """

    CONFIG = PlanarConfig
    BATCH = PlanarBatch


class SmaSpineVectorEnv(SpineVectorEnv):
    """``num_envs`` copies of :class:`SmaSpineEnv` in one jitted loop over the spines (conventions of
    :class:`~spine_gym.envs.spine_vector_env.SpineVectorEnv`: autoreset modes, ``reset_mask``,
    ``get_attr``, snapshot/restore)."""

    CONFIG = PlanarConfig
    BATCH = PlanarBatch


if SmaSpineEnv.__doc__ is not None:  # the observation table, from the env's table (python -OO strips docs)
    SmaSpineEnv.__doc__ = SmaSpineEnv.__doc__.replace(
        "{obs_table}", PlanarConfig().table().markdown_observation().replace("\n", "\n    ")
    )
