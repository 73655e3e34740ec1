"""What an agent of the learning environments observes: engine-free, batched, one definition for every env.

The single Gymnasium environment (:mod:`neuronav.scenarios.envs.gym_env`), the native vector environment
and the dm_env tasks read a backend's raw sensors (the *state*) and turn them into observations here, so
they observe the same thing on every backend. Every function works on a batch: each state array has a
leading axis of N agents, each observation too.

- :func:`observation_space` (task, sensors, ...) -> ``gymnasium.spaces.Dict`` of one agent's observations;
- :func:`state_ports` (task, space, ...) -> the backend sensors to read for them (and for the reward);
- :func:`observe` (task, state, space) -> ``{name: (N, *space[name].shape) array of space[name].dtype}``;
- :func:`check_actions` (actions, low, high, ...) -> the actions as (N, A) floats, clipped to [low, high]
  (:data:`ACTION_RULE`), or a :class:`~neuronav.errors.PortError`;
- :func:`fallen` (state, max_tilt_deg) -> (N,) bool, the fall rule (:data:`FALL_RULE`).

Observations (frames: *world* = x east, y north, z up; *body* = (forward, left) in the ground plane;
heading h is clockwise from +y, so the body's forward axis in the world is (sin h, cos h)):

=================  ============  ===================  =======================================================
observation        shape         units, bounds        what, frame
=================  ============  ===================  =======================================================
``heading``        (2,)          [-1, 1]              (sin h, cos h): the forward axis in world (x, y)
``velocity_body``  (2,)          m/s, unbounded       the root's ground velocity, body frame (forward, left)
``home_vector``    (2,)          m, unbounded         homing: the nest from the root, body frame (forward, left)
``eye_L/eye_R``    (19, 74, 1)   uint8 [0, 255]       beacon: grey image (255 = white), channel-last
``panorama``       (72, 72, 1)   uint8 [0, 255]       ``panorama=True``: the head's spherical camera, grey
``compound_eye*``  (M, 2)        [0, 1]               ``compound_eyes=True``: (green, UV) per ommatidium
``odour``          (O, K)        amount/m^3, >= 0     plume: concentration of each odour at each antenna tip
``wind``           (W, 2)        m/s, unbounded       plume: wind at each antenna tip, world (x, y)
``joint_pos``      (J,)          rad, joint ranges    ``proprioception``: joint angles, clipped to each range
``joint_vel``      (J,)          rad/s, ±100          ``proprioception``: joint velocities, clipped
``contact_force``  (C, 3)        N, ±1000             ``proprioception``: force on each contact site, world
``body_up``        (3,)          [-1, 1]              ``proprioception``: the root's up axis in world (x, y, z)
=================  ============  ===================  =======================================================

Proprioception is observed in ``action_mode="joints"`` by default and in ``"locomotion"`` on request
(``proprioception=True``; physics backends only: the kinematic unicycle has no joints). Its
bounds: each joint's range (MuJoCo's soft limits let a joint pass it by a little: the observation
is clipped), :data:`JOINT_VEL_LIMIT_RAD_S` (PyBullet's velocity clamp) and
:data:`CONTACT_FORCE_LIMIT_N` (about 8 body weights of the 12.2 kg desert ant), clipped likewise.
``body_up`` with ``heading`` gives the body's orientation (tilt and yaw).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from gymnasium import spaces

from neuronav.errors import ConfigError, PortError
from neuronav.spec.ports import SensorSpec

# Observations clipped to these bounds (documented in the module docstring).
JOINT_VEL_LIMIT_RAD_S = 100.0
CONTACT_FORCE_LIMIT_N = 1000.0
# The fall rule: the root's up axis more than this far from vertical.
FALL_TILT_DEG = 60.0
FALL_RULE = ("fell: the root's up axis tilts more than max_tilt_deg (default 60°) from vertical, i.e. its world z "
             "component is below cos(max_tilt_deg); the episode is terminated (not a success)")
ACTION_RULE = ("finite actions outside the action box are clipped to it; an action of another shape, not finite, "
               "or not real numbers (a string, a dict, complex) is a PortError")
# Raw backend sensor -> observation name, where they differ.
RENAMED = {"heading": "heading", "velocity": "velocity_body", "body_quat": "body_up"}
PROPRIOCEPTION = ("joint_pos", "joint_vel", "contact_force", "body_quat")
IMAGE_UNITS = "grey [0, 1]"
COMPOUND_EYE_PREFIX = "compound_eye"  # the sensors of compound eyes: (M, 2) green and UV in [0, 1]
# Bounds of sensors whose spec has no range, by their units.
UNIT_BOUNDS = {"amount/m^3": (0.0, np.inf)}


def _box(low, high, shape: tuple[int, ...], dtype=np.float32) -> spaces.Box:
    return spaces.Box(low=np.asarray(low, dtype=dtype) if np.ndim(low) else dtype(low),
                      high=np.asarray(high, dtype=dtype) if np.ndim(high) else dtype(high), shape=shape, dtype=dtype)


def _raw_ports(task, sensors: Mapping[str, SensorSpec], proprioception: bool, panorama: bool,
               compound_eyes: bool) -> tuple[str, ...]:
    ports = [p for p in task.observation_ports]
    if panorama:
        ports.append("panorama")
    if compound_eyes:
        eyes = sorted(name for name in sensors if name.startswith(COMPOUND_EYE_PREFIX))
        if not eyes:
            raise ConfigError("compound_eyes=True: this backend's body carries no compound eyes (no sensor named "
                              f"{COMPOUND_EYE_PREFIX}*; it has: {', '.join(sorted(sensors))})")
        ports += [eye for eye in eyes if eye not in ports]
    if proprioception:
        ports += [p for p in PROPRIOCEPTION if p not in ports]
    return tuple(ports)


def observation_space(task, sensors: Mapping[str, SensorSpec], *, action_mode: str = "locomotion",
                      proprioception: bool | None = None, panorama: bool = False, compound_eyes: bool = False,
                      joint_ranges_rad: np.ndarray | None = None) -> spaces.Dict:
    """One agent's observation space (see the module docstring's table).

    Parameters
    ----------
    task : NavigationTask
        Which ports it observes (``task.observation_ports``) and computes (``task.task_sensors``).
    sensors : dict
        The backend's sensors by name (``{s.name: s for s in backend.capabilities.sensors}``): shapes.
    action_mode : {"locomotion", "joints"}
        ``"joints"`` observes the proprioception unless ``proprioception=False``.
    proprioception : bool, optional
        Add ``joint_pos``, ``joint_vel``, ``contact_force``, ``body_up``; default: in joints mode only.
    panorama : bool
        Add the head's panoramic camera as ``panorama`` (H, W, 1) uint8.
    compound_eyes : bool
        Add every compound eye the body carries (sensors ``compound_eye*``: (M, 2) green and UV in [0, 1]).
    joint_ranges_rad : (J, 2) array, optional
        Each joint's (low, high): the bounds of ``joint_pos`` (needed with proprioception).

    Raises
    ------
    ConfigError
        A port the backend does not carry (the kinematic backend with proprioception; a body without a
        panorama), or proprioception without the joint ranges.
    """
    if proprioception is None:
        proprioception = action_mode == "joints"
    boxes: dict[str, spaces.Box] = {}
    for port in _raw_ports(task, sensors, bool(proprioception), bool(panorama), bool(compound_eyes)):
        if port not in sensors:
            what = "proprioception" if port in PROPRIOCEPTION else ("panorama" if port == "panorama" else port)
            raise ConfigError(f"observation {what!r} needs the backend sensor {port!r}, which this backend does not "
                              f"carry (it has: {', '.join(sorted(sensors))})"
                              + ("; proprioception needs a physics backend" if port in PROPRIOCEPTION else ""))
        spec = sensors[port]
        name = RENAMED.get(port, port)
        if port == "heading":
            boxes[name] = _box(-1.0, 1.0, (2,))
        elif port == "velocity":
            boxes[name] = _box(-np.inf, np.inf, (2,))
        elif port == "body_quat":
            boxes[name] = _box(-1.0, 1.0, (3,))
        elif port == "joint_pos":
            if joint_ranges_rad is None:
                raise ConfigError("proprioception needs joint_ranges_rad (J, 2): the bounds of joint_pos")
            ranges = np.asarray(joint_ranges_rad, dtype=np.float32).reshape(-1, 2)
            if ranges.shape[0] != spec.shape[0]:
                raise ConfigError(f"joint_ranges_rad has {ranges.shape[0]} joints, the backend's joint_pos "
                                  f"{spec.shape[0]}")
            boxes[name] = _box(ranges[:, 0], ranges[:, 1], tuple(spec.shape))
        elif port == "joint_vel":
            boxes[name] = _box(-JOINT_VEL_LIMIT_RAD_S, JOINT_VEL_LIMIT_RAD_S, tuple(spec.shape))
        elif port == "contact_force":
            boxes[name] = _box(-CONTACT_FORCE_LIMIT_N, CONTACT_FORCE_LIMIT_N, tuple(spec.shape))
        elif spec.units == IMAGE_UNITS:
            boxes[name] = spaces.Box(0, 255, (*spec.shape, 1), np.uint8)
        elif port.startswith(COMPOUND_EYE_PREFIX):
            boxes[name] = _box(0.0, 1.0, tuple(spec.shape))
        else:
            low, high = spec.range if spec.range is not None else UNIT_BOUNDS.get(spec.units, (-np.inf, np.inf))
            boxes[name] = _box(low, high, tuple(spec.shape))
    for spec in task.task_sensors:
        low, high = spec.range if spec.range is not None else (-np.inf, np.inf)
        boxes[spec.name] = _box(low, high, tuple(spec.shape))
    return spaces.Dict(boxes)


def state_ports(task, space: spaces.Dict, *, physics: bool = False) -> tuple[str, ...]:
    """The backend sensors to read for ``space``'s observations, the task's reward and termination
    (``task.state_ports``) and, on a ``physics`` backend, the fall rule (``body_quat``)."""
    inverse = {observed: port for port, observed in RENAMED.items()}
    ports = list(task.state_ports)
    for name in space.spaces:
        port = inverse.get(name, name)
        if port not in ports and name not in {s.name for s in task.task_sensors}:
            ports.append(port)
    if physics and "body_quat" not in ports:
        ports.append("body_quat")
    return tuple(ports)


def up_vector(body_quat: np.ndarray) -> np.ndarray:
    """The root's up axis (N, 3) in world (x, y, z) from its rotation (N, 4) (w, x, y, z)."""
    w, x, y, z = np.moveaxis(np.asarray(body_quat, dtype=float), -1, 0)
    return np.stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)], axis=-1)


def heading_sin_cos(heading_rad: np.ndarray) -> np.ndarray:
    """(N, 2) (sin h, cos h) of headings (N, 1) or (N,): bounded, the same whatever the wrapping."""
    h = np.asarray(heading_rad, dtype=float).reshape(len(heading_rad), -1)[:, 0]
    return np.stack([np.sin(h), np.cos(h)], axis=-1)


def body_frame(vectors_xy: np.ndarray, heading_rad: np.ndarray) -> np.ndarray:
    """World (x, y) vectors (N, 2) in the body frame (forward, left) of headings (N, 1) or (N,)."""
    h = np.asarray(heading_rad, dtype=float).reshape(len(vectors_xy), -1)[:, 0]
    v = np.asarray(vectors_xy, dtype=float)
    forward = v[:, 0] * np.sin(h) + v[:, 1] * np.cos(h)
    left = -v[:, 0] * np.cos(h) + v[:, 1] * np.sin(h)
    return np.stack([forward, left], axis=-1)


def observe(task, state: Mapping[str, np.ndarray], space: spaces.Dict) -> dict[str, np.ndarray]:
    """Every observation of ``space`` for a batch: ``{name: (N, *shape) array of the space's dtype}``.

    ``state``: the backend's readings of :func:`state_ports` with their leading batch axis (N, ...);
    the task's own observations come from ``task.observe(state)`` (batched). Grey images become uint8
    (round(255 g)) with a channel axis; bounded observations are clipped to their box.
    """
    computed = None
    out = {}
    for name, box in space.spaces.items():
        if name == "heading":
            value = heading_sin_cos(state["heading"])
        elif name == "velocity_body":
            value = body_frame(state["velocity"], state["heading"])
        elif name == "body_up":
            value = up_vector(state["body_quat"])
        elif name in state:
            value = np.asarray(state[name])
        else:
            if computed is None:
                computed = task.observe(state)
            value = np.asarray(computed[name])
        n = len(value)
        if box.dtype == np.uint8:
            value = np.rint(np.clip(value, 0.0, 1.0) * 255.0).astype(np.uint8).reshape(n, *box.shape)
        else:
            value = value.reshape(n, *box.shape)
            if np.isfinite(box.low).any() or np.isfinite(box.high).any():
                value = np.clip(value, box.low, box.high)
            value = value.astype(box.dtype)
        out[name] = value
    return out


def check_actions(actions, low: np.ndarray, high: np.ndarray, names: str = "", count: int | None = None) -> np.ndarray:
    """Actions (N, A) (or one action (A,) as N = 1) as float, clipped to [low, high] (:data:`ACTION_RULE`);
    ``count``: the N required (None: any).

    Raises
    ------
    PortError
        Not real numbers (strings, dicts, complex, objects), another shape, or not finite.
    """
    low, high = np.asarray(low, float), np.asarray(high, float)
    size = low.size
    expected = f"{size} finite real numbers" + (f" ({names})" if names else "") + (
        f" for each of {count} agents" if count not in (None, 1) else "")
    try:
        array = np.asarray(actions)
    except (TypeError, ValueError):  # ragged sequences
        array = np.asarray(None)
    if array.dtype.kind not in "biuf":
        raise PortError(f"action must be {expected}; got {type(actions).__name__} {actions!r:.200}")
    array = array.astype(float)
    if array.ndim == 1:
        array = array[None, :]
    if array.ndim != 2 or array.shape[1] != size or not np.isfinite(array).all() or (
            count is not None and array.shape[0] != count):
        raise PortError(f"action must be {expected}, within [{', '.join(f'{v:.4g}' for v in low[:4])}"
                        f"{', ...' if size > 4 else ''}] .. [{', '.join(f'{v:.4g}' for v in high[:4])}"
                        f"{', ...' if size > 4 else ''}] (outside: clipped); got {actions!r:.200}")
    return np.clip(array, low, high)


def fallen(state: Mapping[str, np.ndarray], max_tilt_deg: float | None = FALL_TILT_DEG) -> np.ndarray:
    """(N,) bool: the agents that fell by :data:`FALL_RULE` (all False without ``body_quat`` in the state,
    e.g. on the kinematic backend, or with ``max_tilt_deg=None``: no fall rule)."""
    if max_tilt_deg is None or "body_quat" not in state:
        n = len(next(iter(state.values()))) if state else 0
        return np.zeros(n, dtype=bool)
    return up_vector(state["body_quat"])[:, 2] < np.cos(np.radians(max_tilt_deg))
