"""The ant odometer on stilts and stumps (Wittlinger, Wehner & Wolf 2006, Science 312:1965).

An ant walks a straight outbound channel of ``channel_m`` from the nest (y = 0) to a feeder (y =
``channel_m``) with normal legs, its odometer integrating the distance along the channel. At the feeder
its legs are changed (``legs``: normal, stilts, stumps; a comma list is cycled over trials by seed) — a
new body on a new engine, as physics backends cannot change a body mid-run — and it walks home along the
channel until its odometer has counted the outbound distance again: there it starts to search. The
metric is ``search_start_m``, the true distance walked home at that moment. Odometry ``steps``: the
step odometer (:class:`neuronav.bodies.step_odometer.StepOdometer`) reads the joint angles and leg loads
through the leg kinematics of the normal body (the belief, fixed for the trial); ``true``: the true
displacement (legs then cannot matter). The kinematic unicycle counts strides × the believed stride length
(:class:`~neuronav.bodies.step_odometer.UnicycleStrideOdometer`) and walks with its calibrated speed times
the legs' stride-length factor. The heading is held along the channel by a proportional turn command on
the true heading, once per gait cycle (the channel's walls do this for the real ant).

Metrics per trial: ``search_start_m``, ``search_ratio`` (over the true outbound distance),
``outbound_odometer_m`` (the distance stored at the feeder), ``outbound_true_m``, ``stride_length_m`` and
``stride_length_believed_m`` (homeward, true and as the odometer measured it, per gait cycle),
``trial_time_s``, ``real_time_factor``; ``legs`` is the condition the statistics compare with normal.

Variability (``variability=on``, the default): start jitter (across the channel and in heading, at the
nest and at the release) and motor noise (:class:`neuronav.scenarios.motor_noise.MotorNoise`), each from its
own stream of the trial's seed; ``off``: every trial of a condition is the same walk.

Results, sources and model choices: README.md in this folder.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from neuronav import registry
from neuronav.angles import wrap_rad
from neuronav.bodies.desert_ant import desert_ant
from neuronav.bodies.desert_ant.manipulations import (
    MANIPULATIONS,
    STILTS_FACTOR,
    STUMPS_SEGMENT_FACTORS,
    leg_length_ratio,
    manipulated_ant,
)
from neuronav.bodies.gaits import make_gait
from neuronav.bodies.step_odometer import StepOdometer, UnicycleStrideOdometer
from neuronav.config import field
from neuronav.engine.loop import AgentLoop, Clocks, Hook, integer_ratio
from neuronav.engine.video import join_filmed_parts
from neuronav.runs.scenario import Scenario, ScenarioResult
from neuronav.runs.summary_statistics import Statistics
from neuronav.scenarios import EVERY_BACKEND, settings
from neuronav.scenarios.aggregation import mean_of, per_condition
from neuronav.scenarios.motor_noise import MotorNoise, stride_noise_field, turn_noise_field
from neuronav.scenarios.trial_loop import run_loop, trials_one_by_one
from neuronav.scenarios.variability import is_on, jitter_start, trial_generators, variability_field
from neuronav.scenarios.visual_setup import CONTROL_S, CYCLE_S
from neuronav.scenarios.worlds.scenes import pack_world
from neuronav.spec.world import Ground, PointAgents, World

LEG_CONDITIONS = MANIPULATIONS  # normal, stilts, stumps
ODOMETRY = ("steps", "true")
NEST_HEADING_RAD = 0.0  # outbound: along +y, from the nest to the feeder
HOME_HEADING_RAD = np.pi  # homeward: along -y


@dataclass
class OdometerConfig:
    legs: str = field("normal,stilts,stumps", "the legs the ant walks home on: normal, stilts or stumps; a comma "
                      "list (normal,stilts,stumps) is cycled over trials by seed")
    odometry: str = field("steps", "what measures the distance: steps (the step odometer through the believed "
                          "normal legs; on kinematic, strides x believed stride length) or true (the true "
                          "displacement: the control the real experiment cannot do)", choices=ODOMETRY)
    channel_m: float = field(10.0, "length of the nest-feeder channel in model metres (the ant is at x100 "
                             "scale: 10 m is about 10 body lengths)", min=0.5, max=100.0)
    stride_deg: float = field(25.0, "hip swing S_l of every gait cycle (deg; eq. 3.7's straight-walking stride)",
                              min=5.0, max=30.0)
    steer_gain: float = field(1.0, "turn command per rad of heading error from along the channel (the walls' "
                              "effect), once per gait cycle", min=0.0, max=20.0)
    timeout_s: float = field(120.0, "each leg of the trip (outbound, homeward) gives up after this long (s)",
                             min=CYCLE_S, max=3600.0)
    timestep_s: float = settings.timestep_field()
    variability: str = variability_field()
    start_position_sd_m: float = field(0.05, "std of the start's offset across the channel, at the nest and "
                                       "at the release (m; variability=on)", min=0.0, max=1.0)
    start_heading_sd_deg: float = field(5.0, "std of the start heading's offset from along the channel, at the "
                                        "nest and at the release (deg; variability=on)", min=0.0, max=45.0)
    turn_noise_sd: float = turn_noise_field()
    stride_noise_fraction: float = stride_noise_field()

    def cross_check(self) -> None:
        leg_conditions(self)


def leg_conditions(config: OdometerConfig) -> tuple[str, ...]:
    """The leg conditions of ``config.legs`` (one, or a comma list cycled over trials by seed)."""
    return settings.choice_list("legs", config.legs, LEG_CONDITIONS)


def trial_legs(config: OdometerConfig, seed: int) -> str:
    """Trial ``seed``'s legs: the comma list of ``legs`` cycled by seed."""
    values = leg_conditions(config)
    return values[seed % len(values)]


def stride_factor(legs: str) -> float:
    """The unicycle's stride-length factor for a manipulation: the mean ratio of the manipulated to the normal
    leg length, coxa to claw (:func:`neuronav.bodies.desert_ant.manipulations.leg_length_ratio`; stilts 1.3,
    stumps 0.548), as if strides scaled with the legs."""
    if legs == "stilts":
        return STILTS_FACTOR
    return leg_length_ratio(STUMPS_SEGMENT_FACTORS) if legs == "stumps" else 1.0


def start_offsets(config: OdometerConfig, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Trial ``seed``'s start jitter: offsets across the channel (2,) m and of heading (2,) rad, for the
    nest start and the release at the feeder (zeros with ``variability=off``)."""
    if not is_on(config):
        return np.zeros(2), np.zeros(2)
    position, heading = jitter_start(trial_generators([seed], "start") * 2, np.zeros((2, 2)), np.zeros(2),
                                     config.start_position_sd_m, np.radians(config.start_heading_sd_deg))
    return position[:, 0], heading


class ChannelSteering:
    """The channel's walls: once per gait cycle, turn = ``steer_gain`` × (heading − target) (θ > 0 turns
    left, toward a smaller heading), at the configured stride, through the trial's motor noise.

    ``commanded`` holds the last command before the motor noise (what a unicycle's stride odometer reads).
    """

    def __init__(self, config: OdometerConfig, target_rad: float, motor: MotorNoise) -> None:
        self.gain, self.target_rad, self.motor = config.steer_gain, float(target_rad), motor
        self.stride_rad = float(np.radians(config.stride_deg))
        self.commanded = (0.0, self.stride_rad)
        self.log: dict[str, list] = {"time_s": [], "position_m": [], "heading_rad": []}

    def __call__(self, loop: AgentLoop) -> tuple[float, float]:
        sensed = loop.backend.read(("heading", "position"))
        heading = float(sensed["heading"][0, 0])
        turn = float(np.clip(self.gain * wrap_rad(heading - self.target_rad), -1.0, 1.0))
        self.commanded = (turn, self.stride_rad)
        for key, value in (("time_s", loop.time_s), ("position_m", sensed["position"][0]), ("heading_rad", heading)):
            self.log[key].append(np.array(value, float))
        return self.motor(turn, self.stride_rad)


class ChannelOdometer(Hook):
    """The distance along the channel (toward ``axis``, a unit (2,) world vector) the odometer measures,
    updated after every control step: the step odometer's body-frame displacement, the unicycle's
    counted strides, or (``odometry=true``) the true displacement, projected on the channel's axis with
    the body's heading (the compass is not the question here)."""

    def __init__(self, odometry: str, axis: np.ndarray, believed, steering: ChannelSteering | None = None) -> None:
        self.odometry, self.axis, self.steering = odometry, np.asarray(axis, float), steering
        self.unicycle = believed if isinstance(believed, UnicycleStrideOdometer) else None
        self.steps = StepOdometer(believed) if odometry == "steps" and self.unicycle is None else None
        self.distance_m = 0.0
        self.last_position_m: np.ndarray | None = None
        # The odometer reading and true position before the last control step (for the crossing point).
        self.previous_distance_m = 0.0
        self.previous_position_m: np.ndarray | None = None
        self.start_position_m: np.ndarray | None = None  # where the body stood after the reset

    def initialize_episode(self, loop: AgentLoop) -> None:
        self.distance_m = self.previous_distance_m = 0.0
        self.last_position_m = loop.backend.read(("position",))["position"][0].copy()
        self.previous_position_m = self.last_position_m.copy()
        self.start_position_m = self.last_position_m.copy()
        if self.steps is not None:
            self.steps.reset()
        if self.unicycle is not None:
            self.unicycle.reset()

    def after_step(self, loop: AgentLoop) -> None:
        position = loop.backend.read(("position",))["position"][0].copy()
        self.previous_distance_m, self.previous_position_m = self.distance_m, self.last_position_m
        self.last_position_m = position
        if self.odometry == "true":
            self.distance_m += float(np.dot(position - self.previous_position_m, self.axis))
            return
        heading = float(loop.backend.read(("heading",))["heading"][0, 0])
        forward = np.array([np.sin(heading), np.cos(heading)])
        left = np.array([-np.cos(heading), np.sin(heading)])
        if self.unicycle is not None:
            turn, stride = self.steering.commanded
            step_m = float(self.unicycle.update(turn, stride, loop.clocks.control_dt_s)[0])
            self.distance_m += step_m * float(np.dot(forward, self.axis))
            return
        sensed = loop.backend.read(("joint_pos", "contact_load"))
        moved = self.steps.update(sensed["joint_pos"][0], sensed["contact_load"][0])
        self.distance_m += float(np.dot(moved[0] * forward + moved[1] * left, self.axis))

    def crossing_m(self, reading_m: float) -> np.ndarray:
        """The true position (2,) m where the odometer read ``reading_m`` during the last control step
        (linear between the positions before and after it; the position after it when it did not move)."""
        moved = self.distance_m - self.previous_distance_m
        fraction = float(np.clip((reading_m - self.previous_distance_m) / moved, 0.0, 1.0)) if moved > 0 else 1.0
        return self.previous_position_m + fraction * (self.last_position_m - self.previous_position_m)


def walking_setup(backend_name: str, config: OdometerConfig, legs: str):
    """(engine, body, gait, physics step) for one leg of the trip with ``legs``: the manipulated ant on a
    physics backend, or the unicycle whose calibrated speed is scaled by the legs' stride-length factor."""
    engine_class = registry.load("backend", backend_name)
    if backend_name == "kinematic":
        calibration = registry.load("unicycle_calibration", "desert_ant")()
        factor = stride_factor(legs)
        scaled = replace(calibration, speed_m_s=np.asarray(calibration.speed_m_s) * factor,
                         source=f"{calibration.source}; speed x {factor:g} ({legs})")
        return engine_class(calibration=scaled, timestep_s=CONTROL_S), PointAgents(count=1, mode="unicycle"), \
            None, CONTROL_S
    body = manipulated_ant(legs)
    return engine_class(timestep_s=config.timestep_s), body, make_gait("tripod", body), config.timestep_s


def believed_odometer(backend_name: str):
    """What the odometer believes about the body, fixed for the trial: the normal ant's legs, or on the
    kinematic backend the normal ant's unicycle calibration (a stride counter)."""
    if backend_name == "kinematic":
        return UnicycleStrideOdometer(registry.load("unicycle_calibration", "desert_ant")(), cycle_s=CYCLE_S)
    return desert_ant()


def walk_leg(config: OdometerConfig, backend_name: str, legs: str, seed: int, start_m, heading_rad: float,
             target_rad: float, believed, motor: MotorNoise, stop, video_path=None) -> dict:
    """One leg of the trip: walk along the channel toward ``target_rad`` from ``start_m`` until
    ``stop(loop, odometer)`` or the timeout; returns the odometer, the steering's log and the end."""
    engine, body, gait, physics_dt = walking_setup(backend_name, config, legs)
    steering = ChannelSteering(config, target_rad, motor)
    axis = np.array([np.sin(target_rad), np.cos(target_rad)])
    odometer = ChannelOdometer(config.odometry, axis, believed, steering)
    clocks = Clocks(physics_dt_s=physics_dt, control_dt_s=CONTROL_S, brain_dt_s=CYCLE_S)
    stopped = []

    def until(lp: AgentLoop) -> bool:
        if stop(lp, odometer):
            stopped.append(True)
        return bool(stopped)

    loop, final, wall_s = run_loop(engine, World(ground=Ground(size_m=4.0 * config.channel_m + 20.0)), body, gait,
                                   clocks, steering, heading_rad=heading_rad, seed=seed, duration_s=config.timeout_s,
                                   until=until, hooks=(odometer,), video_path=video_path,
                                   position_m=tuple(start_m))
    return {"odometer": odometer, "log": steering.log, "final_m": np.asarray(final, float), "time_s": loop.time_s,
            "wall_s": wall_s, "stopped": bool(stopped)}


def odometer_trial(config: OdometerConfig, backend_name: str, seed: int, video_path=None) -> tuple[dict, dict]:
    """One ant: outbound with normal legs to the feeder, homeward with ``legs`` until its odometer has
    counted the outbound distance; the metrics row and the log."""
    legs = trial_legs(config, seed)
    across_m, heading_jitter = start_offsets(config, seed)
    motor = MotorNoise(seed, config.turn_noise_sd if is_on(config) else 0.0,
                       config.stride_noise_fraction if is_on(config) else 0.0)
    believed = believed_odometer(backend_name)
    nest_m = np.array([across_m[0], 0.0])
    # Filmed (trial 0): each leg in a part of its own (each leg is its own engine and loop), joined after.
    parts = [None, None] if video_path is None else [Path(video_path).with_suffix(f".{leg}.partial.mp4")
                                                       for leg in ("outbound", "homeward")]
    row, log = _trip(config, backend_name, seed, legs, nest_m, across_m, heading_jitter, believed, motor, parts)
    if video_path is not None:  # (a trip stopped or failed leaves its legs' parts under their temporary names)
        join_filmed_parts(parts, video_path)
    return row, log


def _trip(config: OdometerConfig, backend_name: str, seed: int, legs: str, nest_m: np.ndarray, across_m,
          heading_jitter, believed, motor: MotorNoise, parts: list) -> tuple[dict, dict]:
    """:func:`odometer_trial`'s two legs, each filmed into its part of ``parts`` (None: not filmed)."""
    def at_feeder(lp: AgentLoop, _odometer) -> bool:
        return bool(lp.backend.read(("position",))["position"][0, 1] >= config.channel_m)

    out = walk_leg(config, backend_name, "normal", seed, nest_m, NEST_HEADING_RAD + heading_jitter[0],
                   NEST_HEADING_RAD, believed, motor, at_feeder, parts[0])
    stored_m = out["odometer"].distance_m
    release_m = np.array([out["final_m"][0] + across_m[1], out["final_m"][1]])

    def searching(_lp, odometer: ChannelOdometer) -> bool:
        return odometer.distance_m >= stored_m

    home = walk_leg(config, backend_name, legs, seed, release_m, HOME_HEADING_RAD + heading_jitter[1],
                    HOME_HEADING_RAD, believed, motor, searching, parts[1])
    # Where the odometer reached the stored distance (within the last 8 ms control step): the search start.
    search_m = home["odometer"].crossing_m(stored_m) if home["stopped"] else home["final_m"]
    walked_home_m = float(home["odometer"].start_position_m[1] - search_m[1])
    outbound_true_m = float(out["final_m"][1] - out["odometer"].start_position_m[1])
    cycles_home = home["time_s"] / CYCLE_S
    row = {
        "success": bool(out["stopped"] and home["stopped"]), "status": "ok", "error": "", "legs": legs,
        "search_start_m": walked_home_m,
        "search_ratio": walked_home_m / outbound_true_m,
        "outbound_odometer_m": float(stored_m),
        "outbound_true_m": outbound_true_m,
        "stride_length_m": walked_home_m / cycles_home if cycles_home > 0 else float("nan"),
        "stride_length_believed_m": home["odometer"].distance_m / cycles_home if cycles_home > 0 else float("nan"),
        "trial_time_s": float(out["time_s"] + home["time_s"]),
        "real_time_factor": float((out["time_s"] + home["time_s"]) / (out["wall_s"] + home["wall_s"])),
    }
    log = {key: list(out["log"][key]) + list(home["log"][key]) for key in out["log"]}
    log["phase"] = [0.0] * len(out["log"]["time_s"]) + [1.0] * len(home["log"]["time_s"])
    log["position_m"].append(home["final_m"])
    return row, log


def pack_logs(logs: list[dict]) -> dict[str, np.ndarray]:
    """Per-cycle logs as NaN-padded arrays: ``time_s``, ``heading_rad``, ``phase`` (0 outbound, 1 homeward)
    (trials, cycles) and ``position_m`` (trials, cycles + 1, 2) with the search start last."""
    cycles = max(len(log["time_s"]) for log in logs)
    packed = {}
    for key in ("time_s", "heading_rad", "phase"):
        packed[key] = np.full((len(logs), cycles), np.nan)
        for i, log in enumerate(logs):
            packed[key][i, : len(log[key])] = np.asarray(log[key], float)
    packed["position_m"] = np.full((len(logs), cycles + 1, 2), np.nan)
    for i, log in enumerate(logs):
        packed["position_m"][i, : len(log["position_m"])] = np.asarray(log["position_m"], float)
    return packed


class Odometer(Scenario):
    """Wittlinger et al. 2006's stilts and stumps on every backend."""

    name = "odometer"
    description = ("the ant odometer: walk 10 m to a feeder on normal legs, home on stilts or stumps; where does "
                   "the ant start to search (Wittlinger et al. 2006)")
    config_type = OdometerConfig
    backends = EVERY_BACKEND
    default_backend = "kinematic"
    records_video = True
    timing_metrics = ("real_time_factor",)
    condition_columns = ("legs",)

    def smoke_config(self) -> dict:
        return {"channel_m": 1.0, "timeout_s": 10.0}

    def check(self, config: OdometerConfig, backend: str) -> None:
        leg_conditions(config)
        if backend != "kinematic":
            integer_ratio(CONTROL_S, config.timestep_s, "control step (8 ms) / timestep_s")

    def aggregate(self, trials: list[dict], config: OdometerConfig) -> dict:
        """Per leg condition (finished trials): the mean search start, its ratio to the outbound distance and
        the mean true and believed homeward stride."""
        present = [legs for legs in LEG_CONDITIONS if any(t.get("legs") == legs for t in trials)]
        return per_condition(trials, "legs", {
            "search_start_{}_m": mean_of("search_start_m"), "search_ratio_{}": mean_of("search_ratio"),
            "stride_length_{}_m": mean_of("stride_length_m"),
            "stride_length_believed_{}_m": mean_of("stride_length_believed_m"),
        }, labels={legs: legs for legs in present})

    def statistics(self, config: OdometerConfig) -> Statistics:
        """Each leg condition against normal legs (or the first listed): the search start, its ratio to the
        outbound distance, and the true and believed homeward stride (Mann-Whitney U)."""
        values = leg_conditions(config)
        return Statistics(condition="legs", reference="normal" if "normal" in values else values[0],
                          metrics=("search_start_m", "search_ratio", "stride_length_m", "stride_length_believed_m",
                                   "outbound_odometer_m"))

    def run(self, config: OdometerConfig, *, backend: str, trials: int, seed: int,
            video_path: Path | None = None) -> ScenarioResult:
        self.check(config, backend)
        rows, logs = trials_one_by_one(lambda s, video: odometer_trial(config, backend, s, video), trials, seed,
                                       video_path)
        timeseries = pack_logs(logs)
        world = {"nest_m": (0.0, 0.0), "feeder_m": (0.0, config.channel_m)}  # the channel's ends, every trial
        timeseries.update(pack_world([{k: np.array(v) for k, v in world.items()}] * trials))
        return ScenarioResult(trials=rows, timeseries=timeseries, aggregates=self.aggregate(rows, config),
                              simulated_time_s=float(np.mean([r["trial_time_s"] for r in rows])))

    def figures(self, result: ScenarioResult, config: OdometerConfig, out_dir: Path) -> list[Path]:
        from neuronav.scenarios.odometer.figures import write_odometer_figures

        return write_odometer_figures(result, config, Path(out_dir))
