"""The evaluate command's job: its options, the checks of its arguments and the run that writes its
outputs (the command line :mod:`spine_gym.agents.evaluate` and :mod:`spine_gym.agents.family_comparison`
use it; the evaluation itself is :mod:`spine_gym.agents.evaluation`)."""

from __future__ import annotations

import argparse
import shutil
import time
from pathlib import Path

import torch

from spine_gym import cli_conventions as cli
from spine_gym.controllers.registry import BASELINES, REGISTRY, baselines_for, registry_for
from spine_gym.envs import base_id, config_of

from . import equal_terms
from .evaluation import (
    ERROR_UNIT,
    evaluate,
    format_relative,
    format_tables,
    plot_controller,
    relative_rows,
    shipped_policies,
    summarize,
    write_csv,
    write_trajectories,
)
from .policy_files import check_policy_env, policy_meta, trained_env_id
from .runtime import (
    build_controller,
    evaluation_env_kwargs,
    load_policy,
    make_env,
    policy_env_kwargs,
    run_episode,
)
from .scenarios import SUITES, Scenario, get_suite
from .video import require_ffmpeg, write_videos
from .zoo_config import DEFAULT_ENV_ID

MPC_CONTROLLERS = tuple(name for name, spec in REGISTRY.items() if spec.plans_on_env)
#: the evaluate command's name as ``python -m <module>``
PROG = cli.module_prog("spine_gym.agents.evaluate")


def add_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """The evaluate command's options, added to ``p``."""
    cli.add_env(
        p, help=f"environment id (default: the env of the one model of --models, else {DEFAULT_ENV_ID}), "
        "one of: " + ", ".join(cli.ENV_IDS),
    )  # fmt: skip
    cli.add_env_kwargs(
        p, help="env keyword arguments key=value of every controller's envs (over a policy's own)"
    )
    p.add_argument(
        "--baselines",
        nargs="*",
        default=None,
        help=f"registered controllers to run (default for the planar ids: {' '.join(BASELINES)}; "
        f"all: {' '.join(REGISTRY)}; other envs: their registry)",
    )
    p.add_argument(
        "--mpc",
        action="store_true",
        help=f"also run {' and '.join(MPC_CONTROLLERS)} (MPPI, on every env id: ~0.1 s per step, "
        "~15-30 min per mode on a full suite)",
    )
    p.add_argument(
        "--models",
        nargs="*",
        default=None,
        metavar="NAME=PATH",
        help="saved models NAME=PATH (PATH: a run folder, shipped folder or .zip); default: every policy in "
        "spine_gym/agents/policies/ trained on --env",
    )
    p.add_argument(
        "--suite", default="full", choices=sorted(SUITES), help="scenario suite (default: %(default)s)"
    )
    p.add_argument("--groups", nargs="*", default=None, help="only these scenario groups")
    p.add_argument("--scenarios", nargs="*", default=None, help="only these scenario names")
    cli.add_out(p, default="results/eval", help="output folder (an earlier evaluation's outputs there are replaced)")
    cli.add_progress(p)
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    p.add_argument("--no-trajectories", action="store_true", help="skip the per-step CSVs")
    p.add_argument("--plain", action="store_true", help="plain-text tables (no rich)")
    p.add_argument(
        "--relative-to",
        default=None,
        metavar="NAME",
        help="also print RMSE/energy ratios and T>limit differences to this controller (e.g. mpc_estimated)",
    )
    p.add_argument("--video", action="store_true", help="also write videos/<controller>/<scenario>.mp4")
    p.add_argument("--video-speed", type=float, default=1.0, help="video playback speed (default: real time)")
    return p


def models_of(items: list[str] | None, env_id: str) -> dict[str, Path]:
    """``--models`` as {name: path} (None: the shipped policies of ``env_id``); ValueError if a path
    does not exist."""
    if items is None:
        return shipped_policies(env_id)
    models = {}
    for item in items:
        name, sep, path = item.partition("=")
        if not sep and not Path(item).exists():
            raise ValueError(f"--models takes NAME=PATH (e.g. mine=logs/ppo/SmaSpine-v2_1), got {item!r}")
        if not sep:
            name, path = Path(item).stem if Path(item).suffix else Path(item).name, item
        cli.check_file(path, f"--models {name}")
        models[name] = Path(path)
    return models


def env_of(args) -> str:
    """``--env``, else the trained env of the one model of ``--models`` (ValueError if it is not
    a registered id), else :data:`DEFAULT_ENV_ID`."""
    if args.env:
        return args.env
    if args.models and len(args.models) == 1:
        path = args.models[0].partition("=")[2] or args.models[0]
        if Path(path).exists():
            trained = trained_env_id(path)
            if trained is not None and trained not in cli.ENV_IDS:
                raise ValueError(f"--models: {path} was trained on {trained}, not a registered id; pass --env")
            return trained or DEFAULT_ENV_ID
    return DEFAULT_ENV_ID


#: the env settings that make the actuator envelope (what the actuators may do), the same for every
#: controller of one comparison: a policy and the baselines it is ranked against share them
ENVELOPE_KWARGS = ("v_max",)


def check_envelope(name: str, own: dict, given: dict) -> None:
    """ValueError (one line) if ``given`` (``--env-kwargs``) sets an envelope setting that the model
    ``name`` was trained with at another value: the model keeps its own
    (:func:`~spine_gym.agents.runtime.policy_env_kwargs`) while the baselines would take the given
    one, an unequal comparison."""
    kept = evaluation_env_kwargs(own)
    for key in ENVELOPE_KWARGS:
        if key in given and key in kept and float(given[key]) != float(kept[key]):
            raise ValueError(
                f"--env-kwargs {key}={given[key]} differs from model {name}'s own {key}={kept[key]}, "
                f"which it keeps: pass {key}={kept[key]} to run every controller at it, or leave {key} out"
            )


def plan(args) -> tuple[list[Scenario], list[str], dict[str, Path]]:
    """(scenarios, baselines, models) of the arguments, every one checked (ValueError, one line)
    before anything is built or written."""
    args.env = env_of(args)
    cli.check_out_dir(args.out)
    scenarios = get_suite(args.suite, groups=args.groups, names=args.scenarios, env_id=args.env)
    chosen = list(baselines_for(args.env)) if args.baselines is None else args.baselines
    baselines = list(dict.fromkeys(chosen + (list(MPC_CONTROLLERS) if args.mpc else [])))
    cli.check_keys(baselines, registry_for(args.env), "--baselines", what=f"controller of {args.env}")
    models = models_of(args.models, args.env)
    if args.models:
        for name, path in models.items():
            check_policy_env(path, args.env, f"--models {name}")
            check_envelope(name, policy_meta(path).get("env_kwargs") or {}, args.env_kwargs)
    if not baselines and not models:
        raise ValueError("nothing to evaluate: no baselines and no models")
    names = [*baselines, *models]
    if args.relative_to and args.relative_to not in names:
        hint = cli.did_you_mean(args.relative_to, names)
        raise ValueError(f"--relative-to {args.relative_to!r} is not one of {names}{hint}")
    cli.check_env_kwargs(args.env, args.env_kwargs)
    if args.video:
        require_ffmpeg()  # before the evaluation, not after it
    return scenarios, baselines, models


def _v_max(env_id: str, env_kwargs: dict) -> float:
    """[V] The ``v_max`` of an env of ``env_id`` made with ``env_kwargs`` (the voltage of action +1 on a
    full-length wire)."""
    return float(config_of(env_id, **env_kwargs).v_max)


def _build_baselines(env_id: str, baselines: list[str], kwargs: dict, suffix: str = "") -> dict:
    probe = make_env(kwargs, env_id=env_id)
    try:
        return {f"{b}{suffix}": build_controller(b, probe) for b in baselines}
    finally:
        probe.close()


def controllers_of(
    args, baselines: list[str], models: dict[str, Path]
) -> tuple[dict, dict, float, dict[str, equal_terms.Entry]]:
    """(controllers, their env kwargs, the env's temperature limit [K], their
    :class:`~spine_gym.agents.equal_terms.Entry`).

    A model that runs at another voltage ceiling than the baselines' (its own ``v_max``) gets the
    baselines again at its ceiling, named with :func:`~spine_gym.agents.equal_terms.envelope_suffix`
    (``pid@6V``), so that it is compared with baselines in its own envelope."""
    controllers = _build_baselines(args.env, baselines, args.env_kwargs)
    env_kwargs = {b: dict(args.env_kwargs) for b in baselines}
    entries = {b: equal_terms.Entry(b, True) for b in baselines}
    limit = float(config_of(args.env, **args.env_kwargs).temperature_limit)
    if models:
        torch.set_num_threads(1)
    for name, path in models.items():
        pol = load_policy(path, name=name)
        controllers[name] = pol
        env_kwargs[name] = policy_env_kwargs(pol.env_kwargs, args.env_kwargs)
        entries[name] = equal_terms.Entry(name, False)
    own = _v_max(args.env, args.env_kwargs)
    for v_max in dict.fromkeys(_v_max(args.env, env_kwargs[m]) for m in models):
        if baselines and v_max != own:
            kw = {**args.env_kwargs, "v_max": v_max}
            suffix = equal_terms.envelope_suffix(v_max)
            controllers |= _build_baselines(args.env, baselines, kw, suffix)
            env_kwargs |= {f"{b}{suffix}": dict(kw) for b in baselines}
            entries |= {f"{b}{suffix}": equal_terms.Entry(b, True) for b in baselines}
    return controllers, env_kwargs, limit, entries


#: what an evaluation writes into --out (removed before a new one writes there)
OUTPUTS = ("metrics.csv", "summary.csv", "relative.csv", "equal_terms.csv", "trajectories", "plots", "videos")


def remove_outputs(out: Path) -> None:
    """Remove an earlier evaluation's :data:`OUTPUTS` from ``out`` (nothing else)."""
    for name in OUTPUTS:
        path = out / name
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        elif path.exists() or path.is_symlink():
            path.unlink()



def run(args, planned: tuple[list[Scenario], list[str], dict[str, Path]], t_start: float | None = None) -> int:
    """Evaluate the ``planned`` (scenarios, baselines, models) of :func:`plan`, print the tables and
    write the outputs to ``args.out``; exit status 0. ``t_start``: when the command started."""
    t_start = time.perf_counter() if t_start is None else t_start
    scenarios, baselines, models = planned
    controllers, env_kwargs, limit, entries = controllers_of(args, baselines, models)
    print(f"evaluating {list(controllers)} on suite '{args.suite}' ({len(scenarios)} scenarios)", flush=True)
    rows, trajs = evaluate(controllers, scenarios, env_kwargs, progress=args.progress)
    summary = summarize(rows)
    print()
    unit = ERROR_UNIT.get(base_id(args.env), "deg")
    comparison = equal_terms.comparison_rows(summary, entries)
    default_v_max = _v_max(args.env, args.env_kwargs)
    print(equal_terms.format_comparison(comparison, unit, default_v_max))
    print(format_tables(summary, use_rich=not args.plain, error_unit=unit))
    out = Path(args.out)
    remove_outputs(out)
    write_csv(out / "equal_terms.csv", comparison)
    if args.relative_to:
        rel = relative_rows(summary, args.relative_to)
        print(format_relative(rel, args.relative_to))
        write_csv(out / "relative.csv", rel)
    write_csv(out / "metrics.csv", rows)
    write_csv(out / "summary.csv", summary)
    if not args.no_trajectories:
        write_trajectories(out, trajs)
    if not args.no_plots:
        groups = list(dict.fromkeys(s.group for s in scenarios))
        for ctrl in controllers:
            for g in groups:
                scs = [s for s in scenarios if s.group == g]
                plot_controller(out / "plots" / f"{ctrl}_{g}.png", ctrl, g, scs, trajs, limit)
    if args.video:
        videos = write_videos(
            controllers, scenarios, out / "videos", env_kwargs,
            make_env=lambda kw: make_env(kw, env_id=args.env), run_episode=run_episode,
            speed=args.video_speed,
        )  # fmt: skip
        print(f"wrote {len(videos)} videos to {out / 'videos'}")
    wrote = "metrics.csv, summary.csv" + ("" if args.no_plots else ", plots/")
    print(f"wrote {wrote} to {out} in {time.perf_counter() - t_start:.1f} s total")
    return 0
