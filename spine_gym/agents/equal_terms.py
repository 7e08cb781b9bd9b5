"""The equal-terms comparison that ``spine-gym evaluate`` prints first.

Controllers are compared only with controllers that ran in the same actuator envelope (``v_max``,
the voltage of action +1 on a full-length wire): a model trained at another ceiling gets its own
block, in which the baselines were re-run at its ceiling, and is never ranked against baselines
held to another.
In each block and scenario group, as in Safety-Gymnasium, the methods at most
:data:`~spine_gym.agents.metrics.TIME_OVER_LIMIT_CAP_S` per episode over the temperature limit (the
mean over the group's scenarios, one episode each) are ranked by tracking RMSE, with the energy
next to it, both also as multiples of the tuned PID's in the same block; the others are shown apart
with their violation. Every row names who cuts a hot wire (the ``guard`` column of the evaluation's
rows, :func:`spine_gym.agents.runtime.envelope_of`: the plant's cut-off on the ``-v2`` ids, the
controller's own guard, or none).

* :func:`comparison_rows` — the rows from :func:`spine_gym.agents.evaluation.summarize`'s summary
  and each controller's :class:`Entry`;
* :func:`format_comparison` — the rows as plain text (the constrained ranking first per block).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .metrics import TIME_OVER_LIMIT_CAP_S

__all__ = ["REFERENCE", "Entry", "envelope_suffix", "comparison_rows", "format_comparison"]

#: the baseline the energy and RMSE multiples refer to (the tuned PID of the same envelope)
REFERENCE = "pid"
RANKED, OVER_CAP, NOT_RECORDED = "ranked", "over the cap", "not recorded"


@dataclass(frozen=True)
class Entry:
    """What the comparison needs to know of one evaluated controller besides its summary row.

    Attributes:
        method: its name in the table (a re-run baseline keeps its registry name, e.g. ``pid``).
        baseline: a registered controller (else a saved model).
    """

    method: str
    baseline: bool


def envelope_suffix(v_max: float) -> str:
    """The name suffix of a baseline re-run at ceiling ``v_max`` (``pid@6V``)."""
    return f"@{v_max:g}V"


def _status(row: dict) -> str:
    t, rmse = row.get("time_over_limit_s"), row.get("rmse_deg")
    if any(x is None or not math.isfinite(x) for x in (t, rmse)):
        return NOT_RECORDED
    return RANKED if t <= TIME_OVER_LIMIT_CAP_S else OVER_CAP


def _ratio(x: float, ref: dict | None, key: str) -> float:
    if ref is None or not ref[key]:
        return math.nan
    return x / ref[key]


def comparison_rows(summary: list[dict], entries: dict[str, Entry], reference: str = REFERENCE) -> list[dict]:
    """One row per (envelope, scenario group, controller) of ``summary`` (rows with ``controller``,
    ``group``, ``rmse_deg``, ``energy_J``, ``time_over_limit_s`` and the envelope ``v_max_V``,
    ``guard``): the metrics, the RMSE and energy as multiples of ``reference``'s in the same
    envelope and group (NaN without it), the envelope and the cap status. Ordered by envelope (the
    first row's first), group, then status (ranked by RMSE, those over the cap by their violation,
    the unrecorded ones), so a block's constrained ranking comes first.

    Raises:
        ValueError: a summary controller without an entry, or a row without its envelope.
    """
    missing = sorted({s["controller"] for s in summary} - set(entries))
    if missing:
        raise ValueError(f"entries: no entry for controller(s) {missing}")
    bare = sorted({s["controller"] for s in summary if "v_max_V" not in s or "guard" not in s})
    if bare:
        raise ValueError(f"summary: no envelope (v_max_V, guard) in the rows of {bare}")
    blocks = list(dict.fromkeys(float(s["v_max_V"]) for s in summary))
    groups = list(dict.fromkeys(s["group"] for s in summary))
    out = []
    for v_max in blocks:
        for group in groups:
            sel = [s for s in summary if s["group"] == group and float(s["v_max_V"]) == v_max]
            ref = next((s for s in sel if entries[s["controller"]].baseline
                        and entries[s["controller"]].method == reference), None)  # fmt: skip
            rows = []
            for s in sel:
                e = entries[s["controller"]]
                rows.append({
                    "v_max_V": v_max, "group": group, "method": e.method, "controller": s["controller"],
                    "kind": "baseline" if e.baseline else "model", "guard": s["guard"],
                    "rmse_deg": s["rmse_deg"], "rmse_ratio": _ratio(s["rmse_deg"], ref, "rmse_deg"),
                    "energy_J": s["energy_J"], "energy_ratio": _ratio(s["energy_J"], ref, "energy_J"),
                    "time_over_limit_s": s["time_over_limit_s"], "status": _status(s),
                })  # fmt: skip
            order = {RANKED: 0, OVER_CAP: 1, NOT_RECORDED: 2}
            rows.sort(key=lambda r: (order[r["status"]], _sort_value(r)))
            rank = 0
            for r in rows:
                rank += r["status"] == RANKED
                r["rank"] = rank if r["status"] == RANKED else None
            out += rows
    return out


def _sort_value(row: dict) -> float:
    if row["status"] == RANKED:
        return row["rmse_deg"]
    return row["time_over_limit_s"] if row["status"] == OVER_CAP else 0.0


def _num(x: float, spec: str) -> str:
    return "—" if x is None or not math.isfinite(x) else spec.format(x)


def _table(rows: list[dict], ranked: bool, unit: str) -> list[str]:
    head = (["rank"] if ranked else []) + [
        "method", f"RMSE [{unit}]", "× PID", "energy [J]", "× PID", "T>limit [s/episode]", "guard",
    ]  # fmt: skip
    body = [
        ([str(r["rank"])] if ranked else [])
        + [r["method"], _num(r["rmse_deg"], "{:.2f}"), _num(r["rmse_ratio"], "{:.2f}")]
        + [_num(r["energy_J"], "{:.0f}"), _num(r["energy_ratio"], "{:.2f}")]
        + [_num(r["time_over_limit_s"], "{:.1f}"), r["guard"]]
        for r in rows
    ]
    w = [max(len(h), *(len(b[i]) for b in body)) for i, h in enumerate(head)]
    first = 1 if ranked else 0  # left-aligned: rank's neighbour (the method) and the guard

    def line(cells):
        return "    " + "  ".join(
            c.ljust(w[i]) if i in (first, len(cells) - 1) else c.rjust(w[i]) for i, c in enumerate(cells)
        ).rstrip()

    return [line(head), *map(line, body)]


def format_comparison(rows: list[dict], error_unit: str = "deg", default_v_max: float | None = None) -> str:
    """:func:`comparison_rows` as plain text: per envelope and scenario group the constrained
    ranking, then the methods over the cap with their violation and those without a record of it.
    ``default_v_max``: the env's own ceiling (a block at another one says its baselines were re-run
    there)."""
    cap = f"{TIME_OVER_LIMIT_CAP_S:g} s"
    lines = [
        "equal-terms comparison: each controller only against those run in the same actuator envelope "
        f"(mean per scenario of each group; ranked: at most {cap} per episode over the temperature limit, "
        "by RMSE; × PID: of the tuned PID in the same envelope)",
    ]
    for v_max in dict.fromkeys(r["v_max_V"] for r in rows):
        whose = ""
        if default_v_max is not None and v_max != default_v_max:
            whose = " (a model's own ceiling; the baselines re-run at it, named @" + f"{v_max:g}V)"
        for group in dict.fromkeys(r["group"] for r in rows if r["v_max_V"] == v_max):
            sel = [r for r in rows if r["v_max_V"] == v_max and r["group"] == group]
            lines.append(f"  envelope v_max {v_max:g} V{whose}, group {group}")
            ranked = [r for r in sel if r["status"] == RANKED]
            lines += _table(ranked, True, error_unit) if ranked else ["    ranked: none"]
            over = [r for r in sel if r["status"] == OVER_CAP]
            if over:
                lines.append(f"    not ranked, more than {cap} per episode over the temperature limit:")
                lines += _table(over, False, error_unit)
            unrecorded = ", ".join(r["method"] for r in sel if r["status"] == NOT_RECORDED)
            if unrecorded:
                lines.append(f"    not ranked, RMSE or time over the limit not recorded: {unrecorded}")
    return "\n".join(lines) + "\n"
