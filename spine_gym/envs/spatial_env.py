"""``SmaSpine3D-v0`` and ``SmaSpineChain-v0``: the seed's four-wire module and a chain of them.

The class docstrings are the documentation pages; their observation and info tables are
generated from the envs' declarative tables (:meth:`.spatial.Spine3DConfig.table`,
:meth:`.spatial.ChainConfig.table`), the reach tables were computed from the model by
:mod:`spine_gym.envs.reach` (and are checked against it by the tests). Everything else is the
one env layer of spine_gym (:class:`.spine_env.SpineEnv`, :class:`.spine_vector_env.SpineVectorEnv`);
the planar sibling is in :mod:`.planar_env`.
"""

from __future__ import annotations

from . import reach
from .spatial import (
    ChainBatch,
    ChainConfig,
    Spine3DBatch,
    Spine3DConfig,
    workspace_low_mm,
    workspace_radius_mm,
)
from .spine_env import SpineEnv
from .spine_vector_env import SpineVectorEnv

__all__ = ["SmaSpine3DEnv", "SmaSpineChainEnv", "SmaSpine3DVectorEnv", "SmaSpineChainVectorEnv"]


class SmaSpine3DEnv(SpineEnv):
    """SMA-actuated robotic spine with four wires: point the tip in any direction.

    ## Description

    The seed's hardware (docs/SPATIAL.md): one flexible tube of 13 segments (0.455 m) with four
    NiTi wires in pores 90° apart, 14 mm off the axis (wire j at azimuth ψ = 90° j; wire 0 and 2
    are the planar env's right and left wire). Heating a wire bends the tube toward it, so one
    module bends in two planes. The physics is the wire-generic spatial core of SPATIAL.md §1-§5
    (each wire the MAS model of MODEL.md §3, 3-D parallel-transported segment kinematics,
    follower wire moments, a coupled Newton solve), integrated with adaptive sub-steps. The task:
    make the tip bending vector b = (Θ cos β, Θ sin β) — Θ the polar angle of the tip tangent from
    the vertical, β its azimuth from wire 0 toward wire 1 — track a target b*(t) while tip forces
    in any 3-D direction and a payload disturb the spine.

    What makes it hard, besides the slow hysteretic wires of ``SmaSpine-v0``: a direction between
    two wires needs both heated in the right ratio; the wire opposite a bend is stretched
    (detwinned) and does not pull back by itself, while the two wires 90° off the bend plane sit on
    its neutral axis and keep their length; so turning the bend (circles, figure-eights) hands the
    work from wire to wire, each of which must first cool or be stretched back.

    ## Action space

    ``Box(-1, 1, (4,), float32)``; volts_j = (clip(a_j, -1, 1) + 1) / 2 · ``v_max`` on wire j
    (ψ = 0°, 90°, 180°, 270°). Out-of-range actions are clipped (silently; the applied volts are
    ``info["voltage"]``); an action that is not a finite array of shape (4,) raises ``ValueError``.
    Zero-order hold over the control period.

    ## Observation space

    ``Box(low, high, (20,), float32)``; entries outside the bounds are clipped to them.

    {obs_table}

    The resistance bound is 2 × the largest one-wire resistance over the nominal and randomised
    parameters (plus 10 standard deviations of resistance noise); the table shows the defaults. Bending, temperatures and resistances are sensor
    readings (``sensor_delay`` control periods old, Gaussian ``sensor_noise`` "angle" [deg],
    "temperature" [K], "resistance" [Ohm]); the rate differentiates the measured bending vector;
    targets and previous actions are exact. The indices follow from the env's table
    (:meth:`spine_gym.envs.spatial.Spine3DConfig.table`; ``env.unwrapped.obs_index(key)`` gives
    the slice of an entry, e.g. ``obs_index("temperature")``).

    ## What a controller can reach

    Steady states of the model (:mod:`spine_gym.envs.reach`; heated from cold at a constant
    voltage for 60 s, no load): the voltage on the heated wire(s) that holds a bend Θ, the wire
    temperature and the electrical power it costs. "axis": toward a wire (β = 0°, one wire
    heated); "diagonal": between two wires (β = 45°, both at the same voltage). Other directions
    lie between the two (four-fold symmetry).

    {reach_table}

    Holding 40° costs 414 K and 3.6 W toward a wire, 386 K and 5.6 W between two (each wire does
    less, both together more). At the default ``temperature_limit`` (423 K) a wire holds about 44°
    toward itself (45° costs 427 K); between two wires 45° costs 394 K. Full drive (5 V on one
    wire) reaches Θ = 63° at ~600 K. The default targets stay within 45°.

    ## Rewards

    As ``SmaSpine-v0``, with e = b*(t) − b(t) the error vector [deg] (true bending) and E the
    electrical energy of the step (all four wires), E_ref the largest one (all wires at ``v_max``,
    lowest resistance; 5.3 J at the defaults):

        r = −|e| / error_scale − energy_weight · E / E_ref − cost_weight · cost

    **Cost** ``info["cost"]`` = Σ over the four wires of max(0, T − ``temperature_limit``) [K].

    ## Starting state

    A straight spine at ambient temperature with the pre-strained wires, solved under the
    episode's payload. Each reset draws from the env's seeded generator, in this order: a target
    (:meth:`spine_gym.envs.targets_spatial.BendTarget.sample`: 1-3 setpoint steps to random
    directions with magnitudes in ``target_range``, a circle of the tip direction at a polar angle
    in ``target_range``, or a figure-eight of that half-width, periods in
    ``target_period_range``), a load schedule (:meth:`LoadSchedule.sample` with ``dim=3``: events
    of magnitude in ``tip_force_range`` N, direction uniform on the sphere, a payload in
    ``payload_range`` kg hanging along −z), and, if enabled, randomised parameters.
    ``reset(options=...)`` pins any of them: ``"target"`` (a :class:`BendTarget` or a constant
    (b1, b2) [deg]), ``"loads"`` (a :class:`LoadSchedule` with ``dim=3``), ``"params"``.

    ## Episode end

    Truncation after ``episode_duration`` (default 60 s = 600 steps, the registration's
    ``max_episode_steps``). Termination only when the model fails (``info["status"]`` != 0, its
    meaning in ``info["status_text"]``, e.g. buckling under a large downward force); the failed
    step is rolled back, the observation is that of the last valid state, never NaN.

    ## Info

    {info_table}

    plus ``status`` (int, 0 = ok) and, on a failed step, ``status_text``. ``reset`` returns the
    same keys (zero voltage, energy and reward terms).

    ## Arguments

    ``v_max`` (0, 8] V, ``control_period``, ``physics_dt``, ``episode_duration``,
    ``target_preview``, ``tip_force_range`` (<= 20 N), ``tip_force_count``,
    ``tip_force_duration``, ``payload_range`` (<= 1 kg), ``domain_randomization``,
    ``sensor_delay``, ``temperature_limit``, ``thermal_cutoff``, ``error_scale`` [deg],
    ``energy_weight``, ``cost_weight``, ``observe_errors``, ``params``, ``solver``: as
    ``SmaSpine-v0``.
    ``sensor_noise``: ``None`` or a dict with keys among "angle" [deg], "temperature" [K],
    "resistance" [Ohm]. Own arguments:

    * ``target_range`` [deg]: (low, high) magnitude |b*| of sampled targets, within [0, 60].
      Default (0, 45).
    * ``target_kinds``: subset of ``("steps", "circle", "figure8")``.
    * ``target_period_range`` [s]: period of circles and figure-eights. Default (20, 60).
    * ``wire_values``: per-wire material values, one mapping per wire with keys among
      ``lam_scale``, ``T_shift`` [K], ``eps0`` (:class:`spine_gym.WireGroup`); default: those of a
      spatial fit preset given as ``domain_randomization``, else none. A preset whose fit varied
      per-wire parameters also draws them per episode (docs/calibration.md, spatial section).
    * ``render_mode``: ``None`` or ``"rgb_array"``: a 480×480 frame with a perspective view of
      the spine (each wire in its own colour map, pale at ambient, dark at ``temperature_limit``),
      a top view of the tip with its recent path and the target, a legend (target, tip path, tip
      force arrow, temperature limit) and bars of the wire temperatures [K] with their voltages
      [V] (:class:`spine_gym.envs.render.SpatialRenderer`).

    Bad arguments raise ``ValueError`` naming the argument and its allowed range.

    ## Vector environment

    ``gym.make_vec("SmaSpine3D-v0", num_envs=N)``: :class:`SmaSpine3DVectorEnv`, the same parallel
    numba loop over the spatial core; row i equals this env seeded with seed + i.
    ``spine_gym.envs.sb3.make_sb3_vec_env(N, env_id="SmaSpine3D-v0")`` for Stable-Baselines3.

    ## Version history

    * v0: initial release.
    * v1 (``SmaSpine3D-v1``; tiers ``SmaSpine3DEasy-v1``, ``SmaSpine3DHard-v1``): ``observe_errors=True`` (the
      observation ends with target − measured tip bending vector and preview − measured), reward ÷ 10
      (``error_scale`` 100°, ``energy_weight`` 0.05) so that returns are of order one; the
      tiers change only the task distribution (:mod:`spine_gym.envs.ids`). ``-v0`` is unchanged.
    """

    CONFIG = Spine3DConfig
    BATCH = Spine3DBatch


class SmaSpineChainEnv(SpineEnv):
    """A chain of four-wire SMA spine modules: move the tip to a target position.

    ## Description

    ``n_modules`` (default 2) four-wire modules stacked end to end (SPATIAL.md §6,
    :meth:`spine_gym.SpineLayout.chain`): they share the seed's bending length (0.455 m; default
    2 × 7 segments of 32.5 mm) and wire length (each module's wires are L0 / n_modules long), and
    every joint carries a disk like the top disk. Module k's four wires (ψ = 0°, 90°, 180°, 270° in
    its material frame) are anchored at its two disks and bend only that module. With two modules
    the chain can bend into an S and put the tip at positions one module cannot. The default
    chain stands with margin: its straight column's load factor is 0.38 (< 1 stands, SPATIAL.md §6;
    3 modules 0.41, 4 modules 0.44; ``SpineLayout`` rejects a chain that does not stand). The
    task: track a target tip position p*(t) [mm] (global frame, z up, x toward wire 0 of the
    bottom module).

    Joule heating goes as V²/(ρ L0²): a module's shorter wires heat like the seed's at a lower
    voltage, so the voltage on module k's wires is the action's voltage times L0_k / L0 (= 1 /
    n_modules here; ``SpineLayout.voltage_scale``): ``v_max`` is the seed-equivalent full drive.

    ## Action space

    ``Box(-1, 1, (4·n_modules,), float32)``: wire j of module k is action 4k + j (bottom module
    first; ψ = 90° j); volts = (clip(a, -1, 1) + 1) / 2 · ``v_max`` / n_modules.

    ## Observation space

    ``Box(low, high, (14·n_modules + 12,), float32)`` (40 for two modules); clipped to the bounds.

    {obs_table}

    Position bounds are ± the chain's length (455 mm). Sensor readings: tip position ("position" noise [mm]),
    module bending vectors ("angle" [deg]; each module's top tangent in the module's base frame),
    temperatures and resistances; the tip velocity differentiates the measured tip position.

    ## Workspace and what a controller can reach

    A target is drawn as one bending vector per module (:meth:`ChainTarget.sample`), each of
    magnitude at most ``module_bend_limit`` (default 20°), and mapped to the tip by the spatial
    core's kinematics with every module a circular arc (:func:`arc_tip_position`). So the
    workspace is the set of tip positions of chains whose modules are arcs bent by up to
    ``module_bend_limit`` in any direction; with the defaults it spans a horizontal radius of up to
    {radius:.0f} mm (both modules bent the same way) at a height of {z_low:.0f} to 455 mm. Each module of
    the model reaches the limit toward a wire and between two (tested with both modules bent the
    same way; a module's wires act on that module only), and the arc map of the model's own module
    bends puts the tip within 3.4 mm of the model's tip (gravity bends the arcs a little; tested
    at the limit, between two wires). Steady states (:mod:`spine_gym.envs.reach`;
    constant voltage from cold, 60 s, no load, both modules bent the same way):

    {reach_table}

    ## Rewards, cost, starting state, episode end, info

    As ``SmaSpine3D-v0`` with the tip position: e = p*(t) − p(t) [mm],
    r = −|e| / error_scale − energy_weight · E / E_ref − cost_weight · cost, ``error_scale``
    20 mm by default (``-v0``; 200 mm in the ``-v1`` ids); E_ref with every wire at its full voltage. ``reset(options={{"target": ...}})``
    takes a :class:`ChainTarget` or an (n_modules, 2) array of module bending vectors [deg] (held).

    {info_table}

    plus ``status`` and, on a failed step, ``status_text``.

    ## Arguments

    Those of ``SmaSpine3D-v0`` except ``target_range``; ``sensor_noise`` keys "angle" [deg],
    "temperature" [K], "resistance" [Ohm], "position" [mm]. Own:

    * ``n_modules``: modules in the chain, an integer >= 1 (default 2); layouts past self-weight
      buckling raise ``ValueError``.
    * ``module_bend_limit`` [deg]: largest bend magnitude of a module in sampled targets, in
      [0, 60 / n_modules]. Default 20.

    ## Vector environment

    ``gym.make_vec("SmaSpineChain-v0", num_envs=N)``: :class:`SmaSpineChainVectorEnv`.

    ## Version history

    * v0: initial release.
    * v1 (``SmaSpineChain-v1``; tiers ``SmaSpineChainEasy-v1``, ``SmaSpineChainHard-v1``): ``observe_errors=True`` (the
      observation ends with target − measured tip position and preview − measured), reward ÷ 10
      (``error_scale`` 200 mm, ``energy_weight`` 0.05) so that returns are of order one; the
      tiers change only the task distribution (:mod:`spine_gym.envs.ids`). ``-v0`` is unchanged.
    """

    CONFIG = ChainConfig
    BATCH = ChainBatch


class SmaSpine3DVectorEnv(SpineVectorEnv):
    """``num_envs`` copies of :class:`SmaSpine3DEnv` in one jitted loop over the spines (conventions of
    :class:`~spine_gym.envs.spine_vector_env.SpineVectorEnv`: autoreset modes, ``reset_mask``,
    ``get_attr``, snapshot/restore)."""

    CONFIG = Spine3DConfig
    BATCH = Spine3DBatch


class SmaSpineChainVectorEnv(SpineVectorEnv):
    """``num_envs`` copies of :class:`SmaSpineChainEnv` in one jitted loop over the spines (conventions of
    :class:`~spine_gym.envs.spine_vector_env.SpineVectorEnv`)."""

    CONFIG = ChainConfig
    BATCH = ChainBatch


# ---------------------------------------------------------------- the documentation pages' tables
def _indent(text: str) -> str:
    return text.replace("\n", "\n    ")


def _document() -> None:
    """Fill the generated tables into the class docstrings (from the tables and reach.py's rows)."""
    if SmaSpine3DEnv.__doc__ is None:  # python -OO strips docstrings
        return
    cfg3, cfgc = Spine3DConfig(), ChainConfig()
    t3, tc = cfg3.table(), cfgc.table()
    SmaSpine3DEnv.__doc__ = SmaSpine3DEnv.__doc__.format(
        obs_table=_indent(t3.markdown_observation()),
        info_table=_indent(t3.markdown_info()),
        reach_table=_indent(reach.markdown(reach.REACH_3D)),
    )
    radius = workspace_radius_mm(cfgc)
    SmaSpineChainEnv.__doc__ = SmaSpineChainEnv.__doc__.format(
        obs_table=_indent(tc.markdown_observation()),
        info_table=_indent(tc.markdown_info()),
        reach_table=_indent(reach.markdown(reach.REACH_CHAIN, "Θ per module [deg]")),
        radius=radius,
        z_low=workspace_low_mm(cfgc),
    )


_document()
