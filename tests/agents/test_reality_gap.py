"""Fine-tuning across the reality gap (spine_gym.agents.reality_gap, ``spine-gym finetune``): the
shifted plant is reproducible and differs from the fit by the stated amounts; the command runs end to
end on a tiny budget; bad arguments are one-line errors naming the parameter."""

import csv
import json

import numpy as np
import pytest
from repo import ROOT

from spine_gym import cli
from spine_gym.agents.reality_gap import (
    LEARNERS,
    Learner,
    StudyConfig,
    fitted_layout,
    recovered_fraction,
    shift_plant,
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


BAD = {
    "env": (["--env", "SmaSpine-v2"], "env_id must be a four-wire module id"),
    "k": (["--k", "-3"], "k (the shift in standard errors)"),
    "finetune steps": (["--finetune-steps", "0"], "finetune_steps must be an integer"),
    "finetune seeds": (["--finetune-seeds", "0"], "finetune_seeds must be an integer"),
    "learner": (["--learners", "dqn"], "learners must be among"),
    "suite": (["--suite", "long"], "suite must be 'full' or 'quick'"),
    "pretrained": (["--pretrain-steps", "0"], "pretrained: give a pretrained run folder"),
    "planar preset": (["--preset", str(ROOT / "docs" / "calibration" / "fit.json")], "preset: "),
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
    assert cli.main([*argv, "--no-progress"]) == 0
    assert "fine-tuned on the shifted plant in 256 steps (0.4 min of hardware)" in capsys.readouterr().out
    with open(out / "scores.csv") as f:
        rows = list(csv.DictReader(f))
    expected = {"pretrained@nominal", "pretrained@shifted", "finetuned@shifted", "pid@shifted"}
    assert {r["controller"] for r in rows} == expected
    assert {r["group"] for r in rows} == {"nominal", "disturbed", "all"}
    assert all(float(r["rmse_deg"]) > 0 and float(r["energy_J"]) > 0 for r in rows)
    with open(out / "selection.csv") as f:
        assert len(list(csv.DictReader(f))) == 2 * 2  # 2 learners x 2 tuning plants
    with open(out / "finetune_seeds.csv") as f:
        runs = list(csv.DictReader(f))
    assert {r["controller"] for r in runs} == {"finetuned@shifted#0", "finetuned@shifted#1"}
    for group in ("nominal", "disturbed", "all"):  # the fine-tuned row is the median of the runs
        median = np.median([float(r["rmse_deg"]) for r in runs if r["group"] == group])
        row = [r for r in rows if r["controller"] == "finetuned@shifted" and r["group"] == group]
        assert float(row[0]["rmse_deg"]) == pytest.approx(median)
    meta = json.loads((out / "finetuned_1" / "meta.json").read_text())
    assert meta["seed"] == 1
    assert meta["finetune_timesteps"] >= 256 and meta["n_envs"] == 1
    pretrained = json.loads((out / "pretrained" / "meta.json").read_text())
    assert meta["start_timesteps"] == pretrained["total_timesteps"]
    assert (out / "reality_gap.png").stat().st_size > 10_000
    assert (out / "command.txt").read_text().startswith("spine-gym finetune --preset")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["finetune_steps"] == 256 and summary["hardware_minutes"] == pytest.approx(256 * 0.1 / 60)
