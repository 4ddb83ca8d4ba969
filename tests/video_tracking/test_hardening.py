"""Hostile but fair input to ``belief track``, ``belief eval`` and ``belief experiment``.

Each test replays one reproducer: a truncated video, huge ids, frames and boxes, SIGTERM in
the middle of a run, an empty ``--out``, hundreds of init boxes, a ground-truth frame 0, and
bad experiment arguments.  Each ends in exactly one line on standard error and no traceback
(or in a valid result where that is right), and leaves no stray file.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from belief.cli import main

STAGED = ".*.partial*"
CLI = "import sys; from belief.cli import main; sys.exit(main())"


def belief(argv: list[str], capsys) -> tuple[int, str, str]:
    """Run the ``belief`` command line here, with every warning an error; returns status, stdout, stderr."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def belief_process(argv: list[str], **kwargs) -> subprocess.Popen:
    """The ``belief`` command line in a process of its own (its standard error is the real one)."""
    return subprocess.Popen([sys.executable, "-c", CLI, *[str(a) for a in argv]], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kwargs)


def one_error_line(err: str) -> str:
    assert "Traceback" not in err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("belief"), err
    return lines[0]


def no_staged_files(folder: Path) -> None:
    assert not list(folder.rglob(STAGED))


# -- 1: a truncated or corrupt video -------------------------------------------------------------------
def test_a_truncated_video_keeps_the_decoded_frames_and_exits_1_in_one_line(tmp_path, scene_files):
    video, gt = scene_files
    data = video.read_bytes()
    truncated = tmp_path / "t.avi"
    truncated.write_bytes(data[: int(len(data) * 0.6)])
    out = tmp_path / "o"
    env = {k: v for k, v in os.environ.items() if not k.startswith("OPENCV_")}
    process = belief_process(["track", truncated, "--init-from-gt", gt, "--out", out, "--no-progress",
                              "--no-video", "--particles", "20"], env=env)
    stdout, stderr = process.communicate()
    assert process.returncode == 1
    line = one_error_line(stderr)           # no FFmpeg line beside it
    summary = json.loads((out / "summary.json").read_text())
    decoded = summary["frames"]
    assert 1 <= decoded < 12 and summary["expected_frames"] == 12 and summary["complete"] is False
    assert f"decoded {decoded} of the 12 frames" in line and str(out) in line
    assert f"tracked {decoded} frames" in stdout
    assert {p.name for p in out.iterdir()} == {"tracks.txt", "diagnostics.csv", "diagnostics.png", "tracks.png",
                                               "summary.json", ".belief-outputs.json"}
    tracks = np.loadtxt(out / "tracks.txt", delimiter=",", ndmin=2)
    assert tracks[:, 0].max() <= decoded


# -- 2: ids, frames and boxes out of any sane range --------------------------------------------------
GT_LINE = "1,1,93,129,18,52,1,1,1"
HUGE = {
    "id 1e20": ("1,1e20,93,129,18,52,1,1,1", "line 1: the id must be an integer", "1e20"),
    "frame 2^63": ("9223372036854775808,1,93,129,18,52,1,1,1", "line 1: the frame must be an integer",
                   "9223372036854775808"),
    "id 2^63": ("1,9223372036854775808,93,129,18,52,1,1,1", "line 1: the id must be an integer",
                "9223372036854775808"),
    "box 1e308": ("1,1,1e308,129,18,52,1,1,1", "line 1: the box x 1e+308 is beyond 1e+06 pixels", "1e+308"),
    "height 1e308": ("1,1,93,129,18,1e308,1,1,1", "line 1: the box height 1e+308 is beyond", "1e+308"),
}


@pytest.mark.parametrize("command", ["track", "eval"])
@pytest.mark.parametrize("case", list(HUGE))
def test_huge_ids_frames_and_boxes_are_one_line_naming_file_line_and_value(tmp_path, capsys, scene_files, command,
                                                                            case):
    video, good_gt = scene_files
    line, message, value = HUGE[case]
    gt = tmp_path / "gt.txt"
    gt.write_text(line + "\n" + "\n".join(good_gt.read_text().splitlines()[1:]) + "\n")
    out = tmp_path / "o"
    if command == "track":
        argv = ["track", video, "--init-from-gt", gt, "--out", out, "--no-progress", "--no-video"]
    else:
        tracks = tmp_path / "tracks.txt"
        tracks.write_text(GT_LINE + "\n")
        argv = ["eval", tracks, gt]
    status, stdout, stderr = belief(argv, capsys)
    assert status == 1 and stdout == ""
    error = one_error_line(stderr)
    assert f"{gt}, {message}" in error and value in error
    assert not out.exists()


def test_huge_values_in_detection_and_init_files_are_refused_too(tmp_path, capsys, scene_files):
    video, _ = scene_files
    detections = tmp_path / "det.txt"
    detections.write_text("1,-1,11,21,1e300,20,0.5\n")
    boxes = tmp_path / "boxes.csv"
    boxes.write_text("1e20,21,11,10,20\n")
    out = tmp_path / "o"
    status, _, stderr = belief(["track", video, "--detections", detections, "--out", out, "--no-progress"], capsys)
    assert status == 1 and f"{detections}, line 1: the box width 1e+300 is beyond" in one_error_line(stderr)
    status, _, stderr = belief(["track", video, "--init", boxes, "--out", out, "--no-progress"], capsys)
    assert status == 1 and f"{boxes}, line 1: the id must be an integer" in one_error_line(stderr)
    assert not out.exists()


# -- 3: SIGTERM in the middle of a run ---------------------------------------------------------------
@pytest.mark.skipif(sys.platform == "win32", reason="SIGTERM is a POSIX signal")
def test_sigterm_removes_the_staged_files_and_exits_143_in_one_line(tmp_path):
    # The demo keeps its files staged for many seconds, so the signal lands in the middle of the
    # run however slowly this test is scheduled.
    out = tmp_path / "o"
    process = belief_process(["track", "--demo", "--out", out, "--no-progress"])
    try:
        deadline = time.monotonic() + 120
        while not (out / ".annotated.partial.avi").exists() and process.poll() is None \
                and time.monotonic() < deadline:
            time.sleep(0.01)
        assert process.poll() is None, "the run ended before it could be interrupted"
        process.send_signal(signal.SIGTERM)
        _, stderr = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 128 + signal.SIGTERM
    assert "terminated (SIGTERM); nothing of this run was left" in one_error_line(stderr)
    assert not out.exists()


@pytest.mark.skipif(sys.platform == "win32", reason="SIGTERM is a POSIX signal")
def test_sigterm_during_the_commit_waits_for_it_so_no_run_is_left_half_renamed(tmp_path, monkeypatch):
    from belief_tracking import outdir

    class Stop(Exception):
        pass

    def stop(signum, frame):
        raise Stop()

    staged = outdir.OutputFolder(tmp_path / "o", ["a.txt", "b.txt", "summary.json"])
    for name in staged.names:
        staged.path(name).write_text(name)
    real_replace = os.replace

    def replace_then_signal(source, target):
        real_replace(source, target)
        os.kill(os.getpid(), signal.SIGTERM)   # after the first rename: the rest must still happen

    previous = signal.signal(signal.SIGTERM, stop)
    try:
        monkeypatch.setattr(outdir.os, "replace", replace_then_signal)
        with pytest.raises(Stop):
            staged.commit()
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert staged.committed
    assert sorted(p.name for p in (tmp_path / "o").iterdir() if not p.name.startswith(".")) == \
        ["a.txt", "b.txt", "summary.json"]
    assert not list((tmp_path / "o").glob(STAGED))


def test_sigterm_after_the_files_are_in_place_says_so(tmp_path, capsys, monkeypatch, scene_files):
    from belief_tracking import cli as tracking_cli

    def terminated_while_reporting(args, summary):
        raise tracking_cli._Terminated()

    monkeypatch.setattr(tracking_cli, "_report", terminated_while_reporting)
    video, gt = scene_files
    out = tmp_path / "o"
    status, _, stderr = belief(["track", video, "--init-from-gt", gt, "--out", out, "--no-progress",
                                "--particles", "50", "--no-video"], capsys)
    assert status == 128 + signal.SIGTERM
    assert f"after the run had written all its files to {out}" in one_error_line(stderr)
    assert (out / "summary.json").is_file() and (out / "tracks.txt").is_file()


# -- 4: an empty output path --------------------------------------------------------------------------
@pytest.mark.parametrize("command", ["track", "experiment"])
def test_an_empty_out_is_refused_and_writes_nothing_here(tmp_path, capsys, monkeypatch, command):
    monkeypatch.chdir(tmp_path)
    if command == "track":
        argv = ["track", "--demo", "--out", "", "--no-progress"]
    else:
        Path("grid.toml").write_text('[[sequences]]\nscene = "crossing"\nframes = 3\n')
        argv = ["experiment", "grid.toml", "--out", " ", "--workers", "1", "--no-progress"]
    before = set(os.listdir(tmp_path))
    status, stdout, stderr = belief(argv, capsys)
    assert status == 1 and stdout == ""
    assert "--out must name a folder" in one_error_line(stderr)
    assert set(os.listdir(tmp_path)) == before


# -- 5: hundreds of init boxes -------------------------------------------------------------------------
def test_more_targets_at_once_than_max_targets_are_refused_before_any_work(tmp_path, capsys, scene_files):
    video, _ = scene_files
    boxes = tmp_path / "boxes.csv"
    rng = np.random.default_rng(0)
    boxes.write_text("".join(f"{k},{rng.integers(1, 290)},{rng.integers(1, 180)},20,50\n" for k in range(1, 501)))
    out = tmp_path / "o"
    status, stdout, stderr = belief(["track", video, "--init", boxes, "--out", out, "--no-progress"], capsys)
    assert status == 1 and stdout == ""
    error = one_error_line(stderr)
    assert "500 targets at once (at frame 1)" in error and "max_targets = 100" in error
    assert "--set max_targets=500" in error
    assert not out.exists()


def test_the_target_limit_is_raisable(tmp_path, capsys, scene_files, quick_plot):
    video, _ = scene_files
    boxes = tmp_path / "boxes.csv"
    boxes.write_text("1,21,11,10,20\n2,61,11,10,20\n3,101,11,10,20\n")
    out = tmp_path / "o"
    argv = ["track", video, "--init", boxes, "--out", out, "--no-progress", "--no-video", "--particles", "10",
            "--warm-up", "0", "--set", "initiation=false"]
    status, _, stderr = belief([*argv, "--set", "max_targets=2"], capsys)
    assert status == 1 and "3 targets at once" in one_error_line(stderr) and not out.exists()
    status, _, stderr = belief([*argv, "--set", "max_targets=3"], capsys)
    assert status == 0 and stderr == ""
    assert set(np.loadtxt(out / "tracks.txt", delimiter=",")[:, 1]) == {1, 2, 3}
    no_staged_files(out)


def test_automatic_tracks_wait_for_room_under_the_limit():
    from belief_tracking.config import TrackerConfig
    from belief_tracking.detections import Detections
    from belief_tracking.tracker import Tracker

    frames = np.full((4, 60, 80, 3), 90, np.uint8)
    boxes = [[5 + 15 * k, 10, 10, 20, 0.9] for k in range(5)]
    detections = Detections({f: boxes for f in range(1, 5)})
    config = TrackerConfig.from_settings({"particles": 10, "max_targets": 3, "cues": ["colour", "location"],
                                          "initiation": {"first_frame": True}})
    tracker = Tracker(config, None, np.random.default_rng(0))
    counts = [len(tracker.targets) for _ in tracker.track(frames, detections=detections)]
    assert max(counts) == 3


# -- 6: a ground-truth frame 0 -------------------------------------------------------------------------
@pytest.mark.parametrize("command", ["track", "eval"])
def test_a_ground_truth_frame_0_names_the_file_and_line(tmp_path, capsys, scene_files, command):
    video, good_gt = scene_files
    gt = tmp_path / "gt.txt"
    gt.write_text(good_gt.read_text() + "0,1,93,129,18,52,1,1,1\n")
    line = len(good_gt.read_text().splitlines()) + 1
    out = tmp_path / "o"
    argv = ["track", video, "--init-from-gt", gt, "--out", out, "--no-progress", "--no-video"] \
        if command == "track" else ["eval", good_gt, gt]
    status, stdout, stderr = belief(argv, capsys)
    assert status == 1 and stdout == ""
    assert f"{gt}, line {line}: the frame must be an integer of at least 1, got 0" in one_error_line(stderr)
    assert not out.exists()


# -- 7: belief experiment ------------------------------------------------------------------------------
GRID = '[[sequences]]\nscene = "crossing"\nframes = 3\n[tracker]\nparticles = 10\n'


def _scheduler_case():
    try:
        import distributed  # noqa: F401
    except ImportError:
        return pytest.param("scheduler", marks=pytest.mark.skip(reason="needs the dask extra"))
    return "scheduler"


@pytest.mark.parametrize("case", ["binary", "a billion seeds", "workers 0", "out is a file", _scheduler_case()])
def test_a_bad_experiment_is_one_line_before_anything_is_printed(tmp_path, capsys, case):
    import socket

    config = tmp_path / "grid.toml"
    config.write_text(GRID)
    out = tmp_path / "out"
    argv = ["experiment", config, "--out", out, "--no-progress"]
    message = None
    if case == "binary":
        config.write_bytes(bytes(range(256)) * 4)
        message = "not a TOML file (it is not UTF-8 text)"
    elif case == "a billion seeds":
        config.write_text("seeds = 1000000000\n" + GRID)
        argv.append("--dry-run")
        message = "seeds = 1000000000 is more runs than an experiment may have (MAX_RUNS = 100000)"
    elif case == "workers 0":
        argv += ["--workers", "0"]
    elif case == "out is a file":
        out.write_text("mine")
        message = "exists and is not a folder"
    else:
        with socket.socket() as free:           # a port that nothing listens on
            free.bind(("127.0.0.1", 0))
            port = free.getsockname()[1]
        argv += ["--scheduler", f"tcp://127.0.0.1:{port}"]
        message = "cannot reach the Dask scheduler"
    status, stdout, stderr = belief(argv, capsys)
    assert status != 0 and stdout == ""
    error = one_error_line(stderr)
    if message is not None:
        assert message in error
    if case == "out is a file":
        assert out.read_text() == "mine"
    else:
        assert not out.exists()


def test_the_scheduler_help_and_the_docs_say_a_dask_scheduler_runs_pickled_tasks(capsys):
    with pytest.raises(SystemExit):
        main(["experiment", "--help"])
    assert "pickled" in " ".join(capsys.readouterr().out.split())
    docs = (Path(__file__).resolve().parents[2] / "docs" / "experiments.md").read_text(encoding="utf-8")
    assert "pickled" in docs and "trust" in docs
