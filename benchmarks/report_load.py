"""Benchmark: the HTML report of a many-trial run: the time to build it, its size, and its load time in Chromium.

Makes a ``path-integration`` run on the kinematic backend (``--trials``, default 1000; the run records
its first 20 trials' time series, so the report replays those), then:

1. builds its report (``neuronav report``) ``--repeats`` times: CPU time (``time.process_time``) and
   wall time (``time.perf_counter``) of each build, and the file's size;
2. when Chromium (``/usr/bin/chromium`` or ``chromium`` on PATH) and playwright are installed, opens
   the file headless ``--loads`` times and prints the wall time from navigation until the first
   replay is drawn (its Plotly SVG exists), with no network (every non-file request is refused and
   counted), and this process's CPU time over the same span (the browser's own CPU is in other
   processes, so the wall time is the number that counts). Target (issue 26): under 5 s.

Usage::

    python benchmarks/report_load.py [--trials 1000] [--repeats 3] [--loads 3]
    python benchmarks/report_load.py --trials 3 --steps 200 --repeats 1 --no-browser   # quick mode
    python benchmarks/report_load.py --trials 3 --repeats 1 --loads 1 --screenshot docs/report.png
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
        "--disable-sync", "--no-first-run"]
TARGET_S = 5.0


def make_run(out: Path, trials: int, steps: int | None) -> float:
    from neuronav.runs import cli

    extra = ["--set", f"outbound_steps={steps}", "--set", f"inbound_steps={steps}"] if steps else []
    start = time.perf_counter()
    status = cli.main(["run", "path-integration", "--backend", "kinematic", "--trials", str(trials), *extra,
                       "--out", str(out), "--no-progress"])
    if status != 0:
        raise SystemExit(f"the run failed (exit {status})")
    return time.perf_counter() - start


def build(run: Path, repeats: int) -> Path:
    from neuronav.runs.report import write_report

    print(f"{'build':<28}{'cpu s':>8}{'wall s':>8}")
    for i in range(repeats):
        cpu, wall = time.process_time(), time.perf_counter()
        page = write_report([run])
        print(f"{f'report build {i + 1}':<28}{time.process_time() - cpu:8.2f}{time.perf_counter() - wall:8.2f}")
    size = page.stat().st_size
    print(f"HTML size: {size / 1e6:.2f} MB ({size} bytes): {page}")
    return page


def browser_load(page: Path, loads: int, screenshot: Path | None = None) -> None:
    executable = shutil.which("chromium") or shutil.which("chromium-browser")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        executable = None
    if not executable:
        print("browser load: skipped (Chromium or playwright not installed)")
        return
    print(f"{'browser (headless Chromium)':<28}{'cpu s':>8}{'wall s':>8}")
    with sync_playwright() as driver:
        browser = driver.chromium.launch(executable_path=executable, args=ARGS)
        walls = []
        for i in range(loads):
            tab = browser.new_page(viewport={"width": 1400, "height": 1000})
            refused = []
            tab.route("**", lambda r, refused=refused: r.continue_() if r.request.url.startswith(("file:", "data:"))
                      else (refused.append(r.request.url), r.abort()))
            cpu, wall = time.process_time(), time.perf_counter()
            tab.goto(page.as_uri())
            tab.wait_for_function("document.querySelector('.replay .main-svg') !== null", timeout=60_000)
            walls.append(time.perf_counter() - wall)
            print(f"{f'load {i + 1} (to first replay)':<28}{time.process_time() - cpu:8.2f}{walls[-1]:8.2f}"
                  f"   network requests refused: {len(refused)}")
            if screenshot and i == 0:
                save_screenshot(tab, screenshot)
            tab.close()
        browser.close()
    best = min(walls)
    print(f"browser load: best {best:.2f} s wall of {loads}; target < {TARGET_S:g} s: "
          f"{'met' if best < TARGET_S else 'MISSED'} (wall time, in the browser's processes)")


def save_screenshot(tab, path: Path) -> None:
    """The first replay with its slider at 55 %, as a PNG of at most 128 colours (docs/report.png)."""
    from PIL import Image

    rail = tab.locator(".replay .slider-rail-touch-rect").first
    box = rail.bounding_box()
    rail.click(position={"x": 0.55 * box["width"], "y": box["height"] / 2})
    tab.wait_for_timeout(500)
    raw = path.with_suffix(".raw.png")
    tab.locator("details.trial").first.screenshot(path=str(raw))
    Image.open(raw).convert("RGB").quantize(colors=128).save(path, optimize=True)
    raw.unlink()
    print(f"screenshot: {path} ({path.stat().st_size / 1e3:.0f} kB)")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=1000)
    parser.add_argument("--steps", type=int, help="outbound and inbound steps (default: the scenario's 1500)")
    parser.add_argument("--repeats", type=int, default=3, help="report builds")
    parser.add_argument("--loads", type=int, default=3, help="browser loads")
    parser.add_argument("--no-browser", dest="browser", action="store_false")
    parser.add_argument("--screenshot", type=Path, metavar="FILE.png",
                        help="save the first replay (slider at 55 %%) as seen in Chromium, e.g. docs/report.png")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="neuronav-report-") as folder:
        run = Path(folder) / "run"
        wall = make_run(run, args.trials, args.steps)
        print(f"run: path-integration, {args.trials} trials on kinematic in {wall:.2f} s wall (not part of the report)")
        page = build(run, args.repeats)
        if args.browser:
            browser_load(page, args.loads, args.screenshot)
    return 0


if __name__ == "__main__":
    sys.exit(main())
