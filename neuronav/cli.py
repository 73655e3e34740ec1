"""The ``neuronav`` command line: list, run, compare, sweep.

Bad input (unknown scenario, backend not installed, bad ``--set`` key or value, a bad ``--config``
file, a run directory holding other settings) prints one line to stderr and exits 2. ``run`` and
``sweep`` are resumable: rerunning the same command skips the trials already finished.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from neuronav import registry
from neuronav.config import describe
from neuronav.errors import ConfigError, NeuronavError
from neuronav.rundir import write_atomic
from neuronav.runner import load_scenario, run_scenario


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
        p.add_argument("--out", type=Path, help="run directory")

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
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); return the exit status.

    0: done. 2: bad input, printed as one line on stderr (argparse's own usage errors exit 2 through
    SystemExit). 130: interrupted (finished trials are kept; rerun the command to resume).
    """
    argv = sys.argv[1:] if argv is None else list(argv)
    args = _parser().parse_args(argv)
    try:
        if args.command == "list":
            return _list()
        if args.command == "run":
            summary = run_scenario(args.scenario, backend=args.backend, trials=args.trials, seed=args.seed,
                                   overrides=args.overrides, out_dir=args.out, video=args.video,
                                   command=["neuronav", *argv], config_file=args.config,
                                   workers=args.workers,
                                   scheduler=args.scheduler, chunk_size=args.chunk_size,
                                   progress=args.progress, figures=args.figures)
            _print_summary(summary)
            return 0
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
    except KeyboardInterrupt:
        sys.stderr.write("neuronav: interrupted; finished trials are kept — rerun the same command to resume\n")
        return 130


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
    backends = [b.strip() for b in args.backends.split(",") if b.strip()]
    if not backends:
        raise ConfigError("--backends needs at least one backend name")
    out = args.out or Path("runs") / f"compare-{args.scenario}"
    # A scenario may need settings that make its backends comparable (one protocol for all);
    # the user's own --set still wins.
    hook = getattr(load_scenario(args.scenario), "compare_overrides", None)
    common = [f"{k}={v}" for k, v in (hook(backends) if callable(hook) else {}).items()]
    summaries = {}
    for backend in backends:
        summaries[backend] = run_scenario(args.scenario, backend=backend, trials=args.trials, seed=args.seed,
                                          overrides=[*common, *args.overrides], out_dir=out / backend,
                                          command=["neuronav", *argv], config_file=args.config)
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
    print("\n".join(lines))
    print(f"comparison: {out / 'compare.md'}")
    return 0


def _cell(value) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return "" if value is None else str(value)


def _compare_figure(rows: list[dict], metrics: list[str], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    shown = [m for m in metrics if all(isinstance(r.get(m), (int, float)) for r in rows)][:8] + ["real_time_factor"]
    fig, axes = plt.subplots(1, len(shown), figsize=(2.4 * len(shown), 3), squeeze=False)
    for ax, metric in zip(axes[0], shown):
        ax.bar([r["backend"] for r in rows], [r[metric] for r in rows], color="tab:gray")
        ax.set_title(metric, fontsize=8)
        ax.tick_params(labelsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _sweep(args: argparse.Namespace, argv: list[str]) -> int:
    from neuronav.sweep import run_sweep

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
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
