"""Assembling a run directory from its parts: per-point results, then the sweep's table and figure.

Every finished chunk of trials is a part file (:func:`neuronav.runs.rundir.write_part`); the results a
user reads (``summary.json``, ``trials.csv``, ``timeseries.h5``, figures) are made from the parts
alone, so a run interrupted while assembling is finished by rerunning it: with every part there, a
rerun only assembles.
"""

from __future__ import annotations

import dataclasses
import json
import sys
import time
from pathlib import Path
from typing import Any

from neuronav.runs.executors import task_failure
from neuronav.runs.figure_process import draw_figures
from neuronav.runs.grid import GridPoint
from neuronav.runs.rundir import (
    PARTS_DIR,
    VIDEO_NAME,
    git_revision,
    json_default,
    list_parts,
    package_versions,
    read_part,
    trials_csv,
    write_atomic,
    write_run_directory,
)
from neuronav.runs.scenario import Scenario, ScenarioResult
from neuronav.runs.summary_statistics import run_statistics
from neuronav.runs.sweep_figures import METRICS_FIGURE, metrics_figure
from neuronav.runs.trials import leading_series, merge_timeseries


def first_failure(rows: list[dict]) -> str:
    """``"trial N: reason"`` of the first failed row, or "" when none failed."""
    for row in rows:
        if row.get("status", "ok") != "ok":
            return f"trial {row.get('trial')}: {row.get('error') or 'failed'}"
    return ""


@dataclasses.dataclass
class Assembler:
    """Where the parts of a run are and how its results are written from them."""

    scenario: Scenario
    name: str
    backend: str
    seed: int
    trials: int
    out: Path
    figures: bool
    command: list[str]
    is_sweep: bool
    wall_time_s: float = 0.0

    def parts_folder(self, point: GridPoint) -> Path:
        return self.out / PARTS_DIR / point.name if point.name else self.out / PARTS_DIR

    def point_folder(self, point: GridPoint) -> Path:
        return self.out / point.name if point.name else self.out

    def assemble(self, point: GridPoint) -> dict:
        """Write the point's summary.json, trials.csv, timeseries.h5 and figures from its parts.

        A point whose parts have not changed since its summary was written, and whose result files
        are all there, is kept as it is; a missing one is rebuilt. Time series that cannot be joined
        are named on stderr and under ``timeseries_problems`` in the summary. The returned summary
        carries the rows under ``_rows`` (not written).
        """
        parts = list_parts(self.parts_folder(point))
        names = [path.name for _, _, path in parts]
        kept = self._unchanged(point, names)
        if kept is not None:
            kept["_rows"] = self.rows(parts)
            return kept
        rows, pieces, metas = self._read(parts)
        aggregates, note = self._aggregates(rows, metas, point.config)
        simulated = max((m.get("simulated_time_s", 0.0) for m in metas), default=0.0)
        problems: list[str] = []
        leading = leading_series(self.scenario, point.config, self.backend)
        timeseries = merge_timeseries(pieces, self.trials, leading, problems)
        for line in problems:
            sys.stderr.write(f"neuronav: warning: {self.name}{' ' + point.name if point.name else ''}: "
                             f"time series {line}\n")
        result = ScenarioResult(trials=rows, timeseries=timeseries, aggregates=aggregates, simulated_time_s=simulated)
        folder = self.point_folder(point)
        folder.mkdir(parents=True, exist_ok=True)
        figure_paths, extra = self._figures(result, point, folder)
        compute_s = sum(m.get("compute_s", 0.0) for m in metas)
        extra["statistics"] = self._statistics(rows, point.config)
        from neuronav.engine.video import video_failure  # lazily: a run without video never needs it

        video_error = video_failure(folder / VIDEO_NAME)
        extra.update({
            **({"grid": point.labels} if point.labels else {}),
            "compute_time_s": compute_s, "chunks": len(parts), "parts": names,
            "figures_requested": self.figures, "first_error": first_failure(rows),
            "timeseries": sorted(timeseries), **({"timeseries_problems": problems} if problems else {}),
            **({"aggregates_note": note} if note else {}),
            **({"video_error": video_error} if video_error else {}),
        })
        summary = write_run_directory(
            folder, scenario=self.name, backend=self.backend, seed=self.seed,
            config=dataclasses.asdict(point.config), trials=rows, aggregates=aggregates,
            timeseries=result.timeseries, wall_time_s=self.wall_time_s if not self.is_sweep else compute_s,
            simulated_time_s=simulated, figures=figure_paths, command=self.command, extra=extra,
        )
        summary["_rows"] = rows
        return summary

    def _statistics(self, rows: list[dict], config: Any) -> dict:
        """The point's statistics block (:mod:`neuronav.runs.summary_statistics`), seeded by the run's seed."""
        try:
            spec = self.scenario.statistics(config)
        except Exception as error:  # noqa: BLE001 - a scenario's bug costs its statistics, not its results
            return {"note": f"the scenario's statistics() failed: {task_failure(error)}"}
        return run_statistics(rows, spec, seed=self.seed, timing=tuple(self.scenario.timing_metrics))

    def _between_points(self, points: list[GridPoint], rows: list[dict], keys: list[str]) -> dict:
        """The grid points compared, each against the first (the sweep's rows grouped by their grid
        values; the metrics the scenario compares within a run)."""
        if len(points) < 2 or not rows:
            return {}
        label = {tuple(str(p.labels[k]) for k in keys): p.name for p in points}
        # The grid's own columns are settings, not measurements.
        grouped = [{k: v for k, v in row.items() if k not in keys}
                   | {"grid_point": label[tuple(str(row[k]) for k in keys)]} for row in rows]
        try:
            spec = self.scenario.statistics(points[0].config)
        except Exception as error:  # noqa: BLE001 - a scenario's bug costs its statistics, not its results
            return {"note": f"the scenario's statistics() failed: {task_failure(error)}"}
        spec = dataclasses.replace(spec, condition="grid_point", reference=points[0].name,
                                   metrics=tuple(m for m in spec.metrics if m not in keys))
        return run_statistics(grouped, spec, seed=self.seed, timing=tuple(self.scenario.timing_metrics))

    def _unchanged(self, point: GridPoint, names: list[str]) -> dict | None:
        folder = self.point_folder(point)
        existing = folder / "summary.json"
        if not existing.exists():
            return None
        try:
            summary = json.loads(existing.read_text())
            # Every result file the summary lists must still be there; a missing one is rebuilt from the parts.
            if (summary.get("parts") == names and summary.get("figures_requested") == self.figures
                    and (folder / "trials.csv").exists() and all((folder / f).exists() for f in summary["figures"])
                    and "timeseries" in summary and (folder / "timeseries.h5").exists() == bool(summary["timeseries"])):
                return summary
        except (OSError, ValueError, KeyError, TypeError):
            pass
        return None

    @staticmethod
    def _read(parts: list[tuple[int, int, Path]]) -> tuple[list[dict], list, list[dict]]:
        rows_by_trial: dict[int, dict] = {}
        pieces, metas = [], []
        for first, count, path in parts:
            rows, series, meta = read_part(path)
            if any(row["trial"] in rows_by_trial for row in rows):
                continue  # overlapping parts (two runs raced): keep the first
            rows_by_trial.update({row["trial"]: row for row in rows})
            pieces.append((first, count, series))
            metas.append(meta)
        return [rows_by_trial[t] for t in sorted(rows_by_trial)], pieces, metas

    def _figures(self, result: ScenarioResult, point: GridPoint, folder: Path) -> tuple[list[Path], dict]:
        if not self.figures or not any(row.get("status") == "ok" for row in result.trials):
            return [], {}
        try:
            return draw_figures(self.scenario, result, point.config, folder), {}
        except Exception as error:  # noqa: BLE001 - results are kept; the figure failure is reported
            reason = task_failure(error)
            sys.stderr.write(f"neuronav: warning: figures of {self.name}"
                             f"{' ' + point.name if point.name else ''} failed: {reason}\n")
            return [], {"figure_error": reason}

    @staticmethod
    def rows(parts: list[tuple[int, int, Path]]) -> list[dict]:
        """The trial rows of ``parts`` (the first part wins where two overlap), in trial order."""
        rows: dict[int, dict] = {}
        for _, _, path in parts:
            for row in read_part(path, timeseries=False)[0]:
                rows.setdefault(row["trial"], row)
        return [rows[t] for t in sorted(rows)]

    def _aggregates(self, rows: list[dict], metas: list[dict], config: Any) -> tuple[dict, str]:
        hook = getattr(self.scenario, "aggregate", None)
        if callable(hook):
            try:
                return {k: float(v) for k, v in hook(rows, config).items()}, ""
            except Exception as error:  # noqa: BLE001
                return {}, f"the scenario's aggregate() failed: {task_failure(error)}"
        if len(metas) == 1:
            return dict(metas[0].get("aggregates", {})), ""
        names = sorted({k for m in metas for k in m.get("aggregates", {})})
        if not names:
            return {}, ""
        return {}, (f"{', '.join(names)}: over-all-trials aggregates are not combined across {len(metas)} chunks "
                    "(the scenario has no aggregate() method); metrics show per-trial means")

    def assemble_sweep(self, points: list[GridPoint], summaries: dict[int, dict], settings: dict, ran: int) -> dict:
        """The sweep's trials.csv (grid columns first), summary.json and metric figure."""
        keys = list(points[0].labels) if points else []
        all_rows, entries = [], []
        for point in points:
            summary = summaries[point.index]
            point_rows = summary.pop("_rows", [])
            all_rows += [dict(point.labels, **row) for row in point_rows]
            entries.append({"grid": point.labels, "dir": point.name, "trials": summary["trials"],
                            "failed_trials": summary["failed_trials"], "metrics": summary["metrics"],
                            "metrics_std": summary["metrics_std"], "compute_time_s": summary.get("compute_time_s"),
                            "first_error": first_failure(point_rows)})
        write_atomic(self.out / "trials.csv", trials_csv(all_rows, extra_columns=tuple(keys)))
        figures = []
        if self.figures and entries:
            try:
                figures = [metrics_figure(all_rows, keys, self.out / METRICS_FIGURE)]
            except Exception as error:  # noqa: BLE001
                sys.stderr.write(f"neuronav: warning: the sweep's metric figure failed: {task_failure(error)}\n")
        failed = sum(e["failed_trials"] for e in entries)
        first = next((f"{e['dir']} {e['first_error']}" for e in entries if e["first_error"]), "")
        between = self._between_points(points, all_rows, keys)
        summary = {
            "scenario": self.name, "backend": self.backend, "seed": self.seed, "trials": self.trials,
            "grid": settings["grid"], "config": settings["config"], "points": entries,
            "total_trials": len(all_rows), "failed_trials": failed, "first_error": first,
            "resumed_trials": len(all_rows) - ran, "wall_time_s": self.wall_time_s,
            "compute_time_s": sum(e["compute_time_s"] or 0.0 for e in entries),
            "versions": package_versions(), "git_revision": git_revision(), "command": self.command,
            "figures": [Path(f).name for f in figures], "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "statistics": between,
        }
        write_atomic(self.out / "summary.json", json.dumps(summary, indent=2, default=json_default) + "\n")
        return summary | {"out_dir": str(self.out)}
