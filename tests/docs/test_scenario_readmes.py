"""Every registered scenario's folder carries a README.md in the agreed shape, and the READMEs under
``scenarios/`` only show commands that can run.

A scenario's folder is the package of its entry point's module (``neuronav.scenarios.NAME.scenario`` ->
``scenarios/NAME/``). Its README has exactly the ``##`` sections of :data:`HEADINGS`, in that order;
its *Settings* section names every setting of the scenario (its config dataclass's fields, as ``neuronav
list`` shows them) and its *Files* section every module of the folder. Every ``neuronav run|compare|sweep
NAME`` command in any README under ``scenarios/`` names a registered scenario and only ``--set KEY=`` /
``--grid KEY=`` keys that are settings of it (a ``--set KEY=`` written alone in a scenario's README is
checked against that scenario); every ``python -m MODULE`` names an importable module. A scenario's
``scenario.py`` module docstring stays short (at most :data:`MAX_DOCSTRING_LINES` lines) and points to
the README. Nothing runs: the test reads files and entry points only.
"""

import ast
import importlib.util
import re
from importlib.metadata import entry_points
from pathlib import Path

import pytest

from neuronav import registry
from neuronav.config import describe

HEADINGS = ("What it reproduces", "Sources", "Settings", "Results", "Model choices", "Files")
MAX_DOCSTRING_LINES = 25
DOCSTRING_LAST_LINE = "Results, sources and model choices: README.md in this folder."
SCENARIOS_DIR = Path(importlib.util.find_spec("neuronav.scenarios").submodule_search_locations[0])
# Folders under scenarios/ that are not scenarios but must say what they hold.
OTHER_READMES = ("tools", "worlds")

_FENCE = re.compile(r"^```[^\n]*\n(.*?)^```[ \t]*$", re.S | re.M)
_INLINE = re.compile(r"`([^`]+)`")
_NEURONAV = re.compile(r"\bneuronav\s+(?=(?:run|compare|sweep)\b)")
_PYTHON_M = re.compile(r"\bpython3?\s+-m\s+([A-Za-z_][\w.]*)")


def scenario_folders() -> dict[str, Path]:
    """Registered scenario name -> the folder of its entry point's package."""
    folders = {}
    for point in entry_points(group=registry.GROUPS["scenario"]):
        package = point.module.rpartition(".")[0]
        spec = importlib.util.find_spec(package)
        assert spec is not None and spec.submodule_search_locations, f"{point.name}: {package} is not a package"
        folders[point.name] = Path(spec.submodule_search_locations[0])
    return folders


def setting_names(name: str) -> list[str]:
    """The settings of scenario ``name``, as ``neuronav list`` shows them."""
    return [key for key, _default, _help in describe(registry.load("scenario", name).config_type)]


def headings(text: str) -> list[str]:
    """The ``##`` headings of a Markdown text, outside fenced code, in order."""
    return [line[3:].strip() for line in _FENCE.sub("", text).splitlines() if line.startswith("## ")]


def section(text: str, heading: str) -> str:
    """The text of the ``## heading`` section (up to the next ``##`` heading), or ""."""
    match = re.search(rf"^## {re.escape(heading)}[ \t]*\n(.*?)(?=^## |\Z)", _FENCE.sub("", text), re.S | re.M)
    return match.group(1) if match else ""


def code_snippets(text: str) -> list[str]:
    """Each line of fenced code (continuations joined, comments dropped) and each inline code span."""
    snippets = []
    for block in _FENCE.findall(text):
        for line in block.replace("\\\n", " ").splitlines():
            snippets.append(re.split(r"\s#", line)[0])
    snippets += _INLINE.findall(_FENCE.sub("", text))
    return snippets


def option_keys(tokens: list[str]) -> list[str]:
    """The setting keys given by ``--set KEY=V`` / ``--set=KEY=V`` / ``--grid KEY=V1,V2 ...`` in ``tokens``
    (``key`` and upper-case keys such as ``KEY`` are placeholders, not settings, and are left out)."""
    keys = []
    for i, token in enumerate(tokens):
        if token == "--set" and i + 1 < len(tokens):
            keys.append(tokens[i + 1].split("=")[0])
        elif token.startswith("--set="):
            keys.append(token[len("--set="):].split("=")[0])
        elif token == "--grid":
            for value in tokens[i + 1:]:
                if value.startswith("--") or "=" not in value:
                    break
                keys.append(value.split("=")[0])
    return [key for key in keys if not (key.isupper() or key == "key")]


def commands(text: str) -> list[tuple[str, list[str]]]:
    """(scenario, setting keys) of every ``neuronav run|compare|sweep SCENARIO ...`` command in ``text``."""
    found = []
    for snippet in code_snippets(text):
        for part in _NEURONAV.split(snippet)[1:]:
            tokens = part.replace("[", " ").replace("]", " ").split()
            if len(tokens) >= 2:
                found.append((tokens[1], option_keys(tokens[2:])))
    return found


def loose_set_keys(text: str) -> list[str]:
    """Keys of ``--set KEY=`` written in code outside any ``neuronav run|compare|sweep`` or ``python -m``."""
    keys = []
    for snippet in code_snippets(text):
        if not _NEURONAV.search(snippet) and not _PYTHON_M.search(snippet):
            keys += option_keys(snippet.replace("[", " ").replace("]", " ").split())
    return keys


FOLDERS = scenario_folders()
ALL_READMES = sorted(SCENARIOS_DIR.rglob("README.md"))


def test_every_scenario_is_a_folder_under_scenarios():
    assert len(FOLDERS) >= 9
    for name, folder in FOLDERS.items():
        assert folder.parent == SCENARIOS_DIR, f"{name}: {folder} is not a folder of {SCENARIOS_DIR}"


@pytest.mark.parametrize("name", sorted(FOLDERS))
def test_a_scenario_readme_has_the_sections_in_order(name):
    readme = FOLDERS[name] / "README.md"
    assert readme.is_file(), f"{name}: no README.md in {FOLDERS[name]}"
    found = headings(readme.read_text())
    assert tuple(found) == HEADINGS, f"{name}: README.md's ## headings are {found}, expected {list(HEADINGS)}"


@pytest.mark.parametrize("name", sorted(FOLDERS))
def test_a_scenario_readme_lists_every_setting_and_module(name):
    readme = FOLDERS[name] / "README.md"
    assert readme.is_file(), f"{name}: no README.md in {FOLDERS[name]}"
    text = readme.read_text()
    settings = section(text, "Settings")
    missing = [key for key in setting_names(name) if not re.search(rf"(?<!\w){re.escape(key)}(?!\w)", settings)]
    assert not missing, f"{name}: README.md's Settings section does not name {missing}"
    files = section(text, "Files")
    modules = sorted(p.name for p in FOLDERS[name].glob("*.py") if p.name != "__init__.py")
    unlisted = [module for module in modules if module not in files]
    assert not unlisted, f"{name}: README.md's Files section does not list {unlisted}"


@pytest.mark.parametrize("readme", ALL_READMES, ids=[str(p.relative_to(SCENARIOS_DIR)) for p in ALL_READMES])
def test_readme_commands_name_scenarios_settings_and_modules(readme):
    text = readme.read_text()
    where = readme.relative_to(SCENARIOS_DIR)
    for scenario, keys in commands(text):
        assert scenario in FOLDERS, f"{where}: 'neuronav ... {scenario}': no such scenario ({', '.join(FOLDERS)})"
        unknown = sorted(set(keys) - set(setting_names(scenario)))
        assert not unknown, f"{where}: a {scenario} command sets {unknown}, which are not settings of {scenario}"
    owner = next((name for name, folder in FOLDERS.items() if folder == readme.parent), None)
    if owner is not None:
        unknown = sorted(set(loose_set_keys(text)) - set(setting_names(owner)))
        assert not unknown, f"{where}: '--set' of {unknown}, which are not settings of {owner}"
    for module in _PYTHON_M.findall("\n".join(code_snippets(text))):
        assert importlib.util.find_spec(module) is not None, f"{where}: 'python -m {module}': no such module"


@pytest.mark.parametrize("name", sorted(FOLDERS))
def test_a_scenario_module_docstring_is_short_and_points_to_the_readme(name):
    source = (FOLDERS[name] / "scenario.py").read_text()
    docstring = ast.get_docstring(ast.parse(source)) or ""
    lines = docstring.splitlines()
    assert 0 < len(lines) <= MAX_DOCSTRING_LINES, (
        f"{name}: scenario.py's docstring has {len(lines)} lines (at most {MAX_DOCSTRING_LINES}; "
        "results and model choices go to README.md)")
    assert lines[-1].strip() == DOCSTRING_LAST_LINE, f"{name}: scenario.py's docstring must end {DOCSTRING_LAST_LINE!r}"


@pytest.mark.parametrize("folder", OTHER_READMES)
def test_tools_and_worlds_have_a_readme(folder):
    readme = SCENARIOS_DIR / folder / "README.md"
    assert readme.is_file() and readme.read_text().strip(), f"scenarios/{folder}/README.md is missing or empty"
    assert readme in ALL_READMES
