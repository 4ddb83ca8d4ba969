"""Random input to the tracking commands: MOTChallenge rows for ``belief eval`` and ``belief track``,
truncated or corrupt videos and images, and experiment configurations for ``belief experiment``.

Whatever the input, each command either exits 0 with a valid result (finite numbers, nothing on
standard error), or exits non-zero with exactly one line on standard error and no traceback.
The rows mix valid boxes with what a hand-edited or foreign file holds: NaN, infinities, huge
and negative numbers, missing and extra columns, other separators, blank lines, text and stray
bytes.
"""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st

from belief.cli import main

FUZZ = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])

ODD_NUMBERS = st.sampled_from(["nan", "inf", "-inf", "1e20", "1e308", "-1e308", "9223372036854775808", "2147483648",
                               "-5", "0", "", " ", "abc", "1,5", "0x10", "1e-320", "−1"])
#: A valid row of a 12-frame scene of 320 x 240: frame, id, x, y, w, h, conf, -1, -1, -1.
VALID = st.tuples(st.integers(1, 12), st.integers(1, 5), st.floats(-20, 330), st.floats(-20, 250),
                  st.floats(1, 120), st.floats(1, 200), st.floats(0, 1)).map(
    lambda r: f"{r[0]},{r[1]},{r[2]:.2f},{r[3]:.2f},{r[4]:.2f},{r[5]:.2f},{r[6]:.3f},-1,-1,-1")


@st.composite
def damaged(draw) -> str:
    """A valid row with some of its fields replaced, dropped or added to, or another separator."""
    fields = draw(VALID).split(",")
    for _ in range(draw(st.integers(1, 3))):
        k = draw(st.integers(0, len(fields) - 1))
        action = draw(st.sampled_from(["replace", "drop", "add"]))
        if action == "replace":
            fields[k] = draw(ODD_NUMBERS)
        elif action == "drop" and len(fields) > 1:
            del fields[k]
        else:
            fields.insert(k, draw(ODD_NUMBERS))
    return draw(st.sampled_from([",", ", ", " ", "\t", ";"])).join(fields)


LINES = st.one_of(VALID, VALID, damaged(), st.sampled_from(["", "   ", "# a comment", "frame,id,x,y,w,h"]),
                  st.text(max_size=12))
FILES = st.one_of(st.lists(LINES, min_size=0, max_size=8).map("\n".join),
                  # a well-formed file: one box per id and frame
                  st.lists(VALID, min_size=1, max_size=8, unique_by=lambda row: tuple(row.split(",")[:2])).map(
                      "\n".join),
                  st.binary(max_size=40).map(lambda b: b.decode("latin-1")))


def run(argv, capsys) -> tuple[int, str, str]:
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # a RuntimeWarning (overflow, invalid cast) is a failure too
        status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def check_contract(status: int, err: str) -> None:
    assert "Traceback" not in err
    if status == 0:
        assert err == "", err
    else:
        assert len(err.splitlines()) == 1 and err.startswith("belief"), err


def finite_numbers(value) -> None:
    if isinstance(value, float):
        assert math.isfinite(value), value
    elif isinstance(value, dict):
        for item in value.values():
            finite_numbers(item)
    elif isinstance(value, list):
        for item in value:
            finite_numbers(item)


@FUZZ
@given(tracks=FILES, ground_truth=FILES, which=st.sampled_from(["tracks", "gt", "both"]))
def test_eval_of_random_rows(tmp_path, capsys, scene_files, tracks, ground_truth, which):
    good = scene_files[1].read_text(encoding="utf-8")
    tracks_file, gt_file = tmp_path / "tracks.txt", tmp_path / "gt.txt"
    tracks_file.write_text(tracks if which != "gt" else good, encoding="utf-8", errors="surrogateescape")
    gt_file.write_text(ground_truth if which != "tracks" else good, encoding="utf-8", errors="surrogateescape")
    status, out, err = run(["eval", tracks_file, gt_file, "--json"], capsys)
    event(f"exit {status}")
    check_contract(status, err)
    if status == 0:
        scores = json.loads(out)
        finite_numbers(scores)
        assert scores["mota"] is None or scores["mota"] <= 1.0


@FUZZ
@given(rows=FILES, kind=st.sampled_from(["--detections", "--init-from-gt"]))
def test_track_with_random_rows(tmp_path, capsys, scene_files, quick_plot, rows, kind):
    video, _ = scene_files
    rows_file = tmp_path / "rows.txt"
    rows_file.write_text(rows, encoding="utf-8", errors="surrogateescape")
    out = tmp_path / "run"
    argv = ["track", video, kind, rows_file, "--out", out, "--particles", "20", "--no-progress", "--no-video"]
    status, _, err = run(argv, capsys)
    event(f"exit {status}")
    check_contract(status, err)
    if status == 0:
        text = (out / "tracks.txt").read_text(encoding="utf-8")
        rows = [[float(field) for field in line.split(",")] for line in text.splitlines() if line.strip()]
        assert all(len(row) == 10 and all(map(math.isfinite, row)) for row in rows), text[:500]


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(keep=st.floats(0.0, 1.0), corrupt=st.lists(st.tuples(st.floats(0.0, 1.0), st.binary(min_size=1, max_size=64)),
                                                  max_size=3))
@example(keep=0.001, corrupt=[])        # the header alone: OpenCV's Motion-JPEG reader printed to stderr
def test_track_a_truncated_or_corrupt_video(tmp_path, capfd, scene_files, quick_plot, keep, corrupt):
    # capfd sees the decoder's own writes to the process's stderr too: none may pass.
    video, gt = scene_files
    data = bytearray(video.read_bytes()[: int(len(video.read_bytes()) * keep)])
    for where, junk in corrupt:
        start = int(len(data) * where)
        data[start:start + len(junk)] = junk
    damaged_video = tmp_path / "damaged.avi"
    damaged_video.write_bytes(bytes(data))
    out = tmp_path / "run"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        status = main([str(a) for a in ["track", damaged_video, "--init-from-gt", gt, "--out", out, "--particles",
                                        "20", "--no-progress", "--no-video"]])
    err = capfd.readouterr().err
    event(f"exit {status}")
    check_contract(status, err)
    assert status in (0, 1)


def test_a_damaged_image_in_a_folder_is_one_line(tmp_path, capfd):
    # OpenCV's decoder warns on descriptor 2 ("PNG input buffer is incomplete"): only the error may show.
    import cv2

    folder = tmp_path / "frames"
    folder.mkdir()
    for k in range(1, 4):
        cv2.imwrite(str(folder / f"{k:06d}.png"), np.full((60, 80, 3), 100, np.uint8))
    damaged = folder / "000002.png"
    damaged.write_bytes(damaged.read_bytes()[:60])
    status = main(["track", str(folder), "--out", str(tmp_path / "run"), "--no-progress", "--no-video"])
    err = capfd.readouterr().err
    assert status == 1
    check_contract(status, err)
    assert "000002.png" in err


CONFIG_VALUES = st.one_of(st.integers(-3, 5), st.sampled_from(["0", "1e9", "-1", "nan", "inf", '"x"', "[]", "[0, 1]",
                                                              "true", '"crossing"', "{}", '"r_rule"', '"colour"']))
CONFIG_KEYS = st.sampled_from(["name", "seeds", "scene", "frames", "particles", "rule", "cues", "init", "video",
                               "unknown", "fusion", "grid"])


@st.composite
def configs(draw) -> str:
    """A small experiment configuration, often valid, with random keys and values mixed in."""
    seeds = draw(st.sampled_from(["1", "[0]", "0", "[]", "-2", "1000000000", '"two"']))
    frames = draw(st.sampled_from(["3", "0", "-1", "2.5", '"3"']))
    top = [f"seeds = {seeds}"]
    sequence = ['scene = "crossing"', f"frames = {frames}"]
    tracker = ["particles = 5"]
    for section in (top, sequence, tracker):
        for _ in range(draw(st.integers(0, 2))):
            section.append(f"{draw(CONFIG_KEYS)} = {draw(CONFIG_VALUES)}")
    text = "\n".join([*top, "[[sequences]]", *sequence, "[tracker]", *tracker]) + "\n"
    return draw(st.one_of(st.just(text), st.text(max_size=30), st.binary(max_size=30).map(
        lambda b: b.decode("latin-1"))))


@FUZZ
@given(config=configs())
def test_experiment_dry_run_of_random_configurations(tmp_path, capsys, config):
    path = tmp_path / "grid.toml"
    path.write_text(config, encoding="utf-8", errors="surrogateescape")
    status, out, err = run(["experiment", path, "--dry-run", "--out", tmp_path / "runs"], capsys)
    event(f"exit {status}")
    check_contract(status, err)
    if status == 0:
        assert "runs" in out


def test_a_video_is_read_where_stderr_cannot_be_redirected(scene_files, monkeypatch):
    # Without a descriptor to duplicate (an embedding that closed it), the decoder's noise is let through.
    import os

    from belief_tracking.video import VideoReader

    def no_dup(fd):
        raise OSError("no descriptor")

    monkeypatch.setattr(os, "dup", no_dup)
    with VideoReader(scene_files[0]) as reader:
        assert sum(1 for _ in reader) == 12
