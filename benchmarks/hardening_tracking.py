"""Hostile but fair input to the tracking commands: each reproducer run as a process of its own.

For every case it prints the exit status, the number of lines on standard error, the wall time
and the peak memory of the process (its own ``ru_maxrss``, read with ``os.wait4``: the resource
usage of children, for that child alone), and
PASS or FAIL against: at most 10 s, at most 1 GB, exactly one line on standard error (none for
a case that must succeed), no traceback, and the expected kind of exit status.

    python benchmarks/hardening_tracking.py            # in a temporary folder, removed afterwards
    python benchmarks/hardening_tracking.py --keep DIR # keep the inputs and outputs in DIR

The demo scene (``belief track --demo``, 100 frames of 320 x 240) is rendered once as input and
is not a case itself.
"""

from __future__ import annotations

import argparse
import os
import shutil
import socket
import sys
import tempfile
from pathlib import Path

from process_usage import LIMIT_BYTES, LIMIT_SECONDS, run_cli

def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def prepare(folder: Path) -> None:
    """The demo scene, a truncated copy, and the hostile files of the cases."""
    status, err = run_cli(["track", "--demo", "--out", "d", "--no-progress", "--no-video"], folder)[:2]
    if status != 0:
        sys.exit(f"cannot render the demo scene: {err}")
    video = (folder / "d" / "scene.avi").read_bytes()
    (folder / "t.avi").write_bytes(video[:709000])
    gt = (folder / "d" / "gt.txt").read_text().splitlines()
    first = gt[0].split(",")
    variants = {"gt_id.txt": [first[0], "1e20", *first[2:]],
                "gt_frame.txt": ["9223372036854775808", *first[1:]],
                "gt_box.txt": [*first[:2], "1e308", *first[3:]],
                "gt_frame0.txt": ["0", *first[1:]]}
    for name, fields in variants.items():
        (folder / name).write_text("\n".join([",".join(fields), *gt[1:]]) + "\n")
    lines = [f"{k},{1 + (37 * k) % 290},{1 + (53 * k) % 180},20,50" for k in range(1, 501)]
    (folder / "init500.csv").write_text("\n".join(lines) + "\n")
    grid = '[[sequences]]\nscene = "crossing"\nframes = 5\n[tracker]\nparticles = 10\n'
    (folder / "grid.toml").write_text(grid)
    (folder / "seeds.toml").write_text("seeds = 1000000000\n" + grid)
    (folder / "binary.toml").write_bytes(bytes(range(256)) * 4)
    (folder / "a_file").write_text("not a folder\n")


def cases(folder: Path) -> list[tuple[str, list, str, Path | None]]:
    """(name, argv, expected exit: 'error' or 'ok' or 'terminated', file whose existence triggers SIGTERM)."""
    track = ["track", "d/scene.avi", "--no-progress"]
    return [
        ("1 truncated video", ["track", "t.avi", "--init-from-gt", "d/gt.txt", "--out", "o1", "--no-progress"],
         "error", None),
        ("2 track: gt id 1e20", [*track, "--init-from-gt", "gt_id.txt", "--out", "o2a"], "error", None),
        ("2 track: gt frame 2^63", [*track, "--init-from-gt", "gt_frame.txt", "--out", "o2b"], "error", None),
        ("2 eval: gt frame 2^63", ["eval", "d/tracks.txt", "gt_frame.txt"], "error", None),
        ("2 track: gt box 1e308", [*track, "--init-from-gt", "gt_box.txt", "--out", "o2c"], "error", None),
        ("2 eval: gt box 1e308", ["eval", "d/tracks.txt", "gt_box.txt"], "error", None),
        ("3 SIGTERM during track", [*track, "--init-from-gt", "d/gt.txt", "--out", "o3"], "terminated",
         folder / "o3" / ".annotated.partial.avi"),
        ("4 --out ''", ["track", "--demo", "--out", "", "--no-progress"], "error", None),
        ("5 500 init boxes", [*track, "--init", "init500.csv", "--out", "o5"], "error", None),
        ("6 gt frame 0", [*track, "--init-from-gt", "gt_frame0.txt", "--out", "o6"], "error", None),
        ("7 experiment: binary config", ["experiment", "binary.toml", "--no-progress"], "error", None),
        ("7 experiment: seeds = 1e9 --dry-run", ["experiment", "seeds.toml", "--dry-run"], "error", None),
        ("7 experiment: --workers 0", ["experiment", "grid.toml", "--workers", "0"], "error", None),
        ("7 experiment: --out is a file", ["experiment", "grid.toml", "--out", "a_file"], "error", None),
        ("7 experiment: unreachable scheduler", ["experiment", "grid.toml", "--out", "o7", "--no-progress",
                                                 "--scheduler", f"tcp://127.0.0.1:{free_port()}"], "error", None),
    ]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--keep", metavar="DIR", help="work in DIR and keep it")
    args = parser.parse_args()
    folder = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="hardening-"))
    folder.mkdir(parents=True, exist_ok=True)
    try:
        prepare(folder)
        print(f"{'case':38} {'exit':>4} {'stderr':>6} {'seconds':>8} {'peak MB':>8}  verdict")
        failed = 0
        selected = cases(folder)
        for name, argv, expected, trigger in selected:
            status, err, seconds, peak, killed = run_cli(argv, folder, terminate_when=trigger)
            lines = err.splitlines()
            leftovers = [str(p.relative_to(folder)) for p in folder.rglob(".*.partial*")]
            problems = ["killed after 60 s"] if killed else []
            if seconds > LIMIT_SECONDS:
                problems.append(f"> {LIMIT_SECONDS:g} s")
            if peak > LIMIT_BYTES:
                problems.append("> 1 GB")
            if "Traceback" in err:
                problems.append("traceback")
            if len(lines) != 1:
                problems.append(f"{len(lines)} stderr lines")
            if expected == "error" and status in (0, None) or expected == "terminated" and status != 143:
                problems.append(f"exit {status}")
            if leftovers:
                problems.append(f"left {', '.join(leftovers)}")
            verdict = "PASS" if not problems else "FAIL (" + "; ".join(problems) + ")"
            failed += bool(problems)
            print(f"{name:38} {status:>4} {len(lines):>6} {seconds:>8.2f} {peak / 2**20:>8.0f}  {verdict}")
            if lines:
                print(f"    {lines[0][:150]}")
        print(f"{failed} of {len(selected)} cases failed")
        return 1 if failed else 0
    finally:
        if not args.keep:
            shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    os.environ.pop("OPENCV_FFMPEG_LOGLEVEL", None)   # measure the plugin's own setting, not the caller's
    sys.exit(main())
