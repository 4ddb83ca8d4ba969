"""Benchmark: speed of the DSmT particle-filter tracker (plugins.video_tracking).

Run from the repository root::

    python benchmarks/bench_tracking.py             # tables and PASS/FAIL per target
    python benchmarks/bench_tracking.py --check     # exit 1 if a target fails
    python benchmarks/bench_tracking.py --json      # machine-readable output
    python benchmarks/bench_tracking.py --quick     # fewer frames and τ values, a smoke run (targets skipped)
    python benchmarks/bench_tracking.py --data DIR  # another copy of the PETS sequence

Two parts:

(a) PETS 2009 S2.L1, frames 1-200 (480x360, 8 people, 3-8 per frame): the directory
    ``shared/data/pets09_s2l1_f0001_0200`` next to the repository (``video.avi`` and
    ``gt.txt``), or ``--data DIR``.  The targets are born and removed as with
    ``belief track --init-from-gt`` (``init_from_gt(gt.txt)``), with
    ``TrackerConfig(particles=100)``: the cues colour, location and foreground and the
    default rule.  Two figures, each in a fresh (spawned) process:

    * tracking fps (decoding excluded): every frame is decoded into memory first, then
      only ``Tracker.step`` is timed, over all frames;
    * overall fps (decoding included): the clock runs from opening the video with
      ``VideoReader`` until the last frame has been decoded and tracked.

    The mean number of live targets per frame is printed as well.  Without the data the
    part is skipped and so is its target.

(b) Synthetic scaling: 640x480 scenes of 30 frames (``scenes.SceneConfig``) with τ = 1, 2,
    4, 8, 16, 32 people on a grid, each walking slowly in its own direction in its own
    colours, all born at frame 1 from the scene's ground truth; N = 100 particles per
    target, the default cues and rule.  One fresh process per τ.  The time per frame is
    the median of ``Tracker.step`` over the frames after the first 5, which leaves out
    the first fusion frame, where the combination plan is compiled.  The table gives the
    time per frame, the time per frame per particle (τ·N), and the log-log slope of the
    time against τ from τ = 8 to 32.

Targets:

* (a) at least 50 frames per second of tracking (decoding excluded) on the PETS sequence;
* (b) the time per frame grows no faster than linearly in τ·N.  At small τ the fixed costs
  of a frame dominate (the background model, the image-wide work of the cues), so the check
  is made at the large-τ end: the time per frame per (τ·N) at τ = 32 is at most 1.5 times
  its value at τ = 8.  Equivalently, t(32) / t(8) <= 6, a log-log slope of at most 1.29.

``--quick`` tracks the first 60 PETS frames and τ = 2, 8, 32 with 15 frames each (median
over the last 10); it is a smoke run and the targets are skipped.  A full run takes under
a minute on a 2-core machine.
"""

from __future__ import annotations

import argparse
import colorsys
import json
import math
import multiprocessing
import os
import platform
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

# Measure the checkout this script belongs to, installed or not (spawned children inherit sys.path).
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

DEFAULT_DATA = Path(__file__).resolve().parent.parent.parent / "shared" / "data" / "pets09_s2l1_f0001_0200"
SEED = 0
PARTICLES = 100

FULL = {"pets_frames": None, "taus": (1, 2, 4, 8, 16, 32), "scene_frames": 30, "skip_frames": 5}
QUICK = {"pets_frames": 60, "taus": (2, 8, 32), "scene_frames": 15, "skip_frames": 5}

# Targets.
MIN_FPS = 50.0
TAU_LOW, TAU_HIGH, MAX_GROWTH = 8, 32, 1.5
MAX_SLOPE = 1.0 + math.log(MAX_GROWTH) / math.log(TAU_HIGH / TAU_LOW)

# The synthetic scenes.
SCENE_WIDTH, SCENE_HEIGHT = 640, 480
GRID_COLUMNS, GRID_ROWS = 8, 4            # 32 cells of 80 x 120 pixels
WALKER_SIZE = (20.0, 50.0)
SPEED = 0.5                               # pixels per frame


# -- (a) PETS -----------------------------------------------------------------------------------------
def pets_tracking_only(data: str, max_frames: int | None, seed: int) -> dict:
    """Runs in a fresh process: decode every frame into memory, then time ``Tracker.step`` alone."""
    import numpy as np

    from plugins.video_tracking.tracker import Tracker, TrackerConfig, init_from_gt
    from plugins.video_tracking.video import VideoReader

    folder = Path(data)
    frames = []
    with VideoReader(folder / "video.avi") as reader:
        for image in reader:
            frames.append(image)
            if max_frames is not None and len(frames) == max_frames:
                break
        decode_seconds = reader.decode_seconds
    tracker = Tracker(TrackerConfig(particles=PARTICLES), init_from_gt(folder / "gt.txt"), np.random.default_rng(seed))
    times, live = [], []
    for index, image in enumerate(frames):
        start = time.perf_counter()
        tracker.step(index + 1, image)
        times.append(time.perf_counter() - start)
        live.append(len(tracker.targets))
    height, width = frames[0].shape[:2]
    return {"frames": len(frames), "width": width, "height": height, "tracking_s": sum(times),
            "median_frame_s": statistics.median(times), "max_frame_s": max(times),
            "decode_s": decode_seconds, "mean_live": sum(live) / len(live), "min_live": min(live),
            "max_live": max(live)}


def pets_overall(data: str, max_frames: int | None, seed: int) -> dict:
    """Runs in a fresh process: open, decode and track frame by frame, all on the clock."""
    import numpy as np

    from plugins.video_tracking.tracker import Tracker, TrackerConfig, init_from_gt
    from plugins.video_tracking.video import VideoReader

    folder = Path(data)
    plan = init_from_gt(folder / "gt.txt")
    start = time.perf_counter()
    count = 0
    with VideoReader(folder / "video.avi") as reader:
        tracker = Tracker(TrackerConfig(particles=PARTICLES), plan, np.random.default_rng(seed))
        for image in reader:
            count += 1
            tracker.step(count, image)
            if max_frames is not None and count == max_frames:
                break
        decode_seconds = reader.decode_seconds
    return {"frames": count, "overall_s": time.perf_counter() - start, "decode_s": decode_seconds}


# -- (b) synthetic scaling ----------------------------------------------------------------------------
def bgr(hue: float, saturation: float, value: float) -> tuple[int, int, int]:
    r, g, b = colorsys.hsv_to_rgb(hue % 1.0, saturation, value)
    return int(round(b * 255)), int(round(g * 255)), int(round(r * 255))


def scene_config(tau: int, n_frames: int, seed: int):
    """τ walkers in distinct cells of an 8 x 4 grid, slow and far apart, in distinct colours."""
    from plugins.video_tracking.scenes import SceneConfig, Walker

    if not 1 <= tau <= GRID_COLUMNS * GRID_ROWS:
        raise ValueError(f"tau must lie in 1..{GRID_COLUMNS * GRID_ROWS}, got {tau}")
    cell_w, cell_h = SCENE_WIDTH / GRID_COLUMNS, SCENE_HEIGHT / GRID_ROWS
    # Spread the walkers over the grid: with few of them, every (32 / τ)-th cell.
    cells = sorted({round(k * GRID_COLUMNS * GRID_ROWS / tau) for k in range(tau)})
    walkers = []
    for k, cell in enumerate(cells):
        row, column = divmod(cell, GRID_COLUMNS)
        angle = 2.0 * math.pi * (k * 0.381966 % 1.0)     # golden-angle directions
        hue = k * 0.618033988749895                      # golden-ratio hues
        walkers.append(Walker(id=k + 1, first_frame=0,
                              start_centre=((column + 0.5) * cell_w, (row + 0.5) * cell_h),
                              velocity=(SPEED * math.cos(angle), SPEED * math.sin(angle)),
                              size=WALKER_SIZE, shirt=bgr(hue, 0.8, 0.85),
                              trousers=bgr(hue + 0.5, 0.6, 0.45)))
    return SceneConfig(walkers=tuple(walkers), width=SCENE_WIDTH, height=SCENE_HEIGHT, n_frames=n_frames,
                       seed=seed, name=f"bench_tau{tau}")


def synthetic(tau: int, n_frames: int, skip: int, seed: int) -> dict:
    """Runs in a fresh process: render the scene (untimed), then time ``Tracker.step`` per frame."""
    import numpy as np

    from plugins.video_tracking.scenes import render
    from plugins.video_tracking.tracker import Tracker, TrackerConfig, init_from_gt

    scene = render(scene_config(tau, n_frames, seed))
    plan = init_from_gt(scene.ground_truth, source=scene.config.name)
    tracker = Tracker(TrackerConfig(particles=PARTICLES), plan, np.random.default_rng(seed))
    times, live = [], []
    for index, image in enumerate(scene.frames):
        start = time.perf_counter()
        tracker.step(index + 1, image)
        times.append(time.perf_counter() - start)
        live.append(len(tracker.targets))
    if min(live) != tau:
        raise RuntimeError(f"τ = {tau}: only {min(live)} targets were tracked on some frame")
    kept = times[skip:]
    return {"tau": tau, "particles": PARTICLES, "frames": n_frames, "timed_frames": len(kept),
            "frame_s": statistics.median(kept), "min_frame_s": min(kept), "max_frame_s": max(kept),
            "first_fusion_s": times[1] if len(times) > 1 else None,
            "live_targets": min(live), "per_particle_s": statistics.median(kept) / (tau * PARTICLES)}


def in_fresh_process(function, *args) -> dict:
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        return pool.submit(function, *args).result()


# -- targets ------------------------------------------------------------------------------------------
def scaling(rows: list[dict]) -> dict | None:
    by_tau = {r["tau"]: r for r in rows}
    low, high = by_tau.get(TAU_LOW), by_tau.get(TAU_HIGH)
    if low is None or high is None:
        return None
    ratio = high["frame_s"] / low["frame_s"]
    return {"time_ratio": ratio, "per_particle_growth": high["per_particle_s"] / low["per_particle_s"],
            "slope": math.log(ratio) / math.log(TAU_HIGH / TAU_LOW)}


def targets(pets: dict | None, rows: list[dict], quick: bool, pets_note: str | None) -> list[dict]:
    found = []

    def target(name, value, ok, skip=None):
        status = "SKIP" if skip else ("PASS" if ok else "FAIL")
        found.append({"target": name, "value": value, "status": status, "note": skip})

    fps = pets and pets["tracking_fps"]
    target(f"(a) PETS S2.L1, {PARTICLES} particles per target, 3 cues: tracking (decoding excluded) "
           f">= {MIN_FPS:g} fps", fps, fps is not None and fps >= MIN_FPS,
           pets_note or ("--quick" if quick else None))
    grow = scaling(rows)
    target(f"(b) time per frame per (τ·N) at τ = {TAU_HIGH} <= {MAX_GROWTH:g} x its value at τ = {TAU_LOW} "
           f"(t({TAU_HIGH}) / t({TAU_LOW}) <= {MAX_GROWTH * TAU_HIGH / TAU_LOW:g})",
           grow and grow["per_particle_growth"], grow is not None and grow["per_particle_growth"] <= MAX_GROWTH,
           "--quick" if quick else (None if grow else f"τ = {TAU_LOW} or {TAU_HIGH} not run"))
    return found


# -- printing -----------------------------------------------------------------------------------------
def print_table(header: list[tuple[str, int]], lines: list[list[str]]) -> None:
    print("  ".join(f"{h:>{w}}" for h, w in header))
    print("-" * (sum(w for _, w in header) + 2 * (len(header) - 1)))
    for line in lines:
        print("  ".join(f"{c:>{w}}" for c, (_, w) in zip(line, header)))


def print_report(pets: dict | None, pets_note: str | None, rows: list[dict], found: list[dict],
                 sizes: dict) -> None:
    print(f"(a) PETS 2009 S2.L1, init from ground truth, {PARTICLES} particles per target, "
          "cues colour, location, foreground, rule r_rule")
    if pets is None:
        print(f"    skipped: {pets_note}")
    else:
        print(f"    {pets['frames']} frames of {pets['width']}x{pets['height']}; live targets per frame: "
              f"mean {pets['mean_live']:.2f} (min {pets['min_live']}, max {pets['max_live']})")
        print_table([("", 34), ("seconds", 8), ("fps", 7), ("ms/frame", 9)], [
            ["tracking only (decoding excluded)", f"{pets['tracking_s']:.2f}", f"{pets['tracking_fps']:.1f}",
             f"{1e3 * pets['tracking_s'] / pets['frames']:.1f}"],
            ["overall (decoding included)", f"{pets['overall_s']:.2f}", f"{pets['overall_fps']:.1f}",
             f"{1e3 * pets['overall_s'] / pets['frames']:.1f}"],
            ["decoding alone", f"{pets['decode_s']:.2f}", f"{pets['frames'] / pets['decode_s']:.0f}",
             f"{1e3 * pets['decode_s'] / pets['frames']:.2f}"],
        ])
        print(f"    tracking only: median frame {1e3 * pets['median_frame_s']:.1f} ms, "
              f"slowest {1e3 * pets['max_frame_s']:.1f} ms")
    print()
    print(f"(b) synthetic {SCENE_WIDTH}x{SCENE_HEIGHT} scenes, {sizes['scene_frames']} frames, τ walkers, "
          f"N = {PARTICLES} particles per target, same cues and rule;")
    print(f"    ms/frame = median of Tracker.step over frames {sizes['skip_frames'] + 1}..{sizes['scene_frames']} "
          "(first fusion frame, with plan compilation, shown apart)")
    lines = []
    for r in rows:
        lines.append([str(r["tau"]), str(r["tau"] * r["particles"]), f"{1e3 * r['frame_s']:.2f}",
                      f"{1e3 * r['min_frame_s']:.2f}", f"{1e3 * r['max_frame_s']:.2f}",
                      f"{1e6 * r['per_particle_s']:.2f}", f"{1e3 * r['first_fusion_s']:.1f}",
                      f"{1.0 / r['frame_s']:.1f}"])
    print_table([("τ", 3), ("τ·N", 5), ("ms/frame", 9), ("min", 7), ("max", 7), ("µs/(τ·N)", 9),
                 ("1st fusion ms", 13), ("fps", 6)], lines)
    grow = scaling(rows)
    if grow:
        print(f"    τ = {TAU_LOW} -> {TAU_HIGH}: time x{grow['time_ratio']:.2f} (linear: x{TAU_HIGH / TAU_LOW:g}), "
              f"per (τ·N) x{grow['per_particle_growth']:.2f}, log-log slope {grow['slope']:.2f} "
              f"(target: <= {MAX_SLOPE:.2f})")
    print()
    print("Targets:")
    for t in found:
        if t["status"] == "SKIP":
            print(f"{t['status']:<5} {t['target']} ({t['note']})")
        else:
            unit = " fps" if t["target"].startswith("(a)") else "x"
            print(f"{t['status']:<5} {t['target']}: {t['value']:.2f}{unit}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA,
                        help="directory of the PETS sequence (video.avi, gt.txt); default: "
                             "shared/data/pets09_s2l1_f0001_0200 next to the repository")
    parser.add_argument("--seed", type=int, default=SEED, help="random seed of the trackers and scenes (default 0)")
    parser.add_argument("--quick", action="store_true",
                        help="fewer frames and τ values, a smoke run (targets skipped)")
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    parser.add_argument("--check", action="store_true", help="exit 1 if a target fails")
    args = parser.parse_args(argv)
    if args.seed < 0:
        parser.error("--seed must be a non-negative integer")
    sizes = QUICK if args.quick else FULL

    import cv2
    import numpy as np

    def log(message):
        if not args.json:
            print(message, file=sys.stderr, flush=True)

    if not args.json:
        print(f"Tracker speed; Python {platform.python_version()}, numpy {np.__version__}, "
              f"OpenCV {cv2.__version__}, {os.cpu_count()} CPUs")
        print("Each measurement runs in a fresh (spawned) process.  Rendering the scenes is never timed; "
              "decoding the video")
        print("is timed only in the overall figure.")
        print()
    start = time.perf_counter()

    pets, pets_note = None, None
    data = args.data.resolve()
    if not ((data / "video.avi").is_file() and (data / "gt.txt").is_file()):
        pets_note = f"no video.avi and gt.txt in {args.data}" if args.data != DEFAULT_DATA else \
            "the PETS sequence is absent (shared/data/pets09_s2l1_f0001_0200; --data DIR to give it)"
        log(f"  (a) PETS skipped: {pets_note}")
    else:
        log("  (a) PETS, tracking only")
        pets = in_fresh_process(pets_tracking_only, str(data), sizes["pets_frames"], args.seed)
        log("  (a) PETS, overall")
        overall = in_fresh_process(pets_overall, str(data), sizes["pets_frames"], args.seed)
        pets["tracking_fps"] = pets["frames"] / pets["tracking_s"]
        pets["overall_s"] = overall["overall_s"]
        pets["overall_fps"] = overall["frames"] / overall["overall_s"]
        pets["overall_decode_s"] = overall["decode_s"]

    rows = []
    for tau in sizes["taus"]:
        log(f"  (b) τ = {tau}")
        rows.append(in_fresh_process(synthetic, tau, sizes["scene_frames"], sizes["skip_frames"], args.seed))

    found = targets(pets, rows, args.quick, pets_note)
    if args.json:
        print(json.dumps({"python": platform.python_version(), "numpy": np.__version__, "opencv": cv2.__version__,
                          "cpus": os.cpu_count(), "quick": args.quick, "sizes": sizes, "pets": pets,
                          "pets_note": pets_note, "synthetic": rows, "scaling": scaling(rows),
                          "targets": found}, indent=2))
    else:
        print_report(pets, pets_note, rows, found, sizes)
        print(f"\n(total {time.perf_counter() - start:.0f} s)")
    failed = any(t["status"] == "FAIL" for t in found)
    return 1 if failed and args.check else 0


if __name__ == "__main__":
    sys.exit(main())
