"""TOML config files (--config): the keys of --set, typed, checked; --set wins over the file."""

import json

import pytest

from neuronav import registry
from neuronav.config import build_config, load_config_file
from neuronav.errors import ConfigError
from neuronav.runs.cli import main
from neuronav.runs.runner import load_scenario
from neuronav.scenarios.path_integration.scenario import PathIntegrationConfig


def write(tmp_path, text, name="settings.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_a_file_sets_typed_values_and_set_wins(tmp_path):
    path = write(tmp_path, 'noise = 0.2\noutbound_steps = 300\ndtype = "float64"\nkappa = 50\n')
    values = load_config_file(PathIntegrationConfig, path)
    assert values == {"noise": 0.2, "outbound_steps": 300, "dtype": "float64", "kappa": 50}
    config = build_config(PathIntegrationConfig, values, ["noise=0.3"])
    assert (config.noise, config.outbound_steps, config.dtype, config.inbound_steps) == (0.3, 300, "float64", 1500)
    assert config.kappa == 50.0 and isinstance(config.kappa, float)  # an integer for a float setting


@pytest.mark.parametrize("text, message", [
    ("nois = 0.1\n", "unknown key 'nois'; allowed: .*noise"),
    ("noise = \"0.1\"\n", "key 'noise' expects a number, got '0.1'"),
    ("outbound_steps = 1.5\n", "key 'outbound_steps' expects an integer, got 1.5"),
    ("noise = true\n", "key 'noise' expects a number, got True"),
    ("noise = 2.0\n", "key 'noise' must be <= 1.0, got 2.0"),
    ("drag = 1\n", "key 'drag' must be < 1.0"),
    ("dtype = \"float16\"\n", "key 'dtype' must be one of float32, float64; got 'float16'"),
    ("noise = [0.1, 0.2]\n", "key 'noise' expects a number, got \\[0.1, 0.2\\]"),
    ("[noise]\nvalue = 1\n", "key 'noise' expects a number"),
    ("noise = nan\n", "key 'noise' must be finite"),
    ("noise = 0.1\nnoise = 0.2\n", "is not valid TOML: Cannot overwrite a value"),
    ("noise 0.1\n", "is not valid TOML"),
])
def test_bad_files_name_the_key_and_what_is_allowed(tmp_path, text, message):
    path = write(tmp_path, text)
    with pytest.raises(ConfigError, match=message) as caught:
        load_config_file(PathIntegrationConfig, path)
    assert str(path) in str(caught.value) and "\n" not in str(caught.value)


def test_missing_or_unreadable_files(tmp_path):
    with pytest.raises(ConfigError, match="does not exist"):
        load_config_file(PathIntegrationConfig, tmp_path / "none.toml")
    with pytest.raises(ConfigError, match="cannot be read"):
        load_config_file(PathIntegrationConfig, tmp_path)  # a directory
    (tmp_path / "binary.toml").write_bytes(b"\xff\xfe noise = 1")
    with pytest.raises(ConfigError, match="cannot be read"):
        load_config_file(PathIntegrationConfig, tmp_path / "binary.toml")


def test_run_and_sweep_read_the_file_and_record_the_result(tmp_path, capsys):
    path = write(tmp_path, "outbound_steps = 120\ninbound_steps = 150\nnoise = 0.05\n")
    run_dir, sweep_dir = tmp_path / "run", tmp_path / "sweep"
    assert main(["run", "path-integration", "--config", str(path), "--set", "noise=0.0", "--trials", "2",
                 "--no-figures", "--out", str(run_dir)]) == 0
    recorded = json.loads((run_dir / "summary.json").read_text())["config"]
    assert (recorded["outbound_steps"], recorded["inbound_steps"], recorded["noise"]) == (120, 150, 0.0)
    assert main(["sweep", "path-integration", "--config", str(path), "--grid", "kappa=50,100", "--trials", "1",
                 "--workers", "1", "--no-figures", "--out", str(sweep_dir)]) == 0
    point = json.loads((sweep_dir / "kappa=50.0" / "summary.json").read_text())["config"]
    assert (point["outbound_steps"], point["noise"], point["kappa"]) == (120, 0.05, 50.0)
    capsys.readouterr()
    bad = write(tmp_path, "noise = -1\n", "bad.toml")
    assert main(["run", "path-integration", "--config", str(bad), "--out", str(tmp_path / "x")]) == 2
    assert capsys.readouterr().err == f"neuronav: error: config file '{bad}': key 'noise' must be >= 0.0, got -1.0\n"


@pytest.mark.parametrize("name", registry.names("scenario"))
@pytest.mark.parametrize("nested", [
    "x = " + "[" * 500 + "]" * 500,  # deeper than tomllib's recursion reaches
    "x = " + "{a = " * 500 + "1" + "}" * 500,
    "x = " + "[" * 300 + "]" * 300,  # tomllib reads it; still far deeper than any setting goes
    "[a.b.c.d.e]\nx = 1\n",
], ids=["arrays-500", "inline-tables-500", "arrays-300", "tables-5"])
def test_a_deeply_nested_file_is_refused_in_one_line(tmp_path, name, nested):
    path = write(tmp_path, nested + "\n")
    config_type = load_scenario(name).config_type
    with pytest.raises(ConfigError, match="nests tables or arrays more than 4 deep") as caught:
        load_config_file(config_type, path)
    assert str(path) in str(caught.value) and "\n" not in str(caught.value)


def test_nesting_up_to_the_limit_gets_the_usual_wrong_type_message(tmp_path):
    path = write(tmp_path, "noise = [[[[0.1]]]]\n")
    with pytest.raises(ConfigError, match=r"key 'noise' expects a number, got \[\[\[\[0.1\]\]\]\]"):
        load_config_file(PathIntegrationConfig, path)


def test_a_number_for_a_text_setting_stands_for_its_text(tmp_path):
    from neuronav.scenarios.cue_integration.scenario import CueIntegrationConfig, conflicts_deg

    path = write(tmp_path, "conflict_deg = 60\n")
    values = load_config_file(CueIntegrationConfig, path)
    assert values == {"conflict_deg": "60"}
    assert conflicts_deg(build_config(CueIntegrationConfig, values)) == (60.0,)
    assert conflicts_deg(build_config(CueIntegrationConfig, {"conflict_deg": 90.0})) == (90.0,)  # from Python too
    with pytest.raises(ConfigError, match="every angle must be within 0–180"):
        load_config_file(CueIntegrationConfig, write(tmp_path, "conflict_deg = 200\n", "far.toml"))
    with pytest.raises(ConfigError, match="key 'conflict_deg' expects a string, got True"):
        load_config_file(CueIntegrationConfig, write(tmp_path, "conflict_deg = true\n", "bool.toml"))


@pytest.mark.parametrize("text", ["noise = 5.0\n", 'noise = "high"\n', "noise = [0.1]\n"])
def test_a_value_that_set_overrides_is_not_checked_whatever_is_wrong_with_it(tmp_path, text):
    """As the docstring says: neither the range nor the type of a value that is not used."""
    path = write(tmp_path, text + "outbound_steps = 120\n")
    for overridden in ({"noise": 0.2}, ["noise"]):
        assert load_config_file(PathIntegrationConfig, path, overridden)["outbound_steps"] == 120
    with pytest.raises(ConfigError, match="key 'noise'"):
        load_config_file(PathIntegrationConfig, path)


def test_list_prints_integer_limits_as_integers(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    seed_lines = [line for line in out.splitlines() if "--set forest_seed=" in line]
    assert len(seed_lines) == 2 and all("x <= 2147483647]" in line for line in seed_lines), seed_lines
    assert "e+09" not in out
    assert "--set timeout_s=120.0  a trial gives up after this long (s): at least one gait cycle" in out
