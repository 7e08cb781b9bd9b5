"""Layering (STYLE.md): the physics kernels are numpy + numba only."""

import ast
import pathlib
import subprocess
import sys

PHYSICS = pathlib.Path(__file__).resolve().parents[1] / "spine_gym" / "physics"
ALLOWED = {"numpy", "numba", "math", "__future__", "functools"}


def test_physics_modules_import_only_numpy_and_numba():
    files = sorted(PHYSICS.glob("*.py"))
    assert len(files) >= 5
    for f in files:
        tree = ast.parse(f.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                roots = {a.name.split(".")[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom):
                if node.level > 0:
                    continue  # relative import inside spine_gym.physics
                roots = {node.module.split(".")[0]}
            else:
                continue
            assert roots <= ALLOWED, f"{f.name} imports {roots - ALLOWED}"


def test_simulate_pulls_in_no_torch_sb3_or_matplotlib():
    code = (
        "import sys, spine_gym; spine_gym.simulate(0.05, 1.0, 0.0);"
        "bad = [m for m in ('torch', 'stable_baselines3', 'matplotlib') if m in sys.modules];"
        "print(bad); sys.exit(1 if bad else 0)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr


AGENTS = pathlib.Path(__file__).resolve().parents[1] / "agents"
CLIS = {"evaluate", "tune", "train", "select"}


def _agents_imports(tree):
    """(node, imported agents module names, inside a function?) for every import of an agents module."""
    out = []

    def visit(node, in_func):
        for child in ast.iter_child_nodes(node):
            inner = in_func or isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef)
            if isinstance(child, ast.ImportFrom) and child.level > 0:
                mods = [child.module] if child.module else [a.name for a in child.names]
                out.append((child, {m.split(".")[0] for m in mods}, inner))
            elif isinstance(child, ast.ImportFrom) and (child.module or "").startswith("agents"):
                out.append((child, {child.module.split(".")[1] if "." in child.module else ""}, inner))
            visit(child, inner)

    visit(tree, False)
    return out


def test_agents_modules_import_each_other_only_at_module_level_and_runtime_imports_no_cli():
    files = sorted(AGENTS.glob("*.py"))
    assert {"runtime.py", "registry.py"} <= {f.name for f in files}
    for f in files:
        for node, mods, in_func in _agents_imports(ast.parse(f.read_text())):
            assert not in_func, f"{f.name}:{node.lineno} imports {mods} inside a function"
            if f.stem in ("runtime", "registry", "residual"):
                assert not mods & CLIS, f"{f.name} imports the CLI module(s) {mods & CLIS}"


def test_controllers_and_mpc_pull_in_no_torch():
    code = (
        "import sys, spine_gym.controllers, agents.registry;"
        "bad = [m for m in ('torch', 'stable_baselines3', 'matplotlib') if m in sys.modules];"
        "print(bad); sys.exit(1 if bad else 0)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr
