"""The UV skyline comparison: the mushroom body's view code from the compound eyes' green, UV or UV-green channel.

In UV the sky outshines the trees and the ground (0.5 against 0.04 and 0.10, ``neuronav.spec.world``), in green
the trees (0.12) barely differ from the sky (0.15): Möller 2002's argument for a UV-green skyline. Here each
view code (the panoramic camera's grey image, and :mod:`.compound_view`'s layout of the compound eyes' ``green``,
``uv`` and ``uv_green`` channels) is measured the ways the README's ``mb_familiarity`` measures are made
(:mod:`neuronav.scenarios.tools.mb_familiarity`, the same route, forests and mushroom body):

- Every view carries the scenario's pixel noise (``--eye-noise``, 0.02 s.d.).
- **Rotational familiarity**: the first ``views`` route views stored; at up to ``tests`` midpoints between
  them the novelty at all 72 headings; the fraction of midpoints whose least novel heading lies within ±15° of
  the route's (and the median offset).
- **Discrimination**: the same memory; on-route midpoints against ``tests`` random views 5–25 m off the route,
  the area under the ROC curve.
- **Route following**: ``neuronav run route-following --set eyes=... --set eye_channel=...`` on the kinematic
  backend, ``trials`` trials from ``seed`` (the same seeds, hence forests, for every code: paired), the scan;
  success with its Wilson interval, and each code against the UV code by Fisher's exact test.

Run ``python -m neuronav.scenarios.route_following.uv_skyline [--views 100] [--tests 50] [--seeds 1,2,3]
[--trials 20] [--seed 1]``. Results: README.md in this folder.
"""

from __future__ import annotations

import argparse

import numpy as np

from neuronav.brains.mushroom_body import novelty, panorama_code
from neuronav.runs.stats import compare_successes, success_rate
from neuronav.scenarios.tools.mb_familiarity import (
    SPACING_M,
    TOLERANCE_DEG,
    _off_route_points,
    auc,
    forest_world,
    memory,
    rotated_codes,
    route,
)

CODES = ("camera", "green", "uv", "uv_green")


def code_settings(code: str) -> dict:
    """The route-following settings of a view code: ``camera`` or one compound-eye channel."""
    return {"eyes": "camera"} if code == "camera" else {"eyes": "compound", "eye_channel": code}


def views_of(code: str):
    """The scenario's view reader (:class:`.scenario.RouteViews`) of ``code``."""
    from neuronav.scenarios.route_following.scenario import RouteFollowingConfig, RouteViews

    return RouteViews(RouteFollowingConfig(**code_settings(code)))


def familiarity(code: str, views: int = 100, tests: int = 50, seed: int = 1, n_kc: int = 4000,
                eye_noise: float = 0.02) -> dict:
    """Rotational familiarity and discrimination of view code ``code`` in forest ``seed`` (see the module doc),
    every view (stored, at a midpoint, off the route) read with Gaussian pixel noise of s.d. ``eye_noise`` (the
    scenario's default; seeded by ``seed``): it is what tells the channels apart, as z-scoring the code removes
    their contrast's scale.

    Returns ``within`` (fraction of midpoints whose least novel heading is within ±15°), ``median_offset_deg``
    (of |best offset|), ``auc`` (off-route against on-route novelty) and ``best_deg`` (tests,).
    """
    reader = views_of(code)
    noise = np.random.default_rng([seed, 24])

    def seen(images: np.ndarray) -> np.ndarray:
        return images + eye_noise * noise.normal(0.0, 1.0, images.shape) if eye_noise else images

    points, headings = route(views + 1)
    world = forest_world(points, seed=seed)
    judge = memory(seen(reader.at(world, points[:views], headings[:views])), n_kc=n_kc, batch=max(tests, 72))
    mids = np.linspace(0, views - 1, min(tests, views)).astype(int)
    mid_points, mid_headings = route(2 * views + 1, SPACING_M / 2)
    images = seen(reader.at(world, mid_points[2 * mids + 1], mid_headings[2 * mids + 1]))
    codes = rotated_codes(images)
    values = novelty(judge, codes.reshape(-1, codes.shape[2])).reshape(codes.shape[:2])
    offset_deg = -np.arange(-images.shape[2] // 2, images.shape[2] // 2) * 360.0 / images.shape[2]
    best = offset_deg[np.argmin(values, axis=1)]
    on = values[:, int(np.flatnonzero(offset_deg == 0.0)[0])]
    rng = np.random.default_rng(seed)
    off_points = _off_route_points(points, tests, rng)
    off = novelty(judge, panorama_code(seen(reader.at(world, off_points, rng.uniform(0, 2 * np.pi, tests)))))
    return {"within": float(np.mean(np.abs(best) <= TOLERANCE_DEG)),
            "median_offset_deg": float(np.median(np.abs(best))), "auc": auc(off, on), "best_deg": best}


def route_following(code: str, trials: int = 20, seed: int = 1) -> list[dict]:
    """The scenario's kinematic trials (scan, defaults otherwise, no landscape) with view code ``code``."""
    from neuronav.config import apply_overrides
    from neuronav.scenarios.route_following.scenario import RouteFollowing, RouteFollowingConfig

    config = apply_overrides(RouteFollowingConfig, dict(code_settings(code), landscape=False))
    return RouteFollowing().run(config, backend="kinematic", trials=trials, seed=seed).trials


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--views", type=int, default=100, help="route views stored (familiarity)")
    parser.add_argument("--tests", type=int, default=50, help="test positions per forest (familiarity)")
    parser.add_argument("--seeds", default="1,2,3", help="forests of the familiarity measures (comma list)")
    parser.add_argument("--trials", type=int, default=20, help="route-following trials per code (0: none)")
    parser.add_argument("--seed", type=int, default=1, help="first trial seed of the route-following runs")
    parser.add_argument("--codes", default=",".join(CODES), help="view codes to compare (comma list)")
    parser.add_argument("--eye-noise", type=float, default=0.02, help="pixel noise of the familiarity views (s.d.)")
    args = parser.parse_args(argv)
    codes = [c.strip() for c in args.codes.split(",")]
    seeds = [int(s) for s in args.seeds.split(",")]
    print(f"familiarity: {args.views} views stored, {args.tests} midpoints and {args.tests} off-route views "
          f"per forest, forests {seeds}, pixel noise {args.eye_noise:g}")
    for code in codes:
        results = [familiarity(code, args.views, args.tests, s, eye_noise=args.eye_noise) for s in seeds]
        within = np.mean([r["within"] for r in results])
        offset = np.median(np.concatenate([np.abs(r["best_deg"]) for r in results]))
        per_forest = ", ".join(f"{100 * r['within']:.0f}" for r in results)
        aucs = ", ".join(f"{r['auc']:.3f}" for r in results)
        print(f"  {code:9s} least novel heading within ±{TOLERANCE_DEG:g}°: {100 * within:.1f} % of "
              f"{len(seeds) * min(args.tests, args.views)} (per forest {per_forest} %), median |offset| "
              f"{offset:.1f}°; discrimination AUC {aucs}")
    if args.trials <= 0:
        return
    print(f"route following: kinematic, scan, seeds {args.seed}-{args.seed + args.trials - 1} for every code")
    runs = {code: route_following(code, args.trials, args.seed) for code in codes}
    reference = runs.get("uv")
    for code, rows in runs.items():
        k = sum(bool(r["success"]) for r in rows)
        rate = success_rate(k, len(rows))
        checkpoints = np.mean([r["checkpoints_reached"] for r in rows])
        distance = np.median([r["mean_distance_m"] for r in rows])
        line = (f"  {code:9s} reached the end {k}/{len(rows)} [Wilson {rate['ci'][0]:.2f}, {rate['ci'][1]:.2f}], "
                f"checkpoints {100 * checkpoints:.1f} % (mean), mean distance {distance:.2f} m (median)")
        if reference is not None and code != "uv":
            k_uv = sum(bool(r["success"]) for r in reference)
            test = compare_successes(k, len(rows), k_uv, len(reference))
            line += f"; against uv: risk difference {test['risk_difference']:+.2f}, Fisher's p = {test['p']:.2g}"
        print(line)


if __name__ == "__main__":
    main()
