"""Per-wire material values of a spatial layout (WireGroup lam_scale, T_shift, eps0).

Each value is checked against its definition in terms of ModelParams fields: a value applied to
every wire alike must give the spine that the corresponding params change gives (T_shift: T_low
and T_high moved together, MODEL.md §3.1; lam_scale: λ_A and λ_M scaled; eps0: the params'
pre-strain), and a resistivity scale k must heat a wire at voltage √k·U exactly as the unscaled
wire at U (Joule heating U²/(λ L0²), MODEL.md §3.7).
"""

import numpy as np
import pytest

from spine_gym import ModelParams, SolverOptions, SpineLayout, WireGroup
from spine_gym.simulate_spatial import simulate_spatial


def _drive(nw: int, volts=(3.2, 0.0, 0.0, 2.4)):
    """Wire 0 on for 12 s, wire 3 from 6 s to 18 s (a bend in both planes that swings back)."""

    def v(t):
        out = np.zeros(nw)
        out[0] = volts[0] if t < 12.0 else 0.0
        out[3] = volts[3] if 6.0 <= t < 18.0 else 0.0
        return out

    return v


def _run(layout, volts=(3.2, 0.0, 0.0, 2.4), duration=25.0):
    return simulate_spatial(duration, _drive(layout.n_wires, volts), layout=layout, dt=0.1)


def _uniform(layout, **values):
    return layout.with_wire_values([dict(values)] * layout.n_wires)


def test_default_wire_values_are_the_params():
    lay = SpineLayout.seed()
    assert lay.wire_values == [{"lam_scale": 1.0, "T_shift": 0.0, "eps0": 0.048}] * 4


def test_uniform_T_shift_is_the_params_T_shift():
    p = ModelParams()
    s = 6.0
    a = _run(_uniform(SpineLayout.seed(p), T_shift=s))
    b = _run(SpineLayout.seed(p.replace(T_low=p.T_low + s, T_high=p.T_high + s)))
    assert np.max(np.abs(a.tip_bending_deg[-1])) > 1.0  # the drive bends the spine
    np.testing.assert_allclose(a.tip_bending_deg, b.tip_bending_deg, atol=1e-6, rtol=0)
    np.testing.assert_allclose(a.temperature, b.temperature, atol=1e-6, rtol=0)


def test_uniform_lam_scale_is_the_params_resistivities():
    p = ModelParams()
    k = 1.1
    a = _run(_uniform(SpineLayout.seed(p), lam_scale=k))
    b = _run(SpineLayout.seed(p.replace(lam_A=k * p.lam_A, lam_M=k * p.lam_M)))
    np.testing.assert_allclose(a.tip_bending_deg, b.tip_bending_deg, atol=1e-6, rtol=0)
    np.testing.assert_allclose(a.resistance, b.resistance, rtol=1e-9)


def test_uniform_eps0_is_the_params_pre_strain():
    p = ModelParams()
    a = _run(_uniform(SpineLayout.seed(p), eps0=0.04))
    b = _run(SpineLayout.seed(p.replace(eps0=0.04)))
    np.testing.assert_allclose(a.tip_bending_deg, b.tip_bending_deg, atol=1e-6, rtol=0)
    np.testing.assert_allclose(a.strain, b.strain, atol=1e-12, rtol=0)


def test_lam_scale_of_one_wire_is_its_joule_heating():
    """Wire 0 with resistivity × k at √k·U heats and bends exactly as the nominal wire at U."""
    k = 1.1
    lay = SpineLayout.seed()
    scaled = lay.with_wire_values([{"lam_scale": k}, {}, {}, {}])
    a = _run(scaled, volts=(3.2 * np.sqrt(k), 0, 0, 2.4))
    b = _run(lay)
    np.testing.assert_allclose(a.temperature, b.temperature, atol=1e-6, rtol=0)
    np.testing.assert_allclose(a.tip_bending_deg, b.tip_bending_deg, atol=1e-6, rtol=0)
    np.testing.assert_allclose(a.resistance[:, 0], k * b.resistance[:, 0], rtol=1e-9)
    np.testing.assert_allclose(a.resistance[:, 1:], b.resistance[:, 1:], rtol=1e-9)


def test_one_wire_shift_acts_on_that_wire_only():
    """A wire 0 that transforms 8 K higher contracts later: its bend (b1) lags while it is heated
    (MODEL.md §3.1: σ_A(T) lower at every T), and it is hotter at that time (less latent heat
    absorbed so far)."""
    lay = SpineLayout.seed()
    late = _run(lay.with_wire_values([{"T_shift": 8.0}, {}, {}, {}]))
    nominal = _run(lay)
    i = int(round(10.0 / 0.1))  # wire 0 alone, mid-contraction
    assert late.tip_bending_deg[i, 0] < nominal.tip_bending_deg[i, 0] - 3.0
    assert late.temperature[i, 0] > nominal.temperature[i, 0]


def test_continued_run_equals_one_run_with_wire_values():
    lay = SpineLayout.seed().with_wire_values(
        [{"T_shift": -4.0}, {"lam_scale": 1.1}, {"T_shift": 3.0, "eps0": 0.045}, {"T_shift": 6.0}]
    )
    # stepped to every output (no dense output across the split, MODEL.md §6.5): the state's rate
    # cache, keyed by each wire's Δu offset, makes the continued run the same numbers
    kw = dict(layout=lay, dt=0.1, solver=SolverOptions(dense_output=False))
    whole = simulate_spatial(20.0, _drive(4), **kw)
    first = simulate_spatial(8.0, _drive(4), **kw)
    rest = simulate_spatial(12.0, lambda t: _drive(4)(t + 8.0), state=first.final_state, **kw)
    np.testing.assert_allclose(whole.tip_bending_deg[80:], rest.tip_bending_deg, atol=1e-12, rtol=0)


def test_chain_takes_wire_values_per_wire():
    lay = SpineLayout.chain(2)
    vals = [{"T_shift": float(j)} for j in range(8)]
    out = lay.with_wire_values(vals)
    assert [v["T_shift"] for v in out.wire_values] == list(range(8))


@pytest.mark.parametrize(
    "values, match",
    [
        ([{}] * 3, "sequence of 4 mappings"),
        ([{"lam_scale": 0.0}, {}, {}, {}], "lam_scale must be in"),
        ([{"T_shift": 500.0}, {}, {}, {}], "T_shift must be in"),
        ([{"eps0": -0.1}, {}, {}, {}], "eps0 must be in"),
        ([{"rho": 1.0}, {}, {}, {}], "keys among"),
    ],
)
def test_bad_wire_values_raise(values, match):
    with pytest.raises(ValueError, match=match):
        SpineLayout.seed().with_wire_values(values)


def test_wire_group_validates_its_values():
    with pytest.raises(ValueError, match="T_shift must be in"):
        WireGroup(0.0, 0.014, 1, T_shift=float("nan"))
