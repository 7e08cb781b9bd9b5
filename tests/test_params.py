"""Parameter dataclasses: defaults are MODEL.md §7, bad values raise ValueError naming the field."""

import dataclasses
import math

import numpy as np
import pytest

from spine_gym.params import ModelParams, SolverOptions, alternative, field_names
from spine_gym.physics import columns as L


def test_baseline_derived_constants_match_model_md():
    p = ModelParams()
    # MODEL.md §7: Δη = 4.2860e5 J/(m^3 K), Δu = 1.4253e8 J/m^3; §4.7: I = 7.653e-9 m^4; §7: L_ref = 0.43893 m
    assert p.delta_eta == pytest.approx(4.2860e5, rel=1e-4)
    assert p.delta_u == pytest.approx(1.4253e8, rel=1e-4)
    assert p.I_tube == pytest.approx(7.653e-9, rel=1e-3)
    assert p.L_ref == pytest.approx(0.43893, rel=1e-4)
    assert p.wire_area == pytest.approx(1.9635e-7, rel=1e-4)
    # §3.10: seed's initial fractions 0.9528 / 0.0472
    assert p.x_plus0 == pytest.approx(0.9528, abs=1e-4)
    # Δβ = 0 at 332.5 K (§7)
    assert p.delta_u / p.delta_eta == pytest.approx(332.5, abs=0.1)


def test_alternative_preset():
    p = alternative()
    assert (p.alpha, p.sigma_A_low, p.sigma_A_high) == (60.0, 220e6, 850e6)
    assert p.E_t == ModelParams().E_t


@pytest.mark.parametrize(
    "field, value",
    [
        ("E_t", -1.0),
        ("alpha", float("nan")),
        ("a", 0.0),
        ("n_w", 0),
        ("n_w", 1.5),
        ("tau", math.inf),
        ("d", "thick"),
    ],
)
def test_bad_model_values_name_the_field_and_range(field, value):
    with pytest.raises(ValueError) as exc:
        ModelParams(**{field: value})
    msg = str(exc.value)
    assert field in msg and repr(value) in msg


def test_range_message_states_bounds():
    with pytest.raises(ValueError, match=r"E_t must be in \[100000, 1e\+12\], got -5"):
        ModelParams(E_t=-5)


def test_cross_field_constraints():
    with pytest.raises(ValueError, match="D_i"):
        ModelParams(D_i=0.03)
    with pytest.raises(ValueError, match="eps_T"):
        ModelParams(eps_T=0.005)  # ε_T must exceed Δσ/E_M (§3.1)
    with pytest.raises(ValueError, match="L0"):
        ModelParams(L0=0.3)
    with pytest.raises(ValueError, match="T_high"):
        ModelParams(T_high=300.0)


def test_frozen_and_replace_revalidates():
    p = ModelParams()
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.a = 0.01  # type: ignore[misc]
    q = p.replace(a=0.006)
    assert q.a == 0.006 and p.a == 0.014
    with pytest.raises(ValueError, match="unknown ModelParams field"):
        p.replace(wire_offset=0.01)
    with pytest.raises(ValueError, match="a must be"):
        p.replace(a=-1.0)
    assert "a" in field_names() and "n_w" in field_names()


def test_solver_options_validation():
    with pytest.raises(ValueError, match="method must be one of"):
        SolverOptions(method="secant")
    with pytest.raises(ValueError, match="step_c"):
        SolverOptions(step_c=0.0)
    with pytest.raises(ValueError, match="tol_moment"):
        SolverOptions(tol_moment=-1e-9)
    ks = SolverOptions(method="bisect").to_kernel()
    assert ks[L.S_METHOD] == L.METHOD_BISECT and ks.shape == (L.KS_SIZE,)


def test_to_kernel_layout():
    p = ModelParams(n_w=2, a=0.01)
    kp = p.to_kernel()
    assert kp.shape == (L.KP_SIZE,) and kp.dtype == np.float64 and np.all(np.isfinite(kp))
    assert kp[L.K_NW] == 2.0 and kp[L.K_A] == 0.01
    assert kp[L.K_ASV] == pytest.approx(40.0 * 8000.0)  # α S_V with S_V = 4/d = 8000 1/m
    assert kp[L.K_EI] == pytest.approx(25e6 * p.I_tube)
