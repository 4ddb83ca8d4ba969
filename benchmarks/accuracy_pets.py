"""Accuracy of the DSmT particle-filter tracker on PETS 2009 S2.L1, frames 1-200.

Run from the repository root::

    python benchmarks/accuracy_pets.py                        # default rule, Dempster, DSmC; seeds 0-4
    python benchmarks/accuracy_pets.py --rules r_rule --seeds 0 1
    python benchmarks/accuracy_pets.py --check                # exit 1 if the default rule misses a target
    python benchmarks/accuracy_pets.py --data DIR             # another copy of the sequence

The targets are born and removed as with ``belief track --init-from-gt`` (each ground-truth
id is born at its first box and removed after its last), with ``TrackerConfig(particles=100)``:
the cues colour, location and foreground, weight Bel(θ_J).  Each run is scored by
``plugins.video_tracking.evaluation.evaluate`` (IoU ≥ 0.5; ground-truth rows with flag 0
ignored).  The table gives, per rule, the mean over the seeds of MOTA, IDF1, the median
centre error and the ID switches, and the MOTA of each seed.

Targets (default rule, mean over seeds 0-4): MOTA ≥ 0.35, IDF1 ≥ 0.65, median centre error
≤ 5 px.  The sequence is looked for in ``shared/data/pets09_s2l1_f0001_0200`` next to the
repository; without it the script says so and exits 0.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from plugins.video_tracking.evaluation import evaluate, read_mot  # noqa: E402
from plugins.video_tracking.tracker import TrackerConfig, init_from_gt, run  # noqa: E402

DEFAULT_DATA = ROOT.parent / "shared" / "data" / "pets09_s2l1_f0001_0200"
TARGETS = {"mota": 0.35, "idf1": 0.65, "median_centre_error": 5.0}


def score(data: Path, rule: str, seed: int, particles: int):
    with tempfile.TemporaryDirectory() as out:
        run(data / "video.avi", init_from_gt(data / "gt.txt"), TrackerConfig(particles=particles, rule=rule),
            out_dir=out, seed=seed, write_video=False, progress=False)
        tracks = read_mot(Path(out) / "tracks.txt")
    return evaluate(tracks, read_mot(data / "gt.txt"))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA)
    parser.add_argument("--rules", nargs="+", default=["r_rule", "dempster", "dsmc"])
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2, 3, 4])
    parser.add_argument("--particles", type=int, default=100)
    parser.add_argument("--check", action="store_true", help="exit 1 if the default rule misses a target")
    args = parser.parse_args(argv)
    if not (args.data / "video.avi").is_file() or not (args.data / "gt.txt").is_file():
        print(f"PETS sequence not found in {args.data}: skipped")
        return 0
    print(f"PETS09 S2.L1 f1-200, N = {args.particles}, cues colour+location+foreground, seeds {args.seeds}")
    print(f"{'rule':<10} {'MOTA':>7} {'IDF1':>7} {'median px':>10} {'ID sw':>6}   MOTA per seed")
    failed = False
    for rule in args.rules:
        scores = [score(args.data, rule, seed, args.particles) for seed in args.seeds]
        mean = {key: statistics.fmean(getattr(s, key) for s in scores)
                for key in ("mota", "idf1", "median_centre_error", "id_switches")}
        per_seed = " ".join(f"{s.mota:.3f}" for s in scores)
        print(f"{rule:<10} {mean['mota']:>7.3f} {mean['idf1']:>7.3f} {mean['median_centre_error']:>10.2f} "
              f"{mean['id_switches']:>6.1f}   {per_seed}", flush=True)
        if rule == TrackerConfig().rule:
            ok = (mean["mota"] >= TARGETS["mota"] and mean["idf1"] >= TARGETS["idf1"]
                  and mean["median_centre_error"] <= TARGETS["median_centre_error"])
            failed |= not ok
            print(f"  target MOTA >= {TARGETS['mota']}, IDF1 >= {TARGETS['idf1']}, median <= "
                  f"{TARGETS['median_centre_error']} px: {'PASS' if ok else 'FAIL'}")
    return 1 if (args.check and failed) else 0


if __name__ == "__main__":
    sys.exit(main())
