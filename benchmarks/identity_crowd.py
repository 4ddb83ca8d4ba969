"""Identity swaps on the crowd scenes: twelve walkers dressed alike, tracked from the ground truth.

Run from the repository root::

    python benchmarks/identity_crowd.py                       # crowd scenes 0-4, tracker seed 0
    python benchmarks/identity_crowd.py --scenes 0 1 --seeds 0 1 2
    python benchmarks/identity_crowd.py --set particles=50 --set "belief.rule='dempster'"   # tracker settings, TOML
    python benchmarks/identity_crowd.py --check 245           # exit 1 if more frames have a swap than before
    python benchmarks/identity_crowd.py --init gt follow automatic   # also as belief track does
    python benchmarks/identity_crowd.py --jobs 1              # one process (default: one per core)

Each run renders the crowd scene of a seed (:func:`belief_tracking.scenes.crowd`: 150 frames
of 320 x 240, twelve walkers in close reds and dark blues who cross each other's paths), starts
a track at each ground-truth id's first box and removes it after its last
(:func:`~belief_tracking.initiation.init_from_gt`), and tracks, with the particle filters
alone (no background model), the default :class:`~belief_tracking.config.TrackerConfig` but for the ``--set``
settings (lines of TOML, as in an experiment file: strings are quoted, a dotted key names a
setting of a table), from ``numpy.random.default_rng(tracker seed)``.  The tracks keep the ground-truth
ids, so a target's identity is its own id.

``--init`` says how the tracks start (one table each): ``gt`` (the default) as above, the
particle filters alone; ``follow`` as ``belief track --init-from-gt`` (the same births and
deaths, with tracks that learn the background from 50 frames and follow the person blobs,
:func:`~belief_tracking.runner.run_config`); ``automatic`` as ``belief track VIDEO`` (the
tracks start and end on their own; a target's identity is then the track the IDF1
assignment gives it, ``identities=None``).

A row per scene and tracker seed gives the frames in which some target is paired with a
track that carries another id (:func:`~belief_tracking.evaluation.identity_swaps`: the
CLEAR MOT pairs of :func:`~belief_tracking.evaluation.evaluate`, IoU >= 0.5), the (frame,
target) pairs so swapped, MOTA, IDF1, HOTA with its detection and association parts (DetA,
AssA), the CLEAR MOT identity switches and the seconds the run took (rendering included;
runs in parallel share the cores).  The last row sums the counts and the seconds and
averages the scores.  ``--check MAX`` is the acceptance check of identities: the frames
with a swapped identity, summed over the runs (of every ``--init``), are at most MAX.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from belief_tracking.config import TrackerConfig  # noqa: E402
from belief_tracking.errors import TrackingError  # noqa: E402
from belief_tracking.evaluation import evaluate, identity_swaps  # noqa: E402
from belief_tracking.initiation import init_from_gt  # noqa: E402
from belief_tracking.runner import run_config, start_tracker  # noqa: E402
from belief_tracking.scenes import crowd, render  # noqa: E402
from belief_tracking.sources import open_source  # noqa: E402
from belief_tracking.tracker import Tracker  # noqa: E402


def settings_of(assignments: list[str]) -> dict:
    """The TrackerConfig settings of ``KEY=VALUE`` lines of TOML: a dotted key fills a nested table."""
    try:
        return tomllib.loads("\n".join(assignments))
    except tomllib.TOMLDecodeError as exc:
        raise TrackingError(f"--set takes KEY=VALUE in TOML, e.g. particles=50 or belief.rule='dempster' "
                            f"({exc})") from None


#: How the tracks start: ``gt``, the particle filters alone from the ground truth's births and
#: deaths (init_from_gt, no background model); ``follow``, as ``belief track --init-from-gt``
#: (the same births and deaths, tracks that learn the background and follow the blobs,
#: runner.run_config); ``automatic``, as ``belief track VIDEO`` (no ground truth given).
INITS = ("gt", "follow", "automatic")


def track(scene_seed: int, tracker_seed: int, settings: dict, init: str = "gt") -> dict:
    """Track the crowd of ``scene_seed`` as ``init`` says and score the identities."""
    started = time.perf_counter()
    scene = render(crowd(scene_seed))
    config = TrackerConfig.from_settings(settings, "--set")
    plan = None if init == "automatic" else init_from_gt(scene.ground_truth)
    if init == "gt":
        tracker = Tracker(config, plan, np.random.default_rng(tracker_seed))
    else:
        config = run_config(config, plan)
        with open_source(scene) as source:
            tracker = start_tracker(config, plan, tracker_seed, source)
    rows = [row for result in tracker.track(scene.frames) for row in result.mot_rows()]
    tracks = np.array(rows, dtype=np.float64).reshape(-1, 10)
    # Tracks born from the ground truth keep its ids; automatic ones get the IDF1 assignment's.
    swaps = identity_swaps(scene.ground_truth, tracks, identities=None if init == "automatic" else "gt")
    scores = evaluate(scene.ground_truth, tracks)
    return {"scene": scene_seed, "seed": tracker_seed, "init": init, "frames": swaps.frames, "pairs": swaps.pairs,
            "mota": scores.mota, "idf1": scores.idf1, "hota": scores.hota, "deta": scores.deta,
            "assa": scores.assa, "id_switches": scores.id_switches, "seconds": time.perf_counter() - started}


BORN = {"gt": "born from the ground truth", "follow": "born from the ground truth, following the blobs",
        "automatic": "automatic"}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", nargs="+", type=int, default=[0, 1, 2, 3, 4], metavar="SEED",
                        help="seeds of the crowd scenes (default: 0 1 2 3 4)")
    parser.add_argument("--seeds", nargs="+", type=int, default=[0], metavar="SEED",
                        help="seeds of the tracker (default: 0)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="a tracker setting as a line of TOML, e.g. --set particles=50 or "
                             "--set \"belief.rule='dempster'\" (repeatable)")
    parser.add_argument("--init", nargs="+", default=["gt"], choices=INITS,
                        help="how the tracks start: gt (the particle filters alone, from the ground truth's "
                             "births and deaths; the default), follow (as belief track --init-from-gt: the same "
                             "births, tracks that learn the background and follow the blobs), automatic (as "
                             "belief track VIDEO)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--check", type=int, metavar="MAX",
                        help="exit 1 if the frames with a swapped identity, summed over the runs, exceed MAX")
    args = parser.parse_args(argv)
    try:
        settings = settings_of(args.set)
        TrackerConfig.from_settings(settings, "--set")  # a bad setting fails here, not in every worker
    except TrackingError as exc:
        parser.error(str(exc))
    inits = list(dict.fromkeys(args.init))
    jobs = [(scene, seed, settings, init) for init in inits for scene in args.scenes for seed in args.seeds]
    with ProcessPoolExecutor(max(1, min(args.jobs, len(jobs)))) as pool:
        runs = list(pool.map(track, *zip(*jobs)))
    total = 0
    for init in inits:
        own = [run for run in runs if run["init"] == init]
        print(f"crowd scenes {args.scenes}, tracker seeds {args.seeds}, {BORN[init]}"
              + (f", --set {' '.join(args.set)}" if args.set else ""))
        print(f"{'scene':>5} {'seed':>4} {'swapped frames':>14} {'swapped pairs':>13} {'MOTA':>7} {'IDF1':>7} "
              f"{'HOTA':>7} {'DetA':>7} {'AssA':>7} {'ID sw':>6} {'seconds':>8}")
        for run in own:
            print(f"{run['scene']:>5} {run['seed']:>4} {run['frames']:>14} {run['pairs']:>13} {run['mota']:>7.3f} "
                  f"{run['idf1']:>7.3f} {run['hota']:>7.3f} {run['deta']:>7.3f} {run['assa']:>7.3f} "
                  f"{run['id_switches']:>6} {run['seconds']:>8.1f}")
        frames = sum(run["frames"] for run in own)
        mean = {key: statistics.fmean(run[key] for run in own) for key in ("mota", "idf1", "hota", "deta", "assa")}
        print(f"{'total':<10} {frames:>14} {sum(run['pairs'] for run in own):>13} {mean['mota']:>7.3f} "
              f"{mean['idf1']:>7.3f} {mean['hota']:>7.3f} {mean['deta']:>7.3f} {mean['assa']:>7.3f} "
              f"{sum(run['id_switches'] for run in own):>6} {sum(run['seconds'] for run in own):>8.1f}"
              "   (MOTA, IDF1, HOTA, DetA, AssA: means)")
        total += frames
    if args.check is not None:
        print(f"frames with a swapped identity: {total}, at most {args.check} allowed: "
              f"{'PASS' if total <= args.check else 'FAIL'}")
        return 1 if total > args.check else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
