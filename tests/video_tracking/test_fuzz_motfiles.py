"""Random MOTChallenge rows, well formed or not, given to ``belief eval`` and ``belief track``.

Whatever the rows, each command either exits 0 with scores that are finite numbers, or exits
non-zero with exactly one line on standard error and no traceback.  The rows mix valid boxes
with what a hand-edited or foreign file holds: NaN, infinities, huge and negative numbers,
missing and extra columns, other separators, blank lines, text and stray bytes.
"""

from __future__ import annotations

import dataclasses
import json
import math
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st

from belief.cli import main
from belief_tracking import scenes

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
                  st.lists(VALID, min_size=1, max_size=8).map("\n".join),
                  st.binary(max_size=40).map(lambda b: b.decode("latin-1")))


@pytest.fixture(scope="module")
def scene_files(tmp_path_factory):
    """A short crossing scene (12 frames of 320 x 240) as scene.avi and gt.txt."""
    folder = tmp_path_factory.mktemp("scene")
    scene = scenes.render(dataclasses.replace(scenes.crossing(0), n_frames=12))
    scenes.write_video(folder / "scene.avi", scene)
    scenes.write_gt(folder / "gt.txt", scene.ground_truth, visibility=scene.visibility)
    return folder / "scene.avi", folder / "gt.txt"


def run(argv, capsys) -> tuple[int, str, str]:
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # a RuntimeWarning (overflow, invalid cast) is a failure too
        status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def check_contract(status: int, err: str) -> None:
    assert "Traceback" not in err
    if status == 0:
        assert err.strip() == "" or all(line.startswith(("tracked", "warning")) for line in err.splitlines()), err
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
        finite_numbers({k: v for k, v in scores.items() if k not in ("mota",)})
        assert scores["mota"] is None or scores["mota"] <= 1.0


@FUZZ
@given(rows=FILES, kind=st.sampled_from(["--detections", "--init-from-gt"]))
def test_track_with_random_rows(tmp_path, capsys, scene_files, monkeypatch, rows, kind):
    from belief_tracking import outputs

    # The diagnostics figure is drawn and tested elsewhere; here it would cost a second a run.
    monkeypatch.setattr(outputs, "plot_diagnostics", lambda path, *args, **kwargs: path.write_bytes(b"png"))
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
def test_track_a_truncated_or_corrupt_video(tmp_path, capfd, scene_files, monkeypatch, keep, corrupt):
    # capfd sees the decoder's own writes to the process's stderr too: none may pass.
    from belief_tracking import outputs

    monkeypatch.setattr(outputs, "plot_diagnostics", lambda path, *args, **kwargs: path.write_bytes(b"png"))
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
