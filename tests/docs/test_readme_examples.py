"""README.md's Python examples run as written, each in a fresh interpreter outside the repository.

Run from an empty folder, the examples can import only what is installed: the one import package
``neuronav`` (its subpackages ``neuronav.brains``, ``neuronav.bodies``, ``neuronav.backends``,
``neuronav.scenarios``), so an example still written with an old top-level import fails here.
"""

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[2] / "README.md"


def python_blocks(text: str) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", text, flags=re.S | re.M)


BLOCKS = python_blocks(README.read_text())


def test_the_readme_has_python_examples():
    assert len(BLOCKS) >= 4 and all("neuronav" in block for block in BLOCKS)


@pytest.mark.parametrize("number", range(len(BLOCKS)), ids=[f"block{i + 1}" for i in range(len(BLOCKS))])
def test_a_readme_example_runs_outside_the_repository(tmp_path, number):
    if "import load" in BLOCKS[number] and "dm_env_tasks" in BLOCKS[number]:  # the dm_control tasks' example
        if importlib.util.find_spec("dm_control") is None and sys.version_info >= (3, 13):
            pytest.skip("the dm_control extra does not install on Python 3.13 (labmaze has no wheel)")
    script = tmp_path / "example.py"
    script.write_text(BLOCKS[number])
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"), "MPLBACKEND": "Agg"}
    env.pop("PYTHONPATH", None)
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, f"README python block {number + 1} failed:\n{done.stderr[-3000:]}"
