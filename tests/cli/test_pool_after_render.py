"""A pool run after a rendered trial in the same Python session: workers that do not hang.

A child forked from a process that has made a GL context deadlocks inside the driver (Mesa's
swrast under EGL); such a process spawns its workers instead (neuronav.runs.executors.pool_context).
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from neuronav.runs.executors import gl_driver_loaded

SCRIPT = textwrap.dedent("""
    import os, sys
    os.environ.setdefault("MUJOCO_GL", "egl")
    from neuronav.runs.executors import gl_driver_loaded
    from neuronav.runs.runner import run_scenario

    if __name__ == "__main__":
        out = sys.argv[1]
        settings = {"timeout_s": 1.28}
        run_scenario("visual-beacon", backend="mujoco", trials=1, overrides=settings, out_dir=out + "/alone",
                     figures=False, progress=False)
        assert gl_driver_loaded(), "the rendered trial loaded no GL driver: this test tests nothing"
        summary = run_scenario("visual-beacon", backend="mujoco", trials=2, workers=2, overrides=settings,
                               out_dir=out + "/pool", figures=False, progress=False)
        print("failed", summary["failed_trials"])
""")


def test_a_pool_started_after_rendering_runs_its_trials_instead_of_hanging(tmp_path):
    pytest.importorskip("mujoco")
    script = tmp_path / "render_then_pool.py"
    script.write_text(SCRIPT)
    try:
        done = subprocess.run([sys.executable, str(script), str(tmp_path)], capture_output=True, text=True,
                              timeout=120)
    except subprocess.TimeoutExpired:
        pytest.fail("the pool started after a rendered trial hung (forked workers deadlock in the GL driver)")
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split()[-2:] == ["failed", "0"], done.stdout


def test_the_gl_driver_is_found_in_the_memory_map(tmp_path):
    with_driver = tmp_path / "maps"
    with_driver.write_text("7f00-7f10 r-xp 00000000 08:01 1 /usr/lib/x86_64-linux-gnu/dri/swrast_dri.so\n")
    without = tmp_path / "maps-plain"
    without.write_text("7f00-7f10 r-xp 00000000 08:01 1 /usr/lib/x86_64-linux-gnu/libEGL.so.1.1.0\n")
    assert gl_driver_loaded(str(with_driver)) and not gl_driver_loaded(str(without))
    assert not gl_driver_loaded(str(tmp_path / "missing"))


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="workers are forked on Linux only")
def test_a_process_that_has_not_rendered_forks_its_workers():
    """Fork stays the default (workers start in milliseconds): in a fresh process, nothing rendered."""
    check = "from neuronav.runs.executors import pool_context; print(pool_context().get_start_method())"
    done = subprocess.run([sys.executable, "-c", check], capture_output=True, text=True, timeout=60)
    assert done.stdout.strip() == "fork", done.stderr[-2000:]
