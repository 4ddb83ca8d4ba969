"""Nothing a user owns is overwritten: ``--out`` takes only the files a run names, written safely (issue 26, point 2).

Each test replays one defect measured on the code before: a user's own tracks.txt or gt.txt
in ``--out`` replaced, ``--out`` an image folder, a symlinked partial file followed out of
``--out``, tracebacks on output paths that cannot be written, ``belief plot --out X`` writing
X.png, an experiment's long sequence name.  Every refusal is one line with exit status 1, and
every file outside ``--out`` or not written by the run is compared byte for byte.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import numpy as np
import pytest

from belief.cli import main
from belief_tracking import scenes

MANIFEST = ".belief-outputs.json"
QUICK = ["--particles", "10", "--no-video", "--no-progress"]


def snapshot(root: Path) -> dict[str, object]:
    """Every path under ``root``: a file's bytes, a symlink's target, or ``"folder"``."""
    seen: dict[str, object] = {}
    for folder, dirs, files in os.walk(root):
        for name in dirs + files:
            path = Path(folder) / name
            key = str(path.relative_to(root))
            if path.is_symlink():
                seen[key] = ("symlink", os.readlink(path))
            elif path.is_dir():
                seen[key] = "folder"
            else:
                seen[key] = path.read_bytes()
    return seen


def belief(capsys, *argv) -> tuple[int, str, str]:
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def refused(status: int, err: str) -> str:
    """The one line of a refusal (exit status 1, no traceback)."""
    assert status == 1, err
    assert "Traceback" not in err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("belief: error: "), err
    return lines[0]


@pytest.fixture
def video(tmp_path) -> tuple[Path, Path]:
    """A 4-frame 64 x 48 video with one red block, and the init file of that block."""
    frames = np.full((4, 48, 64, 3), 100, np.uint8)
    frames[:, 10:30, 20:30] = (40, 40, 190)
    path = tmp_path / "v.avi"
    scenes.write_video(path, frames)
    boxes = tmp_path / "boxes.csv"
    boxes.write_text("1,21,11,10,20\n")
    return path, boxes


def write_images(folder: Path, n_frames: int = 4) -> Path:
    import cv2

    folder.mkdir(parents=True)
    for k in range(n_frames):
        image = np.full((48, 64, 3), 100, np.uint8)
        image[10:30, 20:30] = (40, 40, 190)
        cv2.imwrite(str(folder / f"{k + 1:06d}.png"), image)
    return folder


# -- files the user owns -------------------------------------------------------------------------------
def test_a_users_own_tracks_file_in_out_is_refused_and_left_byte_for_byte(tmp_path, capsys, video, quick_plot):
    source, boxes = video
    out = tmp_path / "out"
    out.mkdir()
    (out / "tracks.txt").write_bytes(b"my own tracks, not a run's\n")
    before = snapshot(tmp_path)
    status, stdout, err = belief(capsys, "track", source, "--init", boxes, "--out", out, *QUICK)
    line = refused(status, err)
    assert "no run of belief wrote there: tracks.txt" in line and "--force" in line
    assert stdout == "" and snapshot(tmp_path) == before


def test_the_demo_never_replaces_a_users_ground_truth(tmp_path, capsys):
    out = tmp_path / "D"
    out.mkdir()
    (out / "gt.txt").write_bytes(b"1,1,10,10,20,40,1,1,1\n")
    before = snapshot(tmp_path)
    status, _, err = belief(capsys, "track", "--demo", "--out", out, "--no-progress", "--no-video")
    assert "gt.txt" in refused(status, err)
    assert snapshot(tmp_path) == before


def test_force_replaces_the_runs_own_names_and_leaves_every_other_file(tmp_path, capsys, video, quick_plot):
    source, boxes = video
    out = tmp_path / "out"
    out.mkdir()
    (out / "tracks.txt").write_bytes(b"mine\n")
    (out / "notes.txt").write_bytes(b"my notes\n")
    (out / "annotated.avi").write_bytes(b"not a run's video\n")   # a run name this run does not write
    status, stdout, _ = belief(capsys, "track", source, "--init", boxes, "--out", out, *QUICK, "--force")
    assert status == 0
    assert (out / "notes.txt").read_bytes() == b"my notes\n"
    assert (out / "annotated.avi").read_bytes() == b"not a run's video\n"
    assert np.loadtxt(out / "tracks.txt", delimiter=",").shape == (4, 10)
    # The message names the files written, and only those.
    assert stdout.splitlines()[0].endswith(f"outputs in {out}: tracks.txt, diagnostics.csv, diagnostics.png, "
                                           "tracks.png, summary.json")


def test_a_run_may_write_again_where_runs_wrote_but_not_over_an_edited_file(tmp_path, capsys, video, quick_plot):
    source, boxes = video
    out = tmp_path / "out"
    argv = ["track", source, "--init", boxes, "--out", out, *QUICK]
    assert belief(capsys, *argv)[0] == 0
    assert belief(capsys, *argv)[0] == 0              # every file there is a run's: no --force needed
    assert (out / MANIFEST).is_file()
    (out / "tracks.txt").write_bytes(b"edited by hand\n")
    before = snapshot(tmp_path)
    status, _, err = belief(capsys, *argv)
    assert "tracks.txt" in refused(status, err)
    assert snapshot(tmp_path) == before


def test_a_run_with_no_video_removes_the_video_of_the_run_before_only(tmp_path, capsys, video, quick_plot):
    source, boxes = video
    out = tmp_path / "out"
    argv = ["track", source, "--init", boxes, "--out", out, "--particles", "10", "--no-progress"]
    assert belief(capsys, *argv)[0] == 0 and (out / "annotated.avi").is_file()
    assert belief(capsys, *argv, "--no-video")[0] == 0
    assert {p.name for p in out.iterdir()} == {"tracks.txt", "diagnostics.csv", "diagnostics.png", "tracks.png",
                                               "summary.json", MANIFEST}


# -- inputs in --out -----------------------------------------------------------------------------------
@pytest.mark.parametrize("case", ["out is the image folder", "out inside the image folder", "out holds the video",
                                  "out holds det.txt", "out holds gt.txt", "out holds the init file",
                                  "out holds the pattern's images"])
def test_an_out_that_is_inside_or_holds_an_input_is_refused_even_with_force(tmp_path, capsys, video, case):
    source, boxes = video
    images = write_images(tmp_path / "frames")
    argv = ["track", source, "--init", boxes]
    if case == "out is the image folder":
        argv[1], out = images, images
    elif case == "out inside the image folder":
        argv[1], out = images, images / "results"
    elif case == "out holds the pattern's images":
        argv[1], out = images / "%06d.png", tmp_path
    elif case == "out holds the video":
        out = tmp_path
    elif case == "out holds det.txt":
        out = tmp_path / "run"
        out.mkdir()
        (out / "det.txt").write_text("1,-1,21,11,10,20,0.9\n")
        argv += ["--detections", out / "det.txt"]
    elif case == "out holds gt.txt":
        out = tmp_path / "run"
        out.mkdir()
        (out / "gt.txt").write_text("1,1,21,11,10,20,1,1,1\n")
        argv += ["--gt", out / "gt.txt"]
    else:
        out = tmp_path
    before = snapshot(tmp_path)
    for force in ([], ["--force"]):
        status, _, err = belief(capsys, *argv, "--out", out, *QUICK, *force)
        line = refused(status, err)
        assert "input" in line and "another folder" in line
    assert snapshot(tmp_path) == before


# -- never through a symlink -----------------------------------------------------------------------------
@pytest.mark.skipif(sys.platform == "win32", reason="symlinks need privileges on Windows")
def test_a_symlinked_partial_file_is_never_followed(tmp_path, capsys, video, quick_plot):
    source, boxes = video
    outside = tmp_path / "precious.txt"
    outside.write_bytes(b"outside --out\n")
    out = tmp_path / "out"
    out.mkdir()
    (out / ".tracks.partial.txt").symlink_to(outside)
    argv = ["track", source, "--init", boxes, "--out", out, *QUICK]
    status, _, err = belief(capsys, *argv)
    assert ".tracks.partial.txt" in refused(status, err)
    assert belief(capsys, *argv, "--force")[0] == 0
    assert outside.read_bytes() == b"outside --out\n"
    assert os.readlink(out / ".tracks.partial.txt") == str(outside)
    assert not (out / "tracks.txt").is_symlink() and np.loadtxt(out / "tracks.txt", delimiter=",").shape == (4, 10)


@pytest.mark.skipif(sys.platform == "win32", reason="symlinks need privileges on Windows")
def test_a_symlink_at_an_output_name_is_replaced_not_followed(tmp_path, capsys, video, quick_plot):
    source, boxes = video
    outside = tmp_path / "precious.json"
    outside.write_bytes(b'{"mine": true}\n')
    out = tmp_path / "out"
    out.mkdir()
    (out / "summary.json").symlink_to(outside)
    argv = ["track", source, "--init", boxes, "--out", out, *QUICK]
    refused(*belief(capsys, *argv)[::2])
    assert belief(capsys, *argv, "--force")[0] == 0
    assert outside.read_bytes() == b'{"mine": true}\n'
    assert not (out / "summary.json").is_symlink() and json.loads((out / "summary.json").read_text())["frames"] == 4


# -- output paths that cannot be written ------------------------------------------------------------------
@pytest.mark.parametrize("case", ["read-only folder", "kernel folder", "name over 255", "folder named summary.json",
                                  "folder named tracks.txt", "a file as a parent"])
def test_an_output_path_that_cannot_take_the_files_is_one_line(tmp_path, capsys, video, quick_plot, case):
    source, boxes = video
    out = tmp_path / "out"
    if case == "read-only folder":
        if os.name != "posix" or os.geteuid() == 0:
            pytest.skip("a folder without write permission is still writable for root")
        out.mkdir()
        out.chmod(0o555)
    elif case == "kernel folder":
        out = Path("/sys/kernel")
        if not out.is_dir():
            pytest.skip("no /sys/kernel here")
    elif case == "name over 255":
        out = tmp_path / ("o" * 300)
    elif case == "a file as a parent":
        out = boxes / "out"
    else:
        out.mkdir()
        (out / case.split()[-1]).mkdir()
    before = snapshot(tmp_path)
    try:
        status, stdout, err = belief(capsys, "track", source, "--init", boxes, "--out", out, *QUICK)
        if case.startswith("folder named"):
            # --force replaces files of the run's names, never a folder.
            forced = belief(capsys, "track", source, "--init", boxes, "--out", out, *QUICK, "--force")
            assert "is a folder, where the run writes its file" in refused(*forced[::2])
    finally:
        if case == "read-only folder":
            out.chmod(0o755)
    line = refused(status, err)
    assert stdout == "" and line.startswith(f"belief: error: --out {out}")
    assert snapshot(tmp_path) == before


# -- belief plot -----------------------------------------------------------------------------------------
BBA = {"frame": ["a", "b"], "mass": {"a": 0.6, "a|b": 0.4}}


@pytest.fixture
def bba(tmp_path) -> Path:
    pytest.importorskip("matplotlib")
    path = tmp_path / "m.json"
    path.write_text(json.dumps(BBA))
    return path


def test_plot_writes_exactly_the_file_it_names(tmp_path, capsys, bba):
    out = tmp_path / "X"
    status, stdout, _ = belief(capsys, "plot", bba, "--out", out)
    assert status == 0 and stdout == f"wrote {out}\n"
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["X", "m.json"]


@pytest.mark.parametrize("case", ["missing folder", "name over 255", "a folder", "unknown format"])
def test_plot_to_a_path_it_cannot_write_is_one_line(tmp_path, capsys, bba, case):
    out = {"missing folder": tmp_path / "missing_dir" / "x.png", "name over 255": tmp_path / ("x" * 300 + ".png"),
           "a folder": tmp_path, "unknown format": tmp_path / "x.notaformat"}[case]
    before = snapshot(tmp_path)
    refused(*belief(capsys, "plot", bba, "--out", out)[::2])
    assert snapshot(tmp_path) == before


@pytest.mark.skipif(sys.platform == "win32", reason="symlinks need privileges on Windows")
def test_plot_replaces_a_symlink_rather_than_writing_through_it(tmp_path, capsys, bba):
    outside = tmp_path / "precious.png"
    outside.write_bytes(b"not a picture of ours")
    link = tmp_path / "fig.png"
    link.symlink_to(outside)
    assert belief(capsys, "plot", bba, "--out", link)[0] == 0
    assert outside.read_bytes() == b"not a picture of ours"
    assert not link.is_symlink() and link.read_bytes()[:4] == b"\x89PNG"


# -- belief experiment -----------------------------------------------------------------------------------
def test_an_experiment_with_a_400_character_sequence_name_runs_or_is_refused_in_one_line(tmp_path, capsys):
    name = "s" * 400
    grid = tmp_path / "grid.toml"
    grid.write_text(f'[[sequences]]\nname = "{name}"\nscene = "crossing"\nframes = 2\n\n'
                    '[[methods]]\nname = "m"\nparticles = 10\n')
    out = tmp_path / "grid"
    status, stdout, err = belief(capsys, "experiment", grid, "--out", out, "--workers", "1", "--no-progress")
    if status == 0:
        assert "ran 1 runs" in stdout
        assert all(len(p.name) <= 255 for p in (out / "cells").iterdir())
    else:
        assert "name" in refused(status, err) and not out.exists()


def test_an_experiment_whose_out_holds_its_settings_file_is_refused(tmp_path, capsys):
    grid = tmp_path / "grid.toml"
    grid.write_text('[[sequences]]\nscene = "crossing"\nframes = 2\n\n[[methods]]\nname = "m"\nparticles = 10\n')
    before = snapshot(tmp_path)
    status, _, err = belief(capsys, "experiment", grid, "--out", tmp_path, "--workers", "1", "--no-progress")
    assert "grid.toml" in refused(status, err)
    assert snapshot(tmp_path) == before


def test_a_file_of_the_manifest_s_name_that_no_run_wrote_is_the_user_s(tmp_path, capsys, video, quick_plot):
    source, boxes = video
    out = tmp_path / "out"
    out.mkdir()
    (out / ".belief-outputs.json").write_text("my notes\n")
    before = snapshot(tmp_path)
    status, _, err = belief(capsys, "track", source, "--init", boxes, "--out", out, *QUICK)
    assert ".belief-outputs.json" in refused(status, err)
    assert snapshot(tmp_path) == before


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs")
def test_a_fifo_of_the_manifest_s_name_is_refused_without_blocking(tmp_path, capsys, video, quick_plot):
    source, boxes = video
    out = tmp_path / "out"
    out.mkdir()
    os.mkfifo(out / ".belief-outputs.json")
    status, _, err = belief(capsys, "track", source, "--init", boxes, "--out", out, *QUICK)
    assert ".belief-outputs.json" in refused(status, err)
    assert (out / ".belief-outputs.json").is_fifo()
