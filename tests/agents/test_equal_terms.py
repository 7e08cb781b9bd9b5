"""spine_gym.agents.equal_terms: the equal-terms comparison of ``spine-gym evaluate`` on synthetic
summaries (one block per voltage ceiling, the cap on the time over the limit, the multiples of the
PID of the same envelope), the rows' own guard column, and the baselines re-run at a
model's own ceiling."""

from __future__ import annotations

import math

import numpy as np
import pytest
from repo import ROOT

from spine_gym.agents import equal_terms as et
from spine_gym.agents import evaluation_job as job
from spine_gym.agents.evaluate import build_parser
from spine_gym.agents.metrics import TIME_OVER_LIMIT_CAP_S

ECO_POLICY = ROOT / "spine_gym" / "agents" / "policies" / "ppo_3d_v1_eco"  # SmaSpine3D-v1 at a 6-V ceiling
GUARD = "controller 418 K"


def _s(controller: str, rmse: float, energy: float, over: float, group: str = "nominal", v_max=5.0) -> dict:
    """A summary row; a baseline (``pid``, ``step``, ``pid@6V``) with its own guard, a model without."""
    guard = GUARD if controller.split("@")[0] in ("pid", "step") else "none"
    return {"controller": controller, "group": group, "rmse_deg": rmse, "energy_J": energy,
            "time_over_limit_s": over, "v_max_V": v_max, "cutoff_K": None, "guard": guard}  # fmt: skip


def _entries(*names: str) -> dict[str, et.Entry]:
    """Entries of controllers named ``<baseline>`` or ``<baseline>@<V>V`` (baselines) and others (models)."""
    out = {}
    for name in names:
        base = name.split("@")[0]
        baseline = base in ("pid", "step")
        out[name] = et.Entry(base if baseline else name, baseline)
    return out


def test_a_model_at_another_ceiling_is_compared_only_with_the_baselines_rerun_there():
    summary = [_s("pid", 8.0, 500, 0.0), _s("pid@6V", 6.0, 520, 0.0, v_max=6.0),
               _s("eco", 5.0, 480, 0.0, v_max=6.0), _s("mine", 7.0, 510, 0.0)]  # fmt: skip
    rows = et.comparison_rows(summary, _entries("pid", "pid@6V", "eco", "mine"))
    five = [r for r in rows if r["v_max_V"] == 5.0]
    six = [r for r in rows if r["v_max_V"] == 6.0]
    assert [r["controller"] for r in five] == ["mine", "pid"]  # ranked by RMSE within the block
    assert [r["controller"] for r in six] == ["eco", "pid@6V"]
    eco = six[0]
    assert eco["rank"] == 1 and eco["rmse_ratio"] == pytest.approx(5.0 / 6.0)  # the 6-V PID's, not 5.0 / 8.0
    assert eco["energy_ratio"] == pytest.approx(480 / 520)
    assert six[1]["method"] == "pid" and six[1]["rmse_ratio"] == 1.0
    text = et.format_comparison(rows, "deg", default_v_max=5.0)
    head5, head6 = text.index("envelope v_max 5 V, group nominal"), text.index("envelope v_max 6 V (a model")
    assert head5 < head6 and "eco" not in text[head5:head6] and "mine" not in text[head6:]


def test_a_method_over_the_cap_is_shown_apart_with_its_violation_never_ranked():
    cap = TIME_OVER_LIMIT_CAP_S
    summary = [_s("pid", 4.0, 200, 0.0), _s("hot", 2.0, 300, 19.0), _s("edge", 3.0, 250, cap),
               _s("warm", 1.0, 260, cap + 0.1)]  # fmt: skip
    rows = et.comparison_rows(summary, _entries("pid", "hot", "edge", "warm"))
    order = [(r["controller"], r["rank"]) for r in rows]
    assert order == [("edge", 1), ("pid", 2), ("warm", None), ("hot", None)]
    assert [r["status"] for r in rows] == [et.RANKED, et.RANKED, et.OVER_CAP, et.OVER_CAP]
    text = et.format_comparison(rows)
    ranked, apart = text.split("not ranked, more than 0.5 s per episode over the temperature limit:")
    assert "hot" not in ranked and "warm" not in ranked
    hot = next(line for line in apart.splitlines() if line.split()[:1] == ["hot"])
    # RMSE, × PID, energy, × PID, T>limit
    assert hot.split()[1:6] == ["2.00", "0.50", "300", "1.50", "19.0"]


def test_a_missing_time_over_the_limit_is_listed_apart_and_each_group_has_its_own_ranking():
    summary = [_s("pid", 4.0, 200, 0.0), _s("x", 1.0, 100, math.nan),
               _s("pid", 6.0, 300, 0.0, "hard"), _s("x", 5.0, 280, 0.0, "hard")]  # fmt: skip
    rows = et.comparison_rows(summary, _entries("pid", "x"))
    nominal = [r for r in rows if r["group"] == "nominal"]
    assert [(r["controller"], r["status"]) for r in nominal] == [("pid", et.RANKED), ("x", et.NOT_RECORDED)]
    assert [r["controller"] for r in rows if r["group"] == "hard"] == ["x", "pid"]
    assert "not recorded: x" in et.format_comparison(rows)


def test_without_a_pid_in_the_envelope_the_multiples_are_not_made_up():
    rows = et.comparison_rows([_s("step", 9.0, 100, 0.0), _s("m", 3.0, 90, 0.0)], _entries("step", "m"))
    assert all(math.isnan(r["rmse_ratio"]) and math.isnan(r["energy_ratio"]) for r in rows)
    assert " — " in et.format_comparison(rows)
    with pytest.raises(ValueError, match="no entry for controller"):
        et.comparison_rows([_s("ghost", 1.0, 1.0, 0.0)], {})
    bare = {k: v for k, v in _s("m", 1.0, 1.0, 0.0).items() if k != "guard"}
    with pytest.raises(ValueError, match="no envelope"):
        et.comparison_rows([bare], _entries("m"))


def test_the_guard_column_is_the_rows_own():
    plant = {"guard": "plant 418 K", "cutoff_K": 418.0}
    summary = [{**_s("pid", 4.0, 200, 0.0), **plant}, {**_s("m", 3.0, 190, 0.0), **plant}]
    rows = et.comparison_rows(summary, _entries("pid", "m"))
    assert [r["guard"] for r in rows] == ["plant 418 K"] * 2  # a -v2 plant: the same protection for both
    assert et.format_comparison(rows).count("plant 418 K") == 2


def test_evaluate_reruns_the_baselines_at_a_models_own_ceiling():
    args = build_parser().parse_args(["--env", "SmaSpine3D-v1", "--baselines", "pid", "--models",
                                      f"eco={ECO_POLICY}", "--suite", "quick"])  # fmt: skip
    _, baselines, models = job.plan(args)
    controllers, env_kwargs, _, entries = job.controllers_of(args, baselines, models)
    assert list(controllers) == ["pid", "eco", "pid@6V"]
    assert env_kwargs["pid"] == {} and env_kwargs["pid@6V"] == {"v_max": 6.0}
    assert np.allclose(controllers["pid@6V"].v_max, 6.0) and np.allclose(controllers["pid"].v_max, 5.0)
    expected = [("pid", True), ("eco", False), ("pid", True)]
    assert [(e.method, e.baseline) for e in entries.values()] == expected


def test_selection_compares_a_model_with_the_pid_at_the_models_own_ceiling():
    from spine_gym.agents.selection import reference

    refs: dict = {}
    short = {"episode_duration": 5.0}
    five = reference(refs, short, None, 1, "SmaSpineEasy-v1")  # the env's own ceiling first
    six = reference(refs, short, 6.0, 1, "SmaSpineEasy-v1")
    assert list(refs) == [5.0, 6.0] and (five["model"], six["model"]) == ("pid", "pid@6V")
    assert (five["v_max_V"], six["v_max_V"]) == (5.0, 6.0) and six["energy_J"] != five["energy_J"]
    assert reference(refs, short, 6.0, 1, "SmaSpineEasy-v1") is six  # run once per ceiling
    assert reference(refs, short, 5.0, 1, "SmaSpineEasy-v1") is five
