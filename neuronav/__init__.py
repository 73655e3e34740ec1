"""neuronav: embodied, multi-modal simulation of insect navigation.

The core: circuits of rate neurons, sensor/motor ports, the backend protocol, worlds, scenarios,
run directories and the command line. It imports no physics engine and none of its sibling
packages (brains, bodies, backends, scenarios): those are found by name through entry points.
"""

from neuronav.errors import (
    CircuitError,
    ConfigError,
    NeuronavError,
    PortError,
    RegistryError,
    SimulationError,
)
from neuronav.spec.ports import MotorSpec, SensorSpec, bind

__version__ = "0.1.0"

# The circuit classes load on first use (they bring networkx: 0.1 s a run that has no circuit, such as
# a locomotion run, need not pay).
_LAZY = {"Circuit": "neuronav.circuits.circuit", "Population": "neuronav.circuits.circuit",
         "CompiledCircuit": "neuronav.circuits.compiled"}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'neuronav' has no attribute {name!r}")

__all__ = [
    "Circuit", "CompiledCircuit", "Population", "SensorSpec", "MotorSpec", "bind",
    "NeuronavError", "CircuitError", "ConfigError", "PortError", "RegistryError", "SimulationError",
]
