"""``python -m spine_gym.agents.benchmark --address``: the runs farmed out as Ray tasks give the same results as
the same runs trained locally, and resume like them.

One plan (PPO and SAC on one env id, ``--quick`` sizes: 512 steps, evaluations at 0, 256 and 512
steps) is run three ways: locally in one process; on a Ray head started with ``ray start --head``
(two CPUs, free loopback ports, its own temp dir and ``HOME`` for the auth token) through
``--address 127.0.0.1:PORT``; and, for the SAC run only (its folder removed), with ``--address local``
(a Ray instance started by the driver). Every evaluation's numbers (step, RMSE, energy, time over the
limit) must be equal; the training times may differ. Whatever happens, the Ray processes (those
whose command line names the temp dir) are stopped by id (tests/support/ray_cluster.py), never by
``ray stop``.

Runs where Ray is installed (``.ci/run``'s ``.venv-rllib``); skipped in the main venv.
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
from ray_cluster import cluster_pids, free_ports, node_ports, stop_cluster
from repo import ROOT

pytest.importorskip("ray", reason="Ray is not installed (it runs in .venv-rllib, see .ci/run)")

RAY = str(Path(sys.executable).with_name("ray"))
ENV_ID = "SmaSpineEasy-v1"
PLAN = ["--quick", "--envs", ENV_ID, "--algos", "ppo", "sac"]
SAME = ("step", "rmse", "energy_J", "time_over_limit_s")  # not the training and evaluation times


def _run(args: list[str], env: dict, timeout: float = 300) -> subprocess.CompletedProcess:
    r = subprocess.run(args, cwd=ROOT, env=env, capture_output=True, text=True, timeout=timeout)
    assert r.returncode == 0, f"{args} failed:\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    return r


def _benchmark(out: Path, env: dict, *extra: str) -> str:
    return _run([sys.executable, "-m", "spine_gym.agents.benchmark", *PLAN, "--out", str(out), *extra], env).stdout


def _curve(out: Path, algo: str) -> list[dict]:
    with open(out / "runs" / ENV_ID / algo / "seed_0" / "curve.csv", newline="") as f:
        return [{k: float(row[k]) for k in SAME} for row in csv.DictReader(f)]


def _sessions(tmp: Path) -> list[Path]:
    return sorted((tmp / "ray").glob("session_2*"))  # Ray's session folders in its temp dir


@pytest.fixture(scope="module")
def three_ways():
    tmp = Path(tempfile.mkdtemp(prefix="spine_ray_", dir="/tmp"))  # short: Ray's socket paths
    pythonpath = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)
    env = {
        **os.environ,
        "HOME": str(tmp / "home"),  # Ray's auth token goes to ~/.ray
        "RAY_TMPDIR": str(tmp),  # the --address local instance's temp dir: tmp/ray
        "RAY_DISABLE_USAGE_STATS": "1",
        "OMP_NUM_THREADS": "1",
        "PYTHONPATH": pythonpath,
    }
    gcs, client, *ports = free_ports(8)
    try:
        local = tmp / "local"
        _benchmark(local, env)
        cluster = tmp / "cluster"
        shutil.copytree(local / "references", cluster / "references")  # the PID's episodes, cached
        _run([RAY, "start", "--head", f"--port={gcs}", f"--ray-client-server-port={client}",
              "--node-ip-address=127.0.0.1", "--num-cpus=2", "--include-dashboard=false",
              f"--temp-dir={tmp / 'ray'}", *node_ports(ports)], env)  # fmt: skip
        on_cluster = _benchmark(cluster, env, "--address", f"127.0.0.1:{gcs}")
        stop_cluster(str(tmp))

        shutil.rmtree(cluster / "runs" / ENV_ID / "sac")
        sessions = _sessions(tmp)
        on_local_ray = _benchmark(cluster, env, "--address", "local", "--workers", "1")
        started = [s for s in _sessions(tmp) if s not in sessions]
        again = _benchmark(cluster, env, "--address", "local")
        yield local, cluster, on_cluster, on_local_ray, again, started, _sessions(tmp)
    finally:
        stop_cluster(str(tmp))
        left = cluster_pids(str(tmp))
        shutil.rmtree(tmp, ignore_errors=True)
        assert not left, f"Ray processes of the test still running: {left}"


def test_runs_on_a_ray_cluster_equal_the_local_runs(three_ways):
    local, cluster, on_cluster, *_ = three_ways
    assert "2 runs, 0 finished before (skipped), 2 to run on Ray (127.0.0.1:" in on_cluster
    assert ": 2 CPU(s)" in on_cluster  # the head's, not this machine's
    for algo in ("ppo", "sac"):
        curve = _curve(local, algo)
        assert [r["step"] for r in curve] == [0, 256, 512]
        assert _curve(cluster, algo) == curve, algo
    # the driver wrote the same files; the run records differ only in the training times
    for algo in ("ppo", "sac"):
        here, there = local / "runs" / ENV_ID / algo / "seed_0", cluster / "runs" / ENV_ID / algo / "seed_0"
        assert sorted(p.name for p in here.iterdir()) == sorted(p.name for p in there.iterdir())
        a, b = (json.loads((d / "done.json").read_text()) for d in (here, there))
        assert a["settings"] == b["settings"]
        untimed = [{k: v for k, v in d["record"].items() if k not in ("wall_s", "cpu_s")} for d in (a, b)]
        assert untimed[0] == untimed[1]


def test_a_local_ray_instance_reruns_only_the_missing_run_and_then_nothing(three_ways):
    local, cluster, _, on_local_ray, again, started, sessions = three_ways
    assert "2 runs, 1 finished before (skipped), 1 to run on Ray (local)" in on_local_ray
    assert ": 1 CPU(s)" in on_local_ray  # --workers 1
    assert _curve(cluster, "sac") == _curve(local, "sac")
    assert len(started) == 1  # the driver's own instance, in RAY_TMPDIR
    assert "2 runs, 2 finished before (skipped), 0 to run" in again
    assert sessions[-1] == started[0]  # nothing to run: no Ray instance started for it
