"""Design studies over spatial / chained layouts: the ``n_modules`` design parameter.

Checked against the specs: a one-module four-wire layout with its 90°/270° wires unpowered is the
planar spine (SPATIAL.md §7.1, within the adaptive stepping's round-off sensitivity of §8.1), and
the seed's design study 1 trends (MODEL.md §10.4: a smaller wire offset bends further and resists
a tip force less) hold for a two-module chain too. Plus validation, CSV/plot, optimiser and CLI.
"""

from __future__ import annotations

import csv
import json
import subprocess
import sys

import pytest
from repo import ROOT

from spine_gym import ModelParams, SpineLayout
from spine_gym.capacity import CapacityProtocol
from spine_gym.design import DesignProblem, SweepResult, make_design, optimize, sweep
from spine_gym.design.plots import plot_sweep

SHORT = CapacityProtocol(t_stable=20.0, t_respond=20.0, t_load=10.0)
TINY = CapacityProtocol(t_stable=10.0, t_respond=6.0, t_load=4.0)


def test_make_design_builds_a_chain_from_the_params():
    model, proto = make_design({"n_modules": 2, "a": 10e-3, "n_w": 2, "voltage": 3.0})
    assert model == SpineLayout.chain(2, ModelParams().replace(a=10e-3, n_w=2))
    assert all(w.a == 10e-3 and w.n_w == 2 for m in model.modules for w in m.wires)
    assert proto.voltage == 3.0
    planar, _ = make_design({"a": 10e-3})
    assert isinstance(planar, ModelParams)
    # a chain base keeps its module count under further overrides
    again, _ = make_design({"a": 12e-3}, base=model)
    assert again.n_modules == 2 and again.modules[0].wires[0].a == 12e-3


@pytest.mark.parametrize(
    "overrides, words",
    [
        ({"n_modules": 0}, ["n_modules must be in [1, 100]", "0"]),
        ({"n_modules": 1.5}, ["n_modules takes integers"]),
        ({"n_modules": 2, "E_t": 3e6}, ["invalid design", "load factor"]),  # past self-weight buckling
    ],
)
def test_bad_layout_designs_name_the_parameter(overrides, words):
    with pytest.raises(ValueError) as exc:
        make_design(overrides)
    for w in words:
        assert w in str(exc.value)


def test_custom_base_layout_is_refused():
    custom = SpineLayout.planar()
    with pytest.raises(ValueError, match=r"SpineLayout.chain\(n_modules, params\)"):
        make_design({"a": 10e-3}, base=custom)


def test_one_module_layout_reproduces_the_model_md_10_4_table():
    """SPATIAL.md §7.1 (the four-wire module with 90°/270° unpowered is the planar spine) applied
    to the full capacity protocol: the MODEL.md §10.4 table of design study 1."""
    res = sweep({"n_modules": [1], "a": [6e-3, 10e-3, 14e-3]})
    assert list(res.column("status")) == ["ok"] * 3
    # within the adaptive stepping's round-off sensitivity of the two cores (SPATIAL.md §8.1)
    assert res.column("stable_angle_deg") == pytest.approx([79.03, 64.80, 51.34], abs=0.15)
    assert res.column("actuating_ability") == pytest.approx([0.057, 0.112, 0.206], abs=2e-3)
    assert res.column("responding_time_s") == pytest.approx([35.41, 35.78, 35.90], abs=0.1)


def test_one_module_layout_is_the_planar_spine_on_other_designs():
    spatial = sweep({"n_modules": [1], "n_w": [2], "E_t": [20e6, 30e6]}, protocol=SHORT)
    planar = sweep({"n_w": [2], "E_t": [20e6, 30e6]}, protocol=SHORT)
    for s, p in zip(spatial.rows, planar.rows, strict=True):
        assert s["status"] == p["status"] == "ok"
        assert s["stable_angle_deg"] == pytest.approx(p["stable_angle_deg"], abs=0.15)
        assert s["load_deflection_deg"] == pytest.approx(p["load_deflection_deg"], abs=0.15)
        assert s["peak_temperature_K"] == pytest.approx(p["peak_temperature_K"], abs=0.5)


def test_chain_follows_the_seed_design_study_trends():
    """MODEL.md §10.4 study 1 on a two-module chain (full protocol): smaller a -> larger stable
    angle and smaller actuating ability."""
    res = sweep({"n_modules": [2], "a": [6e-3, 10e-3, 14e-3]})
    assert list(res.column("status")) == ["ok"] * 3
    angle, ability = res.column("stable_angle_deg"), res.column("actuating_ability")
    assert angle[0] > angle[1] + 5 > angle[2] + 10
    assert ability[0] < ability[1] < ability[2]


def test_layout_sweep_csv_plot_and_metadata(tmp_path):
    res = sweep({"n_modules": [1, 2], "a": [8e-3, 12e-3]}, protocol=TINY, fixed={"n_w": 2})
    path = res.to_csv(tmp_path / "s.csv")
    with path.open() as fh:
        rows = list(csv.DictReader(fh))
    assert [r["n_modules"] for r in rows] == ["1", "1", "2", "2"]
    back = SweepResult.from_csv(path)
    assert back.rows == res.rows and back.axes == {"n_modules": [1, 2], "a": [8e-3, 12e-3]}
    meta = json.loads(res.write_metadata(tmp_path / "s.json").read_text())
    assert meta["base_params"]["n_w"] == 2 and meta["base_n_modules"] is None
    files = plot_sweep(res, tmp_path / "plots")
    assert "curves_n_modules.png" in {p.name for p in files}
    for p in files:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_design_problem_with_fixed_chain_round_trips_and_optimises():
    problem = DesignProblem(space=("a=8e-3:14e-3",), metric="ability", protocol=TINY, fixed={"n_modules": 2})
    assert isinstance(problem.base, SpineLayout) and problem.base.n_modules == 2
    assert DesignProblem.from_config(problem.to_config()) == problem
    res = optimize(problem, n_trials=3, seed=0)
    best = res.best_design()
    assert isinstance(best, SpineLayout) and best.n_modules == 2
    assert best.modules[1].wires[0].a == res.best["params"]["a"] == res.best_params().a


def test_cli_sweeps_layouts(tmp_path):
    out = tmp_path / "sw"
    cmd = [sys.executable, "-m", "spine_gym.design", "sweep", "--param", "n_modules=1,2", "--param",
           "a=8e-3,12e-3", "--protocol", "t_stable=10,t_respond=6,t_load=4", "--no-progress",
           "--out", str(out)]  # fmt: skip
    r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=900)  # a cold spatial compile alone takes 1.5-3 min
    assert r.returncode == 0, r.stderr
    assert "4 designs" in r.stdout and (out / "curves_n_modules.png").exists()
    bad = subprocess.run(cmd[:5] + ["n_modules=0,1"], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and "n_modules must be in [1, 100]" in bad.stderr
