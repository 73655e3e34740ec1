"""Mushroom-body familiarity measured on ray-cast forest views: rotational familiarity and capacity.

Views are the desert ant's panoramic camera (72 x 72, the whole sphere; one ray per pixel here)
rendered by the kinematic backend's ray caster in a seeded forest, at points of a meandering route
(a sine of 3 m amplitude and 20 m wavelength, views every ``SPACING_M`` along it, the heading along
the route); ``route-following`` uses the same route and forest. The PN code is the down-sampled
panorama (:func:`neuronav.brains.mushroom_body.panorama_code`, 36 x 9 blocks of 10°): it turns with
the viewer. Turning on the spot is rolling the panorama by whole columns (5°; the eye sits 8 mm ahead
of the turning axis, ignored).

Measurements:

- **Rotational familiarity**: the first ``views`` route views are stored (one step each, learning
  on); at the midpoints between stored views the novelty is read at 72 headings; the heading of least
  novelty should lie within ±15° of the route's heading (at >= 90 % of the positions).
- **Capacity**: 10, 100 and 1000 views stored; on-route test views (midpoints, route heading)
  against off-route views (random points 5–25 m from the route, random headings); the
  discrimination is the area under the ROC curve (ties counted half).

Run ``python -m neuronav.scenarios.tools.mb_familiarity [--views 100] [--tests 100] [--seed 1] [--out DIR]``:
prints the numbers, writes ``mb_rotational.png`` and ``mb_capacity.png`` into ``--out``.
``tests/unit/test_mushroom_body.py`` keeps the numbers true. Results: README.md in this folder.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np

from neuronav import registry
from neuronav.bodies.desert_ant import desert_ant
from neuronav.brains.mushroom_body import (
    PANORAMA_COLUMNS,
    PANORAMA_ROWS,
    learn_views,
    mushroom_body,
    novelty,
    panorama_code,
)
from neuronav.scenarios.visual_setup import point_agent_cameras
from neuronav.scenarios.worlds.scenes import forest, vision_appearance
from neuronav.spec.world import PointAgents, World

SPACING_M = 0.1
AMPLITUDE_M, WAVELENGTH_M = 3.0, 20.0
TOLERANCE_DEG = 15.0
ROLL_STEP_DEG = 5.0  # one column of the 72-column panorama


def route(n_points: int, spacing_m: float = SPACING_M) -> tuple[np.ndarray, np.ndarray]:
    """``n_points`` points (n, 2) m along the meandering route, ``spacing_m`` apart along it, starting
    at the origin, and the route's heading there (n,) rad (clockwise from +y, as the backends count)."""
    x = np.linspace(0.0, n_points * spacing_m * 1.2 + 1.0, 20 * n_points + 200)
    y = AMPLITUDE_M * np.sin(2 * np.pi * x / WAVELENGTH_M)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))])
    at = np.arange(n_points) * spacing_m
    px, py = np.interp(at, arc, x), np.interp(at, arc, y)
    slope = AMPLITUDE_M * 2 * np.pi / WAVELENGTH_M * np.cos(2 * np.pi * px / WAVELENGTH_M)
    heading = np.arctan2(1.0, slope)  # direction (1, slope): heading atan2(dx, dy)
    return np.stack([px, py], axis=1), heading


def forest_world(route_m: np.ndarray, seed: int = 1, trees_per_100_m2: float = 5.0) -> World:
    """A seeded forest about the route, no tree reaching within 0.5 m of it."""
    low, high = route_m.min(axis=0) - 25.0, route_m.max(axis=0) + 25.0
    centre = (low + high) / 2.0
    radius = float(np.hypot(*(high - low)) / 2.0)
    count = int(trees_per_100_m2 * np.pi * radius ** 2 / 100.0)
    clear = [(x, y, 0.5) for x, y in route_m[::5]]
    trees = forest(count, seed=seed, outer_radius_m=radius, centre_m=tuple(centre), clear=clear)
    return World(objects=trees, appearance=vision_appearance())


def panoramas(world: World, positions_m: np.ndarray, headings_rad: np.ndarray, chunk: int = 200) -> np.ndarray:
    """Grey panoramas (N, 72, 72) seen by the ant's panoramic camera (one ray per pixel) from each
    position and heading, ray cast by the kinematic backend."""
    camera = next(c for c in point_agent_cameras(desert_ant()) if c.name == "panorama")
    camera = replace(camera, supersample=1)
    positions_m, headings_rad = np.asarray(positions_m, float), np.asarray(headings_rad, float)
    images = []
    for start in range(0, len(positions_m), chunk):
        where, facing = positions_m[start:start + chunk], headings_rad[start:start + chunk]
        backend = registry.load("backend", "kinematic")()
        backend.load(world, [PointAgents(count=len(where), mode="unicycle", cameras=(camera,))])
        backend.reset(position_m=where, heading_rad=facing)
        images.append(backend.read(["panorama"])["panorama"])
    return np.concatenate(images)


def rotated_codes(images: np.ndarray) -> np.ndarray:
    """PN codes (N, R, n_pn) of each panorama rolled by every whole column (R = width; roll k is
    k x 360°/W, k = -W/2 .. W/2 - 1)."""
    width = images.shape[2]
    rolls = np.arange(-width // 2, width // 2)
    return np.stack([panorama_code(np.roll(images, k, axis=2)) for k in rolls], axis=1)


def auc(off: np.ndarray, on: np.ndarray) -> float:
    """P(off-route novelty > on-route novelty), ties counted half."""
    off, on = np.asarray(off, float)[:, None], np.asarray(on, float)[None, :]
    return float((off > on).mean() + 0.5 * (off == on).mean())


def memory(world_views: np.ndarray, n_kc: int = 4000, seed: int = 0, batch: int = 500):
    """A compiled mushroom body (panorama code) of ``batch`` agents that stored the views
    (N, 72, 72) in order."""
    circuit = mushroom_body(n_pn=PANORAMA_ROWS * PANORAMA_COLUMNS, n_kc=n_kc, seed=seed)
    learner = circuit.compile(batch=1)
    learn_views(learner, panorama_code(world_views))
    judge = circuit.compile(batch=batch)
    judge.set_weights("KC->MBON", learner.weights("KC->MBON"))
    return judge


def rotational_familiarity(views: int = 100, tests: int = 50, seed: int = 1, n_kc: int = 4000) -> dict:
    """Store ``views`` route views; at up to ``tests`` midpoints the novelty at every roll.

    Returns a dict: ``offset_deg`` (R,) the heading offsets from the route's heading (positive: turned
    right; rolling the panorama by k columns is turning right by -k x 5°), ``novelty`` (tests, R),
    ``best_deg`` (tests,) the offset of least novelty (the first in roll order on ties), ``within``
    the fraction within ±15°.
    """
    points, headings = route(views + 1)
    world = forest_world(points, seed=seed)
    sim = memory(panoramas(world, points[:views], headings[:views]), n_kc=n_kc)
    mids = np.linspace(0, views - 1, min(tests, views)).astype(int)
    mid_points, mid_headings = route(2 * views + 1, SPACING_M / 2)
    images = panoramas(world, mid_points[2 * mids + 1], mid_headings[2 * mids + 1])
    codes = rotated_codes(images)
    values = novelty(sim, codes.reshape(-1, codes.shape[2])).reshape(codes.shape[:2])
    offset_deg = -np.arange(-images.shape[2] // 2, images.shape[2] // 2) * 360.0 / images.shape[2]
    best = offset_deg[np.argmin(values, axis=1)]
    return {"offset_deg": offset_deg, "novelty": values, "best_deg": best,
            "within": float(np.mean(np.abs(best) <= TOLERANCE_DEG))}


def capacity(stored=(10, 100, 1000), tests: int = 100, seed: int = 1, n_kc: int = 4000) -> dict:
    """On- and off-route novelty after storing each number of views (see the module doc).

    Returns a dict per number of views: ``on``, ``off`` (novelty arrays), ``auc``, ``depressed`` (the
    fraction of KC→MBON weights at 0).
    """
    most = max(stored)
    points, headings = route(most + 1)
    world = forest_world(points, seed=seed)
    route_images = panoramas(world, points[:most], headings[:most])
    mid_points, mid_headings = route(2 * most + 1, SPACING_M / 2)
    rng = np.random.default_rng(seed)
    off_points = _off_route_points(points, tests, rng)
    off_images = panoramas(world, off_points, rng.uniform(0, 2 * np.pi, tests))
    results = {}
    for n in stored:
        sim = memory(route_images[:n], n_kc=n_kc, batch=tests)
        mids = np.linspace(0, n - 1, min(tests, n)).astype(int)
        on = novelty(sim, panorama_code(panoramas(world, mid_points[2 * mids + 1], mid_headings[2 * mids + 1])))
        off = novelty(sim, panorama_code(off_images))
        results[n] = {"on": on, "off": off, "auc": auc(off, on),
                      "depressed": float(np.mean(sim.weights("KC->MBON")[0] == 0.0))}
    return results


def _off_route_points(route_m: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """``count`` random points 5–25 m from the nearest route point, within the route's span."""
    points = []
    low, high = route_m.min(axis=0) - 25.0, route_m.max(axis=0) + 25.0
    while len(points) < count:
        candidate = rng.uniform(low, high)
        distance = np.hypot(*(route_m - candidate).T).min()
        if 5.0 <= distance <= 25.0:
            points.append(candidate)
    return np.array(points)


def plot(rotation: dict, capacities: dict, out: Path) -> list[Path]:
    """Two figures: the rotational familiarity functions and the capacity."""
    from neuronav.runs.plotting import new_figure, save

    fig, ax = new_figure((6.0, 3.5))
    order = np.argsort(rotation["offset_deg"])
    offset, values = rotation["offset_deg"][order], rotation["novelty"][:, order]
    for row in values:
        ax.plot(offset, row, color="0.7", lw=0.6)
    ax.plot(offset, np.median(values, axis=0), color="C3", lw=2, label="median")
    ax.axvspan(-TOLERANCE_DEG, TOLERANCE_DEG, color="C2", alpha=0.15, label="±15°")
    ax.set_xlabel("heading offset from the route (°, + right)")
    ax.set_ylabel("MBON novelty (active KCs, intact weights)")
    ax.set_title(f"rotational familiarity: minimum within ±15° at {100 * rotation['within']:.0f} % of positions")
    ax.legend(fontsize=7)
    paths = [save(fig, out / "mb_rotational.png")]
    fig, (left, right) = new_figure((9.0, 3.5), ncols=2)
    counts = sorted(capacities)
    left.boxplot([capacities[n]["on"] for n in counts], positions=np.arange(len(counts)) - 0.18, widths=0.3)
    left.boxplot([capacities[n]["off"] for n in counts], positions=np.arange(len(counts)) + 0.18, widths=0.3)
    left.set_xticks(range(len(counts)), [str(n) for n in counts])
    left.set_xlabel("views stored (left box: on route, right: off route)")
    left.set_ylabel("novelty")
    right.plot(counts, [capacities[n]["auc"] for n in counts], "o-", label="discrimination (AUC)")
    right.plot(counts, [capacities[n]["depressed"] for n in counts], "s--", label="KC weights at 0")
    right.set_xscale("log")
    right.set_ylim(0, 1.05)
    right.set_xlabel("views stored")
    right.legend(fontsize=7)
    paths.append(save(fig, out / "mb_capacity.png"))
    return paths


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--views", type=int, default=100, help="views stored for the rotational test")
    parser.add_argument("--tests", type=int, default=100, help="test positions per measurement")
    parser.add_argument("--seed", type=int, default=1, help="forest seed")
    parser.add_argument("--out", type=Path, default=Path("mb_familiarity"), help="folder for the figures")
    args = parser.parse_args(argv)
    rotation = rotational_familiarity(args.views, args.tests, args.seed)
    print(f"rotational familiarity ({args.views} views stored, {len(rotation['best_deg'])} midpoints): minimum "
          f"within ±{TOLERANCE_DEG:g}° at {100 * rotation['within']:.1f} %; median |offset| "
          f"{np.median(np.abs(rotation['best_deg'])):.1f}°")
    capacities = capacity(tests=args.tests, seed=args.seed)
    for n, result in sorted(capacities.items()):
        print(f"{n:5d} views: on-route novelty median {np.median(result['on']):.1f}, off-route "
              f"{np.median(result['off']):.1f}, discrimination (AUC) {result['auc']:.3f}, KC weights at 0 "
              f"{100 * result['depressed']:.1f} %")
    args.out.mkdir(parents=True, exist_ok=True)
    for path in plot(rotation, capacities, args.out):
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
