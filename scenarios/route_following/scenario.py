"""Route following by visual familiarity: a mushroom body learns a route's views, then steers the ant along it.

Each trial grows a seeded forest about a fixed meandering route (:mod:`neuronav.scenarios.tools.mb_familiarity`:
a sine of 3 m amplitude and 20 m wavelength from the origin, ``route_m`` long).

1. **Training**: the ant walks the route under guidance (pure pursuit of the route point 1 m ahead of
   the nearest one) and, ``views_per_cycle`` times per gait cycle (0.64 s), stores its panoramic view
   in the mushroom body (:func:`neuronav.brains.mushroom_body.mushroom_body`, panorama code, learning on),
   turned to face its last cycle's travel when ``travel_aligned_views`` is on.
2. **Test**: the ant is put back at the route's start (``release_offset_m`` to its right, plus
   ``release_jitter_m``), facing the route's first heading, and only the mushroom body steers, once per
   gait cycle, by ``strategy``: ``scan`` judges the panorama rolled to headings within ±``scan_deg`` in
   ``scan_step_deg`` steps and turns toward the least novel, θ = clip(−offset / ``scan_full_turn_deg``,
   −1, 1) (θ > 0 left); ``klinokinesis`` turns alternately left and right by θ = ±``klinokinesis_max_turn``
   · min(1, ``klinokinesis_gain`` · novelty / active KCs); stride 20° in both. Settings left at 0 take
   the body's own values (:func:`body_steering`).

With ``forest_seed`` ≥ 0 the trials share one forest and route, tested as one batch on kinematic. Eyes: the
panoramic camera, or (``eyes=compound``) one ``eye_channel`` of the compound eyes (:mod:`.compound_view`).
Metrics: the fraction of the route's checkpoints (every ``checkpoint_every_m``) the test path came within
``reach_m`` of, the mean and maximum distance from the route, success (the last checkpoint reached), the views.

Results, sources and model choices: README.md in this folder.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from neuronav import registry
from neuronav.angles import wrap_rad
from neuronav.bodies.desert_ant import desert_ant
from neuronav.brains.mushroom_body import (
    PANORAMA_COLUMNS,
    PANORAMA_ROWS,
    kc_sparsity,
    mushroom_body,
    novelty,
    panorama_code,
)
from neuronav.config import field
from neuronav.engine.loop import AgentLoop, Clocks
from neuronav.engine.video import VideoRecorder
from neuronav.engine.video_overlay import EyeInset, LevelInset, Marker, VideoContent, VideoOverlay
from neuronav.errors import ConfigError
from neuronav.runs.scenario import Scenario, ScenarioResult
from neuronav.runs.summary_statistics import Statistics
from neuronav.scenarios import EVERY_BACKEND, settings
from neuronav.scenarios.route_following.compound_view import EYE_CHANNELS, EYE_SENSORS, CompoundPanorama, ant_eyes
from neuronav.scenarios.tools.mb_familiarity import SPACING_M, forest_world, panoramas, route
from neuronav.scenarios.trial_loop import VIDEO_EVERY, pack_cycle_logs
from neuronav.scenarios.variability import is_on, trial_generators, variability_field
from neuronav.scenarios.visual_setup import CONTROL_S, CYCLE_S, make_engine, point_agent_cameras
from neuronav.scenarios.worlds.scenes import pack_world, world_record
from neuronav.spec.world import PointAgents

STRIDE_RAD = np.radians(20.0)
LOOKAHEAD_M = 1.0
COLUMN_DEG = 5.0  # one column of the 72-column panorama
LOG_KEYS = ("time_s", "heading_rad", "novelty", "turn", "kc_active")
STRATEGIES = ("scan", "klinokinesis")
EYES = ("camera", "compound")


@dataclass
class RouteFollowingConfig:
    strategy: str = field("scan", "how the mushroom body steers: scan (turn toward the least novel of several "
                          "headings) or klinokinesis (zig-zag, wider where the view is novel); a comma list "
                          "(scan,klinokinesis) is cycled over trials by seed")
    route_m: float = field(10.0, "length of the trained route (m)", min=2.0, max=100.0)
    release_offset_m: str = field("0", "test release this far right (+) or left (-) of the route's start (m, "
                                  "-10 to 10); a comma list (0,1) is cycled over trials by seed, after the strategy")
    duration_s: float = field(60.0, "test time limit (s)", min_exclusive=0.0, max=3600.0)
    scan_deg: float = field(60.0, "scan: headings judged within ± this of the current one (deg)", min=10.0,
                            max=180.0)
    n_kc: int = field(4000, "Kenyon cells", min=100, max=40000)
    views_per_cycle: int = field(4, "training: views stored (and guidance updates) per gait cycle",
                                 choices=(1, 2, 4, 8))
    checkpoint_every_m: float = field(1.0, "route checkpoints this far apart (m)", min=0.1, max=10.0)
    reach_m: float = field(0.5, "a checkpoint is reached within this distance (m)", min_exclusive=0.0, max=5.0)
    landscape: bool = field(True, "kinematic backend: map the first trial's novelty on a grid about the route")
    timestep_s: float = settings.timestep_field()
    scan_full_turn_deg: float = field(0.0, "scan: the least novel heading this far off (or more) turns at θ = ±1; "
                                      "smaller offsets turn proportionally less (deg); 0: the body's own (30 on the "
                                      "kinematic unicycle, 45 on the physics ants)", min=0.0, max=180.0)
    test_views_per_cycle: int = field(0, "test: views judged per gait cycle, their novelty averaged for the one turn "
                                      "per cycle (the kinematic batch judges one); 0: the body's own (1 on the "
                                      "kinematic unicycle, 4 on the physics ants, whose heading sways in a stride)",
                                      choices=(0, 1, 2, 4, 8))
    travel_aligned_views: bool = field(True, "training: store each view turned to face the way the ant moved over its "
                                       "last gait cycle rather than the way its body points")
    scan_step_deg: float = field(10.0, "scan: the judged headings lie this far apart (deg; whole panorama columns)",
                                 choices=(5.0, 10.0, 20.0))
    klinokinesis_gain: float = field(8.0, "klinokinesis: θ = ±max_turn · min(1, gain · novelty / active KCs)",
                                     min_exclusive=0.0, max=100.0)
    klinokinesis_max_turn: float = field(0.6, "klinokinesis: the widest turn θ (at ±1 the ant turns on the spot)",
                                         min_exclusive=0.0, max=1.0)
    forest_seed: int = field(-1, "seed of one forest (and KC wiring) shared by every trial, whose route is then "
                             "learnt once and, on the kinematic backend, tested by all trials as one batch of "
                             "agents; -1: each trial grows its own forest from its seed (trials one at a time)",
                             min=-1, max=2**31 - 1)
    eyes: str = field("camera", "what the mushroom body sees: camera (the ant's panoramic camera, grey) or compound "
                      "(its two compound eyes' ommatidia, one channel: eye_channel)", choices=EYES)
    eye_channel: str = field("uv", "eyes=compound: the ommatidia's channel the view code is made of: green, uv, or "
                             "uv_green (the UV-green contrast (UV - G) / (UV + G))", choices=EYE_CHANNELS)
    variability: str = variability_field()
    release_jitter_m: float = field(0.1, "variability: each trial's release moved by a seeded Gaussian offset of "
                                    "this standard deviation on each axis (m)", min=0.0, max=5.0)
    release_heading_jitter_deg: float = field(10.0, "variability: each trial's release heading turned by a seeded "
                                              "Gaussian angle of this standard deviation (deg)", min=0.0, max=180.0)
    eye_noise: float = field(0.02, "variability: Gaussian noise added to every pixel of every view the mushroom "
                             "body reads, training and test (standard deviation, grey levels 0-1; with "
                             "eyes=compound in the channel's units)", min=0.0, max=1.0)
    turn_noise: float = field(0.03, "variability: Gaussian noise added to each gait cycle's test turn θ "
                              "(standard deviation; θ = ±1 turns on the spot)", min=0.0, max=1.0)
    stride_noise_deg: float = field(1.0, "variability: Gaussian noise added to each gait cycle's test stride of 20° "
                                    "(standard deviation, deg)", min=0.0, max=10.0)

    def cross_check(self) -> None:
        strategies(self)
        release_offsets_m(self)


def strategies(config: RouteFollowingConfig) -> tuple[str, ...]:
    """The strategies of ``config.strategy`` (one, or a comma list cycled over trials by seed)."""
    return settings.choice_list("strategy", config.strategy, STRATEGIES)


def release_offsets_m(config: RouteFollowingConfig) -> tuple[float, ...]:
    """The release offsets of ``config.release_offset_m`` (m; one, or a comma list cycled over trials)."""
    return settings.number_list("release_offset_m", config.release_offset_m, -10.0, 10.0, "m", "offset")


def trial_release_offset_m(config: RouteFollowingConfig, seed: int) -> float:
    """Trial ``seed``'s release offset: the list of ``release_offset_m`` cycled by whole cycles of the strategies
    (so that every strategy meets every offset)."""
    values = release_offsets_m(config)
    return values[(seed // len(strategies(config))) % len(values)]


def trial_strategy(config: RouteFollowingConfig, seed: int) -> str:
    """Trial ``seed``'s strategy: the comma list of ``strategy`` cycled by seed."""
    values = strategies(config)
    return values[seed % len(values)]


class RouteNoise:
    """The sensor and motor noise of a batch of trials (agent i seeded by ``seeds[i]``), sized by ``config``
    and drawn only when ``variability`` is on: each trial draws from its own generators, whatever its batch.

    Parameters
    ----------
    config : RouteFollowingConfig
        ``eye_noise``, ``turn_noise``, ``stride_noise_deg`` and ``variability`` are read.
    seeds : sequence of int
        One per agent; the eye and the motor are separate streams of each.
    eye_source : str
        The eye's stream: ``"eye"`` for the test, ``"eye_training"`` for the guided walk.
    """

    def __init__(self, config: RouteFollowingConfig, seeds, eye_source: str = "eye") -> None:
        on = is_on(config)
        self.eye_sd = config.eye_noise if on else 0.0
        self.turn_sd = config.turn_noise if on else 0.0
        self.stride_sd_rad = float(np.radians(config.stride_noise_deg)) if on else 0.0
        self.eye = trial_generators(seeds, eye_source)
        self.motor = trial_generators(seeds, "motor")

    def view(self, agent: int, panorama: np.ndarray) -> np.ndarray:
        """Agent ``agent``'s panorama as its eye reads it (unchanged without eye noise)."""
        if not self.eye_sd:
            return panorama
        return panorama + self.eye[agent].normal(0.0, self.eye_sd, np.shape(panorama))

    def command(self, agent: int, turn: float, stride_rad: float = STRIDE_RAD) -> tuple[float, float]:
        """A gait cycle's (turn, stride) as the legs carry it out: turn clipped to [-1, 1], stride >= 0."""
        if not (self.turn_sd or self.stride_sd_rad):
            return turn, stride_rad
        d_turn, d_stride = self.motor[agent].normal(0.0, 1.0, 2)
        return (float(np.clip(turn + self.turn_sd * d_turn, -1.0, 1.0)),
                float(max(stride_rad + self.stride_sd_rad * d_stride, 0.0)))


# The scan's steering constants per body where the settings leave them at 0 (measured, seeds 1-4 and 1-10:
# the physics ants overshoot at the unicycle's gain and sway within a stride; README "route-following").
UNICYCLE_STEERING = {"scan_full_turn_deg": 30.0, "test_views_per_cycle": 1}
PHYSICS_ANT_STEERING = {"scan_full_turn_deg": 45.0, "test_views_per_cycle": 4}


def body_steering(config: RouteFollowingConfig, backend: str) -> RouteFollowingConfig:
    """The settings with the scan gain and test views per cycle left at 0 replaced by the body's own."""
    own = UNICYCLE_STEERING if backend == "kinematic" else PHYSICS_ANT_STEERING
    return replace(config, **{key: value for key, value in own.items() if not getattr(config, key)})


def make_route_engine(backend_name: str, timestep_s: float, eyes: str = "camera"):
    """(engine, body, gait, physics step): the ant on a physics backend (with its compound eyes when ``eyes`` is
    ``compound``), or the kinematic unicycle with the ant's panoramic camera at one ray per pixel (the
    supersampled one costs 16x the rays) or its two compound eyes."""
    if backend_name != "kinematic":
        return make_engine(backend_name, timestep_s, **({"compound_eyes": True} if eyes == "compound" else {}))
    if eyes == "compound":
        body = PointAgents(count=1, mode="unicycle", compound_eyes=ant_eyes()[0])
    else:
        camera = next(c for c in point_agent_cameras(desert_ant()) if c.name == "panorama")
        body = PointAgents(count=1, mode="unicycle", cameras=(replace(camera, supersample=1),))
    return registry.load("backend", "kinematic")(timestep_s=CONTROL_S), body, None, CONTROL_S


class RouteViews:
    """What the mushroom body sees, as panoramas (N, 72, 72): the panoramic camera's image, or (``eyes`` compound)
    one channel of the two compound eyes laid out on its grid (:class:`.compound_view.CompoundPanorama`)."""

    def __init__(self, config: RouteFollowingConfig) -> None:
        self.eyes = config.eyes
        self.layout = CompoundPanorama(*ant_eyes(), config.eye_channel) if self.eyes == "compound" else None
        self.sensors = EYE_SENSORS if self.layout else ("panorama",)

    def read(self, backend, also=("position", "heading")) -> tuple[dict, np.ndarray]:
        """(the sensors ``also`` read with the eyes, the panoramas)."""
        sensed = backend.read((*also, *self.sensors))
        return sensed, (self.layout(sensed) if self.layout else sensed["panorama"])

    def at(self, world, positions_m: np.ndarray, headings_rad: np.ndarray, chunk: int = 200) -> np.ndarray:
        """The panoramas seen from each position and heading, ray cast by the kinematic backend."""
        if not self.layout:
            return panoramas(world, positions_m, headings_rad)
        eyes = ant_eyes()[0]
        images = []
        for start in range(0, len(positions_m), chunk):
            where, facing = positions_m[start:start + chunk], headings_rad[start:start + chunk]
            backend = registry.load("backend", "kinematic")()
            backend.load(world, [PointAgents(count=len(where), mode="unicycle", compound_eyes=eyes)])
            backend.reset(position_m=where, heading_rad=facing)
            images.append(self.read(backend, also=())[1])
        return np.concatenate(images)


class RouteMemory:
    """The mushroom body of one ant: a learner (batch 1) and a judge (one agent per scanned heading)."""

    def __init__(self, config: RouteFollowingConfig, seed: int) -> None:
        circuit = mushroom_body(n_pn=PANORAMA_ROWS * PANORAMA_COLUMNS, n_kc=config.n_kc, seed=seed)
        self.circuit = circuit
        step_columns = int(round(config.scan_step_deg / COLUMN_DEG))
        steps = int(config.scan_deg // (step_columns * COLUMN_DEG))
        self.rolls = np.arange(-steps, steps + 1) * step_columns  # columns
        self.learner = circuit.compile(batch=1)
        self.judge = circuit.compile(batch=len(self.rolls))
        self.views = 0

    def learn(self, panorama: np.ndarray) -> None:
        self.learner.step({"pn": panorama_code(panorama), "learning": np.ones((1, 1))})
        self.views += 1

    def freeze(self) -> None:
        """Give the judge the learnt weights (every scanned heading judged by the same memory)."""
        self.judge.set_weights("KC->MBON", self.learner.weights("KC->MBON"))

    def scan(self, panorama: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        """Heading offsets (deg, + right), their novelty, and the share of KCs active looking ahead."""
        codes = np.concatenate([panorama_code(np.roll(panorama, k, axis=-1)) for k in self.rolls])
        values = novelty(self.judge, codes)
        ahead = int(np.flatnonzero(self.rolls == 0)[0])
        return -self.rolls * COLUMN_DEG, values, float(kc_sparsity(self.judge)[ahead])


class GuidedLearning:
    """Training steering: pure pursuit along the route, a view stored at every call.

    With ``travel_aligned`` each view is stored turned to face the way the ant moved over its last
    gait cycle (``calls_per_cycle`` calls), not the way its body points: a legged body turning
    under differential stride walks crabwise (the body axis several degrees off its path), and a
    memory of body-aligned views would then steer the test ant, which walks along its body axis,
    off the route (see :mod:`neuronav.scenarios.tools.turn_response`). The turned view is the panorama rolled by
    whole columns (5°), as in the test's scan.
    """

    def __init__(self, route_m: np.ndarray, memory: RouteMemory, calls_per_cycle: int = 1,
                 travel_aligned: bool = False, noise: RouteNoise | None = None,
                 views: RouteViews | None = None) -> None:
        self.route_m, self.memory, self.noise, self.views = route_m, memory, noise, views
        self.calls_per_cycle, self.travel_aligned = calls_per_cycle, travel_aligned
        self.positions: list[np.ndarray] = []
        self.crab_deg: list[float] = []
        self.done = False

    def __call__(self, loop: AgentLoop) -> tuple[float, float]:
        sensed, panorama = self.views.read(loop.backend) if self.views else _camera_read(loop.backend)
        position, heading = sensed["position"][0], float(sensed["heading"][0, 0])
        self.positions.append(position.copy())
        panorama = self.noise.view(0, panorama) if self.noise else panorama
        self.memory.learn(np.roll(panorama, self.view_roll_columns(heading), axis=-1))
        nearest = int(np.argmin(np.hypot(*(self.route_m - position).T)))
        target = self.route_m[min(nearest + int(round(LOOKAHEAD_M / SPACING_M)), len(self.route_m) - 1)]
        desired = np.arctan2(target[0] - position[0], target[1] - position[1])
        error = float(wrap_rad(desired - heading))  # positive: the target lies to the right
        self.done = nearest >= len(self.route_m) - 1 or np.hypot(*(self.route_m[-1] - position)) < 0.3
        return float(np.clip(-error / np.radians(45.0), -1.0, 1.0)), STRIDE_RAD

    def view_roll_columns(self, heading_rad: float) -> int:
        """Columns to roll the panorama so that it faces the way the ant moved over its last gait cycle (the
        chord from the position a cycle ago; 0 when not ``travel_aligned``, in the first cycle, or standing
        still). Headings are clockwise from +y. The body's sway within the stride is rolled out with the
        crab; in a steady turn the chord lags the current direction of travel by half the cycle's turn."""
        if not self.travel_aligned or len(self.positions) <= self.calls_per_cycle:
            return 0
        moved = self.positions[-1] - self.positions[-1 - self.calls_per_cycle]
        if np.hypot(*moved) < 1e-3:
            return 0
        crab_deg = float(np.degrees(wrap_rad(np.arctan2(moved[0], moved[1]) - heading_rad)))  # + travel to the right
        self.crab_deg.append(crab_deg)
        return -int(round(crab_deg / COLUMN_DEG))  # rolling k columns faces -5k° (+ right), as in the scan


def familiarity_turn(strategy: str, memory: RouteMemory, offsets: np.ndarray, values: np.ndarray, active: float,
                     side: float, full_turn_deg: float = 30.0, klinokinesis_gain: float = 2.0,
                     klinokinesis_max_turn: float = 1.0) -> float:
    """The turn (θ > 0 left) the mushroom body gives for the novelty ``values`` of the scanned heading
    ``offsets`` (deg, + right; :meth:`RouteMemory.scan`); ``side`` (±1) is klinokinesis's turn direction
    this cycle, ``active`` the share of KCs active looking ahead; scan turns at ±1 from ``full_turn_deg`` off,
    klinokinesis by ±``klinokinesis_max_turn`` · min(1, ``klinokinesis_gain`` · novelty / active KCs)."""
    if strategy == "scan":
        return float(np.clip(-offsets[int(np.argmin(values))] / full_turn_deg, -1.0, 1.0))
    ahead = values[np.flatnonzero(offsets == 0.0)[0]]
    kcs = max(active * memory.learner.rates("KC").shape[1], 1.0)
    return side * klinokinesis_max_turn * min(1.0, klinokinesis_gain * ahead / kcs)


class FamiliaritySteering:
    """Test steering: the mushroom body alone, by scanning or by klinokinesis."""

    def __init__(self, strategy: str, memory: RouteMemory, route_m: np.ndarray, reach_m: float,
                 views_per_cycle: int = 1, full_turn_deg: float = 30.0,
                 klinokinesis: tuple[float, float] = (2.0, 1.0), noise: RouteNoise | None = None,
                 views: RouteViews | None = None) -> None:
        self.strategy, self.memory, self.route_m, self.reach_m = strategy, memory, route_m, reach_m
        self.views = views
        self.noise, self.stride = noise, STRIDE_RAD
        self.log: dict[str, list] = {k: [] for k in LOG_KEYS}
        self.log["position_m"] = []
        self.side = 1.0
        self.views_per_cycle, self.ticks, self.turn = views_per_cycle, 0, 0.0
        self.full_turn_deg, self.klinokinesis = full_turn_deg, klinokinesis
        self.recent: list[np.ndarray] = []

    def __call__(self, loop: AgentLoop) -> tuple[float, float]:
        """Called ``views_per_cycle`` times per gait cycle; turns once per cycle, on the novelty averaged over
        the last ``views_per_cycle`` views (so that the body's sway within a stride averages out)."""
        sensed, panorama = self.views.read(loop.backend) if self.views else _camera_read(loop.backend)
        panorama = self.noise.view(0, panorama) if self.noise else panorama
        offsets, values, active = self.memory.scan(panorama)
        self.recent = [*self.recent, values][-self.views_per_cycle:]
        self.ticks += 1
        if (self.ticks - 1) % self.views_per_cycle:
            return self.turn, self.stride
        self.side = -self.side
        ahead = values[np.flatnonzero(offsets == 0.0)[0]]
        turn = familiarity_turn(self.strategy, self.memory, offsets, np.mean(self.recent, axis=0), active,
                                self.side, self.full_turn_deg, *self.klinokinesis)
        if self.noise:
            turn, self.stride = self.noise.command(0, turn)
        self.turn = turn
        for key, value in (("time_s", loop.time_s), ("heading_rad", sensed["heading"][0, 0]), ("novelty", ahead),
                           ("turn", turn), ("kc_active", active)):
            self.log[key].append(float(value))
        self.log["position_m"].append(sensed["position"][0].copy())
        return turn, self.stride

    def arrived(self, loop: AgentLoop) -> bool:
        """Within ``reach_m`` of the route's end (checked every control step)."""
        position = loop.backend.read(("position",))["position"][0]
        return bool(np.hypot(*(position - self.route_m[-1])) < self.reach_m)


def _camera_read(backend) -> tuple[dict, np.ndarray]:
    """Position, heading and the panoramic camera's image."""
    sensed = backend.read(("position", "heading", "panorama"))
    return sensed, sensed["panorama"]


def release_point(points: np.ndarray, headings: np.ndarray, offset_m: float) -> np.ndarray:
    """The route's start moved ``offset_m`` to the right of its first heading (negative: left)."""
    h = headings[0]
    return points[0] + offset_m * np.array([np.cos(h), -np.sin(h)])


def world_seed(config: RouteFollowingConfig, seed: int) -> int:
    """The seed of a trial's forest and KC wiring: the shared ``forest_seed``, or the trial's own."""
    return config.forest_seed if config.forest_seed >= 0 else seed


def trial_start(config: RouteFollowingConfig, points: np.ndarray, headings: np.ndarray,
                seed: int) -> tuple[np.ndarray, float]:
    """A trial's release point and heading (rad, clockwise from +y): its release offset right of the route's
    start, facing its first heading; with ``variability`` on, moved by the trial's seeded jitter
    (``release_jitter_m`` on each axis, then ``release_heading_jitter_deg``)."""
    position, heading = release_point(points, headings, trial_release_offset_m(config, seed)), float(headings[0])
    if not is_on(config):
        return position, heading
    draws = trial_generators([seed], "release")[0].normal(0.0, 1.0, 3)
    return (position + config.release_jitter_m * draws[:2],
            heading + float(np.radians(config.release_heading_jitter_deg)) * float(draws[2]))


def route_video(points: np.ndarray, memory: RouteMemory, steering: FamiliaritySteering) -> VideoContent:
    """What the test's video shows: the learnt route and its end, the panorama and the mushroom body's novelty
    looking ahead (its output over the active KCs, the share klinokinesis turns by)."""
    def novelty(loop) -> float:
        if not steering.log["novelty"]:
            return 0.0
        kcs = max(steering.log["kc_active"][-1] * memory.learner.rates("KC").shape[1], 1.0)
        return steering.log["novelty"][-1] / kcs

    return VideoContent(routes=(points,), markers=(Marker("end", tuple(points[-1]), 0.3),),
                        insets=(EyeInset(("panorama",), "panorama", height_px=144),
                                LevelInset("MB novelty", novelty)),
                        keep_in_view=(tuple(points.min(axis=0)), tuple(points.max(axis=0))))


def route_trial(config: RouteFollowingConfig, backend_name: str, seed: int,
                landscape: bool = False, video_path=None) -> tuple[dict, dict]:
    """One trial: train along the route, test from the release point (filmed to ``video_path`` when given);
    the metrics row and the logs."""
    config = body_steering(config, backend_name)
    points, headings = route(int(round(config.route_m / SPACING_M)) + 1)
    world = forest_world(points, seed=world_seed(config, seed))
    engine, body, gait, physics_dt = make_route_engine(backend_name, config.timestep_s, config.eyes)
    views = RouteViews(config)
    memory = RouteMemory(config, world_seed(config, seed))
    clocks = Clocks(physics_dt_s=physics_dt, control_dt_s=CONTROL_S, brain_dt_s=CYCLE_S / config.test_views_per_cycle)
    training_clocks = Clocks(physics_dt_s=physics_dt, control_dt_s=CONTROL_S,
                             brain_dt_s=CYCLE_S / config.views_per_cycle)
    steering = FamiliaritySteering(trial_strategy(config, seed), memory, points, config.reach_m,
                                   config.test_views_per_cycle, config.scan_full_turn_deg,
                                   (config.klinokinesis_gain, config.klinokinesis_max_turn),
                                   noise=RouteNoise(config, [seed]), views=views)
    with engine:
        engine.load(world, [body])
        guide = GuidedLearning(points, memory, config.views_per_cycle, config.travel_aligned_views,
                               noise=RouteNoise(config, [world_seed(config, seed)], "eye_training"), views=views)
        training = AgentLoop(engine, gait, training_clocks, steering=guide)
        training.reset(seed=seed, position_m=(0.0, 0.0), yaw_rad=np.pi / 2 - headings[0])
        training.run(10.0 * config.route_m, until=lambda loop: guide.done)  # at least 0.1 m/s
        memory.freeze()
        video = (VideoRecorder(video_path, "follow", every=VIDEO_EVERY,
                               compose=VideoOverlay(route_video(points, memory, steering)))
                 if video_path is not None else None)
        test = AgentLoop(engine, gait, clocks, steering=steering, hooks=[video] if video else [])
        start, start_heading = trial_start(config, points, headings, seed)
        test.reset(seed=seed, position_m=tuple(start), yaw_rad=np.pi / 2 - start_heading)
        try:
            test.run(config.duration_s, until=steering.arrived)
        finally:
            if video is not None:
                video.close()
        final = engine.read(("position",))["position"][0]
        test_time_s = test.time_s
    log = {k: np.array(v, float) for k, v in steering.log.items() if k != "position_m"}
    log["position_m"] = np.array([*steering.log["position_m"], final]).reshape(-1, 2)
    log["train_position_m"] = np.array(guide.positions).reshape(-1, 2)
    log["world"] = world_record(world, goal_m=points[-1])
    if landscape:
        log.update(familiarity_landscape(memory, world, points, headings, views=views))
    row = route_metrics(log["position_m"], points, config, memory.views, test_time_s)
    return dict(row, strategy=steering.strategy, release_offset_m=trial_release_offset_m(config, seed)), log


def route_metrics(path_m: np.ndarray, points: np.ndarray, config: RouteFollowingConfig, views: int,
                  test_time_s: float) -> dict:
    """Checkpoints reached, distances from the route, success (the last checkpoint reached).

    The path (one position per gait cycle) is taken as straight between its points, sampled every
    5 cm, so that a checkpoint passed between two looks counts.
    """
    path_m = densify(path_m, 0.05)
    every = max(1, int(round(config.checkpoint_every_m / SPACING_M)))
    checkpoints = points[every::every]
    if not len(checkpoints) or not np.array_equal(checkpoints[-1], points[-1]):
        checkpoints = np.vstack([checkpoints.reshape(-1, 2), points[-1]])
    to_checkpoint = np.hypot(*(checkpoints[:, None, :] - path_m[None, :, :]).transpose(2, 0, 1)).min(axis=1)
    reached = to_checkpoint <= config.reach_m
    from_route = np.hypot(*(path_m[:, None, :] - points[None, :, :]).transpose(2, 0, 1)).min(axis=1)
    return {
        "success": bool(reached[-1]), "status": "ok", "error": "",
        "checkpoints_reached": float(reached.mean()),
        "mean_distance_m": float(from_route.mean()),
        "max_distance_m": float(from_route.max()),
        "final_distance_to_goal_m": float(np.hypot(*(path_m[-1] - points[-1]))),
        "views_stored": float(views),
        "test_time_s": float(test_time_s),
    }


def densify(path_m: np.ndarray, step_m: float) -> np.ndarray:
    """The polyline ``path_m`` (P, 2) with points added so that none lies more than ``step_m`` apart."""
    pieces = [path_m[:1]]
    for a, b in zip(path_m[:-1], path_m[1:]):
        count = max(1, int(np.ceil(np.hypot(*(b - a)) / step_m)))
        pieces.append(a + (b - a) * (np.arange(1, count + 1) / count)[:, None])
    return np.concatenate(pieces)


def familiarity_landscape(memory: RouteMemory, world, points: np.ndarray, headings: np.ndarray,
                          shape=(9, 13), margin_m: float = 3.0, views: RouteViews | None = None) -> dict:
    """Relative novelty (novelty / active KCs; NaN where no KC fires, e.g. inside a tree's crown) on a
    grid about the route, each point facing the heading of its nearest route point (ray cast with the
    kinematic backend's eyes: ``views``', the panoramic camera by default)."""
    low, high = points.min(axis=0) - margin_m, points.max(axis=0) + margin_m
    xs, ys = np.linspace(low[0], high[0], shape[1]), np.linspace(low[1], high[1], shape[0])
    grid = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    nearest = np.argmin(np.hypot(*(grid[:, None, :] - points[None, :, :]).transpose(2, 0, 1)), axis=1)
    images = views.at(world, grid, headings[nearest]) if views else panoramas(world, grid, headings[nearest])
    codes = panorama_code(images)
    values = novelty(memory.judge, codes)
    active = novelty(memory.circuit.compile(batch=memory.judge.batch), codes)  # nothing learnt: every active KC
    relative = np.divide(values, active, out=np.full_like(values, np.nan), where=active > 0)
    return {"landscape_x_m": xs, "landscape_y_m": ys, "landscape_novelty": relative.reshape(shape)}


class RouteFollowing(Scenario):
    """Learn a route's views with the mushroom body, then follow it by familiarity alone."""

    name = "route-following"
    condition_columns = ("strategy",)
    description = ("learn a forest route's views in one guided walk (mushroom body), then follow it by "
                   "familiarity: scanning or klinokinesis; displaced releases give the catchment")
    config_type = RouteFollowingConfig
    backends = EVERY_BACKEND
    default_backend = "kinematic"
    records_video = True
    chunk_trials = 1000  # kinematic batches (shared forest) of at most this many agents

    def smoke_config(self) -> dict:
        return {"route_m": 2.0, "duration_s": 4.0, "n_kc": 500, "landscape": False}

    def statistics(self, config: RouteFollowingConfig) -> Statistics:
        """Per strategy (each trial's ``strategy`` column; ``--set strategy=scan,klinokinesis`` runs both, cycled
        by seed) against the first listed or, with one strategy and several release offsets
        (``release_offset_m=0,1``), per offset against the first listed: the checkpoints reached, the distances
        from the route, the test time and success."""
        offsets = release_offsets_m(config)
        if len(strategies(config)) == 1 and len(offsets) > 1:
            return Statistics(condition="release_offset_m", reference=offsets[0],
                              metrics=("checkpoints_reached", "mean_distance_m", "max_distance_m",
                                       "final_distance_to_goal_m", "test_time_s"))
        return Statistics(condition="strategy", reference=strategies(config)[0],
                          metrics=("checkpoints_reached", "mean_distance_m", "max_distance_m",
                                   "final_distance_to_goal_m", "test_time_s"))

    def leading_series(self, config: RouteFollowingConfig, backend: str) -> dict[str, int]:
        """The first trial's landscape, stored once."""
        return dict.fromkeys(("landscape_x_m", "landscape_y_m", "landscape_novelty"), 1)

    def check(self, config: RouteFollowingConfig, backend: str) -> None:
        from neuronav.engine.loop import integer_ratio

        if backend != "kinematic":
            integer_ratio(CONTROL_S, config.timestep_s, "control step (8 ms) / timestep_s")

    def check_video(self, config: RouteFollowingConfig, backend: str) -> None:
        """A shared forest on the kinematic backend runs every trial as one batch, with no agent loop to film."""
        if self._batched(body_steering(config, backend), backend):
            raise ConfigError("--video films one trial's agent loop; with forest_seed >= 0 on kinematic the trials run "
                              "as one batch: give --set forest_seed=-1 (or another backend)")

    @staticmethod
    def _batched(config: RouteFollowingConfig, backend: str) -> bool:
        return backend == "kinematic" and config.forest_seed >= 0 and config.test_views_per_cycle == 1

    def run(self, config: RouteFollowingConfig, *, backend: str, trials: int, seed: int,
            video_path: Path | None = None) -> ScenarioResult:
        config = body_steering(config, backend)
        if self._batched(config, backend):
            rows, logs = run_kinematic_batch(config, [seed + i for i in range(trials)], landscape=config.landscape)
            rows = [dict(row, trial=i, seed=seed + i) for i, row in enumerate(rows)]
            return ScenarioResult(trials=rows, timeseries=pack_route_logs(logs, config),
                                  simulated_time_s=config.duration_s)
        rows, logs = [], []
        for i in range(trials):
            row, log = route_trial(config, backend, seed + i, landscape=(i == 0 and config.landscape
                                                                         and backend == "kinematic"),
                                   video_path=video_path if i == 0 else None)
            rows.append(dict(row, trial=i, seed=seed + i))
            logs.append(log)
        return ScenarioResult(trials=rows, timeseries=pack_route_logs(logs, config),
                              simulated_time_s=config.duration_s)

    def figures(self, result: ScenarioResult, config: RouteFollowingConfig, out_dir: Path) -> list[Path]:
        from neuronav.scenarios.route_following.figures import write_route_figures

        return write_route_figures(result, config, Path(out_dir))


def pack_route_logs(logs: list[dict], config: RouteFollowingConfig) -> dict[str, np.ndarray]:
    """The trials' logs as NaN-padded arrays (trials, cycles, ...), each trial's world (its forest, the route
    ``route_m`` and its end ``goal_m``) and the first trial's landscape."""
    timeseries = pack_cycle_logs(logs, LOG_KEYS)
    longest = max(len(log["train_position_m"]) for log in logs)
    timeseries["train_position_m"] = np.full((len(logs), longest, 2), np.nan)
    for i, log in enumerate(logs):
        timeseries["train_position_m"][i, :len(log["train_position_m"])] = log["train_position_m"]
    # The route is the same in every trial; each trial keeps it (a few kB), so that each trial's replay in a
    # report draws it (a series stored for the first trial only is that trial's alone).
    points = route(int(round(config.route_m / SPACING_M)) + 1)[0]
    timeseries["route_m"] = np.repeat(points[None], len(logs), axis=0)
    timeseries.update(pack_world([log["world"] for log in logs]))  # each trial's forest (objects_m) and goal
    if "landscape_novelty" in logs[0]:
        for key in ("landscape_x_m", "landscape_y_m", "landscape_novelty"):
            timeseries[key] = logs[0][key][None]  # the first trial's, with a trial axis of one
    return timeseries


def train_once(config: RouteFollowingConfig, world, points: np.ndarray, headings: np.ndarray,
               memory: RouteMemory, views: RouteViews | None = None) -> np.ndarray:
    """The guided training walk on the kinematic unicycle (one agent); the learnt memory frozen. Its path."""
    engine, body, gait, physics_dt = make_route_engine("kinematic", config.timestep_s, config.eyes)
    clocks = Clocks(physics_dt_s=physics_dt, control_dt_s=CONTROL_S, brain_dt_s=CYCLE_S / config.views_per_cycle)
    guide = GuidedLearning(points, memory, config.views_per_cycle, config.travel_aligned_views,
                           noise=RouteNoise(config, [config.forest_seed], "eye_training"), views=views)
    with engine:
        engine.load(world, [body])
        training = AgentLoop(engine, gait, clocks, steering=guide)
        training.reset(seed=0, position_m=(0.0, 0.0), yaw_rad=np.pi / 2 - headings[0])
        training.run(10.0 * config.route_m, until=lambda loop: guide.done)
    memory.freeze()
    return np.array(guide.positions).reshape(-1, 2)


def run_kinematic_batch(config: RouteFollowingConfig, seeds: list[int], landscape: bool = False):
    """Every trial at once in the shared forest (``forest_seed``): the route learnt once, then one point agent
    per trial released at its own (seeded) point, each steered by the same memory. Rows and logs per trial.

    A trial's numbers do not depend on the batch: its release comes from its seed, and every agent's
    panorama is judged on its own, exactly as a trial run alone.
    """
    config = body_steering(config, "kinematic")
    points, headings = route(int(round(config.route_m / SPACING_M)) + 1)
    world = forest_world(points, seed=config.forest_seed)
    memory = RouteMemory(config, config.forest_seed)
    views = RouteViews(config)
    train_path = train_once(config, world, points, headings, memory, views)
    n = len(seeds)
    releases = [trial_start(config, points, headings, s) for s in seeds]
    starts = np.array([position for position, _ in releases]).reshape(-1, 2)
    start_headings = np.array([heading for _, heading in releases])
    trial_strategies = [trial_strategy(config, s) for s in seeds]
    noise = RouteNoise(config, seeds)
    engine, body, _, _ = make_route_engine("kinematic", config.timestep_s, config.eyes)
    body = replace(body, count=n)
    controls = int(round(CYCLE_S / CONTROL_S))
    done_s, final = np.full(n, np.nan), np.full((n, 2), np.nan)
    logs = [dict({k: [] for k in LOG_KEYS}, position_m=[]) for _ in seeds]
    sides = np.ones(n)
    with engine:
        engine.load(world, [body])
        engine.reset(seed=0, position_m=starts, heading_rad=start_headings)
        while engine.time < config.duration_s - 1e-9 and np.isnan(done_s).any():
            sensed, seen = views.read(engine)
            turn, stride = np.zeros((n, 1)), np.zeros((n, 1))
            sides = -sides
            for i in np.flatnonzero(np.isnan(done_s)):
                offsets, values, active = memory.scan(noise.view(i, seen[i:i + 1]))
                ahead = values[np.flatnonzero(offsets == 0.0)[0]]
                turn[i, 0], stride[i, 0] = noise.command(i, familiarity_turn(
                    trial_strategies[i], memory, offsets, values, active, sides[i], config.scan_full_turn_deg,
                    config.klinokinesis_gain, config.klinokinesis_max_turn))
                for key, value in (("time_s", engine.time), ("heading_rad", sensed["heading"][i, 0]),
                                   ("novelty", ahead), ("turn", turn[i, 0]), ("kc_active", active)):
                    logs[i][key].append(float(value))
                logs[i]["position_m"].append(sensed["position"][i].copy())
            engine.write({"turn": turn, "stride": stride})
            for _ in range(controls):
                engine.step(1)
                position = engine.read(("position",))["position"]
                near = np.isnan(done_s) & (np.hypot(*(position - points[-1]).T) < config.reach_m)
                done_s[near], final[near] = engine.time, position[near]
                if not np.isnan(done_s).any() or engine.time >= config.duration_s - 1e-9:
                    break
        running = np.isnan(done_s)
        final[running] = engine.read(("position",))["position"][running]
        end_s = np.where(running, engine.time, done_s)
    rows, out = [], []
    for i in range(n):
        log = {k: np.array(v, float) for k, v in logs[i].items() if k != "position_m"}
        log["position_m"] = np.array([*logs[i]["position_m"], final[i]]).reshape(-1, 2)
        log["train_position_m"] = train_path
        log["world"] = world_record(world, goal_m=points[-1])
        rows.append(dict(route_metrics(log["position_m"], points, config, memory.views, float(end_s[i])),
                         strategy=trial_strategies[i], release_offset_m=trial_release_offset_m(config, seeds[i])))
        out.append(log)
    if landscape and n:
        out[0].update(familiarity_landscape(memory, world, points, headings, views=views))
    return rows, out
