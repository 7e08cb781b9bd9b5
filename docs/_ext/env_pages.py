"""The documentation page of a registered env id, read from ``gymnasium.make(id)`` itself.

What differs between ids (the observation space, the action space, the reward coefficients, the
task and plant settings) is read from the env that ``gymnasium.make(id)`` returns: its spaces, its
configuration (``env.unwrapped.config``) and its declarative table (``env.unwrapped.table``). What
the ids of a class share (the description, starting state, episode end, info, arguments) is the
entry point's class docstring (Gymnasium's convention), whose own action and observation sections
(those of the class defaults) are replaced by this id's. The docstrings are reST-flavoured
Markdown: their roles (``:meth:`x```) become MyST roles (``{meth}`x```) here.

Plain functions of the env, without Sphinx: :mod:`spine_docs` writes the pages at build time and
``tests/test_docs_env_pages.py`` checks them against ``gymnasium.make``.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import re
import warnings

import gymnasium as gym
import numpy as np

ROLE = re.compile(r":(?:py:)?(meth|class|func|mod|data|attr|exc|obj|doc|ref):`([^`]+)`")
# sections of the class docstring that this page writes from the id itself
REPLACED_SECTIONS = ("Action space", "Observation space")
# configuration fields shown elsewhere on the page, or not a task or plant setting
# units of the settings that have one (the class docstrings' Arguments sections say the same)
_UNITS = {
    "v_max": "V",
    "control_period": "s",
    "physics_dt": "s",
    "episode_duration": "s",
    "target_preview": "s",
    "target_range": "deg",
    "sine_period_range": "s",
    "target_period_range": "s",
    "tip_force_range": "N",
    "tip_force_duration": "s",
    "payload_range": "kg",
    "sensor_delay": "control periods",
    "module_bend_limit": "deg",
    "thermal_cutoff": "K",
}
_NOT_SETTINGS = {"params", "solver", "error_scale", "energy_weight", "cost_weight", "temperature_limit"}


def myst_roles(text: str) -> str:
    """reST roles (``:meth:`x```, ``:py:class:`x```) as MyST roles (``{meth}`x```)."""
    return ROLE.sub(lambda m: f"{{{m.group(1)}}}`{m.group(2)}`", text)


def entry_class(entry_point: str) -> type:
    """The class an entry point ``"module:Name"`` names."""
    module, name = entry_point.split(":")
    return getattr(importlib.import_module(module), name)


def make(env_id: str) -> gym.Env:
    """``gymnasium.make(env_id)`` without the out-of-date warning of a ``-v0`` id."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return gym.make(env_id)


def observation_shape(env_id: str) -> tuple[int, ...]:
    """The shape of ``gymnasium.make(env_id).observation_space``."""
    env = make(env_id)
    try:
        return env.observation_space.shape
    finally:
        env.close()


def fmt(value) -> str:
    """A setting's value as table text."""
    if value is None or value is False or value == ():
        return "off"
    if value is True:
        return "on"
    if isinstance(value, float | np.floating):
        return f"{value:g}"
    if isinstance(value, tuple) and value and all(isinstance(v, tuple) for v in value):
        return ", ".join(f"`{v[0]}` ∈ [{fmt(v[1])}, {fmt(v[2])}]" for v in value)
    if isinstance(value, tuple):
        return "(" + ", ".join(fmt(v) for v in value) + ")"
    if isinstance(value, str):
        return f"`{value}`"
    return f"{value}"


def observation_rows(env: gym.Env) -> list[tuple[int, str, str, str, float, float]]:
    """(index, name, description, unit, low, high) of each observation entry: names from the env's
    table, bounds from ``env.observation_space``."""
    space = env.observation_space
    table = env.unwrapped.table
    docs = [(e.doc, e.unit) for e in table.entries if e.obs is not None for _ in e.names]
    names = env.unwrapped.observation_names
    if len(names) != space.shape[0]:
        raise ValueError(f"{env.spec.id}: {len(names)} observation names for a space of shape {space.shape}")
    return [
        (i, n, d, u, float(space.low[i]), float(space.high[i]))
        for i, (n, (d, u)) in enumerate(zip(names, docs, strict=True))
    ]


def observation_section(env: gym.Env) -> list[str]:
    space = env.observation_space
    lines = [
        "## Observation space",
        "",
        f"`{space}`: {space.shape[0]} entries; entries outside the bounds are clipped to them. Read from "
        f"`gymnasium.make(\"{env.spec.id}\").observation_space` and the env's table "
        "(`env.unwrapped.table`; `env.unwrapped.obs_index(key)` gives the indices of an entry).",
        "",
        "| index | observation | description | unit | low | high |",
        "|---|---|---|---|---|---|",
    ]
    rows = observation_rows(env)
    lines += [f"| {i} | `{n}` | {d} | {u} | {lo:g} | {hi:.6g} |" for i, n, d, u, lo, hi in rows]
    return lines + [""]


def action_section(env: gym.Env) -> list[str]:
    space, cfg = env.action_space, env.unwrapped.config
    if cfg.thermal_cutoff is None:
        cutoff = "This id's wire driver has no thermal cut-off (`thermal_cutoff` off)."
    else:
        cutoff = (
            f"The wire driver cuts a hot wire: a wire whose true temperature (not the sensor's) is at "
            f"or above `thermal_cutoff` = {cfg.thermal_cutoff:g} K at the start of a control period "
            "gets 0 V for that period, whatever the action (the observation's previous action stays "
            "the commanded one)."
        )
    return [
        "## Action space",
        "",
        f"`{space}`: one entry per wire (group); {drive_formula(cfg, space.shape[0])}, held over the "
        f"control period of {cfg.control_period:g} s (zero-order hold). Actions outside [−1, 1] are "
        f'clipped; the applied volts are `info["voltage"]`. {cutoff}',
        "",
    ]


def drive_formula(cfg, n_act: int) -> str:
    """The volts an action puts on each wire, read from the coefficient the env's step applies
    (``config.volt_coef``, :mod:`spine_gym.envs.drive`: volts = (clip(a, −1, 1) + 1) · coef, coef = ½
    ``v_max`` × the wire's voltage scale, 1 but on a chain's shorter wires)."""
    coef = np.broadcast_to(np.asarray(cfg.volt_coef, dtype=np.float64), (n_act,))
    scale, top = 2.0 * coef / cfg.v_max, 2.0 * coef
    if np.allclose(top, top[0]):
        on = f"action +1 puts {top[0]:g} V on every wire"
    else:
        on = f"action +1 puts ({', '.join(f'{x:g}' for x in top)}) V on the wires, by action index"
    if np.allclose(scale, 1.0):
        return f"volts = (clip(a, −1, 1) + 1) / 2 · `v_max`, with `v_max` = {cfg.v_max:g} V here: {on}"
    scales = f"{scale[0]:g}" if np.allclose(scale, scale[0]) else f"({', '.join(f'{x:g}' for x in scale)})"
    return (
        "volts = (clip(a, −1, 1) + 1) / 2 · `v_max` · s, with s = L0_k / L0 the wire's length (its "
        "module's) over the seed's: a shorter wire heats like the seed's at a lower voltage (SPATIAL.md "
        f"§6), so `v_max` = {cfg.v_max:g} V here is the seed-equivalent full drive; s = {scales} here: {on}"
    )


def reward_section(env: gym.Env) -> list[str]:
    cfg, unit = env.unwrapped.config, env.unwrapped.table.task.unit
    return [
        "## Reward coefficients",
        "",
        "r = −|e| / `error_scale` − `energy_weight` · E / E_ref − `cost_weight` · cost "
        "(e the tracking error, E the step's electrical energy, E_ref the largest one; the Rewards "
        f"section below), with `{env.spec.id}`'s coefficients:",
        "",
        "| coefficient | value |",
        "|---|---|",
        f"| `error_scale` | {cfg.error_scale:g} {unit} (−1 per {cfg.error_scale:g} {unit} of error) |",
        f"| `energy_weight` | {cfg.energy_weight:g} |",
        f"| `cost_weight` | {cfg.cost_weight:g} 1/K |",
        f"| `temperature_limit` (threshold of the cost) | {cfg.temperature_limit:g} K |",
        "",
    ]


def settings_section(env: gym.Env, registered: dict) -> list[str]:
    cfg = env.unwrapped.config
    lines = [
        "## Task and plant settings",
        "",
        f"The configuration `gymnasium.make(\"{env.spec.id}\")` builds (`env.unwrapped.config`); "
        "**bold**: set by the registration, the others are the class defaults. Any of them can be "
        "overridden as a keyword argument of `make`.",
        "",
        "| setting | value |",
        "|---|---|",
        f"| `max_episode_steps` (registration) | {env.spec.max_episode_steps} |",
    ]
    for f in dataclasses.fields(cfg):
        if f.name in _NOT_SETTINGS:
            continue
        value = getattr(cfg, f.name)
        if f.name == "sensor_noise":
            value = tuple((k, s) for k, s in cfg.noise_sigma.items() if s) or None
            text = ", ".join(f"`{k}` σ = {s:g}" for k, s in value) if value else "off"
        else:
            text = fmt(value)
            if f.name in _UNITS and text != "off":
                text += f" {_UNITS[f.name]}"
        name = f"**`{f.name}`**" if f.name in registered else f"`{f.name}`"
        lines.append(f"| {name} | {text} |")
    return lines + [""]


def docstring_sections(doc: str) -> tuple[str, list[tuple[str, str]]]:
    """The summary line and the ``## `` sections (title, body) of a class docstring."""
    doc = inspect.cleandoc(doc)
    summary, _, rest = doc.partition("\n\n")
    sections = []
    for chunk in re.split(r"^## ", rest, flags=re.M):
        if chunk.strip():
            title, _, body = chunk.partition("\n")
            sections.append((title.strip(), body.strip()))
    return summary.strip(), sections


def _placed(sections: list[tuple[str, str]], generated: dict[str, list[str]]) -> list[str]:
    """The docstring's sections with the generated ones in their places: ``Action space`` and
    ``Observation space`` replaced, the reward coefficients before the rewards, the settings
    before the arguments (any not placed at the end)."""
    before = {"Rewards": "rewards", "Arguments": "settings"}
    lines: list[str] = []
    for title, body in sections:
        key = next((k for t, k in before.items() if title.startswith(t)), None)
        if key in generated:
            lines += generated.pop(key)
        if title in REPLACED_SECTIONS:
            lines += generated.pop(title, [])
        else:
            lines += [f"## {title}", "", myst_roles(body), ""]
    return lines + [line for rest in generated.values() for line in rest]


def env_page(spec, tracks: str) -> str:
    """The Markdown page of one registered id (a :class:`spine_gym.envs.ids.EnvSpec`)."""
    cls = entry_class(spec.entry_point)
    summary, sections = docstring_sections(cls.__doc__ or "")
    env = make(spec.id)
    try:
        generated = {
            "Action space": action_section(env),
            "Observation space": observation_section(env),
            "rewards": reward_section(env),
            "settings": settings_section(env, spec.kwargs),
        }
        obs_shape, act_shape = env.observation_space.shape, env.action_space.shape
    finally:
        env.close()
    head = [
        f"# {spec.id}",
        "",
        f"```{{py:currentmodule}} {cls.__module__}",
        "```",
        "",
        myst_roles(summary),
        "",
        "| property | value |",
        "|---|---|",
        f"| make | `gymnasium.make(\"{spec.id}\")`, `gymnasium.make_vec(\"{spec.id}\", num_envs=N)` |",
        f"| class | {{class}}`{cls.__module__}.{cls.__qualname__}` |",
        f"| vector class | `{spec.vector_entry_point.replace(':', '.')}` |",
        f"| family | {spec.family} (tracks the {tracks}) |",
        f"| version | v{spec.version} |",
        f"| tier | {spec.tier} |",
        f"| observation shape | `{obs_shape}` |",
        f"| action shape | `{act_shape}` |",
        "",
        f"![A frame of {spec.family}-v1 (render_mode=\"rgb_array\"): the spine, its wires coloured by "
        f"temperature, the target and the tip force](../images/frame_{spec.family}-v1.png)",
        "",
        f"What `env.render()` draws for the {spec.family} family (`render_mode=\"rgb_array\"`; "
        "`scripts/render_doc_frames.py`).",
        "",
    ]
    return "\n".join(head + _placed(sections, generated))
