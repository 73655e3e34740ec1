"""TOML config files (--config): the keys of --set, typed, checked; --set wins over the file."""

import json

import pytest

from neuronav.cli import main
from neuronav.config import build_config, load_config_file
from neuronav.errors import ConfigError
from scenarios.path_integration import PathIntegrationConfig


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
