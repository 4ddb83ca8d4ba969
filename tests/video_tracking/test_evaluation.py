"""Track evaluation: MOT file reading, IoU distances, CLEAR MOT / IDF1 scores and ``belief eval``."""

import argparse
import json
import math
import re
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from belief.errors import BeliefError
from belief_tracking import motfiles
from belief_tracking.cli import register_eval
from belief_tracking.errors import TrackFileError, TrackingError
from belief_tracking.evaluation import IdentitySwaps, Scores, evaluate, identity_swaps, iou_distance
from belief_tracking.motfiles import read_mot

REPO_ROOT = Path(__file__).resolve().parents[2]
PETS_GT = REPO_ROOT.parent / "shared" / "data" / "pets09_s2l1_f0001_0200" / "gt.txt"


def track(track_id, frames, x0=0.0, y0=0.0, width=30.0, height=40.0, step=(2.0, 1.0), flag=1):
    """Rows ``frame, id, x, y, w, h, flag`` of one box moving by ``step`` pixels a frame."""
    frames = np.asarray(list(frames), dtype=float)
    k = frames - frames[0]
    return np.column_stack([frames, np.full_like(frames, track_id), x0 + step[0] * k, y0 + step[1] * k,
                            np.full_like(frames, width), np.full_like(frames, height), np.full_like(frames, flag)])


def three_targets(frames=range(1, 21)):
    return np.vstack([track(1, frames, 0, 0), track(2, frames, 200, 50), track(3, frames, 400, 300, 20, 60)])


def shifted(rows, dx, dy, id_offset=0):
    out = rows.copy()
    out[:, 2] += dx
    out[:, 3] += dy
    out[:, 1] += id_offset
    return out


# -- evaluate: hand-computed cases --------------------------------------------------------------------
def test_perfect_tracks_score_one():
    gt = three_targets()
    hyp = shifted(gt, 0, 0, id_offset=100)  # other id numbers, same boxes
    scores = evaluate(gt, hyp)
    assert scores.mota == 1.0 and scores.idf1 == 1.0 and scores.motp == 1.0
    assert scores.precision == 1.0 and scores.recall == 1.0
    assert (scores.id_switches, scores.false_positives, scores.false_negatives) == (0, 0, 0)
    assert scores.matched_pairs == scores.num_objects == scores.num_predictions == len(gt) == 60
    assert scores.num_frames == 20 and scores.ignored_predictions == 0
    assert scores.mean_centre_error == 0.0 and scores.median_centre_error == 0.0


def test_known_shift_gives_known_centre_error_and_iou():
    gt = three_targets()
    scores = evaluate(gt, shifted(gt, 3.0, 4.0))
    assert scores.mean_centre_error == pytest.approx(5.0) and scores.median_centre_error == pytest.approx(5.0)
    assert scores.mota == 1.0 and scores.false_positives == scores.false_negatives == 0
    # 30x40 boxes overlap 27x36 = 972, union 2*1200 - 972; the 20x60 box: 17x56 = 952, union 2*1200 - 952.
    iou_big, iou_small = 972 / 1428, 952 / 1448
    assert scores.motp == pytest.approx((40 * iou_big + 20 * iou_small) / 60)


@pytest.mark.parametrize("dx, matched", [(10.0, True), (11.0, False)])
def test_iou_threshold_is_inclusive_at_one_half(dx, matched):
    # A 30x40 box moved by dx: IoU = (30 - dx) / (30 + dx), exactly 0.5 at dx = 10.
    gt = track(1, range(1, 6))
    scores = evaluate(gt, shifted(gt, dx, 0.0))
    if matched:
        assert scores.mota == 1.0 and scores.motp == pytest.approx(0.5)
        assert scores.mean_centre_error == pytest.approx(10.0)
    else:
        assert (scores.false_negatives, scores.false_positives, scores.matched_pairs) == (5, 5, 0)


def test_shift_beyond_box_width_gives_only_misses_and_false_positives():
    gt = three_targets()
    scores = evaluate(gt, shifted(gt, 61.0, 0.0))  # wider than every box: no overlap at all
    n = len(gt)
    assert scores.false_negatives == n and scores.false_positives == n and scores.matched_pairs == 0
    assert scores.id_switches == 0
    assert scores.mota == pytest.approx(1 - (n + n + 0) / n) == -1.0
    assert scores.recall == 0.0 and scores.precision == 0.0 and scores.idf1 == 0.0
    assert math.isnan(scores.motp) and math.isnan(scores.mean_centre_error) and math.isnan(scores.median_centre_error)
    as_dict = scores.to_dict()
    assert as_dict["motp"] is None and as_dict["mean_centre_error"] is None
    assert json.loads(json.dumps(as_dict)) == as_dict


def test_one_target_changing_hypothesis_id_halfway_is_one_switch():
    gt = track(1, range(1, 11))
    hyp = gt.copy()
    hyp[:5, 1], hyp[5:, 1] = 10, 20
    scores = evaluate(gt, hyp)
    # CLEAR MOT: frame 6 matches object 1 to 20 where it was 10 before -> one switch.
    assert scores.id_switches == 1 and scores.false_positives == scores.false_negatives == 0
    assert scores.mota == pytest.approx(1 - 1 / 10)
    # IDF1: the best single id pairing covers 5 of 10 boxes on each side -> 2*5 / (10 + 10).
    assert scores.idf1 == pytest.approx(0.5)
    assert scores.mean_centre_error == 0.0


def swapped_halfway():
    """Two targets over frames 1-10 and hypotheses that swap their ids from frame 6 on."""
    frames = range(1, 11)
    gt = np.vstack([track(1, frames, 0, 0), track(2, frames, 300, 300)])
    hyp = gt.copy()
    hyp[:, 1] = np.where(gt[:, 1] == 1, 10, 20)
    second_half = gt[:, 0] > 5
    hyp[second_half, 1] = np.where(gt[second_half, 1] == 1, 20, 10)
    return gt, hyp, second_half


def test_two_targets_swapping_identities_halfway_are_two_switches():
    gt, hyp, _ = swapped_halfway()
    scores = evaluate(gt, hyp)
    # Frame 6: object 1 goes to hypothesis 20 (was 10) and object 2 to 10 (was 20): both switch.
    assert scores.id_switches == 2
    assert scores.mota == pytest.approx(1 - 2 / 20)
    assert scores.idf1 == pytest.approx(2 * 10 / (20 + 20))
    assert scores.matched_pairs == 20 and scores.mean_centre_error == 0.0


def test_centre_errors_count_each_switched_pair_once():
    # As above, but the second half of the hypotheses is off by (3, 4): 10 pairs at 0 px, 10 at 5 px.
    # (motmetrics also logs a switched pair as TRANSFER/ASCEND/MIGRATE events; those must not count.)
    gt, hyp, second_half = swapped_halfway()
    hyp[second_half, 2:4] += (3.0, 4.0)
    scores = evaluate(gt, hyp)
    assert scores.id_switches == 2 and scores.matched_pairs == 20
    assert scores.mean_centre_error == pytest.approx(2.5) and scores.median_centre_error == pytest.approx(2.5)


def test_flag_zero_ground_truth_is_ignored_and_its_hypotheses_are_not_false_positives():
    frames = range(1, 11)
    gt = np.vstack([track(1, frames, 0, 0), track(2, frames, 200, 200, flag=0)])
    stray = np.array([[1, 99, 500, 500, 10, 10, 1]])  # overlaps nothing: a real false positive
    hyp = np.vstack([shifted(gt, 0, 0, id_offset=10), stray])
    scores = evaluate(gt, hyp)
    assert scores.num_objects == 10 and scores.ignored_predictions == 10
    assert scores.num_predictions == 11 and scores.false_positives == 1 and scores.false_negatives == 0
    assert scores.mota == pytest.approx(1 - 1 / 10)
    # Without the flag column every row is scored: the second target now counts.
    unflagged = evaluate(gt[:, :6], hyp)
    assert unflagged.num_objects == 20 and unflagged.ignored_predictions == 0 and unflagged.false_positives == 1


def test_hypothesis_far_from_an_ignored_box_stays_a_false_positive():
    # Frame 2 holds only an ignored box and a hypothesis that does not overlap it.
    gt = np.array([[1, 1, 0, 0, 10, 10, 1], [2, 2, 0, 0, 10, 10, 0]])
    hyp = np.array([[1, 5, 0, 0, 10, 10, 1], [2, 5, 100, 100, 10, 10, 1]])
    scores = evaluate(gt, hyp)
    assert scores.false_positives == 1 and scores.ignored_predictions == 0 and scores.num_objects == 1
    assert scores.mota == 0.0


@pytest.mark.parametrize("second_hypothesis, misses, ignored", [(False, 1, 1), (True, 0, 1)])
def test_hypotheses_are_matched_against_all_ground_truth_first(second_hypothesis, misses, ignored):
    # Scored box S at x=3 and ignored box I at x=0; hypothesis A at x=1 overlaps both (IoU 0.67 with S,
    # 0.82 with I).  The first assignment is over all ground truth, so A goes to I and is dropped,
    # leaving S missed -- unless a second hypothesis B sits on S.
    gt = np.array([[1, 1, 3, 0, 10, 10, 1], [1, 2, 0, 0, 10, 10, 0]])
    hyp = [[1, 7, 1, 0, 10, 10, 1]] + ([[1, 8, 3, 0, 10, 10, 1]] if second_hypothesis else [])
    scores = evaluate(gt, np.array(hyp, dtype=float))
    assert scores.false_negatives == misses and scores.false_positives == 0
    assert scores.ignored_predictions == ignored


def test_frames_with_only_hypotheses_or_only_ground_truth():
    gt = track(1, range(1, 6))
    hyp = np.vstack([gt[:3], track(5, range(7, 9))])  # frames 4-5 missed, frames 7-8 extra
    scores = evaluate(gt, hyp)
    assert (scores.false_negatives, scores.false_positives, scores.matched_pairs) == (2, 2, 3)
    assert scores.num_frames == 7 and scores.mota == pytest.approx(1 - 4 / 5)


def test_no_hypotheses_at_all():
    gt = three_targets()
    scores = evaluate(gt, np.zeros((0, 7)))
    assert scores.false_negatives == len(gt) and scores.false_positives == 0 and scores.mota == 0.0
    assert scores.num_predictions == 0 and math.isnan(scores.mean_centre_error)


@pytest.mark.parametrize("gt, hyp, message", [
    (np.zeros((0, 7)), np.zeros((0, 7)), "no rows"),
    (track(1, range(1, 4), flag=0), track(1, range(1, 4)), "flag 0"),
    (np.ones((2, 5)), np.ones((2, 7)), "shape"),
    (np.array([[1.5, 1, 0, 0, 5, 5, 1]]), np.zeros((0, 7)), "integer"),
    (np.array([[1, 1, 0, 0, -5, 5, 1]]), np.zeros((0, 7)), "negative"),
    (np.array([[1, 1, 0, 0, 5, np.nan, 1]]), np.zeros((0, 7)), "finite"),
    (np.array([[1, 1, 0, 0, 5, 5, 1], [1, 1, 9, 9, 5, 5, 1]]), np.zeros((0, 7)), "twice"),
    (track(1, range(1, 4)), np.array([[1, 4, 0, 0, 5, 5, 1], [1, 4, 0, 0, 5, 5, 1]]), "twice"),
])
def test_evaluate_rejects_bad_rows(gt, hyp, message):
    with pytest.raises(TrackingError, match=message):
        evaluate(gt, hyp)


def test_scores_is_frozen_and_its_table_names_every_score():
    scores = evaluate(three_targets(), three_targets())
    with pytest.raises(AttributeError):
        scores.mota = 0.5
    table = scores.format_table()
    assert len(table.splitlines()) == 2 + len(scores.to_dict())
    for label in ("MOTA", "MOTP (mean IoU of matches)", "IDF1", "HOTA (higher-order tracking accuracy)",
                  "DetA (detection accuracy)", "AssA (association accuracy)", "ID switches", "false positives",
                  "mean centre error (px)", "median centre error (px)"):
        assert label in table
    assert list(scores.to_dict()) == [
        "mota", "motp", "idf1", "hota", "deta", "assa", "loca", "detre", "detpr", "assre", "asspr",
        "precision", "recall", "id_switches", "false_positives", "false_negatives",
        "matched_pairs", "num_objects", "num_predictions", "ignored_predictions", "num_frames",
        "mean_centre_error", "median_centre_error"]
    assert isinstance(Scores(**scores.to_dict()), Scores)


# -- identity swaps ----------------------------------------------------------------------------------
def crossed_midway(first_ids=(1, 2), swap_from=6):
    """Two targets over frames 1-10 and two tracks that follow them, then each other's from ``swap_from`` on.

    The tracks carry ``first_ids``: the ground-truth ids by default, as tracks born from the
    ground truth do.
    """
    gt, hyp, _ = swapped_halfway()
    own = np.where(gt[:, 1] == 1, *first_ids)
    other = np.where(gt[:, 1] == 1, first_ids[1], first_ids[0])
    hyp[:, 1] = np.where(gt[:, 0] >= swap_from, other, own)
    return gt, hyp


def test_tracks_that_keep_the_ground_truth_ids_swap_nothing():
    gt = three_targets()
    for mode in ("gt", None):
        swaps = identity_swaps(gt, gt.copy(), identities=mode)
        assert swaps == IdentitySwaps(frames=0, pairs=0, per_target={1: 0, 2: 0, 3: 0},
                                      identities={1: 1, 2: 2, 3: 3})


def test_a_swap_in_the_middle_of_the_tracks_counts_each_of_its_frames():
    gt, hyp = crossed_midway(swap_from=6)      # frames 6-10 swapped, both targets in each
    swaps = identity_swaps(gt, hyp, identities="gt")
    assert (swaps.frames, swaps.pairs, swaps.per_target) == (5, 10, {1: 5, 2: 5})
    # the CLEAR MOT switches count the moment of the swap once per target, not its length
    assert evaluate(gt, hyp).id_switches == 2


def test_a_swap_of_one_target_counts_its_frames_once_each():
    gt, hyp = crossed_midway(swap_from=8)
    hyp = hyp[~((hyp[:, 0] >= 8) & (gt[:, 1] == 2))]   # the second track is lost instead of swapped
    swaps = identity_swaps(gt, hyp, identities="gt")
    assert (swaps.frames, swaps.pairs, swaps.per_target) == (3, 3, {1: 3, 2: 0})


def test_the_idf1_assignment_finds_the_identities_of_tracks_numbered_otherwise():
    gt, hyp = crossed_midway(first_ids=(7, 8), swap_from=8)
    assert identity_swaps(gt, hyp, identities="gt").frames == 10      # no track carries a ground-truth id
    swaps = identity_swaps(gt, hyp)
    # tracks 7 and 8 follow targets 1 and 2 for 7 of 10 frames: those are their identities
    assert swaps.identities == {1: 7, 2: 8}
    assert (swaps.frames, swaps.pairs, swaps.per_target) == (3, 6, {1: 3, 2: 3})


def test_consistently_relabelled_tracks_swap_nothing_in_automatic_mode():
    gt = three_targets()
    swaps = identity_swaps(gt, shifted(gt, 1.0, 0.0, id_offset=40))
    assert (swaps.frames, swaps.pairs) == (0, 0) and swaps.identities == {1: 41, 2: 42, 3: 43}


def test_tracks_paired_with_nobody_do_not_count():
    gt = three_targets()
    far = track(2, range(1, 21), 700, 700)            # another target's id, but on nobody
    stray = track(99, range(5, 9), 0, 400)            # an id of nobody's, on nobody
    swaps = identity_swaps(gt, np.vstack([gt[gt[:, 1] != 2], far, stray]), identities="gt")
    assert (swaps.frames, swaps.pairs) == (0, 0)
    assert swaps.per_target == {1: 0, 2: 0, 3: 0}     # target 2 is missed, which MOTA counts, not this


def test_flag_zero_ground_truth_carries_no_identity():
    frames = range(1, 11)
    gt = np.vstack([track(1, frames, 0, 0), track(2, frames, 200, 200, flag=0)])
    hyp = np.vstack([track(1, frames, 0, 0), track(5, frames, 200, 200)])   # track 5 on the ignored box
    for mode in ("gt", None):
        swaps = identity_swaps(gt, hyp, identities=mode)
        assert (swaps.frames, swaps.pairs, swaps.per_target) == (0, 0, {1: 0})
    swapped = hyp.copy()
    swapped[:, 1] = np.where(hyp[:, 1] == 1, 5, 1)    # the same boxes, ids traded: now target 1 carries 5
    assert identity_swaps(gt, swapped, identities="gt")[:3] == (10, 10, {1: 10})


def test_given_identities_and_targets_without_one():
    gt, hyp = crossed_midway(swap_from=6)
    assert identity_swaps(gt, hyp, identities={1: 2, 2: 1})[:2] == (5, 10)    # frames 1-5 are the swapped ones
    partial = identity_swaps(gt, hyp, identities={1: 1})                       # target 2 has no identity
    assert partial.identities == {1: 1, 2: None} and partial.per_target == {1: 5, 2: 10}
    missed = identity_swaps(gt, np.zeros((0, 7)))
    assert missed.identities == {1: None, 2: None} and missed.frames == 0
    astray = identity_swaps(gt, np.vstack([gt[gt[:, 1] == 1], track(9, range(1, 11), 700, 700)]))
    assert astray.identities == {1: 1, 2: None}                 # a track it never overlaps is no identity


@pytest.mark.parametrize("identities, message", [("own", "identities"), ([1, 2], "mapping"),
                                                 ({1: "one"}, "integer"), ({1.5: 1}, "integer")])
def test_identity_swaps_rejects_identities_of_no_known_kind(identities, message):
    gt, hyp = crossed_midway()
    with pytest.raises(TrackingError, match=message):
        identity_swaps(gt, hyp, identities=identities)


# -- iou_distance ----------------------------------------------------------------------------------
def literal_iou_distance(gt_boxes, hyp_boxes, max_iou_distance):
    """Exact rational IoU, pair by pair, from interval overlaps."""
    out = np.full((len(gt_boxes), len(hyp_boxes)), np.nan)
    for i, (gx, gy, gw, gh) in enumerate(gt_boxes):
        for j, (hx, hy, hw, hh) in enumerate(hyp_boxes):
            gx, gy, gw, gh, hx, hy, hw, hh = (Fraction(v) for v in (gx, gy, gw, gh, hx, hy, hw, hh))
            overlap_x = max(Fraction(0), min(gx + gw, hx + hw) - max(gx, hx))
            overlap_y = max(Fraction(0), min(gy + gh, hy + hh) - max(gy, hy))
            intersection = overlap_x * overlap_y
            union = gw * gh + hw * hh - intersection
            iou = intersection / union if union > 0 else Fraction(0)
            if 1 - iou <= Fraction(max_iou_distance):
                out[i, j] = float(1 - iou)
    return out


# Multiples of 1/8: sums and products stay exact in floating point, so the NaN pattern at the
# threshold can be compared exactly with the rational reference.
coordinate = st.integers(-400, 400).map(lambda k: k / 8)
size = st.integers(0, 240).map(lambda k: k / 8)
box = st.tuples(coordinate, coordinate, size, size)
near_box = st.tuples(st.integers(-40, 40), st.integers(-40, 40), st.integers(0, 30), st.integers(0, 30)).map(
    lambda b: tuple(float(v) for v in b))


@given(gt_boxes=st.lists(st.one_of(box, near_box), max_size=6),
       hyp_boxes=st.lists(st.one_of(box, near_box), max_size=6),
       max_iou_distance=st.sampled_from([0.0, 0.25, 0.5, 0.75, 1.0]))
def test_iou_distance_matches_literal_loop(gt_boxes, hyp_boxes, max_iou_distance):
    got = iou_distance(np.array(gt_boxes).reshape(-1, 4), np.array(hyp_boxes).reshape(-1, 4), max_iou_distance)
    want = literal_iou_distance(gt_boxes, hyp_boxes, max_iou_distance)
    assert got.shape == (len(gt_boxes), len(hyp_boxes))
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)


def test_iou_distance_known_values_and_empty_shapes():
    d = iou_distance([[0, 0, 10, 10]], [[0, 0, 10, 10], [5, 0, 10, 10], [2, 0, 10, 10], [0, 0, 0, 0]],
                     max_iou_distance=1.0)
    np.testing.assert_allclose(d, [[0.0, 1 - 50 / 150, 1 - 80 / 120, 1.0]])
    assert iou_distance(np.zeros((3, 4)), np.zeros((0, 4))).shape == (3, 0)
    assert iou_distance([], [[0, 0, 1, 1]]).shape == (0, 1)
    assert iou_distance([[0, 0, 0, 0]], [[0, 0, 0, 0]], max_iou_distance=1.0)[0, 0] == 1.0  # no area: IoU 0


@pytest.mark.parametrize("gt_boxes, hyp_boxes, threshold, message", [
    (np.zeros((2, 3)), np.zeros((1, 4)), 0.5, "shape"),
    (np.zeros((1, 4)), np.zeros((4,)), 0.5, "shape"),
    ([[0, 0, -1, 1]], [[0, 0, 1, 1]], 0.5, "negative"),
    ([[0, 0, 1, 1]], [[np.inf, 0, 1, 1]], 0.5, "finite"),
    ([[0, 0, 1, 1]], [[0, 0, 1, 1]], 1.5, r"\[0, 1\]"),
])
def test_iou_distance_rejects_bad_input(gt_boxes, hyp_boxes, threshold, message):
    with pytest.raises(TrackingError, match=message):
        iou_distance(gt_boxes, hyp_boxes, threshold)


# -- read_mot --------------------------------------------------------------------------------------
@pytest.fixture
def mot_file(tmp_path):
    def write(text, name="tracks.txt"):
        path = tmp_path / name
        path.write_text(text, encoding="utf-8")
        return path

    return write


def test_read_mot_accepts_6_to_10_columns_and_blank_lines(mot_file):
    path = mot_file("1,1,10,20,30,40\n\n"
                    "1,2,11.5,21,31,41,0\n"
                    "2,1,12,22,32,42,1,-1,-1\n"
                    "2, 2, 13, 23, 33, 43, 0.8, -1, -1, -1\n"
                    "3 1 14 24 34 44 1 -1\n\n")
    rows = read_mot(path)
    np.testing.assert_array_equal(rows, [[1, 1, 10, 20, 30, 40, 1], [1, 2, 11.5, 21, 31, 41, 0],
                                         [2, 1, 12, 22, 32, 42, 1], [2, 2, 13, 23, 33, 43, 0.8],
                                         [3, 1, 14, 24, 34, 44, 1]])
    assert rows.dtype == np.float64 and rows.shape[1] == len(motfiles.MOT_COLUMNS)


@pytest.mark.parametrize("bad_line, message", [
    ("2,1,10,20,30", "expected 6 to 10 fields"),
    ("2,1,10,20,30,40,1,-1,-1,-1,7", "got 11"),
    ("2,1,10,abc,30,40,1", "field 4 is not a number"),
    ("2,1,10,20,30,nan,1", "field 6 is not finite"),
    ("2.5,1,10,20,30,40,1", "frame must be an integer"),
    ("2,1.25,10,20,30,40,1", "id must be an integer"),
    ("2,1,10,20,-30,40,1", "negative box size"),
    ("1,1,10,20,30,40,1", r"frame 1 has id 1 twice \(first on line 1\)"),
])
def test_read_mot_names_file_and_line_of_a_malformed_line(mot_file, bad_line, message):
    path = mot_file(f"1,1,10,20,30,40,1\n\n{bad_line}\n2,2,10,20,30,40,1\n", name="broken_gt.txt")
    with pytest.raises(TrackFileError, match=message) as info:
        read_mot(path)
    assert "broken_gt.txt" in str(info.value) and "line 3" in str(info.value)


def test_read_mot_missing_empty_and_directory(tmp_path, mot_file):
    with pytest.raises(TrackFileError, match="no such file") as info:
        read_mot(tmp_path / "absent.txt")
    assert "absent.txt" in str(info.value)
    for text in ("", "\n  \n"):
        with pytest.raises(TrackFileError, match="empty") as info:
            read_mot(mot_file(text, name="nothing.txt"))
        assert "nothing.txt" in str(info.value)
    with pytest.raises(TrackFileError, match="directory"):
        read_mot(tmp_path)
    binary = tmp_path / "binary.txt"
    binary.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(TrackFileError, match="UTF-8"):
        read_mot(binary)


def test_read_mot_accepts_an_empty_tracks_file_when_asked(mot_file):
    for text in ("", "\n  \n"):
        rows = read_mot(mot_file(text, name="tracks.txt"), allow_empty=True)
        assert rows.shape == (0, len(motfiles.MOT_COLUMNS)) and rows.dtype == np.float64
    with pytest.raises(TrackFileError, match="line 1"):
        read_mot(mot_file("1,1,oops,2,3,4\n"), allow_empty=True)


def test_a_mot17_ground_truth_from_write_gt_reads_back_and_scores(tmp_path, rendered_scene):
    from belief_tracking import scenes

    scene = rendered_scene(scenes.crossing(0))
    # frames 40 to 60: walker 1 goes behind walker 2, so the visibilities run from 1 down to 0
    rows_40_60 = (scene.ground_truth[:, 0] >= 40) & (scene.ground_truth[:, 0] <= 60)
    gt, seen = scene.ground_truth[rows_40_60], scene.visibility[rows_40_60]
    assert seen.min() == 0.0 and seen.max() == 1.0 and ((seen > 0) & (seen < 1)).any()
    path = tmp_path / "gt.txt"
    scenes.write_gt(path, gt, visibility=seen)
    lines = path.read_text().splitlines()
    assert len(lines) == len(gt) and all(line.count(",") == 8 for line in lines)
    assert lines[0] == ",".join(str(v) for v in gt[0, :7]) + ",1," + f"{seen[0]:g}"
    np.testing.assert_allclose([float(line.rsplit(",", 1)[1]) for line in lines], seen, atol=5e-7)
    rows = read_mot(path)
    np.testing.assert_array_equal(rows, gt[:, :7])
    scores = evaluate(rows, gt)
    assert scores.mota == 1.0 and scores.idf1 == 1.0 and scores.num_objects == len(gt)
    with pytest.raises(TrackingError, match="one value in \\[0, 1\\] per row"):
        scenes.write_gt(path, gt, visibility=seen[:-1])


def test_errors_belong_to_the_belief_family():
    assert issubclass(TrackFileError, TrackingError)
    assert issubclass(TrackingError, BeliefError) and issubclass(TrackingError, ValueError)


# -- command line ----------------------------------------------------------------------------------
@pytest.fixture
def files(tmp_path):
    gt = three_targets(range(1, 6))
    hyp = shifted(gt, 3.0, 4.0, id_offset=50)
    gt_path, hyp_path = tmp_path / "gt.txt", tmp_path / "tracks.txt"
    for path, rows in ((gt_path, gt), (hyp_path, hyp)):
        path.write_text("".join(",".join(f"{v:g}" for v in row) + ",-1,-1,-1\n" for row in rows))
    return str(hyp_path), str(gt_path), evaluate(gt, hyp)


def parse(argv):
    parser = argparse.ArgumentParser(prog="belief")
    register_eval(parser.add_subparsers(dest="command"))
    return parser.parse_args(argv)


def test_register_eval_prints_json(files, capsys):
    tracks, gt, expected = files
    args = parse(["eval", tracks, gt, "--json"])
    assert args.func(args) == 0
    data = json.loads(capsys.readouterr().out)
    assert data == expected.to_dict()
    assert data["mean_centre_error"] == pytest.approx(5.0) and data["mota"] == 1.0


def test_register_eval_prints_table(files, capsys):
    tracks, gt, expected = files
    args = parse(["eval", tracks, gt])
    assert args.func(args) == 0
    assert capsys.readouterr().out == expected.format_table() + "\n"


def test_belief_cli_runs_eval_through_the_entry_point(files, monkeypatch, capsys, tmp_path):
    import belief.cli as cli

    class EvalEntryPoint:
        name = "eval"
        value = "belief_tracking.cli:register_eval"

        @staticmethod
        def load():
            return register_eval

    monkeypatch.setattr(cli, "entry_points", lambda group: [EvalEntryPoint] if group == cli.ENTRY_POINT_GROUP else [])
    tracks, gt, expected = files
    assert cli.main(["eval", tracks, gt, "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == expected.to_dict()

    bad = tmp_path / "bad.txt"
    bad.write_text("1,1,10,20,30,40,1\n1,2,oops,20,30,40,1\n")
    assert cli.main(["eval", str(bad), gt]) == 1
    out, err = capsys.readouterr()
    assert out == "" and len(err.strip().splitlines()) == 1
    assert err.startswith("belief: error: ") and "bad.txt, line 2" in err

    assert cli.main(["eval", str(tmp_path / "absent.txt"), gt]) == 1
    assert "no such file" in capsys.readouterr().err


def test_belief_eval_scores_an_empty_tracks_file_as_missing_every_box(files, capsys, tmp_path):
    _, gt, _ = files
    empty = tmp_path / "nobody_tracks.txt"
    empty.write_text("")
    args = parse(["eval", str(empty), gt, "--json"])
    assert args.func(args) == 0
    scores = json.loads(capsys.readouterr().out)
    assert scores["mota"] == 0.0 and scores["idf1"] == 0.0 and scores["recall"] == 0.0
    assert scores["matched_pairs"] == 0 and scores["num_predictions"] == 0
    assert scores["false_negatives"] == scores["num_objects"] > 0 and scores["motp"] is None
    assert scores["hota"] == scores["deta"] == scores["assa"] == 0.0
    args = parse(["eval", str(empty), gt])
    assert args.func(args) == 0
    table = capsys.readouterr().out
    assert re.search(r"^MOTA +0\.0000$", table, re.MULTILINE)
    assert re.search(r"^HOTA \(higher-order tracking accuracy\) +0\.0000$", table, re.MULTILINE)
    args = parse(["eval", gt, str(empty)])  # an empty ground truth is still refused
    with pytest.raises(TrackFileError, match="empty"):
        args.func(args)


# -- recorded data -----------------------------------------------------------------------------------
@pytest.mark.data
@pytest.mark.skipif(not PETS_GT.is_file(), reason="the PETS 2009 S2L1 ground truth is not available")
def test_pets_ground_truth_against_itself():
    gt = read_mot(PETS_GT)
    flagged_out = int((gt[:, 6] == 0).sum())
    scores = evaluate(gt, gt)
    assert flagged_out > 0
    assert scores.mota == 1.0 and scores.idf1 == 1.0 and scores.motp == 1.0
    assert scores.num_objects == len(gt) - flagged_out and scores.ignored_predictions == flagged_out
    assert scores.false_positives == scores.false_negatives == scores.id_switches == 0
    assert scores.mean_centre_error == 0.0
