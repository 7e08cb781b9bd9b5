"""Export a trained SB3 policy so that it runs without Python's torch: ONNX, NumPy and C.

Example (``spine-gym export`` is the same command)::

    python -m spine_gym.agents.export spine_gym/agents/policies/ppo -o exported/ppo

writes into ``exported/ppo/``:

* ``policy.npz`` — the deterministic actor's weights (``W0``, ``b0``, …, float32, ``W`` as
  (out, in)), the ``VecNormalize`` statistics (``obs_mean``, ``obs_std`` = √(var + ε),
  ``clip_obs``) and the action bounds (``action_low``, ``action_high``);
* ``policy.json`` — what they mean: algorithm, layer activations, output stage (``clip`` for PPO's
  mean action, ``squash`` = tanh and rescaling for SAC, TD3 and the JAX learners), the names and units of the
  network's inputs and of the actions, the env id and kwargs, the spine_gym version, and the
  specs of the observation memories (``features``);
* ``policy.onnx`` — the same network, normalisation and output stage included (input ``obs``
  (batch, n_input) float32, output ``action`` (batch, n_act)); opset 17;
* ``policy.h`` / ``policy.c`` — plain C99 (:mod:`spine_gym.agents.export_c`).

The exported action is SB3's ``predict(deterministic=True)`` for a Box action space after
``VecNormalize.normalize_obs``: PPO's mean action clipped to the bounds, SAC's tanh-squashed mean
and TD3's actor, rescaled to the bounds. The JAX learners of the ``jax`` extra (SBX's CrossQ and SAC,
:mod:`spine_gym.agents.jax_algos`) export likewise: their actor's mean through tanh, CrossQ's batch
renormalisation (affine at inference: running statistics) folded into the Dense layer after it.
:mod:`spine_gym.agents.numpy_policy` runs the bundle with NumPy
alone; the formulas are in its docstring.

Observation memories (:mod:`spine_gym.agents.observations`: the integral of the error, the
frame history) are exported: the network's input is the env's observation followed by their
features, ``policy.json`` holds their specs, and :meth:`spine_gym.agents.numpy_policy.ExportedPolicy.step`
and ``policy_step`` of the C code keep them. A residual policy on a PID (:mod:`spine_gym.agents.residual`)
is refused: its baseline (the PID with its guard and filters) runs outside the network and is not
exported. So are non-MLP feature extractors, non-Box spaces and activations other than tanh and
ReLU. A PPO trained with state-dependent exploration (``use_sde``) exports its mean head: its
deterministic action.

The ONNX file is built node by node from the arrays of ``policy.npz`` (``onnx.helper``, no
``torch.onnx``), so every runner reads the same numbers. ``onnx`` is imported here only: the
NumPy runner and the C code do not need it.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

import numpy as np
import onnx
from gymnasium import spaces
from onnx import TensorProto, helper, numpy_helper
from stable_baselines3 import PPO, SAC, TD3
from stable_baselines3.common.distributions import DiagGaussianDistribution, StateDependentNoiseDistribution
from stable_baselines3.common.torch_layers import FlattenExtractor
from torch import nn

import spine_gym
from spine_gym.cli_conventions import Parser, add_out, check_file, check_out_dir, first_line, module_prog

from . import numpy_policy
from .export_c import write_c
from .numpy_policy import BUNDLE_FORMAT
from .observations import HistoryObsPolicy, IntegralObsPolicy
from .residual import ResidualPolicy
from .runtime import SavedPolicy, load_policy, make_env
from .zoo_config import ENV_ID

__all__ = [
    "UnsupportedPolicyError",
    "actor_layers",
    "bundle_of",
    "export_policy",
    "write_onnx",
    "record_observations",
    "OneUlpUp",
    "main",
]

ONNX_OPSET = 17
_ACTIVATION_NAMES = {nn.Tanh: "tanh", nn.ReLU: "relu"}


class UnsupportedPolicyError(ValueError):
    """The policy has a part that the export cannot reproduce (the message says which)."""


# --------------------------------------------------------------------------- the actor
def _linear_stack(modules) -> list[list]:
    """``[[W, b, activation], …]`` of a sequence of ``nn.Linear`` and activation modules."""
    layers = []
    for m in modules:
        if isinstance(m, nn.Linear):
            w = m.weight.detach().cpu().numpy().astype(np.float32)
            b = (m.bias.detach().cpu().numpy() if m.bias is not None else np.zeros(w.shape[0])).astype(
                np.float32
            )
            layers.append([w, b, "none"])
        elif type(m) in _ACTIVATION_NAMES and layers and layers[-1][2] == "none":
            layers[-1][2] = _ACTIVATION_NAMES[type(m)]
        else:
            raise UnsupportedPolicyError(
                f"exporting a network with a {type(m).__name__} layer is not supported: "
                "only Linear layers, each followed by at most one Tanh or ReLU"
            )
    return layers


def _check_extractor(extractor) -> None:
    if not isinstance(extractor, FlattenExtractor):
        raise UnsupportedPolicyError(
            f"exporting a policy with a {type(extractor).__name__} features extractor is not supported: "
            "only the MLP policies' FlattenExtractor"
        )


def actor_layers(model) -> tuple[str, list[list], str]:
    """``(algo, layers, output)`` of the deterministic actor of an SB3 ``PPO``, ``SAC`` or ``TD3``, or of
    an SBX (JAX) ``CrossQ`` or ``SAC`` (:func:`_sbx_actor_layers`).

    ``layers`` is ``[[W (out, in), b, activation], …]`` (float32) and ``output`` ``"clip"`` (PPO's
    mean action, clipped to the action bounds) or ``"squash"`` (tanh, then rescaled to them)."""
    if not isinstance(getattr(model, "action_space", None), spaces.Box):
        raise UnsupportedPolicyError("exporting a policy is supported for a Box action space only")
    if len(model.observation_space.shape) != 1:
        raise UnsupportedPolicyError("exporting a policy is supported for a flat Box observation only")
    pol = model.policy
    if isinstance(model, PPO):
        # the deterministic action is the mean head's output, with or without state-dependent
        # exploration (gSDE only adds noise to it); a squashed gSDE mean goes through tanh
        if not isinstance(pol.action_dist, DiagGaussianDistribution | StateDependentNoiseDistribution):
            raise UnsupportedPolicyError(
                f"exporting a PPO policy with {type(pol.action_dist).__name__} is not supported"
            )
        _check_extractor(pol.pi_features_extractor)
        out = "squash" if pol.squash_output else "clip"
        return "ppo", _linear_stack([*pol.mlp_extractor.policy_net, pol.action_net]), out
    if isinstance(model, SAC):
        _check_extractor(pol.actor.features_extractor)
        return "sac", _linear_stack([*pol.actor.latent_pi, pol.actor.mu]), "squash"
    if isinstance(model, TD3):  # DDPG too (a TD3 subclass); the actor's mu ends in Tanh
        _check_extractor(pol.actor.features_extractor)
        layers = _linear_stack(pol.actor.mu)
        if layers[-1][2] != "tanh":
            raise UnsupportedPolicyError("exporting a TD3 actor that does not end in Tanh is not supported")
        layers[-1][2] = "none"
        return type(model).__name__.lower(), layers, "squash"
    if _sbx_class(model) is not None:
        return _sbx_actor_layers(model)
    raise UnsupportedPolicyError(
        f"exporting a {type(model).__name__} model is not supported: "
        "PPO, SAC, TD3 and SBX's CrossQ and SAC are"
    )


def _sbx_activation(fn) -> str:
    """``relu`` or ``tanh``: an SBX policy's activation, by name (a loaded model holds an unpickled copy
    of JAX's function, not JAX's own object)."""
    name = getattr(fn, "__name__", repr(fn))
    if name not in ("relu", "tanh"):
        raise UnsupportedPolicyError(
            f"exporting an SBX policy with activation {name!r} is not supported: only relu and tanh"
        )
    return name


def _sbx_actor_layers(model) -> tuple[str, list[list], str]:
    """``("sbx_<class>", layers, "squash")`` of an SBX ``CrossQ``, ``SAC`` (DroQ is SBX's SAC) or ``TQC``: the
    Dense layers of the actor up to its mean head, whose tanh is SBX's deterministic action. CrossQ's batch
    renormalisation layers are affine at inference (running statistics: ``scale (x − mean) /
    √(var + ε) + bias``) and are folded into the Dense layer after each, in float64."""
    from sbx.common.policies import SquashedGaussianActor
    from sbx.crossq.policies import Actor as CrossQActor

    pol = model.policy
    actor = pol.actor
    if type(actor) not in (SquashedGaussianActor, CrossQActor):
        raise UnsupportedPolicyError(
            f"exporting an SBX {type(actor).__name__} is not supported: only the MLP actors of SAC and "
            "CrossQ (not the Simba ones)"
        )
    params = pol.actor_state.params
    params = params.get("params", params)  # SBX's SAC keeps Flax's "params" level, CrossQ not
    act = _sbx_activation(pol.activation_fn)
    norm = isinstance(actor, CrossQActor) and bool(actor.use_batch_norm)
    stats = pol.actor_state.batch_stats if norm else None
    n_hidden = len(actor.net_arch)
    layers = []
    for i in range(n_hidden + 1):  # the hidden layers, then the mean head (Dense_<n_hidden>)
        kernel = np.asarray(params[f"Dense_{i}"]["kernel"], np.float64)  # (in, out)
        bias = np.asarray(params[f"Dense_{i}"]["bias"], np.float64)
        if norm:  # BatchRenorm_i normalises this layer's input: x -> a x + c
            a, c = _renorm_affine(params[f"BatchRenorm_{i}"], stats[f"BatchRenorm_{i}"])
            kernel, bias = kernel * a[:, None], bias + c @ kernel
        layers.append([kernel.T.astype(np.float32), bias.astype(np.float32), act if i < n_hidden else "none"])
    # sbx_crossq, sbx_sac (DroQ's and MBPO's too: SAC's actor), sbx_tqc
    return "sbx_" + _sbx_class(model).__name__.lower(), layers, "squash"


def _sbx_class(model) -> type | None:
    """The SBX class ``model`` is or derives from (MBPO: SAC), ``None`` for any other model."""
    return next((c for c in type(model).__mro__ if c.__module__.split(".")[0] == "sbx"), None)


#: the epsilon of SBX's ``BatchRenorm`` (its default; CrossQ does not set it)
SBX_RENORM_EPSILON = 1e-3


def _renorm_affine(params, stats) -> tuple[np.ndarray, np.ndarray]:
    """``(a, c)`` of a ``BatchRenorm`` layer at inference: ``y = a x + c`` (float64)."""
    var = np.asarray(stats["var"], np.float64)
    a = np.asarray(params["scale"], np.float64) / np.sqrt(var + SBX_RENORM_EPSILON)
    return a, np.asarray(params["bias"], np.float64) - np.asarray(stats["mean"], np.float64) * a


# --------------------------------------------------------------------------- the bundle
def _unwrap(policy) -> tuple[SavedPolicy, list[dict]]:
    """The :class:`SavedPolicy` under the observation wrappers and their feature specs, in the
    order they are appended to the observation (the outermost first)."""
    if isinstance(policy, ResidualPolicy):
        raise UnsupportedPolicyError(
            "exporting a residual policy is not supported: its PID baseline (guard, filters, "
            "anti-windup) runs outside the network and is not exported; export a policy trained "
            "without -params residual:pid"
        )
    features = []
    while isinstance(policy, (IntegralObsPolicy, HistoryObsPolicy)):
        kind = "integral" if isinstance(policy, IntegralObsPolicy) else "history"
        features.append({"kind": kind, **policy.spec.to_dict(), "size": policy.spec.size})
        policy = policy.model
    if not isinstance(policy, SavedPolicy):
        raise UnsupportedPolicyError(f"exporting a {type(policy).__name__} is not supported")
    return policy, features


def _feature_names(features: list[dict], names: list[str], units: list[str]) -> None:
    """Append the names and units of the features' entries to ``names`` / ``units`` (in place)."""
    for f in features:
        if f["kind"] == "integral":
            for i in range(f["size"]):
                tr = f["tracked"][0] + i
                names.append(f"integral_error_{names[tr]}")
                units.append(f"{units[tr]} s")
        else:
            frame = [i for a, b in f["ranges"] for i in range(a, b)]
            for k in range(1, f["frames"] + 1):
                names += [f"{names[i]}[t-{k}]" for i in frame]
                units += [units[i] for i in frame]


def _env_description(meta: dict, n_obs: int, n_act: int) -> dict:
    """Observation and action names and units from the env's table."""
    env = make_env(meta.get("env_kwargs", {}), meta.get("env_id", ENV_ID))
    table = env.config.table()
    names = [n for e in table.entries if e.obs is not None for n in e.names]
    units = [e.unit for e in table.entries if e.obs is not None for _ in e.names]
    if len(names) != n_obs:
        raise UnsupportedPolicyError(
            f"the policy observes {n_obs} entries but its env {meta.get('env_id', ENV_ID)} with "
            f"kwargs {meta.get('env_kwargs', {})} has {len(names)}"
        )
    prev = [e for e in table.entries if e.key == "previous_action"]
    act = (
        [n.replace("previous_", "") for n in prev[0].names] if prev else [f"action_{i}" for i in range(n_act)]
    )
    v_max = float(getattr(env, "v_max", np.nan))
    env.close()
    return {"names": names, "units": units, "action_names": act, "v_max": v_max}


def bundle_of(policy, source: str = "") -> tuple[dict, dict]:
    """``(arrays, spec)``: the contents of ``policy.npz`` and ``policy.json`` for a policy
    returned by :func:`spine_gym.agents.runtime.load_policy` (see the module docstring)."""
    saved, features = _unwrap(policy)
    algo, layers, output = actor_layers(saved.model)
    n_input = int(saved.model.observation_space.shape[0])
    n_obs = n_input - sum(f["size"] for f in features)
    n_act = int(saved.model.action_space.shape[0])
    arrays = {}
    for i, (w, b, _) in enumerate(layers):
        arrays[f"W{i}"], arrays[f"b{i}"] = w, b
    rms = saved.obs_rms
    arrays["obs_mean"] = np.zeros(n_input) if rms is None else np.asarray(rms.mean, np.float64)
    arrays["obs_std"] = (
        np.ones(n_input) if rms is None else np.sqrt(np.asarray(rms.var, np.float64) + saved.epsilon)
    )
    arrays["clip_obs"] = np.float64(np.inf if rms is None else saved.clip_obs)
    arrays["action_low"] = saved.model.action_space.low.astype(np.float32)
    arrays["action_high"] = saved.model.action_space.high.astype(np.float32)
    env = _env_description(saved.meta, n_obs, n_act)
    names, units = list(env["names"]), list(env["units"])
    _feature_names(features, names, units)
    spec = {
        "format": BUNDLE_FORMAT,
        "source": str(source),
        "algo": algo,
        "env_id": saved.meta.get("env_id", ENV_ID),
        "env_kwargs": saved.meta.get("env_kwargs", {}),
        "spine_gym_version": spine_gym.__version__,
        "n_obs": n_obs,
        "n_input": n_input,
        "n_act": n_act,
        "network": {
            "normalize": "x = clip((input - obs_mean) / obs_std, -clip_obs, clip_obs)",
            "normalized": rms is not None,
            "sizes": [n_input] + [int(w.shape[0]) for w, _, _ in layers],
            "activations": [a for _, _, a in layers],
            "output": output,
        },
        "input": {"names": names, "units": units},
        "action": {
            "names": env["action_names"],
            "low": arrays["action_low"].tolist(),
            "high": arrays["action_high"].tolist(),
            "meaning": "normalised wire drive: volts = (clip(a, -1, 1) + 1) / 2 * v_max",
            "v_max_V": env["v_max"],
        },
        "features": features,
    }
    return arrays, spec


# --------------------------------------------------------------------------- ONNX
def _const(name: str, value) -> onnx.TensorProto:
    return numpy_helper.from_array(np.asarray(value, dtype=np.float32), name)


def onnx_model(arrays: dict, spec: dict) -> onnx.ModelProto:
    """The ONNX graph of a bundle: normalisation, the layers and the output stage, float32."""
    net = spec["network"]
    inits = [_const("obs_mean", arrays["obs_mean"]), _const("obs_std", arrays["obs_std"])]
    nodes = [
        helper.make_node("Sub", ["obs", "obs_mean"], ["centred"]),
        helper.make_node("Div", ["centred", "obs_std"], ["x"]),
    ]
    h = "x"
    if np.isfinite(arrays["clip_obs"]):
        c = float(arrays["clip_obs"])
        inits += [_const("clip_lo", -c), _const("clip_hi", c)]
        nodes.append(helper.make_node("Clip", ["x", "clip_lo", "clip_hi"], ["x_clipped"]))
        h = "x_clipped"
    for i, act in enumerate(net["activations"]):
        inits += [_const(f"W{i}", arrays[f"W{i}"]), _const(f"b{i}", arrays[f"b{i}"])]
        nodes.append(helper.make_node("Gemm", [h, f"W{i}", f"b{i}"], [f"z{i}"], transB=1))
        h = f"z{i}"
        if act != "none":
            nodes.append(helper.make_node({"tanh": "Tanh", "relu": "Relu"}[act], [h], [f"h{i}"]))
            h = f"h{i}"
    low, high = arrays["action_low"], arrays["action_high"]
    if net["output"] == "squash":  # low + 0.5 (tanh(h) + 1) (high - low)
        inits += [_const("action_low", low), _const("action_range", high - low)]
        inits += [_const("one", 1.0), _const("half", 0.5)]
        nodes += [
            helper.make_node("Tanh", [h], ["t"]),
            helper.make_node("Add", ["t", "one"], ["t1"]),
            helper.make_node("Mul", ["half", "t1"], ["t2"]),
            helper.make_node("Mul", ["t2", "action_range"], ["t3"]),
            helper.make_node("Add", ["action_low", "t3"], ["action"]),
        ]
    else:
        inits += [_const("action_low", low), _const("action_high", high)]
        nodes += [
            helper.make_node("Max", [h, "action_low"], ["a_lo"]),
            helper.make_node("Min", ["a_lo", "action_high"], ["action"]),
        ]
    graph = helper.make_graph(
        nodes,
        f"{spec['algo']}_policy",
        [helper.make_tensor_value_info("obs", TensorProto.FLOAT, ["batch", spec["n_input"]])],
        [helper.make_tensor_value_info("action", TensorProto.FLOAT, ["batch", spec["n_act"]])],
        initializer=inits,
    )
    model = helper.make_model(
        graph, opset_imports=[helper.make_opsetid("", ONNX_OPSET)], producer_name="spine_gym"
    )
    model.ir_version = 8
    model.doc_string = (
        f"{spec['algo']} policy of {spec['env_id']} exported from {spec['source']} (see policy.json)"
    )
    onnx.checker.check_model(model)
    return model


def write_onnx(arrays: dict, spec: dict, path: str | Path) -> Path:
    path = Path(path)
    onnx.save(onnx_model(arrays, spec), path)
    return path


# --------------------------------------------------------------------------- API and CLI
def export_policy(policy, out: str | Path, source: str = "") -> dict[str, Path]:
    """Write the bundle of ``policy`` (a :func:`spine_gym.agents.runtime.load_policy` result) into the
    folder ``out``, with a copy of the NumPy runner (``numpy_policy.py``, NumPy and the standard library
    only) so that the folder runs on its own; returns ``{file kind: path}``. Unsupported policies raise
    :class:`UnsupportedPolicyError` before anything is written."""
    arrays, spec = bundle_of(policy, source)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"npz": out / "policy.npz", "json": out / "policy.json", "onnx": out / "policy.onnx"}
    np.savez(paths["npz"], **arrays)
    paths["json"].write_text(json.dumps(spec, indent=2) + "\n")
    write_onnx(arrays, spec, paths["onnx"])
    paths["h"], paths["c"] = write_c(arrays, spec, out)
    paths["runner"] = Path(shutil.copyfile(numpy_policy.__file__, out / "numpy_policy.py"))
    return paths


def record_observations(n: int = 1000, seed: int = 0) -> np.ndarray:
    """``n`` observations (float32, ``(n, 10)``) of ``SmaSpine-v0`` under uniform random actions held
    for 10 steps, reset with ``seed`` (and ``seed`` + the rows so far after an episode's end): the
    observations an exported policy's runners are compared and timed on."""
    env = make_env()
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    rows = []
    while len(rows) < n:
        a = rng.uniform(-1, 1, size=2).astype(np.float32)
        for _ in range(10):
            rows.append(obs)
            obs, _, term, trunc, _ = env.step(a)
            if term or trunc:
                obs, _ = env.reset(seed=seed + len(rows))
    env.close()
    return np.asarray(rows[:n], dtype=np.float32)


class OneUlpUp:
    """A controller that passes observations moved up by one float32 ulp to ``policy``: the yardstick
    of a closed loop's own sensitivity to rounding, against which an exported policy's episode
    metrics are compared (an export cannot be held to more than the loop itself gives)."""

    def __init__(self, policy):
        self.policy = policy

    def reset(self):
        self.policy.reset()

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        moved = np.nextafter(np.asarray(observation, np.float32), np.float32(np.inf))
        return self.policy.predict(moved, state, episode_start, deterministic)


#: this command's name as ``python -m <module>`` (``spine-gym <command>`` passes its own ``prog``)
PROG = module_prog(__spec__.name)

EXAMPLES = """
spine-gym export logs/ppo/SmaSpine-v2_1 -o exported/ppo          # a run folder (or a shipped policy's)
spine-gym export logs/ppo/SmaSpine-v2_1/model.zip -o exported/zip   # a model file
"""


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    p = Parser(prog=prog, description=__doc__.split("\n")[0], examples=EXAMPLES)
    p.add_argument(
        "policy", help="a policy folder (model.zip + vecnormalize.pkl + meta.json) or a model .zip"
    )
    add_out(p, required=True, help="output folder (created)")
    return p


def main(argv: list[str] | None = None, prog: str = PROG) -> int:
    """Run the CLI; exit status 0, or 2 (one line on stderr) for a missing or unsupported policy,
    before anything is written."""
    parser = build_parser(prog)
    args = parser.parse_args(argv)
    try:
        check_file(args.policy, "policy")
        check_out_dir(args.out)
        paths = export_policy(load_policy(args.policy), args.out, source=args.policy)
    except ValueError as e:  # UnsupportedPolicyError is one
        print(f"{parser.prog}: error: {first_line(e)}", file=sys.stderr)
        return 2
    for kind, path in paths.items():
        print(f"{kind:5s} {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
