"""tests/conftest.py in CI: a skip for a package that the test extra installs fails; other skips stay skips."""

import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path
from xml.etree import ElementTree

CONFTEST = Path(__file__).resolve().parents[1] / "conftest.py"

# A project whose test extra installs two packages that are not here (one of them as an outside
# requirement's extra), and whose rl extra, outside the test extra, a third.
PYPROJECT = """
[project]
name = "demo"
version = "0"
[project.optional-dependencies]
engine = ["absent-engine-pkg>=1"]
rl = ["absent-rl-pkg"]
test = ["pytest", "demo[engine]", "absent-suite[absent_cluster]"]
[tool.pytest.ini_options]
addopts = "-p no:cacheprovider"
"""

TESTS = '''
import pytest

def test_engine():
    pytest.importorskip("absent_engine_pkg")

def test_cluster():
    pytest.skip("absent_cluster is not installed")

def test_rl():
    pytest.importorskip("absent_rl_pkg")

def test_not_about_a_package():
    pytest.skip("pytest runs this elsewhere")

def test_passes():
    pass
'''


def load_conftest():
    spec = importlib.util.spec_from_file_location("tests_conftest", CONFTEST)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def outcomes(project: Path, ci: bool) -> dict[str, tuple[str, str]]:
    """Run the demo project's tests: {test or module: (passed / skipped / failure / error, message)}."""
    env = {k: v for k, v in os.environ.items() if k != "CI"} | ({"CI": "true"} if ci else {})
    report = project / f"report_{ci}.xml"
    subprocess.run([sys.executable, "-m", "pytest", "-q", "--continue-on-collection-errors", f"--junitxml={report}",
                    "tests"], cwd=project, env=env, capture_output=True, timeout=120)
    result = {}
    for case in ElementTree.parse(report).iter("testcase"):
        verdict = next(iter(case), None)
        result[case.get("name")] = ("passed", "") if verdict is None else (verdict.tag, verdict.text)
    return result


def test_in_ci_a_skip_for_a_package_of_the_test_extra_fails_and_other_skips_stay(tmp_path):
    (tmp_path / "pyproject.toml").write_text(PYPROJECT)
    (tmp_path / "tests").mkdir()
    shutil.copy(CONFTEST, tmp_path / "tests" / "conftest.py")
    (tmp_path / "tests" / "test_demo.py").write_text(TESTS)
    (tmp_path / "tests" / "test_module_level.py").write_text(
        'import pytest\n\npytest.importorskip("absent_engine_pkg")\n\ndef test_never():\n    pass\n')

    local = outcomes(tmp_path, ci=False)
    assert {name: verdict for name, (verdict, _) in local.items()} == {
        "test_engine": "skipped", "test_cluster": "skipped", "test_rl": "skipped",
        "test_not_about_a_package": "skipped", "test_passes": "passed", "tests.test_module_level": "skipped"}

    ci = outcomes(tmp_path, ci=True)  # the module skipped at collection is an error
    assert {name: verdict for name, (verdict, _) in ci.items()} == {
        "test_engine": "failure", "test_cluster": "failure", "test_rl": "skipped",
        "test_not_about_a_package": "skipped", "test_passes": "passed", "tests.test_module_level": "error"}
    assert ci["test_engine"][1] == ("CI: skipped because 'absent_engine_pkg' cannot be imported, but the test extra "
                                    "installs it (pip install -e '.[test]'); the skip said: could not import "
                                    "'absent_engine_pkg': No module named 'absent_engine_pkg'")
    assert ci["test_cluster"][1].startswith("CI: skipped because 'absent_cluster' cannot be imported")
    assert ci["tests.test_module_level"][1].startswith("CI: skipped because 'absent_engine_pkg' cannot be imported")


def test_the_real_test_extra_lists_both_engines_and_every_optional_suite_package():
    modules = load_conftest().extra_modules(CONFTEST.parents[1] / "pyproject.toml")
    assert {"mujoco", "pybullet", "dm_control", "dask", "distributed", "gymnasium", "pettingzoo", "imageio",
            "imageio_ffmpeg", "hypothesis"} <= modules
    assert "stable_baselines3" not in modules  # the rl extra: its skip stays a skip
