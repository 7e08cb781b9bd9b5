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
