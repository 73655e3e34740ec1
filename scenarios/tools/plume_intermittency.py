"""Measure the filament plume's intermittency: how often, and for how long, the odour is above threshold.

A turbulent odour plume reaches a fixed sensor as *whiffs* (odour above the detection threshold)
separated by *blanks* (below it). This command builds the plume of :mod:`neuronav.senses.plume` (no
engine, no body), lets it run for ``warmup_s``, then reads the odour at fixed points every plume step
(``plume_dt_s``, 0.01 s by default) for ``--duration-s`` seconds: along the plume's axis (``--downwind``,
metres downwind of the source) and across it (``--crosswind``, metres from the axis), i.e. at
``(source_x_m + downwind, crosswind)``. For each point it prints

- the *intermittency*: the fraction of samples with odour above ``threshold`` (1: the odour never
  leaves; 0: it never comes);
- the whiffs per second, and the mean and median whiff and blank durations (s). Only whole whiffs
  and blanks count: a run of samples that touches the start or the end of the record is cut off by
  it, so it is left out (a record with odour throughout has no whole blank, and no whole whiff);

each as the mean ± standard deviation over ``--seeds`` seeds (``--seed``, ``--seed`` + 1, ...), one record
per seed; "(n=k)" marks a statistic that only k seeds' records had. Each seed is a separate plume; the
same seeds give the same numbers. It needs no engine and takes a few seconds (5 seeds of 60 s: 3-5 s
of CPU).

The settings (``--set KEY=VALUE``, as for ``neuronav run``) are the plume-tracking scenario's plume
(:func:`neuronav.scenarios.plume_tracking.scenario.plume_config`): one source at ``(source_x_m, 0)``,
the wind along +x, Farrell et al. 2002's model; the defaults are the scenario's (since issue 22: 3e-7
units of odour per puff, 10 puffs/s, threshold 1e-6, wind 2 m/s, wind noise gain 0.4, puff spread
0.2 m/√s). With them (``--downwind 1,2,4,6.5``) the odour on the plume's axis is above threshold 30,
26, 22 and 19 % of the time 1, 2, 4 and 6.5 m downwind (5 seeds of 60 s, measured 2026-11-27), against
the 25-20 % that Murlis & Jones (1981) measured on the axis 2-15 m from a source in the field (as cited
by Rando et al., eLife, article 102906). The plume before issue 22 (``--set release_rate_hz=60 --set
puff_amount=1 --set wind_gain=0.2``) is above threshold 93-100 % of the time from 1 to 6.5 m downwind.

Usage::

    python -m neuronav.scenarios.tools.plume_intermittency [--set KEY=VALUE ...] [--seed N] [--seeds K]
        [--duration-s S] [--downwind 1,2,4,6] [--crosswind 0,0.25,0.5,-0.25,-0.5]
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np

from neuronav.config import apply_overrides, field
from neuronav.errors import ConfigError, NeuronavError
from neuronav.senses.plume import OdourSource, Plume, PlumeConfig, WindConfig

# The arena of the plume-tracking scenario (x in [0, 8] m, y in [-2, 2] m).
ARENA_X_M, ARENA_Y_M = (0.0, 8.0), (-2.0, 2.0)
DEFAULT_DOWNWIND_M = (1.0, 2.0, 4.0, 6.0)
DEFAULT_CROSSWIND_M = (0.0, 0.25, 0.5, -0.25, -0.5)
# The statistics of one record, in the order they are printed.
STATISTICS = ("intermittency", "whiffs_per_s", "whiff_mean_s", "whiff_median_s", "blank_mean_s", "blank_median_s")


@dataclass
class IntermittencyConfig:
    """The plume measured: the scenario's source, wind and threshold, and the model's constants."""

    puff_amount: float = field(3e-7, "Q, the odour carried by one puff (amount)", min_exclusive=0.0, max=1e9)
    release_rate_hz: float = field(10.0, "puffs released per second at the source", min_exclusive=0.0, max=1e4)
    threshold: float = field(1e-6, "detection threshold (amount/m^3): odour above it is a whiff",
                             min_exclusive=0.0, max=1e6)
    wind_mps: float = field(2.0, "mean wind speed along +x (m/s)", min=0.5, max=5.0)
    wind_gain: float = field(0.4, "G, the gain of the wind's coloured noise: the plume's meander (m/s per "
                             "sqrt(rad/s))", min=0.0, max=10.0)
    puff_spread_m_per_sqrt_s: float = field(0.2, "sigma, the white noise on each puff's centre (m/sqrt(s))",
                                            min=0.0, max=10.0)
    growth_m2_per_s: float = field(0.001, "gamma, the growth of a puff's squared radius (m^2/s)", min=0.0, max=1.0)
    source_x_m: float = field(0.5, "the source's x (m); the points lie downwind of it", min=0.1, max=4.0)
    warmup_s: float = field(10.0, "the plume runs this long before the record starts (s)", min=0.0, max=120.0)
    plume_dt_s: float = field(0.01, "the plume's step, also the sampling interval (s)", min_exclusive=0.0, max=0.1)


def plume_config(config: IntermittencyConfig) -> PlumeConfig:
    """The plume of ``config``: one source at ``(source_x_m, 0)`` in the 8 × 4 m arena, wind along +x."""
    source = OdourSource(position_m=(config.source_x_m, 0.0, 0.0), release_rate_hz=config.release_rate_hz,
                         puff_amount=config.puff_amount)
    wind = WindConfig(mean_mps=(config.wind_mps, 0.0), gain=config.wind_gain)
    return PlumeConfig(sources=(source,), wind=wind, puff_spread_m_per_sqrt_s=config.puff_spread_m_per_sqrt_s,
                       growth_m2_per_s=config.growth_m2_per_s, arena_x_m=ARENA_X_M, arena_y_m=ARENA_Y_M)


def sample_points(config: IntermittencyConfig, downwind_m=DEFAULT_DOWNWIND_M,
                  crosswind_m=DEFAULT_CROSSWIND_M) -> np.ndarray:
    """The sensor points (x, y, 0) m, one per (downwind, crosswind) pair, downwind-major: shape (n, 3)."""
    grid = [(config.source_x_m + d, c, 0.0) for d in downwind_m for c in crosswind_m]
    points = np.array(grid, dtype=float).reshape(-1, 3)
    inside = ((points[:, 0] >= ARENA_X_M[0]) & (points[:, 0] <= ARENA_X_M[1])
              & (points[:, 1] >= ARENA_Y_M[0]) & (points[:, 1] <= ARENA_Y_M[1]))
    if not inside.all():
        raise ConfigError(f"plume intermittency: points {points[~inside, :2].tolist()} lie outside the arena "
                          f"x {ARENA_X_M}, y {ARENA_Y_M} m")
    return points


def record(config: IntermittencyConfig, points_m: np.ndarray, seed: int, duration_s: float) -> np.ndarray:
    """The odour at ``points_m`` every plume step for ``duration_s`` after the warm-up: shape (samples, points)."""
    plume = Plume(plume_config(config), seed=seed)
    warmup_steps = int(round(config.warmup_s / config.plume_dt_s))
    if warmup_steps:
        plume.advance(config.plume_dt_s, warmup_steps)
    samples = int(round(duration_s / config.plume_dt_s))
    out = np.empty((samples, len(points_m)))
    for k in range(samples):
        plume.advance(config.plume_dt_s)
        out[k] = plume.concentration_at(points_m)[:, 0]
    return out


def episodes(above: np.ndarray, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The durations (s) of the whole whiffs (runs of True) and whole blanks (runs of False) in ``above``.

    A run that touches the first or the last sample is cut off by the record, so it is left out.

    Examples
    --------
    >>> episodes(np.array([1, 0, 0, 1, 1, 1, 0, 1], bool), 0.5)
    (array([1.5]), array([1. , 0.5]))
    """
    above = np.asarray(above, dtype=bool).reshape(-1)
    if above.size == 0:
        return np.zeros(0), np.zeros(0)
    change = np.flatnonzero(above[1:] != above[:-1]) + 1
    starts = np.concatenate([[0], change])
    lengths = np.diff(np.concatenate([starts, [above.size]]))
    values = above[starts]
    whole = np.ones(len(starts), dtype=bool)
    whole[0] = whole[-1] = False
    return lengths[whole & values] * dt_s, lengths[whole & ~values] * dt_s


def signal_statistics(concentration, threshold: float, dt_s: float) -> dict[str, float]:
    """Intermittency, whiffs per second and mean / median whiff and blank durations of one record.

    Parameters
    ----------
    concentration : array (samples,)
        The odour at one point, one sample every ``dt_s`` seconds.
    threshold : float
        Odour strictly above it is a whiff.
    dt_s : float
        The sampling interval (s).

    Returns
    -------
    dict
        ``intermittency`` (fraction of samples above threshold), ``whiffs_per_s`` (whole whiffs per second
        of record), ``whiff_mean_s``, ``whiff_median_s``, ``blank_mean_s``, ``blank_median_s`` (NaN when
        the record holds no whole whiff, or no whole blank).
    """
    concentration = np.asarray(concentration, dtype=float).reshape(-1)
    above = concentration > threshold
    whiffs, blanks = episodes(above, dt_s)
    duration_s = concentration.size * dt_s

    def stat(f, values):
        return float(f(values)) if values.size else float("nan")

    return {"intermittency": float(above.mean()) if above.size else float("nan"),
            "whiffs_per_s": whiffs.size / duration_s if duration_s else float("nan"),
            "whiff_mean_s": stat(np.mean, whiffs), "whiff_median_s": stat(np.median, whiffs),
            "blank_mean_s": stat(np.mean, blanks), "blank_median_s": stat(np.median, blanks)}


def measure(config: IntermittencyConfig, seeds, duration_s: float, downwind_m=DEFAULT_DOWNWIND_M,
            crosswind_m=DEFAULT_CROSSWIND_M) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Every statistic at every point for every seed.

    Returns
    -------
    points : array (n, 3)
        The sensor points (:func:`sample_points`).
    stats : dict of array (seeds, n)
        One array per name of :data:`STATISTICS`.
    """
    points = sample_points(config, downwind_m, crosswind_m)
    stats = {name: np.full((len(seeds), len(points)), np.nan) for name in STATISTICS}
    for i, seed in enumerate(seeds):
        signal = record(config, points, int(seed), duration_s)
        for j in range(len(points)):
            for name, value in signal_statistics(signal[:, j], config.threshold, config.plume_dt_s).items():
                stats[name][i, j] = value
    return points, stats


def _mean_sd(values: np.ndarray, digits: int) -> str:
    finite = values[np.isfinite(values)]
    if not finite.size:
        return "-"
    text = f"{finite.mean():.{digits}f}±{finite.std(ddof=1) if finite.size > 1 else 0.0:.{digits}f}"
    return text if finite.size == values.size else f"{text} (n={finite.size})"


def report(config: IntermittencyConfig, points: np.ndarray, stats: dict[str, np.ndarray]) -> str:
    """The table printed: one row per point, each statistic as mean ± sd over the seeds."""
    header = (f"{'downwind m':>10} {'cross m':>7}  {'intermittency':>13}  {'whiffs/s':>11}  {'whiff mean s':>14}  "
              f"{'whiff median s':>14}  {'blank mean s':>14}  {'blank median s':>14}")
    lines = [header]
    for j, (x, y, _) in enumerate(points):
        cells = [_mean_sd(stats["intermittency"][:, j], 3), _mean_sd(stats["whiffs_per_s"][:, j], 2)]
        cells += [_mean_sd(stats[name][:, j], 3) for name in STATISTICS[2:]]
        lines.append(f"{x - config.source_x_m:>10.2f} {y:>7.2f}  {cells[0]:>13}  {cells[1]:>11}  "
                     + "  ".join(f"{c:>14}" for c in cells[2:]))
    return "\n".join(lines)


def _floats(text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected numbers separated by commas, got {text!r}") from None
    if not values or not all(np.isfinite(values)):
        raise argparse.ArgumentTypeError(f"expected finite numbers separated by commas, got {text!r}")
    return values


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="a plume setting: " + ", ".join(IntermittencyConfig.__dataclass_fields__))
    parser.add_argument("--seed", type=int, default=0, help="the first plume seed (default 0)")
    parser.add_argument("--seeds", type=int, default=5, help="how many plumes (seeds), default 5")
    parser.add_argument("--duration-s", type=float, default=60.0, help="record length after the warm-up (s)")
    parser.add_argument("--downwind", type=_floats, default=DEFAULT_DOWNWIND_M, metavar="D1,D2,...",
                        help="distances downwind of the source (m)")
    parser.add_argument("--crosswind", type=_floats, default=DEFAULT_CROSSWIND_M, metavar="C1,C2,...",
                        help="distances from the plume's axis (m)")
    args = parser.parse_args(argv)
    if args.seed < 0 or args.seeds < 1:
        parser.error("--seed must be >= 0 and --seeds >= 1")
    if not (0.0 < args.duration_s <= 3600.0):
        parser.error("--duration-s must be in (0, 3600]")
    try:
        config = apply_overrides(IntermittencyConfig, args.set)
        seeds = range(args.seed, args.seed + args.seeds)
        points, stats = measure(config, seeds, args.duration_s, args.downwind, args.crosswind)
    except NeuronavError as error:
        parser.exit(2, f"error: {error}\n")
    settings = ", ".join(f"{k}={getattr(config, k):g}" for k in IntermittencyConfig.__dataclass_fields__)
    print(f"plume: {settings}")
    print(f"seeds {seeds.start}-{seeds.stop - 1}, {args.duration_s:g} s each after the warm-up, sampled every "
          f"{config.plume_dt_s:g} s; mean ± sd over seeds")
    print(report(config, points, stats))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
