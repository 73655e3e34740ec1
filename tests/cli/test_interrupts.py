"""Ctrl-C: however many, to the run alone or to its whole process group (as a terminal sends it), the
run ends at once with exit 130 and one line, leaves no process behind and keeps its finished trials.

A run is started as its own process group, interrupted once it works, and must be gone well within
:data:`GONE_S` (the promise is 2 s; the margin is for a loaded machine): before the fix it waited for
every running chunk and then hung on its idle workers, or printed the workers' tracebacks.
"""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

NEURONAV = str(Path(sys.executable).with_name("neuronav"))
# A trial of about 0.1 s on kinematic: a run of 24 is still busy when its first part is written.
STEPS = ["--set", "outbound_steps=500", "--set", "inbound_steps=500"]
# A chunk of 8 such trials per worker: minutes when waited for.
BIG = ["--set", "outbound_steps=100000", "--set", "inbound_steps=100000"]
GONE_S = 10.0
INTERRUPTED = "neuronav: interrupted; finished trials are kept — rerun the same command to resume"

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")


def descendants(pid):
    """Every process below ``pid`` (from /proc)."""
    children = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                fields = Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            children.setdefault(int(fields[1]), []).append(int(entry))
    found, todo = [], [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            found.append(child)
            todo.append(child)
    return found


def alive(pid):
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] not in ("Z", "X")
    except OSError:
        return False


def interrupt(args, out, *, workers, group, times, wait_for_part):
    """Run ``neuronav ARGS``; once its workers (and the figure helper) run, and a part is written when
    ``wait_for_part``, send SIGINT ``times`` times 0.3 s apart, to the run or to its process group.

    Returns (exit status, stderr lines, the processes below the run that outlived it).
    """
    process = subprocess.Popen([NEURONAV, *args], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                               start_new_session=True)  # its own group: killpg reaches it and its children only
    below = []
    try:
        deadline = time.monotonic() + 180
        while True:
            assert process.poll() is None, process.stderr.read().decode()
            assert time.monotonic() < deadline, "the run never got to the point of the interrupt"
            below = descendants(process.pid)
            # The figure helper, and the pool's workers; a run in this process: its settings are written.
            started = len(below) >= 1 + (workers if workers > 1 else 0) and (out / "settings.json").exists()
            if started and (not wait_for_part or list(out.glob("parts/*.npz"))):
                break
            time.sleep(0.01)
        below = descendants(process.pid)
        for i in range(times):
            if i:
                time.sleep(0.3)
            if group:
                os.killpg(process.pid, signal.SIGINT)
            else:
                os.kill(process.pid, signal.SIGINT)
        stderr = wait_gone(process)
    finally:
        left = clean_up(process, below)
    return process.returncode, stderr.splitlines(), left


def wait_gone(process):
    """The stderr of ``process`` once it has ended; the test fails if it runs GONE_S more seconds."""
    try:
        process.wait(timeout=GONE_S)
    except subprocess.TimeoutExpired:
        pytest.fail(f"the run still ran {GONE_S} s after the first Ctrl-C")
    return process.stderr.read().decode()


def clean_up(process, watched):
    """Kill ``process`` (and its group) if it still runs, and every ``watched`` process that outlived it;
    return those: nothing is left behind, even when the test fails."""
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
    process.stderr.close()
    left = [pid for pid in watched if alive(pid)]
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    return left


def check_interrupted(result):
    returncode, lines, left = result
    assert (returncode, lines) == (130, [INTERRUPTED]), "\n".join(lines[-20:])
    assert left == [], "processes outlived the interrupted run"


@pytest.mark.parametrize(("group", "times"), [(True, 2), (True, 3)], ids=["group-twice", "group-thrice"])
def test_ctrl_c_ends_a_pool_run_at_once_and_keeps_its_finished_trials(tmp_path, group, times):
    out = tmp_path / "out"
    args = ["run", "path-integration", "--trials", "24", "--workers", "2", "--chunk-size", "1", *STEPS,
            "--out", str(out)]
    check_interrupted(interrupt(args, out, workers=2, group=group, times=times, wait_for_part=True))
    done = len(list(out.glob("parts/*.npz")))
    assert 1 <= done < 24
    if (group, times) != (True, 3):
        return
    rerun = subprocess.run([NEURONAV, *args, "--no-figures"], capture_output=True, text=True, timeout=300)
    assert rerun.returncode == 0, rerun.stderr
    assert f"{done} already done" in rerun.stdout  # the lock was released and the parts kept


@pytest.mark.parametrize(("workers", "group", "times"), [(1, True, 2), (2, False, 1), (2, True, 2)],
                         ids=["here-group-twice", "pool-run-once", "pool-group-twice"])
def test_ctrl_c_does_not_wait_for_a_big_chunk(tmp_path, workers, group, times):
    """A chunk of 8 long trials takes minutes; the interrupt neither waits for it nor keeps a part of it."""
    out = tmp_path / "out"
    args = ["run", "path-integration", "--trials", str(8 * workers), "--workers", str(workers), "--chunk-size",
            "8", *BIG, "--out", str(out)]
    check_interrupted(interrupt(args, out, workers=workers, group=group, times=times, wait_for_part=False))
    assert list(out.glob("parts/*.npz")) == []


def test_an_interrupt_while_a_part_is_written_does_not_wait_for_the_running_chunks(tmp_path):
    """Ctrl-C outside the wait for results (here: while the short point's part is written) leaves the
    pool's loop suspended; the run still kills the workers busy with the long points instead of
    waiting for them (about 200 000 steps: tens of seconds)."""
    signalled = tmp_path / "interrupted"
    probe = ("import pathlib, sys\n"
             "import neuronav.runs.sweep\n"
             "from neuronav.runs.cli import main\n"
             "def interrupted(*args, **kwargs):\n"
             f"    pathlib.Path({str(signalled)!r}).touch()\n"
             "    raise KeyboardInterrupt\n"
             "neuronav.runs.sweep.write_part = interrupted\n"
             "sys.exit(main(sys.argv[1:]))\n")
    args = ["sweep", "path-integration", "--grid", "outbound_steps=100,100000", "--grid", "inbound_steps=100,100000",
            "--workers", "2", "--chunk-size", "1", "--no-figures", "--out", str(tmp_path / "out")]
    process = subprocess.Popen([sys.executable, "-c", probe, *args], stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE, start_new_session=True)
    workers = []
    try:
        deadline = time.monotonic() + 180
        while not signalled.exists():
            assert process.poll() is None, process.stderr.read().decode()
            assert time.monotonic() < deadline, "the short point never finished"
            workers = descendants(process.pid) or workers
            time.sleep(0.01)
        stderr = wait_gone(process)
    finally:
        left = clean_up(process, workers)
    assert (process.returncode, stderr.splitlines()) == (130, [INTERRUPTED])
    assert left == []


@pytest.mark.slow
@pytest.mark.parametrize("times", [1, 2, 3])
@pytest.mark.parametrize("group", [True, False], ids=["group", "run"])
@pytest.mark.parametrize(("workers", "chunk"), [(1, 1), (2, 1), (1, 8), (2, 8)])
def test_every_way_of_interrupting_ends_the_run_at_once(tmp_path, workers, chunk, group, times):
    out = tmp_path / "out"
    trials, steps = (24, STEPS) if chunk == 1 else (8 * workers, BIG)
    args = ["run", "path-integration", "--trials", str(trials), "--workers", str(workers), "--chunk-size", str(chunk),
            *steps, "--out", str(out)]
    check_interrupted(interrupt(args, out, workers=workers, group=group, times=times, wait_for_part=chunk == 1))
    assert (1 if chunk == 1 else 0) <= len(list(out.glob("parts/*.npz"))) < trials
