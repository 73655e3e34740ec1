"""Antennae that stay fixed or sweep, for the ant on every backend.

Source: the I2Bot paper §2.5.1 and its methods (odour trail: antennae fixed, or swept in yaw
±0.7 rad with noise, after Draft et al. 2018's carpenter ants); ``docs/parameters.md`` §5.

:class:`AntennaSweep` gives the antennae's yaw offsets from rest over time. Both antennae pan
together, left then right, ``amplitude_rad · sin(φ)``, with the phase φ advancing by
``2π dt / period_s`` plus phase noise (``phase_noise_rad_per_sqrt_s · √dt · ξ``, ξ standard normal):
a sweep whose rhythm wanders from cycle to cycle, seeded. ``fixed`` holds both at 0.

The same offsets drive the physics ant's antenna yaw joints (added to their rest targets,
:meth:`AntennaSweep.joint_targets`) and the kinematic body's ``antenna_yaw`` command, whose
antennae (:func:`point_antennae`) are the ant's odour sites at rest, swinging about the ant's yaw
joints (taken as vertical: the ant's yaw axis is tilted by the 0.35 rad rest pitch of the antenna).
"""

from __future__ import annotations

import math

import numpy as np

from neuronav.bodies.gaits import segment_pose
from neuronav.engine.loop import Hook
from neuronav.errors import ConfigError
from neuronav.spec.body import BodySpec
from neuronav.spec.world import PointAntenna

ANTENNA_MODES = ("fixed", "moving")
SIDES = ("L", "R")


class AntennaSweep:
    """Yaw offsets (rad) of the left and right antenna from rest, stepped in time.

    Parameters
    ----------
    mode : str
        ``fixed`` (offsets stay 0) or ``moving`` (sweep).
    amplitude_rad : float
        Half the sweep's range (the paper: 0.7 rad).
    period_s : float
        Mean period of one left-right-left sweep (default one gait cycle, 0.64 s).
    phase_noise_rad_per_sqrt_s : float
        Diffusion of the sweep's phase (0: a pure sinusoid).
    seed : int
        Seeds the phase noise and the starting phase.
    """

    def __init__(self, mode: str = "fixed", amplitude_rad: float = 0.7, period_s: float = 0.64,
                 phase_noise_rad_per_sqrt_s: float = 1.0, seed: int = 0) -> None:
        if mode not in ANTENNA_MODES:
            raise ConfigError(f"antennae {mode!r} is unknown; allowed: {', '.join(ANTENNA_MODES)}")
        for label, value in (("amplitude_rad", amplitude_rad), ("period_s", period_s),
                             ("phase_noise_rad_per_sqrt_s", phase_noise_rad_per_sqrt_s)):
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise ConfigError(f"antenna sweep {label} must be a finite number >= 0, got {value!r}")
        if not period_s > 0:
            raise ConfigError(f"antenna sweep period_s must be > 0, got {period_s!r}")
        self.mode = mode
        self.amplitude_rad = float(amplitude_rad)
        self.period_s = float(period_s)
        self.phase_noise = float(phase_noise_rad_per_sqrt_s)
        self.reset(seed)

    def reset(self, seed: int = 0) -> None:
        """Start again: a random phase (moving) from ``seed``."""
        self._rng = np.random.default_rng(seed)
        self.phase_rad = float(self._rng.uniform(0.0, 2.0 * math.pi)) if self.mode == "moving" else 0.0

    @property
    def offsets_rad(self) -> np.ndarray:
        """The (left, right) yaw offsets now, rad (positive: to the left)."""
        offset = self.amplitude_rad * math.sin(self.phase_rad) if self.mode == "moving" else 0.0
        return np.array([offset, offset])

    def step(self, dt_s: float) -> np.ndarray:
        """Advance by ``dt_s`` seconds and return the new (left, right) offsets."""
        if self.mode == "moving":
            noise = self.phase_noise * math.sqrt(dt_s) * float(self._rng.standard_normal())
            self.phase_rad += 2.0 * math.pi * dt_s / self.period_s + noise
        return self.offsets_rad

    @staticmethod
    def yaw_joints(body: BodySpec) -> np.ndarray:
        """Indices of ``antenna_L_yaw`` and ``antenna_R_yaw`` in the body's joint order."""
        names = body.joint_names
        missing = [f"antenna_{side}_yaw" for side in SIDES if f"antenna_{side}_yaw" not in names]
        if missing:
            raise ConfigError(f"body {body.name!r} has no joint {missing[0]!r}: antenna sweeps need "
                              f"antenna_L_yaw and antenna_R_yaw")
        return np.array([names.index(f"antenna_{side}_yaw") for side in SIDES])

    def joint_targets(self, targets_rad: np.ndarray, yaw_joints: np.ndarray) -> np.ndarray:
        """``targets_rad`` (J,) with the current offsets added at the antenna yaw joints (a copy)."""
        out = np.array(targets_rad, dtype=float, copy=True)
        out[..., yaw_joints] += self.offsets_rad
        return out


def point_antennae(body: BodySpec) -> tuple[PointAntenna, PointAntenna]:
    """The kinematic body's antennae matching ``body``'s at rest: tips at its odour sites.

    Each antenna's base is its yaw joint (the origin of segment ``antenna_<side>_scape``), its tip
    the odour site ``odour_<side>``, both in the root frame at the rest pose, raised by the body's
    spawn height (the kinematic frame's origin is on the ground).
    """
    rest = dict(zip(body.joint_names, body.rest_pose_rad()))
    sites = {s.name: s for s in body.sites}
    antennae = []
    for side in SIDES:
        site = sites.get(f"odour_{side}")
        if site is None:
            raise ConfigError(f"body {body.name!r} has no odour site 'odour_{side}'")
        _, base = segment_pose(body, f"antenna_{side}_scape", rest)
        rotation, origin = segment_pose(body, site.segment, rest)
        tip = origin + rotation @ np.asarray(site.pos_m, float)
        lift = np.array([0.0, 0.0, body.spawn_height_m])
        antennae.append(PointAntenna(side, tuple(base + lift), tuple(tip + lift)))
    return tuple(antennae)


class SweptAntennaeGait:
    """A gait whose targets carry the antenna sweep: ``gait``'s joint targets plus the sweep's yaw
    offsets at the antenna yaw joints, the sweep advanced by ``control_dt_s`` each step.

    Everything else (phases, cycle, envelope, ...) is the wrapped gait's.
    """

    def __init__(self, gait, sweep: AntennaSweep, body: BodySpec, control_dt_s: float, seed: int = 0) -> None:
        self.gait, self.sweep, self.control_dt_s, self.seed = gait, sweep, float(control_dt_s), seed
        self._yaw_joints = AntennaSweep.yaw_joints(body)

    def __getattr__(self, name):
        return getattr(self.gait, name)

    def reset(self) -> None:
        self.gait.reset()
        self.sweep.reset(self.seed)

    def step(self, turn: float = 0.0, stride_rad: float | None = None) -> np.ndarray:
        targets = self.gait.step(turn, stride_rad)
        self.sweep.step(self.control_dt_s)
        return self.sweep.joint_targets(targets, self._yaw_joints)


class AntennaYawHook(Hook):
    """Sweeps the kinematic body's antennae: writes the sweep's offsets as ``antenna_yaw`` before
    every control step (every agent of the batch the same)."""

    def __init__(self, sweep: AntennaSweep, seed: int = 0) -> None:
        self.sweep, self.seed = sweep, seed

    def initialize_episode(self, loop) -> None:
        self.sweep.reset(self.seed)

    def before_step(self, loop) -> None:
        offsets = self.sweep.step(loop.clocks.control_dt_s)
        loop.backend.write({"antenna_yaw": np.broadcast_to(offsets, (loop.backend.batch, offsets.size))})
