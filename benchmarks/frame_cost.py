"""Benchmark: what one tracker frame costs in instructions and cache misses, a count that no other process changes.

Run from the repository root::

    python benchmarks/frame_cost.py                        # PETS with det.txt, this checkout
    python benchmarks/frame_cost.py --against f6930d4      # and an earlier commit, measured in the same run
    python benchmarks/frame_cost.py --configs gt detections automatic --against HEAD~3
    python benchmarks/frame_cost.py --frames 20 120        # the two run lengths (default)
    python benchmarks/frame_cost.py --data DIR             # another copy of the PETS sequence

Wall-clock frame rates on a shared machine swing by tens of per cent from one run to the next, for the same code
(``benchmarks/bench_tracking.py`` prints them, and the load average, for that reason).  This script counts instead:
it runs the tracker under ``valgrind --tool=cachegrind --cache-sim=yes`` on the first 20 and on the first 120
frames of PETS 2009 S2.L1 (``shared/data/pets09_s2l1_f0001_0200`` next to the repository), 100 particles per
target, and divides the difference of the two counts by the 100 frames between them, so that start-up, imports,
decoding and the background model's warm-up cancel out.  The result is the instructions, first-level data-cache
misses and last-level cache misses of one frame of tracking, the same on every run of the same code.

The configurations are those of ``benchmarks/accuracy_pets.py``: ``gt`` (born from the ground truth),
``detections`` (automatic, with ``det.txt`` and the detections cue) and ``automatic`` (automatic, foreground
blobs).  ``--against REV`` exports REV's packages with ``git archive`` into a temporary folder and counts them in
the same run, then prints this checkout's counts over REV's.  Without valgrind or the data the script says so and exits 0.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_DATA = ROOT.parent / "shared" / "data" / "pets09_s2l1_f0001_0200"
CONFIGS = ("gt", "detections", "automatic")
COUNTS = {"instructions": r"I\s+refs:\s+([\d,]+)", "D1 misses": r"D1\s+misses:\s+([\d,]+)",
          "LL misses": r"LL misses:\s+([\d,]+)"}


def track(data: Path, frames_file: Path, config_name: str, n: int) -> None:
    """The measured run: the first ``n`` decoded frames through the tracker, with the public API of every version."""
    import numpy as np

    from belief_tracking.experiment import Cell, MethodSpec, SequenceSpec
    from belief_tracking.initiation import init_from_gt
    from belief_tracking.motfiles import read_mot
    from belief_tracking.tracker import Tracker

    sequence = SequenceSpec("PETS09 S2.L1", video=str(data / "video.avi"), gt=str(data / "gt.txt"),
                            init="gt" if config_name == "gt" else "automatic",
                            detections=str(data / "det.txt") if config_name == "detections" else None)
    config = Cell(sequence, MethodSpec.from_mapping(config_name, {}), 0, (("particles", 100),)).config()
    images = np.array(np.load(frames_file, mmap_mode="r")[:n])
    plan = init_from_gt(read_mot(data / "gt.txt")) if config_name == "gt" else None
    tracker = Tracker(config, plan, np.random.default_rng(0))
    if config.warm_up > 0 and tracker.background is not None:
        picks = np.linspace(0, len(images) - 1, config.warm_up).round().astype(int)
        tracker.warm_up(images[k] for k in picks)
    for _ in tracker.track(images, detections=sequence.load_detections()):
        pass


def counted(python_path: str | None, data: Path, frames_file: Path, config_name: str, n: int) -> dict[str, int]:
    """Cachegrind's counts of one measured run in a fresh process (``python_path``: the packages to import)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OPENBLAS", "MALLOC", "OMP_", "MKL"))}
    env["OPENBLAS_NUM_THREADS"] = "1"           # one thread: valgrind serialises threads anyway
    if python_path is not None:
        env["PYTHONPATH"] = python_path
    command = ["valgrind", "--tool=cachegrind", "--cache-sim=yes", "--cachegrind-out-file=/dev/null",
               sys.executable, str(Path(__file__).resolve()), "--run", config_name, str(n),
               "--data", str(data), "--frames-file", str(frames_file)]
    done = subprocess.run(command, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"the measured run failed:\n{done.stderr[-2000:]}")
    return {name: int(re.search(pattern, done.stderr).group(1).replace(",", "")) for name, pattern in COUNTS.items()}


def per_frame(python_path: str | None, data: Path, frames_file: Path, config_name: str,
              lengths: tuple[int, int]) -> dict[str, float]:
    short, long = (counted(python_path, data, frames_file, config_name, n) for n in lengths)
    return {name: (long[name] - short[name]) / (lengths[1] - lengths[0]) for name in COUNTS}


def tree_of(revision: str, workdir: Path) -> str:
    """A PYTHONPATH for the packages of ``revision``, exported from git under ``workdir`` (the checkout is untouched)."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", "--format=tar", revision, "belief",
                              "plugins/video_tracking"], check=True, capture_output=True).stdout
    tree = workdir / "tree"
    tree.mkdir(parents=True)
    subprocess.run(["tar", "-x", "-C", str(tree)], input=archive, check=True)
    packages = workdir / "packages"
    packages.mkdir()
    (packages / "belief").symlink_to(tree / "belief")
    (packages / "belief_tracking").symlink_to(tree / "plugins" / "video_tracking")
    return str(packages)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--configs", nargs="+", default=["detections"], choices=CONFIGS)
    parser.add_argument("--frames", nargs=2, type=int, default=[20, 120], metavar=("SHORT", "LONG"))
    parser.add_argument("--against", metavar="REV", help="a git revision to count in the same run")
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA)
    parser.add_argument("--run", nargs=2, metavar=("CONFIG", "N"), help=argparse.SUPPRESS)
    parser.add_argument("--frames-file", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.run is not None:
        track(args.data, args.frames_file, args.run[0], int(args.run[1]))
        return 0
    if shutil.which("valgrind") is None:
        print("valgrind is not installed: nothing to count (Debian: apt install valgrind)")
        return 0
    if not (args.data / "video.avi").is_file():
        print(f"no PETS sequence in {args.data}: nothing to count (give --data DIR)")
        return 0
    lengths = tuple(sorted(args.frames))
    if lengths[0] < 1 or lengths[0] == lengths[1]:
        parser.error("--frames needs two different lengths of at least one frame")
    sys.path.insert(0, str(ROOT))
    import numpy as np

    from belief_tracking.sources import open_source

    with tempfile.TemporaryDirectory() as scratch:
        frames_file = Path(scratch) / "frames.npy"
        with open_source(str(args.data / "video.avi")) as source:
            np.save(frames_file, np.stack([image for _, image in zip(range(lengths[1]), source)]))
        other = tree_of(args.against, Path(scratch) / "against") if args.against else None
        print(f"PETS 2009 S2.L1, N = 100; cachegrind counts of one frame: (frames 1-{lengths[1]} minus "
              f"frames 1-{lengths[0]}) / {lengths[1] - lengths[0]}")
        header = f"{'configuration':<12} {'code':<16}" + "".join(f"{name:>16}" for name in COUNTS)
        print(header + "\n" + "-" * len(header), flush=True)
        for name in args.configs:
            here = per_frame(None, args.data, frames_file, name, lengths)
            print(f"{name:<12} {'this checkout':<16}" + "".join(f"{here[c]:>16,.0f}" for c in COUNTS), flush=True)
            if other is not None:
                there = per_frame(other, args.data, frames_file, name, lengths)
                print(f"{'':<12} {args.against[:16]:<16}" + "".join(f"{there[c]:>16,.0f}" for c in COUNTS))
                print(f"{'':<12} {'ratio':<16}" + "".join(f"{here[c] / there[c]:>15.3f}x" for c in COUNTS),
                      flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
