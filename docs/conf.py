"""Sphinx configuration of the spine_gym documentation (Furo, MyST, autodoc; built by scripts/docs.sh).

Build: ``bash scripts/docs.sh`` (``sphinx-build -W --keep-going -b html docs docs/_build/html``).
No network is needed: there is no intersphinx, and the notebooks are rendered from their stored
outputs, never executed.
"""

from __future__ import annotations

import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS / "_ext"))
sys.path.insert(0, str(DOCS.parent))

import spine_gym  # noqa: E402

project = "spine_gym"
author = "spine_gym contributors"
copyright = "spine_gym contributors"
release = version = spine_gym.__version__

extensions = [
    "myst_nb",  # MyST Markdown + notebooks (includes myst_parser)
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.viewcode",
    "spine_docs",  # docs/_ext/spine_docs.py: env pages from the registered ids, notebook copies
]

source_suffix = {".md": "myst-nb", ".ipynb": "myst-nb"}
root_doc = "index"
exclude_patterns = [
    "_build",
    "Thumbs.db",
    ".DS_Store",
    "**.ipynb_checkpoints",
]

# MyST: headings get anchors (links such as agents.md#some-heading), $…$ maths, ::: fences.
myst_enable_extensions = ["dollarmath", "colon_fence", "deflist", "substitution"]
myst_heading_anchors = 4
# Cross-reference warnings (myst.xref_missing, …) are NOT suppressed: with -W a broken link fails.
suppress_warnings: list[str] = []

# Notebooks: rendered from their stored outputs, never executed.
nb_execution_mode = "off"
nb_merge_streams = True

# autodoc / napoleon: the docstrings are reST with ``literals`` and :func: roles.
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_typehints_format = "short"
autodoc_preserve_defaults = True
autosummary_generate = False
napoleon_google_docstring = True
napoleon_numpy_docstring = True
napoleon_use_rtype = False

html_theme = "furo"
html_title = f"spine_gym {release}"
html_static_path = ["_static"]
# wide tables: a scroll hint; figures: at most the page's width (docs/_static/spine_docs.*)
html_css_files = ["spine_docs.css"]
html_js_files = ["spine_docs.js"]
html_theme_options = {"navigation_with_keys": True}
