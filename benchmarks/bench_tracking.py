"""Benchmark: speed of the DSmT particle-filter tracker (belief_tracking).

Run from the repository root::

    python benchmarks/bench_tracking.py             # tables and PASS/FAIL per target and condition
    python benchmarks/bench_tracking.py --check     # exit 1 if a target fails
    python benchmarks/bench_tracking.py --json      # machine-readable output
    python benchmarks/bench_tracking.py --quick     # fewer frames and τ values, a smoke run (targets skipped)
    python benchmarks/bench_tracking.py --load off  # the plain condition only (--load on: the loaded one only)
    python benchmarks/bench_tracking.py --repeat 1  # every measurement once (default: 3 times, the fastest kept)
    python benchmarks/bench_tracking.py --data DIR  # another copy of the PETS sequence

Every measurement is made under two conditions, reported side by side:

* plain: nothing else is started;
* loaded: a second process keeps one core busy with a pure-Python loop for the duration of
  the condition's measurements (started before the first, stopped after the last).  Its
  share of a core is printed, so that a loaded condition whose load did not run shows.

A tracker that splits small steps over a thread pool, or whose frames wait on memory the
allocator maps and unmaps, is fast on an idle machine and several times slower beside one
busy process; the loaded condition makes that visible.  The one-minute load average at the
start of each condition is printed too: a plain condition on a machine that others keep
busy is not plain.

Two parts:

(a) PETS 2009 S2.L1, frames 1-200 (480x360, 8 people, 3-8 per frame): the directory
    ``shared/data/pets09_s2l1_f0001_0200`` next to the repository (``video.avi``,
    ``gt.txt`` and ``det.txt``), or ``--data DIR``.  ``TrackerConfig(particles=100)``: the
    cues colour, location and foreground and the default rule.  The tracks start in three
    ways, each measured in its own fresh (spawned) process:

    * init from GT: the targets are born and removed as with ``belief track --init-from-gt``
      (``init_from_gt(gt.txt)``);
    * automatic + det.txt: ``belief track VIDEO --detections det.txt`` (the ``detections``
      configuration of ``benchmarks/accuracy_pets.py``): no init file, the MOT15 public
      detections of ``det.txt`` given to the tracker frame by frame and the detections cue
      fused after the default cues, the default settings otherwise;
    * automatic: ``belief track VIDEO`` (the ``automatic`` configuration): no init file,
      tracks started on foreground blobs.

    Both automatic runs first let the background model learn from 50 frames spread over the
    clip (``Tracker.warm_up``), before the clock starts.  Their settings are built as a cell
    of ``belief experiment`` builds them (``Cell.config()``).

    * tracking fps (decoding excluded), for each of the three: every frame is decoded into
      memory first (and, with det.txt, the file is read), then only ``Tracker.step`` is
      timed, over all frames; the median and the slowest frame are taken over the frames
      after the first 5, which leaves out the first fusion frame and the births of the
      first frame;
    * overall fps (decoding included), init from GT only: the clock runs from opening the
      video with ``VideoReader`` until the last frame has been decoded and tracked.

    The mean number of live targets per frame and the minor page faults per frame after the
    first 5 (memory the process touches for the first time: the allocator handing back and
    mapping anew its large blocks) are printed as well, and the tracking fps of the two
    automatic runs over that of init from GT in the same condition.  Without the data the
    part is skipped and so are its targets; without ``det.txt`` only the run with
    detections and its target are.

(b) Synthetic scaling: 640x480 scenes of 30 frames (``scenes.SceneConfig``) with τ = 1, 2,
    4, 8, 16, 32 people on a grid, each walking slowly in its own direction in its own
    colours, all born at frame 1 from the scene's ground truth; N = 100 particles per
    target, the default cues and rule.  One fresh process per τ.  The time per frame is
    the median of ``Tracker.step`` over the frames after the first 5, which leaves out
    the first fusion frame, where the combination plan is compiled.  The table gives the
    time per frame, the slowest of those frames over the median, the time per frame per
    particle (τ·N), and the log-log slope of the time against τ from τ = 8 to 32.

Targets, each checked under both conditions:

* (a) init from GT: at least 100 frames per second of tracking (decoding excluded);
* (a) automatic + det.txt: at least 100 frames per second of tracking (decoding and
  warm-up excluded);
* (a) automatic: at least 50 frames per second of tracking (decoding and warm-up excluded);
* (a) init from GT: the slowest frame after the first 5 takes at most 4 times the median
  frame;
* (b) the time per frame grows no faster than linearly in τ·N.  At small τ the fixed costs
  of a frame dominate (the background model, the image-wide work of the cues), so the check
  is made at the large-τ end: the time per frame per (τ·N) at τ = 32 is at most 1.5 times
  its value at τ = 8.  Equivalently, t(32) / t(8) <= 6, a log-log slope of at most 1.29.

``--quick`` tracks the first 60 PETS frames (the automatic runs' warm-up is spread over
those) and τ = 2, 8, 32 with 15 frames each (median over the last 10), once each; it is a
smoke run and the targets are skipped.  ``--repeat N`` (default 3) runs every measurement N times,
each in its own fresh process, and keeps the fastest: on a machine that other work loads now
and then (a virtual machine shares its host), a single run can catch that work in one
measurement and not in the next, while what the tracker itself does to its speed (a thread
pool, the allocator) shows in every run.  A full run of both conditions takes about two
minutes on a 2-core machine.
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
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

try:
    import resource
except ImportError:                        # not on Windows: the page faults are then not counted
    resource = None

# Measure the checkout this script belongs to, installed or not (spawned children inherit sys.path).
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

DEFAULT_DATA = Path(__file__).resolve().parent.parent.parent / "shared" / "data" / "pets09_s2l1_f0001_0200"
SEED = 0
PARTICLES = 100

FULL = {"pets_frames": None, "taus": (1, 2, 4, 8, 16, 32), "scene_frames": 30, "skip_frames": 5}
QUICK = {"pets_frames": 60, "taus": (2, 8, 32), "scene_frames": 15, "skip_frames": 5}

# Targets.
MIN_FPS = 100.0                            # PETS, tracks born from the ground truth
MIN_FPS_DETECTIONS = 100.0                 # PETS, automatic with det.txt
MIN_FPS_AUTOMATIC = 50.0                   # PETS, automatic without detections
MAX_SLOWEST = 4.0                          # slowest frame / median frame, PETS, after the first frames
TAU_LOW, TAU_HIGH, MAX_GROWTH = 8, 32, 1.5
MAX_SLOPE = 1.0 + math.log(MAX_GROWTH) / math.log(TAU_HIGH / TAU_LOW)

# The conditions, in the order they run.
CONDITIONS = ("plain", "loaded")

# The load of the loaded condition: one busy core.  It checks now and then that this script
# is still its parent, so that it ends with the script however the script ends.
LOAD_LOOP = """
import os
parent = os.getppid()
while os.getppid() == parent:
    for _ in range(1_000_000):
        pass
"""
LOAD_SETTLE_S = 0.5                        # let the load start before the first measurement

# The synthetic scenes.
SCENE_WIDTH, SCENE_HEIGHT = 640, 480
GRID_COLUMNS, GRID_ROWS = 8, 4            # 32 cells of 80 x 120 pixels
WALKER_SIZE = (20.0, 50.0)
SPEED = 0.5                               # pixels per frame


def minor_faults() -> int | None:
    """Minor page faults of this process so far (None where the platform does not count them)."""
    return None if resource is None else resource.getrusage(resource.RUSAGE_SELF).ru_minflt


def timed_steps(tracker, frames, detections=None) -> tuple[list[float], list[int], list[int] | None]:
    """``Tracker.step`` on every frame: the time of each, the live targets and the page faults of each.

    ``detections`` (a :class:`~belief_tracking.detections.Detections`, optional) gives
    each frame its boxes, looked up before the clock starts.
    """
    times, live, faults = [], [], []
    for index, image in enumerate(frames):
        boxes = None if detections is None else detections.at(index + 1)
        before = minor_faults()
        start = time.perf_counter()
        tracker.step(index + 1, image, boxes)
        times.append(time.perf_counter() - start)
        live.append(len(tracker.targets))
        if before is not None:
            faults.append(minor_faults() - before)
    return times, live, faults or None


def frame_statistics(times: list[float], faults: list[int] | None, skip: int) -> dict:
    """Median and slowest of the frames after the first ``skip``, their ratio, and the page faults per frame."""
    kept = times[skip:] or times
    median, slowest = statistics.median(kept), max(kept)
    # The first frames fault in what a run keeps (imports, plans, buffers): only later faults are churn.
    kept_faults = None if faults is None else (faults[skip:] or faults)
    return {"timed_frames": len(kept), "median_frame_s": median, "min_frame_s": min(kept), "max_frame_s": slowest,
            "slowest_ratio": slowest / median,
            "faults_per_frame": None if kept_faults is None else sum(kept_faults) / len(kept_faults)}


# -- (a) PETS -----------------------------------------------------------------------------------------
def decode_pets(folder: Path, max_frames: int | None) -> tuple[list, float]:
    """The frames of the PETS video (the first ``max_frames``), decoded into memory, and the decoding time."""
    from belief_tracking.video import VideoReader

    frames = []
    with VideoReader(folder / "video.avi") as reader:
        for image in reader:
            frames.append(image)
            if max_frames is not None and len(frames) == max_frames:
                break
        decode_seconds = reader.decode_seconds
    return frames, decode_seconds


def pets_tracking_only(data: str, max_frames: int | None, skip: int, seed: int) -> dict:
    """Runs in a fresh process: decode every frame into memory, then time ``Tracker.step`` alone."""
    import numpy as np

    from belief_tracking.config import TrackerConfig
    from belief_tracking.initiation import init_from_gt
    from belief_tracking.tracker import Tracker

    folder = Path(data)
    frames, decode_seconds = decode_pets(folder, max_frames)
    tracker = Tracker(TrackerConfig(particles=PARTICLES), init_from_gt(folder / "gt.txt"), np.random.default_rng(seed))
    times, live, faults = timed_steps(tracker, frames)
    height, width = frames[0].shape[:2]
    return {"frames": len(frames), "width": width, "height": height, "tracking_s": sum(times),
            **frame_statistics(times, faults, skip), "decode_s": decode_seconds,
            "mean_live": sum(live) / len(live), "min_live": min(live), "max_live": max(live)}


def pets_automatic(data: str, max_frames: int | None, skip: int, seed: int, with_detections: bool) -> dict:
    """Runs in a fresh process: automatic tracking (no init file), with det.txt or without, warm-up untimed.

    The settings are those of ``belief track VIDEO [--detections det.txt]`` and of the
    ``detections`` and ``automatic`` configurations of ``benchmarks/accuracy_pets.py`` (a cell
    of ``belief experiment``): the default settings with N particles, automatic initiation,
    a background warm-up on 50 frames spread over the clip and, with det.txt, the detections
    cue after the default cues.  The frames are decoded into memory first; the warm-up runs
    before the clock starts; then only ``Tracker.step`` is timed, over all frames.
    """
    import numpy as np

    from belief_tracking.experiment import Cell, MethodSpec, SequenceSpec
    from belief_tracking.sources import open_source
    from belief_tracking.tracker import Tracker

    folder = Path(data)
    frames, decode_seconds = decode_pets(folder, max_frames)
    sequence = SequenceSpec("PETS09 S2.L1", video=str(folder / "video.avi"), gt=str(folder / "gt.txt"),
                            init="automatic", detections=str(folder / "det.txt") if with_detections else None)
    cell = Cell(sequence, MethodSpec("default"), seed, (("particles", PARTICLES),))
    config = cell.config()
    detections = sequence.load_detections()
    tracker = Tracker(config, None, np.random.default_rng(seed))
    warm_up_start = time.perf_counter()
    warm_up_frames = 0
    if config.warm_up > 0 and tracker.background is not None:
        with open_source(np.stack(frames)) as source:
            warm_up_frames = tracker.warm_up(source.spread(config.warm_up))
    warm_up_seconds = time.perf_counter() - warm_up_start
    times, live, faults = timed_steps(tracker, frames, detections)
    return {"frames": len(frames), "tracking_s": sum(times), **frame_statistics(times, faults, skip),
            "decode_s": decode_seconds, "warm_up_frames": warm_up_frames, "warm_up_s": warm_up_seconds,
            "cues": list(config.cues), "detections": None if detections is None else len(detections),
            "mean_live": sum(live) / len(live), "min_live": min(live), "max_live": max(live)}


def pets_overall(data: str, max_frames: int | None, seed: int) -> dict:
    """Runs in a fresh process: open, decode and track frame by frame, all on the clock."""
    import numpy as np

    from belief_tracking.config import TrackerConfig
    from belief_tracking.initiation import init_from_gt
    from belief_tracking.tracker import Tracker
    from belief_tracking.video import VideoReader

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
    from belief_tracking.scenes import SceneConfig, Walker

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

    from belief_tracking.config import TrackerConfig
    from belief_tracking.initiation import init_from_gt
    from belief_tracking.scenes import render
    from belief_tracking.tracker import Tracker

    scene = render(scene_config(tau, n_frames, seed))
    plan = init_from_gt(scene.ground_truth, source=scene.config.name)
    tracker = Tracker(TrackerConfig(particles=PARTICLES), plan, np.random.default_rng(seed))
    times, live, faults = timed_steps(tracker, scene.frames)
    if min(live) != tau:
        raise RuntimeError(f"τ = {tau}: only {min(live)} targets were tracked on some frame")
    stats = frame_statistics(times, faults, skip)
    return {"tau": tau, "particles": PARTICLES, "frames": n_frames, **stats, "frame_s": stats["median_frame_s"],
            "first_fusion_s": times[1] if len(times) > 1 else None, "live_targets": min(live),
            "per_particle_s": stats["median_frame_s"] / (tau * PARTICLES)}


def in_fresh_process(function, *args) -> dict:
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        return pool.submit(function, *args).result()


def fastest(repeat: int, key: str, function, *args) -> dict:
    """The run with the smallest ``key`` of ``repeat`` runs of ``function``, each in a fresh process."""
    return min((in_fresh_process(function, *args) for _ in range(repeat)), key=lambda result: result[key])


# -- the load -----------------------------------------------------------------------------------------
class BusyCore:
    """A second process that keeps one core busy from ``__enter__`` to ``__exit__``.

    ``core_share`` is then the CPU time it used over its wall time (1.0: a whole core), or
    None where the platform does not report a child's CPU time.
    """

    def __init__(self) -> None:
        self.core_share: float | None = None
        self._process: subprocess.Popen | None = None
        self._started = 0.0

    def __enter__(self) -> BusyCore:
        self._process = subprocess.Popen([sys.executable, "-c", LOAD_LOOP], stdin=subprocess.DEVNULL)
        self._started = time.perf_counter()
        time.sleep(LOAD_SETTLE_S)
        return self

    def __exit__(self, *exc) -> None:
        process, self._process = self._process, None
        process.kill()
        wall = time.perf_counter() - self._started
        if hasattr(os, "wait4"):
            try:
                _, _, usage = os.wait4(process.pid, 0)
                self.core_share = (usage.ru_utime + usage.ru_stime) / wall
            except ChildProcessError:
                pass
        try:
            process.wait()
        except ChildProcessError:           # already reaped by wait4
            pass


# -- one condition ------------------------------------------------------------------------------------
def measure(data: Path, notes: dict[str, str | None], sizes: dict, seed: int, repeat: int, log) -> dict:
    """Every measurement of the benchmark, each in a fresh process, as the machine is now.

    ``notes``: why the PETS measurements (``"pets"``) or the one with det.txt
    (``"detections"``) cannot run, None when they can.
    """
    pets = pets_detections = pets_automatic_ = None
    if notes["pets"] is None:
        log("(a) PETS, init from ground truth, tracking only")
        pets = fastest(repeat, "tracking_s", pets_tracking_only, str(data), sizes["pets_frames"],
                       sizes["skip_frames"], seed)
        log("(a) PETS, init from ground truth, overall")
        overall = fastest(repeat, "overall_s", pets_overall, str(data), sizes["pets_frames"], seed)
        pets["tracking_fps"] = pets["frames"] / pets["tracking_s"]
        pets["overall_s"] = overall["overall_s"]
        pets["overall_fps"] = overall["frames"] / overall["overall_s"]
        pets["overall_decode_s"] = overall["decode_s"]
        if notes["detections"] is None:
            log("(a) PETS, automatic with det.txt, tracking only")
            pets_detections = fastest(repeat, "tracking_s", pets_automatic, str(data), sizes["pets_frames"],
                                      sizes["skip_frames"], seed, True)
            pets_detections["tracking_fps"] = pets_detections["frames"] / pets_detections["tracking_s"]
        log("(a) PETS, automatic, tracking only")
        pets_automatic_ = fastest(repeat, "tracking_s", pets_automatic, str(data), sizes["pets_frames"],
                                  sizes["skip_frames"], seed, False)
        pets_automatic_["tracking_fps"] = pets_automatic_["frames"] / pets_automatic_["tracking_s"]
    rows = []
    for tau in sizes["taus"]:
        log(f"(b) τ = {tau}")
        rows.append(fastest(repeat, "frame_s", synthetic, tau, sizes["scene_frames"], sizes["skip_frames"], seed))
    return {"pets": pets, "pets_detections": pets_detections, "pets_automatic": pets_automatic_,
            "synthetic": rows, "scaling": scaling(rows)}


def run_condition(name: str, data: Path, notes: dict[str, str | None], sizes: dict, seed: int, repeat: int,
                  log) -> dict:
    load_average = os.getloadavg()[0] if hasattr(os, "getloadavg") else None

    def log_condition(message):
        log(f"  [{name}] {message}")

    if name == "loaded":
        with BusyCore() as load:
            result = measure(data, notes, sizes, seed, repeat, log_condition)
        result["load_core_share"] = load.core_share
    else:
        result = measure(data, notes, sizes, seed, repeat, log_condition)
        result["load_core_share"] = None
    result["load_average_at_start"] = load_average
    return result


# -- targets ------------------------------------------------------------------------------------------
def scaling(rows: list[dict]) -> dict | None:
    by_tau = {r["tau"]: r for r in rows}
    low, high = by_tau.get(TAU_LOW), by_tau.get(TAU_HIGH)
    if low is None or high is None:
        return None
    ratio = high["frame_s"] / low["frame_s"]
    return {"time_ratio": ratio, "per_particle_growth": high["per_particle_s"] / low["per_particle_s"],
            "slope": math.log(ratio) / math.log(TAU_HIGH / TAU_LOW)}


TARGETS = (
    ("fps", f"(a) PETS, init from GT: tracking >= {MIN_FPS:g} fps", " fps"),
    ("fps_detections", f"(a) PETS, automatic + det.txt: tracking >= {MIN_FPS_DETECTIONS:g} fps", " fps"),
    ("fps_automatic", f"(a) PETS, automatic: tracking >= {MIN_FPS_AUTOMATIC:g} fps", " fps"),
    ("slowest", f"(a) PETS, init from GT: slowest frame <= {MAX_SLOWEST:g} x median (frames 6 on)", "x"),
    ("scaling", f"(b) time per (τ·N) at τ = {TAU_HIGH} <= {MAX_GROWTH:g} x at τ = {TAU_LOW}", "x"),
)


def targets(condition: str, result: dict, quick: bool, notes: dict[str, str | None]) -> list[dict]:
    found = []

    def target(key, value, ok, skip=None):
        status = "SKIP" if skip else ("PASS" if ok else "FAIL")
        found.append({"target": dict((k, n) for k, n, _ in TARGETS)[key], "key": key, "condition": condition,
                      "value": value, "status": status, "note": skip})

    pets_skip = notes["pets"] or ("--quick" if quick else None)
    for key, part, minimum, skip in (("fps", "pets", MIN_FPS, pets_skip),
                                     ("fps_detections", "pets_detections", MIN_FPS_DETECTIONS,
                                      pets_skip or notes["detections"]),
                                     ("fps_automatic", "pets_automatic", MIN_FPS_AUTOMATIC, pets_skip)):
        fps = result[part] and result[part]["tracking_fps"]
        target(key, fps, fps is not None and fps >= minimum, skip)
    pets = result["pets"]
    slowest = pets and pets["slowest_ratio"]
    target("slowest", slowest, slowest is not None and slowest <= MAX_SLOWEST, pets_skip)
    grow = result["scaling"]
    target("scaling", grow and grow["per_particle_growth"],
           grow is not None and grow["per_particle_growth"] <= MAX_GROWTH,
           "--quick" if quick else (None if grow else f"τ = {TAU_LOW} or {TAU_HIGH} not run"))
    return found


# -- printing -----------------------------------------------------------------------------------------
def print_table(header: list[tuple[str, int]], lines: list[list[str]], left: bool = False) -> None:
    """Columns right-aligned; the first left-aligned with ``left``."""
    def row(cells):
        return "  ".join(f"{c:<{w}}" if left and k == 0 else f"{c:>{w}}"
                         for k, (c, (_, w)) in enumerate(zip(cells, header)))
    print(row([h for h, _ in header]))
    print("-" * (sum(w for _, w in header) + 2 * (len(header) - 1)))
    for line in lines:
        print(row(line))


def number(value, fmt: str, missing: str = "-") -> str:
    return missing if value is None else format(value, fmt)


PETS_MODES = (("pets", "init from GT"), ("pets_detections", "automatic + det.txt"), ("pets_automatic", "automatic"))


def print_report(results: dict[str, dict], notes: dict[str, str | None], found: list[dict], sizes: dict) -> None:
    names = list(results)
    print("Conditions: " + "; ".join(
        f"{n}: load average {number(r['load_average_at_start'], '.2f')} at the start"
        + ("" if n != "loaded" else f", the busy process used {number(r['load_core_share'], '.0%')} of a core")
        for n, r in results.items()))
    print()
    print(f"(a) PETS 2009 S2.L1, {PARTICLES} particles per target, rule r_rule; three ways for the tracks to start:")
    if notes["pets"] is not None:
        print(f"    skipped: {notes['pets']}")
    else:
        first = results[names[0]]
        modes = [(key, label) for key, label in PETS_MODES if first[key] is not None]
        print("    init from GT: born and removed as in gt.txt (init_from_gt), cues colour, location, foreground")
        if first["pets_detections"] is not None:
            detections = first["pets_detections"]
            print(f"    automatic + det.txt: no init file, the {detections['detections']} boxes of det.txt, "
                  f"cues {', '.join(detections['cues'])}")
        else:
            print(f"    automatic + det.txt: skipped ({notes['detections']})")
        print(f"    automatic: no init file, cues {', '.join(first['pets_automatic']['cues'])}")
        print(f"    (automatic: the background first learns from {first['pets_automatic']['warm_up_frames']} frames "
              "spread over the clip, before the clock starts)")
        print(f"    {first['pets']['frames']} frames of {first['pets']['width']}x{first['pets']['height']}; "
              "live targets per frame:")
        for key, label in modes:
            print(f"      {label + ':':<20} mean {first[key]['mean_live']:.2f} (min {first[key]['min_live']}, "
                  f"max {first[key]['max_live']})")
        rows = [("init from GT, tracking only (decoding excluded)", "pets", "tracking_s"),
                ("init from GT, overall (decoding included)", "pets", "overall_s"),
                ("decoding alone", "pets", "decode_s")]
        rows += [(f"{label}, tracking only (warm-up excluded)", key, "tracking_s")
                 for key, label in modes if key != "pets"]
        header = [("", max(len(label) for label, _, _ in rows))]
        for n in names:
            header += [(f"{n}: s", 10), ("fps", 7), ("ms/frame", 9)]
        lines = []
        for label, key, seconds in rows:
            line = [label]
            for n in names:
                pets = results[n][key]
                line += [f"{pets[seconds]:.2f}", f"{pets['frames'] / pets[seconds]:.1f}",
                         f"{1e3 * pets[seconds] / pets['frames']:.2f}"]
            lines.append(line)
        print_table(header, lines, left=True)
        print(f"    tracking only, frames {sizes['skip_frames'] + 1} on:")
        for n in names:
            for k, (key, label) in enumerate(modes):
                pets = results[n][key]
                print(f"      {n if k == 0 else '':>6}  {label + ':':<20} "
                      f"median frame {1e3 * pets['median_frame_s']:.2f} ms, "
                      f"slowest {1e3 * pets['max_frame_s']:.2f} ms, slowest/median {pets['slowest_ratio']:.2f}; "
                      f"page faults per frame {number(pets['faults_per_frame'], '.1f')}")
        if len(modes) > 1:
            def ratios(n):
                base = results[n]["pets"]["tracking_fps"]
                return ", ".join(f"{label} x{results[n][key]['tracking_fps'] / base:.2f}"
                                 for key, label in modes if key != "pets")
            print("    tracking fps over that of init from GT, in the same run: "
                  + "; ".join(f"{n}: {ratios(n)}" for n in names))
    print()
    print(f"(b) synthetic {SCENE_WIDTH}x{SCENE_HEIGHT} scenes, {sizes['scene_frames']} frames, τ walkers, "
          f"N = {PARTICLES} particles per target, same cues and rule;")
    print(f"    ms/frame = median of Tracker.step over frames {sizes['skip_frames'] + 1}..{sizes['scene_frames']} "
          "(first fusion frame, with plan compilation, in its own")
    print("    column); max/med = the slowest of those frames over the median; faults = minor page faults per frame")
    header = [("τ", 3), ("τ·N", 5)]
    for n in names:
        header += [(f"{n}: ms/frame", 16), ("max/med", 7), ("µs/(τ·N)", 9), ("1st fusion ms", 13), ("faults", 7)]
    by_tau = {n: {r["tau"]: r for r in results[n]["synthetic"]} for n in names}
    lines = []
    for tau in sizes["taus"]:
        line = [str(tau), str(tau * PARTICLES)]
        for n in names:
            r = by_tau[n][tau]
            line += [f"{1e3 * r['frame_s']:.2f}", f"{r['slowest_ratio']:.2f}", f"{1e6 * r['per_particle_s']:.2f}",
                     f"{1e3 * r['first_fusion_s']:.1f}", number(r["faults_per_frame"], ".0f")]
        lines.append(line)
    print_table(header, lines)
    for n in names:
        grow = results[n]["scaling"]
        if grow:
            print(f"    {n:>6}: τ = {TAU_LOW} -> {TAU_HIGH}: time x{grow['time_ratio']:.2f} "
                  f"(linear: x{TAU_HIGH / TAU_LOW:g}), per (τ·N) x{grow['per_particle_growth']:.2f}, "
                  f"log-log slope {grow['slope']:.2f} (target: <= {MAX_SLOPE:.2f})")
    print()
    print("Targets:")
    header = [("", 66)] + [(n, 16) for n in names]
    lines = []
    for key, label, unit in TARGETS:
        line = [label]
        for n in names:
            t = next(t for t in found if t["key"] == key and t["condition"] == n)
            line.append("SKIP" if t["status"] == "SKIP" else f"{t['status']} {t['value']:.2f}{unit}")
        lines.append(line)
    print_table(header, lines, left=True)
    notes = sorted({t["note"] for t in found if t["status"] == "SKIP"})
    if notes:
        print(f"    (skipped: {'; '.join(notes)})")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA,
                        help="directory of the PETS sequence (video.avi, gt.txt); default: "
                             "shared/data/pets09_s2l1_f0001_0200 next to the repository")
    parser.add_argument("--seed", type=int, default=SEED, help="random seed of the trackers and scenes (default 0)")
    parser.add_argument("--quick", action="store_true",
                        help="fewer frames and τ values, a smoke run (targets skipped)")
    parser.add_argument("--load", choices=("both", "off", "on"), default="both",
                        help="the conditions to run: both (default), off (plain only) or on (loaded only: "
                             "a second process keeps one core busy)")
    parser.add_argument("--repeat", type=int, default=None,
                        help="run every measurement this many times, each in a fresh process, and keep the fastest "
                             "(default 3; 1 with --quick)")
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    parser.add_argument("--check", action="store_true", help="exit 1 if a target fails")
    args = parser.parse_args(argv)
    if args.seed < 0:
        parser.error("--seed must be a non-negative integer")
    if args.repeat is None:
        args.repeat = 1 if args.quick else 3
    if args.repeat < 1:
        parser.error("--repeat must be a positive integer")
    sizes = QUICK if args.quick else FULL
    conditions = {"both": CONDITIONS, "off": ("plain",), "on": ("loaded",)}[args.load]

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
        print("is timed only in the overall figure.  Conditions: plain (nothing else started) and loaded "
              "(a second process")
        print("keeps one core busy with a pure-Python loop).")
        if args.repeat > 1:
            print(f"Every measurement is run {args.repeat} times; the fastest run is shown.")
        print()
    start = time.perf_counter()

    notes: dict[str, str | None] = {"pets": None, "detections": None}
    data = args.data.resolve()
    if not ((data / "video.avi").is_file() and (data / "gt.txt").is_file()):
        notes["pets"] = f"no video.avi and gt.txt in {args.data}" if args.data != DEFAULT_DATA else \
            "the PETS sequence is absent (shared/data/pets09_s2l1_f0001_0200; --data DIR to give it)"
        log(f"  (a) PETS skipped: {notes['pets']}")
    elif not (data / "det.txt").is_file():
        notes["detections"] = f"no det.txt in {args.data}"
        log(f"  (a) PETS with detections skipped: {notes['detections']}")

    results = {name: run_condition(name, data, notes, sizes, args.seed, args.repeat, log) for name in conditions}
    found = [t for name, result in results.items() for t in targets(name, result, args.quick, notes)]
    if args.json:
        print(json.dumps({"python": platform.python_version(), "numpy": np.__version__, "opencv": cv2.__version__,
                          "cpus": os.cpu_count(), "quick": args.quick, "repeat": args.repeat, "sizes": sizes,
                          "pets_note": notes["pets"], "detections_note": notes["detections"],
                          "conditions": results, "targets": found}, indent=2))
    else:
        print_report(results, notes, found, sizes)
        print(f"\n(total {time.perf_counter() - start:.0f} s)")
    failed = any(t["status"] == "FAIL" for t in found)
    return 1 if failed and args.check else 0


if __name__ == "__main__":
    sys.exit(main())
