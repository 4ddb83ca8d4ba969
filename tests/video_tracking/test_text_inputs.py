"""The tracking plugin's text inputs (det.txt, gt.txt, tracks files) and ``belief eval``: strict, bounded, in proportion.

The vectorised readers are checked against a line-by-line reading of the same rules
(values, and the message and line of the first bad line), the scoring against motmetrics'
own accumulator and metrics, and the hostile inputs of issue 26 (a field ``1_0``, boxes of
1e-300 px, /dev/zero or a FIFO as the file, ground truth after the end of the video, ids² memory)
each get a test.  Time and memory figures are measured by ``benchmarks/bench_text_inputs.py``,
not here.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from dataclasses import asdict

import numpy as np
import pytest

from belief_tracking import evaluation, motfiles
from belief_tracking.detections import read_detections
from belief_tracking.errors import DetectionFileError, TrackFileError, TrackingError
from belief_tracking.evaluation import evaluate, identity_swaps, matched_pairs
from belief_tracking.motfiles import read_mot


def _line_by_line(path, table):
    """The rows of a file by the strict line reader alone, or the error of its first bad line."""
    text = motfiles.read_table_text(path, "track file")
    rows, lines, error = motfiles._read_lines(text, 1, str(path), table)
    if error is not None:
        raise error
    return np.asarray(rows, dtype=np.float64).reshape(-1, table.columns)


def _random_text(rng, fields_range=(6, 10)):
    pieces = ["12", "-1", "0", "3.5", "1e2", "2.5E-1", ".5", "5.", "-0", "+3", "1e400", "nan", "inf", "1_0",
              "abc", "", "0.0001", "1e-300", "0.9", "\u0661", "1.2.3", "1e", "--1", "9" * 25, "0." + "0" * 30 + "5"]
    lines = []
    for _ in range(int(rng.integers(0, 14))):
        count = int(rng.integers(*fields_range)) if rng.random() < 0.9 else int(rng.integers(3, 13))
        fields = [str(rng.integers(1, 6)), str(rng.integers(-1, 5)), f"{rng.uniform(-5, 70):.2f}",
                  f"{rng.uniform(-5, 50):.2f}", f"{rng.uniform(0.5, 20):.3f}", f"{rng.uniform(0.5, 20):.3f}",
                  f"{rng.random():.4f}", "-1", "-1", "-1", "-1", "-1"][:count]
        if rng.random() < 0.25:
            fields[int(rng.integers(len(fields)))] = str(rng.choice(pieces))
        lines.append(str(rng.choice([",", ", ", " ", "\t", " , "])).join(fields))
        if rng.random() < 0.1:
            lines.append(str(rng.choice(["", "  ", "\t"])))
    end = str(rng.choice(["\n", "\r\n", "\r", "\x0c"]))
    return end.join(lines) + (end if rng.random() < 0.7 else "")


def _outcome(read, *args, **kwargs):
    try:
        return "ok", read(*args, **kwargs)
    except TrackFileError as error:
        return "error", str(error)


# -- the vectorised reading equals the line-by-line reading ---------------------------------------------
@pytest.mark.parametrize("block", [None, 1, 37])
def test_vectorised_reading_gives_the_values_and_first_error_of_the_line_by_line_reading(tmp_path, monkeypatch,
                                                                                         block):
    if block is not None:
        monkeypatch.setattr(motfiles, "_BLOCK", block)   # several blocks per file, and a line per block
    rng = np.random.default_rng(block or 0)
    path = tmp_path / "gt.txt"
    for _ in range(300):
        path.write_text(_random_text(rng), encoding="utf-8")
        fast = _outcome(read_mot, path, allow_empty=True)
        slow = _outcome(_line_by_line, path, motfiles._MOT_TABLE)
        if slow[0] == "ok":
            # The line reader alone has no check of repeated ids: those are compared with the message below.
            keys = {(r[0], r[1]) for r in slow[1].tolist()}
            if len(keys) < len(slow[1]):
                assert fast[0] == "error" and "twice (first on line" in fast[1]
                continue
            assert fast[0] == "ok", fast
            assert fast[1].tobytes() == slow[1].tobytes()  # the same floats, signs of zero included
        else:
            assert fast[0] == "error"
            # A repeated id on an earlier line is the first error; otherwise the same message.
            assert fast[1] == slow[1] or "twice (first on line" in fast[1]


def test_vectorised_detections_equal_the_line_by_line_detections(tmp_path):
    rng = np.random.default_rng(7)
    path = tmp_path / "det.txt"
    table = __import__("belief_tracking.detections", fromlist=["_detection_table"])._detection_table(5, (64, 48))
    for _ in range(300):
        path.write_text(_random_text(rng, (7, 11)), encoding="utf-8")
        fast = _outcome(read_detections, path, frame_count=5, image_size=(64, 48))
        slow = _outcome(_line_by_line, path, table)
        if slow[0] == "error" or fast[0] == "error":
            assert fast[0] == "error" and (slow[0] == "error" or "no detections" in fast[1])
            if slow[0] == "error":
                assert fast[1] == slow[1].replace("track file", "detection file")
            continue
        rows = slow[1]
        for frame in fast[1].frames:
            expected = rows[rows[:, 0] == frame][:, 2:7] - [1.0, 1.0, 0.0, 0.0, 0.0]
            assert fast[1].at(frame).tobytes() == expected.tobytes()


def test_numbers_read_exactly_as_python_reads_them(tmp_path):
    rng = np.random.default_rng(3)
    numbers = [f"{v:.{int(rng.integers(0, 20))}f}" for v in rng.uniform(-1e3, 1e3, 2000)]
    numbers += [f"{v:.17e}" for v in rng.uniform(-1e5, 1e5, 500)] + [
        "9007199254740993", "0.1", "123456789012345678", "1234567890123456789", "4.9e-324", "1e-320", "-0",
        "0." + "0" * 40 + "7", "1" + "0" * 30, "+.5e+3", "7.e-2", "179769313486231570e290"]
    path = tmp_path / "tracks.txt"
    path.write_text("".join(f"1,{k},0,0,1,1,{n}\n" for k, n in enumerate(numbers)))
    flags = read_mot(path)[:, 6]
    assert flags.tobytes() == np.array([float(n) for n in numbers]).tobytes()


# -- strict numbers (issue 26: "1_0" was read as 10) --------------------------------------------------------
@pytest.mark.parametrize("field", ["1_0", "1_000.5", "\u0661\u0660", "１０", "0x10", "1e5_0"])
def test_a_field_that_python_would_read_but_a_detector_never_writes_is_refused(tmp_path, field):
    path = tmp_path / "det.txt"
    path.write_text(f"1,-1,11,21,10,20,0.5\n1,-1,{field},21,10,20,0.5\n")
    with pytest.raises(DetectionFileError, match=f"line 2: field 3 is not a number: '{field}'$"):
        read_detections(path)
    gt = tmp_path / "gt.txt"
    gt.write_text(f"1,1,10,20,30,40,1\n2,1,10,20,{field},40,1\n")
    with pytest.raises(TrackFileError, match=f"line 2: field 5 is not a number: '{field}'$"):
        read_mot(gt)


def test_spelt_out_infinities_still_say_not_finite(tmp_path):
    path = tmp_path / "gt.txt"
    path.write_text("1,1,10,20,30,Infinity,1\n")
    with pytest.raises(TrackFileError, match="line 1: field 6 is not finite: 'Infinity'"):
        read_mot(path)


# -- boxes below the files' precision (issue 26: 1e-300 px boxes gave 0 x 0 tracks) -------------------------
@pytest.mark.parametrize("size", ["1e-300", "0.0004", "5e-4"])
def test_a_detection_below_the_precision_of_the_files_is_refused(tmp_path, size):
    path = tmp_path / "det.txt"
    path.write_text(f"1,-1,11,21,{size},20,0.5\n")
    with pytest.raises(DetectionFileError, match=f"line 1: the box size {size} x 20 is below 0.001 px"):
        read_detections(path)


def test_a_ground_truth_box_below_the_precision_is_refused_but_an_empty_one_is_kept(tmp_path):
    path = tmp_path / "gt.txt"
    path.write_text("1,1,10,20,0,0,0\n1,2,10,20,1e-300,40,1\n")
    with pytest.raises(TrackFileError, match="line 2: the box size 1e-300 x 40 is above 0 but below 0.001 px"):
        read_mot(path)
    path.write_text("1,1,10,20,0,0,0\n1,2,10,20,0.001,40,1\n")
    assert read_mot(path)[:, 4].tolist() == [0.0, 0.001]


# -- regular files of bounded size (issue 26: /dev/zero as det.txt filled 3.3 GB) ----------------------------
@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="no /dev/zero")
def test_a_device_is_refused_before_it_is_read():
    with pytest.raises(DetectionFileError, match="'/dev/zero': it is a device, not a regular file"):
        read_detections("/dev/zero")
    with pytest.raises(TrackFileError, match="not a regular file"):
        read_mot("/dev/zero")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs")
def test_a_fifo_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "det.txt"
    os.mkfifo(fifo)
    with pytest.raises(DetectionFileError, match="it is a FIFO, not a regular file"):
        read_detections(fifo)


def test_a_file_over_the_size_limit_is_refused_before_it_is_read(tmp_path, monkeypatch):
    path = tmp_path / "gt.txt"
    path.write_text("".join(f"{k},1,10,20,30,40,1\n" for k in range(1, 11)))
    monkeypatch.setattr(motfiles, "MAX_TEXT_BYTES", 100)
    with pytest.raises(TrackFileError, match="holds 181 bytes, more than belief_tracking.motfiles.MAX_TEXT_BYTES = 100"):
        read_mot(path)
    monkeypatch.setattr(motfiles, "MAX_TEXT_BYTES", 181)
    assert len(read_mot(path)) == 10


# -- ground truth after the end of the video (issue 26: accepted silently) ------------------------------------
def test_ground_truth_after_the_last_frame_of_the_video_is_refused(tmp_path):
    from belief_tracking import scenes
    from belief_tracking.config import TrackerConfig
    from belief_tracking.initiation import init_from_gt
    from belief_tracking.runner import run

    scene = scenes.render(scenes.PRESETS["demo"](0))
    frames = scene.frames[:4]
    gt = scene.ground_truth[scene.ground_truth[:, 0] <= 6].astype(np.float64)
    path = tmp_path / "gt.txt"
    motfiles.write_tracks(path, gt)
    out = tmp_path / "out"
    with pytest.raises(TrackFileError, match=f"^{path}: frame 6 is after the end of the video \\(4 frames\\)$"):
        run(frames, init_from_gt(gt[gt[:, 0] <= 4]), TrackerConfig(particles=10), out_dir=out, gt=str(path),
            write_video=False, write_plot=False, progress=False)
    assert not out.exists() or not any(out.iterdir())


# -- scoring: the same numbers as motmetrics, memory linear in the overlapping pairs ---------------------------
def _motmetrics_scores(gt, hyp):
    """The scores of the implementation before issue 26: motmetrics' accumulator and metrics, verbatim."""
    import motmetrics
    from motmetrics.lap import linear_sum_assignment

    gt = gt[np.argsort(gt[:, 0], kind="stable")]
    hyp = hyp[np.argsort(hyp[:, 0], kind="stable")]
    accumulator = motmetrics.MOTAccumulator(auto_id=False)
    for frame in np.union1d(gt[:, 0], hyp[:, 0]).astype(int):
        g, h = gt[gt[:, 0] == frame], hyp[hyp[:, 0] == frame]
        distance = evaluation.iou_distance(g[:, 2:6], h[:, 2:6])
        scored = g[:, 6] != 0
        kept = np.ones(len(h), dtype=bool)
        if not scored.all() and len(h):
            for i, j in zip(*linear_sum_assignment(distance)):
                if np.isfinite(distance[i, j]) and not scored[i]:
                    kept[j] = False
        accumulator.update(g[scored, 1].astype(int), h[kept, 1].astype(int), distance[np.ix_(scored, kept)],
                           frameid=int(frame))
    names = ["mota", "motp", "idf1", "precision", "recall", "num_switches", "num_false_positives", "num_misses",
             "num_detections", "num_objects", "num_predictions", "num_frames"]
    return motmetrics.metrics.create().compute(accumulator, metrics=names, name="t").iloc[0]


def _random_case(rng):
    n_frames, n_ids = int(rng.integers(1, 12)), int(rng.integers(1, 7))
    gt = [[f, i, i * rng.choice([6.0, 12.0]) + rng.normal(0, 1), rng.integers(0, 3) * 5.0, 10, 10,
           float(rng.random() > 0.15)]
          for f in range(1, n_frames + 1) for i in rng.choice(np.arange(1, n_ids + 1), rng.integers(0, n_ids + 1),
                                                                replace=False)]
    gt.append([1, 99, 300, 300, 10, 10, 1])
    gt = np.array(gt, dtype=np.float64)
    hyp = gt.copy()
    hyp[:, 1] = rng.integers(1, n_ids + 3, size=len(hyp))
    _, first = np.unique(hyp[:, :2], axis=0, return_index=True)
    hyp = hyp[np.sort(first)]
    hyp[:, 2:4] += rng.normal(0, rng.choice([0.5, 2.0, 4.0]), size=(len(hyp), 2))
    return gt, hyp[rng.random(len(hyp)) > 0.2]


def test_scores_equal_motmetrics_to_the_last_bit_on_random_cases():
    rng = np.random.default_rng(11)
    for _ in range(150):
        gt, hyp = _random_case(rng)
        ours, theirs = evaluate(gt, hyp), _motmetrics_scores(gt, hyp)
        assert ours.mota == float(theirs["mota"]) and ours.idf1 == float(theirs["idf1"])
        assert ours.id_switches == theirs["num_switches"] and ours.false_positives == theirs["num_false_positives"]
        assert ours.false_negatives == theirs["num_misses"] and ours.matched_pairs == theirs["num_detections"]
        assert ours.num_objects == theirs["num_objects"] and ours.num_predictions == theirs["num_predictions"]
        assert ours.num_frames == theirs["num_frames"]
        if ours.matched_pairs:
            assert ours.motp == 1.0 - float(theirs["motp"])
        for value in (ours.precision, ours.recall):
            assert not math.isnan(value) or math.isnan(float(theirs["precision"]))


def test_the_sparse_identity_assignment_has_the_dense_one_s_true_positives():
    rng = np.random.default_rng(5)
    for _ in range(150):
        gt, hyp = _random_case(rng)
        matching = evaluation._accumulate(gt, hyp, 0.5)
        if not matching.overlaps:
            continue
        dense, sparse = (evaluation._dense_identity_assignment(matching),
                         evaluation._sparse_identity_assignment(matching))
        assert dense[1] == sparse[1]
        assert len(set(sparse[0].values())) == len(sparse[0])            # one-to-one
        assert sum(matching.overlaps[pair] for pair in sparse[0].items()) == sparse[1]


def test_many_ids_are_scored_through_the_sparse_assignment_with_the_same_idf1(monkeypatch):
    rng = np.random.default_rng(2)
    gt, hyp = _random_case(rng)
    dense = evaluate(gt, hyp)
    monkeypatch.setattr(evaluation, "DENSE_IDENTITY_IDS", 0)
    sparse = evaluate(gt, hyp)
    assert asdict(dense) == asdict(sparse)


def test_scoring_memory_does_not_grow_with_the_square_of_the_ids():
    """8 000 targets each seen in one frame, with tracks of other ids: the dense IDF1 matrix alone was 2 GB."""
    code = """
import tracemalloc, numpy as np
from belief_tracking.evaluation import evaluate
n = 8000
gt = np.column_stack([np.arange(1, n + 1), np.arange(1, n + 1), np.zeros(n), np.zeros(n), np.full(n, 10.0),
                      np.full(n, 10.0), np.ones(n)])
hyp = gt.copy(); hyp[:, 1] += n
tracemalloc.start()
scores = evaluate(gt, hyp)
print(scores.idf1, scores.matched_pairs, tracemalloc.get_traced_memory()[1])
"""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-500:]
    idf1, pairs, peak = done.stdout.split()
    assert float(idf1) == 1.0 and int(pairs) == 8000
    assert int(peak) < 200 * 2**20                                   # 8 000² float64 would be 512 MB


def test_identity_swaps_and_pairs_keep_their_meaning():
    gt = np.array([[f, i, 0 if i == 1 else 50, 0, 10, 10, 1] for f in (1, 2, 3, 4) for i in (1, 2)], dtype=float)
    hyp = gt.copy()
    hyp[6:, 1] = [2, 1]
    hyp[:, 1] = np.where(hyp[:, 1] == 1, 7, 8)
    swaps = identity_swaps(gt, hyp)
    assert (swaps.frames, swaps.pairs, swaps.identities) == (1, 2, {1: 7, 2: 8})
    assert matched_pairs(gt, hyp)[:, :3].tolist() == [[1, 1, 7], [1, 2, 8], [2, 1, 7], [2, 2, 8], [3, 1, 7],
                                                      [3, 2, 8], [4, 1, 8], [4, 2, 7]]


def test_a_bad_threshold_is_still_refused():
    gt = np.array([[1, 1, 0, 0, 10, 10, 1]], dtype=float)
    with pytest.raises(TrackingError, match="max_iou_distance must be in \\[0, 1\\]"):
        evaluate(gt, gt, max_iou_distance=1.5)


# -- the command line: one line, no traceback -------------------------------------------------------------------
@pytest.mark.parametrize("tracks_text, message", [
    ("1,1,1_0,20,30,40,1\n", "field 3 is not a number: '1_0'"),
    (None, "not a regular file"),
])
def test_belief_eval_reports_a_bad_input_in_one_line(tmp_path, tracks_text, message):
    gt = tmp_path / "gt.txt"
    gt.write_text("1,1,10,20,30,40,1\n")
    tracks = tmp_path / "tracks.txt"
    if tracks_text is None:
        tracks = "/dev/zero"
        if not os.path.exists(tracks):
            pytest.skip("no /dev/zero")
    else:
        tracks.write_text(tracks_text)
    run = "import sys; from belief.cli import main; sys.exit(main(sys.argv[1:]))"
    done = subprocess.run([sys.executable, "-c", run, "eval", str(tracks), str(gt)], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode != 0
    assert message in done.stderr and "Traceback" not in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1
