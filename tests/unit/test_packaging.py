"""What the wheel installs is what the repository holds: every folder of Python modules is a package whose
``__init__.py`` git tracks (an ignore rule once hid ``neuronav/runs/__init__.py``), and ``pyproject.toml``
lists exactly those packages."""

import subprocess
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FOLDERS = {"neuronav": "neuronav", "brains": "neuronav.brains", "bodies": "neuronav.bodies",
           "backends": "neuronav.backends", "scenarios": "neuronav.scenarios"}


def tracked_files() -> list[str]:
    done = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True)
    return done.stdout.split()


def module_folders(files: list[str]) -> set[str]:
    """Folders (relative to the repository) below the package roots that hold a tracked module."""
    return {str(Path(f).parent) for f in files if f.endswith(".py") and f.split("/")[0] in FOLDERS}


def package_name(folder: str) -> str:
    top, *rest = folder.split("/")
    return ".".join([FOLDERS[top], *rest])


def test_every_folder_of_modules_is_a_tracked_package():
    files = tracked_files()
    missing = sorted(folder for folder in module_folders(files) if f"{folder}/__init__.py" not in files)
    assert not missing, f"folders of modules without a tracked __init__.py: {missing}"


def test_pyproject_lists_exactly_the_packages():
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    present = {package_name(folder) for folder in module_folders(tracked_files())}
    assert listed == present, f"not listed: {sorted(present - listed)}; listed, not present: {sorted(listed - present)}"


def test_the_checks_see_a_missing_package():
    files = ["neuronav/runs/cli.py", "scenarios/odour_trail/scenario.py", "scenarios/odour_trail/__init__.py"]
    assert module_folders(files) == {"neuronav/runs", "scenarios/odour_trail"}
    assert package_name("scenarios/odour_trail") == "neuronav.scenarios.odour_trail"
