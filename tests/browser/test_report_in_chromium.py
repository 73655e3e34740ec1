"""The report in a real browser: Debian's Chromium, headless, driven by playwright's Python package.

The page must draw with no console error and no network request, its slider must move the ant's
cursor on the path and the cursors of the brain's heatmaps, and a screenshot must show the path.
Skipped, with the reason, when playwright or a Chromium executable is missing (``.ci/run`` installs
``chromium``; ``playwright`` is in the ``test`` extra) — except where ``NEURONAV_REQUIRE_BROWSER=1``
(``.ci/run`` sets it): there a missing browser fails, so CI never passes without running them.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from neuronav.runs import cli
from neuronav.runs.report.replay import PATH_COLOUR

ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
        "--disable-sync", "--no-first-run"]
# The replay's graph div: the ant cursor and the heatmaps' vertical cursors as the browser holds them.
CURSORS = """() => { const gd = document.querySelector('.replay');
  const pick = t => ({x: Array.from(t.x), y: Array.from(t.y)});
  return {ant: pick(gd.data.find(t => t.name === 'ant')),
          heat: gd.data.filter(t => t.name.endsWith(' cursor')).map(pick),
          step: gd.layout.sliders[0].active,
          heatmaps_drawn: gd.querySelectorAll('.imagelayer image').length}; }"""


def skip_or_fail(reason: str) -> None:
    """Skip with ``reason``, or fail where the browser is required (``NEURONAV_REQUIRE_BROWSER=1``)."""
    if os.environ.get("NEURONAV_REQUIRE_BROWSER") == "1":
        pytest.fail(f"{reason} (NEURONAV_REQUIRE_BROWSER=1: the browser tests must run)")
    pytest.skip(reason)


def chromium() -> str:
    found = os.environ.get("NEURONAV_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
    if not found or not Path(found).exists():
        skip_or_fail("Chromium is not installed (Debian: apt-get install -y chromium); the report's browser "
                     "tests need it")
    return found


@pytest.fixture(scope="module")
def report(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("browser") / "run"
    argv = ["run", "path-integration", "--backend", "kinematic", "--trials", "2", "--set", "outbound_steps=300",
            "--set", "inbound_steps=300", "--no-figures", "--out", str(out), "--report"]
    assert cli.main(argv) == 0
    return out / "report.html"


@pytest.fixture(scope="module")
def browser():
    executable = chromium()
    try:
        from playwright import sync_api
    except ImportError:
        skip_or_fail("playwright is not installed (pip install playwright)")
    with sync_api.sync_playwright() as driver:
        launched = driver.chromium.launch(executable_path=executable, args=ARGS)
        yield launched
        launched.close()


@pytest.fixture(scope="module")
def page(browser, report):
    """The report opened from disk once for this module's tests (in their order: load, slider, play,
    screenshot); every request that is not file:// or data: is recorded and refused."""
    page = browser.new_page(viewport={"width": 1400, "height": 1000})
    page.errors, page.requests = [], []
    page.on("console", lambda message: page.errors.append(message.text) if message.type == "error" else None)
    page.on("pageerror", lambda error: page.errors.append(str(error)))

    def route(r):
        if r.request.url.startswith(("file://", "data:")):
            r.continue_()
        else:
            page.requests.append(r.request.url)
            r.abort()

    page.route("**", route)
    page.goto(report.as_uri())
    page.wait_for_function("document.querySelector('.replay .main-svg') !== null", timeout=30_000)
    yield page
    page.close()


def test_opens_without_errors_or_network(page):
    page.wait_for_timeout(300)
    assert page.errors == []
    assert page.requests == []
    assert page.evaluate("typeof Plotly") == "object"


def test_slider_moves_the_path_and_heatmap_cursors(page):
    before = page.evaluate(CURSORS)
    assert len(before["heat"]) == 2  # cpu4_memory and tb1_rates
    rail = page.locator(".replay .slider-rail-touch-rect").first  # the slider's rail, where a click lands
    box = rail.bounding_box()
    rail.click(position={"x": 0.8 * box["width"], "y": box["height"] / 2})
    page.wait_for_function("document.querySelector('.replay').layout.sliders[0].active > 0", timeout=5000)
    # The slider's step is drawn by Plotly.animate, which resolves after the slider moved: wait (at most 5 s) for
    # the ant's cursor to leave where it was (a timeout fails the test as the assertion below would).
    page.wait_for_function("""(old) => { const t = document.querySelector('.replay').data.find(t => t.name === 'ant');
        return Array.from(t.x).some((v, i) => v !== old.x[i]) || Array.from(t.y).some((v, i) => v !== old.y[i]); }""",
                           arg=before["ant"], timeout=5000)
    after = page.evaluate(CURSORS)
    assert after["step"] > 0
    assert after["ant"]["x"] != before["ant"]["x"] or after["ant"]["y"] != before["ant"]["y"]
    for old, new in zip(before["heat"], after["heat"]):
        assert new["x"][0] > old["x"][0]  # the vertical cursor moved forward in time
    assert before["heatmaps_drawn"] == after["heatmaps_drawn"] == 2  # still drawn after the frame changed
    assert page.errors == []


def test_play_button_animates(page):
    before = page.evaluate(CURSORS)
    page.locator(".replay .updatemenu-button").first.click()  # play, from the current step
    page.wait_for_function(f"document.querySelector('.replay').layout.sliders[0].active > {before['step'] + 3}",
                           timeout=10_000)
    after = page.evaluate(CURSORS)
    assert after["heat"][0]["x"][0] > before["heat"][0]["x"][0]
    assert after["heatmaps_drawn"] == 2


def test_screenshot_shows_the_path(page, tmp_path):
    from PIL import Image

    page.locator(".replay .updatemenu-button").nth(1).click()  # pause
    shot = tmp_path / "replay.png"
    page.locator("details.trial").first.screenshot(path=str(shot))
    pixels = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    assert pixels.shape[0] > 300 and pixels.shape[1] > 600
    assert pixels.std() > 20, "the screenshot is blank"
    colour = np.array([int(PATH_COLOUR[i:i + 2], 16) for i in (1, 3, 5)])
    near = (np.abs(pixels - colour).sum(axis=-1) < 40).sum()
    assert near > 200, f"the path's colour {PATH_COLOUR} covers only {near} pixels"
    page.screenshot(path=str(tmp_path / "page.png"), full_page=True)


def test_video_follows_the_slider(browser, report, tmp_path):
    """A run folder's trial0.mp4 is linked next to the page and seeks with trial 0's slider."""
    imageio = pytest.importorskip("imageio.v2", reason="imageio is not installed (the mujoco extra has it)")
    run = tmp_path / "run"
    shutil.copytree(report.parent, run)
    frames = [np.full((64, 64, 3), 6 * i, np.uint8) for i in range(40)]
    imageio.mimsave(run / "trial0.mp4", frames, fps=10)  # 4 s
    assert cli.main(["report", str(run)]) == 0
    page = browser.new_page(viewport={"width": 1400, "height": 1000})
    try:
        page.route("**", lambda r: r.continue_() if r.request.url.startswith(("file://", "data:")) else r.abort())
        page.goto((run / "report.html").as_uri())
        page.wait_for_function("document.querySelector('.replay .main-svg') !== null", timeout=30_000)
        page.wait_for_function("document.querySelector('video').readyState >= 1", timeout=10_000)
        rail = page.locator(".replay .slider-rail-touch-rect").first
        box = rail.bounding_box()
        rail.click(position={"x": 0.5 * box["width"], "y": box["height"] / 2})
        page.wait_for_function("document.querySelector('video').currentTime > 1", timeout=5000)
        seconds = page.evaluate("document.querySelector('video').currentTime")
        assert seconds == pytest.approx(2.0, abs=0.3)  # half the trial: half the video
    finally:
        page.close()



def test_a_large_first_replay_draws_while_the_page_is_still_loading(browser, tmp_path):
    """Trial 0's replay is open from the start; a figure of megabytes (a swarm's 200 paths and cursors) must not be
    read before the page has it all (its toggle event comes while the page is still being parsed)."""
    out = tmp_path / "swarm"
    assert cli.main(["run", "swarm-homing", "--trials", "2", "--set", "ants=200", "--no-figures", "--no-progress",
                     "--out", str(out), "--report"]) == 0
    page = browser.new_page(viewport={"width": 1400, "height": 1000})
    errors = []
    page.on("pageerror", lambda error: errors.append(str(error)))
    try:
        page.goto((out / "report.html").as_uri())
        page.wait_for_function("document.querySelector('.replay .main-svg') !== null", timeout=30_000)
        assert errors == []
        paths = page.evaluate("document.querySelector('.replay').data.find(t => t.name === \"agents' paths\").x.length")
        assert paths > 200 * 50  # every ant's path drawn
    finally:
        page.close()
