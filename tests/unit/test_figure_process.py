"""The command line's figure helper (``neuronav/runs/figure_process.py``): the same figures as drawn in the
command's own process, failures reported, jobs it cannot take drawn here, and no process left behind.

Each check runs in a fresh interpreter (a subprocess with a timeout): forking the test process itself,
whose other threads may hold locks, could hang the helper.
"""

import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent("""
    import json, os, sys
    from pathlib import Path

    from neuronav.runs.figure_process import draw_figures, figure_process
    from neuronav.runs.scenario import ScenarioResult
    from neuronav.scenarios.locomotion.scenario import Locomotion

    out = Path(sys.argv[1])


    class Paths(Locomotion):
        def figures(self, result, config, out_dir):
            from neuronav.runs.plotting import new_figure, save
            out_dir.mkdir(parents=True, exist_ok=True)
            fig, ax = new_figure()
            ax.plot(*result.timeseries["position_m"][0].T, label="path")
            ax.set_title("a path")
            ax.legend()
            return [save(fig, out_dir / "path.png")]


    scenario = Paths()
    config = scenario.config_type()
    rows = [{"trial": 0, "seed": 0, "success": True, "status": "ok", "error": ""}]


    class Broken(Paths):
        def figures(self, result, config, out_dir):
            raise ValueError("no axes for you")


    class Unpicklable(Paths):
        def __init__(self):
            self.draw = lambda: None  # a lambda does not pickle: the helper cannot take this job

        def figures(self, result, config, out_dir):
            out_dir.mkdir(parents=True, exist_ok=True)
            (out_dir / "here.txt").write_text(str(os.getpid()))
            return [out_dir / "here.txt"]


    def result():
        import numpy as np
        t = np.linspace(0.0, 1.0, 50)
        series = {"time_s": t[None], "position_m": np.stack([t, 0.1 * t], 1)[None]}
        return ScenarioResult(trials=rows, timeseries=series, aggregates={}, simulated_time_s=1.0)

    report = {}
    try:
        report["here"] = [p.name for p in draw_figures(scenario, result(), config, out / "here")]
    except Exception as error:
        report["here"] = f"{type(error).__name__}: {error}"
    with figure_process() as helper:
        report["helper_pid_differs"] = helper.pid != os.getpid()
        try:
            report["helper"] = [p.name for p in draw_figures(scenario, result(), config, out / "helper")]
        except Exception as error:
            report["helper"] = f"{type(error).__name__}: {error}"
        try:
            draw_figures(Broken(), result(), config, out / "broken")
        except RuntimeError as error:
            report["broken"] = str(error)
        drawn = draw_figures(Unpicklable(), result(), config, out / "unpicklable")
        report["unpicklable_drawn_here"] = drawn[0].read_text() == str(os.getpid())
        pid = helper.pid
    try:
        os.kill(pid, 0)
        report["helper_gone"] = False
    except ProcessLookupError:
        report["helper_gone"] = True
    print(json.dumps(report))
""")


def test_the_helper_draws_the_same_figures_reports_failures_and_leaves_nothing_behind(tmp_path):
    script = tmp_path / "figures.py"
    script.write_text(SCRIPT)
    done = subprocess.run([sys.executable, str(script), str(tmp_path)], capture_output=True, text=True,
                          timeout=240, env={"MPLBACKEND": "Agg", "MUJOCO_GL": "egl", "PATH": "/usr/bin:/bin"})
    assert done.returncode == 0, done.stderr
    import json

    report = json.loads(done.stdout.strip().splitlines()[-1])
    assert report["helper_pid_differs"] and report["helper_gone"], report
    assert report["here"] == ["path.png"], report  # the figure drawn in-process
    assert report["helper"] == report["here"], report  # the same files from the helper
    for name in report["here"]:  # byte for byte
        assert (tmp_path / "helper" / name).read_bytes() == (tmp_path / "here" / name).read_bytes(), name
    assert report["broken"] == "ValueError: no axes for you", report
    assert report["unpicklable_drawn_here"] is True, report
