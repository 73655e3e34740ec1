"""The kinematic backend: batched point agents, no physics engine.

Two motion models (chosen by :class:`neuronav.spec.world.PointAgents`):

- ``stone`` — Stone et al. 2017's agent, in distance units per step (timestep 1):
  ``heading += rotation``; ``velocity = (velocity + acceleration * (sin h, cos h)) * (1 - drag)``;
  ``position += velocity``. Commands: ``rotation`` (rad/step), ``acceleration`` (units/step²).
- ``unicycle`` — driven by the locomotion command (``turn`` in [-1, 1], ``stride`` = hip swing S_l in
  rad) through a calibration table of (turn, stride) -> (forward speed m/s, turn rate rad/s),
  interpolated bilinearly (:meth:`neuronav.spec.unicycle.UnicycleCalibration.rates`). The table is body
  data: by default the desert ant's, measured on MuJoCo, found by name in the registry
  (``registry.load("unicycle_calibration", "desert_ant")``: its file is
  ``bodies/desert_ant/unicycle_mujoco.json``, made by ``python -m neuronav.scenarios.tools.calibrate_unicycle``),
  else a geometric one. Timestep 8 ms (the paper's control step).

Heading is clockwise from +y, so an agent at heading h moves along (sin h, cos h).

Eyes: the cameras of :class:`~neuronav.spec.world.PointAgents` are rendered by ray casting
(:mod:`neuronav.senses.raycast`) for every agent at once, only when a camera is read or rendered. A camera
sits in the agent's frame: forward f = (sin h, cos h, 0), left l = (-cos h, sin h, 0), up z; its
position is (x, y, 0) + pos.x f + pos.y l + pos.z up and its frame [f l up] @ R(camera.quat).
``set_scene_yaw`` turns the world's objects about the vertical axis through the origin (the ground
stays), as on the physics backends. Compound eyes (``PointAgents.compound_eyes``, placed as cameras are)
are sensors of their names, (M, 2) green and UV in [0, 1] per ommatidium, read by casting 7 rays per
ommatidium for every agent at once (:class:`neuronav.senses.compound_eye_rays.CompoundEyeReader`).

Head: ``head_pos`` (N, 3) m is (x, y, ``PointAgents.head_height_m``) and ``head_quat`` (N, 4) the turn about
z from the heading (the head's +x is the forward direction); ``cast_rays`` tests rays, stacked over
agents, against the world's objects and the ground plane z = 0 (:func:`neuronav.senses.raycast.first_hit_distance`).

Video: ``render("follow")`` films from above (:class:`neuronav.engine.video_topview.TopViewCamera`: the ground,
trails, objects and every agent's pose, agent 0 kept in view); ``follow_view()`` is that camera's
:class:`~neuronav.engine.video_topview.TopView`, ``keep_in_view(points)`` frames it on a start, nest or goal.

Antennae (:class:`~neuronav.spec.world.PointAntenna`, A per agent): their tips are the odour and wind
sites, read as ``odour_sites`` / ``wind_sites`` (N, A, 3) m, ``odour`` (N, A, K) and ``wind``
(N, A, 2) m/s from the world's chemistry (:mod:`neuronav.senses.chemistry`) in one array operation over
agents and antennae; ``antenna_yaw`` (N, A) rad swings each tip about the vertical through its base
(positive: left), as an articulated antenna's yaw joint does.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Sequence
from dataclasses import replace

import numpy as np

from neuronav import registry
from neuronav.engine.backend import BackendBase, Capabilities, check_seed
from neuronav.errors import ConfigError, PortError, RegistryError, SimulationError
from neuronav.senses.chemistry import Chemistry
from neuronav.senses.vision import average_samples, check_camera, grey, pixel_directions, sampling_camera
from neuronav.spec.body import Camera, quat_to_matrix
from neuronav.spec.ports import MotorSpec, SensorSpec
from neuronav.spec.unicycle import UnicycleCalibration
from neuronav.spec.world import PointAgents, World

# The body whose registered unicycle calibration the point agents walk by, unless given another.
DEFAULT_BODY = "desert_ant"


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


def _start_values(label: str, value, shape: tuple[int, ...], allowed: str) -> np.ndarray:
    """A start pose's ``value`` broadcast to ``shape`` as a finite float array, or a ConfigError."""
    try:
        array = np.broadcast_to(np.asarray(value, float), shape).copy()
    except (TypeError, ValueError):
        raise ConfigError(f"kinematic reset: {label} must be {allowed} for {shape[0]} agents, "
                          f"got shape {np.shape(value)}") from None
    if not np.isfinite(array).all():
        raise ConfigError(f"kinematic reset: {label} must be finite, got {np.asarray(value).tolist()}")
    return array


def default_calibration(body: str = DEFAULT_BODY) -> UnicycleCalibration:
    """The unicycle calibration registered for ``body`` (entry-point group ``neuronav.unicycle_calibrations``),
    or the geometric one (with a RuntimeWarning) when none is registered under that name.

    Raises
    ------
    RegistryError
        ``body``'s calibration is registered but cannot be imported.
    """
    try:
        loader = registry.load("unicycle_calibration", body)
    except RegistryError:
        if body in registry.names("unicycle_calibration"):
            raise
        # Said aloud: a stale install (entry points not refreshed) used to change every walk silently.
        warnings.warn(f"no unicycle calibration is registered for body {body!r} (registered: "
                      f"{', '.join(registry.names('unicycle_calibration')) or 'none'}): the kinematic agents "
                      "walk by the geometric table, not the measured gait", RuntimeWarning, stacklevel=2)
        return geometric_calibration()
    return loader()


class KinematicBackend(BackendBase):
    """Batched point agents; implements the backend protocol (see docs/architecture.md).

    ``capabilities`` (the class attribute) lists the sensors and commands of camera-less agents;
    after :meth:`load` the instance's own adds one sensor per camera (shape (H, W), "grey [0, 1]") and per
    compound eye (shape (M, 2), "green, UV [0, 1]").

    Parameters
    ----------
    calibration : UnicycleCalibration, optional
        The ``unicycle`` mode's table; default :func:`default_calibration` (the desert ant's, by name
        through the registry), looked up on first use (``stone`` mode never needs it).
    timestep_s : float
        The ``unicycle`` mode's step (s), default 8 ms.
    """

    capabilities = Capabilities(
        name="kinematic",
        sensors=(
            SensorSpec("heading", (1,), "rad"),
            SensorSpec("velocity", (2,), "units/step"),
            SensorSpec("position", (2,), "units"),
            SensorSpec("speed", (1,), "units/step"),
            SensorSpec("head_pos", (3,), "m"),
            SensorSpec("head_quat", (4,), ""),
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
    # --video films every world from above (render("follow")), cameras or not.
    films_follow = True

    def __init__(self, calibration: UnicycleCalibration | None = None, timestep_s: float = 0.008) -> None:
        if not timestep_s > 0:
            raise ConfigError(f"kinematic backend: timestep_s must be > 0, got {timestep_s}")
        self._calibration = calibration
        self._unicycle_dt_s = float(timestep_s)
        self._agents: PointAgents | None = None
        self._time_s = 0.0
        self._cameras: dict[str, Camera] = {}
        self._casters: dict = {}
        self._scene_yaw_rad = 0.0
        self._top = None

    # -- protocol ------------------------------------------------------------------------------
    def load(self, world: World, bodies: Sequence[PointAgents]) -> None:
        """Load one :class:`PointAgents` batch (the world's objects do not block point agents; the
        agents' cameras see them)."""
        if len(bodies) != 1 or not isinstance(bodies[0], PointAgents):
            raise ConfigError("the kinematic backend simulates exactly one PointAgents batch")
        cameras = self._check_cameras(world, bodies[0].cameras)
        compound_eyes = self._check_compound_eyes(world, bodies[0].compound_eyes, cameras)
        self._agents = bodies[0]
        self.world = world
        self._cameras = {c.name: c for c in cameras}
        self._casters = {}  # built on a camera's first read
        self._scene_yaw_rad = 0.0
        self._top = None  # the top view, built on the first render("follow")
        sensors = tuple(SensorSpec(c.name, (c.height_px, c.width_px), "grey [0, 1]") for c in cameras)
        # Compound eyes: (M, 2), green and UV per ommatidium (neuronav.senses.compound_eye), read by rays.
        self._compound_eyes = {e.name: e for e in compound_eyes}
        self._eye_readers = {}  # built on an eye's first read
        sensors += tuple(SensorSpec(e.name, (e.n_ommatidia, 2), "green, UV [0, 1]") for e in compound_eyes)
        motors = ()
        antennae = bodies[0].antennae
        if antennae:
            count = len(antennae)
            sensors += (SensorSpec("odour_sites", (count, 3), "m"), SensorSpec("wind_sites", (count, 3), "m"),
                        SensorSpec("odour", (count, world.odour.n_odours), "amount/m^3"),
                        SensorSpec("wind", (count, 2), "m/s"))
            motors = (MotorSpec("antenna_yaw", (count,), "rad"),)
            self._antenna_base = np.array([a.base_m for a in antennae])  # (A, 3), agent frame
            self._antenna_reach = np.array([a.tip_m for a in antennae]) - self._antenna_base
        self.chemistry = Chemistry(world.odour)
        base = type(self).capabilities.sensors  # stone's agent moves in units per step, the unicycle in m and m/s
        if bodies[0].mode == "unicycle":
            metric = {"velocity": "m/s", "speed": "m/s", "position": "m"}
            base = tuple(replace(spec, units=metric.get(spec.name, spec.units)) for spec in base)
        self.capabilities = replace(type(self).capabilities, sensors=base + sensors,
                                    motors=type(self).capabilities.motors + motors, can_render=bool(cameras))
        self.reset()

    @property
    def calibration(self) -> UnicycleCalibration:
        """The ``unicycle`` mode's table (the default one is looked up on first use)."""
        if self._calibration is None:
            self._calibration = default_calibration()
        return self._calibration

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
        instead of the heading: heading = π/2 − yaw. ``position_m`` is (x, y) or one (x, y) per agent
        (N, 2); a heading or yaw is one number or N; all finite (else a ConfigError). ``seed`` (None or
        an int >= 0, as on every backend) seeds the world's plume (:attr:`chemistry`); the point agents
        have no random state.
        """
        seed = check_seed("kinematic", seed)
        n = self.batch
        position = _start_values("position_m", position_m, (n, 2), "(x, y) or (N, 2) m")
        angle = ("yaw_rad", yaw_rad) if yaw_rad is not None else ("heading_rad", heading_rad)
        heading = np.zeros(n) if angle[1] is None else _start_values(angle[0], angle[1], (n,), "one number or N rad")
        self.chemistry.reset(seed)
        self.position = position
        self.velocity = np.zeros((n, 2))
        self.heading = np.pi / 2 - heading if yaw_rad is not None else heading
        self._commands = {m.name: np.zeros((n,) + m.shape) for m in self.capabilities.motors}
        self._push = None  # (batch, 2) velocity change per step from apply_force, for the next step() call
        self._time_s = 0.0
        if self._top is not None:
            self._top.framing.reset()

    def reset_agents(self, agents, position_m, heading_rad=None, yaw_rad: float | None = None) -> None:
        """Put only ``agents`` back at rest at ``position_m``, as :meth:`reset` puts every agent.

        ``agents`` is a sequence of agent indices (K of them) or a boolean mask of N; ``position_m`` is
        (x, y) or (K, 2) m, the heading (or ``yaw_rad``, heading = π/2 − yaw, the same arithmetic as
        :meth:`reset`) one number or K. Those agents' velocity and commands become zero and a pending
        :meth:`apply_force` push on them is dropped; the other agents, the time and the world's plume
        are left as they are (a vector environment's per-env episodes:
        :mod:`neuronav.scenarios.envs.vector_env`). A bad index, shape or non-finite value is a ConfigError.
        """
        n = self.batch
        try:
            index = np.arange(n)[np.asarray(agents) if np.ndim(agents) else [agents]]
        except (IndexError, TypeError, ValueError):
            raise ConfigError(f"kinematic reset_agents: agents must be indices in 0..{n - 1} or a boolean mask "
                              f"of {n}, got {agents!r}") from None
        k = index.size
        position = _start_values("position_m", position_m, (k, 2), "(x, y) or (K, 2) m")
        angle = ("yaw_rad", yaw_rad) if yaw_rad is not None else ("heading_rad", heading_rad)
        heading = np.zeros(k) if angle[1] is None else _start_values(angle[0], angle[1], (k,), "one number or K rad")
        self.position[index] = position
        self.velocity[index] = 0.0
        self.heading[index] = np.pi / 2 - heading if yaw_rad is not None else heading
        for command in self._commands.values():
            command[index] = 0.0
        if self._push is not None:
            self._push[index] = 0.0

    def write(self, commands: dict[str, np.ndarray]) -> None:
        """Set commands (held until overwritten); each of shape (batch, 1) or (batch,).

        ``antenna_yaw`` must be finite (a PortError, as the physics backends refuse non-finite joint
        targets): it moves no agent, so :meth:`step`'s divergence check, which stops a non-finite
        turn or stride, would never see it, and the odour would read NaN.
        """
        checked = self._check_write(commands, self.batch)
        if "antenna_yaw" in checked and not np.isfinite(checked["antenna_yaw"]).all():
            raise PortError(f"kinematic backend: command 'antenna_yaw' must be finite (rad), "
                            f"got {checked['antenna_yaw'].tolist()}")
        self._commands.update(checked)

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
                speed_m_s, turn_rate_rad_s = self.calibration.rates(self._commands["turn"][:, 0],
                                                                    self._commands["stride"][:, 0])
                self.heading += turn_rate_rad_s * self.timestep
                self.velocity = speed_m_s[:, None] * self._direction()
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
            elif name == "head_pos":
                out[name] = np.column_stack([self.position, np.full(self.batch, float(self._agents.head_height_m))])
            elif name == "head_quat":
                out[name] = self.head_quats()
            elif name in ("odour_sites", "wind_sites"):
                out[name] = self.antenna_tips()
            elif name == "odour":
                out[name] = self._odour_at(self.antenna_tips())
            elif name == "wind":
                out[name] = self._wind_at(self.antenna_tips())
            elif name in self._compound_eyes:
                out[name] = self.compound_eye_values(name)
            else:
                out[name] = grey(self.render_batch(name))
        return out

    def render(self, camera: str) -> np.ndarray:
        """Agent 0's uint8 RGB image (H, W, 3) from ``camera``; ``"follow"``: the view from above (module doc)."""
        if camera == "follow" and camera not in self._cameras:
            return self._top_camera().render(self.position, self.heading, self._scene_yaw_rad)
        return self.render_batch(camera, agents=slice(0, 1))[0]

    def follow_view(self):
        """The :class:`~neuronav.engine.video_topview.TopView` that ``render("follow")`` draws from now."""
        camera = self._top_camera()
        camera.framing.keep(self.position[:1])
        return camera.view

    def keep_in_view(self, points_m) -> None:
        """Frame the view from above on ``points_m`` (..., 2) m (a start, a nest, a goal) and agent 0's path, not
        on the whole world (:meth:`neuronav.engine.video_topview.TopFraming.frame`)."""
        self._top_camera().framing.frame(points_m)

    def _top_camera(self):
        self._require()
        if self._top is None:
            from neuronav.engine.video_topview import TopViewCamera  # lazily: only videos need it

            self._top = TopViewCamera(self.world)
        return self._top

    def render_batch(self, camera: str, agents: slice | None = None) -> np.ndarray:
        """Every agent's (or ``agents``') uint8 RGB image (N, H, W, 3) from ``camera``, by ray casting."""
        spec = self._camera(camera)
        caster = self._casters.get(camera)
        if caster is None:
            from neuronav.senses.raycast import RayCaster  # lazily: only worlds with eyes need it

            caster = self._casters[camera] = RayCaster(self.world, pixel_directions(sampling_camera(spec)))
        eyes, rotations = self.camera_frames(camera)
        if agents is not None:
            eyes, rotations = eyes[agents], rotations[agents]
        samples = caster.render(eyes, rotations, self._scene_yaw_rad)
        if spec.supersample == 1:
            return samples
        # Each agent's k x k samples per pixel averaged, as every backend does (neuronav.senses.vision).
        return np.stack([average_samples(image, spec.supersample) for image in samples])

    def head_quats(self) -> np.ndarray:
        """Every agent's head rotation (N, 4) (w, x, y, z), w >= 0: the turn about z that takes +x to the
        forward direction (sin h, cos h, 0), i.e. by π/2 - h counter-clockwise."""
        yaw = np.pi / 2 - self.heading
        yaw = yaw - 2.0 * np.pi * np.round(yaw / (2.0 * np.pi))  # in [-π, π]: cos(yaw / 2) >= 0
        zero = np.zeros_like(yaw)
        return np.stack([np.cos(yaw / 2.0), zero, zero, np.sin(yaw / 2.0)], axis=1)

    def cast_rays(self, origins_m, directions, max_distance_m: float = 50.0) -> np.ndarray:
        """Distance (m) along each ray to the first of the world's objects (at the scene yaw) or the ground
        plane z = 0 seen from above, ``np.inf`` for none within ``max_distance_m``: analytic intersections
        (:func:`neuronav.senses.raycast.first_hit_distance`), one array operation for all rays (the rays
        of many agents stacked, (N, 3) each; directions are normalised). The agents are points: nothing
        of theirs blocks a ray. A ConfigError names a bad argument (:meth:`BackendBase._check_rays`)."""
        from neuronav.senses.raycast import first_hit_distance  # lazily, as the cameras' ray caster

        self._require()
        origins, unit, far = self._check_rays(origins_m, directions, max_distance_m)
        return first_hit_distance(self.world, origins, unit, far, self._scene_yaw_rad)

    def antenna_tips(self) -> np.ndarray:
        """Every agent's antenna tips in the world, (N, A, 3) m, each turned by its ``antenna_yaw``."""
        yaw = self._commands["antenna_yaw"]  # (N, A)
        cos, sin = np.cos(yaw), np.sin(yaw)
        reach_x, reach_y = self._antenna_reach[None, :, 0], self._antenna_reach[None, :, 1]
        # The tip in the agent's frame: the base plus the reach turned about the vertical.
        local_x = self._antenna_base[None, :, 0] + cos * reach_x - sin * reach_y
        local_y = self._antenna_base[None, :, 1] + sin * reach_x + cos * reach_y
        local_z = np.broadcast_to(self._antenna_base[None, :, 2] + self._antenna_reach[None, :, 2], yaw.shape)
        forward = np.stack([np.sin(self.heading), np.cos(self.heading)], axis=1)[:, None, :]  # (N, 1, 2)
        left = np.stack([-np.cos(self.heading), np.sin(self.heading)], axis=1)[:, None, :]
        xy = self.position[:, None, :] + local_x[..., None] * forward + local_y[..., None] * left
        return np.concatenate([xy, local_z[..., None]], axis=2)

    def camera_frames(self, camera: str) -> tuple[np.ndarray, np.ndarray]:
        """Where ``camera`` is on every agent: eye positions (N, 3) and frames (N, 3, 3), columns the
        camera's x, y, z axes in the world (see the module doc)."""
        spec = self._camera(camera)
        return self._mount_frames(spec.pos_m, spec.quat)

    def _mount_frames(self, pos_m, quat) -> tuple[np.ndarray, np.ndarray]:
        """Where a mount at ``pos_m`` / ``quat`` in the agent's frame is on every agent: (N, 3) m, (N, 3, 3)."""
        sin, cos = np.sin(self.heading), np.cos(self.heading)
        zero, one = np.zeros_like(sin), np.ones_like(sin)
        forward, left = np.stack([sin, cos, zero], 1), np.stack([-cos, sin, zero], 1)
        up = np.stack([zero, zero, one], 1)
        x, y, z = (float(v) for v in pos_m)
        eyes = np.stack([self.position[:, 0], self.position[:, 1], zero], 1) + x * forward + y * left + z * up
        frame = np.stack([forward, left, up], axis=2)  # (N, 3, 3), columns f, l, up
        # frame @ R(quat) written out per element: the same bits whatever the batch.
        rotations = (frame[:, :, :, None] * quat_to_matrix(quat)[None, None]).sum(axis=2)
        return eyes, rotations

    def compound_eye_values(self, eye: str) -> np.ndarray:
        """Every agent's ommatidia of compound eye ``eye``, (N, M, 2) green and UV in [0, 1], by rays
        (:class:`neuronav.senses.compound_eye_rays.CompoundEyeReader`, 7 per ommatidium). The eye sits in the
        agent's frame as a camera does (:meth:`camera_frames`); its frame is x forward, y left, z up."""
        spec = self._compound_eyes.get(eye) if self._agents is not None else None
        if spec is None:
            raise PortError(f"kinematic backend has no compound eye {eye!r}; available: "
                            f"{', '.join(self._compound_eyes) or 'none'}")
        reader = self._eye_readers.get(eye)
        if reader is None:
            from neuronav.senses.compound_eye_rays import CompoundEyeReader  # lazily: only agents with eyes need it

            reader = self._eye_readers[eye] = CompoundEyeReader(self.world, spec)
        eyes, rotations = self._mount_frames(spec.pos_m, spec.quat)
        return reader.read(eyes, rotations, self._scene_yaw_rad)

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
    @staticmethod
    def _check_cameras(world: World, cameras) -> tuple[Camera, ...]:
        """The agents' cameras, refused when the ray caster cannot draw them or their world."""
        cameras = tuple(cameras)
        if not cameras:
            return cameras
        names = [c.name if isinstance(c, Camera) else None for c in cameras]
        if None in names:
            raise ConfigError("PointAgents cameras must be neuronav.spec.body.Camera instances")
        if len(set(names)) != len(names):
            raise ConfigError(f"PointAgents cameras: a name is used twice in {names}")
        clash = set(names) & {s.name for s in KinematicBackend.capabilities.sensors}
        if clash:
            raise ConfigError(f"PointAgents cameras: {sorted(clash)} would hide the sensor of that name")
        ground = world.ground
        if not ground.is_flat or ground.kind == "wall":
            raise ConfigError(f"kinematic backend: cameras need a flat ground without a wall (the ray caster's "
                              f"ground is the plane z = 0), got a {ground.kind!r} ground"
                              + (f" with roughness_m {ground.roughness_m}" if not ground.is_flat else ""))
        for camera in cameras:
            if camera.projection not in ("planar", "spherical"):
                raise ConfigError(f"camera {camera.name!r}: unknown projection {camera.projection!r}; "
                                  f"allowed: planar, spherical")
            if not (isinstance(camera.width_px, int) and isinstance(camera.height_px, int)
                    and camera.width_px > 0 and camera.height_px > 0):
                raise ConfigError(f"camera {camera.name!r}: image size must be positive whole pixels, "
                                  f"got {camera.width_px!r} x {camera.height_px!r}")
            check_camera(camera)
            position = np.asarray(camera.pos_m, float)
            quat = np.asarray(camera.quat, float)
            if position.shape != (3,) or not np.isfinite(position).all():
                raise ConfigError(f"camera {camera.name!r}: pos_m must be 3 finite numbers, got {camera.pos_m!r}")
            if quat.shape != (4,) or not np.isfinite(quat).all() or abs(np.linalg.norm(quat) - 1.0) > 1e-6:
                raise ConfigError(f"camera {camera.name!r}: quat must be a unit quaternion (w, x, y, z), "
                                  f"got {camera.quat!r}")
        return cameras

    @staticmethod
    def _check_compound_eyes(world: World, eyes, cameras) -> tuple:
        """The agents' compound eyes, refused when their names clash or the ground is not the plane z = 0."""
        eyes = tuple(eyes)
        if not eyes:
            return eyes
        clash = {e.name for e in eyes} & ({s.name for s in KinematicBackend.capabilities.sensors}
                                          | {c.name for c in cameras})
        if clash:
            raise ConfigError(f"PointAgents compound_eyes: {sorted(clash)} would hide a sensor or camera of that name")
        ground = world.ground
        if not ground.is_flat or ground.kind == "wall":
            raise ConfigError(f"kinematic backend: compound eyes need a flat ground without a wall (their rays' "
                              f"ground is the plane z = 0), got a {ground.kind!r} ground")
        return eyes

    def _camera(self, camera: str) -> Camera:
        self._require()
        spec = self._cameras.get(camera)
        if spec is None:
            if not self._cameras:
                raise SimulationError("the kinematic backend's agents have no cameras: give PointAgents cameras "
                                      "(neuronav.spec.body.Camera) to render")
            raise PortError(f"kinematic backend has no camera {camera!r}; available: {', '.join(self._cameras)}")
        return spec

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
