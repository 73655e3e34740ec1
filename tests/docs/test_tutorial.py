"""docs/tutorial.md runs as written: its Python blocks, executed in order in one namespace."""

import re
from pathlib import Path

import pytest

from neuronav import registry

TUTORIAL = Path(__file__).resolve().parents[2] / "docs" / "tutorial.md"


def python_blocks(text: str) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", text, flags=re.S | re.M)


def test_the_tutorial_has_code_to_run():
    blocks = python_blocks(TUTORIAL.read_text())
    assert len(blocks) >= 4
    assert any("compile(" in b for b in blocks) and any('"mujoco"' in b for b in blocks)


def test_the_tutorial_runs(capsys):
    ok, reason = registry.availability("backend", "mujoco")
    if not ok:
        pytest.skip(reason)
    namespace = {"__name__": "tutorial"}
    for number, block in enumerate(python_blocks(TUTORIAL.read_text()), 1):
        exec(compile(block, f"{TUTORIAL.name}, python block {number}", "exec"), namespace)
    printed = capsys.readouterr().out
    assert "kinematic:" in printed and "mujoco:" in printed


def test_the_block_extractor_finds_only_python_blocks():
    text = "intro\n```python\na = 1\n```\n```\nnot python\n```\n```python\nb = 2\n```\n"
    assert python_blocks(text) == ["a = 1\n", "b = 2\n"]
