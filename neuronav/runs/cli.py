"""The ``neuronav`` command line: list, run, compare, sweep, report.

Exit status
    0: every trial ran (a trial whose ant does not reach home has ``success`` 0; it still ran).
    1: some trials failed (raised, diverged, or their worker died); their count and the first
    reason are printed on stderr, and the results of the others are written. Also 1 when the run
    ran out of memory (one line on stderr), and when ``--video``'s video failed: the trial goes on
    unfilmed and keeps its results, what was filmed stays in ``trial0.partial.mp4`` and why is in
    ``trial0.video-error.txt``, ``summary.json``'s ``video_error`` and one line on stderr.
    2: bad input, found before any trial runs and before anything is written: an unknown scenario,
    a backend that is empty, unknown, unsupported or not installed, a bad ``--set``/``--grid``/
    ``--config`` key or value, settings the scenario cannot run on that backend, more trials than
    the scenario allows, a scheduler address that is not a Dask scheduler or cannot be reached, a
    run folder that may not be written into, or one that holds results of other settings; for
    ``report``, a folder that is not a run, compare or sweep folder, or a ``--out`` that cannot be
    written. One line on stderr, no traceback.
    130: interrupted (Ctrl-C, however many: the run stops at once and its workers are killed); the
    finished trials are kept.

Run folders
    A run writes only into a folder that does not exist yet, an empty folder, or a folder a
    neuronav run made (it holds a ``.neuronav-run`` marker). ``compare`` checks its folder and each
    backend's subfolder the same way, and checks every backend before running the first.

Resuming
    ``run`` and ``sweep`` are resumable: rerunning the same command skips the trials already
    finished, and only assembles the results when all of them are. A folder whose start failed (no
    finished trial) may be reused with other settings.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
from pathlib import Path

from neuronav import registry
from neuronav.config import describe
from neuronav.errors import ConfigError, NeuronavError
from neuronav.runs import interrupts
from neuronav.runs.executors import sigint_held
from neuronav.runs.figure_process import figure_process
from neuronav.runs.rundir import check_out_dir, claim_out_dir, write_atomic
from neuronav.runs.runner import load_scenario, run_scenario
from neuronav.runs.sweep import plan, run_sweep

INTERRUPTED = "neuronav: interrupted; finished trials are kept — rerun the same command to resume\n"


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage error in one line."""

    def error(self, message: str) -> None:  # type: ignore[override]
        sys.stderr.write(f"neuronav: error: {_one_line(message)} (see {self.prog} --help)\n")
        raise SystemExit(2)


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="neuronav", description="Embodied simulation of insect navigation.")
    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    commands.add_parser("list", help="scenarios, backends (with availability), brains, bodies")

    def common(p: argparse.ArgumentParser) -> None:
        p.add_argument("scenario")
        p.add_argument("--trials", type=int, default=1, help="seeded trials (trial i uses seed S + i)")
        p.add_argument("--seed", type=int, default=0)
        p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                       help="override a scenario setting (repeatable; wins over --config)")
        p.add_argument("--config", type=Path, metavar="FILE.toml",
                       help="scenario settings from a TOML file (key = value, the keys of --set)")
        p.add_argument("--out", help="run folder: new, empty, or made by an earlier neuronav run")

    def parallel(p: argparse.ArgumentParser, workers_help: str) -> None:
        p.add_argument("--workers", type=int, help=workers_help)
        p.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="run the trials on this Dask cluster")
        p.add_argument("--chunk-size", type=int, metavar="N",
                       help="trials per task (default: a few tasks per worker)")
        p.add_argument("--no-progress", dest="progress", action="store_const", const=False, default=None,
                       help="no progress bar (it is drawn only on a terminal anyway)")
        p.add_argument("--no-figures", dest="figures", action="store_false", help="skip the figures")

    run = commands.add_parser("run", help="run a scenario and write its run directory")
    common(run)
    run.add_argument("--backend")
    run.add_argument("--video", action="store_true", help="write an MP4 of the first trial")
    parallel(run, "local worker processes (default 1: all trials in one batch, here)")

    compare = commands.add_parser("compare", help="run one scenario on several backends side by side")
    common(compare)
    compare.add_argument("--backends", required=True, help="comma-separated backend names")

    sweep = commands.add_parser("sweep", help="run a scenario over a grid of settings")
    common(sweep)
    sweep.add_argument("--backend")
    sweep.add_argument("--grid", action="append", required=True, metavar="KEY=V1,V2",
                       help="a setting and its values (repeatable; the grid is their product)")
    parallel(sweep, "local worker processes (default: the available CPUs)")

    report = commands.add_parser("report", help="one self-contained HTML page of run, compare or sweep folders")
    report.add_argument("folders", nargs="+", metavar="RUN_DIR", help="folders written by run, compare or sweep")
    report.add_argument("--out", metavar="FILE", help="the HTML file (default: RUN_DIR/report.html; several "
                        "folders: ./report.html)")
    report.add_argument("--replays", type=int, default=20, metavar="N",
                        help="trials replayed per run at most (of those with recorded time series)")
    for p in (run, compare, sweep):
        p.add_argument("--report", action="store_true", help="also write report.html into the run folder")
    return parser


def main(argv: list[str] | None = None, figure_helper: bool = False) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); return the exit status.

    0: every trial ran. 1: some trials failed (their count and the first reason on stderr; the
    results are written), or ``--video``'s video failed (why on stderr; the results are written). 2: bad
    input, one line on stderr, found before any trial runs (argparse's own usage errors exit 2 through
    SystemExit). 130: interrupted (finished trials are kept; rerun
    the command to resume).
    """
    argv = sys.argv[1:] if argv is None else list(argv)
    args = _parser().parse_args(argv)
    # The command line draws figures in a helper that imports matplotlib while the trials run.
    with contextlib.ExitStack() as stack:
        with sigint_held():  # a Ctrl-C while forking the helper is not lost
            stack.enter_context(figure_process(figure_helper and args.command != "list"
                                               and getattr(args, "figures", False)))
        return _command(args, argv)


def _command(args, argv: list[str]) -> int:
    """Run the parsed command; the exit status (see :func:`main`)."""
    try:
        if args.command == "list":
            return _list()
        if args.command == "report":
            return _report(args.folders, args.out, args.replays)
        if args.command == "run":
            summary = run_scenario(args.scenario, backend=args.backend, trials=args.trials, seed=args.seed,
                                   overrides=args.overrides, out_dir=args.out, video=args.video,
                                   command=["neuronav", *argv], config_file=args.config,
                                   workers=args.workers,
                                   scheduler=args.scheduler, chunk_size=args.chunk_size,
                                   progress=args.progress, figures=args.figures)
            _print_summary(summary)
            if args.report:
                _report([summary["out_dir"]])
            status = _failures(summary["failed_trials"], summary["trials"], summary.get("first_error", ""))
            if summary.get("video_error"):  # the trial ran and kept its results; the video asked for is missing
                sys.stderr.write(f"neuronav: the video failed (the trials' results are written): "
                                 f"{_one_line(summary['video_error'])}\n")
                return 1
            return status
        if args.command == "compare":
            return _compare(args, argv)
        return _sweep(args, argv)
    except NeuronavError as error:
        sys.stderr.write(f"neuronav: error: {_one_line(error)}\n")
        return 2
    except BrokenPipeError:  # the reader went away (``neuronav list | head``): nothing more to say
        _silence_stdout()
        return 0
    except OSError as error:  # a file system problem (disk full, permissions): one line too
        where = f" ({error.filename})" if getattr(error, "filename", None) else ""
        sys.stderr.write(f"neuronav: error: {_one_line(f'{error.strerror or error}{where}')}\n")
        return 2
    except MemoryError:
        sys.stderr.write("neuronav: error: out of memory; run fewer trials at once (--chunk-size, --workers) "
                         "or fewer trials\n")
        return 1
    except KeyboardInterrupt:
        interrupts.interrupt_seen()
        sys.stderr.write(INTERRUPTED)
        return 130


def _report(folders: list, out: str | None = None, replays: int = 20) -> int:
    """Write the HTML report of ``folders`` (:mod:`neuronav.runs.report`); print where it went."""
    from neuronav.runs.report import write_report

    if replays < 0:
        raise ConfigError(f"--replays must be 0 or more, got {replays}")
    print(f"report: {write_report(folders, out, max_replays=replays)}")
    return 0


def _failures(failed: int, total: int, first: str) -> int:
    """Exit status 1 with one line on stderr when ``failed`` of ``total`` trials failed, else 0."""
    if not failed:
        return 0
    sys.stderr.write(f"neuronav: {failed} of {total} trials failed; first: {_one_line(first or 'unknown')}\n")
    return 1


def _silence_stdout() -> None:
    """Point stdout at /dev/null so that the interpreter's final flush does not fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


def _one_line(error: BaseException | str) -> str:
    """The message on one printable line: control characters (from user input) escaped."""
    text = str(error)
    text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in text).strip()
    return text or type(error).__name__


def _list() -> int:
    print("scenarios:")
    for name in registry.names("scenario"):
        try:
            scenario = load_scenario(name)
            print(f"  {name:20s} {scenario.description} [backends: {', '.join(scenario.backends)}]")
            for key, default, text in describe(scenario.config_type):
                print(f"      --set {key}={default}  {text}")
        except NeuronavError as error:
            print(f"  {name:20s} unavailable: {error}")
    print("backends:")
    for name in registry.names("backend"):
        ok, reason = registry.availability("backend", name)
        print(f"  {name:20s} {'available' if ok else 'NOT AVAILABLE: ' + reason}")
    print("brains:")
    for name in registry.names("brain"):
        print(f"  {name}")
    print("bodies:")
    for name in registry.names("body") or ["(none registered yet)"]:
        print(f"  {name}")
    return 0


def _print_summary(summary: dict) -> None:
    metrics = ", ".join(f"{k}={v:.4g}" for k, v in summary["metrics"].items() if isinstance(v, (int, float)))
    resumed = summary.get("resumed_trials") or 0
    print(f"{summary['scenario']} on {summary['backend']}: {summary['trials']} trials "
          f"({summary['failed_trials']} failed{f', {resumed} already done' if resumed else ''}) "
          f"in {summary['wall_time_s']:.2f} s")
    print(f"  {metrics}")
    print(f"  run directory: {summary['out_dir']}")


def _compare(args: argparse.Namespace, argv: list[str]) -> int:
    backends = [b.strip() for b in args.backends.split(",")]
    if not any(backends) or not all(backends):
        raise ConfigError(f"--backends needs comma-separated backend names, got {args.backends!r}")
    if len(set(backends)) != len(backends):
        raise ConfigError(f"--backends lists a backend twice: {args.backends!r}")
    out = check_out_dir(Path("runs") / f"compare-{args.scenario}" if args.out is None else args.out, "compare")
    # A scenario may need settings that make its backends comparable (one protocol for all);
    # the user's own --set still wins.
    hook = getattr(load_scenario(args.scenario), "compare_overrides", None)
    common = [f"{k}={v}" for k, v in (hook(backends) if callable(hook) else {}).items()]
    user_keys = {str(o).split("=", 1)[0].strip() for o in args.overrides}
    common = [c for c in common if c.split("=", 1)[0] not in user_keys]
    # Every backend is checked (installed, supported, settings) before the first one runs.
    plans = [plan(args.scenario, backend=backend, trials=args.trials, seed=args.seed,
                  overrides=[*common, *args.overrides], out_dir=out / backend, command=["neuronav", *argv],
                  config_file=args.config) for backend in backends]
    claim_out_dir(out, "compare")
    summaries = {p.backend: p.run() for p in plans}
    fixed = ("backend", "trials", "failed_trials", "wall_time_s", "real_time_factor")
    metrics = sorted({k for s in summaries.values() for k in s["metrics"]} - set(fixed))
    rows = []
    for backend, s in summaries.items():
        # Compute time summed over the run's chunks: the same whether the run was resumed or not.
        compute_s = s.get("compute_time_s") or s["wall_time_s"]
        rtf = s["simulated_time_s"] * s["trials"] / compute_s if compute_s > 0 else float("nan")
        rows.append({"backend": backend, "trials": s["trials"], "failed_trials": s["failed_trials"],
                     "wall_time_s": s["wall_time_s"], "real_time_factor": rtf,
                     **{m: s["metrics"].get(m) for m in metrics}})
    columns = [*fixed, *metrics]
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    for row in rows:
        lines.append("| " + " | ".join(_cell(row[c]) for c in columns) + " |")
    write_atomic(out / "compare.md", "\n".join(lines) + "\n")
    write_atomic(out / "compare.csv", "\n".join(",".join(_cell(r[c]) for c in columns)
                                                for r in [dict(zip(columns, columns)), *rows]) + "\n")
    _compare_figure(rows, metrics, out / "compare.png")
    _compare_statistics(args.scenario, plans, summaries, out / "compare.json")
    print("\n".join(lines))
    print(f"comparison: {out / 'compare.md'}")
    if args.report:
        _report([out])
    failed = sum(s["failed_trials"] for s in summaries.values())
    first = next((f"{b} {s['first_error']}" for b, s in summaries.items() if s.get("first_error")), "")
    return _failures(failed, sum(s["trials"] for s in summaries.values()), first)


def _compare_statistics(scenario_name: str, plans: list, summaries: dict[str, dict], path: Path) -> None:
    """compare.json: each backend's statistics block, whether the backends agree on the direction of
    every effect, and a Kruskal-Wallis test of the backends' values per condition and metric."""
    import json

    from neuronav.runs.summary_statistics import across_backends, agreement

    scenario = load_scenario(scenario_name)
    blocks = {backend: s.get("statistics", {}) for backend, s in summaries.items()}
    try:
        spec = scenario.statistics(plans[0].points[0].config)
        between = across_backends({p.backend: p.rows for p in plans}, spec, timing=tuple(scenario.timing_metrics))
    except Exception as error:  # noqa: BLE001 - a scenario's bug costs the comparison's tests, not the runs
        between = {"note": f"not computed: {type(error).__name__}: {error}"}
    document = {"scenario": scenario_name, "backends": list(summaries), "statistics": blocks,
                "agreement": agreement(blocks), "across_backends": between}
    write_atomic(path, json.dumps(document, indent=2, default=_json_number) + "\n")


def _json_number(value):
    """numpy numbers in a JSON document as Python numbers."""
    return value.item() if hasattr(value, "item") else str(value)


def _cell(value) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return "" if value is None else str(value)


def _compare_figure(rows: list[dict], metrics: list[str], path: Path) -> None:
    # Imported here: matplotlib only for a command that draws. Saved as every figure is (a temporary
    # file renamed over the name), so a link standing at compare.png is replaced, not written through.
    from neuronav.runs.plotting import new_figure, save

    shown = [m for m in metrics if all(isinstance(r.get(m), (int, float)) for r in rows)][:8] + ["real_time_factor"]
    fig, axes = new_figure((2.4 * len(shown), 3), 1, len(shown), squeeze=False)
    for ax, metric in zip(axes[0], shown):
        ax.bar([r["backend"] for r in rows], [r[metric] for r in rows], color="tab:gray")
        ax.set_title(metric, fontsize=8)
        ax.tick_params(labelsize=7)
    save(fig, path)


def _sweep(args: argparse.Namespace, argv: list[str]) -> int:
    summary = run_sweep(args.scenario, args.grid, backend=args.backend, trials=args.trials, seed=args.seed,
                        overrides=args.overrides, config_file=args.config, out_dir=args.out,
                        workers=args.workers, scheduler=args.scheduler, chunk_size=args.chunk_size,
                        progress=args.progress, figures=args.figures, command=["neuronav", *argv])
    for point in summary["points"]:
        metrics = ", ".join(f"{k}={v:.4g}" for k, v in point["metrics"].items() if isinstance(v, (int, float)))
        failed = f" ({point['failed_trials']} failed)" if point["failed_trials"] else ""
        print(f"{point['dir']}{failed}: {metrics}")
    resumed = summary["resumed_trials"]
    print(f"sweep: {summary['total_trials']} trials over {len(summary['points'])} points "
          f"({summary['failed_trials']} failed{f', {resumed} already done' if resumed else ''}) "
          f"in {summary['wall_time_s']:.2f} s: {summary['out_dir']}")
    if args.report:
        _report([summary["out_dir"]])
    return _failures(summary["failed_trials"], summary["total_trials"], summary.get("first_error", ""))


def console_main() -> int:
    """The ``neuronav`` command: :func:`main`, then a quick exit.

    The young generation is collected every 50 000 allocations instead of 700: importing the
    engines and matplotlib and drawing the figures allocate millions of objects that live on, and
    walking them again and again cost 0.05 s of a 1 s run; garbage is still collected. At the end,
    ``gc.freeze()`` moves every live object out of the collector's reach, so the interpreter's last
    collections at exit do not walk the ~1300 modules' objects (0.2 s). Only for the command: a
    process that goes on after :func:`main` keeps the interpreter's own settings.

    Ctrl-C interrupts the command once (:mod:`neuronav.runs.interrupts`): exit 130 and one line on stderr,
    however many follow.
    """
    import gc

    gc.set_threshold(50_000, 20, 20)
    interrupts.install()
    try:
        return main(figure_helper=True)
    except KeyboardInterrupt:  # outside the command itself: while parsing, or starting the figure helper
        interrupts.interrupt_seen()
        sys.stderr.write(INTERRUPTED)
        return 130
    finally:
        gc.freeze()


if __name__ == "__main__":
    raise SystemExit(console_main())
