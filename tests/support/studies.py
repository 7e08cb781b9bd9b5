"""The study scripts of ``scripts/studies/`` as modules, for their tests (they are not in the package)."""

import importlib.util
import sys

from repo import ROOT

STUDIES = ROOT / "scripts" / "studies"


def load_study(name: str):
    """The module of ``scripts/studies/<name>.py`` (loaded once, kept in ``sys.modules``)."""
    key = f"studies_{name}"
    if key not in sys.modules:
        spec = importlib.util.spec_from_file_location(key, STUDIES / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        sys.modules[key] = module
        spec.loader.exec_module(module)
    return sys.modules[key]
