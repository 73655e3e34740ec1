"""Benchmark: what ``--video`` costs a trial, per physics backend (issue 26).

One odour-trail trial (:func:`neuronav.scenarios.odour_trail.scenario.trail_trial`, ``variability=off``,
the normal trail, ``--seconds`` simulated seconds: the ant does not reach the trail's end in that time)
on each backend of ``--backends``, once without video and once filming the follow camera into an MP4
as ``neuronav run odour-trail --video`` does (:class:`neuronav.engine.video.VideoRecorder`, one frame
every ``VIDEO_EVERY`` control steps, 640 × 480). The two runs alternate ``--repeats`` times; the best
of each is printed:

- ``loop s``: the CPU time of the thread that runs the trial (``time.thread_time``): what the trial waits
  for. MuJoCo's follow view is rasterised on a GL thread and each frame drawn on and encoded by the video
  writer's thread and ffmpeg (:mod:`neuronav.engine.video`), beside the loop;
- ``cpu s``: this process's CPU time (``time.process_time``: every thread, the GL and writer threads too);
- ``ffmpeg s``: the encoder's CPU time (the ffmpeg subprocess imageio-ffmpeg pipes frames to, from
  ``resource.getrusage(RUSAGE_CHILDREN)`` once it has exited);
- ``wall s``: the trial's wall time (``time.perf_counter``); the verdict says how much CPU time other processes
  of the machine took meanwhile (``/proc/stat``);
- the ratios with / without video of each, and of all the CPU the video costs (``cpu s + ffmpeg s``).

Target (issue 26): recording costs at most 2 × the trial without video on MuJoCo. The verdict lines say,
per measure, "met" or "MISSED" and why. The loop's CPU time does not depend on what else runs on the
machine; the wall time does: the work beside the loop needs a free core.

Usage::

    python benchmarks/video_cost.py                      # --seconds 8 --repeats 2 --backends mujoco,pybullet
    python benchmarks/video_cost.py --seconds 0.5 --repeats 1   # quick look (tests/unit/test_benchmarks.py)
    python benchmarks/video_cost.py --in-loop                    # every frame drawn in the loop, for comparison
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"
os.environ.setdefault("MUJOCO_GL", "egl")

import argparse  # noqa: E402
import resource  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from neuronav.scenarios.odour_trail.scenario import OdourTrailConfig, trail_trial  # noqa: E402
from neuronav.scenarios.trial_loop import VIDEO_EVERY  # noqa: E402

TARGET_RATIO = 2.0  # issue 26: a filmed MuJoCo trial costs at most twice the same trial without video


def children_cpu_s() -> float:
    """CPU seconds of this process's waited-for children (the ffmpeg encoders)."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def machine_busy_s() -> float:
    """CPU seconds every process of the machine has used since boot (``/proc/stat``; NaN where there is none)."""
    try:
        with open("/proc/stat") as stat:
            user, nice, system, _, _, irq, softirq, steal = (int(v) for v in stat.readline().split()[1:9])
    except (OSError, ValueError):
        return float("nan")
    return (user + nice + system + irq + softirq + steal) / os.sysconf("SC_CLK_TCK")


def one_trial(backend: str, seconds: float, video_path: Path | None) -> dict:
    """Run one trial; its CPU (the loop's thread, the process, the encoder), wall and simulated seconds, and the
    CPU seconds other processes of the machine used meanwhile."""
    config = OdourTrailConfig(timeout_s=seconds, variability="off", antennae="fixed")
    busy, children = machine_busy_s(), children_cpu_s()
    loop, cpu, wall = time.thread_time(), time.process_time(), time.perf_counter()
    row, _ = trail_trial(config, backend, seed=0, video_path=video_path)
    run = {"loop_s": time.thread_time() - loop, "cpu_s": time.process_time() - cpu,
           "wall_s": time.perf_counter() - wall, "ffmpeg_s": children_cpu_s() - children,
           "sim_s": row["trial_time_s"]}
    run["others_s"] = max(machine_busy_s() - busy - run["cpu_s"] - run["ffmpeg_s"], 0.0)
    return run


def frames_in(path: Path) -> int:
    """The number of frames in an MP4 (imageio's ffmpeg reader)."""
    import imageio.v2 as imageio

    with imageio.get_reader(path) as reader:
        return reader.count_frames()


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=8.0, help="simulated seconds per trial")
    parser.add_argument("--repeats", type=int, default=2, help="runs of each variant (best printed)")
    parser.add_argument("--backends", default="mujoco,pybullet")
    parser.add_argument("--in-loop", action="store_true",
                        help="draw every frame in the loop's thread (the recorder's background=False: as before "
                             "the GL and writer threads took it), for comparison")
    args = parser.parse_args(argv)
    if args.in_loop:
        from neuronav.engine import video

        video.DRAW_BESIDE_LOOP = False
    folder = Path(tempfile.mkdtemp(prefix="video_cost_"))
    print(f"odour-trail trial, {args.seconds:g} s simulated, one frame every {VIDEO_EVERY} control steps "
          f"(640 x 480), best of {args.repeats} (by the loop's CPU time), {os.cpu_count()} cores")
    print(f"{'backend':10s} {'video':6s} {'loop s':>7s} {'cpu s':>7s} {'ffmpeg s':>9s} {'wall s':>7s} "
          f"{'x real time':>12s} {'frames':>7s}")
    ratios, others = {}, {}
    for backend in args.backends.split(","):
        best: dict[bool, dict] = {}
        frames = 0
        for path in (None, folder / f"{backend}_warm_up.mp4"):  # warm-up: imports, GL contexts, the overlay's text
            one_trial(backend, min(args.seconds, 0.1), path)
        for _ in range(args.repeats):
            for video in (False, True):
                path = folder / f"{backend}.mp4" if video else None
                run = one_trial(backend, args.seconds, path)
                if video:
                    frames = frames_in(path)
                if video not in best or run["loop_s"] < best[video]["loop_s"]:
                    best[video] = run
        for video in (False, True):
            run = best[video]
            print(f"{backend:10s} {'yes' if video else 'no':6s} {run['loop_s']:7.2f} {run['cpu_s']:7.2f} "
                  f"{run['ffmpeg_s']:9.2f} {run['wall_s']:7.2f} {run['sim_s'] / run['wall_s']:12.2f} "
                  f"{frames if video else 0:7d}")
        on, off = best[True], best[False]
        ratios[backend] = {"loop": on["loop_s"] / off["loop_s"], "cpu": on["cpu_s"] / off["cpu_s"],
                           "all": (on["cpu_s"] + on["ffmpeg_s"]) / (off["cpu_s"] + off["ffmpeg_s"]),
                           "wall": on["wall_s"] / off["wall_s"]}
        others[backend] = (on["others_s"], on["wall_s"])
    print()
    for backend, ratio in ratios.items():
        print(f"{backend:10s} with / without video: loop {ratio['loop']:.2f}x, cpu {ratio['cpu']:.2f}x, "
              f"cpu + ffmpeg {ratio['all']:.2f}x, wall {ratio['wall']:.2f}x")
    if "mujoco" in ratios:
        for line in verdicts(ratios["mujoco"], *others["mujoco"], in_loop=args.in_loop):
            print(line)


def verdicts(ratio: dict, others_s: float, wall_s: float, in_loop: bool = False) -> list[str]:
    """One line per measure of the MuJoCo ratios: met or MISSED against TARGET_RATIO, and why (``in_loop``: the
    frames were drawn in the loop, which waited for each)."""
    def said(value: float) -> str:
        return f"{value:.2f}x, {'met' if value <= TARGET_RATIO else 'MISSED'}"

    cores = os.cpu_count() or 1
    return [
        f"target: a filmed MuJoCo trial <= {TARGET_RATIO:g}x the trial without video",
        f"  loop's CPU  {said(ratio['loop'])}: " + ("--in-loop: the loop waits while the GL thread draws each frame, "
                                                    "this is not what it costs (see wall)" if in_loop else
                                                    "the trial's thread only takes each frame's scene and the "
                                                    "overlay's inputs"),
        f"  process CPU {said(ratio['cpu'])}: every frame is still rasterised in software (Mesa llvmpipe) and "
        "drawn on, on the GL and writer threads",
        f"  all CPU     {said(ratio['all'])}: with the encoder (ffmpeg, its own process)",
        f"  wall        {said(ratio['wall'])}: the GL thread, the writer and ffmpeg run beside the loop, on the "
        f"other core(s): other processes used {others_s:.2f} CPU s of the {cores * wall_s:.2f} the {cores} cores "
        "had during the filmed run",
    ]


if __name__ == "__main__":
    main()
