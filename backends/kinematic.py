"""The kinematic backend: batched point agents, no physics engine.

Two motion models (chosen by :class:`neuronav.world.PointAgents`):

- ``stone`` — Stone et al. 2017's agent, in distance units per step (timestep 1):
  ``heading += rotation``; ``velocity = (velocity + acceleration * (sin h, cos h)) * (1 - drag)``;
  ``position += velocity``. Commands: ``rotation`` (rad/step), ``acceleration`` (units/step²).
- ``unicycle`` — driven by the locomotion command (``turn`` in [-1, 1], ``stride`` = hip swing S_l in
  rad) through a calibration table of (turn, stride) -> (forward speed m/s, turn rate rad/s),
  interpolated bilinearly: the one measured on MuJoCo (``backends/data/unicycle_mujoco.json``,
  made by ``python -m scenarios.calibrate_unicycle``) when present, else a geometric one.
  Timestep 8 ms (the paper's control step).

Heading is clockwise from +y, so an agent at heading h moves along (sin h, cos h).
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from neuronav.backend import BackendBase, Capabilities, check_seed
from neuronav.errors import ConfigError, SimulationError
from neuronav.ports import MotorSpec, SensorSpec
from neuronav.world import PointAgents, World


@dataclass(frozen=True)
class UnicycleCalibration:
    """(turn, stride) -> (forward speed, turn rate) on a grid.

    Attributes
    ----------
    turn : ndarray, shape (T,)
        Rotation configuration θ, increasing, covering [-1, 1].
    stride_rad : ndarray, shape (S,)
        Hip swing S_l in rad, increasing.
    speed_m_s : ndarray, shape (T, S)
    turn_rate_rad_s : ndarray, shape (T, S)
        Positive turns clockwise (toward increasing heading).
    source : str
        Where the numbers come from.
    """

    turn: np.ndarray
    stride_rad: np.ndarray
    speed_m_s: np.ndarray
    turn_rate_rad_s: np.ndarray
    source: str


def geometric_calibration(hip_reach_m: float = 0.55, cycle_s: float = 0.64,
                          half_track_m: float = 0.35) -> UnicycleCalibration:
    """A calibration from gait geometry alone, used until a measured table is supplied.

    A tripod cycle of ``cycle_s`` moves each foot through an arc of ``2 * stride * hip_reach_m``.
    With the Table 2 yaw control (paper eq. 3.3) each side drives forward by a fraction of that;
    the body moves at the mean of the two sides and turns at their difference over the track
    width. θ = 0 walks straight, θ = ±1 turns on the spot (θ > 0 to the left).
    """
    turn = np.linspace(-1.0, 1.0, 21)
    stride = np.radians(np.linspace(0.0, 30.0, 13))
    # Table 2 as forward drive per side: for θ >= 0 the left legs swing Δ(2θ - 1) — mirrored, that
    # is a forward drive of (1 - 2θ) — while the right legs keep Δ; for θ < 0 the other way round.
    left_drive = np.where(turn >= 0, 1.0 - 2.0 * turn, 1.0)[:, None]
    right_drive = np.where(turn >= 0, 1.0, 1.0 + 2.0 * turn)[:, None]
    foot_speed = 2.0 * stride[None, :] * hip_reach_m / cycle_s
    speed = foot_speed * (left_drive + right_drive) / 2.0
    # Clockwise positive: a faster left side turns the agent to the right.
    turn_rate = foot_speed * (left_drive - right_drive) / (2.0 * half_track_m)
    return UnicycleCalibration(turn, stride, speed, turn_rate, source="geometric (not measured)")


DATA_DIR = Path(__file__).resolve().parent / "data"


def load_calibration(path: Path) -> UnicycleCalibration:
    """A calibration table written by ``python -m scenarios.calibrate_unicycle``."""
    try:
        table = json.loads(Path(path).read_text())
        calibration = UnicycleCalibration(
            turn=np.array(table["turn"], float), stride_rad=np.array(table["stride_rad"], float),
            speed_m_s=np.array(table["speed_m_s"], float), turn_rate_rad_s=np.array(table["turn_rate_rad_s"], float),
            source=str(table["source"]),
        )
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise ConfigError(f"unicycle calibration {path}: cannot be read ({error})") from None
    expected = (calibration.turn.size, calibration.stride_rad.size)
    if calibration.speed_m_s.shape != expected or calibration.turn_rate_rad_s.shape != expected:
        raise ConfigError(f"unicycle calibration {path}: tables must have shape {expected}")
    return calibration


def default_calibration() -> UnicycleCalibration:
    """The table measured on MuJoCo when it ships with the package, else the geometric one."""
    measured = DATA_DIR / "unicycle_mujoco.json"
    return load_calibration(measured) if measured.exists() else geometric_calibration()


class KinematicBackend(BackendBase):
    """Batched point agents; implements the backend protocol (see docs/architecture.md)."""

    capabilities = Capabilities(
        name="kinematic",
        sensors=(
            SensorSpec("heading", (1,), "rad"),
            SensorSpec("velocity", (2,), "units/step"),
            SensorSpec("position", (2,), "units"),
            SensorSpec("speed", (1,), "units/step"),
        ),
        motors=(
            MotorSpec("rotation", (1,), "rad/step"),
            MotorSpec("acceleration", (1,), "units/step^2"),
            MotorSpec("turn", (1,), "", (-1.0, 1.0)),
            MotorSpec("stride", (1,), "rad", (0.0, np.pi / 2)),
        ),
        batched=True,
        can_render=False,
    )

    def __init__(self, calibration: UnicycleCalibration | None = None, timestep_s: float = 0.008) -> None:
        if not timestep_s > 0:
            raise ConfigError(f"kinematic backend: timestep_s must be > 0, got {timestep_s}")
        self.calibration = calibration or default_calibration()
        self._unicycle_dt_s = float(timestep_s)
        self._agents: PointAgents | None = None
        self._time_s = 0.0

    # -- protocol ------------------------------------------------------------------------------
    def load(self, world: World, bodies: Sequence[PointAgents]) -> None:
        """Load one :class:`PointAgents` batch (the world's objects do not affect point agents)."""
        if len(bodies) != 1 or not isinstance(bodies[0], PointAgents):
            raise ConfigError("the kinematic backend simulates exactly one PointAgents batch")
        self._agents = bodies[0]
        self.world = world
        grid = (self.calibration.turn, self.calibration.stride_rad)
        from scipy.interpolate import RegularGridInterpolator  # lazily: start-up cost

        self._speed = RegularGridInterpolator(grid, self.calibration.speed_m_s, bounds_error=False, fill_value=None)
        self._turn_rate = RegularGridInterpolator(grid, self.calibration.turn_rate_rad_s, bounds_error=False,
                                                  fill_value=None)
        self.reset()

    @property
    def batch(self) -> int:
        return self._require().count

    @property
    def timestep(self) -> float:
        """1 step in ``stone`` mode (units are steps); ``timestep_s`` (8 ms) in ``unicycle`` mode."""
        return self._unicycle_dt_s if self._agents is not None and self._agents.mode == "unicycle" else 1.0

    @property
    def time(self) -> float:
        return self._time_s

    def reset(self, seed: int | None = None, heading_rad: np.ndarray | None = None,
              position_m=(0.0, 0.0), yaw_rad: float | None = None) -> None:
        """Put every agent at ``position_m``, at rest, facing ``heading_rad`` (default 0: along +y).

        ``yaw_rad`` (counter-clockwise from +x, as the physics backends take it) may be given
        instead of the heading: heading = π/2 − yaw. ``seed`` (None or an int >= 0, as on every
        backend) changes nothing here: the point agents have no random state.
        """
        check_seed("kinematic", seed)
        n = self.batch
        if yaw_rad is not None:
            heading_rad = np.pi / 2 - np.asarray(yaw_rad, float)
        self.position = np.zeros((n, 2)) + np.asarray(position_m, float)
        self.velocity = np.zeros((n, 2))
        self.heading = np.zeros(n) if heading_rad is None else np.broadcast_to(
            np.asarray(heading_rad, float), (n,)).copy()
        self._commands = {m.name: np.zeros((n, 1)) for m in self.capabilities.motors}
        self._push = None  # (batch, 2) velocity change per step from apply_force, for the next step() call
        self._time_s = 0.0

    def write(self, commands: dict[str, np.ndarray]) -> None:
        """Set commands (held until overwritten); each of shape (batch, 1) or (batch,)."""
        self._commands.update(self._check_write(commands, self.batch))

    def step(self, n: int = 1) -> None:
        agents = self._require()
        push, self._push = self._push, None
        for _ in range(int(n)):
            if agents.mode == "stone":
                self.heading += self._commands["rotation"][:, 0]
                thrust = self._commands["acceleration"][:, 0, None] * self._direction()
                if push is not None:
                    thrust += push
                self.velocity = (self.velocity + thrust) * (1.0 - agents.drag)
                self.position += self.velocity
            else:
                turn = np.clip(self._commands["turn"][:, 0], -1.0, 1.0)
                stride = np.clip(self._commands["stride"][:, 0], 0.0, self.calibration.stride_rad[-1])
                query = np.stack([turn, stride], axis=1)
                self.heading += self._turn_rate(query) * self.timestep
                self.velocity = self._speed(query)[:, None] * self._direction()
                if push is not None:
                    self.velocity += push
                self.position += self.velocity * self.timestep
            self._time_s += self.timestep
        # One sum is finite exactly when every term is (or it overflowed: diverged all the same).
        if not np.isfinite(self.position.sum() + self.heading.sum()):
            raise SimulationError("kinematic backend diverged: an agent's position or heading is not finite")

    def read(self, names: Iterable[str]) -> dict[str, np.ndarray]:
        out = {}
        for name in self._check_read(names):
            if name == "heading":
                out[name] = self.heading[:, None].copy()
            elif name == "velocity":
                out[name] = self.velocity.copy()
            elif name == "position":
                out[name] = self.position.copy()
            elif name == "speed":
                out[name] = np.linalg.norm(self.velocity, axis=1)[:, None]
        return out

    def render(self, camera: str) -> np.ndarray:
        raise SimulationError("the kinematic backend has no cameras; render with mujoco or pybullet")

    def apply_force(self, body: int, site: str, force: np.ndarray) -> None:
        """Push agent ``body`` with a world-frame ``force`` (2 or 3 numbers; z is ignored) during every
        step of the next :meth:`step` call, as the physics backends do (``site`` is ignored).

        Each of those steps adds ``force[:2] * dt / mass_kg`` to the agent's velocity before it moves.
        In ``stone`` mode the velocity carries over (then drag slows it, as it does the thrust); in
        ``unicycle`` mode the gait sets the velocity again every step, so the push displaces the
        agent by ``force * dt² / mass_kg`` per step of that call and is gone after it. Pushes on the
        same agent before one step add up.
        """
        agents = self._require()
        if isinstance(body, bool) or not isinstance(body, (int, np.integer)) or not 0 <= body < agents.count:
            raise ConfigError(f"apply_force: agent {body!r} out of range 0..{agents.count - 1}")
        try:
            force = np.asarray(force, float).reshape(-1)
        except (TypeError, ValueError):
            raise ConfigError(f"apply_force: force must be 2 or 3 finite numbers, got {force!r}") from None
        if force.size not in (2, 3) or not np.isfinite(force).all():
            raise ConfigError(f"apply_force: force must be 2 or 3 finite numbers, got {force.tolist()}")
        if self._push is None:
            self._push = np.zeros((agents.count, 2))
        self._push[int(body)] += force[:2] * self.timestep / agents.mass_kg

    # -- helpers -------------------------------------------------------------------------------
    def _direction(self) -> np.ndarray:
        """Unit vectors of the headings, (sin h, cos h), shape (batch, 2)."""
        # Computed into contiguous rows (strided output halves numpy's trig throughput).
        direction = np.empty((2, self.heading.size))
        np.sin(self.heading, out=direction[0])
        np.cos(self.heading, out=direction[1])
        return direction.T

    def _require(self) -> PointAgents:
        if self._agents is None:
            raise SimulationError("kinematic backend: call load(world, [PointAgents(...)]) first")
        return self._agents
