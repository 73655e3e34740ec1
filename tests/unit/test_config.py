"""Scenario configs: --set parsing and validation give clear errors naming the key."""

import pytest

from neuronav.config import apply_overrides
from neuronav.errors import ConfigError
from neuronav.scenarios.path_integration.scenario import PathIntegrationConfig


def test_defaults_and_typed_overrides():
    config = apply_overrides(PathIntegrationConfig, ["noise=0.2", "outbound_steps=300"])
    assert config.noise == 0.2 and config.outbound_steps == 300 and config.inbound_steps == 1500


@pytest.mark.parametrize("assignment, message", [
    ("nois=0.1", "unknown key 'nois'; allowed: .*noise"),
    ("noise=abc", "key 'noise' expects a number, got 'abc'"),
    ("outbound_steps=1.5", "key 'outbound_steps' expects an integer"),
    ("noise=-1", "key 'noise' must be >= 0.0"),
    ("drag=1", "key 'drag' must be < 1.0"),
    ("success_radius=0", "key 'success_radius' must be > 0.0"),
    ("noise=nan", "key 'noise' expects a number"),
    ("noise", "--set expects key=value"),
])
def test_bad_overrides(assignment, message):
    with pytest.raises(ConfigError, match=message):
        apply_overrides(PathIntegrationConfig, [assignment])


def test_python_values_are_validated_too():
    with pytest.raises(ConfigError, match="key 'inbound_steps' expects an integer"):
        apply_overrides(PathIntegrationConfig, {"inbound_steps": "many"})
    with pytest.raises(ConfigError, match="key 'noise' expects a number"):
        apply_overrides(PathIntegrationConfig, {"noise": [0.1]})
