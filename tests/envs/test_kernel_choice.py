"""The vector env's online choice between its serial and parallel kernel (envs/_kernel_choice.py).

Switching kernels must change nothing but speed (the kernels are bit-identical): a run whose
kernel flips at every probe, mid-episode, through autoresets, equals a serial run bit for bit.
The chooser itself is checked on a fake clock: it moves to the faster kernel, stays (with rarer
probes) on the faster one, leaves a kernel that became slow, and a bad probe costs one step.
"""

import os
import pickle
import subprocess
import sys
import time

import numpy as np
import pytest
from repo import ROOT

import spine_gym  # noqa: F401 - registers the envs
from spine_gym.envs import SmaSpineVectorEnv
from spine_gym.envs._kernel_choice import KernelChoice, step_clock
from spine_gym.envs.spine_vector_env import PARALLEL_MIN_ENVS

KW = {  # short episodes (autoresets), every source of randomness on
    "episode_duration": 3.0,
    "tip_force_count": (1, 3),
    "domain_randomization": True,
    "sensor_noise": {"angle": 0.2, "temperature": 0.5, "resistance": 0.01},
    "sensor_delay": 1,
}


class CostClock:
    """A fake clock for :class:`KernelChoice`: each step costs ``cost(parallel, step)`` per row."""

    def __init__(self, cost, rows: int = 1):
        self.cost, self.rows, self.t, self.calls, self.step = cost, rows, 0.0, 0, 0
        self.choice: KernelChoice | None = None

    def __call__(self, parallel: bool) -> float:
        self.calls += 1
        if self.calls % 2 == 0:  # the stop() call of a step
            self.t += self.rows * self.cost(self.choice.parallel, self.step)
            self.step += 1
        return self.t


def run(choice: KernelChoice, clock: CostClock, n_steps: int) -> list[bool]:
    """The kernel of each of ``n_steps`` steps."""
    clock.choice = choice
    used = []
    for _ in range(n_steps):
        used.append(choice.parallel)
        choice.start()
        choice.stop(clock.rows)
    return used


def test_moves_to_the_faster_kernel_and_probes_less_and_less():
    clock = CostClock(lambda par, k: 5.0 if par else 1.0)  # the parallel kernel 5x slower
    choice = KernelChoice(parallel=True, clock=clock)
    used = run(choice, clock, 4000)
    assert choice.current is False and choice.switches == 1
    first_serial = used.index(False)
    assert first_serial <= 32 + 1  # the first probe (first step of each kernel not counted)
    assert all(not u for u in used[first_serial : first_serial + 32])
    # later probes of the slow kernel end after one counted step, ever rarer (interval doubles to 1024)
    assert choice.probes <= 10 and sum(used[first_serial:]) <= 2 * choice.probes
    assert sum(used[first_serial:]) / len(used[first_serial:]) < 0.005


def test_stays_on_the_faster_kernel():
    clock = CostClock(lambda par, k: 1.0 if par else 1.8)
    choice = KernelChoice(parallel=True, clock=clock)
    used = run(choice, clock, 3000)
    assert choice.switches == 0 and choice.current is True
    assert 1.0 - sum(used) / len(used) < 0.02  # serial probes are < 2 % of the steps


def test_leaves_a_kernel_that_became_slow_and_comes_back():
    """Load that starts mid-run (the parallel kernel 6x slower from step 2000) is seen within a probe
    of the rise; when it stops (step 4000) the chooser returns to the parallel kernel."""

    def cost(par, k):
        if par:
            return 6.0 if 2000 <= k < 4000 else 1.0
        return 1.8

    clock = CostClock(cost)
    choice = KernelChoice(parallel=True, clock=clock)
    used = run(choice, clock, 6000)
    assert used[1999] is True and used.index(False, 2000) < 2000 + 16
    assert sum(used[2000 + 32 : 3990]) <= 6  # one-step probes of the slow kernel, ever rarer
    assert used[5999] is True and choice.switches == 2
    assert used.index(True, 4000) < 4000 + 1024 + 8  # the next probe after at most max_interval


def test_a_small_difference_does_not_switch():
    clock = CostClock(lambda par, k: 1.0 if par else 0.95)  # within the 10 % margin
    choice = KernelChoice(parallel=True, clock=clock)
    run(choice, clock, 2000)
    assert choice.switches == 0


@pytest.mark.parametrize(
    "kw",
    [{"probe": 0}, {"probe": 20, "window": 16}, {"first_interval": 0},
     {"first_interval": 64, "max_interval": 32}, {"margin": 1.0}, {"abort": 1.0}, {"rise": 0.5}],
)  # fmt: skip
def test_bad_settings_raise(kw):
    with pytest.raises(ValueError, match="KernelChoice needs"):
        KernelChoice(**kw)


def test_default_kernel_choice_by_num_envs_and_parallel():
    assert SmaSpineVectorEnv(3).kernel_choice is None and not SmaSpineVectorEnv(3).parallel
    auto = SmaSpineVectorEnv(PARALLEL_MIN_ENVS)
    assert isinstance(auto.kernel_choice, KernelChoice) and auto.parallel  # starts on the parallel kernel
    assert isinstance(SmaSpineVectorEnv(3, parallel="auto").kernel_choice, KernelChoice)
    assert SmaSpineVectorEnv(PARALLEL_MIN_ENVS, parallel=True).kernel_choice is None
    fixed = SmaSpineVectorEnv(PARALLEL_MIN_ENVS, parallel=np.False_)
    assert fixed.kernel_choice is None and not fixed.parallel


@pytest.mark.parametrize("bad", ["AUTO", "serial", 1, 0.0, [True]])
def test_bad_parallel_raises(bad):
    with pytest.raises(ValueError, match="parallel must be True, False, None or 'auto'"):
        SmaSpineVectorEnv(4, parallel=bad)


def rollout(venv, n_steps: int, n: int):
    obs, _ = venv.reset(seed=5)
    out = [obs]
    acts = np.random.default_rng(3).uniform(-1.3, 1.3, size=(n_steps, n, 2)).astype(np.float32)
    for a in acts:
        obs, rew, term, trunc, info = venv.step(a)
        out += [obs, rew, term, trunc, info["status"], info["temperature"]]
    return out


def test_switching_kernels_mid_episode_is_bit_identical_to_serial():
    n, n_steps = 16, 70  # 30-step episodes: switches mid-episode and across autoresets
    ref = rollout(SmaSpineVectorEnv(n, parallel=False, **KW), n_steps, n)
    venv = SmaSpineVectorEnv(n, parallel="auto", **KW)
    # the kernel in use always looks 3x slower than the other: every probe switches
    clock = CostClock(lambda par, k: 3.0 if par == venv.kernel_choice.current else 1.0)
    venv.kernel_choice = clock.choice = KernelChoice(
        window=2, probe=1, first_interval=2, max_interval=2, clock=clock
    )
    got = rollout(venv, n_steps, n)
    choice = venv.kernel_choice
    assert choice.switches >= 10 and min(choice.steps) >= 20
    assert len(got) == len(ref)
    for a, b in zip(got, ref, strict=True):
        assert np.array_equal(a, b)


SHOW_POLICY = (
    "import os\n"
    "from spine_gym.envs._kernel_choice import launch_threads\n"
    "print(launch_threads(), os.environ.get('OMP_WAIT_POLICY'))\n"
)


def _launch(extra_env: dict) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}
    return subprocess.run(
        [sys.executable, "-c", SHOW_POLICY],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
        env={**env, "OMP_DISPLAY_ENV": "TRUE", **extra_env},
    )


def test_threads_start_with_sleeping_workers_and_the_environment_is_restored():
    """libgomp prints its settings at load with OMP_DISPLAY_ENV: PASSIVE, unless the user chose."""
    r = _launch({})
    assert r.returncode == 0, r.stderr
    if not r.stdout.startswith("omp"):
        pytest.skip(f"numba's threading layer is {r.stdout.split()[0]}, not OpenMP")
    assert r.stdout.split() == ["omp", "None"]  # the process environment is as before
    assert "OMP_WAIT_POLICY = 'PASSIVE'" in r.stderr
    r = _launch({"OMP_WAIT_POLICY": "ACTIVE"})
    assert r.stdout.split() == ["omp", "ACTIVE"] and "OMP_WAIT_POLICY = 'ACTIVE'" in r.stderr


def test_a_pickled_env_keeps_its_chooser_and_steps_as_the_original():
    n = PARALLEL_MIN_ENVS
    venv = SmaSpineVectorEnv(n, **KW)
    venv.reset(seed=2)
    a = np.random.default_rng(1).uniform(-1, 1, size=(n, 2)).astype(np.float32)
    venv.step(a)
    clone = pickle.loads(pickle.dumps(venv))
    assert isinstance(clone.kernel_choice, KernelChoice) and clone.kernel_choice is not venv.kernel_choice
    assert clone.kernel_choice.steps == venv.kernel_choice.steps == [0, 1]
    obs = [env.step(a)[0] for env in (venv, clone)]
    assert np.array_equal(obs[0], obs[1]) and clone.kernel_choice.steps == [0, 2]


def test_step_clock_times_serial_steps_in_thread_cpu_time():
    """A serial step is timed in the calling thread's CPU time: a sleep (the thread waiting, as when
    spinning OpenMP workers or another process hold its core) does not count; in wall time it does."""
    t = [step_clock(False), step_clock(True)]
    time.sleep(0.05)
    assert step_clock(False) - t[0] < 0.01 and step_clock(True) - t[1] >= 0.05
