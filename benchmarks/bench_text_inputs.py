"""Cost of the tracking plugin's text inputs: reading det.txt and gt.txt, and ``belief eval``.

Prints, for each case, the wall-clock time and the peak resident memory of a process of its own
(``VmHWM``, else ``resource.getrusage``), so that one case's memory never counts against another:

* ``det.txt``, 10^6 rows (``read_detections``): the target is at most 3 s and 500 MB;
* ``gt.txt``, 10^6 rows (``read_mot``): the same target;
* ``evaluate`` on 10^6 ground-truth rows of 10 000 ids against tracks with identity switches, false
  positives and misses: at most 30 s and 1 GB (the files are read too, as ``belief eval`` does).

Usage::

    python benchmarks/bench_text_inputs.py [--rows N] [--ids N] [--package belief_tracking]

``--package`` names the package to measure (another copy of the plugin, to compare before and
after a change).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

_CHILD = r"""
import json, resource, sys, time, importlib
package, case, paths = sys.argv[1], sys.argv[2], sys.argv[3:]
motfiles = importlib.import_module(package + ".motfiles")
started = time.perf_counter()
if case == "det":
    detections = importlib.import_module(package + ".detections")
    result = len(detections.read_detections(paths[0]))
elif case == "gt":
    result = len(motfiles.read_mot(paths[0]))
else:
    evaluation = importlib.import_module(package + ".evaluation")
    scores = evaluation.evaluate(motfiles.read_mot(paths[1]), motfiles.read_mot(paths[0], allow_empty=True))
    result = {"mota": round(scores.mota, 6), "idf1": round(scores.idf1, 6), "switches": scores.id_switches}
seconds = time.perf_counter() - started
try:
    # VmHWM belongs to this program's memory map; ru_maxrss on Linux keeps the peak of the parent
    # process forked before the exec, which here holds the generated inputs.
    with open("/proc/self/status") as status:
        peak = next(int(line.split()[1]) for line in status if line.startswith("VmHWM")) / 1024
except (OSError, StopIteration):
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps({"seconds": seconds, "peak_mb": peak, "result": result}))
"""


def _scene(rows: int, ids: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Ground truth of ``rows`` boxes and ``ids`` targets, each alive for an equal run of frames, and noisy tracks."""
    rng = np.random.default_rng(seed)
    life = max(1, rows // ids)
    rows = life * ids                                   # every target lives as long
    per_frame = max(1, min(ids, 100))
    target = np.repeat(np.arange(1, ids + 1), life)[:rows]
    # Targets start in waves of `per_frame`, so each frame holds about that many boxes.
    start = ((target - 1) // per_frame) * life
    frame = start + np.tile(np.arange(life), ids)[:rows] + 1
    lane = (target - 1) % per_frame
    x = 20.0 * lane + (frame - start) * 0.5
    y = 40.0 * (lane % 20) + 10.0
    gt = np.column_stack([frame, target, x, y, np.full(rows, 15.0), np.full(rows, 35.0), np.ones(rows)])
    tracks = gt.copy()
    tracks[:, 2:4] += rng.normal(0.0, 1.5, size=(rows, 2))
    # Identity switches: a track id changes every 40 frames of a target; 5 % of boxes are missed.
    tracks[:, 1] = target * 10 + (frame - start) // 40
    tracks = tracks[rng.random(rows) > 0.05]
    false = tracks[rng.random(len(tracks)) < 0.02].copy()
    false[:, 1] += 5
    false[:, 2] += 600.0
    return gt, np.vstack([tracks, false])


def _write_mot(path: Path, rows: np.ndarray, detections: bool = False) -> None:
    with open(path, "w", encoding="ascii") as handle:
        for f, i, x, y, w, h, flag in rows.tolist():
            if detections:
                handle.write(f"{int(f)},-1,{x + 1:.2f},{y + 1:.2f},{w:.2f},{h:.2f},{0.9:.6f},-1,-1,-1\n")
            else:
                handle.write(f"{int(f)},{int(i)},{x + 1:.3f},{y + 1:.3f},{w:.3f},{h:.3f},{int(flag)},-1,-1,-1\n")


def _measure(package: str, case: str, *paths: Path, timeout: float = 600.0) -> dict:
    try:
        done = subprocess.run([sys.executable, "-c", _CHILD, package, case, *map(str, paths)],
                              capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": f"over {timeout:g} s"}
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["?"])[-1]
        return {"error": f"exit {done.returncode}: {last[:160]}"}
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rows", type=int, default=1_000_000, help="rows of det.txt and gt.txt (default 10^6)")
    parser.add_argument("--ids", type=int, default=10_000, help="targets of the ground truth (default 10 000)")
    parser.add_argument("--package", default="belief_tracking", help="the plugin package to measure")
    parser.add_argument("--timeout", type=float, default=600.0, help="seconds before a case is given up")
    args = parser.parse_args(argv)

    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        started = time.perf_counter()
        gt, tracks = _scene(args.rows, args.ids)
        _write_mot(folder / "det.txt", gt, detections=True)
        _write_mot(folder / "gt.txt", gt)
        _write_mot(folder / "tracks.txt", tracks)
        track_rows = len(tracks)
        del gt, tracks
        print(f"inputs: {args.rows:,} ground-truth rows, {args.ids:,} ids, {track_rows:,} track rows "
              f"({time.perf_counter() - started:.1f} s to write)")
        cases = [("det.txt, read_detections", "det", [folder / "det.txt"], "3 s, 500 MB"),
                 ("gt.txt, read_mot", "gt", [folder / "gt.txt"], "3 s, 500 MB"),
                 ("belief eval (read + evaluate)", "eval", [folder / "tracks.txt", folder / "gt.txt"], "30 s, 1 GB")]
        for label, case, paths, target in cases:
            figures = _measure(args.package, case, *paths, timeout=args.timeout)
            if "error" in figures:
                print(f"{label:<32} failed: {figures['error']}   (target {target})")
            else:
                print(f"{label:<32} {figures['seconds']:7.2f} s {figures['peak_mb']:8.0f} MB   (target {target})"
                      f"   {figures['result']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
