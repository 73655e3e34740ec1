"""Imports flow one way: scenarios -> {brains, bodies, backends} -> neuronav; engines only in backends/."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
ALLOWED = {
    "neuronav": set(),
    "brains": {"neuronav"},
    "bodies": {"neuronav"},
    "backends": {"neuronav"},
    "scenarios": {"neuronav", "brains", "bodies", "backends"},
}
PROJECT = set(ALLOWED)
ENGINES = {"mujoco", "dm_control", "pybullet", "pybullet_data"}


def imported_modules(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.add(node.module.split(".")[0])
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


def test_the_checker_catches_a_wrong_import(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("import scenarios.path_integration\nfrom mujoco import MjModel\n")
    assert imported_modules(bad) == {"scenarios", "mujoco"}
