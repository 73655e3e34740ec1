"""Wittlinger, Wehner & Wolf 2006's leg manipulations (Science 312:1965) on the desert-ant body.

At the feeder the ants' legs were changed and the ants walked home: ``stumps``, the legs cut in the
middle of the tibia (the distal tibia and the whole tarsus gone); ``stilts``, pig bristles glued on
to lengthen each leg; ``normal``, untouched. How each becomes this body's numbers (the sources, and
which numbers are our estimates) is in this folder's README.md, "Leg manipulations":

- ``normal``: the published legs.
- ``stumps``: per segment, as the paper cut them: tibia × 0.5, tarsus × ``TARSUS_STUB`` (gone but for a
  stub that carries the claw's contact sphere, the end of the stump). With its standing height
  re-solved as :func:`~neuronav.bodies.desert_ant.desert_ant` does by default the trunk would lie on
  the ground (0.075 m, less than the gaster's radius), so the standing height keeps the posture's
  proportions: 0.43 m × the mean ratio of the new to the old leg length (coxa to claw).
- ``stilts``: one factor on the whole leg, ``STILTS_FACTOR`` (our estimate). Lengthening only the
  distal segments, as a bristle does, makes this body's strides *shorter* on both engines (the legs
  reach down, not out, and the body rides higher): the opposite of what the ants did, so the whole
  leg is scaled.
"""

from __future__ import annotations

from neuronav.bodies.desert_ant.body import LEG_SEGMENTS, LEGS, STANDING_HEIGHT_M, desert_ant, leg_geometry
from neuronav.errors import ConfigError
from neuronav.spec.body import BodySpec

MANIPULATIONS = ("normal", "stilts", "stumps")
# Left of the tarsus after the cut: a stub 5 % of its length carries the claw (the stump's end).
TARSUS_STUB = 0.05
STUMPS_SEGMENT_FACTORS = {"tibia": 0.5, "tarsus": TARSUS_STUB}
# Our estimate of the bristles' effect (README.md, "Leg manipulations"): each leg 30 % longer.
STILTS_FACTOR = 1.3


def leg_length_ratio(segment_factors: dict[str, float]) -> float:
    """Mean over the legs of the normal ant of (coxa + femur + tibia + tarsus) after / before ``segment_factors``."""
    geometry = leg_geometry(desert_ant())
    ratios = []
    for leg in LEGS:
        lengths = {segment: geometry[leg][f"{segment}_m"] for segment in LEG_SEGMENTS}
        ratios.append(sum(v * segment_factors.get(k, 1.0) for k, v in lengths.items()) / sum(lengths.values()))
    return sum(ratios) / len(ratios)


def leg_manipulation(name: str, scale: float = 1.0) -> dict:
    """The :func:`~neuronav.bodies.desert_ant.desert_ant` keyword arguments of a manipulation.

    Parameters
    ----------
    name : {"normal", "stilts", "stumps"}
    scale : float
        The body's ``scale`` (the standing height of ``stumps`` follows it).

    Returns
    -------
    dict
        ``{}`` for ``normal``; ``leg_length_factors`` for ``stilts``; ``leg_segment_factors`` and
        ``standing_height_m`` for ``stumps``.
    """
    if name == "normal":
        return {}
    if name == "stilts":
        return {"leg_length_factors": STILTS_FACTOR}
    if name == "stumps":
        height_m = STANDING_HEIGHT_M * scale * leg_length_ratio(STUMPS_SEGMENT_FACTORS)
        return {"leg_segment_factors": dict(STUMPS_SEGMENT_FACTORS), "standing_height_m": height_m}
    raise ConfigError(f"unknown leg manipulation {name!r}; allowed: {', '.join(MANIPULATIONS)}")


def manipulated_ant(name: str, scale: float = 1.0, **options) -> BodySpec:
    """The desert ant with the legs of manipulation ``name`` (other ``desert_ant`` options passed on)."""
    kwargs = leg_manipulation(name, scale)
    clash = sorted(set(kwargs) & set(options))
    if clash:
        raise ConfigError(f"manipulated_ant({name!r}): {clash[0]!r} is set by the manipulation")
    return desert_ant(scale=scale, **kwargs, **options)
