"""Layering: the physics kernels are numpy + numba only (the simulator must install and run without
gymnasium, torch or matplotlib); the envs need no RL stack."""

import ast
import re
import subprocess
import sys
import tomllib

from repo import ROOT

PHYSICS = ROOT / "spine_gym" / "physics"
ALLOWED = {"numpy", "numba", "math", "__future__", "functools"}


def test_physics_modules_import_only_numpy_and_numba():
    files = sorted(PHYSICS.rglob("*.py"))  # the shared modules and both cores (planar/, spatial/)
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
            assert roots <= ALLOWED, f"{f.relative_to(PHYSICS)} imports {roots - ALLOWED}"


def test_simulate_pulls_in_no_torch_sb3_or_matplotlib():
    code = (
        "import sys, spine_gym; spine_gym.simulate(0.05, 1.0, 0.0);"
        "bad = [m for m in ('torch', 'stable_baselines3', 'matplotlib') if m in sys.modules];"
        "print(bad); sys.exit(1 if bad else 0)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr


HEAVY = ("torch", "stable_baselines3", "optuna", "tensorboard")


AGENTS = ROOT / "spine_gym" / "agents"
CLIS = {"evaluate", "tune", "train", "select", "benchmark"}
RUNTIME = {"runtime", "registry", "residual", "observations", "training", "benchmark_run", "zoo_config"}


def _agents_imports(tree):
    """(node, imported agents module names, inside a function?) for every import of an agents module."""
    out = []

    def visit(node, in_func):
        for child in ast.iter_child_nodes(node):
            inner = in_func or isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef)
            if isinstance(child, ast.ImportFrom) and child.level > 0:
                mods = [child.module] if child.module else [a.name for a in child.names]
                out.append((child, {m.split(".")[0] for m in mods}, inner))
            elif isinstance(child, ast.ImportFrom) and (child.module or "").startswith("spine_gym.agents"):
                out.append((child, {child.module.split(".")[2] if child.module.count(".") >= 2 else ""}, inner))
            visit(child, inner)

    visit(tree, False)
    return out


def test_agents_modules_import_each_other_only_at_module_level_and_runtime_imports_no_cli():
    files = sorted(AGENTS.glob("*.py"))
    assert {"runtime.py", "registry.py"} <= {f.name for f in files}
    for f in files:
        for node, mods, in_func in _agents_imports(ast.parse(f.read_text())):
            assert not in_func, f"{f.name}:{node.lineno} imports {mods} inside a function"
            if f.stem in RUNTIME:
                assert not mods & CLIS, f"{f.name} imports the CLI module(s) {mods & CLIS}"


def test_the_agents_registry_pulls_in_no_rl_stack():
    code = (
        "import sys, spine_gym.controllers, spine_gym.agents.registry;"
        f"bad = [m for m in {HEAVY!r} if m in sys.modules];"
        "print(bad); sys.exit(1 if bad else 0)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr


def test_the_envs_controllers_and_simulate_import_no_rl_or_design_stack():
    """``pip install spine_gym`` (no extras) is enough for the simulator and the envs."""
    code = (
        "import sys, numpy as np, gymnasium as gym, spine_gym, spine_gym.envs, spine_gym.controllers;"
        "env = gym.make('SmaSpine-v0'); env.reset(seed=0); env.step(np.zeros(2));"
        "venv = gym.make_vec('SmaSpine-v0', num_envs=2); venv.reset(seed=0); venv.step(np.zeros((2, 2)));"
        "spine_gym.simulate(0.05, 1.0, 0.0);"
        f"bad = [m for m in {HEAVY!r} + ('spine_gym.envs.sb3',) if m in sys.modules];"
        "print(bad); sys.exit(1 if bad else 0)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr


def test_base_dependencies_leave_the_heavy_stack_to_extras():
    meta = tomllib.loads((PHYSICS.parents[1] / "pyproject.toml").read_text())["project"]
    names = {re.split(r"[<>=\[ ;]", d, maxsplit=1)[0].lower() for d in meta["dependencies"]}
    assert names == {"numpy", "numba", "gymnasium", "matplotlib", "tqdm", "rich", "pyyaml"}
    extras = meta["optional-dependencies"]
    assert {"rl", "design", "calibrate", "video", "rllib", "export", "datasets", "test", "docs", "all"} <= set(extras)
    assert any(d.startswith("torch==") for d in extras["rl"])  # pinned: never an unpinned CUDA build
    assert extras["all"] == ["spine_gym[rl,design,calibrate,video,export,datasets,test,docs]"]


def test_exported_policy_runner_and_c_writer_import_only_numpy_and_the_standard_library():
    """spine_gym/agents/numpy_policy.py runs an exported bundle where torch, SB3 and spine_gym are absent;
    spine_gym/agents/export_c.py writes the C from the bundle's arrays alone."""
    agents = PHYSICS.parents[1] / "spine_gym" / "agents"
    stdlib = set(sys.stdlib_module_names) | {"__future__"}
    for name in ("numpy_policy.py", "export_c.py"):
        tree = ast.parse((agents / name).read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                roots = {a.name.split(".")[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom):
                assert node.level == 0, f"{name} imports from the agents package"
                roots = {node.module.split(".")[0]}
            else:
                continue
            assert roots <= stdlib | {"numpy"}, f"{name} imports {roots - stdlib - {'numpy'}}"
