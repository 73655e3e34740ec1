"""What an ant perceives, computed without a physics engine: the camera model and ray caster (vision),
the odour floor, trails, the filament plume and wind (chemistry). Imports the base and
:mod:`neuronav.spec` only."""
