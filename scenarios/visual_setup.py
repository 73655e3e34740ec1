"""What the embodied sensory scenarios share: the ant's cameras and antennae on a point agent, and
the bodies per backend.

The kinematic backend's unicycle carries the ant's own cameras, placed where they sit on the ant
standing at rest (:func:`point_agent_cameras`), and its antennae, tips at the ant's odour sites
(:func:`neuronav.bodies.antennae.point_antennae`), so the same eyes look at the same world and the same
antennae smell the same odour on all three backends.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from neuronav import registry
from neuronav.bodies.antennae import point_antennae
from neuronav.bodies.desert_ant import desert_ant
from neuronav.bodies.desert_ant.body import point_agent_compound_eyes
from neuronav.bodies.gaits import make_gait, segment_pose
from neuronav.spec.body import BodySpec, Camera, quat_to_matrix
from neuronav.spec.world import PointAgents

CONTROL_S = 0.008
CYCLE_S = 0.64


def matrix_to_quat(rotation: np.ndarray) -> tuple[float, float, float, float]:
    """A rotation matrix (3, 3) as a unit quaternion (w, x, y, z) with w >= 0."""
    m = np.asarray(rotation, float)
    w = np.sqrt(max(0.0, 1.0 + m[0, 0] + m[1, 1] + m[2, 2])) / 2.0
    x = np.copysign(np.sqrt(max(0.0, 1.0 + m[0, 0] - m[1, 1] - m[2, 2])) / 2.0, m[2, 1] - m[1, 2])
    y = np.copysign(np.sqrt(max(0.0, 1.0 - m[0, 0] + m[1, 1] - m[2, 2])) / 2.0, m[0, 2] - m[2, 0])
    z = np.copysign(np.sqrt(max(0.0, 1.0 - m[0, 0] - m[1, 1] + m[2, 2])) / 2.0, m[1, 0] - m[0, 1])
    quat = np.array([w, x, y, z])
    quat /= np.linalg.norm(quat)
    return tuple(float(v) for v in quat)


def point_agent_cameras(body: BodySpec) -> tuple[Camera, ...]:
    """The body's cameras placed in a point agent's frame as they sit on the body at rest.

    The root frame (x forward, y left, z up) stands ``spawn_height_m`` above the ground, level,
    every joint at its rest angle: a camera's position and orientation in the agent's frame (origin
    on the ground under the root) follow by forward kinematics of the spec.
    """
    cameras = []
    for camera in body.cameras:
        rotation, position = segment_pose(body, camera.segment, {})
        eye = position + rotation @ np.asarray(camera.pos_m, float) + np.array([0.0, 0.0, body.spawn_height_m])
        frame = rotation @ quat_to_matrix(camera.quat)
        cameras.append(replace(camera, pos_m=tuple(float(v) for v in eye), quat=matrix_to_quat(frame)))
    return tuple(cameras)


def make_engine(backend_name: str, timestep_s: float, **ant_options):
    """(engine, body, gait, physics step) of one trial: the ant (``desert_ant(**ant_options)``, e.g.
    ``antenna_length_m``, ``compound_eyes=True``) on a physics backend, or the kinematic unicycle carrying
    the ant's cameras (rendered only when read), compound eyes (when it has them) and antennae."""
    engine_class = registry.load("backend", backend_name)
    ant = desert_ant(**ant_options)
    if backend_name == "kinematic":
        body = PointAgents(count=1, mode="unicycle", cameras=point_agent_cameras(ant), antennae=point_antennae(ant),
                           compound_eyes=point_agent_compound_eyes(ant))
        return engine_class(timestep_s=CONTROL_S), body, None, CONTROL_S
    return engine_class(timestep_s=timestep_s), ant, make_gait("tripod", ant), timestep_s
