"""Sweeps: chunking, the local pool against a Dask cluster, failures and crashes, resuming."""

import csv
import json
import os
from dataclasses import dataclass

import numpy as np
import pytest

from neuronav.config import field
from neuronav.errors import ConfigError, SimulationError
from neuronav.runs.rundir import list_parts, read_part
from neuronav.runs.runner import merge_timeseries, run_scenario
from neuronav.runs.scenario import Scenario, ScenarioResult
from neuronav.runs.sweep import chunk_size_for, execute, plan_chunks, run_sweep
from neuronav.runs.trials import pad_value

SHORT = {"outbound_steps": 100, "inbound_steps": 100, "record_trials": 2}


def read_rows(path):
    with open(path) as stream:
        return list(csv.DictReader(stream))


# -- a test-only scenario: failures on demand --------------------------------------------------------

@dataclass
class FlakyConfig:
    raise_seed: int = field(-1, "this trial raises")
    diverge_seed: int = field(-1, "this trial reports a divergence")
    crash_seed: int = field(-1, "this trial kills its worker process (never the test's own process)")
    parent_pid: int = field(0, "the test's process id", min=0)


class Flaky(Scenario):
    """Trial with seed s has metric ``value`` = 2 s and a time series of 3 samples of s."""

    name = "flaky"
    description = "test-only"
    config_type = FlakyConfig
    backends = ("kinematic",)
    default_backend = "kinematic"

    def run(self, config, *, backend, trials, seed, video_path=None):
        seeds = [seed + i for i in range(trials)]
        if config.raise_seed in seeds:
            raise ValueError(f"boom at seed {config.raise_seed}")
        if config.crash_seed in seeds and os.getpid() != config.parent_pid:
            os._exit(3)
        rows = []
        for i, s in enumerate(seeds):
            diverged = s == config.diverge_seed
            rows.append({"trial": i, "seed": s, "success": not diverged, "status": "failed" if diverged else "ok",
                         "error": "diverged: value not finite" if diverged else "",
                         "value": float("nan") if diverged else 2.0 * s})
        series = {"samples": np.repeat(np.array(seeds, float)[:, None], 3, axis=1),
                  "first_two": np.array(seeds[:2], float)}
        return ScenarioResult(trials=rows, timeseries=series, aggregates={"count": float(trials)},
                              simulated_time_s=1.0)

    def figures(self, result, config, out_dir):
        return []


# -- planning ------------------------------------------------------------------------------------------

def test_chunk_size_keeps_every_worker_busy_and_one_worker_batches_everything():
    assert chunk_size_for(1000, points=1, workers=1) == 1000  # one batch, in process
    assert chunk_size_for(1000, points=1, workers=2) == 125  # 8 tasks: 4 per worker
    assert chunk_size_for(100, points=10, workers=2) == 100  # 10 points are tasks enough
    assert chunk_size_for(10, points=1, workers=8) == 1
    assert chunk_size_for(1000, points=1, workers=2, hint=10) == 10  # a scenario's cap
    assert chunk_size_for(1000, points=1, workers=2, requested=7) == 7


def test_chunks_are_cut_at_multiples_of_the_chunk_size():
    assert plan_chunks(range(10), 4) == [(0, 4), (4, 4), (8, 2)]
    # Resuming with trials 2, 5 and 6 done computes the chunks an uninterrupted run would have.
    assert plan_chunks([0, 1, 3, 4, 7, 8, 9], 4) == [(0, 2), (3, 1), (4, 1), (7, 1), (8, 2)]


def test_merge_timeseries_joins_chunks_in_trial_order():
    pieces = [
        (3, 3, {"x": np.arange(3.0) + 3, "head": np.array([30.0]), "fixed": np.zeros(5)}),
        (0, 3, {"x": np.arange(3.0), "head": np.array([0.0, 1.0]), "fixed": np.ones(5)}),
    ]
    merged = merge_timeseries(pieces, 7)
    np.testing.assert_array_equal(merged["x"][:6], np.arange(6.0))
    assert np.isnan(merged["x"][6])  # no chunk covered trial 6
    np.testing.assert_array_equal(merged["head"], [0.0, 1.0])  # the prefix up to the first gap
    np.testing.assert_array_equal(merged["fixed"], np.ones(5))  # not per trial: the first chunk's


def one_batch(rows):
    """What one batch writes for these trials: NaN-padded to the longest (float rows)."""
    longest = max(len(r) for r in rows)
    out = np.full((len(rows), longest), np.nan)
    for i, r in enumerate(rows):
        out[i, :len(r)] = r
    return out


def test_merge_pads_chunks_of_unequal_length_to_the_file_of_one_batch():
    trials = [np.arange(n, dtype=float) for n in (2, 5, 3, 1)]  # per-cycle logs of unequal length
    pieces = [(0, 2, {"x": one_batch(trials[:2]), "code": np.array([[1, 2, 0], [3, 4, 5]], np.int16)}),
              (2, 2, {"x": one_batch(trials[2:]), "code": np.array([[6], [7]], np.int16)})]
    problems = []
    merged = merge_timeseries(pieces, 4, problems=problems)
    expected = one_batch(trials)
    assert merged["x"].shape == expected.shape and merged["x"].dtype == expected.dtype
    np.testing.assert_array_equal(merged["x"], expected)  # NaN where NaN
    assert merged["code"].dtype == np.int16  # integers keep their type, padded with pad_value: 0
    np.testing.assert_array_equal(merged["code"], [[1, 2, 0], [3, 4, 5], [6, 0, 0], [7, 0, 0]])
    assert problems == []
    assert np.isnan(pad_value(np.float32)) and pad_value(np.int64) == 0 and pad_value(bool) is False


def test_merge_keeps_a_leading_series_of_the_first_k_trials_whatever_the_chunking():
    def chunk(first, count, recorded):
        rows = np.arange(first, first + min(count, recorded), dtype=float)[:, None] * np.ones(3)
        return first, count, {"activity": rows, "route": np.ones((1, 4))}

    leading = {"activity": 2, "route": 1}
    for chunks in ([(0, 5)], [(0, 3), (3, 2)], [(t, 1) for t in range(5)]):
        merged = merge_timeseries([chunk(f, c, 2) for f, c in chunks], 5, leading)
        np.testing.assert_array_equal(merged["activity"], [[0.0] * 3, [1.0] * 3])
        np.testing.assert_array_equal(merged["route"], np.ones((1, 4)))
    empty = merge_timeseries([(0, 2, {"activity": np.zeros((0, 3))})], 2, {"activity": 0})
    assert empty["activity"].shape == (0, 3)  # as one batch with nothing recorded writes it


def test_merge_names_what_it_cannot_join_instead_of_dropping_it_silently(capsys):
    pieces = [(0, 1, {"ragged": np.zeros((1, 2)), "scene": np.zeros(3)}),
              (1, 1, {"ragged": np.zeros((1, 2, 2)), "scene": np.ones(3)})]
    problems = []
    merged = merge_timeseries(pieces, 2, problems=problems)
    assert "ragged" not in merged and any(p.startswith("ragged: left out") for p in problems)
    np.testing.assert_array_equal(merged["scene"], np.zeros(3))
    assert any(p.startswith("scene: not per trial and not the same") for p in problems)
    merge_timeseries(pieces, 2)  # without a list to fill: a warning on stderr
    assert "neuronav: warning: time series ragged: left out" in capsys.readouterr().err


# -- failures ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("workers", [1, 2])
def test_a_trial_that_raises_or_diverges_is_recorded_and_the_rest_finish(tmp_path, workers):
    summary = run_sweep(Flaky(), {"diverge_seed": [-1, 5]}, trials=8, seed=1, chunk_size=3, workers=workers,
                        overrides={"raise_seed": 4}, out_dir=tmp_path, progress=False)
    assert summary["total_trials"] == 16 and summary["failed_trials"] == 1 + 2
    rows = read_rows(tmp_path / "trials.csv")
    assert [(r["diverge_seed"], r["trial"]) for r in rows] == [(d, str(t)) for d in ("-1", "5") for t in range(8)]
    by_seed = {(r["diverge_seed"], int(r["seed"])): r for r in rows}
    for point in ("-1", "5"):
        raised = by_seed[(point, 4)]
        assert raised["status"] == "failed" and raised["error"] == "ValueError: boom at seed 4"
        assert raised["success"] == "False"
    assert by_seed[("5", 5)]["status"] == "failed" and by_seed[("5", 5)]["error"] == "diverged: value not finite"
    finished = [r for r in rows if r["status"] == "ok"]
    assert len(finished) == 13 and all(float(r["value"]) == 2 * int(r["seed"]) for r in finished)
    # The chunk with the raising trial (seeds 4..6 = trials 3..5) fell back to one trial at a time:
    # its other trials kept their time series.
    point = json.loads((tmp_path / "diverge_seed=-1" / "summary.json").read_text())
    assert point["trials"] == 8 and point["failed_trials"] == 1
    import h5py

    with h5py.File(tmp_path / "diverge_seed=-1" / "timeseries.h5") as store:
        samples = store["samples"][:]
    assert samples.shape == (8, 3)
    np.testing.assert_array_equal(samples[[0, 1, 2, 4, 5, 6, 7], 0], [1, 2, 3, 5, 6, 7, 8])
    assert np.isnan(samples[3]).all()


def test_a_trial_that_kills_its_worker_is_recorded_and_the_rest_finish(tmp_path):
    summary = run_sweep(Flaky(), {"crash_seed": [3]}, trials=6, seed=0, chunk_size=3, workers=2,
                        overrides={"parent_pid": os.getpid()}, out_dir=tmp_path, progress=False)
    rows = read_rows(tmp_path / "trials.csv")
    assert [int(r["trial"]) for r in rows] == list(range(6))
    crashed = [r for r in rows if r["status"] != "ok"]
    assert [r["seed"] for r in crashed] == ["3"]
    assert crashed[0]["error"].startswith("WorkerDied: the worker process running this trial died")
    assert summary["failed_trials"] == 1


def test_run_trials_records_a_failed_batch_trial_by_trial():
    from neuronav.runs.runner import run_trials

    result = run_trials(Flaky(), FlakyConfig(raise_seed=2), "kinematic", 4, 0)
    assert [t["status"] for t in result.trials] == ["ok", "ok", "failed", "ok"]
    assert result.timeseries["samples"].shape == (4, 3) and np.isnan(result.timeseries["samples"][2]).all()


# -- local pool against Dask -------------------------------------------------------------------------

def test_local_pool_and_dask_cluster_give_identical_trials(tmp_path):
    distributed = pytest.importorskip("distributed")
    options = dict(trials=6, seed=3, overrides=SHORT, chunk_size=2, progress=False, figures=False)
    run_sweep("path-integration", ["noise=0.0,0.2"], workers=2, out_dir=tmp_path / "pool", **options)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, host="127.0.0.1",
                                  protocol="tcp", dashboard_address=None) as cluster:
        summary = run_sweep("path-integration", ["noise=0.0,0.2"], scheduler=cluster.scheduler_address,
                            out_dir=tmp_path / "dask", **options)
    assert summary["total_trials"] == 12 and summary["failed_trials"] == 0
    pool, dask = read_rows(tmp_path / "pool" / "trials.csv"), read_rows(tmp_path / "dask" / "trials.csv")
    assert len(pool) == 12 and pool == dask  # every column of every trial, to the last digit
    assert len(list_parts(tmp_path / "dask" / "parts" / "noise=0.2")) == 3


# -- resuming ------------------------------------------------------------------------------------------

def test_a_rerun_skips_finished_trials_and_recomputes_only_lost_ones(tmp_path):
    options = dict(trials=6, seed=0, overrides=SHORT, chunk_size=2, workers=1, progress=False,
                   out_dir=tmp_path, figures=False)
    first = run_scenario("path-integration", **options)
    assert first["trials"] == 6 and first["chunks"] == 3 and first["resumed_trials"] == 0
    parts = {path.name: path.stat().st_mtime_ns for _, _, path in list_parts(tmp_path / "parts")}
    before = read_rows(tmp_path / "trials.csv")
    (tmp_path / "parts" / "trials-000002-000003.npz").unlink()  # lose one chunk
    (tmp_path / "parts" / ".trials-000004-000005.npz.x1.tmp").write_bytes(b"half a file")  # a killed writer
    second = run_scenario("path-integration", **options)
    assert second["resumed_trials"] == 4
    after = {path.name: path.stat().st_mtime_ns for _, _, path in list_parts(tmp_path / "parts")}
    assert after.keys() == parts.keys()
    assert all(after[n] == parts[n] for n in parts if n != "trials-000002-000003.npz")
    assert not list((tmp_path / "parts").glob(".*.tmp"))
    assert read_rows(tmp_path / "trials.csv") == before  # the same chunk gives the same numbers
    third = run_scenario("path-integration", **options)
    assert third["resumed_trials"] == 6


def test_a_rerun_with_other_settings_is_refused(tmp_path):
    options = dict(trials=2, seed=0, chunk_size=1, workers=1, progress=False, out_dir=tmp_path, figures=False)
    run_scenario("path-integration", overrides=SHORT, **options)
    with pytest.raises(ConfigError, match=r"holds results with other settings \(config.noise: 0.1 there, 0.3 now\)"):
        run_scenario("path-integration", overrides=dict(SHORT, noise=0.3), **options)
    with pytest.raises(ConfigError, match=r"\(trials: 2 there, 3 now\)"):
        run_scenario("path-integration", overrides=SHORT, **dict(options, trials=3))
    with pytest.raises(ConfigError, match=r"\(kind: 'run' there, 'sweep' now\)"):
        run_sweep("path-integration", {"noise": [0.1]}, overrides=SHORT, **options)
    # Workers, chunk size and scheduler are not settings of the results: a rerun with others resumes.
    assert run_scenario("path-integration", overrides=SHORT, **dict(options, workers=2, chunk_size=2))[
        "resumed_trials"] == 2


def test_parts_hold_rows_with_global_trial_numbers_and_seeds(tmp_path):
    execute(Flaky(), trials=5, seed=10, chunk_size=2, out_dir=tmp_path, progress=False)
    found = list_parts(tmp_path / "parts")
    assert [(first, count) for first, count, _ in found] == [(0, 2), (2, 2), (4, 1)]
    rows, series, meta = read_part(found[1][2])
    assert [(r["trial"], r["seed"]) for r in rows] == [(2, 12), (3, 13)]
    assert series["samples"].shape == (2, 3) and meta["aggregates"] == {"count": 2.0}
    summary = json.loads((tmp_path / "summary.json").read_text())
    # An over-all-trials aggregate cannot be combined from chunks without the scenario's help.
    assert "aggregates_note" in summary and "count" not in summary["metrics"]


@pytest.mark.parametrize("kwargs, message", [
    (dict(workers=0), "workers must be a positive integer, got 0"),
    (dict(chunk_size=-1), "chunk size must be a positive integer"),
    (dict(scheduler="localhost:8786"), "--scheduler expects an address like tcp://HOST:PORT"),
    (dict(grid={"noise": []}), "--grid 'noise' has no values"),
    (dict(grid={"noise": [0.1, 0.10]}), "--grid 'noise' lists the value 0.1 twice"),
    (dict(grid={"nois": [0.1]}), "unknown key 'nois'"),
    (dict(grid={"noise": [2.0]}), "key 'noise' must be <= 1.0"),
    (dict(grid={"noise": [0.1]}, overrides=["noise=0.2"]), "key 'noise' is in both --grid and --set"),
])
def test_bad_sweep_input_is_a_clear_error_before_anything_runs(tmp_path, kwargs, message):
    with pytest.raises(ConfigError, match=message):
        execute("path-integration", out_dir=tmp_path / "out", **{"grid": {"noise": [0.1]}, **kwargs})
    assert not (tmp_path / "out").exists()


def test_a_scenario_returning_the_wrong_number_of_rows_fails_its_trials(tmp_path):
    class Short(Flaky):
        def run(self, config, *, backend, trials, seed, video_path=None):
            result = super().run(config, backend=backend, trials=trials, seed=seed)
            if trials > 1:
                raise SimulationError("batch refused")
            result.trials = []
            return result

    summary = execute(Short(), trials=2, out_dir=tmp_path, progress=False)
    assert summary["failed_trials"] == 2
    assert read_rows(tmp_path / "trials.csv")[0]["error"].startswith("SimulationError: scenario 'flaky' returned 0")


def test_the_progress_bar_counts_trials_and_failures_and_is_off_without_a_terminal(monkeypatch):
    import io

    from neuronav.runs.progress import Progress, progress_enabled

    monkeypatch.delenv("NEURONAV_PROGRESS", raising=False)
    stream = io.StringIO()
    monkeypatch.setattr("sys.stderr", stream)
    assert not progress_enabled()  # not a terminal
    with Progress(10, done=2) as bar:
        bar.advance(3, failed=1)
    assert stream.getvalue() == "" and (bar.done, bar.failed) == (5, 1)
    monkeypatch.setenv("NEURONAV_PROGRESS", "1")
    with Progress(10, done=2, description="demo") as bar:
        bar.advance(3, failed=1)
    drawn = stream.getvalue()
    assert "demo" in drawn and "5/10" in drawn and "failed=1" in drawn


def test_sweep_figure_leaves_out_metrics_undefined_everywhere():
    from neuronav.runs.sweep import plotted_metrics

    rows = [{"trial": i, "seed": i, "status": "ok", "error": "", "adhesion_n": a, "climb_m": a / 100.0,
             "turn_rate": float("nan"), "label": "x"} for i, a in enumerate((0.0, 120.0))]
    rows.append({"trial": 2, "seed": 2, "status": "failed", "error": "boom", "adhesion_n": 200.0})
    assert plotted_metrics([r for r in rows if r["status"] == "ok"], ["adhesion_n"]) == ["climb_m"]


def figure_rows(x_values, metrics=15, series=("a", "b")):
    rows = []
    for x in x_values:
        for s in series:
            for trial in range(2):
                row = {"gait": x, "terrain": s, "trial": trial, "seed": trial, "status": "ok", "error": ""}
                row.update({f"metric_{m:02d}": float(m + trial) for m in range(metrics)})
                rows.append(row)
    return rows


def test_sweep_figure_shows_every_metric_with_y_labels_and_categorical_grids_as_points():
    from neuronav.runs.sweep_figures import build_metrics_figure

    rows = figure_rows(["tripod", "wave", "ripple"])
    fig = build_metrics_figure(rows, ["gait", "terrain"])
    panels = [ax for ax in fig.axes if ax.axison]
    assert len(panels) == 15  # every metric, not the first 12
    assert [ax.get_ylabel() for ax in panels] == [f"metric_{m:02d}" for m in range(15)]
    for ax in panels:
        assert [t.get_text() for t in ax.get_xticklabels()] == ["tripod", "wave", "ripple"]
        data_lines = [container.lines[0] for container in ax.containers]  # each errorbar's data line
        assert len(data_lines) == 2 and all(len(line.get_xdata()) == 3 for line in data_lines)  # one per terrain
        for line in data_lines:
            assert line.get_linestyle() == "None" and line.get_marker() == "o"  # points: categories are not a scale
        offsets = {tuple(np.round(np.asarray(line.get_xdata(), float), 6)) for line in data_lines}
        assert len(offsets) == 2  # the two series side by side, not on top of each other
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_sweep_figure_joins_numeric_grid_values_with_lines():
    from neuronav.runs.sweep_figures import build_metrics_figure

    fig = build_metrics_figure(figure_rows([0.0, 0.1, 0.3], metrics=2, series=("a",)), ["gait", "terrain"])
    panels = [ax for ax in fig.axes if ax.axison]
    assert len(panels) == 2 and all(ax.get_ylabel() for ax in panels)
    (line,) = [container.lines[0] for container in panels[0].containers]
    assert line.get_linestyle() == "-" and list(line.get_xdata()) == [0.0, 0.1, 0.3]
    np.testing.assert_allclose(np.asarray(line.get_ydata(), float), [0.5, 0.5, 0.5])  # mean over the two trials
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_dask_cluster_with_worker_processes_runs_a_sweep(tmp_path):
    distributed = pytest.importorskip("distributed")
    options = dict(trials=4, seed=2, overrides=SHORT, chunk_size=1, progress=False, figures=False)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  protocol="tcp", dashboard_address=None) as cluster:
        summary = run_sweep("path-integration", ["noise=0.0,0.2"], scheduler=cluster.scheduler_address,
                            out_dir=tmp_path / "dask", **options)
        with distributed.Client(cluster.scheduler_address, set_as_default=False) as client:
            worker_pids = set(client.run(os.getpid).values())
    assert summary["total_trials"] == 8 and summary["failed_trials"] == 0
    rows = read_rows(tmp_path / "dask" / "trials.csv")
    assert sorted((r["noise"], int(r["trial"])) for r in rows) == [(n, t) for n in ("0.0", "0.2") for t in range(4)]
    workers = {meta["worker"].rsplit(":", 1)[1] for point in ("noise=0.0", "noise=0.2")
               for _, _, path in list_parts(tmp_path / "dask" / "parts" / point)
               for meta in [read_part(path, timeseries=False)[2]]}
    assert workers and {int(w) for w in workers} <= worker_pids and os.getpid() not in worker_pids
    run_sweep("path-integration", ["noise=0.0,0.2"], workers=1, out_dir=tmp_path / "here", **options)
    assert read_rows(tmp_path / "here" / "trials.csv") == rows  # the same numbers in other processes


def test_no_module_of_the_run_stack_imports_one_above_it():
    """runner -> sweep -> assembly -> executors -> trials: the imports point one way (no cycle)."""
    import ast
    from pathlib import Path

    import neuronav.runs

    order = ["runner", "sweep", "assembly", "executors", "trials"]
    root = Path(neuronav.runs.__file__).parent
    for i, module in enumerate(order):
        tree = ast.parse((root / f"{module}.py").read_text())
        imported = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom) and node.module}
        imported |= {alias.name for node in ast.walk(tree) if isinstance(node, ast.Import) for alias in node.names}
        above = {f"neuronav.runs.{m}" for m in order[:i]}
        assert not imported & above, (module, imported & above)


def test_a_run_that_cannot_fit_in_memory_is_refused_before_it_starts(tmp_path):
    class Hungry(Flaky):
        def estimate_bytes(self, config, trials):
            return trials * 2**40  # a TiB per trial

    with pytest.raises(ConfigError, match=r"4 trials in chunks of 4 need about 4096.0 GiB at once.*--chunk-size"):
        execute(Hungry(), trials=4, workers=1, out_dir=tmp_path / "out", progress=False)
    assert not (tmp_path / "out").exists()
    with pytest.raises(ConfigError, match="trials must be at most 1000000 per run of 'flaky', got 1000001"):
        execute(Flaky(), trials=1_000_001, out_dir=tmp_path / "out", progress=False)
    assert not (tmp_path / "out").exists()


def test_a_scenarios_check_runs_for_every_grid_point_before_anything_is_written(tmp_path):
    class Picky(Flaky):
        def check(self, config, backend):
            if config.raise_seed == 7:
                raise ConfigError("raise_seed=7 cannot run on kinematic")

    with pytest.raises(ConfigError, match="raise_seed=7 cannot run"):
        run_sweep(Picky(), {"raise_seed": [1, 7]}, trials=2, out_dir=tmp_path / "out", progress=False)
    assert not (tmp_path / "out").exists()


def test_sweep_figure_shows_each_trial_the_mean_and_its_bootstrap_interval_with_n():
    from neuronav.runs.stats import describe
    from neuronav.runs.summary_statistics import resamples_for
    from neuronav.runs.sweep_figures import build_metrics_figure

    rows = [{"gait": x, "terrain": "a", "trial": t, "seed": t, "status": "ok", "error": "", "speed": x + v}
            for x in (0.0, 1.0) for t, v in enumerate([0.0, 0.1, 0.5, 2.0])]
    fig = build_metrics_figure(rows, ["gait", "terrain"])
    (panel,) = [ax for ax in fig.axes if ax.axison]
    assert panel.get_title().startswith("speed (n = 4;")
    (bars,) = panel.containers
    low, high = describe([0.0, 0.1, 0.5, 2.0], seed=0, n_resamples=resamples_for(4))["mean_ci"]
    segment = bars.lines[2][0].get_segments()[0]  # the first point's vertical bar
    np.testing.assert_allclose([segment[0][1], segment[1][1]], [low, high])
    assert high - 0.65 != 0.65 - low  # the interval is the bootstrap's, not a symmetric ± spread
    points = np.concatenate([c.get_offsets() for c in panel.collections if len(c.get_offsets()) == 4])
    assert sorted(points[:, 1]) == sorted(r["speed"] for r in rows)  # every trial drawn
    import matplotlib.pyplot as plt

    plt.close(fig)
