"""How often Stone et al. 2017's Fig. 7 claim holds: many independent 1000-agent runs.

Stone et al. (2017, Curr. Biol. 27: 3069–3085, Fig. 7; docs/parameters.md §3) report that every one
of 1000 agents came within 20 steps of the nest. The model
misses now and then (an agent homes along the right bearing but passes the nest 20–40 steps off,
mostly after a long outbound route), so whether a 1000-agent sample has no miss is a matter of
chance. This script runs ``--runs`` samples of ``--trials`` agents (seeds 0, 1000, 2000, ...) and
prints the misses per sample, the per-agent miss rate, the fraction of samples with every agent
home, and the spread of the tortuosity.

Usage::

    python -m neuronav.scenarios.tools.fig7_statistics [--runs 40] [--trials 1000]
        [--set dtype=float64 --set noise_method=gaussian]

Results: README.md in this folder.
"""

from __future__ import annotations

import argparse

import numpy as np

from neuronav.config import apply_overrides
from neuronav.errors import NeuronavError
from neuronav.scenarios.path_integration.scenario import PathIntegration, PathIntegrationConfig


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=40)
    parser.add_argument("--trials", type=int, default=1000)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="a path-integration setting, as for neuronav run")
    args = parser.parse_args(argv)
    if args.runs < 1 or args.trials < 1:
        parser.error("--runs and --trials must be at least 1")
    try:
        config = apply_overrides(PathIntegrationConfig, args.set)
    except NeuronavError as error:
        parser.exit(2, f"error: {error}\n")
    scenario = PathIntegration()
    misses, tortuosity, missed = [], [], []
    for run in range(args.runs):
        seed = run * args.trials
        result = scenario.run(config, backend="kinematic", trials=args.trials, seed=seed)
        closest = np.array([t["closest_distance"] for t in result.trials])
        home = np.array([t["home_distance"] for t in result.trials])
        out = closest > config.success_radius
        misses.append(int(out.sum()))
        missed += list(zip(closest[out], home[out]))
        tortuosity.append(result.aggregates["tortuosity"])
        print(f"seed {seed:>6}: {misses[-1]} of {args.trials} missed, tortuosity {tortuosity[-1]:.3f}", flush=True)
    total = args.runs * args.trials
    print(f"\nmissed {sum(misses)} of {total} agents ({100 * sum(misses) / total:.3f} %); "
          f"samples with every agent home: {sum(m == 0 for m in misses)} of {args.runs}")
    print(f"tortuosity over samples: mean {np.mean(tortuosity):.3f}, range {min(tortuosity):.3f}-{max(tortuosity):.3f}")
    if missed:
        closest, home = np.array(missed).T
        print(f"the misses: closest approach {closest.min():.1f}-{closest.max():.1f}, outbound route ending "
              f"{np.median(home):.0f} (median) from the nest")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
