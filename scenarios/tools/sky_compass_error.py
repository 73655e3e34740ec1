"""Measure the sky compass's heading error against the sun's elevation and the cloud cover.

No body and no engine: for every (sun elevation, cloud cover) pair, ``--headings`` agents (default 40),
each with a random heading, under a sun at a random azimuth (seeded; the sky is the same about any
vertical axis, so only heading − sun azimuth matters), read the sky through the dorsal rim
(:class:`neuronav.senses.dorsal_rim.DorsalRim`, level head, nothing occluding) into the sky compass
(:func:`neuronav.brains.sky_compass.sky_compass`, with its noise: 0.1 on SOL, CL1 and TB1, and
``--pol-noise`` on every POL cell); the compass runs 30 steps and TB1, averaged over the last 10,
is decoded (:func:`neuronav.brains.sky_compass.compass_errors_rad`). The error is the decoded
heading minus (heading − sun azimuth), wrapped, in degrees.

It prints one markdown table row per elevation: the mean and the 95th percentile of |error| for each
cloud cover, then the trend tests (scipy.stats): Spearman's rank correlation of |error| with the cloud
cover (all elevations pooled, and per elevation), and Kruskal-Wallis across elevations (clear sky); last,
the same error of Stone et al.'s compass fed the true heading, for comparison.
A few seconds of CPU with the defaults.

Usage::

    python -m neuronav.scenarios.tools.sky_compass_error [--elevations 0,10,...,80] [--covers 0,0.25,...]
        [--headings 40] [--seed 0] [--compass-gain 2] [--pol-noise 0.1] [--noise 0.1]
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy import stats

from neuronav.brains.cx import heading_circuit
from neuronav.brains.sky_compass import compass_errors_rad, decode_heading
from neuronav.errors import NeuronavError
from neuronav.senses.sky import Sky

DEFAULT_ELEVATIONS_DEG = (0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0)
DEFAULT_COVERS = (0.0, 0.25, 0.5, 0.75, 0.9, 1.0)


def measure(elevations_deg=DEFAULT_ELEVATIONS_DEG, covers=DEFAULT_COVERS, headings: int = 40, seed: int = 0,
            compass_gain: float = 2.0, noise: float = 0.1, pol_noise: float = 0.1) -> np.ndarray:
    """|error| (deg) of every agent: shape (len(elevations), len(covers), headings).

    Condition (i, j) draws its headings and sun azimuths, and seeds its compass's noise, from
    ``seed`` + the condition's index: the same arguments give the same numbers.
    """
    errors = np.empty((len(elevations_deg), len(covers), headings))
    for i, elevation in enumerate(elevations_deg):
        for j, cover in enumerate(covers):
            index = i * len(covers) + j
            rng = np.random.default_rng([seed, index])
            heading = rng.uniform(0.0, 2.0 * np.pi, headings)
            sky = Sky(sun_azimuth_rad=rng.uniform(0.0, 2.0 * np.pi), sun_elevation_rad=np.radians(elevation),
                      cloud_cover=cover)
            relative = compass_errors_rad(sky, heading, noise=noise, pol_noise=pol_noise, compass_gain=compass_gain,
                                          seed=int(rng.integers(2 ** 31)))
            errors[i, j] = np.degrees(np.abs(relative))
    return errors


def true_heading_errors(headings: int = 40, seed: int = 0, noise: float = 0.1, cells: int = 9) -> np.ndarray:
    """|error| (deg) of Stone et al.'s compass fed the true heading (``heading_circuit``), same noise and readout.

    ``cells`` x ``headings`` agents at random headings (as many as one column of the table); 30 steps, TB1
    averaged over the last 10.
    """
    rng = np.random.default_rng([seed, 10 ** 6])
    heading = rng.uniform(0.0, 2.0 * np.pi, headings * cells)
    brain = heading_circuit(noise).compile(batch=heading.size, seed=int(rng.integers(2 ** 31)))
    tb1 = np.zeros((heading.size, 8))
    for step in range(30):
        brain.step({"heading": heading[:, None]})
        if step >= 20:
            tb1 += brain.rates("TB1")
    return np.degrees(np.abs(np.angle(np.exp(1j * (decode_heading(tb1 / 10) - heading)))))


def report(errors: np.ndarray, elevations_deg, covers) -> str:
    """The markdown table and the trend tests, as printed."""
    header = "| sun elevation | " + " | ".join(f"cloud {c:g}: mean / 95th pct" for c in covers) + " |"
    lines = [header, "|---" * (len(covers) + 1) + "|"]
    for i, elevation in enumerate(elevations_deg):
        cells = [f"{errors[i, j].mean():.1f}° / {np.percentile(errors[i, j], 95):.1f}°" for j in range(len(covers))]
        lines.append(f"| {elevation:g}° | " + " | ".join(cells) + " |")
    n = errors.shape[2]
    lines.append("")
    lines.append(f"n = {n} agents per cell (random headings; one random sun azimuth per cell).")
    cover_of = np.broadcast_to(np.asarray(covers, float)[None, :, None], errors.shape)
    if len(covers) > 1:
        rho, p = stats.spearmanr(cover_of.ravel(), errors.ravel())
        lines.append(f"Spearman |error| vs cloud cover, all elevations pooled (n = {errors.size}): "
                     f"rho = {rho:.3f}, p = {p:.2g}")
        for i, elevation in enumerate(elevations_deg):
            rho, p = stats.spearmanr(cover_of[i].ravel(), errors[i].ravel())
            lines.append(f"  sun at {elevation:g}°: rho = {rho:.3f}, p = {p:.2g}")
    if len(elevations_deg) > 1:
        h, p = stats.kruskal(*[errors[i, 0] for i in range(len(elevations_deg))])
        lines.append(f"Kruskal-Wallis |error| across sun elevations, cloud {covers[0]:g}: H = {h:.1f}, p = {p:.2g}")
    return "\n".join(lines)


def _floats(text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected numbers separated by commas, got {text!r}") from None
    if not all(np.isfinite(values)):
        raise argparse.ArgumentTypeError(f"expected finite numbers separated by commas, got {text!r}")
    return values


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--elevations", type=_floats, default=DEFAULT_ELEVATIONS_DEG, metavar="E1,E2,...",
                        help="sun elevations (deg, 0-90)")
    parser.add_argument("--covers", type=_floats, default=DEFAULT_COVERS, metavar="C1,C2,...",
                        help="cloud covers (0-1)")
    parser.add_argument("--headings", type=int, default=40, help="agents per condition (>= 2), default 40")
    parser.add_argument("--seed", type=int, default=0, help="the seed (>= 0), default 0")
    parser.add_argument("--compass-gain", type=float, default=2.0, help="the compass gain (> 0), default 2")
    parser.add_argument("--noise", type=float, default=0.1, help="noise on SOL, CL1, TB1 (>= 0), default 0.1")
    parser.add_argument("--pol-noise", type=float, default=0.1, help="noise on each POL cell (>= 0), default 0.1")
    args = parser.parse_args(argv)
    if args.headings < 2 or args.seed < 0:
        parser.error("--headings must be >= 2 and --seed >= 0")
    try:
        errors = measure(args.elevations, args.covers, args.headings, args.seed, args.compass_gain, args.noise,
                         args.pol_noise)
    except NeuronavError as error:
        parser.exit(2, f"error: {error}\n")
    print(report(errors, args.elevations, args.covers))
    baseline = true_heading_errors(args.headings, args.seed, args.noise, len(args.elevations))
    print(f"For comparison, the compass fed the true heading (heading_circuit, noise {args.noise:g}, same readout, "
          f"n = {baseline.size}): mean {baseline.mean():.1f}° / 95th pct {np.percentile(baseline, 95):.1f}°")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
