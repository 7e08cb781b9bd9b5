"""spine_gym.agents.benchmark_ranking: the constrained ranking of the benchmark table on synthetic
results (the cap on the time over the temperature limit, the order, the CI cells, missing records)
and the envelope and budget columns on a real env id."""

from __future__ import annotations

import math

import pytest

from spine_gym.agents import benchmark_ranking as ranking
from spine_gym.agents import benchmark_stats as stats
from spine_gym.agents.metrics import TIME_OVER_LIMIT_CAP_S
from spine_gym.controllers.registry import GUARD_MARGIN_K
from spine_gym.agents.runtime import build_controller, controller_cutoff, envelope_of, make_env

ENV_ID = "SmaSpineEasy-v1"
UNITS = {ENV_ID: "deg"}
CAP = TIME_OVER_LIMIT_CAP_S


def _runs(algo: str, rmse: list[float], over: list[float | None], env_id: str = ENV_ID) -> list[dict]:
    """Per-seed records of ``algo`` with final RMSE ``rmse`` and time over the limit ``over``
    (None: a record without the metric)."""
    out = []
    for seed, (e, t) in enumerate(zip(rmse, over, strict=True)):
        r = {"algo": algo, "env_id": env_id, "seed": seed, "steps": 1000, "wall_s": 10.0, "cpu_s": 9.0,
             "final_rmse": e, "final_energy_J": 100.0 + 10 * seed,
             "steps_to_pid": None, "wall_to_pid_s": None}  # fmt: skip
        if t is not None:
            r["final_time_over_limit_s"] = t
        out.append(r)
    return out


def _rows(runs: list[dict], refs: dict | None = None) -> list[dict]:
    return stats.summary_rows(runs, refs or {}, reps=300)


def _ranked_names(rows: list[dict]) -> list[str]:
    return [r["method"] for r in ranking.constrained_split(rows, ENV_ID)[ranking.RANKED]]


def test_the_cap_is_half_a_second():
    assert TIME_OVER_LIMIT_CAP_S == 0.5


def test_a_method_over_the_cap_is_never_ranked_whatever_its_rmse():
    runs = _runs("fast_hot", [1.0] * 4, [0.6] * 4) + _runs("slow_cool", [9.0] * 4, [0.0] * 4)
    rows = _rows(runs)
    split = ranking.constrained_split(rows, ENV_ID)
    assert _ranked_names(rows) == ["slow_cool"]
    assert [r["method"] for r in split[ranking.OVER_CAP]] == ["fast_hot"]
    md = ranking.constrained_markdown(rows, UNITS)
    ranked_part, over_part = md.split("Not ranked: more than 0.5 s")
    assert "| 1 | slow_cool |" in ranked_part and "fast_hot" not in ranked_part
    assert "| fast_hot | 1.00 [" in over_part and "| 0.6 [0.6, 0.6] |" in over_part


def test_a_method_at_exactly_the_cap_is_ranked_and_one_just_above_is_not():
    rows = _rows(_runs("at_cap", [2.0] * 4, [CAP] * 4) + _runs("above", [1.0] * 4, [CAP + 1e-9] * 4))
    assert rows[0]["time_over_limit_s_iqm"] == pytest.approx(CAP)
    assert _ranked_names(rows) == ["at_cap"]
    assert ranking.cap_status(rows[1]) == ranking.OVER_CAP


def test_the_cap_applies_to_the_iqm_over_seeds_not_to_each_seed():
    # one hot seed of four is cut by the interquartile mean: IQM of (0, 0, 0.2, 30) = mean(0, 0.2) = 0.1
    rows = _rows(_runs("one_hot_seed", [2.0, 2.1, 2.2, 2.3], [0.0, 0.0, 0.2, 30.0]))
    assert rows[0]["time_over_limit_s_iqm"] == pytest.approx(0.1)
    assert _ranked_names(rows) == ["one_hot_seed"]


def test_ranked_methods_are_ordered_by_rmse_iqm_not_by_mean_or_table_order():
    # "outlier": IQM 3.0 (the 40 is cut) but mean 12.25; "steady": IQM and mean 4.0
    runs = _runs("steady", [4.0] * 4, [0.0] * 4) + _runs("outlier", [3.0, 3.0, 3.0, 40.0], [0.0] * 4)
    refs = {ENV_ID: {"pid": {"rmse": 3.5, "energy_J": 80.0, "time_over_limit_s": 0.0, "n_episodes": 10}}}
    rows = _rows(runs, refs)
    assert _ranked_names(rows) == ["outlier", "pid", "steady"]
    md = ranking.constrained_markdown(rows, UNITS)
    first, second = md.index("| 1 | outlier |"), md.index("| 2 | pid (reference, 10 episodes) |")
    assert first < second < md.index("| 3 | steady |")


def test_the_cells_are_iqm_and_95_percent_ci_of_rmse_energy_and_time_over_the_limit():
    rmse, over = [3.0, 4.0, 5.0, 6.0, 7.0], [0.0, 0.1, 0.2, 0.3, 0.4]
    rows = _rows(_runs("ppo", rmse, over))
    md = ranking.constrained_markdown(rows, UNITS)
    assert "RMSE [deg] IQM [95 % CI] | energy [J] IQM [95 % CI] | T>limit [s] IQM [95 % CI]" in md
    e, e_lo, e_hi = stats.iqm_interval(rmse, reps=300)
    j, j_lo, j_hi = stats.iqm_interval([100.0, 110.0, 120.0, 130.0, 140.0], reps=300)
    t, t_lo, t_hi = stats.iqm_interval(over, reps=300)
    assert e_lo < e < e_hi and t_lo < t < t_hi
    cells = f"| {e:.2f} [{e_lo:.2f}, {e_hi:.2f}] | {j:.0f} [{j_lo:.0f}, {j_hi:.0f}] | "
    cells += f"{t:.1f} [{t_lo:.1f}, {t_hi:.1f}] |"
    assert f"| 1 | ppo {cells}" in md


@pytest.mark.parametrize("missing", [None, math.nan])
def test_a_missing_or_nan_time_over_the_limit_is_listed_apart_not_ranked(missing):
    runs = _runs("old", [1.0] * 3, [0.0, missing, 0.0]) + _runs("new", [5.0] * 3, [0.0] * 3)
    rows = _rows(runs)
    old = next(r for r in rows if r["method"] == "old")
    assert old["time_over_limit_s_iqm"] is None and old["rmse_iqm"] == pytest.approx(1.0)
    assert ranking.cap_status(old) == ranking.NOT_RECORDED
    assert _ranked_names(rows) == ["new"]
    md = ranking.constrained_markdown(rows, UNITS)
    assert "Not ranked: time over the temperature limit (or RMSE) not recorded: old." in md
    assert "| old |" not in md
    refs = {ENV_ID: {"pid": {"rmse": 3.5, "energy_J": 80.0, "n_episodes": 10}}}  # a cache without it
    pid = next(r for r in _rows(runs, refs) if r["method"] == "pid")
    assert ranking.cap_status(pid) == ranking.NOT_RECORDED


def test_envelope_and_budget_columns_on_a_real_env_id(tmp_path):
    runs = _runs("ppo", [4.0] * 3, [0.0] * 3) + _runs("sac", [3.0] * 3, [2.0] * 3)
    refs = {ENV_ID: {"pid": {"rmse": 3.5, "energy_J": 80.0, "time_over_limit_s": 0.0, "n_episodes": 10}}}
    rows = ranking.with_envelope(_rows(runs, refs), {ENV_ID: {"v_max": 4.0}})
    env = make_env({"v_max": 4.0}, env_id=ENV_ID)
    assert {r["v_max_V"] for r in rows} == {float(env.config.v_max)} == {4.0}
    by = {r["method"]: r for r in rows}
    assert by["ppo"]["guard"] == by["sac"]["guard"] == "none"  # -v1: a policy has no guard
    assert by["pid"]["guard"] == f"controller {423 - GUARD_MARGIN_K:g} K"  # its registry guard
    assert {r["cutoff_K"] for r in rows} == {None}  # the -v1 plant cuts nothing
    assert by["ppo"]["budget"] == "1,000 steps × 3 seeds"
    assert by["pid"]["budget"].endswith("episodes (SmaSpine-v0)") and " trials × " in by["pid"]["budget"]
    md = ranking.report_markdown(rows, runs, UNITS)
    assert md.index("## Constrained ranking") < md.index("## Training cost") < md.index("### Runs")
    assert "| 1 | pid (reference, 10 episodes) | 3.50 | 80 | 0.0 | 4 | controller 418 K |" in md
    stats.plot_table(tmp_path / "table.png", rows, UNITS)
    assert (tmp_path / "table.png").stat().st_size > 0


def test_on_a_v2_id_every_row_meets_the_plants_cutoff():
    """-v2: the plant cuts hot wires at 418 K for every method; the registry's PID brings no guard of
    its own there, so learned and classical rows carry the same protection."""
    env_id = "SmaSpineEasy-v2"
    runs = _runs("ppo", [4.0] * 3, [0.0] * 3, env_id=env_id)
    refs = {env_id: {"pid": {"rmse": 3.5, "energy_J": 80.0, "time_over_limit_s": 0.0, "n_episodes": 10}}}
    rows = ranking.with_envelope(_rows(runs, refs), {env_id: {}})
    by = {r["method"]: r for r in rows}
    assert by["ppo"]["guard"] == by["pid"]["guard"] == "plant 418 K"
    assert by["ppo"]["cutoff_K"] == by["pid"]["cutoff_K"] == 418.0
    assert by["ppo"]["v_max_V"] == by["pid"]["v_max_V"] == 5.0
    md = ranking.constrained_markdown(rows, {env_id: "deg"})
    assert md.count("| plant 418 K |") == 2 and "controller" not in md


def test_the_envelope_of_an_env_names_who_cuts_a_hot_wire():
    v1, v2 = make_env({}, env_id="SmaSpine-v1"), make_env({}, env_id="SmaSpine-v2")
    assert envelope_of(v1) == {"v_max_V": 5.0, "cutoff_K": None, "guard": "none"}
    assert envelope_of(v1, 418.0)["guard"] == "controller 418 K"
    plant = {"v_max_V": 5.0, "cutoff_K": 418.0, "guard": "plant 418 K"}
    assert envelope_of(v2, 418.0) == envelope_of(v2) == plant
    assert envelope_of(make_env({"v_max": 6.0, "thermal_cutoff": 410.0}, env_id="SmaSpine-v2")) == {
        "v_max_V": 6.0,
        "cutoff_K": 410.0,
        "guard": "plant 410 K",
    }
    assert controller_cutoff(build_controller("pid", v1)) == 418.0
    assert controller_cutoff(build_controller("pid", v2)) is None
    assert controller_cutoff(object()) is None  # a learned policy


def test_the_figure_takes_a_row_without_time_over_the_limit(tmp_path):
    rows = _rows(_runs("old", [1.0] * 3, [None] * 3) + _runs("new", [5.0] * 3, [0.0] * 3))
    stats.plot_table(tmp_path / "t.png", rows, UNITS)
    assert (tmp_path / "t.png").stat().st_size > 0


def test_the_budget_of_an_id_with_its_own_gains_is_its_own(tmp_path, monkeypatch):
    """An id's own re-tune (``tuned/<id>.yml``) is what it runs on, so its budget is the re-tune's;
    an id without one shows its family's."""
    import yaml

    from spine_gym.controllers import registry

    def record(trials: int, episodes: int, env_id: str) -> dict:
        return {"pid": {"params": {"kp": 1.0}, "n_trials": trials, "n_episodes": episodes, "env_id": env_id}}

    monkeypatch.setattr(registry, "TUNED_DIR", tmp_path)
    monkeypatch.setattr(registry, "TUNED_FILE", tmp_path / "baselines.yml")
    (tmp_path / "baselines.yml").write_text(yaml.safe_dump(record(80, 10, "SmaSpine-v1")))
    (tmp_path / "SmaSpineHard-v2.yml").write_text(yaml.safe_dump(record(40, 6, "SmaSpineHard-v2")))
    assert ranking.tuning_budget("SmaSpineHard-v2", "pid") == "40 trials × 6 episodes (SmaSpineHard-v2)"
    assert ranking.tuning_budget("SmaSpine-v2", "pid") == "80 trials × 10 episodes (SmaSpine-v1)"
    assert ranking.tuning_budget("SmaSpine-v2", "smc") == "defaults (not tuned)"
    assert ranking.tuning_budget("SmaSpine-v2", "step") == "not tuned"
