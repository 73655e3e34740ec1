"""The desert ant's unicycle calibration: how fast the FK tripod walks and turns for each (turn, stride).

Measured on MuJoCo by ``python -m neuronav.scenarios.tools.calibrate_unicycle --write-package-table``
(the ant on flat ground, 3 s per grid point; provenance in this folder's README.md) and shipped beside
the body as ``unicycle_mujoco.json``. Registered as ``desert_ant`` under the entry-point group
``neuronav.unicycle_calibrations``: the kinematic backend's unicycle reads it by that name.
"""

from __future__ import annotations

from pathlib import Path

from neuronav.spec.unicycle import UnicycleCalibration, load_calibration

# The body's folder, where its calibration tables live (one per engine that measured it).
DATA_DIR = Path(__file__).resolve().parent
# The engine whose table the ant's unicycle walks by.
MEASURED_ON = "mujoco"


def table_path(engine: str = MEASURED_ON) -> Path:
    """Where the table measured on ``engine`` is kept: ``unicycle_<engine>.json`` in this folder."""
    return DATA_DIR / f"unicycle_{engine}.json"


def unicycle_calibration() -> UnicycleCalibration:
    """The desert ant's unicycle calibration, measured on MuJoCo (a ConfigError if the table cannot be read)."""
    return load_calibration(table_path())
