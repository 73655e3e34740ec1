"""What the CX of embodied path integration reads: its compass and its odometer, true or from the senses.

Compass (``compass``):

- ``true``: the body's heading, with the Gaussian error ``compass_noise_deg`` under ``variability=on``
  (stone2017's ``heading`` port).
- ``sky``: the dorsal rims' view of the polarised sky (:class:`neuronav.senses.dorsal_rim.DorsalRim`
  on the sky of :func:`run_sky`), through the head's real pose on the backend (``head_quat``: pitch and
  roll on uneven ground change what the rim sees) and, when the world has objects, with the views the
  scene blocks cast on the backend (``cast_rays``); the circuit is
  :func:`neuronav.brains.sky_compass.sky_stone2017`, whose TB1 follows the sky: no true heading enters
  the brain. Its memory is in the sun's frame: a decoded direction plus the sun's azimuth is the world's.

Odometer (``odometry``):

- ``true``: the body's displacement over the gait cycle (or its velocity sensor, ``velocity_input``),
  scaled by 1 + N(0, ``odometry_noise_fraction``) under ``variability=on``.
- ``steps``: on an articulated body, the step odometer (:class:`neuronav.bodies.step_odometer.StepOdometer`)
  sampled every control step (joint angles and leg loads; updated once per gait cycle) through the leg
  kinematics of the body the brain believes it has (the desert ant as built, fixed at the start); on the
  kinematic unicycle, strides × the believed stride length of the commanded stride
  (:class:`neuronav.bodies.step_odometer.UnicycleStrideOdometer`).
- ``optic_flow``: the image motion of a ventral eye patch looking straight down at the rendered ground
  (:class:`FlowOdometer`, :mod:`neuronav.senses.optic_flow`): the desert ant built with ``ventral_eye=True``;
  on the kinematic unicycle a downward :class:`~neuronav.spec.body.Camera` of the point agent
  (:func:`kinematic_ventral_camera`). It needs a textured ground: on a plain one it sees no motion.

The odometers give the displacement in the body frame (forward, left); the sky circuit's TN cells read
it as it is, stone2017's read it turned into the world by the heading the CX reads (the same heading
its TN encoder turns it back with).
"""

from __future__ import annotations

import numpy as np

from neuronav.bodies.gaits import segment_pose
from neuronav.bodies.step_odometer import StepOdometer, UnicycleStrideOdometer
from neuronav.engine.loop import AgentLoop, Hook
from neuronav.engine.sampling import Sampler
from neuronav.errors import ConfigError
from neuronav.scenarios.settings import choice_list
from neuronav.senses.dorsal_rim import DorsalRim, rotations_from_quaternions
from neuronav.senses.optic_flow import camera_displacement_m, image_shift_px
from neuronav.senses.sky import Sky
from neuronav.senses.sky_occlusion import SkyOcclusion
from neuronav.spec.body import Camera, axis_angle_quat, quat_to_matrix

COMPASSES = ("true", "sky")
ODOMETERS = ("true", "steps", "optic_flow")
# How far a sky ray is cast (cast_rays' default): an object farther away does not hide the sky.
SKY_RAY_M = 50.0
# LegOdometer's default sampling period, control steps (its docstring says why every step).
LEG_ODOMETER_SAMPLE_EVERY = 1
# FlowOdometer's default sampling period, control steps (its docstring says why).
FLOW_ODOMETER_SAMPLE_EVERY = 2
# The kinematic unicycle's ventral eye (PointAgents camera): height above the ground, m, like the ant's.
KINEMATIC_VENTRAL_HEIGHT_M = 0.4


def _choices(config, name: str, allowed: tuple[str, ...]) -> tuple[str, ...]:
    return choice_list(name, getattr(config, name), allowed, repeats=False)


def compasses(config) -> tuple[str, ...]:
    """The compass modes of ``config.compass`` (one, or a comma list cycled over trials by seed)."""
    return _choices(config, "compass", COMPASSES)


def odometers(config) -> tuple[str, ...]:
    """The odometer modes of ``config.odometry`` (one, or a comma list cycled by whole cycles of the compasses)."""
    return _choices(config, "odometry", ODOMETERS)


def trial_inputs(config, seed: int) -> tuple[str, str]:
    """Trial ``seed``'s (compass, odometry): the compass list cycled by seed, the odometry list by whole
    cycles of the compass list, so every compass meets every odometer."""
    compass, odometry = compasses(config), odometers(config)
    return compass[seed % len(compass)], odometry[(seed // len(compass)) % len(odometry)]


def inputs_label(compass: str, odometry: str) -> str:
    """The condition column of a trial: ``compass/odometry`` (``true/true`` is the supervisor's input)."""
    return f"{compass}/{odometry}"


def run_sky(config) -> Sky:
    """The sky of a run: the sun at ``sun_azimuth_deg`` (clockwise from north, +y) and ``sun_elevation_deg``,
    ``cloud_cover`` of it overcast."""
    return Sky(sun_azimuth_rad=float(np.radians(config.sun_azimuth_deg)),
               sun_elevation_rad=float(np.radians(config.sun_elevation_deg)), cloud_cover=float(config.cloud_cover))


def level_rim_mount(body) -> np.ndarray:
    """The dorsal rims' mounting in the head frame of ``body``: the inverse of the head's rest orientation on
    the thorax, so the rims look symmetrically about the zenith when the thorax is level and the head at rest.

    The desert ant holds its head 0.2 rad nose-down at rest (``head_pitch``); its rims' directions
    (:class:`~neuronav.senses.dorsal_rim.DorsalRim`, elevations in a level head frame) are mounted to undo
    it, as its panoramic camera is (``bodies/desert_ant/body.py``). Joint motion away from rest (the gait's
    head bob, a turned head) and the thorax's own pitch and roll still tilt the rims. A body without a
    segment named ``head`` reads the root's pose: no mounting (identity).
    """
    if not any(segment.name == "head" for segment in body.segments):
        return np.eye(3)
    rotation, _ = segment_pose(body, "head", {})
    return rotation.T


class SkyView:
    """Reads the dorsal rims of every agent on a backend: POL responses (N, M).

    Parameters
    ----------
    sky : Sky
    world : World
        Its objects (trees, walls) block the sky: rays from the head along every ommatidium's view are
        cast on the backend when it has any, as far as something can be hit (``SKY_RAY_M`` at most, and
        only until every ray is above the scene's top: :class:`~neuronav.senses.sky_occlusion.SkyOcclusion`).
    rim : DorsalRim, optional
    mount : ndarray, shape (3, 3), optional
        The rims' frame in the head frame (:func:`level_rim_mount`; default identity: the kinematic
        agents' level heads).
    """

    def __init__(self, sky: Sky, world, rim: DorsalRim | None = None, mount: np.ndarray | None = None) -> None:
        self.sky, self.rim = sky, DorsalRim() if rim is None else rim
        self.occludes = bool(world.objects)
        self.mount = None if mount is None else np.asarray(mount, float)
        self._occlusion = SkyOcclusion(world) if self.occludes else None

    def head_rotations(self, backend) -> np.ndarray:
        """Rim-to-world rotations (N, 3, 3): the backend's ``head_quat`` times the mounting."""
        rotations = rotations_from_quaternions(backend.read(("head_quat",))["head_quat"].reshape(-1, 4))
        return rotations if self.mount is None else rotations @ self.mount

    def __call__(self, backend) -> np.ndarray:
        if not self.occludes:
            return self.rim.responses(self.sky, self.head_rotations(backend))
        head = backend.read(("head_quat", "head_pos"))  # one read: the head's pose is found once
        rotations = rotations_from_quaternions(head["head_quat"].reshape(-1, 4))
        if self.mount is not None:
            rotations = rotations @ self.mount
        directions = self.rim.sky_directions(rotations)  # (N, M, 3)
        heads = head["head_pos"].reshape(-1, 3)
        # Cast only as far as something can be hit (SkyOcclusion.reach_m: the same answers as SKY_RAY_M).
        reach_m = self._occlusion.reach_m(heads, directions, SKY_RAY_M)
        if reach_m <= 0.0:  # every ray rises from above everything
            return self.rim.responses(self.sky, rotations)
        hits = backend.cast_rays(np.repeat(heads, directions.shape[1], axis=0), directions.reshape(-1, 3), reach_m)
        visible = ~np.isfinite(hits).reshape(directions.shape[:2])
        return self.rim.responses(self.sky, rotations, visible)


class LegOdometer(Hook):
    """The step odometer of an articulated body, sampled after every ``sample_every``-th control step.

    Each sample reads the proprioception (``joint_pos`` and ``contact_load``, the legs' loads in the last
    physics step) into a buffer; :meth:`take` runs the buffered samples through the odometer at once
    (:meth:`StepOdometer.update_many`, the same numbers as one update per sample) and gives the
    displacement since the last take in the body frame of now (forward, left), from the odometer's
    integrated pose. The samples are recorded by the backend's :class:`~neuronav.engine.sampling.Sampler`
    (``backend.sampler``; through ``read`` for a backend without one), which keeps the per-step cost to
    a copy of the engine's raw state (MuJoCo: the joints' span of ``qpos`` and the legs' contact forces,
    their norms taken at the take): the odometer's work is done once per brain period, in array operations.

    Parameters
    ----------
    believed_body : BodySpec
        The body the brain believes it has (fixed for the trial).
    sample_every : int
        Sample every this many control steps (8 ms each), counted from the episode's start (which is
        always read). It must divide the brain's period (80 control steps) for :meth:`take` to see a
        fresh sample. Default ``LEG_ODOMETER_SAMPLE_EVERY`` = 1, every control step: sparser samples
        change what the odometer reads by more than 1 % of the distance walked (6 gait cycles straight:
        every 2nd step +8.2 % on MuJoCo, −0.7 % on PyBullet; every 8th +17.3 % / −12.0 %; turning at
        ``turn`` 0.3 every 8th integrates 46° / 52° of a true 66° / 98° turn, every step 72° / 85°),
        because on the engines the set of loaded legs changes every few steps (a tripod's legs unload in
        mid stance) and an interval with no leg loaded at both of its ends adds nothing. Strides are
        still marked at every 8th step. Measured with ``python benchmarks/step_odometer.py --sampling``;
        the cost with ``python benchmarks/step_odometer.py`` (bodies/desert_ant/README.md, "Speed").
    """

    SENSORS = ("joint_pos", "contact_load")

    def __init__(self, believed_body, sample_every: int = LEG_ODOMETER_SAMPLE_EVERY) -> None:
        if isinstance(sample_every, bool) or not isinstance(sample_every, int | np.integer) or sample_every < 1:
            raise ConfigError(f"LegOdometer: sample_every must be an int >= 1, got {sample_every!r}")
        self._odometer = StepOdometer(believed_body)
        self.sample_every = int(sample_every)
        self._taken_m = np.zeros(2)
        self._sampler: Sampler | None = None  # the backend's sampler of SENSORS, made at the episode's start

    @property
    def odometer(self) -> StepOdometer:
        """The step odometer, with every buffered sample applied."""
        self.flush()
        return self._odometer

    def initialize_episode(self, loop: AgentLoop) -> None:
        self._odometer.reset()
        self._taken_m = np.zeros(2)
        sampler = getattr(loop.backend, "sampler", None)
        self._sampler = sampler(self.SENSORS) if sampler is not None else Sampler(self._read_sample(loop.backend))
        self._sampler.record()

    def after_step(self, loop: AgentLoop) -> None:
        if loop.control_steps % self.sample_every == 0:
            self._sampler.record()

    @classmethod
    def _read_sample(cls, backend):
        """A sampling function through ``backend.read`` (for a backend without ``sampler``)."""
        def sample() -> np.ndarray:
            sensed = backend.read(cls.SENSORS)
            return np.concatenate([np.ravel(sensed[name][0]) for name in cls.SENSORS])
        return sample

    def flush(self) -> None:
        """Run the buffered samples through the odometer."""
        samples = self._sampler.drain() if self._sampler is not None else ()
        if len(samples):
            joints = self._odometer.joint_count
            self._odometer.update_many(samples[:, :joints], samples[:, joints:])

    def take(self) -> np.ndarray:
        odometer = self.odometer
        moved = odometer.position_m - self._taken_m
        self._taken_m = odometer.position_m.copy()
        yaw = odometer.yaw_rad  # counter-clockwise, in the frame of the first update
        c, s = np.cos(yaw), np.sin(yaw)
        return np.array([c * moved[0] + s * moved[1], -s * moved[0] + c * moved[1]])


class StrideCounter(Hook):
    """The kinematic unicycle's odometer: the believed stride length of each control step's command.

    It counts the command the brain meant (``command``, set by the brain: an efference copy), not the
    one the legs executed with motor noise, so noise makes it differ from the truth as a real one would.
    """

    def __init__(self, calibration) -> None:
        self.odometer = UnicycleStrideOdometer(calibration, agents=1)
        self._forward_m = 0.0
        self.command = (0.0, 0.0)

    def initialize_episode(self, loop: AgentLoop) -> None:
        self.odometer.reset()
        self._forward_m = 0.0

    def after_step(self, loop: AgentLoop) -> None:
        turn, stride_rad = self.command
        self._forward_m += float(self.odometer.update(turn, stride_rad, loop.clocks.control_dt_s)[0])

    def take(self) -> np.ndarray:
        forward, self._forward_m = self._forward_m, 0.0
        return np.array([forward, 0.0])


def kinematic_ventral_camera() -> Camera:
    """The unicycle's ventral eye: the desert ant's (32×32 px, 90°, image top forward) looking straight down
    from ``KINEMATIC_VENTRAL_HEIGHT_M`` above the ground under the agent."""
    from neuronav.bodies.desert_ant.body import VENTRAL_EYE

    size, fov = VENTRAL_EYE["size_px"], VENTRAL_EYE["fov_rad"]
    return Camera("ventral", "agent", (0.0, 0.0, KINEMATIC_VENTRAL_HEIGHT_M),
                  axis_angle_quat((0.0, 0.0, 1.0), -np.pi / 2.0), width_px=size, height_px=size, fov_rad=(fov, fov))


class FlowOdometer(Hook):
    """The optic-flow odometer: the ventral camera's image motion, every ``sample_every``-th control step.

    Each sample measures the global image shift since the previous sample
    (:func:`neuronav.senses.optic_flow.image_shift_px`), turns it into the camera's displacement over flat
    ground at the believed ``height_m`` (:func:`~neuronav.senses.optic_flow.camera_displacement_m`) and into
    the body frame through the camera's mounting, and adds it up; :meth:`take` gives the sum since the
    last take, (forward, left) in m. The turns within a take are not undone (a gait cycle turns the body by a
    few degrees). A sample with no texture in view adds nothing and is counted in ``blind_samples``.

    Parameters
    ----------
    camera : Camera
        The ventral camera (looking straight down; its ``quat`` turns its frame into the body's).
    height_m : float
        How high the brain believes the camera is above the ground (fixed for the trial).
    sample_every : int
        Control steps (8 ms) between samples; it must divide the brain's period (80 control steps).
        Default ``FLOW_ODOMETER_SAMPLE_EVERY`` = 2 (half the renders of every step). The period matters
        little while the ground moves at most a few pixels between samples: on MuJoCo (4 trials, seed 11,
        outbound 8 s, the checker ground, this default patched) the odometer read 0.946–0.977 of the true
        path every step, 0.923–0.954 every 2nd, 0.920–0.936 every 4th and 0.919–0.937 every 8th step.
        It reads a few % short at every period, not from the height: walking, the camera is 0.357 m
        above the ground on average against the believed 0.36 m (MuJoCo, the same trial). The cause was
        not established (candidates: the unrendered sub-pixel motion of hard checker edges, the
        thorax's pitch and roll in the gait, turns within a sample).
    """

    def __init__(self, camera: Camera, height_m: float, sample_every: int = FLOW_ODOMETER_SAMPLE_EVERY) -> None:
        if isinstance(sample_every, bool) or not isinstance(sample_every, int | np.integer) or sample_every < 1:
            raise ConfigError(f"FlowOdometer: sample_every must be an int >= 1, got {sample_every!r}")
        if not 0.0 < height_m < np.inf:
            raise ConfigError(f"FlowOdometer: height_m must be a finite number > 0, got {height_m!r}")
        self.camera, self.height_m, self.sample_every = camera, float(height_m), int(sample_every)
        self._axes = quat_to_matrix(camera.quat)[:2, :2]  # camera (right, top) -> body (forward, left)
        self._previous = None
        self._moved_m = np.zeros(2)
        self.samples = self.blind_samples = 0

    def initialize_episode(self, loop: AgentLoop) -> None:
        self._previous = self._image(loop)
        self._moved_m = np.zeros(2)
        self.samples = self.blind_samples = 0

    def _image(self, loop: AgentLoop) -> np.ndarray:
        return loop.backend.read((self.camera.name,))[self.camera.name][0]

    def after_step(self, loop: AgentLoop) -> None:
        if loop.control_steps % self.sample_every:
            return
        image = self._image(loop)
        shift = image_shift_px(self._previous, image)
        self._previous = image
        self.samples += 1
        if shift is None:
            self.blind_samples += 1
            return
        moved = camera_displacement_m(shift, self.height_m, self.camera.fov_rad, image.shape)
        self._moved_m += self._axes @ moved

    def take(self) -> np.ndarray:
        moved, self._moved_m = self._moved_m, np.zeros(2)
        return moved


def body_to_world(displacement_body, heading_rad: float) -> np.ndarray:
    """A body-frame (forward, left) vector turned into the world at ``heading_rad`` (clockwise from +y)."""
    forward, left = displacement_body
    s, c = np.sin(heading_rad), np.cos(heading_rad)
    return np.array([forward * s - left * c, forward * c + left * s])


def world_to_body(displacement_world, heading_rad: float) -> np.ndarray:
    """The inverse of :func:`body_to_world`."""
    x, y = displacement_world
    s, c = np.sin(heading_rad), np.cos(heading_rad)
    return np.array([x * s + y * c, -x * c + y * s])
