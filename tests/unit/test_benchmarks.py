"""The benchmarks' quick modes: each prints CPU time next to wall time, and the locomotion benchmark's
raw side does the same walk as its loop (otherwise its loop/raw ratio measures nothing).

Nothing here is timed: the scripts run with tiny sizes and only what they print is checked.
"""

from __future__ import annotations

import functools
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"
QUICK = {
    "locomotion_speed": ("--seconds", "0.8", "--repeats", "1", "--gaits", "tripod", "--backends", "mujoco,pybullet"),
    "vision_speed": ("--frames", "2", "--seconds", "0.3", "--agents", "10", "--backends", "kinematic,mujoco",
                     "--trials", "2"),
    "path_integration_1000": ("--trials", "10", "--baseline-trials", "1", "--repeats", "1"),
    "startup": ("--repeats", "1"),
    "sweep_scaling": ("--trials", "4", "--steps", "100", "--repeats", "1", "--no-dask"),
    "dorsal_rim_read": ("--reads", "5", "--agents", "20", "--repeats", "1"),
    "step_odometer": ("--seconds", "0.5", "--repeats", "1", "--every", "1", "--homing-trials", "0"),
    "compound_eye_read": ("--reads", "2", "--agents", "20", "--repeats", "1", "--scale", "0.25",
                          "--physics-reads", "2"),
    "vector_env": ("--envs", "1000", "--steps", "3", "--single-steps", "3", "--repeats", "1"),
    "report_load": ("--trials", "3", "--steps", "100", "--repeats", "1", "--no-browser"),
    "video_cost": ("--seconds", "0.3", "--repeats", "1"),
    "binocular_read": ("--reads", "3", "--repeats", "1"),
}
NUMBER = r"(\d+(?:\.\d+)?)"


@functools.cache
def quick_run(name: str) -> subprocess.CompletedProcess:
    """The benchmark ``name`` run once in its quick mode (shared by the tests that read its output)."""
    env = dict(os.environ, MPLBACKEND="Agg", MUJOCO_GL="egl")
    return subprocess.run([sys.executable, str(BENCHMARKS / f"{name}.py"), *QUICK[name]], capture_output=True,
                          text=True, env=env, timeout=300)


def output_of(name: str) -> str:
    done = quick_run(name)
    assert done.returncode == 0, f"{name} exited {done.returncode}:\n{done.stdout}\n{done.stderr}"
    return done.stdout


@pytest.mark.parametrize("name", sorted(QUICK))
def test_benchmark_prints_cpu_and_wall_time(name):
    out = output_of(name)
    assert re.search(r"\bcpu\b", out, re.IGNORECASE), out
    assert re.search(r"\bwall\b", out, re.IGNORECASE), out


@pytest.mark.parametrize("name, verdicts", [
    ("path_integration_1000", 2),  # the speed-up and the 3 s target
    ("vision_speed", 3),  # the MuJoCo panorama and beacon targets, the forest read <= 1.5x the empty world's
    ("locomotion_speed", 1),
    ("step_odometer", 1),  # the odometer's overhead on a MuJoCo homing step
    ("dorsal_rim_read", 6),  # MuJoCo and PyBullet, three scenes each
    ("compound_eye_read", 9),  # 1000 kinematic agents' eyes, then MuJoCo's and PyBullet's, in three scenes
])
def test_single_threaded_targets_are_judged_on_cpu_time(name, verdicts):
    judged = [line for line in output_of(name).splitlines() if re.search(r"\b(met|MISSED)\b", line)]
    assert len(judged) == verdicts, judged
    assert all(re.search(r"on CPU", line) for line in judged), judged


def test_report_load_gives_the_html_size():
    out = output_of("report_load")
    size = re.search(rf"^HTML size: {NUMBER} MB", out, re.MULTILINE)
    assert size is not None and float(size.group(1)) > 1.0, out  # plotly.js alone is ~4.8 MB: it is inside
    assert re.search(rf"^report build 1\s+{NUMBER}\s+{NUMBER}\s*$", out, re.MULTILINE), out


def test_video_cost_gives_both_runs_of_each_backend_and_their_ratios():
    out = output_of("video_cost")
    for backend in ("mujoco", "pybullet"):
        rows = re.findall(rf"^{backend}\s+(no|yes)\s+{NUMBER}\s+{NUMBER}\s+{NUMBER}\s+{NUMBER}\s+{NUMBER}\s+(\d+)\s*$",
                          out, re.MULTILINE)
        assert [row[0] for row in rows] == ["no", "yes"], out
        assert int(rows[0][6]) == 0 and int(rows[1][6]) > 0, out  # the filmed run wrote frames
        assert re.search(rf"^{backend}\s+with / without video: loop {NUMBER}x, cpu {NUMBER}x, cpu \+ ffmpeg {NUMBER}x, "
                         rf"wall {NUMBER}x$", out, re.MULTILINE), out
    for measure in ("loop's CPU", "process CPU", "all CPU", "wall"):
        assert re.search(rf"^  {measure}\s+{NUMBER}x, (met|MISSED): ", out, re.MULTILINE), out


def test_compound_eye_read_counts_the_rays_objects_cost():
    """Each kinematic scene's rays intersected with objects per read, and their hits: none in the open world,
    some among the trees, never more hits than rays tested."""
    found = re.findall(r"rays intersected with objects per read: ([\d,]+) of ([\d,]+) \(([\d,]+) hits\)",
                       output_of("compound_eye_read"))
    assert len(found) == 3, found  # open, beacon, forest
    numbers = [[int(v.replace(",", "")) for v in row] for row in found]
    assert numbers[0][0] == numbers[0][2] == 0
    assert all(0 < hit <= tested <= all_rays for tested, all_rays, hit in numbers[1:]), numbers


def test_startup_gives_wall_and_cpu_seconds_per_command():
    rows = re.findall(rf"^(1 s locomotion run.*|  the same.*|neuronav list)\s+{NUMBER}\s+{NUMBER}\s*$",
                      output_of("startup"), re.MULTILINE)
    assert len(rows) == 4, rows
    assert all(float(cpu) > 0.0 for _, _, cpu in rows)  # the commands' own CPU time, not this process's


def test_sweep_scaling_gives_summed_cpu_next_to_wall():
    out = output_of("sweep_scaling")
    for variant in ("1 worker", "2 workers"):
        row = re.search(rf"^{variant}.*?\s{NUMBER}\s+{NUMBER}x\s+{NUMBER}\s+{NUMBER}x", out, re.MULTILINE)
        assert row is not None, out
        assert float(row.group(3)) > 0.0
    # two workers run the trials of one: their summed CPU time cannot be a fraction of it
    two = re.search(rf"^2 workers.*?\s{NUMBER}x\s+{NUMBER}\s+{NUMBER}x", out, re.MULTILINE)
    assert float(two.group(3)) > 0.8, out
    assert "identical per-trial results (every variant, every round): yes" in out


@pytest.mark.parametrize("backend", ["mujoco", "pybullet"])
def test_locomotion_raw_side_does_the_same_walk_as_the_loop(backend):
    out = output_of("locomotion_speed")
    row = re.search(rf"^{backend}\s+tripod\s.*?\s{NUMBER}/{NUMBER}\s+{NUMBER}/{NUMBER}\s+(yes|NO)\s*$", out,
                    re.MULTILINE)
    assert row is not None, out
    loop_m, raw_m, loop_low_m, raw_low_m = (float(row.group(i)) for i in range(1, 5))
    assert loop_m > 0.1  # the loop walked (0.8 s: a ramp-up cycle and a little more)
    assert raw_m == pytest.approx(loop_m, rel=0.05)
    assert loop_low_m > 0.35 and raw_low_m == pytest.approx(loop_low_m, rel=0.05)  # both stayed up (0.43 m at rest)
    assert row.group(5) == "yes"
    assert "SAME WALK: yes" in out


def test_binocular_read_compares_both_ways_in_both_worlds():
    out = output_of("binocular_read")
    for world in ("open", "forest"):
        for how in ("together", "one eye at a time"):
            assert re.search(rf"^{world}\s+{how}\s+{NUMBER}\s+{NUMBER}\s*$", out, re.MULTILINE), out
        assert re.search(rf"^{world}\s+together saves -?\d+% of the CPU time", out, re.MULTILINE), out


def test_every_benchmark_is_in_the_benchmarks_readmes_table():
    """benchmarks/README.md's table names every script here, with what it measures and its target."""
    listed = set(re.findall(r"^\| `(\w+\.py)` \|", (BENCHMARKS / "README.md").read_text(), re.MULTILINE))
    scripts = {path.name for path in BENCHMARKS.glob("*.py")}
    assert scripts <= listed, sorted(scripts - listed)
