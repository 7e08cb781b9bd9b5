"""Sphinx extension of the spine_gym docs: pages generated at build time (all gitignored).

* ``docs/envs/<id>.md`` — one page per registered env id (``spine_gym.envs.ids.ENV_SPECS``), made
  of a table of what the id's registration sets (family, version, tier, keyword arguments) and the
  entry point's class docstring, which is the env's documentation page (Gymnasium's convention).
* ``docs/envs/index.md`` — the table of every id and the toctree of those pages.
* ``docs/notebooks/*.ipynb`` — copies of ``notebooks/*.ipynb`` (the source directory is ``docs/``),
  rendered by myst-nb from their stored outputs.

In the API reference an env class's docstring is replaced by a link to its env page: it is Markdown
(the env page), not reST.
"""

from __future__ import annotations

import functools
import importlib
import inspect
import shutil
from pathlib import Path

DOCS = Path(__file__).resolve().parents[1]
ROOT = DOCS.parent


def _write_if_changed(path: Path, text: str) -> None:
    """Write ``text`` unless ``path`` already holds it (an unchanged file is not rebuilt)."""
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")


def _entry_class(entry_point: str):
    module, name = entry_point.split(":")
    return getattr(importlib.import_module(module), name)


def _value(v) -> str:
    return f"`{v!r}`".replace("|", "\\|")


def env_page(spec) -> str:
    """The Markdown page of one :class:`spine_gym.envs.ids.EnvSpec`."""
    from spine_gym.envs.ids import _TRACKS

    cls = _entry_class(spec.entry_point)
    doc = inspect.cleandoc(cls.__doc__ or "")
    summary, _, body = doc.partition("\n\n")
    lines = [
        f"# {spec.id}",
        "",
        summary.strip(),
        "",
        "| property | value |",
        "|---|---|",
        f"| make | `gymnasium.make(\"{spec.id}\")`, `gymnasium.make_vec(\"{spec.id}\", num_envs=N)` |",
        f"| class | `{cls.__module__}.{cls.__qualname__}` |",
        f"| vector class | `{spec.vector_entry_point.replace(':', '.')}` |",
        f"| family | {spec.family} (tracks the {_TRACKS[spec.family]}) |",
        f"| version | v{spec.version} |",
        f"| tier | {spec.tier} |",
        "",
        "## Keyword arguments of the registration",
        "",
    ]
    if spec.kwargs:
        lines += ["| keyword argument | value |", "|---|---|"]
        lines += [f"| `{k}` | {_value(v)} |" for k, v in spec.kwargs.items()]
        lines += ["", "Any other keyword argument of the class keeps its default; all can be overridden in `make`."]
    else:
        lines += ["None: the class defaults. Any keyword argument of the class can be passed to `make`."]
    lines += ["", body.strip(), ""]
    return "\n".join(lines)


def envs_index(specs) -> str:
    from spine_gym.envs.ids import _TRACKS

    lines = [
        "# Environment ids",
        "",
        "One page per registered id, generated from the class docstring of its entry point and the",
        "keyword arguments its registration passes (`spine_gym.envs.ids.ENV_SPECS`). The user guide to",
        "the environments is [Environments](../envs.md).",
        "",
        "| id | tracks | version | tier | keyword arguments set |",
        "|---|---|---|---|---|",
    ]
    for s in specs:
        n = len(s.kwargs)
        lines.append(f"| [{s.id}]({s.id}.md) | {_TRACKS[s.family]} | v{s.version} | {s.tier} | {n or 'none'} |")
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
        pages.setdefault(_entry_class(s.entry_point), s.id)
    return pages


def env_docstring(app, what, name, obj, options, lines) -> None:
    """``autodoc-process-docstring``: an env class's docstring (Markdown) becomes a link to its page."""
    if what != "class":
        return
    pages = _env_classes()
    if obj in pages:
        first = lines[0] if lines else ""
        lines[:] = [first, "", f"The documentation page of this class is :doc:`/envs/{pages[obj]}`.", ""]


def setup(app):
    app.connect("builder-inited", generate)
    app.connect("autodoc-process-docstring", env_docstring)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
