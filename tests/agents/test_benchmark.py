"""spine_gym.agents.benchmark and benchmark_run: the table's statistics against rliable and hand-checked
values, time to the PID's level, resuming, bad arguments, and the --quick pipeline end to end."""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import time

import numpy as np
import pytest
from repo import ROOT
from rliable import library as rly
from rliable import metrics as rly_metrics

from spine_gym.agents import benchmark as bm
from spine_gym.agents import benchmark_run as br
from spine_gym.agents import benchmark_stats as stats
from spine_gym.agents.runtime import load_policy, validation_metrics
from spine_gym.agents.training import action_noise, resolve_config
from spine_gym.agents.zoo_config import ALGOS, ENV_IDS, SB3_ALGOS, load_hyperparams

ENV = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}


# --------------------------------------------------------------------------- statistics
def test_iqm_and_ci_are_rliables_own_on_the_same_data():
    x = np.random.default_rng(1).normal(5.0, 2.0, size=7)
    np.random.seed(3)
    point, interval = rly.get_interval_estimates(
        {"a": x.reshape(-1, 1)}, lambda s: np.array([rly_metrics.aggregate_iqm(s)]), reps=500
    )
    before = np.random.get_state()[1].copy()
    iqm, lo, hi = stats.iqm_interval(x, reps=500, seed=3)
    assert np.array_equal(np.random.get_state()[1], before)  # the caller's global generator is untouched
    assert iqm == point["a"][0] and (lo, hi) == (interval["a"][0, 0], interval["a"][1, 0])
    assert lo < iqm < hi


def test_iqm_and_ci_on_hand_checkable_sets():
    assert stats.iqm_interval(np.arange(1.0, 9.0))[0] == pytest.approx(4.5)  # mean of 3, 4, 5, 6
    assert stats.iqm_interval([0.0, 10, 10, 10, 10, 10, 10, 100])[0] == pytest.approx(10.0)  # outliers cut
    assert stats.iqm_interval([5.0, 5.0, 5.0, 5.0]) == (5.0, 5.0, 5.0)  # no spread, no interval
    assert stats.iqm_interval([2.5]) == (2.5, 2.5, 2.5)  # one seed
    iqm, lo, hi = stats.iqm_interval(np.arange(1.0, 9.0), reps=1000)
    assert 1.0 <= lo < iqm < hi <= 8.0


def test_curve_intervals_are_rliables_per_evaluation_iqm():
    rng = np.random.default_rng(2)
    curves = rng.normal(size=(5, 4)) + np.arange(4)
    np.random.seed(0)
    point, interval = rly.get_interval_estimates(
        {"a": curves[:, None, :]},
        lambda s: np.array([rly_metrics.aggregate_iqm(s[..., k]) for k in range(s.shape[-1])]),
        reps=300,
    )
    iqm, lo, hi = stats.curve_intervals(curves, reps=300, seed=0)
    assert np.array_equal(iqm, point["a"]) and np.array_equal(lo, interval["a"][0])
    assert np.array_equal(hi, interval["a"][1])
    shifted = np.arange(1.0, 9.0)[:, None] + np.array([0.0, 10.0, 20.0])  # 8 runs, 3 evaluations
    assert np.allclose(stats.curve_intervals(shifted, reps=200)[0], [4.5, 14.5, 24.5])


def test_bad_scores_are_rejected():
    for bad in ([], [1.0, float("nan")], [float("inf")]):
        with pytest.raises(ValueError, match="scores"):
            stats.iqm_interval(bad)
    with pytest.raises(ValueError, match="curves"):
        stats.curve_intervals(np.ones(3))


def test_time_to_pid_level_on_a_synthetic_curve():
    steps, wall = [0, 100, 200, 300], [0.0, 1.5, 3.0, 4.5]
    rmse = [10.0, 6.0, 4.9, 5.5]
    assert stats.time_to_level(steps, wall, rmse, 5.0) == (200, 3.0)  # first at or below, not the best
    assert stats.time_to_level(steps, wall, rmse, 6.0) == (100, 1.5)  # "at" counts
    assert stats.time_to_level(steps, wall, rmse, 4.0) == (None, None)
    assert stats.time_to_level(steps, wall, rmse, 50.0) == (0, 0.0)


# --------------------------------------------------------------------------- steps to the PID's level
STEPS = [0, 10_000, 20_000, 30_000, 40_000, 50_000]


def test_steps_to_level_of_a_curve_that_reaches_it():
    rmse = [12.0, 8.0, 5.0, 4.1, 3.9, 3.5]  # PID at 4.0
    assert stats.steps_to_level(STEPS, rmse, 4.0) == 40_000
    assert stats.steps_to_level(STEPS, rmse, 5.0) == 20_000  # at the level counts
    assert stats.steps_to_level(STEPS, rmse, 20.0) == 0  # already there untrained


def test_steps_to_level_of_a_curve_that_never_reaches_it():
    rmse = [12.0, 8.0, 6.0, 5.0, 4.5, 4.01]
    assert stats.steps_to_level(STEPS, rmse, 4.0) is None
    assert stats.steps_to_level(STEPS, [math.nan] * 6, 4.0) is None  # a NaN evaluation is no hit


def test_steps_to_level_of_a_noisy_curve_is_its_first_crossing():
    rmse = [12.0, 3.9, 4.6, 4.2, 3.8, 4.3]  # dips below at 10 k, back above, below again at 40 k
    assert stats.steps_to_level(STEPS, rmse, 4.0) == 10_000  # reaching the level, not staying there
    assert stats.time_to_level(STEPS, [0, 1, 2, 3, 4, 5], rmse, 4.0) == (10_000, 1.0)


def test_steps_to_level_refuses_bad_curves():
    with pytest.raises(ValueError, match="one length"):
        stats.steps_to_level([0, 1], [1.0], 1.0)
    with pytest.raises(ValueError, match="steps must increase"):
        stats.steps_to_level([0, 2, 1], [3.0, 2.0, 1.0], 1.0)
    with pytest.raises(ValueError, match="level must be a finite"):
        stats.steps_to_level([0, 1], [3.0, 2.0], math.nan)


def test_the_iqm_over_seeds_counts_runs_that_never_reach_the_level():
    reached = [20_000, 30_000, 40_000, 50_000, 60_000]
    iqm, lo, hi = stats.censored_iqm_interval(reached, reps=500)
    assert iqm == pytest.approx(40_000) and 20_000 <= lo <= iqm <= hi <= 60_000  # all reached: plain IQM
    assert stats.censored_iqm_interval(reached, reps=500) == (iqm, lo, hi)  # reproducible
    # one of five never: it is the first cut from the top, not dropped (dropping it would give 35 k)
    iqm, lo, hi = stats.censored_iqm_interval([20_000, 30_000, 40_000, 50_000, None], reps=500)
    assert iqm == pytest.approx(40_000) and hi == math.inf and math.isfinite(lo)
    # two of five never: the middle half holds one, the IQM is "not reached", never a made-up number
    assert stats.censored_iqm_interval([20_000, 30_000, 40_000, None, None], reps=500)[0] == math.inf
    assert stats.censored_iqm_interval([None] * 3, reps=200) == (math.inf, math.inf, math.inf)
    with pytest.raises(ValueError, match="values must be"):
        stats.censored_iqm_interval([])
    with pytest.raises(ValueError, match="values must be"):
        stats.censored_iqm_interval([1.0, math.nan])


def test_hardware_time_is_steps_times_the_control_period():
    assert stats.hardware_time(30_000, 0.1) == pytest.approx(3000.0)  # 50 min of a real spine
    assert stats.hardware_time(None, 0.1) is None and stats.hardware_time(math.inf, 0.1) == math.inf
    assert stats.duration(3000.0) == "50.0 min" and stats.duration(math.inf) == stats.NOT_REACHED
    assert stats.steps_cell(30_000) == "30 k" and stats.steps_cell(500) == "500"


def test_a_runs_way_to_the_pid_reads_its_first_evaluation_at_the_level():
    curve = {"step": np.array(STEPS, dtype=float), "rmse": np.array([9.0, 5.0, 3.9, 3.0, 4.5, 3.0]),
             "train_wall_s": np.arange(6.0) * 10, "train_cpu_s": np.arange(6.0) * 8,
             "energy_J": np.array([100.0, 200, 330, 300, 300, 300]),
             "time_over_limit_s": np.array([0.0, 0, 0.7, 0, 0, 0])}  # fmt: skip
    got = bm.to_pid(curve, {"rmse": 4.0, "energy_J": 300.0})
    assert got == {"steps_to_pid": 20_000, "wall_to_pid_s": 20.0, "cpu_to_pid_s": 16.0,
                   "energy_ratio_at_pid": pytest.approx(1.1), "time_over_limit_at_pid_s": 0.7}  # fmt: skip
    assert bm.to_pid(curve, {"rmse": 1.0, "energy_J": 300.0}) == dict.fromkeys(bm.TO_PID_KEYS)


def test_performance_profiles_on_synthetic_runs(tmp_path):
    runs = [{"algo": a, "env_id": e, "seed": k, "final_rmse": r, "final_time_over_limit_s": t}
            for a, r, t in (("good", 2.0, 0.0), ("bad", 8.0, 3.0))
            for e in ("A", "B") for k in range(3)]  # fmt: skip
    runs.append({"algo": "good", "env_id": "C", "seed": 0, "final_rmse": 1.0, "final_time_over_limit_s": 0.0})
    refs = {e: {"pid": {"rmse": 4.0}} for e in ("A", "B", "C")}
    accuracy, over, ids = stats.profile_scores(runs, refs)
    assert ids == ["A", "B"]  # C: only one algorithm ran there
    assert accuracy["good"].shape == (3, 2) and np.all(accuracy["good"] == 2.0)
    assert np.all(accuracy["bad"] == 0.5)
    prof, cis = stats.performance_profiles(accuracy, np.array([0.4, 1.0, 2.0]), reps=200)
    assert prof["good"].tolist() == [1.0, 1.0, 0.0] and prof["bad"].tolist() == [1.0, 0.0, 0.0]
    prof, _ = stats.performance_profiles(over, np.array([0.0, 0.5, 3.0]), reps=200, below=True)
    assert prof["good"].tolist() == [1.0, 1.0, 1.0]
    assert prof["bad"].tolist() == [0.0, 0.0, 1.0]  # at τ counts
    assert stats.plot_profiles(tmp_path / "p.png", runs, refs, reps=200)
    assert (tmp_path / "p.png").stat().st_size > 10_000
    assert not stats.plot_profiles(tmp_path / "q.png", runs, {}, reps=200)
    assert not (tmp_path / "q.png").exists()


def test_envs_v2_is_the_easy_and_hard_tiers_of_v2_and_the_default_stays_v1():
    assert bm.DEFAULT_ENV_IDS == bm.TIER_IDS["v1"] and all(i.endswith("-v1") for i in bm.DEFAULT_ENV_IDS)
    assert bm.TIER_IDS["v2"] == tuple(i.replace("-v1", "-v2") for i in bm.TIER_IDS["v1"])
    args = bm.build_parser().parse_args(["--envs", "v2", "SmaSpineEasy-v2", "SmaSpine-v1", "--algos", "ppo"])
    plan = bm.make_plan(args)
    assert plan.env_ids == [*bm.TIER_IDS["v2"], "SmaSpine-v1"]
    assert {s.env_id for s in plan.specs} == set(plan.env_ids)


def _synthetic_runs():
    runs = []
    for algo, base in (("ppo", 3.0), ("sac", 8.0)):
        for seed in range(5):
            rmse = base + seed
            runs.append({
                "algo": algo, "env_id": "SmaSpine-v0", "seed": seed, "steps": 1000, "wall_s": 60.0 + seed,
                "cpu_s": 50.0, "final_rmse": rmse, "final_energy_J": 100.0 + seed,
                "final_time_over_limit_s": 0.0,
                "steps_to_pid": 500 if rmse <= 5.0 else None, "wall_to_pid_s": 30.0 if rmse <= 5.0 else None,
                "cpu_to_pid_s": 25.0 if rmse <= 5.0 else None,
            })  # fmt: skip
    return runs


def test_table_rows_and_markdown_from_synthetic_runs():
    runs = _synthetic_runs()
    refs = {
        "SmaSpine-v0": {"pid": {"rmse": 5.0, "energy_J": 80.0, "time_over_limit_s": 1.0, "n_episodes": 10}}
    }
    rows = stats.summary_rows(runs, refs, reps=300)
    ppo = next(r for r in rows if r["method"] == "ppo")
    assert (ppo["rmse_iqm"], ppo["rmse_ci_low"], ppo["rmse_ci_high"]) == stats.iqm_interval(
        [3.0, 4.0, 5.0, 6.0, 7.0], reps=300
    )
    assert ppo["rmse_iqm"] == pytest.approx(5.0)  # mean of 4, 5, 6: one of 5 runs cut at each end
    assert ppo["reached_pid"] == 3 and ppo["wall_s_mean"] == pytest.approx(62.0)
    assert next(r for r in rows if r["method"] == "sac")["reached_pid"] == 0
    pid = next(r for r in rows if r["method"] == "pid")
    assert pid["kind"] == "reference" and pid["rmse_iqm"] == 5.0 and pid["rmse_ci_low"] is None
    assert len({tuple(r) for r in rows}) == 1  # one set of columns for the CSV
    # 3 of 5 seeds at 500 steps, 2 never: the middle half holds one that never did, so no number
    assert ppo["steps_to_pid_iqm"] == math.inf and ppo["hardware_to_pid_s_iqm"] is None  # no control period
    md = stats.training_markdown(rows, runs, {"SmaSpine-v0": "deg"})
    assert "| ppo | 5 | 1,000 | 3/5 | not reached [500, not reached] | — | " in md
    assert "| sac | 5 | 1,000 | 0/5 | not reached | — | not reached | not reached |" in md
    assert "| 50 s | 62 s |" in md  # CPU and wall of the budget (means)
    assert "| SmaSpine-v0 | sac | 0 | 1,000 | 60 s | 50 s | 8.00 deg | — | — | — | — | — |" in md


# --------------------------------------------------------------------------- hyperparameters
@pytest.mark.parametrize("algo", ALGOS)
def test_every_algorithm_has_an_entry_for_every_v0_id(algo):
    for env_id in ENV_IDS:
        cfg = resolve_config(algo, env_id)
        assert cfg.n_timesteps > 0 and cfg.n_envs >= 1 and load_hyperparams(algo, env_id)
    noise = action_noise(resolve_config("td3", ENV_IDS[0]), 2)
    assert noise is not None and np.allclose(noise._sigma, 0.1)
    with pytest.raises(ValueError, match="noise_type"):
        action_noise(resolve_config("ppo", ENV_IDS[0], hyperparams={"noise_type": "normal"}), 2)


# --------------------------------------------------------------------------- bad arguments
@pytest.mark.parametrize(
    "argv, message",
    [
        (["--algos", "dqn"], "invalid choice"),
        (["--envs", "CartPole-v9"], "unknown env id"),
        (["-n", "0"], "-n/--n-timesteps must be a positive integer"),
        (["--n-seeds", "0"], "--n-seeds must be a positive integer"),
        (["--eval-freq", "-5"], "--eval-freq must be a positive integer"),
        (["--workers", "0"], "argument --workers: must be an integer >= 1"),
        (["--budget", "SmaSpine-v0:abc"], "--budget takes ID:N"),
        (["--envs", "SmaSpine-v0", "--budget", "SmaSpine3D-v0:100"], "--budget takes ID:N"),
        (["--val-episodes", "2", "--reference-episodes", "3"], "--reference-episodes must be <="),
        (["--references", "lqr"], "unknown reference"),
        (["--bootstrap-reps", "10"], "--bootstrap-reps must be >= 100"),
        (["-n", "x"], "invalid int value"),
        (["--address", "head node"], "--address takes local, auto, HOST:PORT or ray://HOST:PORT"),
        (["--address", "10.0.0.5:6379", "--workers", "2"], "--workers sets the CPUs of --address local"),
    ],
)
def test_bad_arguments_exit_2_with_one_line_before_any_folder(tmp_path, capsys, argv, message):
    out = tmp_path / "bench"
    with pytest.raises(SystemExit) as e:
        bm.main([*argv, "--out", str(out)])
    err = capsys.readouterr().err
    assert e.value.code == 2 and message in err and err.count("\n") == 1, err
    assert not out.exists()


def test_address_without_ray_exits_2_with_one_line_before_any_folder(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # as where Ray is not installed
    out = tmp_path / "bench"
    with pytest.raises(SystemExit) as e:
        bm.main(["--address", "auto", "--out", str(out)])
    err = capsys.readouterr().err
    assert e.value.code == 2 and "--address needs Ray, which is not installed" in err
    assert err.count("\n") == 1 and not out.exists()


# --------------------------------------------------------------------------- one run, resume
TINY = {"n_steps": 32, "batch_size": 32, "n_epochs": 1}


def _tiny_spec(**kw) -> br.RunSpec:
    base = dict(algo="ppo", env_id="SmaSpineChain-v0", seed=0, n_timesteps=128, n_envs=2, eval_freq=64,
                val_episodes=1, env_kwargs={"episode_duration": 2.0}, hyperparams=TINY)  # fmt: skip
    return br.RunSpec(**{**base, **kw})


def test_a_run_validates_on_schedule_and_resume_skips_it(tmp_path):
    spec = _tiny_spec()
    record = br.run_one(spec, tmp_path)
    folder = tmp_path / spec.folder
    curve = br.read_curve(folder / "curve.csv")
    assert list(curve["step"]) == [0, 64, 128] and record["steps"] == 128
    assert np.all(np.diff(curve["train_wall_s"]) > 0) and record["final_rmse"] == curve["rmse"][-1]
    # the saved model is the one validated last: load_policy rebuilds it with its statistics
    rows = validation_metrics(load_policy(folder), 1, {"episode_duration": 2.0}, "SmaSpineChain-v0")
    assert rows[0]["rmse_deg"] == pytest.approx(curve["rmse"][-1], rel=1e-9)

    stamp = {p.name: p.stat().st_mtime_ns for p in folder.iterdir()}
    time.sleep(0.01)
    assert br.run_one(spec, tmp_path) == record  # skipped: the stored record, nothing rewritten
    assert {p.name: p.stat().st_mtime_ns for p in folder.iterdir()} == stamp
    # in a worker process too (the pool path of --workers)
    [(done_spec, pooled, error)] = list(br.execute([spec], tmp_path, workers=2))
    assert error == "" and pooled == record and done_spec == spec
    assert {p.name: p.stat().st_mtime_ns for p in folder.iterdir()} == stamp

    with pytest.raises(ValueError, match="n_timesteps=128, now 256"):
        br.check_finished([_tiny_spec(n_timesteps=256)], tmp_path)
    br.check_finished([spec], tmp_path)
    # a run finished with another YAML entry (the file edited since) is not taken for a current one
    done = folder / br.DONE
    stored = json.loads(done.read_text())
    stored["settings"]["entry"]["gamma"] = 0.5
    done.write_text(json.dumps(stored))
    with pytest.raises(ValueError, match="finished with entry="):
        br.check_finished([spec], tmp_path)


def test_no_progress_draws_no_step_bar(tmp_path, capsys):
    spec = _tiny_spec(n_timesteps=64, eval_freq=64)
    [(_, record, error)] = list(br.execute([spec], tmp_path / "quiet", workers=1, progress=False))
    assert error == "" and record["steps"] == 64
    assert spec.label not in capsys.readouterr().err
    list(br.execute([spec], tmp_path / "shown", workers=1))
    assert spec.label in capsys.readouterr().err


def test_an_interrupted_run_starts_over(tmp_path):
    spec = _tiny_spec(n_timesteps=64, eval_freq=64)
    folder = tmp_path / spec.folder
    folder.mkdir(parents=True)
    (folder / "curve.csv").write_text("step\n999\n")  # left by a killed run, no done marker
    br.run_one(spec, tmp_path)
    assert list(br.read_curve(folder / "curve.csv")["step"]) == [0, 64]
    assert json.loads((folder / br.DONE).read_text())["settings"] == spec.settings()


def test_a_run_sent_as_files_is_written_as_run_one_writes_it(tmp_path):
    spec = _tiny_spec(n_timesteps=64, eval_freq=64)
    record, files = br.run_files(spec)  # what a Ray task returns: no folder of its own is left
    assert sorted(files) == ["curve.csv", "done.json", "meta.json", "model.zip", "vecnormalize.pkl"]
    stale = tmp_path / "sent" / spec.folder
    stale.mkdir(parents=True)
    (stale / "curve.csv").write_text("step\n999\n")  # an interrupted run is replaced
    br.write_run(tmp_path / "sent", spec, files)
    local = br.run_one(spec, tmp_path / "local")
    sent, here = tmp_path / "sent" / spec.folder, tmp_path / "local" / spec.folder
    assert sorted(p.name for p in sent.iterdir()) == sorted(files)
    assert all((sent / name).read_bytes() == data for name, data in files.items())
    a, b = br.read_curve(sent / "curve.csv"), br.read_curve(here / "curve.csv")
    for column in ("step", "rmse", "energy_J", "time_over_limit_s"):  # the same run: equal numbers
        assert np.array_equal(a[column], b[column]), column
    untimed = [{k: v for k, v in r.items() if k not in ("wall_s", "cpu_s")} for r in (record, local)]
    assert untimed[0] == untimed[1]
    # the written run counts as finished: resuming skips it
    assert br.run_one(spec, tmp_path / "sent") == record
    br.check_finished([spec], tmp_path / "sent")


# --------------------------------------------------------------------------- --quick end to end
QUICK_TIMEOUT_S = 600  # a guard against a hung run, not a time budget (the test may share its core)


def test_quick_runs_every_path_end_to_end_and_resumes(tmp_path):
    out = tmp_path / "bench"
    cmd = [sys.executable, "-m", "spine_gym.agents.benchmark", "--quick", "--out", str(out)]
    t0 = time.perf_counter()
    first = subprocess.run(cmd, cwd=ROOT, env=ENV, capture_output=True, text=True, timeout=QUICK_TIMEOUT_S)
    assert first.returncode == 0, first.stderr[-3000:]
    wall = time.perf_counter() - t0
    ids = list(bm.DEFAULT_ENV_IDS[:2])
    n_runs = len(ids) * len(SB3_ALGOS)  # the default --algos
    assert f"{n_runs} runs, 0 finished before" in first.stdout, (first.stdout, wall)
    dones = sorted(out.glob("runs/*/*/seed_0/done.json"))
    assert len(dones) == n_runs
    for name in ("table.md", "table.csv", "table.png", "runs.csv", "learning_curves.csv", "evaluations.csv"):
        assert (out / name).stat().st_size > 0, name
    assert (out / "curves.png").stat().st_size > 0
    for env_id in ids:
        assert (out / "references" / f"{env_id}.json").exists()
    evaluations = (out / "evaluations.csv").read_text().splitlines()
    assert len(evaluations) == 1 + n_runs * 3  # header, then evaluations at 0, 256, 512 steps
    table = (out / "table.md").read_text()
    assert all(f"### {i}" in table for i in ids) and "pid (reference, 2 episodes)" in table

    stamps = [d.stat().st_mtime_ns for d in dones]
    second = subprocess.run(cmd, cwd=ROOT, env=ENV, capture_output=True, text=True, timeout=QUICK_TIMEOUT_S)
    assert second.returncode == 0, second.stderr[-3000:]
    assert f"{n_runs} runs, {n_runs} finished before (skipped), 0 to run" in second.stdout
    assert [d.stat().st_mtime_ns for d in dones] == stamps

    # --report-only trains nothing: a run whose folder is gone stays gone, the table drops it
    shutil.rmtree(dones[0].parent)
    third = subprocess.run(
        [*cmd, "--report-only"], cwd=ROOT, env=ENV, capture_output=True, text=True, timeout=QUICK_TIMEOUT_S
    )
    assert third.returncode == 0, third.stderr[-3000:]
    assert "0 to run" in third.stdout and not dones[0].parent.exists()
    assert len((out / "runs.csv").read_text().splitlines()) == 1 + n_runs - 1


def test_seed_counts_default_to_five_for_ppo_and_three_for_the_others():
    seed_counts = bm.seed_counts
    assert seed_counts([], ["ppo", "sac", "td3", "tqc"]) == {"ppo": 5, "sac": 3, "td3": 3, "tqc": 3}
    assert seed_counts(["2"], ["ppo", "sac"]) == {"ppo": 2, "sac": 2}
    assert seed_counts(["4", "ppo:7"], ["ppo", "sac"]) == {"ppo": 7, "sac": 4}
    assert seed_counts(["tqc:9"], ["ppo"]) == {"ppo": 5}  # an algorithm not run is ignored
    for bad in (["0"], ["ppo:x"], ["a2c:3"]):
        with pytest.raises(ValueError, match="--n-seeds"):
            seed_counts(bad, ["ppo"])
