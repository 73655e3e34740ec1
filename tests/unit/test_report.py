"""``neuronav report`` without a browser: what the HTML file holds, the replay's frames, several
folders, and the exit status 2 cases (the browser tests are in tests/browser/)."""

from __future__ import annotations

import base64
import json
import re
from pathlib import Path

import numpy as np
import pytest

from neuronav.runs import cli
from neuronav.runs.report import replay

TINY = ["--set", "outbound_steps=200", "--set", "inbound_steps=200"]
FIGURE_JSON = re.compile(r"<script type='application/json' id='(figure-\d+)'>(.*?)</script>", re.S)


@pytest.fixture(scope="module")
def folders(tmp_path_factory) -> dict[str, Path]:
    """A tiny kinematic run (with figures), a two-point sweep and a one-backend compare, each with --report."""
    root = tmp_path_factory.mktemp("report")
    common = ["path-integration", "--trials", "3", *TINY]
    assert cli.main(["run", *common, "--backend", "kinematic", "--out", str(root / "run"), "--report"]) == 0
    assert cli.main(["sweep", *common, "--backend", "kinematic", "--grid", "noise=0.1,0.3", "--workers", "1",
                     "--no-figures", "--out", str(root / "sweep"), "--report"]) == 0
    assert cli.main(["compare", *common, "--backends", "kinematic", "--out", str(root / "compare"), "--report"]) == 0
    return {"root": root, "run": root / "run", "sweep": root / "sweep", "compare": root / "compare"}


def replays(page: str) -> list[dict]:
    return [json.loads(text) for _, text in FIGURE_JSON.findall(page)]


def test_run_report_holds_settings_metrics_and_every_figure(folders):
    run = folders["run"]
    page = (run / "report.html").read_text()
    summary = json.loads((run / "summary.json").read_text())
    for key, value in summary["config"].items():
        assert f"<td>{key}</td><td>{value if not isinstance(value, float) else f'{value:.4g}'}</td>" in page, key
    for metric in summary["metrics"]:
        assert f"<td>{metric}</td>" in page, metric
    assert f"{summary['metrics']['closest_distance']:.4g}" in page
    pngs = sorted(run.glob("*.png"))
    assert len(pngs) >= 3
    for png in pngs:
        assert base64.b64encode(png.read_bytes()).decode() in page, png.name


def test_report_needs_no_network(folders):
    page = (folders["run"] / "report.html").read_text()
    outside = re.findall(r"<(?:script|link|img|video|iframe|source)\b[^>]*\b(?:src|href)\s*=\s*['\"]?(?:https?:)?//",
                         page, re.I)
    assert not outside, outside
    assert page.count("plotly.js v") >= 1  # the library itself is inside, once (not once per figure)
    assert page.count("Plotly.newPlot") == 1  # only the glue calls it; no per-figure copy of the library
    assert len(page) < 12_000_000


def test_replay_has_one_frame_per_slider_step_and_its_cursors_move(folders):
    figures = replays((folders["run"] / "report.html").read_text())
    assert len(figures) == 3  # every recorded trial (the run records its first 20)
    for figure in figures:
        steps = figure["layout"]["sliders"][0]["steps"]
        assert 2 <= len(steps) <= replay.MAX_FRAMES
        assert [s["args"][0][0] for s in steps] == [f["name"] for f in figure["frames"]]
        assert len(figure["layout"]["meta"]["frame_times"]) == len(steps)
        first, last = figure["frames"][0], figure["frames"][-1]
        assert first["traces"] == last["traces"] and len(first["traces"]) >= 3  # ant + two heatmap cursors
        ant = figure["data"][first["traces"][0]]
        assert ant["name"] == "ant"
        assert first["data"][0]["x"] != last["data"][0]["x"]  # the ant moved
        assert first["data"][1]["x"][0] < last["data"][1]["x"][0]  # the heatmap cursor moved right
    heatmaps = figures[0]["layout"]["images"]  # PNGs under the axes: Plotly would clear heatmap traces
    assert len(heatmaps) == 2 and all(h["source"].startswith("data:image/png;base64,") for h in heatmaps)
    assert {t["type"] for t in figures[0]["data"]} == {"scatter"}  # cpu4_memory and tb1_rates


def test_replay_is_generic_over_recorded_shapes():
    """A made-up recording: path + heading, a population, a two-channel sense, a world point, an image."""
    n = 500
    t = np.linspace(0, 10, n)
    series = {"position_m": np.stack([np.c_[np.cos(t), np.sin(t)], np.c_[t, t]])[:, :, :],
              "heading_rad": np.stack([t + np.pi / 2, np.full(n, np.pi / 4)]),
              "time_s": np.stack([t, t]), "bump": np.random.default_rng(0).random((2, n, 8)),
              "odour": np.zeros((2, n, 2)), "home_m": np.zeros((2, 2)), "view": np.ones((2, 5, 20))}
    series["position_m"][1, 400:] = np.nan  # trial 1 is shorter: padded
    data = replay.trial_data(series, 1)
    assert len(data.path) == 400
    assert [name for name, _ in data.panels] == ["bump", "odour"]
    assert [name for name, _ in data.world_points] == ["home_m"]
    assert [name for name, _ in data.images] == ["view"]
    fig = replay.figure(data)
    assert len(fig["frames"]) == replay.MAX_FRAMES == len(fig["layout"]["sliders"][0]["steps"])
    end = fig["frames"][-1]["data"][0]
    assert end["x"][0] == pytest.approx(t[399]) and end["x"][1] > end["x"][0]  # heading pi/4: up and right
    assert end["y"][1] > end["y"][0]


def test_several_folders_side_by_side(folders, tmp_path):
    out = tmp_path / "both.html"
    assert cli.main(["report", str(folders["run"]), str(folders["compare"]), "--out", str(out)]) == 0
    page = out.read_text()
    assert "<h2>comparison</h2>" in page and "class='columns'" in page
    assert page.count("<section>") >= 2
    assert "metric (mean ± std)" in page


def test_sweep_and_compare_reports(folders):
    sweep = (folders["sweep"] / "report.html").read_text()
    assert "noise=0.1" in sweep and "noise=0.3" in sweep and "comparisons between grid points" in sweep
    assert len(replays(sweep)) == 6  # 2 points x 3 trials
    compare = (folders["compare"] / "report.html").read_text()
    assert "metrics by backend" in compare and "kinematic" in compare
    assert len(replays(compare)) == 3


@pytest.mark.parametrize("case", ["missing", "empty folder", "a file", "out folder missing", "out under a file",
                                  "negative replays"])
def test_bad_input_exits_2_with_one_line(folders, tmp_path, capsys, case):
    run = str(folders["run"])
    (tmp_path / "empty").mkdir()
    (tmp_path / "file").write_text("x")
    argv = {"missing": ["report", str(tmp_path / "nope")],
            "empty folder": ["report", str(tmp_path / "empty")],
            "a file": ["report", str(tmp_path / "file")],
            "out folder missing": ["report", run, "--out", str(tmp_path / "no" / "r.html")],
            "out under a file": ["report", run, "--out", str(tmp_path / "file" / "r.html")],
            "negative replays": ["report", run, "--replays", "-1"]}[case]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("neuronav: error: "), err
    assert "report" in err or "--replays" in err
    assert "Traceback" not in err


def test_a_report_writes_over_its_own_page_only(folders, tmp_path, capsys):
    """--out over a file neuronav did not write (or a link) is refused with exit 2, the file untouched."""
    run = str(folders["run"])
    foreign, link, own = tmp_path / "notes.html", tmp_path / "link.html", tmp_path / "own.html"
    foreign.write_text("<html>someone's notes</html>")
    link.symlink_to(foreign)
    for target in (foreign, link):
        assert cli.main(["report", run, "--out", str(target)]) == 2
        assert foreign.read_text() == "<html>someone's notes</html>"
        assert "will not write over" in capsys.readouterr().err
    assert cli.main(["report", run, "--out", str(own)]) == 0
    assert cli.main(["report", run, "--out", str(own)]) == 0  # its own page again: rewritten
    assert own.read_text().count("<!DOCTYPE html>") == 1


def mitre_gaps_m(outline: np.ndarray, line: np.ndarray) -> np.ndarray:
    """For a band outline (2 V + 1, 2) about a polyline (V, 2): the distance of each side's vertex k to the
    lines through the segments that meet at vertex k of the polyline (all half the width for a mitred band)."""
    count = len(line)
    sides = (outline[:count], outline[count:2 * count][::-1])
    gaps = []
    for k in range(count):
        for segment in (k - 1, k):
            if 0 <= segment < count - 1:
                a, b = line[segment], line[segment + 1]
                direction = (b - a) / np.hypot(*(b - a))
                gaps += [abs(direction[0] * (side[k] - a)[1] - direction[1] * (side[k] - a)[0]) for side in sides]
    return np.array(gaps)


def test_band_outline_is_mitred_and_half_a_width_from_its_line():
    """A right-angle turn: each side's edges half the width from their segments, the outer corner mitred at
    (w/2)·√2 from the vertex; a repeated vertex is dropped."""
    line = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [1.0, 1.0]])
    outline = replay.band_outline(line, 0.2)
    assert outline.shape == (7, 2)
    assert mitre_gaps_m(outline, line[:3]) == pytest.approx(np.full(8, 0.1))
    assert outline[1] == pytest.approx([0.9, 0.1]) and outline[4] == pytest.approx([1.1, -0.1])  # inner, outer
    assert np.hypot(*(outline[4] - line[1])) == pytest.approx(0.1 * np.sqrt(2.0))


def test_band_outline_caps_a_line_that_turns_back_on_itself():
    """Out along x and straight back: the band keeps its width at the turn (a square cap half the width beyond
    it), where the mitre of the two cancelling normals pinched it to the vertex."""
    line = np.array([[0.0, 0.0], [1.0, 0.0], [0.2, 0.0]])
    outline = replay.band_outline(line, 0.2)
    turn = outline[[1, 4]]  # the turn's vertex on the left side and on the right
    assert np.hypot(*(turn - line[1]).T) == pytest.approx([0.1, 0.1])
    assert turn[:, 0] == pytest.approx([1.1, 0.9])  # ahead of the turn on one side, behind it on the other
    assert np.isfinite(outline).all() and outline[:, 1].max() == pytest.approx(0.1)


WORLD_RUNS = {  # scenario -> (tiny settings, the world's traces its replay must draw)
    "visual-compass": (["--set", "duration_s=1.3"], {"objects_m"}),
    "odour-trail": (["--set", "timeout_s=1.3"], {"trail_m", "trail_m band", "finish_line_m"}),
    "cue-integration": (["--set", "timeout_s=1.28", "--set", "trees=6", "--set", "snapshots=4"],
                        {"objects_m", "nest_m", "snapshots_m"}),
    "plume-tracking": (["--set", "timeout_s=0.7", "--set", "warmup_s=0.5"], {"puffs_m", "source", "plume_raster"}),
    # The route is the same in every trial: every trial's replay draws it, not the first one's only.
    "route-following": (["--set", "route_m=2", "--set", "duration_s=2", "--set", "n_kc=500",
                         "--set", "landscape=false"], {"route_m", "objects_m", "goal_m"}),
}


@pytest.mark.parametrize("scenario", sorted(WORLD_RUNS))
def test_replay_draws_the_recorded_world(scenario, tmp_path):
    """Each trial records its world (objects as x, y, radius_m; trails; the plume raster with its axes), and
    the replay draws it by name, in world coordinates: objects as circles of their radius."""
    import h5py

    settings, expected = WORLD_RUNS[scenario]
    out = tmp_path / "run"
    assert cli.main(["run", scenario, "--trials", "2", *settings, "--backend", "kinematic", "--no-figures",
                     "--no-progress", "--out", str(out), "--report"]) == 0
    with h5py.File(out / "timeseries.h5") as h5:
        recorded = {name: h5[name][()] for name in h5}
    figures = replays((out / "report.html").read_text())
    assert len(figures) == 2
    for trial, figure in enumerate(figures):
        names = {trace["name"] for trace in figure["data"]}
        assert expected <= names, (scenario, trial, expected - names)
        if "objects_m" in expected:
            objects = recorded["objects_m"][trial]
            assert objects.shape[1] == 3 and np.isfinite(objects).all()
            drawn = next(t for t in figure["data"] if t["name"] == "objects_m")
            x = np.array([np.nan if v is None else v for v in drawn["x"]], float)
            first = x[: np.flatnonzero(np.isnan(x))[0]]  # the first circle
            centre_x, _, radius_m = objects[0]
            to_cm = 0.006  # drawn to the mm, to the cm when turning (the compass's scene, at yaw 0 at first)
            assert (first.min(), first.max()) == pytest.approx((centre_x - radius_m, centre_x + radius_m), abs=to_cm)
    if scenario == "visual-compass":  # its five objects 13-17 m away: the cylinder (r 2 m) 14 m off, the ball (r 3 m)
        objects = recorded["objects_m"][1]
        assert np.hypot(objects[:, 0], objects[:, 1]) == pytest.approx([14.0, 13.0, 16.0, 17.0, 15.0])
        assert objects[:, 2] == pytest.approx([2.0, 3.0, 3.0, 2.0, 3.6])  # boxes: the larger half-extent
        # The scene turns (counter-clockwise about the origin): the last frame draws them turned by the last yaw.
        index = next(i for i, t in enumerate(figures[1]["data"]) if t["name"] == "objects_m")
        last = figures[1]["frames"][-1]
        drawn = last["data"][last["traces"].index(index)]
        yaw = recorded["scene_yaw_rad"][1][np.isfinite(recorded["scene_yaw_rad"][1])][-1]
        assert abs(yaw) > 0.005
        x = np.array([np.nan if v is None else v for v in drawn["x"]], float)
        y = np.array([np.nan if v is None else v for v in drawn["y"]], float)
        end = np.flatnonzero(np.isnan(x))[0]
        centre = ((x[:end].min() + x[:end].max()) / 2, (y[:end].min() + y[:end].max()) / 2)
        turned = (objects[0, 0] * np.cos(yaw) - objects[0, 1] * np.sin(yaw), objects[0, 0] * np.sin(yaw)
                  + objects[0, 1] * np.cos(yaw))
        assert centre == pytest.approx(turned, abs=0.02)
    if scenario == "odour-trail":  # the trail drawn as wide as it is, about its centre line
        width_m, centre = recorded["trail_width_m"][0], recorded["trail_m"][0]
        band = next(t for t in figures[0]["data"] if t["name"] == "trail_m band")
        outline = np.column_stack([band["x"], band["y"]]).astype(float)
        assert width_m == pytest.approx(0.27)  # the scenario's default ("normal") trail
        assert len(outline) == 2 * len(centre) + 1 and (outline[0] == outline[-1]).all()
        # Each side runs half the width from the centre line's segments (mitred at the trail's turns).
        gaps = mitre_gaps_m(outline, centre)
        assert gaps == pytest.approx(np.full(len(gaps), width_m / 2), abs=1e-9)
    if scenario == "plume-tracking":  # the snapshot lies under the path over the arena (8 x 4 m), row 0 at the top
        x_m, y_m = recorded["plume_raster_x_m"][0], recorded["plume_raster_y_m"][0]
        assert x_m.shape == (recorded["plume_raster"].shape[2],) and y_m[0] > y_m[-1]
        image = next(i for i in figures[0]["layout"]["images"] if i["xref"] == "x")
        assert image["sizex"] == pytest.approx(8.0) and image["sizey"] == pytest.approx(4.0)
        assert image["x"] == pytest.approx(0.0) and image["y"] == pytest.approx(2.0)


def test_replay_draws_every_agents_path_and_moves_their_cursors():
    """A swarm's (A, T, 2) positions: one line per agent (None between them), cursors at each agent's place."""
    t = np.linspace(0.0, 1.0, 50)
    swarm = np.stack([np.c_[t + k, 2.0 * t] for k in range(3)])  # (3 agents, 50, 2)
    series = {"position_m": np.c_[t, t][None], "swarm_position_m": swarm[None]}
    fig = replay.figure(replay.trial_data(series, 0))
    paths = next(trace for trace in fig["data"] if trace["name"] == "agents' paths")
    assert paths["x"].count(None) == 3
    first = paths["x"][:paths["x"].index(None)]
    assert first == pytest.approx(t.tolist())
    index = next(i for i, trace in enumerate(fig["data"]) if trace["name"] == "agents")
    last = fig["frames"][-1]
    assert last["data"][last["traces"].index(index)]["x"] == pytest.approx([1.0, 2.0, 3.0])


def test_replay_draws_a_map_with_decreasing_y_row_0_at_the_top():
    """A map whose y axis decreases (a plume raster: row 0 at the largest y) is drawn with row 0 at the top."""
    import io

    from PIL import Image

    n = 20
    raster = np.zeros((4, 6))
    raster[0] = 1.0  # the largest y
    series = {"position_m": np.c_[np.linspace(0, 5, n), np.zeros(n)][None], "plume_raster": raster[None],
              "plume_raster_x_m": np.arange(6.0)[None] + 0.5, "plume_raster_y_m": np.array([[1.5, 0.5, -0.5, -1.5]])}
    data = replay.trial_data(series, 0)
    assert [name for name, *_ in data.world_maps] == ["plume_raster"] and not data.images
    image = replay.figure(data)["layout"]["images"][0]
    assert (image["x"], image["y"], image["sizex"], image["sizey"]) == (0.0, 2.0, 6.0, 4.0)
    png = np.asarray(Image.open(io.BytesIO(base64.b64decode(image["source"].split(",", 1)[1]))).convert("L"), float)
    assert png[0].mean() < png[-1].mean() - 50  # the top row dark (high in "Blues"), the bottom light


def test_replay_draws_a_3d_path_from_above_beside_its_world_lines():
    """A body's ``position_m`` (T, 3) (locomotion) is its path seen from above; ``wall_line_m`` a world line."""
    n = 30
    series = {"position_m": np.c_[np.linspace(0, 0.5, n), np.zeros(n), np.full(n, 0.4)][None],
              "wall_line_m": np.array([[[1.0, -1.0], [1.0, 1.0]]]), "trail_m": np.c_[np.zeros(n), np.arange(n)][None]}
    data = replay.trial_data(series, 0)
    assert data.path_name == "position_m" and data.path.shape == (n, 2)
    assert [name for name, _ in data.world_lines] == ["wall_line_m", "trail_m"]  # a trail as long as the path too
    assert not data.panels


def test_replay_heading_tick_is_clockwise_from_plus_y():
    """The heading tick follows the backends' convention (clockwise from +y): heading 0 points up, pi/2 right."""
    n = 10
    series = {"position_m": np.c_[np.zeros(n), np.linspace(0, 1, n)][None],
              "heading_rad": np.r_[np.zeros(n // 2), np.full(n - n // 2, np.pi / 2)][None]}
    fig = replay.figure(replay.trial_data(series, 0))
    first, last = fig["frames"][0]["data"][0], fig["frames"][-1]["data"][0]
    assert first["x"][1] == pytest.approx(first["x"][0]) and first["y"][1] > first["y"][0]  # up
    assert last["x"][1] > last["x"][0] and last["y"][1] == pytest.approx(last["y"][0])  # right


def test_replay_breaks_angle_traces_at_wraps_and_tells_named_points_apart():
    """A compass heading that turns twice round: its line has a gap at each ±180° crossing, no stroke across
    the panel; a nest and a turn-back point get stars of different colours."""
    n = 300
    t = np.linspace(0, 10, n)
    series = {"position_m": np.c_[t, 0 * t][None], "time_s": t[None],
              "compass_heading_rad": np.linspace(0.0, 4 * np.pi, n)[None],
              "nest_m": np.zeros((1, 2)), "turnback_m": np.array([[5.0, 1.0]])}
    fig = replay.figure(replay.trial_data(series, 0))
    line = next(trace for trace in fig["data"] if trace.get("name") == "compass_heading_rad")
    y = line["y"]
    if isinstance(y, dict):  # plotly's typed array: base64 of the numbers
        y = np.frombuffer(base64.b64decode(y["bdata"]), dtype=y["dtype"])
    y = np.array([np.nan if v is None else v for v in y], float)
    assert np.isnan(y).sum() == 2
    steps = np.abs(np.diff(y))
    assert np.all(steps[np.isfinite(steps)] < np.pi) and np.nanmax(np.abs(y)) <= np.pi
    stars = {trace["name"]: trace["marker"]["color"] for trace in fig["data"] if trace.get("name") in
             ("nest_m", "turnback_m")}
    assert len(stars) == 2 and stars["nest_m"] != stars["turnback_m"]


def test_report_leaves_out_videos_still_being_written(tmp_path):
    from neuronav.runs.report.loader import finished_videos

    for name in ("trial0.mp4", "trial0.outbound.partial.mp4", "trial0.partial.mp4"):
        (tmp_path / name).write_bytes(b"")
    assert [path.name for path in finished_videos(tmp_path)] == ["trial0.mp4"]


def test_report_says_why_a_video_failed(tmp_path):
    """A run whose video failed (``video_error`` in its summary) says why in the report's run table."""
    from types import SimpleNamespace

    from neuronav.runs.report.tables import run_facts

    reason = "trial0.mp4 stopped at 0.14 s of the trial after 2 frames: OSError: disk full"
    run = SimpleNamespace(summary={"scenario": "plume-tracking", "trials": 2, "video_error": reason}, settings={})
    assert "video error" in run_facts(run) and "disk full" in run_facts(run)
    run.summary.pop("video_error")
    assert "video error" not in run_facts(run)
