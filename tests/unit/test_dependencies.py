"""Imports flow one way: scenarios -> {brains, bodies} -> neuronav, backends -> neuronav; engines only in
backends/, which scenarios reach by name through the registry.

The folders brains/, bodies/, backends/ and scenarios/ install as neuronav.brains, ... (package-dir in
pyproject.toml); no top-level module of those names is installed.
"""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
ALLOWED = {
    "neuronav": set(),
    "brains": {"neuronav"},
    "bodies": {"neuronav"},
    "backends": {"neuronav"},
    "scenarios": {"neuronav", "brains", "bodies"},
}
# Scenarios reach engines by name through the registry (``registry.load("backend" | "swarm_backend",
# name)``). Still importing a backend, until the calibration is body data and the composer environment
# is reached through the registered dm_control backend (issue 21):
STILL_IMPORT_BACKENDS = {"scenarios/envs/tasks.py", "scenarios/envs/dm_env_tasks.py"}
PROJECT = set(ALLOWED)
ENGINES = {"mujoco", "dm_control", "pybullet", "pybullet_data"}


def layer(module: str) -> str:
    """The layer of an imported module: ``neuronav.brains.cx`` -> ``brains``, ``neuronav.trials`` ->
    ``neuronav``, anything else its top-level name (``mujoco.viewer`` -> ``mujoco``)."""
    parts = module.split(".")
    if parts[0] == "neuronav" and len(parts) > 1 and parts[1] in PROJECT:
        return parts[1]
    return parts[0]


def imported_modules(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found |= {layer(alias.name) for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.add(layer(node.module))
            if node.module == "neuronav":  # from neuronav import brains
                found |= {alias.name for alias in node.names if alias.name in PROJECT}
    return found


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_import_direction(package):
    files = sorted((ROOT / package).rglob("*.py"))
    assert files, f"package {package} has no modules"
    for path in files:
        modules = imported_modules(path)
        allowed = ALLOWED[package] | ({"backends"} if str(path.relative_to(ROOT)) in STILL_IMPORT_BACKENDS else set())
        wrong = (modules & PROJECT) - allowed - {package}
        assert not wrong, f"{path.relative_to(ROOT)} imports {sorted(wrong)} against the dependency arrow"
        if package != "backends":
            assert not modules & ENGINES, f"{path.relative_to(ROOT)} imports a physics engine outside backends/"


def test_the_checker_catches_a_wrong_import(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("import neuronav.scenarios.path_integration\nfrom mujoco import MjModel\n"
                   "from neuronav import backends\n")
    assert imported_modules(bad) == {"scenarios", "mujoco", "neuronav", "backends"}


# Heavy modules a command pays for only when it uses them: plotting (matplotlib), the time-series file
# (h5py), the cluster (dask), the engines. Importing the CLI or a scenario (its figure module included)
# must load none of them, so `neuronav list` and bad-input exits stay fast and a run imports each
# only when it draws, writes, distributes or simulates.
LAZY = {"matplotlib", "h5py", "dask", "distributed", "mujoco", "pybullet", "dm_control", "PIL"}
EAGER_IMPORTS = ["neuronav.cli", "neuronav.plotting", "neuronav.scenarios.path_integration",
                 "neuronav.scenarios.locomotion",
                 "neuronav.scenarios.embodied_homing", "neuronav.scenarios.path_integration_figures",
                 "neuronav.scenarios.embodied_homing_figures", "neuronav.scenarios.locomotion_figures"]


def loaded_top_level_modules(modules: list[str]) -> set[str]:
    """Top-level names in sys.modules after importing ``modules`` in a fresh interpreter."""
    code = "import sys\n" + "".join(f"import {m}\n" for m in modules) + \
        "print(' '.join(sorted({m.split('.')[0] for m in sys.modules})))"
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    return set(done.stdout.split())


def test_importing_the_cli_and_scenarios_loads_no_heavy_module():
    heavy = loaded_top_level_modules(EAGER_IMPORTS) & LAZY
    assert not heavy, f"imported at start-up (import them where they are used): {sorted(heavy)}"


def test_the_lazy_import_check_sees_a_heavy_import():
    assert "matplotlib" in loaded_top_level_modules(["matplotlib.figure"])


@pytest.mark.parametrize("name", ["brains", "bodies", "backends", "scenarios"])
def test_no_top_level_module_of_the_old_names_is_installed(tmp_path, name):
    """Outside the repository (where the folders are not on the path) only ``neuronav.NAME`` imports."""
    code = (f"import importlib.util as u; print(u.find_spec({name!r}) is None, "
            f"u.find_spec('neuronav.{name}') is not None)")
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, check=True)
    assert done.stdout.split() == ["True", "True"], done.stdout + done.stderr


def test_the_exceptions_still_import_a_backend():
    """An exception that no longer imports a backend is dropped from the list, so it cannot return."""
    for name in sorted(STILL_IMPORT_BACKENDS):
        assert "backends" in imported_modules(ROOT / name), f"{name} no longer imports a backend: drop it"
