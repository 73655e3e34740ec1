"""neuronav: embodied, multi-modal simulation of insect navigation.

The core: circuits of rate neurons, sensor/motor ports, the backend protocol, worlds, scenarios,
run directories and the command line. It imports no physics engine and none of its sibling
packages (brains, bodies, backends, scenarios): those are found by name through entry points.
"""

from neuronav.circuit import Circuit, Population
from neuronav.compiled import CompiledCircuit
from neuronav.errors import (
    CircuitError,
    ConfigError,
    NeuronavError,
    PortError,
    RegistryError,
    SimulationError,
)
from neuronav.ports import MotorSpec, SensorSpec, bind

__version__ = "0.1.0"

__all__ = [
    "Circuit", "CompiledCircuit", "Population", "SensorSpec", "MotorSpec", "bind",
    "NeuronavError", "CircuitError", "ConfigError", "PortError", "RegistryError", "SimulationError",
]
