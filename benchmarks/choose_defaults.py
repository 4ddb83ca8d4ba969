"""The table that chose the tracker's defaults: every built-in scene and the PETS dev sequence, together.

Run from the repository root::

    python benchmarks/choose_defaults.py                       # every candidate, seeds 0-4 (about 10 min on 2 cores)
    python benchmarks/choose_defaults.py --candidates default pcr6 --seeds 0 1
    python benchmarks/choose_defaults.py --jobs 1              # one process (default: one per core)
    python benchmarks/choose_defaults.py --data DIR            # another copy of the PETS sequence

Each candidate is a set of :class:`~belief_tracking.config.TrackerConfig` settings
on top of the defaults, run as a user runs it:

* every scene of :data:`belief_tracking.scenes.PRESETS`, automatic (no ground truth
  given to the tracker, the background first learns from 50 frames spread over the scene,
  as ``belief track`` without an init file);
* PETS 2009 S2.L1 frames 1-200 three ways: born from the ground truth (``--init-from-gt``:
  the background learns from 50 frames and the blobs follow the planned tracks,
  :data:`~belief_tracking.initiation.FOLLOW_PLAN`, with the candidate's initiation settings),
  automatic, and automatic with the MOT15 public detections of ``det.txt``
  (``--detections``).

Scores are ``evaluate`` (IoU >= 0.5), means over the seeds.  The table gives each scene's
MOTA, the smallest of them, and MOTA / IDF1 of the three PETS runs; the defaults are the
candidate named ``default``.  Without the PETS data (``shared/data/pets09_s2l1_f0001_0200``
next to the repository, or ``--data``) its columns are left out.
"""

from __future__ import annotations

import argparse
import os
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

DEFAULT_DATA = ROOT.parent / "shared" / "data" / "pets09_s2l1_f0001_0200"
WARM_UP = 50

#: name -> (settings on top of the defaults, what the candidate changes)
CANDIDATES: dict[str, tuple[dict, str]] = {
    "default": ({}, "the defaults"),
    "pcr6": ({"belief": {"rule": "pcr6"}}, "PCR6 instead of the R-weighted rule"),
    "dsmc": ({"belief": {"rule": "dsmc"}}, "DSmC instead of the R-weighted rule"),
    "product": ({"fusion": "product"}, "product of the cues' likelihoods instead of a belief rule"),
    "detections cue": ({"cues": ["colour", "location", "foreground", "detections"]},
                       "the candidates fused as a fourth cue: the detections, or the person blobs without them "
                       "(born from the ground truth too)"),
    "full-size mask": ({"background": {"downscale": 1}}, "the background model at full resolution"),
    "duplicates 15": ({"initiation": {"duplicate_frames": 15}}, "duplicates end after 15 frames instead of 5"),
    "overlap only": ({"initiation": {"appearance_weight": 0.0}},
                     "detections assigned to tracks on overlap alone (appearance weight 0 instead of 0.75)"),
    "appearance 0.5": ({"initiation": {"appearance_weight": 0.5}}, "appearance weight 0.5 instead of 0.75"),
    "appearance 1": ({"initiation": {"appearance_weight": 1.0}}, "appearance weight 1 instead of 0.75"),
    "border births": ({"initiation": {"anywhere": False}}, "new tracks only at the image border (SPEC B.4)"),
}

PETS_RUNS = ("gt", "automatic", "detections")


def _pets(data: Path):
    from belief_tracking.detections import read_detections
    from belief_tracking.motfiles import read_mot
    from belief_tracking.video import VideoReader

    with VideoReader(data / "video.avi") as reader:
        frames = np.array(list(reader))
    detections = read_detections(data / "det.txt", frame_count=len(frames),
                                 image_size=(frames.shape[2], frames.shape[1]))
    return frames, read_mot(data / "gt.txt"), detections


def run(job: tuple) -> tuple:
    """One run: (candidate, task, seed, data) -> (candidate, task, seed, MOTA, IDF1)."""
    from belief_tracking import scenes
    from belief_tracking.config import TrackerConfig
    from belief_tracking.evaluation import evaluate
    from belief_tracking.initiation import FOLLOW_PLAN, init_from_gt, settings_of
    from belief_tracking.tracker import Tracker

    name, task, seed, data = job
    settings = dict(CANDIDATES[name][0])
    detections = plan = None
    if task.startswith("pets "):
        frames, gt, boxes = _pets(Path(data))
        how = task.split(" ", 1)[1]
        if how == "gt":
            # As --init-from-gt (runner.run_config): every birth and death from the ground truth, no
            # automatic tracks; the candidates follow the planned tracks, with the candidate's settings.
            plan = init_from_gt(gt)
            settings["initiation"] = {**settings_of(FOLLOW_PLAN), **settings.get("initiation", {})}
            settings.setdefault("warm_up", WARM_UP)
        detections = boxes if how == "detections" else None
    else:
        scene = scenes.render(scenes.PRESETS[task](seed))
        frames, gt = scene.frames, scene.ground_truth
    if plan is None:
        settings.setdefault("initiation", {})
        settings.setdefault("warm_up", WARM_UP)
    config = TrackerConfig.from_settings(settings, name)
    tracker = Tracker(config, plan, np.random.default_rng(seed))
    if config.warm_up:
        picks = np.linspace(0, len(frames) - 1, config.warm_up).round().astype(int)
        tracker.warm_up(frames[k] for k in picks)
    rows = [row for result in tracker.track(frames, detections=detections) for row in result.mot_rows()]
    scores = evaluate(gt, np.array(rows, dtype=np.float64).reshape(-1, 10))
    return name, task, seed, scores.mota, scores.idf1


def main(argv: list[str] | None = None) -> int:
    from belief_tracking import scenes

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--candidates", nargs="+", choices=list(CANDIDATES), default=list(CANDIDATES))
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2, 3, 4])
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of the PETS dev sequence")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    args = parser.parse_args(argv)

    tasks = list(scenes.PRESETS)
    pets = (args.data / "video.avi").is_file() and (args.data / "det.txt").is_file()
    if pets:
        tasks += [f"pets {how}" for how in PETS_RUNS]
    else:
        print(f"no PETS sequence in {args.data}: its columns are left out")
    jobs = [(name, task, seed, str(args.data)) for name in args.candidates for task in tasks for seed in args.seeds]
    results: dict[tuple[str, str], list[tuple[float, float]]] = {}
    try:
        from tqdm import tqdm
    except ImportError:                                          # pragma: no cover
        def tqdm(iterable, **_):
            return iterable
    with ProcessPoolExecutor(max(1, args.jobs)) as pool:
        for name, task, _, mota, idf1 in tqdm(pool.map(run, jobs), total=len(jobs), desc="runs", file=sys.stderr):
            results.setdefault((name, task), []).append((mota, idf1))

    def mean(name: str, task: str, k: int) -> float:
        return float(np.mean([pair[k] for pair in results[(name, task)]]))

    scene_names = list(scenes.PRESETS)
    header = ["candidate"] + scene_names + ["scenes min"]
    if pets:
        header += ["PETS from GT", "PETS automatic", "PETS detections"]
    print(f"Seeds {args.seeds}; MOTA of each scene (automatic); MOTA / IDF1 of the PETS runs.\n")
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for name in args.candidates:
        cells = [f"{mean(name, s, 0):.3f}" for s in scene_names]
        cells.append(f"{min(mean(name, s, 0) for s in scene_names):.3f}")
        if pets:
            cells += [f"{mean(name, f'pets {how}', 0):.3f} / {mean(name, f'pets {how}', 1):.3f}" for how in PETS_RUNS]
        print(f"| {name} | " + " | ".join(cells) + " |")
    print()
    for name in args.candidates:
        print(f"  {name}: {CANDIDATES[name][1]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
