"""Controllers for ``SmaSpine-v0`` and the spatial envs (no torch needed), all behind SB3's ``predict``.

* :mod:`.base` — what every controller shares (SB3's ``predict``, the temperature guard, actions
  from volts; no observation index), the PID gains and the relay settings;
  :mod:`.steady_state` — the voltage → steady angle map the step drives and feedforwards read.
* :mod:`.planar` — the paper's step voltage, a bang-bang relay and a PID for ``SmaSpine-v0`` (the
  classical baselines; ``spine_gym.controllers.baselines`` is the former module path, kept for
  one release).
* :mod:`.mpc` — sampling model-predictive control (MPPI) on the env's own batched physics, with the
  true state (``oracle``, privileged; ``oracle_causal``, privileged state but only the current
  load and the observed target preview) or an estimated one (``estimated``).
* :mod:`.mpc_long` — MPC over the wires' thermal time scale (15 s): move-blocked MPPI on a coarser
  step of the env's physics, warm-started, with an energy term and a soft temperature bound, from
  the observation (real time: ``benchmarks/bench_mpc_plan_time.py``).
* :mod:`.mpc_spatial` — the same MPPI for ``SmaSpine3D-v0`` and ``SmaSpineChain-v0`` (one voltage
  sequence per wire, the spatial core's batched rollouts).
* :mod:`.estimator` — the phase-fraction estimators behind the ``estimated`` mode.
* :mod:`.sliding_mode` — adaptive terminal sliding-mode control (boundary layer, adaptive switching
  gain), planar and per bending axis of the spatial spines.
* :mod:`.spatial` — the three baselines for ``SmaSpine3D-v0`` and ``SmaSpineChain-v0`` (per
  bending axis and module; the chain's references from the arc inverse kinematics).
"""

from .base import BaseController, PIDGains, action_to_volts, volts_to_action
from .estimator import DisturbanceConfig, PhaseEstimator, SpatialPhaseEstimator, austenite_from_resistance
from .mpc import MODES, PRIVILEGED_MODES, MPPIConfig, MPPIController
from .mpc_long import LongHorizonMPC, LongMPCConfig
from .mpc_spatial import SpatialMPPIController
from .planar import BangBangController, PIDController, PlanarController, StepVoltageController
from .sliding_mode import SlidingModeController, SMCGains, SpatialSlidingModeController
from .spatial import SpatialBangBangController, SpatialPIDController, SpatialSignals, SpatialStepController
from .steady_state import SteadyStateMap, steady_state_map

__all__ = [
    "BangBangController",
    "BaseController",
    "DisturbanceConfig",
    "LongHorizonMPC",
    "LongMPCConfig",
    "MODES",
    "MPPIConfig",
    "MPPIController",
    "PIDController",
    "PIDGains",
    "PRIVILEGED_MODES",
    "PhaseEstimator",
    "PlanarController",
    "SpatialBangBangController",
    "SpatialMPPIController",
    "SpatialPIDController",
    "SpatialSlidingModeController",
    "SpatialPhaseEstimator",
    "SpatialSignals",
    "SpatialStepController",
    "SMCGains",
    "SlidingModeController",
    "SteadyStateMap",
    "StepVoltageController",
    "action_to_volts",
    "austenite_from_resistance",
    "steady_state_map",
    "volts_to_action",
]
