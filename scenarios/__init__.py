"""The experiments: world + body + brain + protocol + metrics + figures, registered by id.

The backend names the scenarios accept are listed here once (a scenario's ``backends``), so a new
physics backend is added to every scenario that carries the ant in one place.
"""

PHYSICS_BACKENDS = ("mujoco", "dm_control", "pybullet")
"""The articulated physics backends that carry the ant body (dm_control steps MuJoCo's model)."""
EVERY_BACKEND = ("kinematic", *PHYSICS_BACKENDS)
"""The physics backends and the kinematic one (scenarios whose brains also drive a point agent)."""
