"""Shared test settings: headless plotting, one BLAS thread (CI has 2 cores); in CI, no skip for a missing engine.

The ``test`` extra of ``pyproject.toml`` installs both physics engines, dm_control, Dask, Gymnasium,
PettingZoo and video writing, so in CI (the environment variable ``CI`` set, as CI services do) a
test skipped because one of them cannot be imported hides a broken install: it is reported as a
failure instead, with one line naming the package. Skips for packages outside that extra (e.g.
stable-baselines3, the ``rl`` extra) stay skips.
"""

import functools
import importlib
import importlib.metadata
import os
import re
import tomllib
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

PYPROJECT = Path(__file__).resolve().parents[1] / "pyproject.toml"


def _normalise(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def extra_modules(pyproject: Path, extra: str = "test") -> set[str]:
    """Import names of every package the ``extra`` of the project in ``pyproject`` installs, its own
    nested extras (``project[a,b]``) resolved; an outside requirement's extras count as packages too
    (``dask[distributed]`` installs ``distributed``)."""
    from packaging.requirements import Requirement

    project = tomllib.loads(pyproject.read_text())["project"]
    extras, own = project.get("optional-dependencies", {}), _normalise(project["name"])
    distributions: set[str] = set()
    pending, seen = [extra], set()
    while pending:
        name = pending.pop()
        if name in seen:
            continue
        seen.add(name)
        for line in extras.get(name, ()):
            requirement = Requirement(line)
            if _normalise(requirement.name) == own:
                pending.extend(requirement.extras)
            else:
                distributions |= {_normalise(requirement.name), *map(_normalise, requirement.extras)}
    # An installed distribution names its modules (pybullet: pybullet, pybullet_data, ...); a missing one
    # is taken to be imported under its own name (dm-control: dm_control).
    installed: dict[str, set[str]] = {}
    for module, owners in importlib.metadata.packages_distributions().items():
        for owner in owners:
            installed.setdefault(_normalise(owner), set()).add(module)
    return set().union(*({d.replace("-", "_")} | installed.get(d, set()) for d in distributions))


@functools.cache
def _test_extra_modules() -> frozenset[str]:
    return frozenset(extra_modules(PYPROJECT)) if PYPROJECT.is_file() else frozenset()


def _missing_extra_module(reason: str) -> str | None:
    """The test extra's module that ``reason`` names and that cannot be imported here, else None."""
    for module in sorted(_test_extra_modules()):
        if not re.search(rf"(?<![\w.]){re.escape(module)}(?!\w)", reason):
            continue
        try:
            importlib.import_module(module)
        except Exception:
            return module
    return None


def _fail_if_an_installed_extra_is_missing(report, reason: str) -> None:
    """In CI, turn the skipped ``report`` into a failure when its reason is a missing test-extra package."""
    if os.environ.get("CI", "").lower() in ("", "0", "false") or not report.skipped:
        return
    module = _missing_extra_module(reason)
    if module is None:
        return
    report.outcome = "failed"
    report.longrepr = (f"CI: skipped because {module!r} cannot be imported, but the test extra installs it "
                       f"(pip install -e '.[test]'); the skip said: {' '.join(reason.split())}")


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    report = (yield).get_result()
    if call.excinfo is not None and call.excinfo.errisinstance(pytest.skip.Exception):
        _fail_if_an_installed_extra_is_missing(report, str(call.excinfo.value.msg))


@pytest.hookimpl(hookwrapper=True)
def pytest_make_collect_report(collector):
    report = (yield).get_result()
    if report.skipped and isinstance(report.longrepr, tuple):  # (path, line, reason) of a module-level skip
        _fail_if_an_installed_extra_is_missing(report, str(report.longrepr[2]).removeprefix("Skipped: "))
