"""Fine-tuning across the reality gap: pretrain on a calibration's uncertainty, fine-tune on a plant
that differs, score both on the evaluation suite (the library behind ``spine-gym finetune``).

The steps, each a function:

* :func:`shift_plant` — the "real" plant: the fitted preset (shared parameters and per-wire values)
  with every fit parameter moved by ``k`` of its standard errors (default 3 σ), the sign of each
  move drawn from ``seed`` (:class:`PlantShift`; an unidentified parameter moves by ``k`` × the
  standard deviation of its uniform draw). :func:`write_plant` saves it as a preset file.
* :func:`pretrain` — PPO on the env id with ``domain_randomization=<preset>`` (every episode a
  plant drawn from the fit's covariance, per-wire values included), the plain ``-v1`` entry of
  ``hyperparams/ppo.yml`` (:func:`plain_entry`: no energy budget, no observation wrappers).
* :func:`finetune` — the pretrained policy trained on the shifted plant for a step budget
  (:class:`Learner`: one spine, as on hardware, PPO with short rollouts; the policy, its value
  function and its observation statistics continue from the pretrained run).
* :func:`select_learner` — the learner chosen among candidates on *tuning* shifts (other seeds than
  the evaluated plant's) by the mean validation RMSE, never on the evaluation suite.
* :func:`score_rows` — the before/after rows on the suite: the pretrained policy on the nominal
  (fitted) plant and on the shifted plant, the fine-tuned policy and the tuned PID on the shifted
  plant; :func:`recovered_fraction` — how much of the RMSE the shift cost the fine-tuning won back.
* :func:`run_study` — all of it into one folder (``scores.csv``, ``plant.csv``, ``selection.csv``,
  ``reality_gap.png``, ``command.txt``, the policies).

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
from spine_gym.layout import SpineLayout
from spine_gym.uncertainty import ParameterUncertainty, apply_offsets

from .evaluation import evaluate, summarize
from .metrics import METRIC_COLUMNS
from .runtime import controller_for, evaluation_env_kwargs, load_policy, validation_metrics
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
    """

    names: tuple[str, ...]
    fitted: np.ndarray
    sigma: np.ndarray
    offsets: np.ndarray
    k: float
    seed: int
    layout: SpineLayout
    source: str = ""

    @property
    def shifted(self) -> np.ndarray:
        return self.fitted + self.offsets

    def rows(self) -> list[dict]:
        """One row per parameter: name, fitted, sigma, shifted, offset in sigmas."""
        return [
            {
                "parameter": n,
                "fitted": float(f),
                "sigma": float(s),
                "shifted": float(f + o),
                "offset_sigma": float(o / s) if s > 0 else 0.0,
            }
            for n, f, s, o in zip(self.names, self.fitted, self.sigma, self.offsets, strict=True)
        ]


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


def shift_plant(unc: ParameterUncertainty, k: float = 3.0, seed: int = 0) -> PlantShift:
    """The fit's plant with every parameter moved by ``k`` standard errors, signs drawn from ``seed``.

    The moves are clipped to the fit bounds; a shift that leaves the model's valid range raises
    ValueError (choose a smaller ``k``)."""
    if not (isinstance(k, int | float) and math.isfinite(k) and 0.0 <= k <= 10.0):
        raise ValueError(f"k (the shift in standard errors) must be in [0, 10], got {k!r}")
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    base = fitted_layout(unc)
    sigma = _sigmas(unc)
    signs = np.random.default_rng(int(seed)).choice([-1.0, 1.0], size=len(unc.names))
    offsets = np.clip(k * sigma * signs, unc.lower - unc.values, unc.upper - unc.values)
    try:
        layout = apply_offsets(base, unc.directions, offsets)
    except ValueError as e:
        raise ValueError(f"k: a {k:g}-sigma shift leaves the model's valid range ({e})") from None
    return PlantShift(
        names=tuple(unc.names),
        fitted=np.asarray(unc.values, dtype=float),
        sigma=sigma,
        offsets=offsets,
        k=float(k),
        seed=int(seed),
        layout=layout,
        source=unc.source,
    )


def write_plant(shift: PlantShift, path: str | Path) -> Path:
    """The shifted plant as a preset file: its params, and its per-wire values and the shift in the
    provenance (``ParameterUncertainty``-free: a plant, not a fit)."""
    provenance = {
        "source": "spine_gym.agents.reality_gap",
        "layout": {"wire_values": shift.layout.wire_values},
        "shift": {"preset": shift.source, "k": shift.k, "seed": shift.seed, "parameters": shift.rows()},
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


def tuning_plants(unc: ParameterUncertainty, k: float, seeds: tuple[int, ...] = TUNING_SHIFT_SEEDS) -> dict:
    """The plants a learner is chosen on: ``k``-sigma shifts with the seeds ``seeds`` (never the
    scored plant's) and the fitted plant itself (a fine-tuning must not spoil a plant without a gap);
    name -> :class:`SpineLayout`."""
    return {**{f"shift{s}": shift_plant(unc, k, s).layout for s in seeds}, "fitted": fitted_layout(unc)}


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


def score_rows(
    pretrained: str | Path,
    finetuned: list[str | Path],
    unc: ParameterUncertainty,
    shift: PlantShift,
    *,
    control: list[str | Path] = (),
    suite: str = "full",
    env_id: str | None = None,
) -> tuple[list[dict], list[dict], list[dict]]:
    """Mean suite metrics per (row, scenario group) and over the whole suite (group ``all``) of
    ``pretrained@nominal``, ``pretrained@shifted``, ``finetuned@shifted`` (the median over the
    fine-tuned runs ``finetuned``, one per training seed), ``finetuned@nominal`` (the median over the
    control runs ``control``, fine-tuned on the fitted plant; none: no row) and ``pid@shifted``.
    Returns (rows, per-run rows ``<row>#<i>``, per-scenario rows of every controller)."""
    env_id = env_id or json.loads((Path(pretrained) / "meta.json").read_text())["env_id"]
    nominal, shifted = nominal_env_kwargs(unc), plant_env_kwargs(shift.layout)
    pre = load_policy(pretrained)
    controllers = {
        "pretrained@nominal": (pre, nominal),
        "pretrained@shifted": (pre, shifted),
        **{f"{FINETUNED}#{i}": (load_policy(f), shifted) for i, f in enumerate(finetuned)},
        **{f"{CONTROL}#{i}": (load_policy(f), nominal) for i, f in enumerate(control)},
        "pid@shifted": (controller_for("pid", env_id, shifted), shifted),
    }
    scenarios = get_suite(suite, env_id=env_id)
    rows, _ = evaluate(
        {n: c for n, (c, _) in controllers.items()}, scenarios, {n: kw for n, (_, kw) in controllers.items()}
    )
    means = summarize(rows)
    for name in controllers:
        sel = [r for r in rows if r["controller"] == name]
        means.append(
            {"controller": name, "group": "all", "n_scenarios": len(sel)}
            | {c: float(np.mean([r[c] for r in sel])) for c in METRIC_COLUMNS}
        )
    runs = [m for m in means if "#" in m["controller"]]
    out = [m for m in means if "#" not in m["controller"]]
    for arm in (FINETUNED, CONTROL):
        arm_runs = [m for m in runs if m["controller"].startswith(arm + "#")]
        for group in dict.fromkeys(m["group"] for m in arm_runs):
            sel = [m for m in arm_runs if m["group"] == group]
            median = {c: float(np.median([m[c] for m in sel])) for c in METRIC_COLUMNS}
            out.append({"controller": arm, "group": group, "n_scenarios": sel[0]["n_scenarios"]} | median)
    order = list(ROW_LABELS)
    out.sort(key=lambda m: (m["group"] == "all", m["group"], order.index(m["controller"])))
    return out, runs, rows


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
        out |= {name: point[j] * scale, f"{name}_ci95": _interval(runs[:, j] * scale)}
    gains = np.mean(pre_s - ft, axis=1)
    out["gain_deg_per_run"] = [float(g) for g in gains]
    out["recovered_fraction_per_run"] = [float(g * scale) for g in gains]
    out["control_gain_deg_per_run"] = [float(g) for g in np.mean(pre_n - ctrl, axis=1)] if len(ctrl) else []
    return out


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
        finetune_seeds: fine-tuning runs per arm (training seeds ``seed`` … ``seed + n − 1``): on the
            shifted plant (the ``finetuned@shifted`` row is their median) and, the control arm, on the
            fitted plant (``finetuned@nominal``).
        k, shift_seed: the shift of the "real" plant in standard errors, and the seed of its signs.
        learners: candidate names of :data:`LEARNERS` (one: no selection; several: chosen by
            :func:`select_learner` on :func:`tuning_plants`).
        selection_episodes: validation episodes per tuning plant in the selection.
        suite: the evaluation suite (``full`` or ``quick``).
        seed: the training seed.
    """

    preset: str
    out: str
    env_id: str = DEFAULT_ENV_ID
    pretrain_steps: int = 300_000
    pretrained: str = ""
    finetune_steps: int = 6_000
    finetune_seeds: int = 8
    k: float = 3.0
    shift_seed: int = 0
    learners: tuple[str, ...] = (DEFAULT_LEARNER,)
    selection_episodes: int = 10
    suite: str = "full"
    seed: int = 0
    command: str = field(default="", compare=False)

    def __post_init__(self):
        if ENV_SPECS.get(self.env_id) is None or not self.env_id.startswith("SmaSpine3D"):
            ids = sorted(i for i in ENV_SPECS if i.startswith("SmaSpine3D"))
            raise ValueError(f"env_id must be a four-wire module id, one of {ids}, got {self.env_id!r}")
        _check_int("pretrain_steps", self.pretrain_steps, 0, 10_000_000)
        _check_int("finetune_steps", self.finetune_steps, 1, STEP_BUDGET_LIMIT)
        _check_int("finetune_seeds", self.finetune_seeds, 1, 100)
        _check_int("shift_seed", self.shift_seed, 0, 2**31 - 1)
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
        shift_plant(unc, self.k, self.shift_seed)  # k and the shift within the model's range


def _write_csv(path: Path, rows: list[dict]) -> None:
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow(csv_row(r))


def run_study(cfg: StudyConfig, *, progress: bool = False) -> dict:
    """Pretrain (or reuse), shift, select the learner, fine-tune, score; files into ``cfg.out``.
    Returns a summary (the recovered fraction, the chosen learner, the folders)."""
    out = Path(cfg.out)
    out.mkdir(parents=True, exist_ok=True)
    say = print if progress else (lambda *a, **k: None)
    unc = ParameterUncertainty.from_file(cfg.preset)
    shift = shift_plant(unc, cfg.k, cfg.shift_seed)
    plant_file = write_plant(shift, out / "real_plant.json")
    _write_csv(out / "plant.csv", shift.rows())
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
        plants = tuning_plants(unc, cfg.k)
        say(f"choosing the learner among {list(candidates)} on the tuning plants {list(plants)}")
        chosen, sel_rows = select_learner(
            pre, plants, out / "selection", candidates=candidates,
            n_timesteps=cfg.finetune_steps, n_episodes=cfg.selection_episodes,
        )  # fmt: skip
        _write_csv(out / "selection.csv", sel_rows)
    seeds = range(cfg.seed, cfg.seed + cfg.finetune_seeds)
    learner = LEARNERS[chosen]
    say(f"fine-tuning with {chosen} on the shifted plant (seed {cfg.shift_seed}, {cfg.finetune_steps} steps, "
        f"training seeds {list(seeds)}), and on the fitted plant (the control arm)")  # fmt: skip
    arms = {}
    plants = (("finetuned", shift.layout, str(plant_file)), ("control", fitted_layout(unc), cfg.preset))
    for arm, layout, plant in plants:
        arms[arm] = [
            finetune(
                pre, layout, out / f"{arm}_{s}", learner=learner,
                n_timesteps=cfg.finetune_steps, seed=s, plant_file=plant,
            )  # fmt: skip
            for s in seeds
        ]
    say(f"scoring on the {cfg.suite} suite")
    scores, runs, scenario_rows = score_rows(
        pre, arms["finetuned"], unc, shift, control=arms["control"], suite=cfg.suite, env_id=cfg.env_id
    )
    _write_csv(out / "scores.csv", scores)
    columns = ("controller", "group", "scenario", *SCORE_COLUMNS)
    _write_csv(out / "scenarios.csv", [{k: r[k] for k in columns} for r in scenario_rows])
    for r in runs:
        shifted_all = r["group"] == "all" and r["controller"].startswith(FINETUNED + "#")
        fraction = recovered_fraction(scores + runs, "all", r["controller"]) if shifted_all else ""
        r["recovered_fraction"] = fraction
    _write_csv(out / "finetune_seeds.csv", runs)
    paired = paired_gains(scenario_rows, seed=cfg.seed)
    summary = {
        "recovered_fraction": recovered_fraction(scores),
        **paired,
        "learner": chosen,
        "finetune_steps": cfg.finetune_steps,
        "finetune_seeds": list(seeds),
        "hardware_minutes": cfg.finetune_steps * float(config_of(cfg.env_id).control_period) / 60.0,
        "pretrained": str(pre),
        "finetuned": [str(f) for f in arms["finetuned"]],
        "control": [str(f) for f in arms["control"]],
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    (out / "command.txt").write_text(cfg.command + "\n")
    title = f"{cfg.env_id}: {cfg.k:g}-sigma shift, {cfg.finetune_steps} fine-tuning steps"
    plot_scores(scores, out / "reality_gap.png", title=title, runs=runs)
    return summary


ROW_LABELS = {
    "pretrained@nominal": "pretrained,\nnominal plant",
    "pretrained@shifted": "pretrained,\nshifted plant",
    "finetuned@shifted": "fine-tuned,\nshifted plant",
    "finetuned@nominal": "fine-tuned,\nnominal plant\n(control)",
    "pid@shifted": "PID,\nshifted plant",
}


def plot_scores(
    scores: list[dict], path: str | Path, title: str = "", runs: list[dict] | None = None
) -> Path:
    """Bars of the suite's mean RMSE [deg], energy [J] and time over the limit [s] per row (a
    fine-tuned bar: the median of its runs, each run a black dot)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [s for s in scores if s["group"] == "all"]
    labels = [ROW_LABELS.get(r["controller"], r["controller"]) for r in rows]
    palette = {"pretrained@nominal": "#7f7f7f", "pretrained@shifted": "#d62728", FINETUNED: "#2ca02c",
               CONTROL: "#98df8a", "pid@shifted": "#1f77b4"}  # fmt: skip
    colors = [palette.get(r["controller"], "#bcbd22") for r in rows]
    names = [r["controller"] for r in rows]
    panels = (("rmse_deg", "tracking RMSE [deg]"), ("energy_J", "energy per episode [J]"),
              ("time_over_limit_s", "time over the temperature limit [s]"))  # fmt: skip
    fig, axes = plt.subplots(1, 3, figsize=(4.0 + 2.2 * len(rows), 4.4))
    for ax, (key, ylabel) in zip(axes, panels, strict=True):
        vals = [r[key] for r in rows]
        ax.bar(range(len(rows)), vals, color=colors)
        ax.set_xticks(range(len(rows)), labels, fontsize=8)
        ax.set_ylabel(ylabel)
        for i, v in enumerate(vals):
            ax.annotate(f"{v:.3g}", (i, v), ha="center", va="bottom", fontsize=8)
        if max(vals) == 0.0:
            ax.set_ylim(0.0, 1.0)  # e.g. no time over the limit at all: a readable empty axis
        for arm in (FINETUNED, CONTROL):
            own = [r for r in runs or [] if r["group"] == "all" and r["controller"].split("#")[0] == arm]
            seeds = [r[key] for r in own]
            if seeds and arm in names:
                label = "fine-tuning runs (seeds)" if arm == FINETUNED else None
                ax.plot([names.index(arm)] * len(seeds), seeds, "k.", label=label)
        if runs and FINETUNED in names:
            ax.legend(fontsize=7, loc="lower right")
    fig.suptitle(title + " (means over the evaluation suite)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)
