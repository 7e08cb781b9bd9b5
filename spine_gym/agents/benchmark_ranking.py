"""The benchmark table's constrained ranking: wire temperature as a constraint, as in Safety-Gymnasium.

Per env id, the methods whose time over the temperature limit per episode is at most
:data:`~spine_gym.agents.metrics.TIME_OVER_LIMIT_CAP_S` (an algorithm: the IQM over its seeds of
the final validation value; a reference controller: the mean over its validation episodes) are
ranked by their tracking RMSE IQM, with the energy next to it; the others are listed apart with
their violation; a method whose time over the limit was not recorded is listed apart as such,
never ranked. Each row carries its actuator envelope (``v_max``, the voltage of action +1 on a
full-length wire; the plant's thermal cut-off; who cuts a hot wire: the plant, the controller or
nothing) and its budget (env steps × seeds of an algorithm, tuning trials × episodes of a tuned
controller).

* :func:`cap_status`, :func:`constrained_split` — the constraint on summary rows
  (:func:`spine_gym.agents.benchmark_stats.summary_rows`);
* :func:`with_envelope` — the envelope and budget columns (:func:`envelope`, :func:`tuning_budget`);
* :func:`report_markdown` — the table's Markdown: the constrained ranking first, then the training
  cost and the runs (:func:`spine_gym.agents.benchmark_stats.training_markdown`).
"""

from __future__ import annotations

import math

from spine_gym.controllers.registry import get_spec, guard_temperature, tuned_record
from spine_gym.envs import base_id

from . import benchmark_stats as stats
from .metrics import TIME_OVER_LIMIT_CAP_S
from .runtime import env_temperature_limit, env_thermal_cutoff, envelope_of, make_env

RANKED, OVER_CAP, NOT_RECORDED = "ranked", "over the cap", "not recorded"
T_OVER = "time_over_limit_s"  # the constrained metric (a key of benchmark_stats.METRICS)


def cap_status(row: dict) -> str:
    """:data:`RANKED` if the row's time over the limit (IQM) is at most the cap, :data:`OVER_CAP` if
    above it, :data:`NOT_RECORDED` if it or the RMSE is missing or not finite."""
    t, rmse = row.get(f"{T_OVER}_iqm"), row.get("rmse_iqm")
    if any(x is None or not math.isfinite(x) for x in (t, rmse)):
        return NOT_RECORDED
    return RANKED if t <= TIME_OVER_LIMIT_CAP_S else OVER_CAP


def constrained_split(summary: list[dict], env_id: str) -> dict[str, list[dict]]:
    """The rows of ``env_id`` by :func:`cap_status`: the ranked ones by RMSE IQM (best first), those
    over the cap by their violation (smallest first), the unrecorded ones in table order."""
    rows = [r for r in summary if r["env_id"] == env_id]
    out = {s: [r for r in rows if cap_status(r) == s] for s in (RANKED, OVER_CAP, NOT_RECORDED)}
    out[RANKED].sort(key=lambda r: r["rmse_iqm"])
    out[OVER_CAP].sort(key=lambda r: r[f"{T_OVER}_iqm"])
    return out


# --------------------------------------------------------------------------- envelope, budget
def envelope(env_id: str, env_kwargs: dict, guard: bool) -> dict:
    """The actuator envelope of a method on ``env_id`` with ``env_kwargs``
    (:func:`~spine_gym.agents.runtime.envelope_of`): ``v_max_V`` (the env's ``v_max``),
    ``cutoff_K`` (the plant's thermal cut-off, the ``-v2`` ids; ``None``: none) and ``guard``
    (``"plant 418 K"``: the env's driver cuts every controller's wires; ``"controller 418 K"``: a
    guarded registry controller (``guard``) cuts a wire observed at
    :func:`~spine_gym.controllers.registry.guard_temperature`; ``"none"``: nothing cuts it)."""
    env = make_env(env_kwargs, env_id=env_id)
    own = guard_temperature(guard, env_temperature_limit(env), env_thermal_cutoff(env))
    out = envelope_of(env, own)
    env.close()
    return out


def tuning_budget(env_id: str, name: str) -> str:
    """The tuning budget of the registered controller ``name`` on ``env_id`` as stored with the tuned
    settings it runs on (:func:`~spine_gym.controllers.registry.tuned_record`: the id's own re-tune
    where it has one, else its family's), ``<trials> trials × <episodes> episodes (<tuning env id>)``,
    or why there is none."""
    if not get_spec(name, env_id).tuned:
        return "not tuned"
    entry = tuned_record(env_id, name)
    if not entry or "n_trials" not in entry:
        return "defaults (not tuned)"
    tuned_on = entry.get("env_id", base_id(env_id))
    return f"{entry['n_trials']} trials × {entry['n_episodes']} episodes ({tuned_on})"


def with_envelope(summary: list[dict], env_kwargs: dict[str, dict]) -> list[dict]:
    """The summary rows with ``v_max_V``, ``cutoff_K``, ``guard`` and ``budget``: an algorithm is
    validated in the env with ``env_kwargs[env_id]`` and no guard of its own (its policy has none), a
    reference controller in the same env with its registry entry's guard, except where the plant
    cuts hot wires itself (a ``thermal_cutoff``): there every method meets the plant's."""
    envelopes, out = {}, []
    for r in summary:
        rl = r["kind"] == "rl"
        guard = False if rl else get_spec(r["method"], r["env_id"]).guard
        key = (r["env_id"], guard)
        if key not in envelopes:
            envelopes[key] = envelope(r["env_id"], env_kwargs.get(r["env_id"], {}), guard)
        if rl:
            budget = f"{r['steps']:,} steps × {r['n_seeds']} seeds"
        else:
            budget = tuning_budget(r["env_id"], r["method"])
        out.append({**r, **envelopes[key], "budget": budget})
    return out


# --------------------------------------------------------------------------- Markdown
def _name(row: dict) -> str:
    if row["kind"] == "rl":
        return row["method"]
    n = row["n_episodes"]
    return f"{row['method']} (reference, {n} episode{'s' * (n != 1)})"


def _envelope_cells(row: dict) -> list[str]:
    v = row.get("v_max_V")
    return [stats.fmt(v, "{:g}"), row.get("guard", stats.DASH), row.get("budget", stats.DASH)]


def _metric_cells(row: dict) -> list[str]:
    return [
        stats.interval_cell(row, "rmse", "{:.2f}"),
        stats.interval_cell(row, "energy_J", "{:.0f}"),
        stats.interval_cell(row, T_OVER, "{:.1f}"),
    ]


def constrained_markdown(summary: list[dict], units: dict[str, str]) -> str:
    """Per env id: the methods within the cap ranked by RMSE IQM [95 % CI] with energy and time over
    the limit next to it, then those over the cap (by violation) and those without a record of it,
    each with its envelope and budget."""
    pct = round(100 * stats.CONFIDENCE)
    cap = f"{TIME_OVER_LIMIT_CAP_S:g} s"
    lines = []
    for env_id in dict.fromkeys(r["env_id"] for r in summary):
        unit = units.get(env_id, "deg")
        head = [f"RMSE [{unit}] IQM [{pct} % CI]", f"energy [J] IQM [{pct} % CI]"]
        head += [f"T>limit [s] IQM [{pct} % CI]", "v_max [V]", "guard", "budget"]
        split = constrained_split(summary, env_id)
        lines += [f"### {env_id}", ""]
        ranked = [
            [str(k + 1), _name(r), *_metric_cells(r), *_envelope_cells(r)] for k, r in enumerate(split[RANKED])
        ]
        lines += [f"Ranked: at most {cap} over the temperature limit per episode, by RMSE IQM.", ""]
        lines += [*stats.md_table(["rank", "method", *head], ranked), ""] if ranked else ["(none)", ""]
        if split[OVER_CAP]:
            over = [[_name(r), *_metric_cells(r), *_envelope_cells(r)] for r in split[OVER_CAP]]
            lines += [f"Not ranked: more than {cap} over the temperature limit per episode.", ""]
            lines += [*stats.md_table(["method", *head], over), ""]
        if split[NOT_RECORDED]:
            names = ", ".join(_name(r) for r in split[NOT_RECORDED])
            lines += [f"Not ranked: time over the temperature limit (or RMSE) not recorded: {names}.", ""]
    return "\n".join(lines)


def report_markdown(summary: list[dict], runs: list[dict], units: dict[str, str]) -> str:
    """The benchmark table as Markdown: the constrained ranking, then the training cost and the runs."""
    cap = f"{TIME_OVER_LIMIT_CAP_S:g} s"
    return "\n".join(
        [
            f"## Constrained ranking (at most {cap} per episode over the temperature limit)",
            "",
            constrained_markdown(summary, units),
            "## Training cost",
            "",
            stats.training_markdown(summary, runs, units),
        ]
    )
