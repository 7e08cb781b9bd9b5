"""Sphinx extension of the spine_gym docs: pages generated at build time (all gitignored).

* ``docs/envs/<id>.md`` — one page per registered env id (``spine_gym.envs.ids.ENV_SPECS``): its
  observation and action spaces, reward coefficients and task settings read from
  ``gymnasium.make(id)``, and the entry point's class docstring (:mod:`env_pages`).
* ``docs/envs/index.md`` — the table of every id and the toctree of those pages.
* ``docs/notebooks/*.ipynb`` — copies of ``notebooks/*.ipynb`` (the source directory is ``docs/``),
  rendered by myst-nb from their stored outputs.

In the API reference an env class's docstring is replaced by a link to its env page: it is Markdown
(the env page), not reST.
"""

from __future__ import annotations

import functools
import shutil
from pathlib import Path

import env_pages

DOCS = Path(__file__).resolve().parents[1]
ROOT = DOCS.parent


def _write_if_changed(path: Path, text: str) -> None:
    """Write ``text`` unless ``path`` already holds it (an unchanged file is not rebuilt)."""
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")


def env_page(spec) -> str:
    """The Markdown page of one :class:`spine_gym.envs.ids.EnvSpec` (:func:`env_pages.env_page`)."""
    from spine_gym.envs.ids import _TRACKS

    return env_pages.env_page(spec, _TRACKS[spec.family])


def envs_index(specs) -> str:
    from spine_gym.envs.ids import _TRACKS

    lines = [
        "# Environment ids",
        "",
        "One page per registered id, generated when the site is built: its spaces, reward coefficients",
        "and settings from `gymnasium.make(id)`, the rest from the class docstring of its entry point.",
        "The user guide to the environments is [Environments](../envs.md).",
        "",
        "| id | tracks | version | tier | observation | keyword arguments set |",
        "|---|---|---|---|---|---|",
    ]
    for s in specs:
        n, shape = len(s.kwargs), env_pages.observation_shape(s.id)
        link = f"[{s.id}]({s.id}.md)"
        cells = [link, _TRACKS[s.family], f"v{s.version}", s.tier, f"`{shape}`", str(n or "none")]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "```{toctree}", ":hidden:", ""] + [s.id for s in specs] + ["```", ""]
    return "\n".join(lines)


def generate(app) -> None:
    """``builder-inited``: write the env pages and copy the notebooks into the source directory."""
    from spine_gym.envs.ids import ENV_SPECS

    out = DOCS / "envs"
    specs = list(ENV_SPECS.values())
    keep = {"index.md"} | {f"{s.id}.md" for s in specs}
    for old in out.glob("*.md") if out.is_dir() else ():
        if old.name not in keep:
            old.unlink()
    for s in specs:
        _write_if_changed(out / f"{s.id}.md", env_page(s))
    _write_if_changed(out / "index.md", envs_index(specs))

    nb_out = DOCS / "notebooks"
    nb_out.mkdir(exist_ok=True)
    for nb in sorted((ROOT / "notebooks").glob("*.ipynb")):
        dest = nb_out / nb.name
        if not dest.exists() or dest.read_bytes() != nb.read_bytes():
            shutil.copyfile(nb, dest)


@functools.cache
def _env_classes() -> dict[object, str]:
    from spine_gym.envs.ids import ENV_SPECS

    pages: dict[object, str] = {}
    for s in ENV_SPECS.values():
        pages.setdefault(env_pages.entry_class(s.entry_point), s.id)
    return pages


def env_docstring(app, what, name, obj, options, lines) -> None:
    """``autodoc-process-docstring``: an env class's docstring (Markdown) becomes a link to its page."""
    if what != "class":
        return
    pages = _env_classes()
    if obj in pages:
        first = lines[0] if lines else ""
        lines[:] = [first, "", f"The documentation page of this class is :doc:`/envs/{pages[obj]}`.", ""]


def viewcode_backlinks(app, env) -> None:
    """``env-updated``: make viewcode's source pages link back to anchors that exist.

    viewcode keeps one prefix per source module for the links from its source page back to the
    documentation (``#<prefix>.<name>``): the module under which the first object of it was
    documented. When an object is documented under a module that re-exports it (``spine_gym.envs``
    for ``spine_gym.envs.ids.EnvSpec``) before the defining module's own objects, every link back
    gets the wrong prefix. Here each module gets the candidate prefix (its recorded one, or its own
    name) under which most of its documented names exist. Modules viewcode could not read
    (``builtins``) are dropped: the index of source pages would link to a page that is not written.
    """
    modules = getattr(env, "_viewcode_modules", {})
    objects = env.get_domain("py").objects
    for modname in list(modules):
        entry = modules[modname]
        if not entry:
            del modules[modname]
            continue
        code, tags, used, refname = entry
        best = max((refname, modname), key=lambda p: sum(f"{p}.{n}" in objects for n in used))
        modules[modname] = (code, tags, used, best)


def setup(app):
    app.connect("builder-inited", generate)
    app.connect("autodoc-process-docstring", env_docstring)
    app.connect("env-updated", viewcode_backlinks)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
