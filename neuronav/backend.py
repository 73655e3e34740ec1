"""The backend protocol: what every physics (or kinematic) engine offers the agent loop.

Backends register under the entry-point group ``neuronav.backends`` and are found by name
(:mod:`neuronav.registry`). ``read`` is lazy: only the names asked for are computed.

Articulated (physics) backends simulate one body and share these sensors, each read with a
leading batch dimension of 1 (J hinge joints, C contact sites, O/W odour/wind sites):
``joint_pos`` (J,) rad, ``joint_vel`` (J,) rad/s, ``joint_torque`` (J,) N*m, ``contact_force``
(C, 3) N in the world frame, ``body_pos`` (3,) m, ``body_quat`` (4,) (w, x, y, z),
``body_linvel`` (3,) m/s, ``body_angvel`` (3,) rad/s, ``heading`` (1,) rad clockwise from +y,
``velocity`` (2,) m/s and ``position`` (2,) m in the world xy plane, ``odour_sites`` (O, 3) and
``wind_sites`` (W, 3); they accept ``joint_targets`` (J,) rad for position-controlled joints
(torque = kp (target - q) - kd q', clipped to each joint's max torque). ``reset(seed,
position_m=(x, y), yaw_rad=...)`` puts the body at its rest pose above the terrain.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from neuronav.errors import PortError
from neuronav.ports import MotorSpec, SensorSpec
from neuronav.world import World


@dataclass(frozen=True)
class Capabilities:
    """What a backend can do.

    Attributes
    ----------
    name : str
    sensors : tuple of SensorSpec
        What ``read`` can return (shapes per agent, without the batch dimension).
    motors : tuple of MotorSpec
        What ``write`` accepts.
    batched : bool
        Whether one instance simulates many agents at once.
    can_render : bool
        Whether ``render`` produces camera images.
    """

    name: str
    sensors: tuple[SensorSpec, ...]
    motors: tuple[MotorSpec, ...]
    batched: bool = False
    can_render: bool = False


@runtime_checkable
class Backend(Protocol):
    """The interface the agent loop uses; see DESIGN.md."""

    capabilities: Capabilities

    def load(self, world: World, bodies: Sequence[Any]) -> None: ...
    def reset(self, seed: int | None = None, **pose) -> None: ...
    def step(self, n: int = 1) -> None: ...
    def read(self, names: Iterable[str]) -> dict[str, np.ndarray]: ...
    def write(self, commands: dict[str, np.ndarray]) -> None: ...
    def render(self, camera: str) -> np.ndarray: ...
    def apply_force(self, body: int | str, site: str, force_n: np.ndarray) -> None: ...
    @property
    def time(self) -> float: ...
    @property
    def timestep(self) -> float: ...
    def close(self) -> None: ...
    def __enter__(self) -> Backend: ...
    def __exit__(self, *exc: object) -> None: ...


class BackendBase:
    """Shared plumbing: name checks for ``read``/``write`` and the context-manager methods."""

    capabilities: Capabilities

    def _check_read(self, names: Iterable[str]) -> list[str]:
        names = list(names)
        known = {s.name for s in self.capabilities.sensors}
        for name in names:
            if name not in known:
                raise PortError(
                    f"backend {self.capabilities.name!r} has no sensor {name!r}; "
                    f"available: {', '.join(sorted(known))}"
                )
        return names

    def _check_write(self, commands: dict[str, np.ndarray], batch: int) -> dict[str, np.ndarray]:
        specs = {m.name: m for m in self.capabilities.motors}
        checked = {}
        for name, value in commands.items():
            spec = specs.get(name)
            if spec is None:
                raise PortError(
                    f"backend {self.capabilities.name!r} accepts no command {name!r}; "
                    f"accepted: {', '.join(sorted(specs))}"
                )
            array = np.asarray(value, dtype=float)
            expected = (batch, *spec.shape)
            if array.shape != expected:
                if array.shape == (batch,) and spec.shape == (1,):
                    array = array[:, None]
                else:
                    raise PortError(
                        f"backend {self.capabilities.name!r}: command {name!r} must have shape {expected} "
                        f"(batch, *shape) [{spec.units}], got {array.shape}"
                    )
            checked[name] = array
        return checked

    def __enter__(self):
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Release the engine's resources (nothing to do by default)."""
