"""Imports flow one way: scenarios -> {brains, bodies} -> neuronav, backends -> neuronav; engines only in
backends/, which scenarios reach by name through the registry. Inside the core too: runs -> engine ->
{senses, circuits} -> spec -> the base modules (errors, config, registry).

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
# Scenarios reach engines only by name through the registry (``registry.load("backend" | "swarm_backend",
# name)``; the dm_control composer environments through the registered backend's ``composer_environment``),
# and the kinematic unicycle's calibration is body data: no scenario imports ``backends`` (issue 21).
PROJECT = set(ALLOWED)
ENGINES = {"mujoco", "dm_control", "pybullet", "pybullet_data"}


def layer(module: str) -> str:
    """The layer of an imported module: ``neuronav.brains.cx`` -> ``brains``, ``neuronav.runs.trials`` ->
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
        wrong = (modules & PROJECT) - ALLOWED[package] - {package}
        assert not wrong, f"{path.relative_to(ROOT)} imports {sorted(wrong)} against the dependency arrow"
        if package != "backends":
            assert not modules & ENGINES, f"{path.relative_to(ROOT)} imports a physics engine outside backends/"


# The core's rooms, each allowed to import the rooms listed (and itself).
CORE_ALLOWED = {
    "base": set(),  # neuronav/errors.py, config.py, registry.py, angles.py
    "spec": {"base"},
    "circuits": {"base", "spec"},
    "senses": {"base", "spec"},
    "engine": {"base", "spec", "senses", "circuits"},
    "runs": {"base", "spec", "senses", "circuits", "engine"},
}
PACKAGE_ROOT = {"__init__.py", "__main__.py"}  # the package's face: re-exports from any room


def core_room(module: str) -> str | None:
    """The room of a core module: ``neuronav.senses.plume`` -> ``senses``, ``neuronav.errors`` -> ``base``;
    None for anything outside the core (and for ``neuronav`` itself)."""
    parts = module.split(".")
    if parts[0] != "neuronav" or len(parts) == 1 or parts[1] in PROJECT:
        return None
    return parts[1] if parts[1] in CORE_ALLOWED else "base"


def imported_core_rooms(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found |= {core_room(alias.name) for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if node.module == "neuronav":  # from neuronav import registry / spec
                found |= {core_room(f"neuronav.{alias.name}") for alias in node.names}
            else:
                found.add(core_room(node.module))
    return found - {None}


def test_the_core_is_in_rooms():
    """Every core module sits in a room (or is one of the base modules)."""
    loose = {p.name for p in (ROOT / "neuronav").glob("*.py")} - PACKAGE_ROOT
    assert loose == {"errors.py", "config.py", "registry.py", "angles.py"}
    assert {p.name for p in (ROOT / "neuronav").iterdir() if p.is_dir() and p.name != "__pycache__"} == \
        set(CORE_ALLOWED) - {"base"}


def test_import_direction_inside_the_core():
    for path in sorted((ROOT / "neuronav").rglob("*.py")):
        relative = path.relative_to(ROOT / "neuronav")
        if str(relative) in PACKAGE_ROOT:
            continue
        room = relative.parts[0] if len(relative.parts) > 1 else "base"
        wrong = imported_core_rooms(path) - CORE_ALLOWED[room] - {room}
        assert not wrong, f"neuronav/{relative} ({room}) imports {sorted(wrong)} against the core's order"


def test_the_core_checker_catches_a_wrong_import(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("from neuronav.runs.trials import run_trials\nimport neuronav.senses.plume\n"
                   "from neuronav import registry, spec\nfrom neuronav.brains import cx\n")
    assert imported_core_rooms(bad) == {"runs", "senses", "base", "spec"}


def test_the_checker_catches_a_wrong_import(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("import neuronav.scenarios.path_integration.scenario\nfrom mujoco import MjModel\n"
                   "from neuronav import backends\n")
    assert imported_modules(bad) == {"scenarios", "mujoco", "neuronav", "backends"}


# Heavy modules a command pays for only when it uses them: plotting (matplotlib), the time-series file
# (h5py), the cluster (dask), the engines. Importing the CLI or a scenario (its figure module included)
# must load none of them, so `neuronav list` and bad-input exits stay fast and a run imports each
# only when it draws, writes, distributes or simulates.
LAZY = {"matplotlib", "h5py", "dask", "distributed", "mujoco", "pybullet", "dm_control", "PIL"}
EAGER_IMPORTS = ["neuronav.runs.cli", "neuronav.runs.plotting", "neuronav.scenarios.path_integration.scenario",
                 "neuronav.scenarios.locomotion.scenario",
                 "neuronav.scenarios.path_integration.embodied", "neuronav.scenarios.path_integration.figures",
                 "neuronav.scenarios.path_integration.embodied_figures", "neuronav.scenarios.locomotion.figures"]


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
