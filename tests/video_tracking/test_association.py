"""The one-to-one assignment of candidates to tracks, on small hand-made cases.

tests/video_tracking/test_lifecycle.py checks the assignment against brute force on random
boxes; here each case is worked out by hand.  Every box is 10 x 10 on row 0, so two boxes
whose left edges are d px apart (d <= 10) overlap by IoU(d) = 10 (10 - d) / (200 - 10 (10 - d))
= (10 - d) / (10 + d): 9/11 at d = 1, 8/12 at 2, 7/13 at 3, 6/14 at 4, 5/15 = 1/3 at 5, 1/19 at 9.
"""

from __future__ import annotations

import numpy as np
import pytest

from belief_tracking.association import UNASSIGNED, Association, assign, contested_pairs, min_cost_assignment
from belief_tracking.initiation import InitiationConfig
from belief_tracking.boxes import iou


def at(*lefts: float) -> np.ndarray:
    """10 x 10 boxes on row 0 with these left edges."""
    return np.array([[x, 0.0, 10.0, 10.0] for x in lefts]).reshape(-1, 4)


def test_the_overlaps_of_the_cases_are_the_ones_worked_out_by_hand():
    assert iou(at(0), at(0, 1, 2, 3, 4, 5, 9))[0].tolist() == pytest.approx(
        [1.0, 9 / 11, 8 / 12, 7 / 13, 6 / 14, 1 / 3, 1 / 19], abs=1e-15)


# -- assign -----------------------------------------------------------------------------------------
def test_each_track_takes_the_candidate_on_it_and_no_candidate_goes_twice():
    # Three tracks far apart, their candidates in another order, and one candidate of nobody.
    taken = assign(at(0, 100, 200), at(201, 300, 1, 99))
    assert taken.tolist() == [2, 3, 0]
    # Two tracks on one candidate: it goes to the one it overlaps most (1 against 9/11).
    assert assign(at(1, 0), at(0)).tolist() == [UNASSIGNED, 0]


def test_the_gate_is_a_least_overlap_and_a_pair_on_it_is_matched():
    # d = 5: IoU exactly 1/3.
    assert assign(at(0), at(5), min_iou=1 / 3).tolist() == [0]
    assert assign(at(0), at(5), min_iou=0.34).tolist() == [UNASSIGNED]
    # A track whose only candidate is under the gate stays unassigned even when that candidate is free.
    assert assign(at(0, 50), at(1, 59), min_iou=0.3).tolist() == [0, UNASSIGNED]          # 1/19 < 0.3


def test_the_optimal_matching_gives_a_second_track_the_candidate_a_greedy_one_would_leave_it_without():
    # Track A (x=0) overlaps c0 (x=2) by 8/12 and c1 (x=-4) by 6/14; track B (x=5) overlaps c0 by
    # 7/13 and c1 not at all (d = 9: 1/19 under the gate).  Greedy takes the best pair A-c0 and
    # leaves B with nothing; the assignment matches A-c1 and B-c0: two pairs.
    assert assign(at(0, 5), at(2, -4), min_iou=0.3).tolist() == [1, 0]


def test_one_more_pair_is_worth_more_than_any_gain_of_overlap():
    # A sits exactly on c0 (IoU 1); c1 overlaps A by 1/3 and c0 overlaps B by 1/3.  The most
    # overlap is A-c0 alone (1 > 2/3), but k + sum IoU is 2 + 2/3 for A-c1, B-c0 against 1 + 1.
    assert assign(at(0, 5), at(0, -5), min_iou=0.3).tolist() == [1, 0]


def test_with_as_many_pairs_either_way_the_larger_total_overlap_wins():
    # A (x=0) overlaps c0 (x=1) by 9/11 and c1 (x=-2) by 8/12; B (x=4) overlaps c0 by 7/13 and
    # c1 by 4/16.  Greedy: A-c0 then B-c1, 9/11 + 4/16 = 1.068; the assignment: A-c1 and B-c0,
    # 8/12 + 7/13 = 1.205.
    assert 8 / 12 + 7 / 13 > 9 / 11 + 4 / 16
    assert assign(at(0, 4), at(1, -2), min_iou=0.2).tolist() == [1, 0]


def test_the_score_column_of_the_candidates_is_ignored():
    boxes = at(1, -2)
    scored = np.column_stack([boxes, [0.1, 0.9]])
    assert assign(at(0, 4), scored, min_iou=0.2).tolist() == assign(at(0, 4), boxes, min_iou=0.2).tolist() == [1, 0]


def test_no_track_or_no_candidate_gives_no_pair():
    assert assign(at(0, 20), np.zeros((0, 4))).tolist() == [UNASSIGNED, UNASSIGNED]
    assert assign(at(0, 20), np.zeros((0, 5))).tolist() == [UNASSIGNED, UNASSIGNED]
    none = assign(np.zeros((0, 4)), np.zeros((0, 4)))
    assert none.shape == (0,) and none.dtype == np.intp


def test_equal_candidates_go_one_to_one_and_the_same_way_every_time():
    # Two copies of one box for one track, and one box for two equal tracks: a tie either way.
    first = assign(at(0), at(1, 1))
    assert first.tolist() in ([0], [1])
    two = assign(at(0, 0), at(1))
    assert sorted(two.tolist()) == [UNASSIGNED, 0]
    for _ in range(3):
        assert assign(at(0), at(1, 1)).tolist() == first.tolist()
        assert assign(at(0, 0), at(1)).tolist() == two.tolist()


# -- appearance -------------------------------------------------------------------------------------
def test_appearance_swaps_a_contested_matching_only_beyond_the_weight_that_pays_for_the_overlap():
    # A (x=0) and B (x=3) both overlap c0 (x=1) and c1 (x=2): A-c0 and B-c1 by 9/11, the crossed
    # pairs by 8/12.  The candidates look like the other track (rho = 1 on the crossed pairs, 0 on
    # the straight ones): the crossing loses 2 (9/11 - 8/12) = 0.303 of overlap and gains 2 w, so it
    # wins for w > 0.1515.
    likeness = [[0.0, 1.0], [1.0, 0.0]]
    tracks, candidates = at(0, 3), at(1, 2)
    assert assign(tracks, candidates).tolist() == [0, 1]
    assert assign(tracks, candidates, likeness=likeness, appearance_weight=0.1).tolist() == [0, 1]
    assert assign(tracks, candidates, likeness=likeness, appearance_weight=0.2).tolist() == [1, 0]
    # Without a likeness the weight does nothing, and with the weight 0 the likeness does nothing.
    assert assign(tracks, candidates, appearance_weight=5.0).tolist() == [0, 1]
    assert assign(tracks, candidates, likeness=likeness, appearance_weight=0.0).tolist() == [0, 1]


def test_appearance_never_changes_an_uncontested_matching():
    # Each track overlaps only its own candidate: whatever the likeness, each keeps it.
    tracks, candidates = at(0, 50), at(1, 52)
    assert contested_pairs(tracks, candidates)[0].size == 0
    for likeness in ([[0.0, 1.0], [1.0, 0.0]], [[0.0, 0.0], [0.0, 0.0]], [[1.0, 1.0], [1.0, 1.0]]):
        assert assign(tracks, candidates, likeness=likeness, appearance_weight=10.0).tolist() == [0, 1]


# -- contested pairs --------------------------------------------------------------------------------
def test_contested_pairs_are_every_pair_within_the_gate_once_any_candidate_or_track_is_shared():
    # A (x=0) overlaps c0 (x=1) and c1 (x=-1); C (x=100) overlaps c2 (x=101) only; B (x=50) nothing.
    rows, cols = contested_pairs(at(0, 50, 100), at(1, -1, 101))
    assert sorted(zip(rows.tolist(), cols.tolist())) == [(0, 0), (0, 1), (2, 2)]
    # Two tracks on one candidate contest it.
    rows, cols = contested_pairs(at(0, 2), at(1))
    assert sorted(zip(rows.tolist(), cols.tolist())) == [(0, 0), (1, 0)]


def test_no_pair_is_contested_when_every_track_has_at_most_one_candidate_and_the_reverse():
    for tracks, candidates in [(at(0, 50), at(1, 51)), (at(0), at(9)), (np.zeros((0, 4)), at(0)),
                               (at(0), np.zeros((0, 4)))]:
        rows, cols = contested_pairs(tracks, candidates)
        assert rows.tolist() == cols.tolist() == []
    # A second candidate under the gate contests nothing; at a lower gate it does.
    assert contested_pairs(at(0), at(1, 5), min_iou=0.5)[0].tolist() == []
    assert sorted(contested_pairs(at(0), at(1, 5), min_iou=0.3)[1].tolist()) == [0, 1]


# -- the solver -------------------------------------------------------------------------------------
def test_the_solver_beats_the_greedy_choice_of_the_cheapest_pair():
    # Greedy takes (0, 0) at 1 and is left with (1, 1) at 10: 11.  The crossing costs 2 + 2 = 4.
    rows, cols = min_cost_assignment([[1.0, 2.0], [2.0, 10.0]])
    assert rows.tolist() == [0, 1] and cols.tolist() == [1, 0]


def test_with_more_rows_than_columns_every_column_is_paired_with_the_cheapest_rows():
    # Pairings of both columns: rows (1, 0) cost 1 + 1 = 2, rows (2, 0) 0 + 1 = 1, the others more.
    rows, cols = min_cost_assignment([[5.0, 1.0], [1.0, 5.0], [0.0, 3.0]])
    assert rows.tolist() == [0, 2] and cols.tolist() == [1, 0]
    rows, cols = min_cost_assignment([[5.0, 1.0, 0.0]])         # one row: its cheapest column
    assert rows.tolist() == [0] and cols.tolist() == [2]


def test_the_solver_takes_negative_costs_and_gives_empty_pairs_for_an_empty_side():
    rows, cols = min_cost_assignment([[-1.0, -5.0], [-4.0, -1.0]])     # -5 - 4 against -1 - 1
    assert cols.tolist() == [1, 0]
    for shape in ((0, 3), (3, 0), (0, 0)):
        rows, cols = min_cost_assignment(np.zeros(shape))
        assert rows.shape == cols.shape == (0,) and rows.dtype == np.intp


def test_following_a_plan_a_free_candidate_goes_to_the_one_track_it_covers_and_a_group_to_neither():
    from belief_tracking.association import take_covering

    predicted = np.array([[0.0, 0, 4, 10], [40.0, 0, 10, 20], [44.0, 0, 10, 20]])
    # Candidate 0 covers the sliver of track 0 alone; candidate 1 covers tracks 1 and 2 (a group).
    candidates = np.array([[0.0, 0, 12, 30, 1], [38.0, 0, 20, 24, 1]])
    assert take_covering(predicted, candidates, np.array([-1, -1, -1])).tolist() == [0, -1, -1]
    # A candidate that a track took already is not given again.
    assert take_covering(predicted, candidates, np.array([-1, 0, -1])).tolist() == [-1, 0, -1]
    # Through the association stage: only where the plan gives every birth.
    obs = None
    follow = Association(InitiationConfig(births=False), [])
    automatic = Association(InitiationConfig(), [])
    far = np.array([[0.0, 0, 4, 10]])
    person = np.array([[0.0, 0, 12, 30, 1]])
    assert follow(obs, far, person, detector=False).tolist() == [0]
    assert automatic(obs, far, person, detector=False).tolist() == [-1]
