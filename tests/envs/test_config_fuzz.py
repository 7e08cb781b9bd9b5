"""Every configuration an env accepts resets and steps on every seed (single and vector env, every
id); every configuration it refuses is refused with a ValueError at construction.

Hypothesis draws keyword arguments over the whole accepted space of each id's configuration
(voltages, periods, durations, load ranges and counts, domain randomisation of any fields, sensor
noise and delay, reward weights, targets), with some draws past the accepted ranges. An accepted
configuration must then reset on several seeds and step (through autoresets in the vector env)
with finite observations inside the observation space, finite rewards and no exception: a reset
that raises would do so inside ``step`` of an autoresetting vector env.
"""

import warnings

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import spine_gym  # noqa: F401 - registers the env ids
from spine_gym.buckling import critical_load
from spine_gym.envs.targets import TARGET_KINDS
from spine_gym.envs.targets_spatial import BEND_KINDS
from spine_gym.params import DYNAMICS_ONLY_FIELDS, ModelParams, SolverOptions, field_names
from spine_gym.physics import columns as L
from spine_gym.physics.planar import columns as PL
from spine_gym.physics.planar.integrate import init_state

IDS = ("SmaSpine-v0", "SmaSpine3D-v0", "SmaSpineChain-v0")
EXAMPLES = {"SmaSpine-v0": 25, "SmaSpine3D-v0": 20, "SmaSpineChain-v0": 15}
FIELDS = [f for f in field_names() if f not in ("n_w", "n_seg")]
NOMINAL = ModelParams()


def _pair(lo, hi):
    return st.tuples(st.floats(lo, hi), st.floats(lo, hi)).map(sorted).map(tuple)


def _int_pair(lo, hi):
    return st.tuples(st.integers(lo, hi), st.integers(lo, hi)).map(sorted).map(tuple)


_DR = st.one_of(
    st.booleans(),
    st.dictionaries(  # any fields, scaled about the nominal value (some draws leave the model's range)
        st.sampled_from(FIELDS),
        st.tuples(st.floats(0.3, 1.0), st.floats(1.0, 3.0)),
        max_size=4,
    ).map(lambda d: {k: (getattr(NOMINAL, k) * lo, getattr(NOMINAL, k) * hi) for k, (lo, hi) in d.items()}),
)
_NOISE = st.one_of(
    st.none(),
    st.dictionaries(st.sampled_from(("angle", "temperature", "resistance")), st.floats(0.0, 1e3), max_size=3),
)


@st.composite
def configs(draw, env_id):
    """Keyword arguments of ``env_id`` over its accepted space (and a little past it)."""
    period = draw(st.sampled_from((0.05, 0.1, 0.2)))
    kw = {
        "v_max": draw(st.floats(0.05, 8.0)),
        "control_period": period,
        "physics_dt": draw(st.sampled_from((None, period, period / 2, period / 4))),
        "episode_duration": period * draw(st.integers(1, 6)),
        "target_preview": draw(st.floats(0.0, 600.0)),
        "tip_force_range": draw(st.one_of(st.none(), _pair(0.0, 20.0))),
        "tip_force_count": draw(_int_pair(0, 100)),
        "tip_force_duration": draw(_pair(1e-6, 86400.0)),
        "payload_range": draw(st.one_of(st.none(), _pair(0.0, 1.0))),
        "domain_randomization": draw(_DR),
        "sensor_noise": draw(_NOISE),
        "sensor_delay": draw(st.integers(0, 1000)),
        "temperature_limit": draw(st.floats(300.0, 2000.0)),
        "error_scale": draw(st.floats(1e-3, 1e6)),
        "energy_weight": draw(st.floats(0.0, 1e6)),
        "cost_weight": draw(st.floats(0.0, 1e6)),
    }
    if env_id == "SmaSpine-v0":
        kw["target_range"] = draw(_pair(-60.0, 60.0))
        kw["target_kinds"] = tuple(draw(st.sets(st.sampled_from(TARGET_KINDS), min_size=1)))
        kw["sine_period_range"] = draw(_pair(2.0 * period, 1e6))
    else:
        kw["target_kinds"] = tuple(draw(st.sets(st.sampled_from(BEND_KINDS), min_size=1)))
        kw["target_period_range"] = draw(_pair(2.0 * period, 1e6))
    return kw


def _check_obs(space, obs, where):
    assert np.all(np.isfinite(obs)), f"{where}: non-finite observation {obs}"
    assert space.contains(obs.astype(space.dtype)), f"{where}: observation outside the space {obs}"


def _run(env_id, kw):
    """Build the single env (None if refused) and, if accepted, reset/step it and a vector env."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            env = gym.make(env_id, **kw)
        except ValueError:  # refused at construction: the vector env must refuse it too
            with pytest.raises(ValueError):
                gym.make_vec(env_id, num_envs=2, **kw)
            return None
        rng = np.random.default_rng(0)
        for seed in (0, 1, 2):
            obs, _ = env.reset(seed=seed)
            _check_obs(env.observation_space, obs, f"reset seed {seed}")
            for _ in range(3):
                obs, reward, term, trunc, _ = env.step(rng.uniform(-1, 1, env.action_space.shape))
                _check_obs(env.observation_space, obs, f"step seed {seed}")
                assert np.isfinite(reward)
                if term or trunc:
                    break
        venv = gym.make_vec(env_id, num_envs=2, **kw)
        obs, _ = venv.reset(seed=3)
        for _ in range(8):  # episodes of 1 to 6 steps: autoresets inside step
            _check_obs(venv.observation_space, obs, "vector step")
            obs, reward, _, _, _ = venv.step(rng.uniform(-1, 1, venv.action_space.shape))
            assert np.all(np.isfinite(reward))
        _check_obs(venv.observation_space, obs, "vector step")
        return env


def _fuzz(env_id):
    @settings(
        max_examples=EXAMPLES[env_id],
        deadline=None,
        derandomize=True,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )
    @given(configs(env_id))
    def check(kw):
        _run(env_id, kw)

    check()


@pytest.mark.parametrize("env_id", IDS)
def test_every_accepted_configuration_resets_and_steps_on_every_seed(env_id):
    _fuzz(env_id)


@pytest.mark.parametrize("env_id", IDS[:2])  # the chain holds any payload_range up to 1 kg (below)
def test_heaviest_payloads_just_inside_and_past_the_limit(env_id):
    """The edge the fuzz rarely hits: a payload range up to just below the limit the refusal names
    resets on 20 seeds (with default domain randomisation too); just past it, refused."""
    for dr in (False, True):
        with pytest.raises(ValueError, match=r"payload_range must have high <= ") as e:
            gym.make(env_id, payload_range=(0.0, 1.0), domain_randomization=dr)
        limit = float(str(e.value).split("<= ")[1].split(" kg")[0])
        env = gym.make(env_id, payload_range=(0.999 * limit, 0.999 * limit), domain_randomization=dr)
        for seed in range(20):
            env.reset(seed=seed)
        with pytest.raises(ValueError, match=r"payload_range"):
            gym.make(env_id, payload_range=(0.0, 1.001 * limit), domain_randomization=dr)


def test_payload_range_past_buckling_is_refused_at_construction():
    """``payload_range=(0, 1)`` used to pass, then 11 of 20 seeded resets raised; now it is refused
    at once, naming the parameter, the limit and the value, single and vector env."""
    for env_id in ("SmaSpine-v0", "SmaSpine3D-v0"):
        for num_envs in (None, 2):
            with pytest.raises(
                ValueError, match=r"^payload_range must have high <= 0\.5699\d* kg .*\(0\.0, 1\.0\)$"
            ):
                if num_envs is None:
                    gym.make(env_id, payload_range=(0.0, 1.0))
                else:
                    gym.make_vec(env_id, num_envs=num_envs, payload_range=(0.0, 1.0))
    gym.make("SmaSpineChain-v0", payload_range=(0.0, 1.0)).reset(seed=0)  # three shorter modules hold it


def test_the_limit_is_the_linearised_buckling_payload_of_the_straight_spine():
    """The reset's own solve (what the refusal uses) fails exactly past MODEL.md §4.9's critical
    payload of the straight spine (``spine_gym.buckling.critical_load``), at the nominal and at a
    softer tube."""
    for params in (NOMINAL, NOMINAL.replace(E_t=0.8 * NOMINAL.E_t)):
        p_crit = critical_load(params).payload
        with pytest.raises(ValueError) as e:
            gym.make("SmaSpine-v0", params=params, payload_range=(0.0, 1.0))
        limit = float(str(e.value).split("<= ")[1].split(" kg")[0])
        assert limit == pytest.approx(p_crit, rel=1e-5)


def test_domain_randomization_that_can_draw_an_invalid_set_is_refused():
    """Each bound valid alone, but E_M above E_A at a corner of the box; a tube modulus range whose
    low end cannot stand under its own weight: resets raised on 2-10 of 20 seeds before."""
    dr = {"E_M": (20e9, 60e9), "E_A": (50e9, 90e9)}
    for env_id in IDS:
        with pytest.raises(ValueError, match=r"domain_randomization can draw an invalid parameter set"):
            gym.make(env_id, domain_randomization=dr)
        with pytest.raises(ValueError, match=r"^domain_randomization .*corner \{'E_t': 200000\.0\}"):
            gym.make(env_id, domain_randomization={"E_t": (2e5, 25e6)})  # too soft to stand at its low end


@pytest.mark.parametrize("field", sorted(DYNAMICS_ONLY_FIELDS))
def test_dynamics_only_fields_do_not_change_the_initial_state(field):
    """The fields the corner check leaves out give a bit-identical initial state and status at
    payloads just below and past the buckling limit."""
    ks = SolverOptions().to_kernel()
    p_crit = critical_load(NOMINAL).payload

    def solve(params, payload):
        state = np.zeros(PL.state_size(params.n_seg))
        vforce = np.zeros((params.n_seg, 2))
        vforce[0, 1] = -payload * params.g
        return init_state(state, params.to_kernel(), ks, vforce), state

    for payload in (0.0, 0.999 * p_crit, 1.001 * p_crit):
        ref_status, ref = solve(NOMINAL, payload)
        for factor in (0.5, 2.0):
            status, state = solve(NOMINAL.replace(**{field: getattr(NOMINAL, field) * factor}), payload)
            assert status == ref_status and np.array_equal(state, ref)
        assert (ref_status == L.OK) == (payload < p_crit)
