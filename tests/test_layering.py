"""Layering: the physics kernels are numpy + numba only (the simulator must install and run without
gymnasium, torch or matplotlib); the envs need no RL stack."""

import ast
import re
import subprocess
import sys
import tomllib

from repo import ROOT

PHYSICS = ROOT / "spine_gym" / "physics"
ALLOWED = {"numpy", "numba", "math", "__future__", "functools", "collections"}


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


HEAVY = ("torch", "stable_baselines3", "optuna", "tensorboard", "jax", "sbx")


AGENTS = ROOT / "spine_gym" / "agents"
SPINE_GYM = AGENTS.parent

#: the command-line modules: each has a ``main(argv) -> int`` that ``spine-gym <command>``
#: (:mod:`spine_gym.cli`) or ``python -m`` runs; each is a thin layer over library modules
CLI_MODULES = (
    "spine_gym.cli",
    "spine_gym.agents.train",
    "spine_gym.agents.evaluate",
    "spine_gym.agents.tune",
    "spine_gym.agents.benchmark",
    "spine_gym.agents.selection",
    "spine_gym.agents.export",
    "spine_gym.agents.datasets",
    "spine_gym.agents.finetune",
    "spine_gym.agents.behaviour_cloning",
    "spine_gym.agents.rllib_ppo",
    "spine_gym.agents.family_comparison",
    "spine_gym.design.__main__",
    "spine_gym.calibrate.__main__",
    "spine_gym.experiments.reproduction",
)
#: the entry points that only hand over to a command line's ``main`` (what they may import of one)
DISPATCH = {
    "spine_gym.__main__": {"spine_gym.cli"},
    "spine_gym.experiments": {"spine_gym.experiments.reproduction"},
    "spine_gym.experiments.__main__": {"spine_gym.experiments.reproduction"},
}


def _package_modules() -> dict[str, tuple[ast.Module, str]]:
    """Every module of spine_gym: its syntax tree and the package its relative imports start from."""
    out = {}
    for f in sorted(SPINE_GYM.rglob("*.py")):
        parts = f.relative_to(SPINE_GYM.parent).with_suffix("").parts
        package = ".".join(parts[:-1])
        out[package if parts[-1] == "__init__" else ".".join(parts)] = (ast.parse(f.read_text()), package)
    return out


def _spine_gym_imports(tree: ast.Module, package: str, known: set[str]) -> set[str]:
    """Every spine_gym module a module imports, anywhere in the file (a lazy import is a dependency
    too): ``from a import b`` counts ``a.b`` where that is a module."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                start = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                base = f"{start}.{base}" if base else start
            out |= {base} | {f"{base}.{a.name}" for a in node.names}
    return out & known


def test_the_cli_modules_are_listed_and_each_has_main_argv_returning_int():
    """Every module with a top-level ``main`` is in :data:`CLI_MODULES`; each takes ``argv`` first,
    is annotated ``-> int`` and is run by ``spine-gym`` or ``python -m``."""
    from spine_gym.cli import COMMANDS

    modules = _package_modules()
    dispatched = {c.module for c in COMMANDS.values()} | {"spine_gym.cli"}
    with_main = {}
    for name, (tree, _) in modules.items():
        mains = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "main"]
        if mains:
            with_main[name] = mains[0]
    assert set(with_main) == set(CLI_MODULES)
    for name, main in with_main.items():
        assert main.args.args[0].arg == "argv", f"{name}.main takes {main.args.args[0].arg!r} first"
        assert ast.unparse(main.returns) == "int", f"{name}.main returns {ast.unparse(main.returns)}"
        guarded = any(
            isinstance(n, ast.If) and "__main__" in ast.unparse(n.test) for n in modules[name][0].body
        )
        forwarded = any(name in allowed and src in dispatched for src, allowed in DISPATCH.items())
        assert guarded or name in dispatched or forwarded, f"{name}: no spine-gym command or python -m runs it"


def test_no_cli_module_imports_another_and_libraries_import_none():
    """A command line is a thin layer over libraries: it imports no other command line (each one's
    library code is a module of its own), and no library module imports a command line."""
    modules = _package_modules()
    clis = set(CLI_MODULES)
    assert clis <= set(modules)
    for name, (tree, package) in modules.items():
        imported = _spine_gym_imports(tree, package, set(modules)) - {name}
        bad = imported & clis - DISPATCH.get(name, set())
        kind = "the command line" if name in clis else "the library module"
        assert not bad, f"{kind} {name} imports the command line(s) {sorted(bad)}"


def test_the_library_names_stay_importable_from_the_command_lines_for_one_release():
    from spine_gym.agents import datasets, evaluate, evaluation, minari_datasets

    for old, new in ((evaluate, evaluation), (datasets, minari_datasets)):
        for name in new.__all__:
            assert getattr(old, name) is getattr(new, name), f"{old.__name__}.{name}"


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


def test_agents_modules_import_each_other_only_at_module_level():
    files = sorted(AGENTS.glob("*.py"))
    assert {"runtime.py", "registry.py"} <= {f.name for f in files}
    for f in files:
        for node, mods, in_func in _agents_imports(ast.parse(f.read_text())):
            assert not in_func, f"{f.name}:{node.lineno} imports {mods} inside a function"


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
    assert {"rl", "jax", "design", "calibrate", "video", "rllib", "export", "datasets", "test", "docs", "all"} <= set(
        extras
    )
    assert any(d.startswith("torch==") for d in extras["rl"])  # pinned: never an unpinned CUDA build
    assert any(d.startswith("sbx-rl") for d in extras["jax"]) and "spine_gym[rl]" in extras["jax"]
    assert extras["all"] == ["spine_gym[rl,jax,design,calibrate,video,export,datasets,test,docs]"]


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
