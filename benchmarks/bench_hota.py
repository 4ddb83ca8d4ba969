"""Cost of HOTA in ``belief eval``: :func:`belief_tracking.hota.hota` on 10^5 ground-truth rows.

The scene is that of ``bench_text_inputs.py`` (targets in waves of up to 100 a frame, noisy
tracks with an identity switch every 40 frames of a target, 5 % misses, 2 % false boxes).
Prints the seconds of HOTA alone (best of ``--repeat``) and of the whole ``evaluate`` (CLEAR
MOT, IDF1 and HOTA) once.  The target is at most 10 s for HOTA on 10^5 rows.

Usage::

    python benchmarks/bench_hota.py [--rows N] [--ids N] [--repeat N]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_text_inputs import _scene  # noqa: E402

from belief_tracking.evaluation import evaluate  # noqa: E402
from belief_tracking.hota import hota  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rows", type=int, default=100_000, help="ground-truth rows (default 10^5)")
    parser.add_argument("--ids", type=int, default=1_000, help="targets of the ground truth (default 1 000)")
    parser.add_argument("--repeat", type=int, default=3, help="runs of HOTA alone; the best is printed")
    args = parser.parse_args(argv)

    gt, tracks = _scene(args.rows, args.ids)
    frames = len(set(gt[:, 0].tolist()))
    print(f"inputs: {len(gt):,} ground-truth rows, {args.ids:,} ids, {len(tracks):,} track rows, {frames:,} frames")
    best = float("inf")
    for _ in range(args.repeat):
        started = time.perf_counter()
        result = hota(gt[:, 0], gt[:, 1], gt[:, 2:6], tracks[:, 0], tracks[:, 1], tracks[:, 2:6]).means()
        best = min(best, time.perf_counter() - started)
    print(f"hota()      {best:7.2f} s   (target 10 s)   HOTA {result['hota']:.4f}  DetA {result['deta']:.4f}  "
          f"AssA {result['assa']:.4f}")
    started = time.perf_counter()
    scores = evaluate(gt, tracks)
    print(f"evaluate()  {time.perf_counter() - started:7.2f} s   MOTA {scores.mota:.4f}  IDF1 {scores.idf1:.4f}  "
          f"HOTA {scores.hota:.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
