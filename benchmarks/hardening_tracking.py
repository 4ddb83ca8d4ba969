"""Hostile but fair input to the tracking commands: each reproducer run as a process of its own.

For every case it prints the exit status, the number of lines on standard error, the wall time
and the peak memory of the process (its own ``ru_maxrss``, read with ``os.wait4``: the resource
usage of children, for that child alone), and PASS or FAIL against the acceptance of issue 26:
at most 30 s (less where a case says so), at most 2 GB, no traceback, and the expected kind of
exit status: a refusal ('error') exits non-zero with exactly one line on standard error (of at
most 2 000 characters); a success ('ok') exits 0 with nothing on standard error; 'either'
accepts both.  No hidden partial output may be left anywhere.

Cases that write (or would write) into an output folder are *guarded*: the bytes of every file
of the working folder are compared before and after the run (symlinks by their target, FIFOs
never opened).  A guarded case fails when a file outside its ``--out`` changed, appeared or
vanished, or when a file inside ``--out`` that the run did not write changed: after a refusal
nothing that existed before may change; after a success only the files an earlier run wrote
there (its ``.belief-outputs.json``), or with ``--force`` the files in ``--out`` itself.

A process still running after 35 s is killed (FAIL); each process is also limited to 6 GB of
address space, so that a runaway job (``/dev/zero`` read whole) cannot take the machine down.

    python benchmarks/hardening_tracking.py            # in a temporary folder, removed afterwards
    python benchmarks/hardening_tracking.py --keep DIR # keep the inputs and outputs in DIR
    python benchmarks/hardening_tracking.py -k out     # only the cases whose name contains 'out'

The demo scene (``belief track --demo``, 100 frames of 320 x 240) is rendered once as input and
is not a case itself.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import socket
import stat
import struct
import sys
import tempfile
import zlib
from pathlib import Path
from typing import Callable, NamedTuple, Optional

from process_usage import run_cli

#: What a hostile input may cost, result or refusal (issue 26's acceptance; process_usage's
#: shared defaults are 10 s and 1 GB, stricter than the issue).
LIMIT_SECONDS = 30.0
LIMIT_BYTES = 2 << 30
KILL_SECONDS = 35.0
ADDRESS_SPACE = 6 << 30
#: The longest refusal line accepted (a value is quoted clipped, not whole).
LONGEST_LINE = 2000


class Case(NamedTuple):
    name: str
    argv: list
    expected: str                     # 'ok', 'error', 'either' or 'terminated'
    trigger: Optional[Path] = None    # SIGTERM once this file exists
    guard: bool = False               # compare the working folder's bytes before and after
    out: Optional[str] = None         # the case's output folder (default: the value of --out)
    seconds: float = LIMIT_SECONDS    # the case's own time limit
    check: Optional[Callable[[str, int], Optional[str]]] = None   # (stderr, status) -> problem


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# -- inputs -----------------------------------------------------------------------------------------
def _png_header_only(width: int, height: int) -> bytes:
    """A PNG whose IHDR claims ``width`` x ``height`` RGB, with a few rows of real data."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    rows = zlib.compress(b"\0" * ((3 * width + 1) * 4))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", rows) + chunk(b"IEND", b""))


def _eval_scene(folder: Path, rows: int = 1_000_000, ids: int = 10_000) -> None:
    """gt.txt of ``rows`` boxes and ``ids`` targets (about 100 a frame) and tracks.txt of noisy copies."""
    import numpy as np

    rng = np.random.default_rng(0)
    life = rows // ids
    per_frame = 100
    target = np.repeat(np.arange(1, ids + 1), life)
    start = ((target - 1) // per_frame) * life
    frame = start + np.tile(np.arange(life), ids) + 1
    lane = (target - 1) % per_frame
    x = 20.0 * lane + (frame - start) * 0.5 + 1
    y = 40.0 * (lane % 20) + 11.0
    gt = np.column_stack([frame, target, x, y, np.full(len(x), 15.0), np.full(len(x), 35.0)])
    tracks = gt.copy()
    tracks[:, 2:4] += rng.normal(0.0, 1.5, size=(len(x), 2))
    tracks[:, 1] = target * 10 + (frame - start) // 40
    for name, table in (("eval_gt.txt", gt), ("eval_tracks.txt", tracks)):
        np.savetxt(folder / name, table, fmt=["%d", "%d", "%.2f", "%.2f", "%.2f", "%.2f"], delimiter=",",
                   footer="", comments="")
        with open(folder / name) as f, open(folder / (name + ".tmp"), "w") as g:   # 7-10 columns of MOT
            for line in f:
                g.write(line.rstrip("\n") + ",1,-1,-1,-1\n")
        os.replace(folder / (name + ".tmp"), folder / name)


def prepare(folder: Path) -> None:
    """The demo scene, a truncated copy, and the hostile files of the cases."""
    import cv2
    import numpy as np

    status, err = run_cli(["track", "--demo", "--out", "d", "--no-progress", "--no-video"], folder)[:2]
    if status != 0:
        sys.exit(f"cannot render the demo scene: {err}")
    video = (folder / "d" / "scene.avi").read_bytes()
    (folder / "t.avi").write_bytes(video[:709000])
    gt_text = (folder / "d" / "gt.txt").read_text()
    gt = gt_text.splitlines()
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

    # -- tracking inputs
    (folder / "png20k").mkdir()
    (folder / "png20k" / "000001.png").write_bytes(_png_header_only(20000, 20000))
    writer = cv2.VideoWriter(str(folder / "big.avi"), cv2.VideoWriter_fourcc(*"MJPG"), 25, (10000, 10000))
    writer.write(np.zeros((10000, 10000, 3), np.uint8))
    writer.release()
    capture = cv2.VideoCapture(str(folder / "d" / "scene.avi"))
    frames = [capture.read()[1] for _ in range(5)]
    capture.release()
    (folder / "imgs").mkdir()
    for k, image in enumerate(frames, 1):
        cv2.imwrite(str(folder / "imgs" / f"{k:06d}.png"), image)
    height, width = frames[0].shape[:2]
    for name, length in (("mot_len7", "10000000"), ("mot_len20", "100000000000000000000")):
        shutil.copytree(folder / "imgs", folder / name / "img1")
        (folder / name / "seqinfo.ini").write_text(
            f"[Sequence]\nname={name}\nimDir=img1\nframeRate=25\nseqLength={length}\n"
            f"imWidth={width}\nimHeight={height}\nimExt=.png\n")
    os.mkfifo(folder / "fifo.avi")

    # -- text files
    rows = [line.split(",") for line in gt]
    det = [",".join([r[0], "-1", *r[2:6], "1", "-1", "-1", "-1"]) for r in rows]
    (folder / "det.txt").write_text("\n".join(det) + "\n")
    (folder / "det_underscore.txt").write_text("\n".join(["1_0" + det[0][len(rows[0][0]):], *det[1:]]) + "\n")
    tiny = [",".join([r[0], "-1", r[2], r[3], "1e-300", "1e-300", "1", "-1", "-1", "-1"]) for r in rows]
    (folder / "det_tiny.txt").write_text("\n".join(tiny) + "\n")
    for name in ("fifo_det.txt", "fifo_gt.txt", "fifo_tracks.txt"):
        os.mkfifo(folder / name)
    for name in ("folder_det.txt", "folder_gt.txt", "folder_tracks.txt"):
        (folder / name).mkdir()
    past = [",".join([str(int(r[0]) + 100), *r[1:]]) for r in rows[:20]]
    (folder / "gt_past.txt").write_text(gt_text + "\n".join(past) + "\n")
    _eval_scene(folder)

    # -- output folders
    def user_file(path: str, text: str = "my own file, not a run's\n") -> None:
        (folder / path).parent.mkdir(parents=True, exist_ok=True)
        (folder / path).write_text(text)

    user_file("o_user/tracks.txt", "1,1,10,10,20,50,1,-1,-1,-1\n")
    user_file("demo_user/gt.txt", "1,1,10,10,20,50,1,-1,-1,-1\n")
    (folder / "ov").mkdir()
    shutil.copy(folder / "d" / "scene.avi", folder / "ov" / "scene.avi")
    (folder / "od").mkdir()
    shutil.copy(folder / "det.txt", folder / "od" / "det.txt")
    for k in (1, 2, 3):
        user_file(f"outside{k}.txt", f"outside file {k}\n")
        (folder / f"os{k}").mkdir()
    os.symlink("../outside1.txt", folder / "os1" / ".tracks.partial.txt")
    os.symlink("../outside2.txt", folder / "os2" / ".tracks.partial.txt")
    os.symlink("../outside3.txt", folder / "os3" / "summary.json")
    user_file("od1/summary.json/keep.txt")
    user_file("od2/tracks.txt/keep.txt")
    user_file("od3/summary.json/keep.txt")
    (folder / "ofifo").mkdir()
    os.mkfifo(folder / "ofifo" / ".belief-outputs.json")
    user_file("omanifest/.belief-outputs.json", "my own notes, in a file of this name\n")
    status, err = run_cli(["track", "d/scene.avi", "--init-from-gt", "d/gt.txt", "--out", "rr", "--no-progress",
                           "--no-video"], folder)[:2]
    if status != 0:
        sys.exit(f"cannot track the demo scene: {err}")
    with open(folder / "rr" / "tracks.txt", "a") as f:
        f.write("1,99,10,10,20,50,1,-1,-1,-1\n")

    # -- experiments
    sequence = '[[sequences]]\nscene = "crossing"\nframes = 5\n'
    toml = {
        "grid_dup.toml": sequence + "[grid]\nrules = [" + ", ".join(['"r_rule"'] * 1000) + "]\n"
                         "cues = [" + ", ".join(['"colour"'] * 1000) + "]\n",
        "name400.toml": f'[[sequences]]\nname = "{"n" * 400}"\nscene = "crossing"\nframes = 5\n'
                        "[tracker]\nparticles = 10\n",
        "nul.toml": '[[sequences]]\nname = "a\\u0000b"\nscene = "crossing"\nframes = 5\n',
        "deep_seeds.toml": "seeds = " + "[" * 100000 + "]" * 100000 + "\n" + grid,
        "frames12.toml": '[[sequences]]\nscene = "crossing"\nframes = 1000000000000\n',
        "scene5.toml": "[[sequences]]\nscene = 5\n",
        "video5000.toml": f'[[sequences]]\nvideo = "{"abcd/" * 999}video.avi"\ngt = "d/gt.txt"\n',
        "million.toml": "seeds = 1000\n" + sequence
                        + "".join(f'[[methods]]\nname = "m{k}"\nparticles = {10 + k}\n' for k in range(1000)),
        "cues5.toml": sequence + "[tracker]\ncues = 5\n",
    }
    for name, text in toml.items():
        (folder / name).write_text(text)
    (folder / "exp_self").mkdir()
    (folder / "exp_self" / "grid.toml").write_text(grid)


def _names_limit(stderr: str, status: int) -> Optional[str]:
    """A refusal of a grid too large must name the limit (an option --max-...)."""
    if status != 0 and "--max-" not in stderr:
        return "the refusal names no --max-... limit"
    return None


def cases(folder: Path) -> list[Case]:
    """The cases, in order."""
    track = ["track", "d/scene.avi", "--no-progress"]
    gt_run = [*track, "--init-from-gt", "d/gt.txt", "--no-video"]
    listed = [
        Case("1 truncated video", ["track", "t.avi", "--init-from-gt", "d/gt.txt", "--out", "o1", "--no-progress"],
             "error"),
        Case("2 track: gt id 1e20", [*track, "--init-from-gt", "gt_id.txt", "--out", "o2a"], "error"),
        Case("2 track: gt frame 2^63", [*track, "--init-from-gt", "gt_frame.txt", "--out", "o2b"], "error"),
        Case("2 eval: gt frame 2^63", ["eval", "d/tracks.txt", "gt_frame.txt"], "error"),
        Case("2 track: gt box 1e308", [*track, "--init-from-gt", "gt_box.txt", "--out", "o2c"], "error"),
        Case("2 eval: gt box 1e308", ["eval", "d/tracks.txt", "gt_box.txt"], "error"),
        Case("3 SIGTERM during track", [*track, "--init-from-gt", "d/gt.txt", "--out", "o3"], "terminated",
             folder / "o3" / ".annotated.partial.avi"),
        Case("4 --out ''", ["track", "--demo", "--out", "", "--no-progress"], "error"),
        Case("5 500 init boxes", [*track, "--init", "init500.csv", "--out", "o5"], "error"),
        Case("6 gt frame 0", [*track, "--init-from-gt", "gt_frame0.txt", "--out", "o6"], "error"),
        Case("7 experiment: binary config", ["experiment", "binary.toml", "--no-progress"], "error"),
        Case("7 experiment: seeds = 1e9 --dry-run", ["experiment", "seeds.toml", "--dry-run"], "error"),
        Case("7 experiment: --workers 0", ["experiment", "grid.toml", "--workers", "0"], "error"),
        Case("7 experiment: --out is a file", ["experiment", "grid.toml", "--out", "a_file"], "error"),
        Case("7 experiment: unreachable scheduler", ["experiment", "grid.toml", "--out", "o7", "--no-progress",
                                                     "--scheduler", f"tcp://127.0.0.1:{free_port()}"], "error"),
    ]

    # -- A: tracking inputs (issue 26: no bounds before work starts)
    listed += [
        Case("A PNG header 20000 x 20000", ["track", "png20k", "--out", "oA1", "--no-progress", "--no-video"],
             "error"),
        Case("A video 10000 x 10000", ["track", "big.avi", "--out", "oA2", "--no-progress", "--no-video"], "error"),
    ]
    for count, expected in (("1000000", "either"), ("10000000", "error"), ("1000000000", "error"),
                            ("100000000000000000000", "error")):
        listed.append(Case(f"A --particles {count}", [*gt_run, "--particles", count, "--out", f"oA_p{len(count)}"],
                           expected))
    settings = [("colour.samples=[100000,100000]", "error"), ("background.mixtures=100000", "error"),
                ("background.history=2147483648", "error"), ("cues=5", "error"),
                ("motion.sigma_pos=1e308", "error"), ("cues=" + "[" * 10000 + "]" * 10000, "error")]
    for k, (value, expected) in enumerate(settings):
        shown = value if len(value) < 40 else value[:12] + "...(nested 10000)"
        listed.append(Case(f"A --set {shown}", [*gt_run, "--set", value, "--out", f"oA_s{k}"], expected))
    listed += [
        Case("A settings TOML: [tracker] cues = 5", ["experiment", "cues5.toml", "--dry-run"], "error"),
        Case("A seqinfo seqLength 10^7", ["track", "mot_len7", "--out", "oA_l7", "--no-progress", "--no-video"],
             "error"),
        Case("A seqinfo seqLength 10^20", ["track", "mot_len20", "--out", "oA_l20", "--no-progress", "--no-video"],
             "error"),
        Case("A pattern d/%300000000d.png", ["track", "d/%300000000d.png", "--out", "oA_pat", "--no-progress",
                                             "--no-video"], "error"),
        Case("A track ''", ["track", "", "--out", "oA_empty", "--no-progress", "--no-video"], "error"),
        Case("A FIFO as the video", ["track", "fifo.avi", "--out", "oA_fifo", "--no-progress", "--no-video"],
             "error"),
        Case("A /dev/zero as the video", ["track", "/dev/zero", "--out", "oA_zero", "--no-progress", "--no-video"],
             "error"),
        Case("A source path of 100000 chars", ["track", "x" * 100000, "--out", "oA_long", "--no-progress",
                                               "--no-video"], "error"),
    ]

    # -- B: text files
    listed += [
        Case("B det.txt field 1_0", [*track, "--detections", "det_underscore.txt", "--out", "oB1", "--no-video"],
             "error"),
        Case("B det.txt boxes of 1e-300 px", [*track, "--detections", "det_tiny.txt", "--out", "oB2", "--no-video"],
             "error"),
    ]
    for kind, det, gtf, tracks in (("/dev/zero", "/dev/zero", "/dev/zero", "/dev/zero"),
                                   ("FIFO", "fifo_det.txt", "fifo_gt.txt", "fifo_tracks.txt"),
                                   ("folder", "folder_det.txt", "folder_gt.txt", "folder_tracks.txt")):
        slug = kind.strip("/").replace("/", "_")
        listed += [
            Case(f"B {kind} as det.txt", [*track, "--detections", det, "--out", f"oB_d_{slug}", "--no-video"],
                 "error"),
            Case(f"B {kind} as gt.txt (track)", [*track, "--init-from-gt", gtf, "--out", f"oB_g_{slug}",
                                                 "--no-video"], "error"),
            Case(f"B {kind} as tracks (eval)", ["eval", tracks, "d/gt.txt"], "error"),
            Case(f"B {kind} as gt.txt (eval)", ["eval", "d/tracks.txt", gtf], "error"),
        ]
    listed += [
        Case("B gt.txt past the video's end", [*track, "--init-from-gt", "gt_past.txt", "--out", "oB3",
                                               "--no-video"], "error"),
        Case("B eval 10^6 gt rows, 10^4 ids", ["eval", "eval_tracks.txt", "eval_gt.txt"], "ok"),
    ]

    # -- C: output folders (guarded: nothing a user owns changes)
    def guarded(name, argv, expected, **kw):
        return Case(name, argv, expected, guard=True, **kw)

    listed += [
        guarded("C user's tracks.txt in --out", [*gt_run, "--out", "o_user"], "error"),
        guarded("C --demo, user's gt.txt in --out", ["track", "--demo", "--out", "demo_user", "--no-progress",
                                                     "--no-video"], "error"),
        guarded("C --out = the image folder", ["track", "imgs", "--out", "imgs", "--no-progress", "--no-video"],
                "error"),
        guarded("C --out inside the image folder", ["track", "imgs", "--out", "imgs/sub", "--no-progress",
                                                    "--no-video"], "error"),
        guarded("C --out holds the video", ["track", "ov/scene.avi", "--init-from-gt", "d/gt.txt", "--out", "ov",
                                            "--no-progress", "--no-video"], "error"),
        guarded("C --out holds the video, --force", ["track", "ov/scene.avi", "--init-from-gt", "d/gt.txt",
                                                     "--out", "ov", "--no-progress", "--no-video", "--force"],
                "error"),
        guarded("C --out holds det.txt", [*track, "--detections", "od/det.txt", "--out", "od", "--no-video"],
                "error"),
        guarded("C .tracks.partial.txt symlink", [*gt_run, "--out", "os1"], "error"),
        guarded("C .tracks.partial.txt symlink --force", [*gt_run, "--out", "os2", "--force"], "either"),
        guarded("C summary.json symlink --force", [*gt_run, "--out", "os3", "--force"], "either"),
        guarded("C --out component of 300 chars", [*gt_run, "--out", "q" * 300], "error"),
        guarded("C folder summary.json in --out", [*gt_run, "--out", "od1"], "error"),
        guarded("C folder tracks.txt in --out --force", [*gt_run, "--out", "od2", "--force"], "error"),
        guarded("C folder summary.json --force", [*gt_run, "--out", "od3", "--force"], "error"),
        guarded("C FIFO .belief-outputs.json", [*gt_run, "--out", "ofifo"], "error"),
        guarded("C FIFO .belief-outputs.json --force", [*gt_run, "--out", "ofifo", "--force"], "either"),
        guarded("C user's own .belief-outputs.json", [*gt_run, "--out", "omanifest"], "error"),
        guarded("C --out's parent is a file", [*gt_run, "--out", "a_file/sub"], "error"),
        guarded("C rerun after editing tracks.txt", [*gt_run, "--out", "rr"], "error"),
    ]

    # -- D: experiments
    listed += [
        Case("D grid 1000 rules x 1000 cues", ["experiment", "grid_dup.toml", "--dry-run"], "error"),
        guarded("D sequence name of 400 chars", ["experiment", "name400.toml", "--out", "oD_400", "--no-progress",
                                                 "--workers", "1"], "either"),
        Case("D NUL in a sequence name", ["experiment", "nul.toml", "--dry-run"], "error"),
        Case("D seeds nested 100000 deep", ["experiment", "deep_seeds.toml", "--dry-run"], "error"),
        Case("D frames = 10^12", ["experiment", "frames12.toml", "--dry-run"], "error"),
        Case("D scene = 5", ["experiment", "scene5.toml", "--dry-run"], "error"),
        Case("D video path of 5000 chars", ["experiment", "video5000.toml", "--dry-run"], "error"),
        Case("D 10^6-run grid --dry-run (2 s)", ["experiment", "million.toml", "--dry-run"], "either",
             seconds=2.0, check=_names_limit),
        guarded("D --out holds its own TOML", ["experiment", "exp_self/grid.toml", "--out", "exp_self",
                                               "--no-progress", "--workers", "1"], "error"),
    ]
    return listed


# -- the byte-for-byte check of guarded cases ------------------------------------------------------------
_digests: dict[tuple, str] = {}


def _digest(path: Path, st: os.stat_result) -> str:
    key = (str(path), st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)
    if key not in _digests:
        h = hashlib.sha256()
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
        _digests[key] = h.hexdigest()
    return _digests[key]


def snapshot(folder: Path) -> dict[str, str]:
    """Every entry under ``folder``: file -> its SHA-256, symlink -> its target, other kinds by kind."""
    seen: dict[str, str] = {}
    for root, dirs, files in os.walk(folder, followlinks=False):
        for name in dirs + files:
            path = Path(root) / name
            rel = str(path.relative_to(folder))
            st = os.lstat(path)
            if stat.S_ISLNK(st.st_mode):
                seen[rel] = "link:" + os.readlink(path)
            elif stat.S_ISREG(st.st_mode):
                seen[rel] = "file:" + _digest(path, st)
            elif stat.S_ISDIR(st.st_mode):
                seen[rel] = "dir"
            else:
                seen[rel] = f"other:{stat.S_IFMT(st.st_mode)}"
    return seen


def _manifest_names(out: Path) -> set[str]:
    path = out / ".belief-outputs.json"
    try:
        if not stat.S_ISREG(os.lstat(path).st_mode):
            return set()
        return set(json.loads(path.read_text()).get("files", {}))
    except (OSError, ValueError, AttributeError):
        return set()


def _out_of(case: Case) -> Optional[str]:
    if case.out is not None:
        return case.out
    if "--out" in case.argv:
        return str(case.argv[case.argv.index("--out") + 1])
    return None


def tree_problems(case: Case, before: dict[str, str], after: dict[str, str], status: int,
                  manifest: set[str]) -> list[str]:
    """What changed that may not have: the guarded case's byte-for-byte check."""
    out = os.path.normpath(_out_of(case) or "\0")
    changed = sorted(p for p in set(before) | set(after) if before.get(p) != after.get(p))
    problems = []
    for path in changed:
        inside = path == out or path.startswith(out + os.sep)
        if not inside:
            problems.append(f"changed outside --out: {path}")
        elif path in before and path != out:
            name = os.path.relpath(path, out)
            if status != 0:
                problems.append(f"changed after a refusal: {path}")
            elif not ("--force" in case.argv and os.sep not in name) and name not in manifest:
                problems.append(f"changed a file no run wrote: {path}")
    return problems[:3] + ([f"... {len(problems) - 3} more"] if len(problems) > 3 else [])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--keep", metavar="DIR", help="work in DIR and keep it")
    parser.add_argument("-k", metavar="TEXT", help="only the cases whose name contains TEXT")
    args = parser.parse_args()
    folder = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="hardening-"))
    folder.mkdir(parents=True, exist_ok=True)
    try:
        prepare(folder)
        print(f"{'case':38} {'exit':>4} {'stderr':>6} {'seconds':>8} {'peak MB':>8}  verdict", flush=True)
        failed = 0
        selected = [case for case in cases(folder) if not args.k or args.k in case.name]
        for case in selected:
            before = snapshot(folder) if case.guard else {}
            out = _out_of(case)
            manifest = _manifest_names(folder / out) if case.guard and out else set()
            status, err, seconds, peak, killed = run_cli(case.argv, folder, terminate_when=case.trigger,
                                                         kill_after=KILL_SECONDS, address_space=ADDRESS_SPACE)
            lines = err.splitlines()
            leftovers = [str(p.relative_to(folder)) for p in folder.rglob(".*.partial*")
                         if not p.is_symlink()]
            problems = [f"killed after {KILL_SECONDS:g} s"] if killed else []
            if not killed and seconds > case.seconds:
                problems.append(f"> {case.seconds:g} s")
            if peak > LIMIT_BYTES:
                problems.append(f"> {LIMIT_BYTES / 2**30:g} GB")
            if "Traceback" in err:
                problems.append("traceback")
            if not killed:
                if case.expected == "ok" and status != 0 or case.expected == "error" and status == 0 \
                        or case.expected == "terminated" and status != 143:
                    problems.append(f"exit {status}")
                elif status < 0 or 125 < status and case.expected != "terminated":
                    problems.append(f"exit {status} (signal)")
                if status == 0 and lines:
                    problems.append(f"{len(lines)} stderr lines")
                if status != 0 and len(lines) != 1:
                    problems.append(f"{len(lines)} stderr lines")
                if status != 0 and len(err) > LONGEST_LINE:
                    problems.append(f"stderr of {len(err):,} chars")
                if case.check is not None:
                    problems += [p for p in [case.check(err, status)] if p]
            if leftovers:
                problems.append(f"left {', '.join(leftovers)}")
            if case.guard:
                problems += tree_problems(case, before, snapshot(folder), status, manifest)
            verdict = "PASS" if not problems else "FAIL (" + "; ".join(problems) + ")"
            failed += bool(problems)
            print(f"{case.name:38} {status:>4} {len(lines):>6} {seconds:>8.2f} {peak / 2**20:>8.0f}  {verdict}",
                  flush=True)
            if lines:
                print(f"    {lines[0][:150]}", flush=True)
        print(f"{failed} of {len(selected)} cases failed")
        return 1 if failed else 0
    finally:
        if not args.keep:
            shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    os.environ.pop("OPENCV_FFMPEG_LOGLEVEL", None)   # measure the plugin's own setting, not the caller's
    sys.exit(main())
