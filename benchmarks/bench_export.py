"""Benchmark: microseconds per action of an exported policy's runners, next to SB3's predict, in one run.

For shipped policies (default ``ppo``: 64-64 tanh; ``sac``: 128-128 ReLU; ``ppo_int``: with the
integral-of-error memory), exported with :mod:`spine_gym.agents.export` into a temporary folder, on the same
1 000 observations of ``SmaSpine-v0`` (random actions held for 10 steps, reset seed 0), one
observation per call (the controller's case):

* ``sb3``    — :func:`spine_gym.agents.runtime.load_policy`'s ``predict`` (VecNormalize transform + SB3's
  ``predict(deterministic=True)``; torch on 1 thread);
* ``onnx``   — ``onnxruntime.InferenceSession.run`` of ``policy.onnx`` (1 intra-op thread);
* ``numpy``  — :meth:`spine_gym.agents.numpy_policy.ExportedPolicy.act` (``step`` with a memory);
* ``c``      — ``policy_act`` (``policy_step`` with a memory) of the generated C, compiled with
  ``cc -std=c99 -O2`` and timed inside the C program (clock_gettime / clock).

A memory policy runs the 1 000 observations as one stream through each runner (the memory kept),
a memoryless one the network on each. Each figure is the best of ``--repeats`` passes over the
1 000 observations (the runners interleaved pass by pass), wall and process CPU time; ratios are
SB3's time over the runner's. The same run checks agreement: the max |action − SB3 action| of
every runner over the 1 000 observations.

Closed loop (``--no-episodes`` skips it): the quick evaluation suite (6 episodes of 20 s) driven
by the SB3 policy, by the NumPy runner and by the SB3 policy fed observations moved up by one
float32 ulp (``np.nextafter``), as a yardstick of the loop's own sensitivity to rounding; per
episode the relative differences of RMSE and energy from the SB3 run. Writes
``benchmarks/results/export_speed.json``.

    .venv/bin/python benchmarks/bench_export.py [--policies ppo sac ppo_int] [--repeats 5] [--no-episodes]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import onnxruntime as ort
import torch

from spine_gym.agents.evaluation import evaluate
from spine_gym.agents.export import OneUlpUp, export_policy, record_observations
from spine_gym.agents.export_c import compile_driver
from spine_gym.agents.numpy_policy import load_bundle
from spine_gym.agents.runtime import evaluation_env_kwargs, load_policy
from spine_gym.agents.scenarios import get_suite

ROOT = Path(__file__).resolve().parents[1]

C_CALLS = 200_000  # calls per timed pass of the C program


def timed(fn) -> tuple[float, float]:
    w0, c0 = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - w0, time.process_time() - c0


def c_pass(exe: Path, mode: str, infile: Path, outfile: Path, repeats: int) -> tuple[float, float]:
    """(wall, cpu) seconds per call of one timed C pass."""
    out = subprocess.run(
        [str(exe), mode, str(infile), str(outfile), str(repeats)], check=True, capture_output=True, text=True
    )
    wall_ns, cpu_ns = map(float, out.stdout.split())
    return wall_ns * 1e-9, cpu_ns * 1e-9


def bench_policy(name: str, obs: np.ndarray, repeats: int, tmp: Path) -> dict:
    policy = load_policy(ROOT / "spine_gym" / "agents" / "policies" / name)
    bundle = tmp / name
    export_policy(policy, bundle, source=f"spine_gym/agents/policies/{name}")
    runner = load_bundle(bundle)
    stateful = bool(runner.memories)
    exe = compile_driver(bundle, tmp / f"{name}_c")
    mode = "step" if stateful else "act"
    obs.tofile(tmp / f"{name}_obs.f32")
    sess_opts = ort.SessionOptions()
    sess_opts.intra_op_num_threads = sess_opts.inter_op_num_threads = 1
    sess = ort.InferenceSession(str(bundle / "policy.onnx"), sess_opts, providers=["CPUExecutionProvider"])

    def sb3_pass(out):
        policy.reset()
        for i, o in enumerate(obs):
            out[i] = policy.predict(o)[0]

    def numpy_pass(out):
        runner.reset()
        for i, o in enumerate(obs):
            out[i] = runner.step(o) if stateful else runner.act(o)

    def onnx_pass(out):  # the network's input: the NumPy runner's features for a memory policy
        for i, x in enumerate(net_inputs):
            out[i] = sess.run(None, {"obs": x})[0][0]

    # the network inputs (observation ++ features) the memory policy sees, for onnxruntime
    net_inputs = _network_inputs(runner, obs)
    actions = {k: np.zeros((len(obs), runner.n_act), np.float32) for k in ("sb3", "onnx", "numpy")}
    passes = {"sb3": sb3_pass, "onnx": onnx_pass, "numpy": numpy_pass}
    best = {k: (np.inf, np.inf) for k in (*passes, "c")}
    reps = max(1, C_CALLS // len(obs))
    for _ in range(repeats):
        for k, fn in passes.items():
            w, c = timed(lambda fn=fn, k=k: fn(actions[k]))
            best[k] = (min(best[k][0], w / len(obs)), min(best[k][1], c / len(obs)))
        w, c = c_pass(exe, mode, tmp / f"{name}_obs.f32", tmp / f"{name}_act.f32", reps)
        best["c"] = (min(best["c"][0], w), min(best["c"][1], c))
    actions["c"] = np.fromfile(tmp / f"{name}_act.f32", np.float32).reshape(len(obs), -1)
    ref = actions["sb3"]
    return {
        "policy": name,
        "network": runner.spec["network"]["sizes"],
        "activations": runner.spec["network"]["activations"],
        "memory": [f["kind"] for f in runner.spec["features"]],
        "us_per_action_wall": {k: v[0] * 1e6 for k, v in best.items()},
        "us_per_action_cpu": {k: v[1] * 1e6 for k, v in best.items()},
        "sb3_over_runner_wall": {k: best["sb3"][0] / v[0] for k, v in best.items() if k != "sb3"},
        "max_abs_diff_vs_sb3": {k: float(np.max(np.abs(actions[k] - ref))) for k in ("onnx", "numpy", "c")},
    }


def _network_inputs(runner, obs: np.ndarray) -> list[np.ndarray]:
    """Per observation, the (1, n_input) float32 input the network sees after the memories."""
    if not runner.memories:
        return [o[None, :] for o in obs]
    out = []
    runner.reset()
    for o in obs:
        x = o[None, :].astype(np.float32)
        runner.step(o)
        for m, mem in zip(runner.memories, runner.mem, strict=True):
            x = np.concatenate([x, m.features(mem)], axis=1).astype(np.float32)
        out.append(x)
    return out


def closed_loop(name: str, tmp: Path) -> list[dict]:
    """Per quick-suite episode: |metric / SB3's metric − 1| of the NumPy runner and of SB3 + 1 ulp."""
    policy = load_policy(ROOT / "spine_gym" / "agents" / "policies" / name)
    runner = load_bundle(tmp / name)
    kw = evaluation_env_kwargs(policy.env_kwargs)
    ctrls = {"sb3": policy, "numpy": runner, "sb3_1ulp": OneUlpUp(policy)}
    rows, _ = evaluate(ctrls, get_suite("quick"), {k: kw for k in ctrls})
    by = {(r["controller"], r["scenario"]): r for r in rows}
    out = []
    for sc in dict.fromkeys(r["scenario"] for r in rows):
        ref = by[("sb3", sc)]
        row = {"scenario": sc}
        for k in ("numpy", "sb3_1ulp"):
            for m in ("rmse_deg", "energy_J"):
                row[f"{k}_{m}_rel"] = abs(by[(k, sc)][m] / ref[m] - 1.0)
        out.append(row)
    return out


def machine() -> dict:
    commit = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=ROOT
    ).stdout.strip()
    cc = subprocess.run(["cc", "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    return {
        "cpu_count": os.cpu_count(),
        "load_average_start": os.getloadavg(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "torch": torch.__version__,
        "torch_threads": torch.get_num_threads(),
        "onnxruntime": ort.__version__,
        "cc": cc,
        "git_commit": commit,
    }


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--policies", nargs="+", default=["ppo", "sac", "ppo_int"])
    p.add_argument("--repeats", type=int, default=5, help="timed passes per runner (best of), >= 1")
    p.add_argument("--no-episodes", action="store_true", help="skip the closed-loop comparison")
    p.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    args = p.parse_args(argv)
    if args.repeats < 1:
        raise ValueError(f"--repeats must be >= 1, got {args.repeats}")
    torch.set_num_threads(1)
    info = machine()
    obs = record_observations()
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.policies:
            r = bench_policy(name, obs, args.repeats, Path(tmp))
            results.append(r)
            w, c = r["us_per_action_wall"], r["us_per_action_cpu"]
            print(f"{name} {r['network']} {r['memory'] or ''}")
            for k in ("sb3", "onnx", "numpy", "c"):
                ratio = "" if k == "sb3" else f"  sb3/{k} {r['sb3_over_runner_wall'][k]:7.1f}x"
                diff = "" if k == "sb3" else f"  max|da| {r['max_abs_diff_vs_sb3'][k]:.1e}"
                print(f"  {k:6s} {w[k]:9.2f} us wall {c[k]:9.2f} us cpu{ratio}{diff}")
            if not args.no_episodes:
                r["closed_loop"] = closed_loop(name, Path(tmp))
                for e in r["closed_loop"]:
                    print(
                        f"  {e['scenario']:16s} numpy: rmse {e['numpy_rmse_deg_rel']:.1e} energy "
                        f"{e['numpy_energy_J_rel']:.1e} | sb3 +1 ulp: rmse {e['sb3_1ulp_rmse_deg_rel']:.1e} "
                        f"energy {e['sb3_1ulp_energy_J_rel']:.1e}"
                    )
    info["load_average_end"] = os.getloadavg()
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "export_speed.json"
    path.write_text(
        json.dumps({"machine": info, "repeats": args.repeats, "results": results}, indent=2) + "\n"
    )
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
