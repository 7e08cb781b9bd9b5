"""Run an exported policy bundle with NumPy alone (no torch, no Stable-Baselines3, no spine_gym).

:mod:`spine_gym.agents.export` writes a folder with ``policy.npz`` (the actor's weights, the observation
normaliser's statistics and the action bounds), ``policy.json`` (what the numbers mean: layer
activations, the output stage, observation and action names, the features of a memory) and
``policy.onnx`` / ``policy.c`` / ``policy.h`` (the same network for onnxruntime and for a C
compiler). This module reads the first two; it imports only ``numpy`` and the standard library,
so it can be copied beside a bundle on any machine with NumPy::

    from spine_gym.agents.numpy_policy import load_bundle
    policy = load_bundle("exported/ppo")
    policy.reset()                        # at an episode's start
    action = policy.step(env_observation)  # keeps the integral / history memory, if any

The network (what ``policy.onnx`` and ``policy_act`` of ``policy.c`` compute):

    x = clip((input − obs_mean) / obs_std, −clip_obs, clip_obs)      (VecNormalize; obs_std = √(var + ε))
    h_{i+1} = act_i(W_i h_i + b_i)                                    (h_0 = x; act_i: tanh, relu or none)
    action = low + ½ (tanh(h_L) + 1)(high − low)   if "squash" (SAC, TD3)
           = min(max(h_L, low), high)               if "clip"   (PPO)

which is what SB3's ``predict(deterministic=True)`` returns for a Box action space after
``VecNormalize.normalize_obs``. The normalisation runs in float64 here (as ``VecNormalize`` does),
the layers in float32; onnxruntime and the C code normalise in float32 (differences ~1e-7).

``input`` is the env's observation followed by the features of the bundle's memories, in the
order of ``policy.json``'s ``features`` (the order :mod:`spine_gym.agents.train` appends them):

* ``integral`` (:mod:`spine_gym.agents.observations`): ``I = clip(decay · I + dt · (obs[target] − obs[tracked]),
  ±limit)``, ``I = 0`` before an episode's first observation, kept in float64;
* ``history`` (:mod:`spine_gym.agents.observations`): the ``frames`` frames before the current one of the
  observation ranges ``ranges``, newest first; at an episode's first observation every frame is
  the current one.

They are re-implemented here from the JSON spec (those modules import Stable-Baselines3);
``tests/agents/test_export.py`` checks that an episode run through :meth:`ExportedPolicy.predict` gives
the same actions as the SB3 policy with its wrappers.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

__all__ = ["BUNDLE_FORMAT", "ACTIVATIONS", "OUTPUT_STAGES", "ExportedPolicy", "load_bundle"]

BUNDLE_FORMAT = "spine_gym.exported_policy/1"
ACTIVATIONS = ("tanh", "relu", "none")
OUTPUT_STAGES = ("clip", "squash")
FEATURE_KINDS = ("integral", "history")


def _activate(h: np.ndarray, name: str) -> np.ndarray:
    if name == "tanh":
        return np.tanh(h)
    if name == "relu":
        return np.maximum(h, np.float32(0.0))
    return h


class _Integral:
    """The leaky integral of the tracking error (see the module docstring)."""

    def __init__(self, spec: dict):
        self.decay = 1.0 if spec["tau"] == "inf" else math.exp(-float(spec["dt"]) / float(spec["tau"]))
        self.dt, self.limit = float(spec["dt"]), float(spec["limit"])
        self.tracked, self.target = tuple(spec["tracked"]), tuple(spec["target"])
        self.size = self.tracked[1] - self.tracked[0]

    def fresh(self, n: int) -> np.ndarray:
        return np.zeros((n, self.size))

    def advance(self, mem: np.ndarray, x: np.ndarray, start: np.ndarray) -> np.ndarray:
        mem = np.where(start.reshape(-1, 1), 0.0, mem)
        x = x.astype(np.float64)
        e = x[:, self.target[0] : self.target[1]] - x[:, self.tracked[0] : self.tracked[1]]
        return np.clip(self.decay * mem + self.dt * e, -self.limit, self.limit)

    def features(self, mem: np.ndarray) -> np.ndarray:
        return mem


class _History:
    """The last ``frames`` frames of the recorded observation ranges (see the module docstring)."""

    def __init__(self, spec: dict):
        self.frames = int(spec["frames"])
        self.ranges = [tuple(r) for r in spec["ranges"]]
        self.width = sum(b - a for a, b in self.ranges)

    def fresh(self, n: int) -> np.ndarray:
        return np.zeros((n, (self.frames + 1) * self.width))

    def advance(self, mem: np.ndarray, x: np.ndarray, start: np.ndarray) -> np.ndarray:
        frame = np.concatenate([x[:, a:b] for a, b in self.ranges], axis=1).astype(np.float64)
        out = np.concatenate([frame, mem[:, : self.frames * self.width]], axis=1)
        out[start] = np.tile(frame[start], self.frames + 1)
        return out

    def features(self, mem: np.ndarray) -> np.ndarray:
        return mem[:, self.width :]


class ExportedPolicy:
    """An exported actor (weights from ``policy.npz``, meaning from ``policy.json``).

    Args:
        arrays: the ``policy.npz`` arrays (``W0``, ``b0``, … ``obs_mean``, ``obs_std``,
            ``clip_obs``, ``action_low``, ``action_high``).
        spec: the ``policy.json`` dict.
    """

    def __init__(self, arrays: dict, spec: dict):
        if spec.get("format") != BUNDLE_FORMAT:
            raise ValueError(f"policy.json format must be {BUNDLE_FORMAT!r}, got {spec.get('format')!r}")
        self.spec = spec
        net = spec["network"]
        self.activations = list(net["activations"])
        for a in self.activations:
            if a not in ACTIVATIONS:
                raise ValueError(f"network activation must be one of {ACTIVATIONS}, got {a!r}")
        self.output = net["output"]
        if self.output not in OUTPUT_STAGES:
            raise ValueError(f"network output must be one of {OUTPUT_STAGES}, got {self.output!r}")
        self.weights = [np.asarray(arrays[f"W{i}"], np.float32) for i in range(len(self.activations))]
        self.biases = [np.asarray(arrays[f"b{i}"], np.float32) for i in range(len(self.activations))]
        self.obs_mean = np.asarray(arrays["obs_mean"], np.float64)
        self.obs_std = np.asarray(arrays["obs_std"], np.float64)
        self.clip_obs = float(arrays["clip_obs"])
        self.low = np.asarray(arrays["action_low"], np.float32)
        self.high = np.asarray(arrays["action_high"], np.float32)
        self.n_obs, self.n_input = int(spec["n_obs"]), int(spec["n_input"])
        self.n_act = int(spec["n_act"])
        self.memories = []
        for f in spec["features"]:
            if f["kind"] not in FEATURE_KINDS:
                raise ValueError(f"feature kind must be one of {FEATURE_KINDS}, got {f['kind']!r}")
            self.memories.append(_Integral(f) if f["kind"] == "integral" else _History(f))
        self.mem = None

    # ------------------------------------------------------------------ the network
    def act(self, net_input: np.ndarray) -> np.ndarray:
        """The action for the network's input (env observation ++ features), (n_input,) or (n, n_input)."""
        x = self._check(net_input, self.n_input, "net_input")
        single = x.ndim == 1
        x = np.atleast_2d(x)
        h = np.clip((x.astype(np.float64) - self.obs_mean) / self.obs_std, -self.clip_obs, self.clip_obs)
        h = h.astype(np.float32)
        for W, b, a in zip(self.weights, self.biases, self.activations, strict=True):
            h = _activate(h @ W.T + b, a)
        if self.output == "squash":
            a = self.low + np.float32(0.5) * (np.tanh(h) + np.float32(1.0)) * (self.high - self.low)
        else:
            a = np.clip(h, self.low, self.high)
        return a[0] if single else a

    # ------------------------------------------------------------------ with memories
    def reset(self) -> None:
        """Forget the memories: the next :meth:`step` starts an episode."""
        self.mem = None

    def step(self, obs: np.ndarray) -> np.ndarray:
        """The action for the env's observation ``obs`` (n_obs,) or (n, n_obs), advancing the
        memories (one per row of a batch; a new batch size restarts them)."""
        x = self._check(obs, self.n_obs, "obs")
        single = x.ndim == 1
        x = np.atleast_2d(x).astype(np.float32)
        start = np.zeros(x.shape[0], dtype=bool)
        if self.mem is None or (self.memories and self.mem[0].shape[0] != x.shape[0]):
            self.mem = [m.fresh(x.shape[0]) for m in self.memories]
            start[:] = True
        for i, m in enumerate(self.memories):
            self.mem[i] = m.advance(self.mem[i], x, start)
            x = np.concatenate([x, m.features(self.mem[i])], axis=1).astype(np.float32)
        a = self.act(x)
        return a[0] if single else a

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True):
        """SB3's ``predict`` interface (deterministic only): ``(action, None)``; ``episode_start``
        restarts the memories."""
        if not deterministic:
            raise ValueError("an exported policy is deterministic: deterministic must be True")
        if episode_start is not None and np.any(episode_start):
            self.reset()
        return self.step(observation), None

    def _check(self, x, n: int, name: str) -> np.ndarray:
        x = np.asarray(x)
        if x.ndim not in (1, 2) or x.shape[-1] != n or not np.issubdtype(x.dtype, np.number):
            raise ValueError(f"{name} must be a numeric array ({n},) or (batch, {n}), got shape {x.shape}")
        if not np.all(np.isfinite(x)):
            raise ValueError(f"{name} must be finite, got NaN or inf")
        return x

    def __repr__(self) -> str:
        algo, n = self.spec.get("algo"), len(self.memories)
        return f"ExportedPolicy({algo}, {self.n_input} -> {self.n_act}, features={n})"


def load_bundle(folder: str | Path) -> ExportedPolicy:
    """The :class:`ExportedPolicy` of an export folder (``policy.npz`` + ``policy.json``)."""
    folder = Path(folder)
    for name in ("policy.npz", "policy.json"):
        if not (folder / name).exists():
            raise ValueError(f"bundle folder {folder} has no {name} (write it with python -m spine_gym.agents.export)")
    spec = json.loads((folder / "policy.json").read_text())
    with np.load(folder / "policy.npz") as z:
        arrays = {k: z[k] for k in z.files}
    return ExportedPolicy(arrays, spec)
