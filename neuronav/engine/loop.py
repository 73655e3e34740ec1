"""The agent loop: a body on a backend, walked by a gait, steered by a brain, on three clocks.

Physics advances every ``physics_dt_s``; the gait produces joint targets every ``control_dt_s``;
the brain updates the locomotion command (``turn``, ``stride_rad``) every ``brain_dt_s``. The
ratios must be integers. Hooks, in the style of dm_control's composer, see the loop at
``initialize_episode``, ``before_step`` and ``after_step`` (one step = one control step), so
recording and perturbations stay out of the scenario's main logic.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from neuronav.errors import ConfigError
from neuronav.spec.body import Gait

# Fast steps per slow step at the most: beyond it one slow step would run for hours (a typo like
# timestep_s=1e-300 would otherwise hang the loop).
MAX_CLOCK_RATIO = 1_000_000


def integer_ratio(slow_s: float, fast_s: float, what: str) -> int:
    """``slow_s / fast_s`` as an int (1 to ``MAX_CLOCK_RATIO``), or a :class:`ConfigError` naming the two clocks."""
    if not (np.isfinite(fast_s) and np.isfinite(slow_s) and fast_s > 0 and slow_s > 0):
        raise ConfigError(f"{what}: clock periods must be positive and finite, got {slow_s} and {fast_s}")
    ratio = slow_s / fast_s
    if ratio > MAX_CLOCK_RATIO:
        raise ConfigError(f"{what}: {slow_s} s / {fast_s} s = {ratio:.3g} steps; at most {MAX_CLOCK_RATIO:,}")
    if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
        raise ConfigError(f"{what}: {slow_s} s is not an integer multiple of {fast_s} s")
    return int(round(ratio))


@dataclass(frozen=True)
class Clocks:
    """The loop's three periods (s); control is a multiple of physics, brain of control."""

    physics_dt_s: float = 0.002
    control_dt_s: float = 0.008
    brain_dt_s: float = 0.64

    def __post_init__(self) -> None:
        integer_ratio(self.control_dt_s, self.physics_dt_s, "control_dt_s / physics_dt_s")
        integer_ratio(self.brain_dt_s, self.control_dt_s, "brain_dt_s / control_dt_s")

    @property
    def physics_per_control(self) -> int:
        return integer_ratio(self.control_dt_s, self.physics_dt_s, "control_dt_s / physics_dt_s")

    @property
    def controls_per_brain(self) -> int:
        return integer_ratio(self.brain_dt_s, self.control_dt_s, "brain_dt_s / control_dt_s")


class Hook:
    """Something that watches or perturbs the loop; override what you need."""

    def initialize_episode(self, loop: AgentLoop) -> None:
        """After the backend and gait are reset."""

    def before_step(self, loop: AgentLoop) -> None:
        """Before each control step (after the brain, if it ran this step)."""

    def after_step(self, loop: AgentLoop) -> None:
        """After each control step's physics."""


# A brain for the loop: reads whatever it needs from loop.backend, returns (turn, stride_rad).
Steering = Callable[["AgentLoop"], tuple[float, float]]


class AgentLoop:
    """Run a body on a backend with a gait and (optionally) a brain that steers it.

    Parameters
    ----------
    backend : Backend
        Loaded with the world and the body.
    gait : Gait or None
        Turns (turn, stride_rad) into joint targets once per control step; None for a backend
        that takes the locomotion command (``turn``, ``stride``) directly (the kinematic unicycle).
    clocks : Clocks
    steering : callable, optional
        Called every brain period with the loop; returns the new (turn, stride_rad).
    hooks : sequence of Hook
    turn, stride_rad : float
        The command until the brain first speaks (or for good, without a brain).
    """

    def __init__(self, backend, gait: Gait | None, clocks: Clocks, steering: Steering | None = None,
                 hooks: Sequence[Hook] = (), turn: float = 0.0, stride_rad: float = np.radians(15)) -> None:
        self.backend, self.gait, self.clocks = backend, gait, clocks
        self.steering, self.hooks = steering, tuple(hooks)
        self.turn, self.stride_rad = float(turn), float(stride_rad)
        self.control_steps = 0
        self.gait_time_s = 0.0  # wall time spent computing gait samples

    def reset(self, **backend_reset) -> None:
        """Reset the backend (with these arguments) and the gait, then the hooks' episode start."""
        self.backend.reset(**backend_reset)
        if self.gait is not None:
            self.gait.reset()
        self.control_steps = 0
        self.gait_time_s = 0.0
        for hook in self.hooks:
            hook.initialize_episode(self)

    @property
    def time_s(self) -> float:
        return self.control_steps * self.clocks.control_dt_s

    def step(self) -> None:
        """One control step: maybe the brain, then the gait, then the physics steps."""
        if self.steering is not None and self.control_steps % self.clocks.controls_per_brain == 0:
            turn, stride = self.steering(self)
            self.turn, self.stride_rad = float(np.clip(turn, -1.0, 1.0)), float(max(stride, 0.0))
        for hook in self.hooks:
            hook.before_step(self)
        if self.gait is None:  # a point agent takes the locomotion command itself
            self.backend.write({"turn": np.array([[self.turn]]), "stride": np.array([[self.stride_rad]])})
        else:
            started = time.perf_counter()
            targets = self.gait.step(self.turn, self.stride_rad)
            self.gait_time_s += time.perf_counter() - started
            self.backend.write({"joint_targets": targets[None, :]})
        self.backend.step(self.clocks.physics_per_control)
        self.control_steps += 1
        for hook in self.hooks:
            hook.after_step(self)

    def run(self, duration_s: float, until: Callable[[AgentLoop], bool] | None = None) -> None:
        """Step for ``duration_s`` of simulated time, or until ``until(loop)`` is true."""
        for _ in range(int(round(duration_s / self.clocks.control_dt_s))):
            self.step()
            if until is not None and until(self):
                break
