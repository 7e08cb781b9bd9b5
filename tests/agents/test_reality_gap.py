"""Fine-tuning across the reality gap (spine_gym.agents.reality_gap, ``spine-gym finetune``): the
shifted plant is reproducible and differs from the fit by the stated amounts; the command runs end to
end on a tiny budget; bad arguments are one-line errors naming the parameter."""

import csv
import json
import re

import numpy as np
import pytest
from repo import ROOT

from spine_gym import cli
from spine_gym.agents.reality_gap import (
    DEFAULT_LEARNER,
    LEARNERS,
    Learner,
    StudyConfig,
    check_model_error,
    fitted_layout,
    paired_gains,
    pooled_gains,
    recovered_fraction,
    shift_plant,
    shift_plants,
    target_verdict,
    tuning_plants,
    write_plant,
)
from spine_gym.layout import wire_key
from spine_gym.params import load_preset
from spine_gym.uncertainty import ParameterUncertainty

PRESET = ROOT / "docs" / "studies" / "reality_gap" / "module_fit.json"


@pytest.fixture(scope="module")
def unc():
    return ParameterUncertainty.from_file(PRESET)


def _value(layout, direction_name: str) -> float:
    """The layout's value of a fit parameter named after one field (``wire<j>.<v>`` or a params field)."""
    key = wire_key(direction_name)
    if key is None:
        return float(getattr(layout.params, direction_name))
    return float(layout.wire_values[key[0]][key[1]])


def test_the_shipped_preset_has_per_wire_and_shared_parameters_with_standard_errors(unc):
    assert unc.per_wire and len(unc.wire_values) == 4
    shared = [n for n in unc.names if wire_key(n) is None]
    assert set(shared) == {"E_t", "alpha"} and len(unc.names) == 14
    assert np.all(np.sqrt(np.diag(unc.covariance)) > 0) and np.all(unc.identified)


def test_the_shift_moves_every_parameter_by_k_standard_errors(unc):
    shift = shift_plant(unc, k=3.0, seed=0)
    sigma = np.sqrt(np.diag(unc.covariance))
    np.testing.assert_allclose(np.abs(shift.offsets), 3.0 * sigma, rtol=1e-12)
    assert 0 < np.sum(shift.offsets > 0) < len(unc.names)  # signs drawn, not all the same
    base = fitted_layout(unc)
    for name, off in zip(unc.names, shift.offsets, strict=True):  # each parameter is one field here
        moved = _value(shift.layout, name) - _value(base, name)
        assert moved == pytest.approx(off, rel=1e-9, abs=1e-12), name
    rows = shift.rows()
    assert [abs(r["offset_sigma"]) for r in rows] == pytest.approx([3.0] * len(rows))


def test_the_shift_is_reproducible_from_its_seed_and_differs_between_seeds(unc):
    a, b, c = shift_plant(unc, 3.0, 7), shift_plant(unc, 3.0, 7), shift_plant(unc, 3.0, 8)
    np.testing.assert_array_equal(a.offsets, b.offsets)
    assert a.layout.params == b.layout.params and a.layout.wire_values == b.layout.wire_values
    assert not np.array_equal(a.offsets, c.offsets)
    assert shift_plant(unc, 0.0, 7).layout.wire_values == fitted_layout(unc).wire_values


def test_the_written_plant_reads_back_as_the_shifted_spine(unc, tmp_path):
    shift = shift_plant(unc, 3.0, 0)
    params, provenance = load_preset(write_plant(shift, tmp_path / "plant.json"))
    assert params == shift.layout.params
    assert provenance["layout"]["wire_values"] == shift.layout.wire_values
    assert provenance["shift"]["k"] == 3.0 and provenance["shift"]["seed"] == 0


def test_the_shift_is_clipped_to_the_fit_bounds(unc):
    shift = shift_plant(unc, 10.0, 0)
    assert np.all(shift.shifted >= unc.lower) and np.all(shift.shifted <= unc.upper)


def test_the_scored_plants_are_one_k_sigma_shift_per_seed_reproducible_and_within_the_bounds(unc):
    plants = shift_plants(unc, 3.0, (0, 1, 2, 3))
    again = shift_plants(unc, 3.0, (0, 1, 2, 3))
    sigma = np.sqrt(np.diag(unc.covariance))
    assert list(plants) == ["shift0", "shift1", "shift2", "shift3"]
    for name, shift in plants.items():
        np.testing.assert_array_equal(shift.offsets, again[name].offsets)  # seeded: the same plant again
        np.testing.assert_array_equal(shift.offsets, shift_plant(unc, 3.0, shift.seed).offsets)
        np.testing.assert_allclose(np.abs(shift.offsets), 3.0 * sigma, rtol=1e-12)  # every parameter 3 sigma
        assert np.all(shift.shifted >= unc.lower) and np.all(shift.shifted <= unc.upper)
    signs = {tuple(np.sign(s.offsets)) for s in plants.values()}
    assert len(signs) == 4  # four directions, none the same
    assert plants["shift0"].layout.wire_values != fitted_layout(unc).wire_values


def test_a_model_error_sets_the_fixed_parameters_on_top_of_the_same_fit_shift(unc):
    error = {"T_E": 303.0, "a": 0.0135}
    plain, warm = shift_plants(unc, 3.0, (0, 1)), shift_plants(unc, 3.0, (0, 1), error)
    for name, shift in warm.items():
        np.testing.assert_array_equal(shift.offsets, plain[name].offsets)  # the fit's part unchanged
        assert shift.layout.wire_values == plain[name].layout.wire_values
        assert shift.layout.params == plain[name].layout.params.replace(**error)
        assert {w.a for m in shift.layout.modules for w in m.wires} == {0.0135}  # the wires' lever arm too
        assert shift.model_error == {"T_E": 293.0, "a": 0.014}  # the preset's values
        rows = [r for r in shift.rows() if r["kind"] == "model_error"]
        assert [(r["parameter"], r["fitted"], r["shifted"]) for r in rows] == [
            ("T_E", 293.0, 303.0), ("a", 0.014, 0.0135)
        ]
        assert all(r["sigma"] is None for r in rows)
    tuning = tuning_plants(unc, 3.0, model_error=error)
    assert tuning["shift101"].params.T_E == 303.0 and tuning["fitted"].params.T_E == 293.0


def test_the_written_plant_with_a_model_error_reads_back_with_it(unc, tmp_path):
    shift = shift_plant(unc, 3.0, 0, [("T_E", 303.0)])
    params, provenance = load_preset(write_plant(shift, tmp_path / "plant.json"))
    assert params.T_E == 303.0 and params == shift.layout.params
    assert provenance["shift"]["model_error"] == {"T_E": 303.0}


@pytest.mark.parametrize(
    "error, message",
    [
        ({"E_t": 3e7}, "model_error: each field once, among the parameters the fit holds fixed"),
        ({"eps0": 0.05}, "model_error: each field once"),  # fitted per wire
        ({"n_seg": 10}, "model_error: each field once"),  # the structure, not a value
        ({"T_ambient": 300.0}, "model_error: each field once"),
        ([("T_E", 300.0), ("T_E", 301.0)], "model_error: each field once"),
        ({"T_E": float("nan")}, "model_error: T_E must be a finite number"),
        ({"T_E": "warm"}, "model_error: T_E must be a finite number"),
        ({"T_E": 1000.0}, "model_error: T_E must be in"),
    ],
    ids=["fit parameter", "per-wire fit value", "structure", "unknown", "repeated", "nan", "text", "range"],
)
def test_a_bad_model_error_names_the_parameter(unc, error, message):
    with pytest.raises(ValueError, match="^" + re.escape(message)):
        check_model_error(unc, error)
    with pytest.raises(ValueError, match="^model_error"):
        shift_plant(unc, 3.0, 0, error)


@pytest.mark.parametrize(
    "seeds",
    [(), (0, 0), (0, 101), (102,), (-1,), (1.5,), (True,), tuple(range(17))],
    ids=["none", "repeated", "tuning 101", "tuning 102", "negative", "float", "bool", "too many"],
)
def test_bad_plant_seeds_name_the_parameter(unc, seeds):
    with pytest.raises(ValueError, match="^shift_seeds must"):
        shift_plants(unc, 3.0, seeds)


@pytest.mark.parametrize(
    "kwargs, name",
    [({"k": -1.0}, "k "), ({"k": float("nan")}, "k "), ({"seed": -2}, "seed"), ({"seed": 1.5}, "seed")],
)
def test_bad_shift_arguments_name_the_parameter(unc, kwargs, name):
    with pytest.raises(ValueError, match=f"^{name}"):
        shift_plant(unc, **{"k": 3.0, "seed": 0, **kwargs})


def test_a_preset_without_per_wire_values_is_refused():
    planar = ParameterUncertainty.from_file(ROOT / "docs" / "calibration" / "fit.json")
    with pytest.raises(ValueError, match="^preset: .*no per-wire values"):
        shift_plant(planar)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"n_steps": 4}, "n_steps"),
        ({"batch_size": 512}, "batch_size"),
        ({"n_epochs": 0}, "n_epochs"),
        ({"learning_rate": 0.5}, "learning_rate"),
        ({"clip_range": 0.0}, "clip_range"),
        ({"vf_warmup_steps": -1}, "vf_warmup_steps"),
    ],
)
def test_bad_learner_settings_name_the_setting(kwargs, name):
    with pytest.raises(ValueError, match=f"^{name}"):
        Learner("x", **kwargs)


def test_the_recovered_fraction_is_the_share_of_the_shift_cost_won_back():
    rows = [
        {"controller": "pretrained@nominal", "group": "all", "rmse_deg": 2.0},
        {"controller": "pretrained@shifted", "group": "all", "rmse_deg": 4.0},
        {"controller": "finetuned@shifted", "group": "all", "rmse_deg": 2.5},
    ]
    assert recovered_fraction(rows) == pytest.approx(0.75)
    rows[1]["rmse_deg"] = 1.5  # the shift cost nothing: nothing to recover
    assert np.isnan(recovered_fraction(rows))


def test_the_value_function_warm_up_freezes_exactly_the_actor():
    from stable_baselines3 import PPO

    from spine_gym.agents.reality_gap import _actor_parameters
    from spine_gym.agents.runtime import make_env

    env = make_env({}, env_id="SmaSpine3DEasy-v2")
    policy = PPO("MlpPolicy", env, use_sde=True, device="cpu").policy
    actor = {id(p) for p in _actor_parameters(policy)}
    critic = {id(p) for p in [*policy.mlp_extractor.value_net.parameters(), *policy.value_net.parameters()]}
    assert actor and critic and not actor & critic
    assert actor | critic == {id(p) for p in policy.parameters()}  # nothing shared, nothing left out
    env.close()


def test_the_tuning_plants_are_other_shifts_and_the_fitted_plant_never_the_scored_one(unc):
    plants = tuning_plants(unc, 3.0)
    scored = shift_plant(unc, 3.0, 0).layout
    assert plants["fitted"].wire_values == fitted_layout(unc).wire_values
    assert all(p.wire_values != scored.wire_values for p in plants.values())
    assert len(plants) == 3 and DEFAULT_LEARNER in LEARNERS


def _scenario_rows(pre_n, pre_s, ft, ctrl):
    rows = []
    for name, vals in (("pretrained@nominal", pre_n), ("pretrained@shifted", pre_s)):
        rows += [{"controller": name, "rmse_deg": v} for v in vals]
    for arm, runs in (("finetuned@shifted", ft), ("finetuned@nominal", ctrl)):
        for i, vals in enumerate(runs):
            rows += [{"controller": f"{arm}#{i}", "rmse_deg": v} for v in vals]
    return rows


def test_paired_gains_are_the_per_run_differences_on_the_same_scenarios():
    pre_n, pre_s = [2.0, 4.0, 3.0], [3.0, 5.0, 4.0]  # the shift costs 1 deg on every scenario
    ft = [[2.5, 4.5, 3.5], [3.0, 5.0, 4.0], [2.0, 4.0, 3.0]]  # gains 0.5, 0, 1
    ctrl = [[2.0, 4.0, 3.0], [2.2, 4.2, 3.2]]  # control gains 0, -0.2
    out = paired_gains(_scenario_rows(pre_n, pre_s, ft, ctrl), n_boot=200)
    assert out["shift_cost_deg"] == pytest.approx(1.0)
    assert out["gain_deg_per_run"] == pytest.approx([0.5, 0.0, 1.0])
    assert out["recovered_fraction"] == pytest.approx(0.5)
    assert out["control_gain_deg_per_run"] == pytest.approx([0.0, -0.2])
    assert out["control_gain_deg"] == pytest.approx(-0.1)
    assert out["excess_gain_deg"] == pytest.approx(0.6) and out["excess_fraction"] == pytest.approx(0.6)
    lo, hi = out["recovered_fraction_ci95"]
    assert 0.0 <= lo <= 0.5 <= hi <= 1.0 and lo < hi  # the runs' spread, never beyond their range
    assert out["shift_cost_deg_ci95"] == pytest.approx([1.0, 1.0])  # the same cost on every scenario


def test_paired_gains_without_spread_have_a_point_interval():
    pre_n, pre_s = [2.0, 4.0], [3.0, 5.0]
    out = paired_gains(_scenario_rows(pre_n, pre_s, [[2.4, 4.4]] * 3, [[2.0, 4.0]] * 2), n_boot=100)
    assert out["recovered_fraction_ci95"] == pytest.approx([0.6, 0.6])
    assert out["control_gain_deg_ci95"] == pytest.approx([0.0, 0.0])
    assert out["gain_deg_ci95_scenarios"] == pytest.approx([0.6, 0.6])


def test_a_shift_that_cost_nothing_has_no_recovered_fraction():
    out = paired_gains(_scenario_rows([3.0, 5.0], [3.0, 4.0], [[2.0, 4.0]], [[3.0, 5.0]]), n_boot=50)
    assert out["shift_cost_deg"] == pytest.approx(-0.5) and np.isnan(out["recovered_fraction"])
    assert np.isnan(out["recovered_fraction_ci95"]).all()


def _plant_rows(pre_n, ctrl, plants):
    """Per-scenario rows of the fitted plant (``pre_n``, control runs ``ctrl``) and of each shifted plant
    ``name -> (pre_s, fine-tuned runs)``, with the plant column."""
    rows = [r | {"plant": "fitted"} for r in _scenario_rows(pre_n, [], [], ctrl)]
    for name, (pre_s, ft) in plants.items():
        own = _scenario_rows([], pre_s, ft, [])
        rows += [r | {"plant": name} for r in own]
    return rows


def test_pooled_gains_average_the_plants_costs_and_median_gains():
    pre_n = [2.0, 4.0, 3.0]
    plants = {
        "a": ([3.0, 5.0, 4.0], [[2.5, 4.5, 3.5], [3.0, 5.0, 4.0], [2.0, 4.0, 3.0]]),  # cost 1, gains .5 0 1
        "b": ([5.0, 7.0, 6.0], [[4.0, 6.0, 5.0], [3.0, 5.0, 4.0], [4.0, 6.0, 5.0]]),  # cost 3, gains 1 2 1
    }
    ctrl = [[2.0, 4.0, 3.0], [2.2, 4.2, 3.2]]  # control gains 0, -0.2
    out = pooled_gains(_plant_rows(pre_n, ctrl, plants), ["a", "b"], n_boot=300)
    assert out["shift_cost_deg"] == pytest.approx(2.0)  # (1 + 3) / 2
    assert out["gain_deg"] == pytest.approx(0.75)  # (median 0.5 + median 1) / 2
    assert out["recovered_fraction"] == pytest.approx(0.375)
    assert out["control_gain_deg"] == pytest.approx(-0.1) and out["excess_gain_deg"] == pytest.approx(0.85)
    assert out["shift_cost_deg_ci95"] == pytest.approx([2.0, 2.0])  # every scenario costs the same: no spread
    lo, hi = out["recovered_fraction_ci95"]
    assert 0.25 - 1e-9 <= lo <= 0.375 <= hi <= 0.75 + 1e-9 and lo < hi  # within what the runs allow
    c_lo, c_hi = out["shift_cost_deg_ci95_plants"]
    assert c_lo == pytest.approx(1.0) and c_hi == pytest.approx(3.0)  # plants resampled: one or the other
    assert out["n_runs"] == 6 and out["n_control_runs"] == 2 and out["plants"] == ["a", "b"]
    assert out["verdict"] == "undecided"  # its interval holds 50 %


def test_pooled_gains_of_one_plant_are_its_paired_gains():
    pre_n, pre_s = [2.0, 4.0, 3.0, 5.0], [3.0, 4.5, 4.0, 5.2]
    ft, ctrl = [[2.5, 4.5, 3.5, 5.0], [2.8, 4.0, 3.9, 5.2]], [[2.0, 4.1, 3.0, 4.9]]
    one = pooled_gains(_plant_rows(pre_n, ctrl, {"a": (pre_s, ft)}), ["a"], n_boot=50)
    ref = paired_gains(_scenario_rows(pre_n, pre_s, ft, ctrl), n_boot=50)
    for key in ("shift_cost_deg", "gain_deg", "control_gain_deg", "excess_gain_deg", "recovered_fraction"):
        assert one[key] == pytest.approx(ref[key]), key


def _gains(cost_ci, fraction_ci):
    return {"shift_cost_deg_ci95": cost_ci, "recovered_fraction_ci95": fraction_ci}


@pytest.mark.parametrize(
    "cost_ci, fraction_ci, verdict",
    [
        ([0.2, 0.9], [0.55, 1.2], "met"),
        ([0.2, 0.9], [0.5, 1.2], "met"),
        ([0.2, 0.9], [-0.3, 0.45], "not met"),
        ([0.2, 0.9], [0.3, 0.9], "undecided"),
        ([-0.1, 0.9], [0.6, 1.2], "undecided (the shift's cost is not distinguishable from zero)"),
        ([0.0, 0.9], [0.6, 1.2], "undecided (the shift's cost is not distinguishable from zero)"),
    ],
)
def test_the_target_is_met_only_when_the_whole_interval_clears_it(cost_ci, fraction_ci, verdict):
    assert target_verdict(_gains(cost_ci, fraction_ci)) == verdict


@pytest.mark.parametrize("target", [0.0, 1.5, float("nan")])
def test_a_bad_target_names_the_parameter(target):
    with pytest.raises(ValueError, match="^target must be in"):
        target_verdict(_gains([0.2, 0.9], [0.6, 1.0]), target)


def test_a_resampled_cost_of_zero_or_less_widens_the_fraction_interval_not_drops_it():
    pre_n = [2.0, 2.0, 2.0, 2.0]
    plants = {"a": ([4.0, 1.0, 4.0, 1.0], [[3.0, 1.0, 3.0, 1.0]])}  # cost +2 or -1 per scenario: some <= 0
    out = pooled_gains(_plant_rows(pre_n, [[2.0] * 4], plants), ["a"], n_boot=400)
    assert out["shift_cost_deg"] == pytest.approx(0.5) and out["recovered_fraction"] == pytest.approx(1.0)
    lo, hi = out["recovered_fraction_ci95"]
    assert lo == -np.inf and hi >= 1.0
    assert out["verdict"].startswith("undecided (the shift's cost")


BAD = {
    "env": (["--env", "SmaSpine-v2"], "env_id must be a four-wire module id"),
    "k": (["--k", "-3"], "k (the shift in standard errors)"),
    "finetune steps": (["--finetune-steps", "0"], "finetune_steps must be an integer"),
    "finetune seeds": (["--finetune-seeds", "0"], "finetune_seeds must be an integer"),
    "learner": (["--learners", "dqn"], "learners must be among"),
    "suite": (["--suite", "long"], "suite must be 'full' or 'quick'"),
    "eval episodes": (["--eval-episodes", "-1"], "eval_episodes must be an integer in [0, 1000]"),
    "tuning plant": (["--shift-seeds", "0", "101"], "shift_seeds must not include the tuning plants' seeds"),
    "repeated plant": (["--shift-seeds", "3", "3"], "shift_seeds must be 1 to 16 distinct integers"),
    "pretrained": (["--pretrain-steps", "0"], "pretrained: give a pretrained run folder"),
    "planar preset": (["--preset", str(ROOT / "docs" / "calibration" / "fit.json")], "preset: "),
    "model error form": (["--model-error", "T_E"], "model_error: expected FIELD=VALUE"),
    "model error value": (["--model-error", "T_E=warm"], "model_error: expected FIELD=VALUE"),
    "model error field": (["--model-error", "E_t=3e7"], "model_error: each field once"),
}


@pytest.mark.parametrize("argv, message", list(BAD.values()), ids=list(BAD))
def test_bad_arguments_are_one_line_errors_naming_the_parameter(argv, message, tmp_path, capsys):
    out = tmp_path / "out"
    args = ["finetune", "--preset", str(PRESET), "-o", str(out), "--no-progress", *argv]
    with pytest.raises(SystemExit) as e:
        cli.main(args)
    err = capsys.readouterr().err
    assert e.value.code == 2 and err.count("\n") == 1 and message in err, err
    assert not out.exists()


def test_the_study_config_refuses_what_the_command_line_would(tmp_path):
    with pytest.raises(ValueError, match="^selection_episodes"):
        StudyConfig(preset=str(PRESET), out=str(tmp_path), selection_episodes=0)


def test_the_command_runs_end_to_end_on_a_tiny_budget(tmp_path, capsys):
    out = tmp_path / "rg"
    argv = ["finetune", "--preset", str(PRESET), "--quick", "--learners", *list(LEARNERS)[:2], "-o", str(out)]
    assert cli.main([*argv, "--shift-seeds", "0", "1", "--model-error", "T_E=298", "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert "fine-tuned on each shifted plant in 256 steps (0.4 min of hardware)" in printed
    assert "over 2 shifted plants the shift cost" in printed
    with open(out / "scores.csv") as f:
        rows = list(csv.DictReader(f))
    arms = ("finetuned@shifted", "finetuned@nominal")
    shifted = {"pretrained@shifted", "finetuned@shifted", "pid@shifted"}
    for plant in ("shift0", "shift1", "pooled"):
        assert {r["controller"] for r in rows if r["plant"] == plant} == shifted
    assert {r["controller"] for r in rows if r["plant"] == "fitted"} == {"pretrained@nominal", arms[1]}
    assert {r["group"] for r in rows} == {"nominal", "disturbed", "episodes", "all"}
    assert all(float(r["rmse_deg"]) > 0 and float(r["energy_J"]) > 0 for r in rows)
    for r in [r for r in rows if r["plant"] == "pooled"]:  # the pooled row: the plants' mean
        own = [float(x["rmse_deg"]) for x in rows if x["plant"] in ("shift0", "shift1")
               and (x["controller"], x["group"]) == (r["controller"], r["group"])]  # fmt: skip
        assert float(r["rmse_deg"]) == pytest.approx(np.mean(own))
    with open(out / "selection.csv") as f:
        assert len(list(csv.DictReader(f))) == 2 * 3 * 2  # 2 learners x 3 tuning plants x 2 seeds
    with open(out / "finetune_seeds.csv") as f:
        runs = list(csv.DictReader(f))
    expected = {("fitted", f"{arms[1]}#{i}") for i in (0, 1)}
    expected |= {(p, f"{arms[0]}#{i}") for p in ("shift0", "shift1") for i in (0, 1)}
    assert {(r["plant"], r["controller"]) for r in runs} == expected
    for plant, arm in (("shift0", arms[0]), ("shift1", arms[0]), ("fitted", arms[1])):
        for group in ("nominal", "disturbed", "episodes", "all"):  # a fine-tuned row: the median of its runs
            sel = [r for r in runs if (r["plant"], r["group"]) == (plant, group)
                   and r["controller"].startswith(arm)]  # fmt: skip
            median = np.median([float(r["rmse_deg"]) for r in sel])
            row = [r for r in rows if (r["plant"], r["controller"], r["group"]) == (plant, arm, group)]
            assert float(row[0]["rmse_deg"]) == pytest.approx(median)
    with open(out / "scenarios.csv") as f:
        per_scenario = list(csv.DictReader(f))
    n_scenarios = 4 + 2  # the quick suite and two held-out episodes
    assert len({r["scenario"] for r in per_scenario}) == n_scenarios
    assert len(per_scenario) == n_scenarios * (1 + 2 + 2 * (2 + 2))  # fitted: 1 + 2 runs; a plant: 2 + 2
    meta = json.loads((out / "finetuned_shift1_1" / "meta.json").read_text())
    assert meta["seed"] == 1 and meta["plant"].endswith("real_plant_shift1.json")
    assert meta["finetune_timesteps"] >= 256 and meta["n_envs"] == 1
    pretrained = json.loads((out / "pretrained" / "meta.json").read_text())
    assert meta["start_timesteps"] == pretrained["total_timesteps"]
    assert (out / "reality_gap.png").stat().st_size > 10_000
    assert (out / "command.txt").read_text().startswith("spine-gym finetune --preset")
    control = json.loads((out / "control_0" / "meta.json").read_text())
    assert control["plant"] == str(PRESET)  # the control arm: the fitted plant
    with open(out / "plant.csv") as f:
        plant_rows = list(csv.DictReader(f))
    assert [r["plant"] for r in plant_rows] == ["shift0"] * 15 + ["shift1"] * 15  # 14 fit parameters, T_E
    assert [r["kind"] for r in plant_rows[:15]] == ["fit"] * 14 + ["model_error"]
    assert load_preset(out / "real_plant_shift1.json")[0].T_E == 298.0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["n_runs"] == 4 and summary["n_control_runs"] == 2
    assert summary["model_error"] == {"T_E": 298.0}
    assert summary["plants"] == ["shift0", "shift1"]
    assert len(summary["recovered_fraction_ci95"]) == 2 and summary["verdict"]
    assert set(summary["per_plant"]) == {"shift0", "shift1"} and summary["per_plant"]["shift0"]["n_runs"] == 2
    assert summary["finetune_steps"] == 256 and summary["hardware_minutes"] == pytest.approx(256 * 0.1 / 60)


@pytest.mark.parametrize(
    ("fraction_pct", "lo", "hi", "expected"),
    [
        (96.0, -np.inf, 11.48, [[96.0 + 1000.0], [1000.0 - 96.0]]),  # lower end unbounded: drawn to the panel's edge
        (1500.0, 0.2, 12.0, [[1000.0 - 20.0], [0.0]]),  # the point beyond the panel: clipped with it, no negative bar
        (-1500.0, -20.0, 0.5, [[0.0], [50.0 + 1000.0]]),
        (50.0, np.nan, np.nan, [[0.0], [0.0]]),  # an unknown interval is drawn as none
    ],
)
def test_error_bars_of_the_recovered_fraction_are_never_negative(fraction_pct, lo, hi, expected):
    from spine_gym.agents.reality_gap import _error_bar

    (below,), (above,) = _error_bar(fraction_pct, lo, hi)
    assert [below, above] == pytest.approx([expected[0][0], expected[1][0]])
