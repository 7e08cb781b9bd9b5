"""Per-wire calibration of the four-wire module (spine_gym.calibrate with SpatialExperiment).

The identifiability case (docs/calibration.md, spatial section): a module whose wires differ
(transformation temperatures −4/0/+3/+6 K, wire 1 with 10 % higher resistivity) measured under
:func:`spine_gym.calibrate.protocols.module_protocol` (each wire 3.2 V alone for 15 s, then the
pairs 0+1 and 2+3, each followed by 15 s cooling; 0.1-s samples) with the tip bending vector
(0.5° noise) and every wire's temperature (1 K) and resistance (0.01 Ω) is fitted from the nominal
module, all 14 parameters (per wire: resistivity scale, transformation-temperature shift,
pre-strain; shared: E_t, α). Tolerances: about twice the largest error measured over noise seeds
0–3 (the table in the docs).
"""

import json

import gymnasium as gym
import numpy as np
import pytest

from spine_gym import ModelParams, SpineLayout
from spine_gym.calibrate import SpatialExperiment, fit, synthetic_spatial_experiment
from spine_gym.calibrate.parameters import resolve_parameters
from spine_gym.calibrate.protocols import EXAMPLE_WIRE_VALUES, MODULE_CHANNELS, module_protocol
from spine_gym.physics.spatial import columns as SL
from spine_gym.simulate_spatial import simulate_spatial
from spine_gym.uncertainty import ParameterUncertainty, apply_offsets

# tolerance per parameter kind (absolute; lam_scale and eps0 relative to the truth)
TOL = {"T_shift": 0.25, "lam_scale": 6e-4, "eps0": 3e-3, "E_t": 0.04, "alpha": 3e-3}


def _truth() -> SpineLayout:
    return SpineLayout.seed().with_wire_values(list(EXAMPLE_WIRE_VALUES))


def _experiments(seed: int = 0):
    rng = np.random.default_rng(seed)
    return [
        synthetic_spatial_experiment(_truth(), t, v, channels=MODULE_CHANNELS, rng=rng, name=n)
        for n, t, v in module_protocol()
    ]


@pytest.fixture(scope="module")
def module_fit():
    return fit(_experiments(0), "wires", SpineLayout.seed(), seed=0, n_starts=1, n_workers=2, progress=False)


def _true_value(name: str) -> float:
    truth = _truth()
    if name.startswith("wire"):
        j, key = name[4:].split(".")
        return truth.wire_values[int(j)][key]
    return getattr(truth.params, name)


def test_per_wire_module_is_recovered(module_fit):
    res = module_fit
    assert len(res.names) == 14
    assert 0.9 < res.reduced_chi2 < 1.1
    for name in res.names:
        kind = name.split(".")[-1]
        true, got = _true_value(name), res.value(name)
        err = abs(got - true) / (abs(true) if kind in ("lam_scale", "eps0", "E_t", "alpha") else 1.0)
        assert err < TOL[kind], (name, true, got)
        assert res.is_identified(name), name
        assert abs(got - true) < 4.0 * res.std_error(name), (name, true, got, res.std_error(name))
    # the differences between the wires come out in the right order
    shifts = [res.value(f"wire{j}.T_shift") for j in range(4)]
    assert np.all(np.diff(shifts) > 0)
    assert res.value("wire1.lam_scale") > max(res.value(f"wire{j}.lam_scale") for j in (0, 2, 3)) + 0.09


def test_bending_only_cannot_see_the_resistivity_scale_apart_from_the_shift():
    """Without temperature or resistance readings a lone wire's resistivity scale and its
    transformation temperature both only delay its contraction: the fit must say so (flag or
    warn), not report a false precision."""
    exps = [
        SpatialExperiment(e.name, e.time, e.voltages, {c: e.measured[c] for c in ("bend_1", "bend_2")})
        for e in _experiments(0)[:1]
    ]
    res = fit(
        exps, ["wire0.lam_scale", "wire0.T_shift"], SpineLayout.seed(), seed=0, n_starts=1, cma_evals=40,
        max_nfev=10, n_workers=2, progress=False,
    )  # fmt: skip
    flagged = not all(res.identified)
    correlated = abs(res.correlation[0, 1]) > 0.95
    assert flagged or correlated, (res.report(), res.correlation)


def test_preset_loads_into_the_spatial_envs(module_fit, tmp_path):
    path = module_fit.to_file(tmp_path / "fit.json")
    doc = json.loads(path.read_text())
    assert len(doc["provenance"]["layout"]["wire_values"]) == 4
    assert ModelParams.from_file(path).E_t == pytest.approx(module_fit.value("E_t"))
    unc = ParameterUncertainty.from_file(path)
    assert unc.per_wire and unc.wire_values == module_fit.wire_values
    env = gym.make("SmaSpine3D-v0", domain_randomization=str(path), tip_force_range=None, payload_range=None)
    cfg = env.unwrapped._core.cfg
    assert cfg.wire_values == module_fit.wire_values
    assert [v["T_shift"] for v in cfg.layout.wire_values] == pytest.approx(
        [module_fit.value(f"wire{j}.T_shift") for j in range(4)]
    )
    # every episode draws its own per-wire values from the fit's covariance
    kws = []
    for seed in (1, 2):
        env.reset(seed=seed)
        kws.append(env.unwrapped._core.kws[0].copy())
    assert not np.array_equal(kws[0][:, SL.W_DU], kws[1][:, SL.W_DU])
    drawn = kws[0][:, SL.W_LAMS]
    se = np.array([module_fit.std_error(f"wire{j}.lam_scale") for j in range(4)])
    fitted = np.array([module_fit.value(f"wire{j}.lam_scale") for j in range(4)])
    assert np.all(np.abs(drawn - fitted) < 6 * se)
    env.close()


def test_chain_env_takes_per_wire_values():
    values = [{"T_shift": float(j)} for j in range(8)]
    env = gym.make("SmaSpineChain-v0", wire_values=values, tip_force_range=None, payload_range=None)
    lay = env.unwrapped._core.cfg.layout
    assert [v["T_shift"] for v in lay.wire_values] == list(range(8))
    with pytest.raises(ValueError, match="wire_values must be a sequence of 8 mappings"):
        gym.make("SmaSpineChain-v0", wire_values=values[:4])
    env.close()


def test_parameter_sets_and_offsets_on_a_layout():
    lay = SpineLayout.seed()
    names = [p.name for p in resolve_parameters("wires", lay)]
    assert names[:3] == ["wire0.lam_scale", "wire0.T_shift", "wire0.eps0"] and names[-2:] == ["E_t", "alpha"]
    with pytest.raises(ValueError, match="needs a SpineLayout start"):
        resolve_parameters("wires", ModelParams())
    with pytest.raises(ValueError, match="wire index must be < 4"):
        resolve_parameters(["wire4.T_shift"], lay)
    moved = apply_offsets(lay, [{"wire2.T_shift": 1.0}, {"E_t": 1.0}], [3.0, 1e6])
    assert moved.wire_values[2]["T_shift"] == 3.0 and moved.params.E_t == lay.params.E_t + 1e6
    assert moved.wire_values[0] == lay.wire_values[0]
    with pytest.raises(ValueError, match="needs a SpineLayout"):
        apply_offsets(ModelParams(), [{"wire0.T_shift": 1.0}], [1.0])


# ---------------------------------------------------------------- CSV checks (no simulation)
def _write(path, header, rows):
    path.write_text(",".join(header) + "\n" + "\n".join(",".join(map(str, r)) for r in rows) + "\n")
    return path


VOLTS = ["time", "voltage_0", "voltage_1", "voltage_2", "voltage_3"]
HEAD = [*VOLTS, "bend_1", "bend_2"]


def _rows(n=5, **override):
    rows = []
    for i in range(n):
        r = {"time": 0.1 * i, "voltage_0": 3.2, "voltage_1": 0, "voltage_2": 0, "voltage_3": 0, "bend_1": 1.0,
             "bend_2": 0.5, "temperature_1": 300.0, "tip_x": 0.01, "tip_y": 0.0, "tip_z": 0.45}  # fmt: skip
        r.update(override)
        rows.append(r)
    return rows


def _csv(tmp_path, header, **override):
    return _write(tmp_path / "e.csv", header, [[r.get(h, 300.0) for h in header] for r in _rows(**override)])


def test_spatial_csv_roundtrip(tmp_path):
    e = SpatialExperiment.from_csv(_csv(tmp_path, [*HEAD, "temperature_1"]), noise={"bend": 0.3})
    assert e.n_wires == 4 and set(e.measured) == {"bend_1", "bend_2", "temperature_1"}
    assert e.noise == {"bend_1": 0.3, "bend_2": 0.3, "temperature_1": 1.0}
    back = SpatialExperiment.from_csv(e.to_csv(tmp_path / "back.csv"))
    np.testing.assert_array_equal(back.voltages, e.voltages)


@pytest.mark.parametrize(
    "header, override, match",
    [
        (["time", "voltage_0", "voltage_1", "voltage_3", *HEAD[5:]], {}, r"missing column.*'voltage_2'"),
        ([*VOLTS, "bend_1"], {}, r"missing column\(s\) \['bend_2'\]"),
        (VOLTS, {}, "the bending vector"),
        ([*VOLTS, "tip_x", "tip_y"], {}, r"\['tip_z'\]"),
        ([*HEAD, "temperatur_1"], {}, r"unknown column\(s\) \['temperatur_1'\]"),
        ([*HEAD, "temperature_7"], {}, r"unknown column\(s\) \['temperature_7'\]"),
        (HEAD, {"voltage_0": 3200.0}, "is it in mV"),
        ([*HEAD, "temperature_1"], {"temperature_1": 27.0}, "°C instead of K"),
        ([*VOLTS, "tip_x", "tip_y", "tip_z"], {"tip_z": 450.0},
         "is it in mm"),
        (HEAD, {"bend_1": float("nan")}, "NaN"),
    ],
)  # fmt: skip
def test_spatial_csv_errors_are_named(tmp_path, header, override, match):
    with pytest.raises(ValueError, match=match):
        SpatialExperiment.from_csv(_csv(tmp_path, header, **override))


def test_spatial_experiment_needs_a_matching_layout(tmp_path):
    e = SpatialExperiment.from_csv(_csv(tmp_path, HEAD))
    with pytest.raises(ValueError, match="4 voltage columns, the start layout 8 wires"):
        fit([e], ["E_t"], SpineLayout.chain(2), progress=False)


def test_chain_tip_position_fit():
    """A chain measured by its tip position only [m]: the channels are the simulator's tip position,
    and a bottom-module wire's transformation-temperature shift is recovered from them."""
    chain = SpineLayout.chain(2)
    truth = chain.with_wire_values([{"T_shift": 5.0}] + [{}] * 7)
    t = np.arange(0.0, 30.05, 0.1)
    v = np.zeros((t.size, 8))
    v[t < 15.0, 0] = 3.2 * chain.voltage_scale[0]
    clean = synthetic_spatial_experiment(
        truth, t, v, channels=("tip_x", "tip_y", "tip_z"), noise={"tip": 1e-9}
    )
    ref = simulate_spatial(t[-1], v[:-1], layout=truth, dt=0.1)
    np.testing.assert_allclose(clean.measured["tip_x"], ref.tip_position[:, 0], atol=1e-8)
    assert np.ptp(clean.measured["tip_x"]) > 0.02  # the drive moves the tip by centimetres
    exp = synthetic_spatial_experiment(truth, t, v, channels=("tip_x", "tip_y", "tip_z"), noise={"tip": 1e-3})
    res = fit([exp], ["wire0.T_shift"], chain, seed=0, n_starts=1, cma_evals=24, max_nfev=8, progress=False)
    assert abs(res.value("wire0.T_shift") - 5.0) < 0.5, res.report()
    assert res.is_identified("wire0.T_shift")
