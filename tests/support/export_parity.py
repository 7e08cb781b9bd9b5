"""The scaffold of the export-parity tests: an untrained model saved as a run folder with non-trivial
``VecNormalize`` statistics, and the exported bundle's ONNX and C runners (the observations they are
compared on: :func:`spine_gym.agents.export.record_observations`)."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import onnxruntime as ort
from stable_baselines3.common.vec_env import VecNormalize

from spine_gym.agents.export_c import compile_driver

CLIP_OBS = 3.0  # tight enough that the normaliser's clip is reached on some rows


def save_model_run(
    folder: Path, model, venv, observations: np.ndarray, meta: dict, seed: int = 0
) -> VecNormalize:
    """``model`` (on ``venv``) as a run folder, with ``VecNormalize`` statistics drawn (``seed``) around
    those of ``observations`` (zero-padded to ``venv``'s observation) and ``meta.json``; the
    ``VecNormalize`` back."""
    vn = VecNormalize(venv, norm_obs=True, norm_reward=False, clip_obs=CLIP_OBS)
    pad = np.zeros((len(observations), vn.observation_space.shape[0] - observations.shape[1]))
    x = np.concatenate([observations, pad], 1)
    rng = np.random.default_rng(seed)
    vn.obs_rms.mean = x.mean(0) + rng.normal(0.0, 1.0, x.shape[1]) * (x.std(0) + 1.0)
    vn.obs_rms.var = (x.var(0) + 1.0) * rng.uniform(0.2, 2.0, x.shape[1])
    folder.mkdir(parents=True)
    model.save(folder / "model.zip")
    vn.save(folder / "vecnormalize.pkl")
    (folder / "meta.json").write_text(json.dumps({"env_id": "SmaSpine-v0", "env_kwargs": {}} | meta))
    return vn


def c_runner(bundle: Path, rows: np.ndarray, tmp: Path, mode: str = "act") -> np.ndarray:
    """The bundle's generated C (``policy_act``, or ``policy_step`` for ``mode="step"``) on ``rows``."""
    exe = compile_driver(bundle, tmp / "c")
    rows.astype(np.float32).tofile(tmp / "c" / "in.f32")
    subprocess.run([str(exe), mode, str(tmp / "c" / "in.f32"), str(tmp / "c" / "out.f32")], check=True)
    return np.fromfile(tmp / "c" / "out.f32", dtype=np.float32).reshape(len(rows), -1)


def onnx_runner(bundle: Path, net_input: np.ndarray) -> np.ndarray:
    """``policy.onnx`` of the bundle under onnxruntime on ``net_input``."""
    sess = ort.InferenceSession(str(bundle / "policy.onnx"), providers=["CPUExecutionProvider"])
    return sess.run(None, {"obs": net_input.astype(np.float32)})[0]
