"""Settings that mean the same in several scenarios, each defined once: default, help text and range.

Each function returns a config field (:func:`neuronav.config.field`) for a scenario's config
dataclass, e.g. ``timestep_s: float = settings.timestep_field()``. A scenario whose setting of the
same name means something else (another default, range or help) keeps its own field.

The embodied-homing fields are shared by path integration's ``i2bot`` protocol and swarm homing, which
takes embodied homing's CX and foraging defaults. Path integration's config also holds the point
agents' settings, so there the help texts start with the protocol (``protocol="i2bot"``: ``"i2bot: "``).

Settings that take one value or a comma list of them (conditions cycled over trials by seed) are read by
:func:`choice_list` (names) and :func:`number_list` (numbers), with one wording for what they refuse.
"""

from __future__ import annotations

import numpy as np

from neuronav.config import field
from neuronav.errors import ConfigError


def choice_list(setting: str, text, allowed: tuple[str, ...], repeats: bool = True) -> tuple[str, ...]:
    """The names in ``text``: one of ``allowed`` or a comma list of them (``repeats=False``: each at most once).

    Raises
    ------
    ConfigError
        A name not in ``allowed`` (or a repeat), naming ``setting`` and what it takes.
    """
    values = tuple(v.strip() for v in str(text).split(","))
    repeated = not repeats and len(set(values)) != len(values)
    if any(v not in allowed for v in values) or repeated:
        names = ", ".join(allowed[:-1]) + " or " + allowed[-1] if len(allowed) > 1 else allowed[0]
        once = "" if repeats else " without repeats"
        raise ConfigError(f"{setting}: expected {names}, or a comma list of them{once}, got {text!r}")
    return values


def number_list(setting: str, text, low: float, high: float, unit: str, what: str) -> tuple[float, ...]:
    """The numbers in ``text``: one, or a comma list, each finite within [``low``, ``high``] (``unit``).

    Raises
    ------
    ConfigError
        Not numbers, or one out of range, naming ``setting``, the range and the unit; ``what`` names one value
        ("angle", "offset").
    """
    span = f"{low:g}–{high:g}" if low >= 0 else f"{low:g} to {high:g}"
    try:
        values = tuple(float(v) for v in str(text).split(","))
    except ValueError:
        raise ConfigError(f"{setting}: expected an {what} or a comma list of them in {unit} ({span}), "
                          f"got {text!r}") from None
    if not all(np.isfinite(v) and low <= v <= high for v in values):
        raise ConfigError(f"{setting}: every {what} must be within {span} {unit}, got {text!r}")
    return values


def _help(text: str, protocol: str) -> str:
    """``text``, after ``"<protocol>: "`` when the setting belongs to one protocol of its scenario."""
    return f"{protocol}: {text}" if protocol else text


# -- the embodied sensory scenarios (one body, or point agents carrying its cameras and antennae) ----
# Their clocks are read where a field is made, so the embodied-homing scenarios, which take neither,
# do not load the sensory scenarios' bodies and gaits.

def timestep_field():
    """``timestep_s``: the physics step of the body, at most one 8 ms control step (s)."""
    from neuronav.scenarios.visual_setup import CONTROL_S

    return field(0.002, "physics step of the body (s); the kinematic unicycle steps every 8 ms", min=1e-4,
                 max=CONTROL_S)


def trial_timeout_field(default_s: float, sense: str):
    """``timeout_s``: a trial's time limit (s), at least one gait cycle, so that the brain reads its
    ``sense`` (``"look"``, ``"sniff"``) at least once."""
    from neuronav.scenarios.visual_setup import CYCLE_S

    return field(default_s, f"a trial gives up after this long (s): at least one gait cycle, one {sense}",
                 min=CYCLE_S, max=3600.0)


# -- embodied homing: foraging walk, then the CX steers home -------------------------------------------

def outbound_field(protocol: str = ""):
    """``outbound_s``: foraging time (s)."""
    return field(32.0, _help("foraging time (s)", protocol), min_exclusive=0.0, max=3600.0)


def homing_timeout_field(protocol: str = ""):
    """``homing_timeout_s``: the homing phase's time limit (s)."""
    return field(90.0, _help("homing gives up after this long (s)", protocol), min_exclusive=0.0, max=3600.0)


def nest_radius_field(help: str):
    """``nest_radius_m``: homing succeeds within this distance of the nest (m); each scenario says it in
    its own words (``help``)."""
    return field(0.67, help, min_exclusive=0.0, max=100.0)


def homing_gain_field(protocol: str = ""):
    """``k_pi``: eq. 3.6's steering gain on the CPU1 imbalance."""
    return field(5.0, _help("turn = k_PI (sum CPU1 left - sum CPU1 right) (eq. 3.6)", protocol),
                 min_exclusive=0.0, max=1000.0)


def cx_noise_field(protocol: str = ""):
    """The CX's rate noise (``noise``, path integration's ``embodied_noise``)."""
    return field(0.0008, _help("CX rate noise (the paper's code)", protocol), min=0.0, max=1.0)


def cpu4_gain_field(protocol: str = ""):
    """The CPU4 integration gain per gait cycle (``memory_gain``, path integration's ``embodied_memory_gain``)."""
    return field(0.04, _help("CPU4 gain per gait cycle (the paper's code)", protocol), min_exclusive=0.0,
                 max=1.0)


def cpu4_leak_field():
    """``memory_leak``: CPU4's leak factor k (Stone et al. 2017), for point agents and bodies alike."""
    return field(0.125, "CPU4 leak factor k (memory loses h*k per step)", min=0.0, max=1.0)


def foraging_turn_field(help: str):
    """``foraging_turn_std``: the std of the random foraging turn command per gait cycle; each scenario
    says it in its own words (``help``)."""
    return field(0.35, help, min=0.0, max=10.0)


def foraging_stride_field(protocol: str = ""):
    """``foraging_stride_deg``: the hip swing while foraging (deg)."""
    return field(15.0, _help("hip swing while foraging (deg)", protocol), min=0.0, max=40.0)


# -- embodied homing's trial-to-trial variability (with ``variability=on``; see scenarios/variability.py) --
# Each source is drawn per gait cycle from the trial's own generator (one stream per source), so a
# path-integration trial and a swarm ant of the same seed read the same noise. Motor noise: path-integration,
# swarm-homing and locomotion use neuronav.scenarios.motor_noise (turn_noise_sd, stride_noise_fraction);
# the turn_noise and stride_noise_deg fields below are odour-trail's and plume-tracking's.

def compass_noise_field(protocol: str = ""):
    """``compass_noise_deg``: std of the Gaussian error on the heading the CX reads each gait cycle (deg)."""
    return field(3.0, _help("std of the error on the heading the CX reads each gait cycle (deg; variability=on)",
                            protocol), min=0.0, max=180.0)


def odometry_noise_field(protocol: str = ""):
    """``odometry_noise_fraction``: std of the relative error on the displacement the CX reads each gait cycle."""
    return field(0.05, _help("std of the relative error on the displacement the CX reads each gait cycle "
                             "(fraction; variability=on)", protocol), min=0.0, max=1.0)
