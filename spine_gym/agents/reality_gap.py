"""Fine-tuning across the reality gap: pretrain on a calibration's uncertainty, fine-tune on a plant
that differs, score both on the evaluation suite (the library behind ``spine-gym finetune``).

The steps, each a function:

* :func:`shift_plant` — the "real" plant: the fitted preset (shared parameters and per-wire values)
  with every fit parameter moved by ``k`` of its standard errors (default 3 σ), the sign of each
  move drawn from ``seed`` (:class:`PlantShift`; an unidentified parameter moves by ``k`` × the
  standard deviation of its uniform draw), and optionally a *model error*: parameters the fit holds
  fixed set to other values (:func:`check_model_error`; e.g. the ambient temperature of the room the
  spine runs in, which a bench calibration cannot see). :func:`shift_plants`: the scored plants, one
  per sign seed (default four). :func:`write_plant` saves one as a preset file.
* :func:`pretrain` — PPO on the env id with ``domain_randomization=<preset>`` (every episode a
  plant drawn from the fit's covariance, per-wire values included), the plain ``-v1`` entry of
  ``hyperparams/ppo.yml`` (:func:`plain_entry`: no energy budget, no observation wrappers).
* :func:`finetune` — the pretrained policy trained on the shifted plant for a step budget
  (:class:`Learner`: one spine, as on hardware, PPO with short rollouts; the policy, its value
  function and its observation statistics continue from the pretrained run).
* :func:`select_learner` — the learner chosen among candidates on *tuning* shifts (other seeds than
  the evaluated plant's) by the mean validation RMSE, never on the evaluation suite.
* :func:`score_rows` — the before/after rows on the evaluation set (the suite and held-out episodes
  of the env's own samplers): the pretrained policy on the nominal (fitted) plant and on each shifted
  plant, the fine-tuned policies and the tuned PID on each shifted plant, the control arm;
  :func:`paired_gains` (one plant) and :func:`pooled_gains` (all of them) — how much of the RMSE
  the shift cost the fine-tuning won back, with bootstrap intervals; :func:`target_verdict` —
  whether that is at least half, with 95 % confidence.
* :func:`run_study` — all of it into one folder (``scores.csv``, ``plant.csv``, ``selection.csv``,
  ``reality_gap.png``, ``summary.json``, ``command.txt``, the policies).

A run folder of :func:`pretrain` or :func:`finetune` holds ``model.zip``, ``vecnormalize.pkl`` and
``meta.json``: ``spine-gym evaluate``, ``spine-gym export`` and ``spine-gym train -i`` read it.
"""

from __future__ import annotations

import csv
import json
import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from spine_gym.csv_numbers import csv_row
from spine_gym.envs import ENV_SPECS, config_of
from spine_gym.layout import SpineLayout, wire_key
from spine_gym.params import field_names
from spine_gym.uncertainty import ParameterUncertainty, apply_offsets

from .evaluation import evaluate
from .metrics import METRIC_COLUMNS, episode_metrics
from .runtime import (
    VALIDATION_SEED_BASE,
    controller_for,
    env_temperature_limit,
    evaluation_env_kwargs,
    load_policy,
    make_env,
    run_episode,
    validation_metrics,
)
from .scenarios import get_suite
from .training import build_envs, build_model, resolve_config
from .vec_env import make_vec_env
from .zoo_config import algo_class

__all__ = [
    "DEFAULT_ENV_ID",
    "STEP_BUDGET_LIMIT",
    "PlantShift",
    "Learner",
    "LEARNERS",
    "DEFAULT_LEARNER",
    "StudyConfig",
    "shift_plant",
    "shift_plants",
    "check_model_error",
    "write_plant",
    "plant_env_kwargs",
    "nominal_env_kwargs",
    "pretrain",
    "plain_entry",
    "finetune",
    "finetune_model",
    "tuning_plants",
    "select_learner",
    "paired_gains",
    "plant_rows",
    "pooled_gains",
    "target_verdict",
    "score_rows",
    "recovered_fraction",
    "run_study",
    "plot_scores",
]

DEFAULT_ENV_ID = "SmaSpine3DEasy-v2"  # a four-wire module: the per-wire values a spatial fit leaves
STEP_BUDGET_LIMIT = 1_000_000  # [env steps] the largest fine-tuning budget the command accepts
SCORE_COLUMNS = ("rmse_deg", "energy_J", "time_over_limit_s", "max_error_deg", "peak_temperature_K")
TUNING_SHIFT_SEEDS = (101, 102)  # the learner is chosen on these plants; the evaluated plant has its own seed
TUNING_TRAIN_SEEDS = (100, 101)  # fine-tuning seeds of the selection; the scored runs use 0, 1, ...
SHIFT_SEEDS = (0, 1, 2, 3)  # the scored plants: the k-sigma shifts with these sign seeds
MAX_PLANTS = 16  # the most scored plants a study takes
EVAL_EPISODES = 20  # held-out episodes of the env's own samplers, scored next to the suite
MAX_EVAL_EPISODES = 1000
#: reset seeds of the held-out episodes (``HELDOUT_SEED_BASE + i``): above the learner selection's
#: validation episodes (``VALIDATION_SEED_BASE + i``, i < 100), below the suite's seeds
HELDOUT_SEED_BASE = VALIDATION_SEED_BASE + 100_000
TARGET_FRACTION = 0.5  # the study's target: the fine-tuning wins back at least half of the shift's cost


def _check_int(name: str, value, lo: int, hi: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise ValueError(f"{name} must be an integer in [{lo}, {hi}], got {value!r}")


# ---------------------------------------------------------------------------------------- the plant
@dataclass(frozen=True)
class PlantShift:
    """A plant that differs from a fit by ``k`` standard errors per fit parameter.

    Attributes:
        names: fit-parameter names (``wire<j>.<value>`` per wire, shared ModelParams fields).
        fitted: the fitted values (the preset's).
        sigma: per parameter its standard error (an unidentified one: the standard deviation of its
            uniform draw over the bounds).
        offsets: shifted − fitted, per parameter (``±k·sigma``, clipped to the fit bounds).
        k, seed: the size of the shift in standard errors and the seed of its signs.
        layout: the shifted spine (shared params and per-wire values).
        source: the preset file.
        model_error: the parameters the fit holds fixed that this plant sets to other values
            (:func:`check_model_error`), each with its preset value ({ModelParams field: the
            preset's value}; the plant's value is in ``layout.params``); empty: none.
    """

    names: tuple[str, ...]
    fitted: np.ndarray
    sigma: np.ndarray
    offsets: np.ndarray
    k: float
    seed: int
    layout: SpineLayout
    source: str = ""
    model_error: dict = field(default_factory=dict)

    @property
    def shifted(self) -> np.ndarray:
        return self.fitted + self.offsets

    def rows(self) -> list[dict]:
        """One row per parameter: name, fitted, sigma, shifted, offset in sigmas, and ``kind``
        (``fit``: a fit parameter; ``model_error``: a parameter the fit holds fixed, its preset value
        as ``fitted``, no sigma: None)."""
        fit = [
            {
                "parameter": n,
                "kind": "fit",
                "fitted": float(f),
                "sigma": float(s),
                "shifted": float(f + o),
                "offset_sigma": float(o / s) if s > 0 else 0.0,
            }
            for n, f, s, o in zip(self.names, self.fitted, self.sigma, self.offsets, strict=True)
        ]
        errors = [
            {
                "parameter": n,
                "kind": "model_error",
                "fitted": float(fitted),
                "sigma": None,
                "shifted": float(getattr(self.layout.params, n)),
                "offset_sigma": None,
            }
            for n, fitted in self.model_error.items()
        ]
        return fit + errors


def _sigmas(unc: ParameterUncertainty) -> np.ndarray:
    """Standard error per fit parameter; an unidentified one: its uniform draw's (width / √12)."""
    var = np.diag(np.asarray(unc.covariance, dtype=float)).copy()
    ok = np.asarray(unc.identified, dtype=bool)
    out = np.where(ok, np.sqrt(np.clip(np.nan_to_num(var, nan=0.0), 0.0, None)), 0.0)
    out[~ok] = (unc.upper[~ok] - unc.lower[~ok]) / math.sqrt(12.0)
    return out


def fitted_layout(unc: ParameterUncertainty) -> SpineLayout:
    """The fit's spine: the seed module with the preset's params and per-wire values."""
    if not unc.per_wire or unc.wire_values is None:
        raise ValueError(
            f"preset: {unc.source or 'the fit'} has no per-wire values; fit a spatial module "
            "(spine-gym calibrate <spatial CSVs> --layout seed --params wires)"
        )
    return SpineLayout.seed(unc.params).with_wire_values([dict(v) for v in unc.wire_values])


#: ModelParams fields that are the spine's structure, not a value a plant can have wrong
STRUCTURE_FIELDS = ("n_w", "n_seg")


def check_model_error(unc: ParameterUncertainty, model_error) -> dict[str, float]:
    """``model_error`` ({ModelParams field: value}, or (field, value) pairs) validated against the fit:
    every field one the fit holds fixed (not a fit parameter, shared or per wire, not
    :data:`STRUCTURE_FIELDS`), every value finite and within the field's valid range; returns it as
    {field: float}.

    A model error is what a calibration cannot see: a parameter it never fits (e.g. ``a``, the pore
    radius) or a condition that differs where the spine runs (``T_E``, the ambient temperature)."""
    pairs = list(model_error.items() if isinstance(model_error, dict) else model_error)
    fit = {n for n in unc.names if wire_key(n) is None}
    # a per-wire fit value (eps0) overrides the shared field of the same name
    fit |= {wire_key(n)[1] for n in unc.names if wire_key(n) is not None}
    fixed = [f for f in field_names() if f not in fit and f not in STRUCTURE_FIELDS]
    out: dict[str, float] = {}
    for pair in pairs:
        name, value = pair if isinstance(pair, tuple | list) and len(pair) == 2 else (pair, None)
        if name not in fixed or name in out:
            raise ValueError(
                f"model_error: each field once, among the parameters the fit holds fixed {fixed}, "
                f"got {name!r}"
            )
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
            raise ValueError(f"model_error: {name} must be a finite number, got {value!r}")
        out[name] = float(value)
    try:
        unc.params.replace(**out)
    except ValueError as e:
        raise ValueError(f"model_error: {e}") from None
    return out


def shift_plant(unc: ParameterUncertainty, k: float = 3.0, seed: int = 0, model_error=()) -> PlantShift:
    """The fit's plant with every parameter moved by ``k`` standard errors, signs drawn from ``seed``,
    and the parameters of ``model_error`` (:func:`check_model_error`) set to their values.

    The moves are clipped to the fit bounds; a shift that leaves the model's valid range raises
    ValueError (choose a smaller ``k``)."""
    if not (isinstance(k, int | float) and math.isfinite(k) and 0.0 <= k <= 10.0):
        raise ValueError(f"k (the shift in standard errors) must be in [0, 10], got {k!r}")
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    errors = check_model_error(unc, model_error)
    base = fitted_layout(unc)
    sigma = _sigmas(unc)
    signs = np.random.default_rng(int(seed)).choice([-1.0, 1.0], size=len(unc.names))
    offsets = np.clip(k * sigma * signs, unc.lower - unc.values, unc.upper - unc.values)
    try:
        layout = apply_offsets(base, unc.directions, offsets)
    except ValueError as e:
        raise ValueError(f"k: a {k:g}-sigma shift leaves the model's valid range ({e})") from None
    if errors:  # rebuilt from the params: the wire groups take a changed pore radius too
        layout = SpineLayout.seed(layout.params.replace(**errors)).with_wire_values(layout.wire_values)
    return PlantShift(
        names=tuple(unc.names),
        fitted=np.asarray(unc.values, dtype=float),
        sigma=sigma,
        offsets=offsets,
        k=float(k),
        seed=int(seed),
        layout=layout,
        source=unc.source,
        model_error={n: float(getattr(unc.params, n)) for n in errors},
    )


def shift_plants(
    unc: ParameterUncertainty, k: float = 3.0, seeds=SHIFT_SEEDS, model_error=()
) -> dict[str, PlantShift]:
    """The scored plants: one :func:`shift_plant` per sign seed, named ``shift<seed>``, in the order
    given, each with the same ``model_error``.

    The seeds are fixed before anything is scored (never chosen by the size of their cost); they must
    be distinct and differ from the tuning plants' seeds (:data:`TUNING_SHIFT_SEEDS`)."""
    seeds = tuple(seeds)
    ints = all(isinstance(s, int | np.integer) and not isinstance(s, bool) and 0 <= s < 2**31 for s in seeds)
    if not ints or not 1 <= len(seeds) <= MAX_PLANTS or len(set(seeds)) != len(seeds):
        raise ValueError(
            f"shift_seeds must be 1 to {MAX_PLANTS} distinct integers in [0, 2**31 - 1], got {list(seeds)!r}"
        )
    tuning = sorted(set(seeds) & set(TUNING_SHIFT_SEEDS))
    if tuning:
        raise ValueError(
            f"shift_seeds must not include the tuning plants' seeds {list(TUNING_SHIFT_SEEDS)}, got {tuning}"
        )
    return {f"shift{s}": shift_plant(unc, k, s, model_error) for s in seeds}


def write_plant(shift: PlantShift, path: str | Path) -> Path:
    """The shifted plant as a preset file: its params, and its per-wire values and the shift in the
    provenance (``ParameterUncertainty``-free: a plant, not a fit)."""
    provenance = {
        "source": "spine_gym.agents.reality_gap",
        "layout": {"wire_values": shift.layout.wire_values},
        "shift": {
            "preset": shift.source,
            "k": shift.k,
            "seed": shift.seed,
            "model_error": {n: float(getattr(shift.layout.params, n)) for n in shift.model_error},
            "parameters": shift.rows(),
        },
    }
    return shift.layout.params.to_file(path, provenance=provenance)


def plant_env_kwargs(layout: SpineLayout) -> dict:
    """Env kwargs of one fixed plant (no randomisation): its params and per-wire values."""
    return {"params": layout.params, "wire_values": layout.wire_values, "domain_randomization": False}


def nominal_env_kwargs(unc: ParameterUncertainty) -> dict:
    """Env kwargs of the fitted (nominal) plant."""
    return plant_env_kwargs(fitted_layout(unc))


# -------------------------------------------------------------------------------------- the learners
@dataclass(frozen=True)
class Learner:
    """How the pretrained PPO continues on one spine: rollout length, minibatch, epochs, step size,
    clip range, and the value-function warm-up (the first ``vf_warmup_steps`` steps update the value
    function only, the policy frozen: the pretrained value function re-fits to this spine's returns
    before its advantages move the policy).

    One sub-env (a real spine is one), so every update waits for ``n_steps`` control periods."""

    name: str
    n_steps: int = 256
    batch_size: int = 64
    n_epochs: int = 10
    learning_rate: float = 1e-4
    clip_range: float = 0.2
    vf_warmup_steps: int = 0

    def __post_init__(self):
        for key, lo in (("n_steps", 8), ("batch_size", 8), ("n_epochs", 1)):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= 100_000:
                raise ValueError(f"{key} must be an integer in [{lo}, 100000], got {v!r}")
        if self.batch_size > self.n_steps:
            raise ValueError(f"batch_size must be <= n_steps ({self.n_steps}), got {self.batch_size}")
        lr = self.learning_rate
        if not (isinstance(lr, int | float) and 0.0 < lr <= 1e-2):
            raise ValueError(f"learning_rate must be in (0, 0.01], got {lr!r}")
        clip = self.clip_range
        if not (isinstance(clip, int | float) and 0.0 < clip <= 1.0):
            raise ValueError(f"clip_range must be in (0, 1], got {clip!r}")
        _check_int("vf_warmup_steps", self.vf_warmup_steps, 0, STEP_BUDGET_LIMIT)

    def overrides(self) -> dict:
        """The PPO settings (``algo.load`` keyword arguments)."""
        return {k: v for k, v in asdict(self).items() if k not in ("name", "vf_warmup_steps")}


#: the candidates :func:`select_learner` compares (PPO on one spine): the step sizes of the pretraining
#: scale (256-step rollouts, minibatch 64, 10 epochs: 960 gradient steps in 6 000 env steps),
#: and gentler ones (512- or 1 024-step rollouts, 5 epochs, clip range 0.1, a smaller step size or a
#: value-function warm-up)
LEARNERS = {
    "ppo_256_lr3e-4": Learner("ppo_256_lr3e-4", 256, 64, 10, 3e-4),
    "ppo_256_lr1e-4": Learner("ppo_256_lr1e-4", 256, 64, 10, 1e-4),
    "ppo_512_lr1e-4_c0.1": Learner("ppo_512_lr1e-4_c0.1", 512, 128, 5, 1e-4, 0.1),
    "ppo_512_lr3e-5_c0.1": Learner("ppo_512_lr3e-5_c0.1", 512, 128, 5, 3e-5, 0.1),
    "ppo_512_lr1e-4_c0.1_vf1024": Learner("ppo_512_lr1e-4_c0.1_vf1024", 512, 128, 5, 1e-4, 0.1, 1024),
    "ppo_1024_lr1e-4_c0.1": Learner("ppo_1024_lr1e-4_c0.1", 1024, 256, 5, 1e-4, 0.1),
}
#: the learner of the command (chosen by :func:`select_learner` among :data:`LEARNERS` on the tuning
#: plants and seeds; the reality-gap study's ``selection.csv``)
DEFAULT_LEARNER = "ppo_512_lr1e-4_c0.1"


# ------------------------------------------------------------------------------------------ training
def plain_entry(env_id: str) -> str:
    """The ``ppo.yml`` entry the pretraining uses: the ``-v1`` one of the same task (``SmaSpine3DEasy-v2``
    -> ``SmaSpine3DEasy-v1``; the ``-v2`` entries add an energy budget and an integral-of-error
    observation, whose wrappers a fine-tuning on hardware would have to run too)."""
    return env_id.replace("-v2", "-v1")


def _write_run(folder: Path, model, env, meta: dict) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    model.save(folder / "model.zip")
    env.save(str(folder / "vecnormalize.pkl"))
    (folder / "meta.json").write_text(json.dumps(meta, indent=2) + "\n")
    return folder


def pretrain(
    preset: str | Path,
    out: str | Path,
    *,
    env_id: str = DEFAULT_ENV_ID,
    n_timesteps: int = 300_000,
    seed: int = 0,
) -> Path:
    """PPO (the plain entry of ``hyperparams/ppo.yml``, :func:`plain_entry`) on ``env_id`` with domain
    randomisation from the fit ``preset`` for ``n_timesteps``; returns the run folder ``out``."""
    import torch

    torch.set_num_threads(1)
    entry = plain_entry(env_id)
    dr = {"domain_randomization": str(preset)}
    cfg = resolve_config("ppo", entry, n_timesteps=n_timesteps, env_kwargs=dr)
    cfg.env_id = env_id
    envs = build_envs(cfg, seed)
    model = build_model(cfg, envs.env, seed)
    t0, c0 = time.time(), time.process_time()
    model.learn(total_timesteps=cfg.n_timesteps)
    meta = {
        "algo": "ppo",
        "env_id": env_id,
        "env_kwargs": cfg.env_kwargs,
        "hyperparams_entry": entry,
        "seed": seed,
        "n_envs": cfg.n_envs,
        "n_timesteps": cfg.n_timesteps,
        "total_timesteps": int(model.num_timesteps),
        "train_wall_time_s": round(time.time() - t0, 1),
        "train_cpu_time_s": round(time.process_time() - c0, 1),
        **envs.meta,
    }
    folder = _write_run(Path(out), model, envs.env, meta)
    envs.env.close()
    return folder


def finetune_model(pretrained: str | Path, venv, *, learner: Learner, n_timesteps: int, seed: int = 0):
    """The pretrained PPO of the run folder ``pretrained`` trained ``n_timesteps`` more steps on the
    vector env ``venv`` (any ``VecEnv`` with the env id's observation: a simulated plant, or the
    Gymnasium wrapper of a real spine in a ``DummyVecEnv``), with ``learner``'s settings; the
    pretrained ``VecNormalize`` statistics wrap ``venv`` and keep updating. Returns (model, the
    normalised env): ``model.save`` and ``env.save`` write a run folder's files."""
    from stable_baselines3.common.vec_env import VecNormalize

    _check_int("n_timesteps", n_timesteps, 1, STEP_BUDGET_LIMIT)
    pre = Path(pretrained)
    env = VecNormalize.load(str(pre / "vecnormalize.pkl"), venv)
    env.training = True
    if learner.vf_warmup_steps >= n_timesteps:
        raise ValueError(
            f"n_timesteps must exceed the learner's vf_warmup_steps ({learner.vf_warmup_steps}), "
            f"got {n_timesteps}"
        )
    model = algo_class("ppo").load(pre / "model.zip", env=env, device="cpu", **learner.overrides())
    model.set_random_seed(seed)
    warmup = learner.vf_warmup_steps
    if warmup:
        actor = _actor_parameters(model.policy)
        for p in actor:
            p.requires_grad_(False)
        model.learn(total_timesteps=warmup, reset_num_timesteps=False)
        for p in actor:
            p.requires_grad_(True)
    model.learn(total_timesteps=n_timesteps - warmup, reset_num_timesteps=False)
    return model, env


def _actor_parameters(policy) -> list:
    """The parameters of an actor-critic policy that only the action distribution uses (the policy
    network, the action head, the log standard deviation); the value network shares none of them."""
    params = [*policy.mlp_extractor.policy_net.parameters(), *policy.action_net.parameters()]
    return [*params, policy.log_std]


def finetune(
    pretrained: str | Path,
    plant: SpineLayout,
    out: str | Path,
    *,
    learner: Learner,
    n_timesteps: int = 6_000,
    seed: int = 0,
    plant_file: str = "",
) -> Path:
    """:func:`finetune_model` on one simulated spine with the plant ``plant`` (no randomisation);
    writes the run folder ``out`` (``model.zip``, ``vecnormalize.pkl``, ``meta.json``)."""
    import torch

    _check_int("n_timesteps", n_timesteps, 1, STEP_BUDGET_LIMIT)
    torch.set_num_threads(1)
    pre = Path(pretrained)
    pre_meta = json.loads((pre / "meta.json").read_text())
    env_id = pre_meta["env_id"]
    env_kwargs = {**evaluation_env_kwargs(pre_meta.get("env_kwargs", {})), **plant_env_kwargs(plant)}
    venv = make_vec_env(env_id, 1, seed=seed, env_kwargs=env_kwargs)
    t0, c0 = time.time(), time.process_time()
    start = int(pre_meta["total_timesteps"])
    model, env = finetune_model(pre, venv, learner=learner, n_timesteps=n_timesteps, seed=seed)
    meta = {
        "algo": "ppo",
        "env_id": env_id,
        "env_kwargs": {},  # the plant is set by params/wire_values: see "plant"
        "plant": plant_file,
        "fine_tuned_from": str(pre),
        "learner": asdict(learner),
        "seed": seed,
        "n_envs": 1,
        "start_timesteps": start,
        "finetune_timesteps": int(model.num_timesteps) - start,
        "total_timesteps": int(model.num_timesteps),
        "train_wall_time_s": round(time.time() - t0, 1),
        "train_cpu_time_s": round(time.process_time() - c0, 1),
    }
    folder = _write_run(Path(out), model, env, meta)
    env.close()
    return folder


def _validation_rmse(policy_dir: Path, plant: SpineLayout, env_id: str, n_episodes: int) -> float:
    rows = validation_metrics(load_policy(policy_dir), n_episodes, plant_env_kwargs(plant), env_id)
    return float(np.mean([r["rmse_deg"] for r in rows]))


def tuning_plants(
    unc: ParameterUncertainty, k: float, seeds: tuple[int, ...] = TUNING_SHIFT_SEEDS, model_error=()
) -> dict:
    """The plants a learner is chosen on: ``k``-sigma shifts with the seeds ``seeds`` (never the
    scored plant's) and the scored plants' ``model_error``, and the fitted plant itself (a
    fine-tuning must not spoil a plant without a gap); name -> :class:`SpineLayout`."""
    shifted = {f"shift{s}": shift_plant(unc, k, s, model_error).layout for s in seeds}
    return {**shifted, "fitted": fitted_layout(unc)}


def select_learner(
    pretrained: str | Path,
    plants: dict[str, SpineLayout],
    out: str | Path,
    *,
    candidates: dict[str, Learner],
    n_timesteps: int,
    seeds: tuple[int, ...] = TUNING_TRAIN_SEEDS,
    n_episodes: int = 10,
) -> tuple[str, list[dict]]:
    """The candidate with the lowest mean validation RMSE after fine-tuning, over the ``plants``
    (:func:`tuning_plants`) and the training ``seeds``; the validation episodes are the same before
    and after. Returns (name, one row per candidate, plant and seed)."""
    env_id = json.loads((Path(pretrained) / "meta.json").read_text())["env_id"]
    rows = []
    for plant_name, plant in plants.items():
        before = _validation_rmse(Path(pretrained), plant, env_id, n_episodes)
        for name, learner in candidates.items():
            for s in seeds:
                folder = Path(out) / f"{name}_{plant_name}_{s}"
                run = finetune(pretrained, plant, folder, learner=learner, n_timesteps=n_timesteps, seed=s)
                after = _validation_rmse(run, plant, env_id, n_episodes)
                cpu = json.loads((run / "meta.json").read_text())["train_cpu_time_s"]
                rows.append(
                    {
                        "learner": name,
                        "plant": plant_name,
                        "train_seed": s,
                        "rmse_before": before,
                        "rmse_after": after,
                        "change": after - before,
                        "train_cpu_s": cpu,
                    }
                )
    means = {n: np.mean([r["rmse_after"] for r in rows if r["learner"] == n]) for n in candidates}
    return min(means, key=means.get), rows


# ------------------------------------------------------------------------------------------ scoring
FINETUNED = "finetuned@shifted"  # the fine-tuned runs on the shifted plant (their median row)
CONTROL = "finetuned@nominal"  # the control arm: the same fine-tuning on the fitted plant (no shift)


FITTED = "fitted"  # the plant column of the rows on the fitted (nominal) plant
POOLED = "pooled"  # the plant column of the rows averaged over the scored plants
HELDOUT_GROUP = "episodes"  # the group of the held-out episodes in the rows


def score_rows(
    pretrained: str | Path,
    finetuned: dict[str, list[str | Path]],
    unc: ParameterUncertainty,
    shifts: dict[str, PlantShift],
    *,
    control: list[str | Path] = (),
    suite: str = "full",
    n_episodes: int = 0,
    env_id: str | None = None,
) -> tuple[list[dict], list[dict], list[dict]]:
    """Every row on the evaluation set: the ``suite``'s scenarios and ``n_episodes`` held-out episodes
    of the env's own samplers (group ``episodes``, reset seeds ``HELDOUT_SEED_BASE + i``), the same
    for every row, so every difference is paired.

    The rows, each with a ``plant`` column: on the fitted plant (``fitted``) ``pretrained@nominal``
    and ``finetuned@nominal`` (the median over the control runs ``control``; none: no row); per
    shifted plant ``name`` of ``shifts`` ``pretrained@shifted``, ``finetuned@shifted`` (the median
    over the fine-tuned runs ``finetuned[name]``) and ``pid@shifted``; plant ``pooled``: the mean of
    each shifted row over the plants. Means per scenario group and over the whole set (``all``).
    Returns (rows, per-run rows ``<row>#<i>``, per-scenario rows of every controller)."""
    env_id = env_id or json.loads((Path(pretrained) / "meta.json").read_text())["env_id"]
    nominal = nominal_env_kwargs(unc)
    pre = load_policy(pretrained)
    controllers = {  # (plant, row) -> (controller, env kwargs)
        (FITTED, "pretrained@nominal"): (pre, nominal),
        **{(FITTED, f"{CONTROL}#{i}"): (load_policy(f), nominal) for i, f in enumerate(control)},
    }
    for name, shift in shifts.items():
        shifted = plant_env_kwargs(shift.layout)
        controllers[(name, "pretrained@shifted")] = (pre, shifted)
        for i, f in enumerate(finetuned[name]):
            controllers[(name, f"{FINETUNED}#{i}")] = (load_policy(f), shifted)
        controllers[(name, "pid@shifted")] = (controller_for("pid", env_id, shifted), shifted)
    keys = {f"{plant}/{row}": (plant, row) for plant, row in controllers}
    suite_rows, _ = evaluate(
        {k: controllers[pr][0] for k, pr in keys.items()},
        get_suite(suite, env_id=env_id),
        {k: controllers[pr][1] for k, pr in keys.items()},
    )
    rows = []
    for key, (plant, row) in keys.items():
        controller, env_kwargs = controllers[(plant, row)]
        own = [r for r in suite_rows if r["controller"] == key]
        own += _heldout_rows(controller, env_kwargs, env_id, n_episodes)
        rows += [{**r, "controller": row, "plant": plant} for r in own]
    means = _means(rows)
    runs = [m for m in means if "#" in m["controller"]]
    out = [m for m in means if "#" not in m["controller"]]
    def arm_of(m: dict) -> tuple[str, str, str]:
        return m["plant"], m["controller"].split("#")[0], m["group"]

    for plant, arm, group in dict.fromkeys(arm_of(m) for m in runs):
        sel = [m for m in runs if arm_of(m) == (plant, arm, group)]
        median = {c: float(np.median([m[c] for m in sel])) for c in METRIC_COLUMNS}
        row = {"plant": plant, "controller": arm, "group": group, "n_scenarios": sel[0]["n_scenarios"]}
        out.append(row | median)
    out += _pooled_rows(out, list(shifts))
    order, plants = list(ROW_LABELS), [FITTED, *shifts, POOLED]
    groups = [*dict.fromkeys(m["group"] for m in out if m["group"] != "all"), "all"]
    out.sort(key=lambda m: (plants.index(m["plant"]), groups.index(m["group"]), order.index(m["controller"])))
    return out, runs, rows


def _heldout_rows(controller, env_kwargs: dict, env_id: str, n_episodes: int) -> list[dict]:
    """Metrics of ``controller`` on the held-out episodes ``0 … n_episodes − 1`` (group ``episodes``)."""
    if not n_episodes:
        return []
    env = make_env(env_kwargs, env_id=env_id)
    limit, dt = env_temperature_limit(env), float(env.control_period)
    rows = []
    for i in range(n_episodes):
        traj = run_episode(env, controller, seed=HELDOUT_SEED_BASE + i)
        rows.append({"group": HELDOUT_GROUP, "scenario": f"episode_{i}", "kind": "env"}
                    | episode_metrics(traj, temperature_limit=limit, dt=dt))  # fmt: skip
    env.close()
    return rows


def _means(rows: list[dict]) -> list[dict]:
    """Mean of each metric per (plant, controller, group) and per (plant, controller) over all rows."""
    out = []
    for plant, name in dict.fromkeys((r["plant"], r["controller"]) for r in rows):
        own = [r for r in rows if r["plant"] == plant and r["controller"] == name]
        for group in [*dict.fromkeys(r["group"] for r in own), "all"]:
            sel = own if group == "all" else [r for r in own if r["group"] == group]
            out.append({"plant": plant, "controller": name, "group": group, "n_scenarios": len(sel)}
                       | {c: _nanmean([r[c] for r in sel]) for c in METRIC_COLUMNS})  # fmt: skip
    return out


def _nanmean(values) -> float:
    """Mean of the finite values (NaN if none: e.g. a settling time where no scenario settles)."""
    v = np.asarray(values, dtype=float)
    return float(np.mean(v[np.isfinite(v)])) if np.isfinite(v).any() else math.nan


def _pooled_rows(rows: list[dict], plants: list[str]) -> list[dict]:
    """Each shifted row averaged over the ``plants`` (plant ``pooled``)."""
    out = []
    for name, group in dict.fromkeys((m["controller"], m["group"]) for m in rows if m["plant"] in plants):
        sel = [m for m in rows if m["plant"] in plants and m["controller"] == name and m["group"] == group]
        out.append({"plant": POOLED, "controller": name, "group": group, "n_scenarios": sel[0]["n_scenarios"]}
                   | {c: float(np.mean([m[c] for m in sel])) for c in METRIC_COLUMNS})  # fmt: skip
    return out


def recovered_fraction(scores: list[dict], group: str = "all", finetuned: str = FINETUNED) -> float:
    """(RMSE pretrained@shifted − finetuned) / (pretrained@shifted − pretrained@nominal): the share
    of the RMSE the shift cost that the fine-tuning won back (NaN if the shift cost none)."""
    r = {s["controller"]: s["rmse_deg"] for s in scores if s["group"] == group}
    cost = r["pretrained@shifted"] - r["pretrained@nominal"]
    return float((r["pretrained@shifted"] - r[finetuned]) / cost) if cost > 0 else math.nan


def _rmse_matrix(scenario_rows: list[dict], prefix: str) -> np.ndarray:
    """RMSE per (run, scenario) of the runs ``<prefix>#<i>`` (rows: runs in index order)."""
    runs = sorted({r["controller"] for r in scenario_rows if r["controller"].startswith(prefix + "#")},
                  key=lambda n: int(n.rsplit("#", 1)[1]))  # fmt: skip
    return np.array([[float(r["rmse_deg"]) for r in scenario_rows if r["controller"] == n] for n in runs])


def paired_gains(scenario_rows: list[dict], *, n_boot: int = 2000, seed: int = 0) -> dict:
    """Paired before/after differences of suite RMSE [deg] and bootstrap intervals of them.

    Per fine-tuning run ``i``: its gain on the shifted plant, ``pretrained@shifted − finetuned@shifted#i``
    (mean over the suite's scenarios, the same scenarios before and after), and its recovered fraction,
    that gain over the shift's cost ``pretrained@shifted − pretrained@nominal``; per control run, its
    gain on the fitted plant, ``pretrained@nominal − finetuned@nominal#i`` (what the fine-tuning does
    without a shift). The rows: the medians over the runs; ``excess_gain_deg`` = median gain − median
    control gain, ``excess_fraction`` = that over the cost (the share of the cost won back beyond
    what the fine-tuning wins on a plant without a gap).

    Two 95 % intervals (``n_boot`` resamples each): ``<name>_ci95`` resamples the runs of each arm
    (the fine-tuning's spread, the suite fixed, so the fractions keep the suite's cost);
    ``<name>_ci95_scenarios`` resamples the scenarios too (the same draw for every row: the pairing
    kept), in degrees only, and gives the cost's interval (``shift_cost_deg_ci95``)."""
    by: dict[str, list[float]] = {}
    for r in scenario_rows:
        by.setdefault(r["controller"], []).append(float(r["rmse_deg"]))
    pre_n, pre_s = np.asarray(by["pretrained@nominal"]), np.asarray(by["pretrained@shifted"])
    ft, ctrl = _rmse_matrix(scenario_rows, FINETUNED), _rmse_matrix(scenario_rows, CONTROL)

    def degrees(cols, ft_rows, ctrl_rows) -> tuple[float, float, float, float]:
        cost = float(np.mean(pre_s[cols] - pre_n[cols]))
        gain = float(np.median(np.mean(pre_s[cols] - ft[np.ix_(ft_rows, cols)], axis=1)))
        c_gain = math.nan
        if len(ctrl_rows):
            c_gain = float(np.median(np.mean(pre_n[cols] - ctrl[np.ix_(ctrl_rows, cols)], axis=1)))
        return cost, gain, c_gain, gain - c_gain

    m, rng = len(pre_n), np.random.default_rng(seed)

    def draw(n: int) -> np.ndarray:
        return rng.integers(0, n, n) if n else np.arange(0)

    cols = np.arange(m)
    point = degrees(cols, np.arange(len(ft)), np.arange(len(ctrl)))
    runs = np.array([degrees(cols, draw(len(ft)), draw(len(ctrl))) for _ in range(n_boot)])
    both = np.array([degrees(draw(m), draw(len(ft)), draw(len(ctrl))) for _ in range(n_boot)])
    cost = point[0]
    scale = 1.0 / cost if cost > 0 else math.nan  # no cost: nothing to recover
    out = {"n_runs": len(ft), "n_control_runs": len(ctrl), "n_scenarios": m,
           "shift_cost_deg": cost, "shift_cost_deg_ci95": _interval(both[:, 0])}  # fmt: skip
    for j, name in enumerate(("gain_deg", "control_gain_deg", "excess_gain_deg"), start=1):
        out |= {name: point[j], f"{name}_ci95": _interval(runs[:, j]),
                f"{name}_ci95_scenarios": _interval(both[:, j])}  # fmt: skip
    for name, j in (("recovered_fraction", 1), ("excess_fraction", 3)):
        out |= {name: point[j] * scale, f"{name}_ci95": _interval(runs[:, j] * scale),
                f"{name}_ci95_scenarios": _ratio_interval(both[:, j], both[:, 0], cost)}  # fmt: skip
    gains = np.mean(pre_s - ft, axis=1)
    out["gain_deg_per_run"] = [float(g) for g in gains]
    out["recovered_fraction_per_run"] = [float(g * scale) for g in gains]
    out["control_gain_deg_per_run"] = [float(g) for g in np.mean(pre_n - ctrl, axis=1)] if len(ctrl) else []
    return out


def plant_rows(scenario_rows: list[dict], plant: str) -> list[dict]:
    """The per-scenario rows of one shifted ``plant`` and those on the fitted plant (the nominal rows
    and the control arm): what :func:`paired_gains` compares."""
    return [r for r in scenario_rows if r["plant"] in (plant, FITTED)]


def pooled_gains(scenario_rows: list[dict], plants: list[str], *, n_boot: int = 2000, seed: int = 0) -> dict:
    """:func:`paired_gains` pooled over the shifted ``plants`` (the ``plant`` column of the rows).

    The shift's cost and the gain are means over the plants of each plant's cost and median gain over
    its runs; the recovered fraction is the pooled gain over the pooled cost, the control gain the
    median over the control runs. Two 95 % intervals (``n_boot`` resamples): ``<name>_ci95``
    resamples the evaluation episodes (the same draw for every row and plant) and the runs of each
    arm and plant, the plants fixed; ``<name>_ci95_plants`` resamples the plants too (other plants
    at the same ``k``)."""
    pre_n = _rmse_vector(scenario_rows, FITTED, "pretrained@nominal")
    ctrl = _rmse_matrix([r for r in scenario_rows if r["plant"] == FITTED], CONTROL)
    pre_s = [_rmse_vector(scenario_rows, p, "pretrained@shifted") for p in plants]
    ft = [_rmse_matrix([r for r in scenario_rows if r["plant"] == p], FINETUNED) for p in plants]
    m, n_p, rng = len(pre_n), len(plants), np.random.default_rng(seed)

    def stats(cols, ft_rows, ctrl_rows, which) -> np.ndarray:
        cost = np.mean([np.mean(pre_s[p][cols] - pre_n[cols]) for p in which])
        gain = np.mean([_median_gain(pre_s[p][cols], ft[p][np.ix_(ft_rows[p], cols)]) for p in which])
        c_gain = _median_gain(pre_n[cols], ctrl[np.ix_(ctrl_rows, cols)]) if len(ctrl) else math.nan
        return np.array([cost, gain, c_gain, gain - c_gain])

    def draw(n: int) -> np.ndarray:
        return rng.integers(0, n, n) if n else np.arange(0)

    point = stats(np.arange(m), [np.arange(len(f)) for f in ft], np.arange(len(ctrl)), range(n_p))
    boots = {}
    for suffix, plants_drawn in (("", False), ("_plants", True)):
        boots[suffix] = np.array([
            stats(draw(m), [draw(len(f)) for f in ft], draw(len(ctrl)),
                  draw(n_p) if plants_drawn else range(n_p))
            for _ in range(n_boot)
        ])  # fmt: skip
    cost = float(point[0])
    out = {"plants": list(plants), "n_scenarios": m, "n_runs": sum(len(f) for f in ft),
           "n_control_runs": len(ctrl)}  # fmt: skip
    for j, name in enumerate(("shift_cost_deg", "gain_deg", "control_gain_deg", "excess_gain_deg")):
        out[name] = float(point[j])
        for suffix, b in boots.items():
            out[f"{name}_ci95{suffix}"] = _interval(b[:, j])
    for name, j in (("recovered_fraction", 1), ("excess_fraction", 3)):
        out[name] = float(point[j]) / cost if cost > 0 else math.nan
        for suffix, b in boots.items():
            out[f"{name}_ci95{suffix}"] = _ratio_interval(b[:, j], b[:, 0], cost)
    out["verdict"] = target_verdict(out)
    return out


def target_verdict(gains: dict, target: float = TARGET_FRACTION) -> str:
    """Whether the fine-tuning wins back at least ``target`` of the shift's cost, with 95 % confidence
    (the intervals ``shift_cost_deg_ci95`` and ``recovered_fraction_ci95`` of :func:`pooled_gains`):
    ``met`` (the fraction's lower bound ≥ target), ``not met`` (its upper bound < target), or
    ``undecided`` (the interval holds the target, or the cost's interval reaches zero: no cost
    established to recover)."""
    if not 0.0 < target <= 1.0:
        raise ValueError(f"target must be in (0, 1], got {target!r}")
    if not gains["shift_cost_deg_ci95"][0] > 0:
        return "undecided (the shift's cost is not distinguishable from zero)"
    lo, hi = gains["recovered_fraction_ci95"]
    if lo >= target:
        return "met"
    if hi < target:
        return "not met"
    return "undecided"


def _rmse_vector(scenario_rows: list[dict], plant: str, controller: str) -> np.ndarray:
    """RMSE per scenario of one controller on one plant."""
    own = (r for r in scenario_rows if r["plant"] == plant and r["controller"] == controller)
    return np.array([float(r["rmse_deg"]) for r in own])


def _median_gain(before: np.ndarray, after: np.ndarray) -> float:
    """The median over runs (rows of ``after``) of the mean over scenarios of ``before − after``."""
    return float(np.median(np.mean(before - after, axis=1)))


def _ratio_interval(num: np.ndarray, den: np.ndarray, point_den: float) -> list[float]:
    """The 95 % interval of resampled ratios ``num / den`` (the cost resampled with the gain); NaN if
    the point cost is not positive (nothing to recover). A resample whose cost is not positive has no
    fraction: it counts as −inf when its gain is ≤ 0 or the cost < 0, else +inf, so the interval
    widens rather than drops it."""
    if not point_den > 0:
        return [math.nan, math.nan]
    with np.errstate(divide="ignore", invalid="ignore"):
        undefined = np.where((num > 0) & (den == 0), np.inf, -np.inf)
        ratio = np.where(den > 0, num / np.where(den > 0, den, 1.0), undefined)
    return _interval(ratio)


def _interval(values: np.ndarray) -> list[float]:
    """The central 95 % of bootstrap values (NaN if any is NaN)."""
    if np.isnan(values).any():
        return [math.nan, math.nan]
    return [float(v) for v in np.quantile(values, [0.025, 0.975], method="inverted_cdf")]


# -------------------------------------------------------------------------------------------- study
@dataclass(frozen=True)
class StudyConfig:
    """The settings of :func:`run_study` (validated on construction, before any work).

    Attributes:
        preset: a spatial fit preset (per-wire values and a covariance).
        out: the output folder.
        env_id: a ``SmaSpine3D*`` id (one four-wire module).
        pretrain_steps: PPO steps of the pretraining (0: reuse ``pretrained``).
        pretrained: an existing pretrained run folder (with ``pretrain_steps`` 0).
        finetune_steps: the fine-tuning budget [env steps] (one spine: × the control period of hardware).
        finetune_seeds: fine-tuning runs per arm (training seeds ``seed`` … ``seed + n − 1``): on each
            shifted plant (its ``finetuned@shifted`` row is their median) and, the control arm, on the
            fitted plant (``finetuned@nominal``).
        k, shift_seeds: the shift of the "real" plants in standard errors, and the seeds of their
            signs (one plant each, :func:`shift_plants`).
        model_error: (field, value) pairs of parameters the fit holds fixed, set to ``value`` on
            every shifted plant (:func:`check_model_error`); empty: the fit's uncertainty only.
        learners: candidate names of :data:`LEARNERS` (one: no selection; several: chosen by
            :func:`select_learner` on :func:`tuning_plants`).
        selection_episodes: validation episodes per tuning plant in the selection.
        suite: the evaluation suite (``full`` or ``quick``).
        eval_episodes: held-out episodes of the env's own samplers scored next to the suite.
        seed: the training seed.
    """

    preset: str
    out: str
    env_id: str = DEFAULT_ENV_ID
    pretrain_steps: int = 300_000
    pretrained: str = ""
    finetune_steps: int = 6_000
    finetune_seeds: int = 4
    k: float = 3.0
    shift_seeds: tuple[int, ...] = SHIFT_SEEDS
    model_error: tuple[tuple[str, float], ...] = ()
    learners: tuple[str, ...] = (DEFAULT_LEARNER,)
    selection_episodes: int = 10
    suite: str = "full"
    eval_episodes: int = EVAL_EPISODES
    seed: int = 0
    command: str = field(default="", compare=False)

    def __post_init__(self):
        if ENV_SPECS.get(self.env_id) is None or not self.env_id.startswith("SmaSpine3D"):
            ids = sorted(i for i in ENV_SPECS if i.startswith("SmaSpine3D"))
            raise ValueError(f"env_id must be a four-wire module id, one of {ids}, got {self.env_id!r}")
        _check_int("pretrain_steps", self.pretrain_steps, 0, 10_000_000)
        _check_int("finetune_steps", self.finetune_steps, 1, STEP_BUDGET_LIMIT)
        _check_int("finetune_seeds", self.finetune_seeds, 1, 100)
        _check_int("eval_episodes", self.eval_episodes, 0, MAX_EVAL_EPISODES)
        _check_int("seed", self.seed, 0, 2**31 - 1)
        _check_int("selection_episodes", self.selection_episodes, 1, 100)
        if (self.pretrain_steps == 0) == (not self.pretrained):
            raise ValueError(
                "pretrained: give a pretrained run folder with pretrain_steps 0, "
                "or pretrain_steps > 0 without one"
            )
        if self.pretrained and not (Path(self.pretrained) / "model.zip").exists():
            raise ValueError(f"pretrained must be a run folder with model.zip, got {self.pretrained!r}")
        bad = [n for n in self.learners if n not in LEARNERS]
        if not self.learners or bad:
            raise ValueError(f"learners must be among {sorted(LEARNERS)}, got {list(self.learners)!r}")
        if self.suite not in ("full", "quick"):
            raise ValueError(f"suite must be 'full' or 'quick', got {self.suite!r}")
        unc = ParameterUncertainty.from_file(self.preset)
        config_of(self.env_id, domain_randomization=unc)  # the preset fits the env's module
        # k, the seeds, the model error and the shifts within the model's range
        shift_plants(unc, self.k, self.shift_seeds, self.model_error)


def _write_csv(path: Path, rows: list[dict]) -> None:
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow(csv_row(r))


def run_study(cfg: StudyConfig, *, progress: bool = False) -> dict:
    """Pretrain (or reuse), shift, select the learner, fine-tune, score; files into ``cfg.out``.
    Returns a summary: the pooled gains and recovered fraction with their intervals and the target's
    verdict (:func:`pooled_gains`), per plant :func:`paired_gains` (``per_plant``), the chosen learner,
    the folders."""
    out = Path(cfg.out)
    out.mkdir(parents=True, exist_ok=True)
    say = print if progress else (lambda *a, **k: None)
    unc = ParameterUncertainty.from_file(cfg.preset)
    shifts = shift_plants(unc, cfg.k, cfg.shift_seeds, cfg.model_error)
    plant_files = {name: str(write_plant(sh, out / f"real_plant_{name}.json")) for name, sh in shifts.items()}
    _write_csv(out / "plant.csv", [{"plant": name} | r for name, sh in shifts.items() for r in sh.rows()])
    pre = Path(cfg.pretrained) if cfg.pretrained else out / "pretrained"
    if cfg.pretrain_steps:
        say(
            f"pretraining PPO on {cfg.env_id} with domain randomisation from {cfg.preset} "
            f"({cfg.pretrain_steps} steps)"
        )
        pretrain(cfg.preset, pre, env_id=cfg.env_id, n_timesteps=cfg.pretrain_steps, seed=cfg.seed)
    candidates = {n: LEARNERS[n] for n in cfg.learners}
    chosen, sel_rows = cfg.learners[0], []
    if len(candidates) > 1:
        plants = tuning_plants(unc, cfg.k, model_error=cfg.model_error)
        say(f"choosing the learner among {list(candidates)} on the tuning plants {list(plants)}")
        chosen, sel_rows = select_learner(
            pre, plants, out / "selection", candidates=candidates,
            n_timesteps=cfg.finetune_steps, n_episodes=cfg.selection_episodes,
        )  # fmt: skip
        _write_csv(out / "selection.csv", sel_rows)
    seeds = range(cfg.seed, cfg.seed + cfg.finetune_seeds)
    learner = LEARNERS[chosen]
    say(f"fine-tuning with {chosen} on the shifted plants {list(shifts)} ({cfg.finetune_steps} steps, "
        f"training seeds {list(seeds)}), and on the fitted plant (the control arm)")  # fmt: skip

    def arm(folder: str, layout: SpineLayout, plant_file: str) -> list[Path]:
        return [
            finetune(pre, layout, out / f"{folder}_{s}", learner=learner,
                     n_timesteps=cfg.finetune_steps, seed=s, plant_file=plant_file)  # fmt: skip
            for s in seeds
        ]

    control = arm("control", fitted_layout(unc), cfg.preset)
    finetuned = {name: arm(f"finetuned_{name}", sh.layout, plant_files[name]) for name, sh in shifts.items()}
    say(f"scoring on the {cfg.suite} suite and {cfg.eval_episodes} held-out episodes")
    scores, runs, scenario_rows = score_rows(
        pre, finetuned, unc, shifts, control=control, suite=cfg.suite,
        n_episodes=cfg.eval_episodes, env_id=cfg.env_id,
    )  # fmt: skip
    _write_csv(out / "scores.csv", scores)
    columns = ("plant", "controller", "group", "scenario", *SCORE_COLUMNS)
    _write_csv(out / "scenarios.csv", [{k: r[k] for k in columns} for r in scenario_rows])
    per_plant = {name: paired_gains(plant_rows(scenario_rows, name), seed=cfg.seed) for name in shifts}
    for r in runs:
        gains = per_plant.get(r["plant"])
        shifted_all = gains and r["group"] == "all" and r["controller"].startswith(FINETUNED + "#")
        r["recovered_fraction"] = (
            gains["recovered_fraction_per_run"][int(r["controller"].rsplit("#", 1)[1])] if shifted_all else ""
        )
    _write_csv(out / "finetune_seeds.csv", runs)
    summary = {
        **pooled_gains(scenario_rows, list(shifts), seed=cfg.seed),
        "target_fraction": TARGET_FRACTION,
        "per_plant": per_plant,
        "learner": chosen,
        "k": cfg.k,
        "shift_seeds": list(cfg.shift_seeds),
        "model_error": dict(cfg.model_error),
        "suite": cfg.suite,
        "eval_episodes": cfg.eval_episodes,
        "finetune_steps": cfg.finetune_steps,
        "finetune_seeds": list(seeds),
        "hardware_minutes": cfg.finetune_steps * float(config_of(cfg.env_id).control_period) / 60.0,
        "pretrained": str(pre),
        "finetuned": {name: [str(f) for f in folders] for name, folders in finetuned.items()},
        "control": [str(f) for f in control],
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    (out / "command.txt").write_text(cfg.command + "\n")
    error = "".join(f", {n} = {v:g}" for n, v in cfg.model_error)
    title = (
        f"{cfg.env_id}: {len(shifts)} plants shifted by {cfg.k:g} sigma{error}, "
        f"{cfg.finetune_steps} fine-tuning steps, {cfg.finetune_seeds} seeds per arm"
    )
    plot_scores(scores, summary, out / "reality_gap.png", title=title, runs=runs)
    return summary


ROW_LABELS = {
    "pretrained@nominal": "pretrained,\nnominal plant",
    "pretrained@shifted": "pretrained,\nshifted plant",
    "finetuned@shifted": "fine-tuned,\nshifted plant",
    "finetuned@nominal": "fine-tuned,\nnominal plant\n(control)",
    "pid@shifted": "PID,\nshifted plant",
}


FRACTION_SHOWN = 10.0  # the recovered-fraction panel draws fractions and intervals within +-10 (+-1000 %)


def _shown(fraction_pct: float) -> float:
    """A recovered fraction [%] as drawn: clipped to the panel's +-1000 %."""
    return float(np.clip(fraction_pct, -100.0 * FRACTION_SHOWN, 100.0 * FRACTION_SHOWN))


def _error_bar(fraction_pct: float, lo: float, hi: float) -> list[list[float]]:
    """Matplotlib's [[below], [above]] for a fraction [%] and its interval (fractions, maybe infinite or
    NaN), both clipped to the panel; never negative, also when the point lies outside its clipped
    interval (a fraction beyond +-1000 %) or the interval is unknown (drawn as none)."""
    f = _shown(fraction_pct)
    lo_pct, hi_pct = (100.0 * float(np.clip(c, -FRACTION_SHOWN, FRACTION_SHOWN)) for c in (lo, hi))
    below, above = np.nan_to_num([f - lo_pct, hi_pct - f], nan=0.0)
    return [[max(float(below), 0.0)], [max(float(above), 0.0)]]


def plot_scores(
    scores: list[dict], summary: dict, path: str | Path, title: str = "", runs: list[dict] | None = None
) -> Path:
    """Two panels. Left: the evaluation set's mean RMSE [deg] per shifted plant and pooled, bars of
    the pretrained policy, the fine-tuned one (the median of its runs, each run a black dot) and the
    PID on that plant, with the pretrained policy and the control arm on the fitted plant as lines.
    Right: the recovered fraction [%] per plant and pooled with its 95 % interval (episodes and runs
    resampled) and the target."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    every = [s for s in scores if s["group"] == "all"]
    plants = [*summary["per_plant"], POOLED]
    rmse = {(s["plant"], s["controller"]): s["rmse_deg"] for s in every}
    bars = (("pretrained@shifted", "#d62728"), (FINETUNED, "#2ca02c"), ("pid@shifted", "#1f77b4"))
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(6.0 + 1.6 * len(plants), 4.6),
                                  gridspec_kw={"width_ratios": [3, 2]})  # fmt: skip
    width = 0.26
    for j, (row, color) in enumerate(bars):
        xs = np.arange(len(plants)) + (j - 1) * width
        vals = [rmse[(p, row)] for p in plants]
        ax.bar(xs, vals, width, color=color, label=ROW_LABELS[row].replace("\n", " "))
        for x, v in zip(xs, vals, strict=True):
            ax.annotate(f"{v:.2f}", (x, v), ha="center", va="bottom", fontsize=7)
    for i, p in enumerate(plants[:-1]):
        own = [r["rmse_deg"] for r in runs or [] if r["plant"] == p and r["group"] == "all"
               and r["controller"].startswith(FINETUNED + "#")]  # fmt: skip
        ax.plot([i] * len(own), own, "k.", ms=3, label="fine-tuning runs (seeds)" if i == 0 else None)
    for row, style in (("pretrained@nominal", "--"), (CONTROL, ":")):
        if (FITTED, row) in rmse:
            label = ROW_LABELS[row].replace("\n", " ")
            ax.axhline(rmse[(FITTED, row)], color="#555555", ls=style, lw=1.2, label=label)
    lo = min(v for v in rmse.values()) * 0.9
    ax.set_ylim(lo, max(v for v in rmse.values()) * 1.12)  # room for the legend above the bars
    ax.set_xticks(range(len(plants)), plants)
    ax.set_ylabel("tracking RMSE, mean over the evaluation set [deg]")
    ax.legend(fontsize=7, loc="upper left", ncol=3)
    gains = [summary["per_plant"][p] for p in plants[:-1]] + [summary]
    frac = [100.0 * g["recovered_fraction"] for g in gains]
    # both resample the episodes and the runs: paired_gains' "_scenarios" interval, pooled_gains' own
    ci = [g["recovered_fraction_ci95_scenarios"] for g in gains[:-1]] + [summary["recovered_fraction_ci95"]]
    for i, (f, (c_lo, c_hi)) in enumerate(zip(frac, ci, strict=True)):
        color = "#2ca02c" if i < len(plants) - 1 else "#000000"
        if np.isfinite(f):
            ax2.errorbar([i], [_shown(f)], yerr=_error_bar(f, c_lo, c_hi), fmt="o", color=color, capsize=4)
        else:
            ax2.annotate("no cost", (i, 0.0), ha="center", fontsize=7)
    ax2.axhline(100.0 * summary.get("target_fraction", TARGET_FRACTION), color="#d62728", ls="--", lw=1,
                label="target")  # fmt: skip
    ax2.axhline(0.0, color="#555555", lw=0.8)
    ax2.set_xticks(range(len(plants)), plants)
    ax2.set_ylabel("share of the shift's cost won back [%]")
    ax2.set_ylim(-150, 250)
    ax2.legend(fontsize=7, loc="upper right")
    ax2.set_title("recovered fraction, 95 % CI (episodes, runs)", fontsize=9)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)
