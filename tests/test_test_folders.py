"""The test tree mirrors the package: the tests of ``spine_gym/<part>/`` sit in ``tests/<part>/``, those of a
package-level module ``spine_gym/<name>.py`` in ``tests/test_<name>.py``; helpers shared by several test
files sit in ``tests/support/`` (on pytest's ``pythonpath``), never in a test file another one imports."""

import ast

from repo import ROOT

TESTS = ROOT / "tests"
PACKAGE = ROOT / "spine_gym"
HELPERS = TESTS / "support"
# top-level test files that check the repository as a whole rather than one module
REPOSITORY_CHECKS = {
    "test_readme.py",
    "test_notebook.py",
    "test_layering.py",
    "test_test_folders.py",
    "test_docs_env_pages.py",  # the documentation site's env pages against gymnasium.make
    "test_docs_browser.py",  # the documentation site in a browser
}


def _test_folders():
    return sorted(d for d in TESTS.rglob("*") if d.is_dir() and d.name != "__pycache__" and d != HELPERS)


def _test_files():
    return sorted(TESTS.rglob("test_*.py"))


def test_every_test_folder_mirrors_a_subpackage():
    """``tests/a/b/`` exists only if ``spine_gym/a/b/`` is a package."""
    stray = [d.relative_to(TESTS) for d in _test_folders() if HELPERS not in d.parents]
    stray = [d for d in stray if not (PACKAGE / d / "__init__.py").is_file()]
    assert not stray, f"test folders with no spine_gym subpackage of that name: {stray}"


def test_top_level_test_files_test_a_package_level_module():
    """A test file directly in ``tests/`` is named after a module ``spine_gym/<name>.py`` (or ``_<name>.py``)
    or is one of the few checks of the whole repository."""
    top = [f for f in TESTS.glob("test_*.py") if f.name not in REPOSITORY_CHECKS]
    modules = {p.stem.lstrip("_") for p in PACKAGE.glob("*.py")}
    stray = [f.name for f in top if f.stem.removeprefix("test_") not in modules]
    assert not stray, (
        f"move these into the tests/<part>/ of the code they test, or name them after it: {stray}"
    )


def test_helpers_hold_no_tests():
    assert not list(HELPERS.glob("test_*.py")), "tests/support/ holds helpers only"


def _imported_modules(path):
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            yield from (a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            yield node.module


def test_no_test_file_imports_another():
    """Shared helpers go to tests/support/: under pytest's importlib import mode a test file is not
    importable by its name, and an import would tie two files' places together."""
    bad = {
        str(f.relative_to(TESTS)): m
        for f in _test_files()
        for m in _imported_modules(f)
        if m.split(".")[0].startswith(("test_", "conftest"))
    }
    assert not bad, f"test files importing a test module (move the shared code to tests/support/): {bad}"
