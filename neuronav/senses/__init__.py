"""What an ant perceives, computed without a physics engine: the camera model and ray caster (vision),
the odour floor, trails, the filament plume and wind (chemistry), the sun and the polarised sky (sky).
Imports the base and :mod:`neuronav.spec` only."""
