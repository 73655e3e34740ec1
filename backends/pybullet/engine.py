"""The pybullet module, imported without its banner, and a catcher for what its C code prints."""

from __future__ import annotations

import os
import sys
import tempfile


def _import_quietly():
    """Import pybullet without the build-time banner it prints from C at import."""
    import ctypes
    import sys

    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    try:
        with open(os.devnull, "wb") as devnull:
            os.dup2(devnull.fileno(), 1)
            os.dup2(devnull.fileno(), 2)
            import pybullet  # an ImportError is an exception, not a message: nothing is lost

            ctypes.CDLL(None).fflush(None)  # empty C's buffers while they still point at /dev/null
    finally:
        for fd, copy in zip((1, 2), saved):
            os.dup2(copy, fd)
            os.close(copy)
    return pybullet


pb = _import_quietly()


class EngineOutput:
    """Collect what PyBullet's C code prints (``b3Warning`` ...) during a call into a warnings list."""

    def __init__(self, warnings: list[str]) -> None:
        self._warnings = warnings

    def __enter__(self):
        sys.stdout.flush()
        sys.stderr.flush()
        self._file = tempfile.TemporaryFile(mode="w+b")
        self._saved = [os.dup(1), os.dup(2)]
        os.dup2(self._file.fileno(), 1)
        os.dup2(self._file.fileno(), 2)
        return self

    def __exit__(self, *exc: object) -> None:
        os.dup2(self._saved[0], 1)
        os.dup2(self._saved[1], 2)
        for fd in self._saved:
            os.close(fd)
        self._file.seek(0)
        text = self._file.read().decode(errors="replace")
        self._file.close()
        lines = [line.strip() for line in text.splitlines() if line.strip()]
        # b3Warning lines name the source file; the message is on the next line.
        messages = [f"pybullet: {line}" for line in lines if not line.startswith("b3Warning[")]
        for message in messages:
            if message not in self._warnings:
                self._warnings.append(message)


def configure_client(client: int, timestep_s: float, substeps: int, solver_iterations: int,
                     gravity_m_s2: float) -> None:
    """Reset a physics client and set what every neuronav simulation in it uses: gravity, ``substeps``
    fixed inner steps per ``timestep_s``, the solver's iterations, deterministic contact pairs, no
    real-time stepping."""
    pb.resetSimulation(physicsClientId=client)
    pb.setGravity(0.0, 0.0, gravity_m_s2, physicsClientId=client)
    inner = timestep_s / substeps
    pb.setTimeStep(inner, physicsClientId=client)
    pb.setPhysicsEngineParameter(fixedTimeStep=inner, numSubSteps=0, numSolverIterations=solver_iterations,
                                 deterministicOverlappingPairs=1, physicsClientId=client)
    pb.setRealTimeSimulation(0, physicsClientId=client)
