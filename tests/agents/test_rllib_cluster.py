"""The multi-node set-up of ``docs/scale_out.md`` §3, run for real as two Ray nodes on this machine:
token authentication, a head (``ray start --head``) and a worker node (``ray start --address``), one
CPU and one ``runner_slot`` each (the worker also its own ``worker_node`` resource), and
``python -m spine_gym.agents.rllib_ppo --address ...`` training a few iterations with one env runner on each
node (each runner needs a ``runner_slot``). The driver's ``result.json`` must show a runner, and env
steps sampled, on both nodes.

The cluster lives in a temp dir (its own ``HOME`` for the token, its own ``--temp-dir``) on ports
picked free, not Ray's defaults; whatever happens, its processes (those whose command line names the
temp dir) are stopped by id (tests/support/ray_cluster.py); ``ray stop`` is not used: it stops every
Ray process of the machine.

Runs where ``ray[rllib]`` is installed (``.ci/run``'s ``.venv-rllib``); skipped in the main venv.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
from ray_cluster import cluster_pids, free_ports, node_ports, stop_cluster
from repo import ROOT

pytest.importorskip("ray.rllib", reason="ray[rllib] is not installed (it runs in .venv-rllib, see .ci/run)")

RAY = str(Path(sys.executable).with_name("ray"))
ITERATIONS = 2
BATCH = 2 * 2 * 32  # runners x sub-envs x fragment


def _run(args: list[str], env: dict, timeout: float = 300) -> subprocess.CompletedProcess:
    r = subprocess.run(args, cwd=ROOT, env=env, capture_output=True, text=True, timeout=timeout)
    assert r.returncode == 0, f"{args} failed:\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    return r


def _cluster_status(head: str, env: dict, timeout: float = 60.0) -> str:
    """``ray status`` once it reports both nodes: right after ``ray start`` it can still say "No
    cluster status" (the GCS has not yet gathered the nodes' resource reports)."""
    deadline = time.monotonic() + timeout
    while True:
        status = _run([RAY, "status", f"--address={head}"], env).stdout
        if "worker_node" in status or time.monotonic() > deadline:
            return status
        time.sleep(1.0)


@pytest.fixture(scope="module")
def cluster_run():
    tmp = Path(tempfile.mkdtemp(prefix="spine_ray_", dir="/tmp"))  # short: Ray's socket paths
    env = {
        **os.environ,
        "HOME": str(tmp / "home"),  # ray get-auth-token --generate writes ~/.ray/auth_token
        "RAY_AUTH_MODE": "token",
        "RAY_DISABLE_USAGE_STATS": "1",
        "OMP_NUM_THREADS": "1",
        "PYTHONPATH": str(ROOT),
    }
    gcs, client, *ports = free_ports(14)
    head = f"127.0.0.1:{gcs}"
    try:
        _run([RAY, "get-auth-token", "--generate"], env)
        _run([RAY, "start", "--head", f"--port={gcs}", f"--ray-client-server-port={client}",
              "--node-ip-address=127.0.0.1", "--num-cpus=1", '--resources={"runner_slot": 1}',
              "--include-dashboard=false", f"--temp-dir={tmp / 'ray'}", *node_ports(ports[:6])],
             env)  # fmt: skip
        _run([RAY, "start", f"--address={head}", "--node-ip-address=127.0.0.1", "--num-cpus=1",
              '--resources={"runner_slot": 1, "worker_node": 1}', *node_ports(ports[6:12])], env)  # fmt: skip
        status = _cluster_status(head, env)
        out = tmp / "out"
        _run([sys.executable, "-m", "spine_gym.agents.rllib_ppo", "--address", head,
              "--env-runners", "2", "--envs-per-runner", "2", "--rollout-fragment-length", "32",
              "--num-epochs", "1", "--iterations", str(ITERATIONS), "--no-eval",
              "--runner-resources", '{"runner_slot": 1}', "--out", str(out)], env, timeout=600)  # fmt: skip
        yield status, json.loads((out / "result.json").read_text())
    finally:
        stop_cluster(str(tmp))
        left = cluster_pids(str(tmp))
        shutil.rmtree(tmp, ignore_errors=True)
        assert not left, f"Ray processes of the test cluster still running: {left}"


def test_the_cluster_has_two_nodes(cluster_run):
    status, result = cluster_run
    assert "0.0/2.0 runner_slot" in status and "0.0/1.0 worker_node" in status  # before the driver
    nodes = result["cluster_nodes"]
    assert len(nodes) == 2
    assert sorted(n["resources"].get("worker_node", 0.0) for n in nodes) == [0.0, 1.0]


def test_env_runners_ran_on_both_nodes(cluster_run):
    _, result = cluster_run
    worker = next(n["node_id"] for n in result["cluster_nodes"] if "worker_node" in n["resources"])
    head = next(n["node_id"] for n in result["cluster_nodes"] if "worker_node" not in n["resources"])
    placement = result["runner_nodes"]
    assert sorted(r["node_id"] for r in placement) == sorted([head, worker])
    # each runner sampled at least its half of the batches (ray 2.60's lifetime counter of a runner
    # read 2x its share in this set-up; the driver's count below is exact)
    assert all(r["env_steps"] >= ITERATIONS * BATCH // 2 for r in placement)
    assert result["runner_envs"] == ["SmaSpineVectorEnv", "SmaSpineVectorEnv"]
    assert [h["env_steps"] for h in result["history"]] == [BATCH * (i + 1) for i in range(ITERATIONS)]
