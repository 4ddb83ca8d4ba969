"""Automatic tracks: candidate assignment, births, coasting, losses, re-identification, exits and duplicates."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from belief_tracking import scenes
from belief_tracking.association import UNASSIGNED, assign, contested_pairs, min_cost_assignment
from belief_tracking.boxes import iou
from belief_tracking.config import TrackerConfig
from belief_tracking.cues import DetectionConfig, DetectionCue, Observation
from belief_tracking.errors import TrackingError
from belief_tracking.initiation import InitiationConfig
from belief_tracking.lifecycle import Lifecycle
from belief_tracking.store import Life
from belief_tracking.tracker import Tracker

NONE = np.zeros(0, dtype=np.intp)


# -- assignment -------------------------------------------------------------------------------------
def brute_force_best_total(tracks: np.ndarray, candidates: np.ndarray, gate: float) -> float:
    """The largest k + Σ IoU of a gated one-to-one matching of k pairs, by trying every injective map."""
    overlap = iou(tracks, candidates)
    best = 0.0
    n, m = overlap.shape
    for k in range(min(n, m) + 1):
        for rows in itertools.combinations(range(n), k):
            for cols in itertools.permutations(range(m), k):
                values = overlap[list(rows), list(cols)]
                if (values >= gate).all():
                    best = max(best, k + float(values.sum()))
    return best


boxes = st.lists(st.tuples(st.integers(0, 60), st.integers(0, 60), st.integers(4, 30), st.integers(4, 30)),
                 min_size=0, max_size=4)


@settings(max_examples=60, deadline=None)
@given(boxes, boxes, st.sampled_from([0.1, 0.3, 0.5]))
def test_the_assignment_is_one_to_one_gated_and_has_the_most_pairs_and_overlap(tracks, candidates, gate):
    tracks = np.array(tracks, dtype=float).reshape(-1, 4)
    candidates = np.array(candidates, dtype=float).reshape(-1, 4)
    taken = assign(tracks, candidates, gate)
    assert taken.shape == (len(tracks),)
    chosen = taken[taken != UNASSIGNED]
    assert len(set(chosen.tolist())) == len(chosen)                    # one-to-one
    total = 0.0
    for track, candidate in enumerate(taken):
        if candidate != UNASSIGNED:
            overlap = iou(tracks[track:track + 1], candidates[candidate:candidate + 1])[0, 0]
            assert overlap >= gate
            total += 1.0 + overlap
    assert total == pytest.approx(brute_force_best_total(tracks, candidates, gate), abs=1e-9)


costs = st.integers(0, 6).flatmap(lambda n: st.integers(0, 6).flatmap(
    lambda m: st.lists(st.lists(st.sampled_from([0.0, 0.25, 0.5, 1.0, 2.0, 0.3, 0.7]) | st.floats(0, 5),
                                min_size=m, max_size=m), min_size=n, max_size=n).map(
        lambda rows: np.array(rows, dtype=float).reshape(n, m))))


@settings(max_examples=150, deadline=None)
@given(costs)
def test_the_hungarian_solver_finds_the_cheapest_full_pairing(cost):
    rows, cols = min_cost_assignment(cost)
    n, m = cost.shape
    assert len(rows) == len(cols) == min(n, m)
    assert len(set(rows.tolist())) == len(rows) and len(set(cols.tolist())) == len(cols)
    assert rows.tolist() == sorted(rows.tolist())
    # Brute force over every injective map of the smaller side into the larger one.
    if n <= m:
        best = min((sum(cost[i, j] for i, j in enumerate(p)) for p in itertools.permutations(range(m), n)),
                   default=0.0)
    else:
        best = min((sum(cost[i, j] for j, i in enumerate(p)) for p in itertools.permutations(range(n), m)),
                   default=0.0)
    assert cost[rows, cols].sum() == pytest.approx(best, abs=1e-9)


def test_the_hungarian_solver_refuses_a_cost_it_cannot_solve():
    with pytest.raises(TrackingError, match="finite 2-D"):
        min_cost_assignment([[0.0, np.nan]])
    with pytest.raises(TrackingError, match="finite 2-D"):
        min_cost_assignment([1.0, 2.0])


def brute_force_best_score(score: np.ndarray, allowed: np.ndarray) -> float:
    """The largest k + Σ score of a one-to-one matching of k allowed pairs, by trying every injective map."""
    best = 0.0
    n, m = score.shape
    for k in range(min(n, m) + 1):
        for rows in itertools.combinations(range(n), k):
            for cols in itertools.permutations(range(m), k):
                if allowed[list(rows), list(cols)].all():
                    best = max(best, k + float(score[list(rows), list(cols)].sum()))
    return best


@settings(max_examples=60, deadline=None)
@given(boxes, boxes, st.sampled_from([0.1, 0.3]), st.sampled_from([0.25, 0.75, 2.0]), st.integers(0, 2**32 - 1))
def test_with_appearance_the_assignment_has_the_most_pairs_and_score(tracks, candidates, gate, weight, seed):
    # Each pair scores IoU + w·ρ; the gate is on the overlap alone; as many pairs as can be.
    tracks = np.array(tracks, dtype=float).reshape(-1, 4)
    candidates = np.array(candidates, dtype=float).reshape(-1, 4)
    likeness = np.random.default_rng(seed).random((len(tracks), len(candidates)))
    taken = assign(tracks, candidates, gate, likeness, weight)
    chosen = taken[taken != UNASSIGNED]
    assert len(set(chosen.tolist())) == len(chosen)
    overlap = iou(tracks, candidates)
    score = (overlap + weight * likeness) / (1.0 + weight)        # in [0, 1], as the overlap alone is
    total = sum(1.0 + score[j, k] for j, k in enumerate(taken) if k != UNASSIGNED)
    assert all(overlap[j, k] >= gate for j, k in enumerate(taken) if k != UNASSIGNED)
    assert total == pytest.approx(brute_force_best_score(score, overlap >= gate), abs=1e-9)


@settings(max_examples=80, deadline=None)
@given(boxes, boxes, st.sampled_from([0.1, 0.3]), st.integers(0, 2**32 - 1))
def test_the_likeness_of_uncontested_pairs_never_changes_the_matching(tracks, candidates, gate, seed):
    # The tracker forms ρ only for the contested pairs; the matching must be the one of the full likeness.
    tracks = np.array(tracks, dtype=float).reshape(-1, 4)
    candidates = np.array(candidates, dtype=float).reshape(-1, 4)
    likeness = np.random.default_rng(seed).random((len(tracks), len(candidates)))
    rows, cols = contested_pairs(tracks, candidates, gate)
    within = iou(tracks, candidates) >= gate
    assert not rows.size or within[rows, cols].all() and len(rows) == within.sum()
    partial = np.zeros_like(likeness)
    partial[rows, cols] = likeness[rows, cols]
    assert assign(tracks, candidates, gate, partial, 0.75).tolist() == \
        assign(tracks, candidates, gate, likeness, 0.75).tolist()


def test_appearance_gives_a_shared_detection_to_the_person_it_shows():
    two = [[0, 0, 10, 20], [3, 0, 10, 20]]
    detection = [[1, 0, 10, 20]]                                    # overlaps the first track more
    assert assign(two, detection).tolist() == [0, UNASSIGNED]
    assert assign(two, detection, likeness=[[0.3], [0.9]], appearance_weight=0.75).tolist() == [UNASSIGNED, 0]
    assert assign(two, detection, likeness=[[0.3], [0.9]], appearance_weight=0.0).tolist() == [0, UNASSIGNED]
    # The gate stays the overlap: a detection that looks like a track but barely overlaps it is not taken.
    assert assign([[0, 0, 10, 20]], [[9, 0, 10, 20]], likeness=[[1.0]], appearance_weight=5.0).tolist() == [-1]


def test_the_tracker_weighs_each_detection_by_how_much_it_looks_like_each_track(monkeypatch):
    # Two people side by side, red and blue, whose boxes overlap both detections: the
    # likeness the tracker hands to the assignment is high for each person's own detection
    # and low for the other's, whatever their order.
    import belief_tracking.association as association_module

    image = np.full((100, 120, 3), 128, np.uint8)
    image[20:50, 20:30] = (0, 0, 255)
    image[20:50, 32:42] = (255, 0, 0)
    red, blue = [17.0, 19.0, 16.0, 32.0, 1.0], [29.0, 19.0, 16.0, 32.0, 1.0]
    seen = []

    def spy(tracks, candidates, min_iou=0.3, likeness=None, appearance_weight=0.0):
        seen.append((None if likeness is None else np.array(likeness), appearance_weight))
        return assign(tracks, candidates, min_iou, likeness, appearance_weight)

    monkeypatch.setattr(association_module, "assign", spy)

    def tracker(**initiation):
        config = TrackerConfig(particles=20, cues=("colour", "location"),
                               initiation=InitiationConfig(match_iou=0.1, **initiation))
        return Tracker(config, None, np.random.default_rng(0))

    both = tracker()
    both.step(1, image, np.array([red, blue]))
    assert [round(t.estimate[0]) for t in both.targets] == [25, 37]
    both.step(2, image, np.array([blue, red]))
    likeness, weight = seen[-1]
    assert weight == InitiationConfig().appearance_weight > 0
    assert likeness.shape == (2, 2)
    assert likeness[0, 1] > 0.8 and likeness[1, 0] > 0.8           # each track's own person
    assert likeness[0, 0] < 0.5 and likeness[1, 1] < 0.5           # the other one
    # With the weight 0 the assignment goes by overlap alone, and no likeness is formed.
    plain = tracker(appearance_weight=0.0)
    plain.step(1, image, np.array([red, blue]))
    plain.step(2, image, np.array([blue, red]))
    assert seen[-1][0] is None
    # Nor where no detection is contested: each track then overlaps its own detection only.
    apart = tracker()
    far = [79.0, 19.0, 16.0, 32.0, 1.0]
    apart.step(1, image, np.array([red, far]))
    apart.step(2, image, np.array([far, red]))
    assert seen[-1][0] is None


def test_bad_assignment_inputs_are_refused():
    with pytest.raises(TrackingError, match="min_iou"):
        assign([[0, 0, 1, 1]], [[0, 0, 1, 1]], min_iou=0)
    with pytest.raises(TrackingError, match=r"min_iou must be a number in \(0, 1\]"):
        contested_pairs([[0, 0, 1, 1]], [[0, 0, 1, 1]], min_iou=1.5)
    with pytest.raises(TrackingError, match="track boxes"):
        contested_pairs([[0, 0, 1, np.nan]], [[0, 0, 1, 1]])
    with pytest.raises(TrackingError, match="candidate boxes"):
        contested_pairs([[0, 0, 1, 1]], [[0, 0, -1, 1, 0.9]])
    with pytest.raises(TrackingError, match="candidate boxes"):
        assign([[0, 0, 1, 1]], [[0, 0, -1, 1]])
    assert assign(np.zeros((0, 4)), [[0, 0, 1, 1, 0.5]]).shape == (0,)
    with pytest.raises(TrackingError, match="likeness must be a \\(1, 1\\) array"):
        assign([[0, 0, 1, 1]], [[0, 0, 1, 1]], likeness=[[0.5, 0.5]], appearance_weight=1.0)
    with pytest.raises(TrackingError, match="likeness must be"):
        assign([[0, 0, 1, 1]], [[0, 0, 1, 1]], likeness=[[np.nan]], appearance_weight=1.0)
    with pytest.raises(TrackingError, match="appearance_weight must be at least 0"):
        assign([[0, 0, 1, 1]], [[0, 0, 1, 1]], likeness=[[0.5]], appearance_weight=-1.0)
    with pytest.raises(TrackingError, match="InitiationConfig.appearance_weight must be at least 0"):
        InitiationConfig(appearance_weight=-0.5)


# -- the lifecycle ----------------------------------------------------------------------------------
def lifecycle(**options) -> Lifecycle:
    options.setdefault("first_frame", False)
    return Lifecycle(InitiationConfig(**options), (100, 200))


def test_a_chain_of_candidates_is_born_after_appear_frames_anywhere_in_the_image():
    life = lifecycle(appear_frames=3)
    births = [life.update([], np.zeros((0, 4)), NONE, np.array([[90.0 + k, 40, 10, 20, 0.9]])).births
              for k in range(3)]
    assert [len(b) for b in births] == [0, 0, 1] and births[2].tolist() == [[92.0, 40.0, 10.0, 20.0]]
    border_only = lifecycle(appear_frames=1, anywhere=False)
    middle = np.array([[90.0, 40, 10, 20, 0.9]])
    assert len(border_only.update([], np.zeros((0, 4)), NONE, middle).births) == 0
    assert len(lifecycle(appear_frames=1).update([], np.zeros((0, 4)), NONE, middle).births) == 1


def test_every_free_candidate_of_the_first_frame_is_born_at_once_and_covered_ones_never():
    life = lifecycle(first_frame=True)
    candidates = np.array([[10.0, 10, 10, 20, 1], [100, 40, 10, 20, 1], [102, 42, 8, 16, 1]])
    outcome = life.update([Life()], np.array([[100.0, 40, 10, 20]]), np.array([1]), candidates)
    # The second is the track's own; the third lies inside the track's box.
    assert outcome.births.tolist() == [[10.0, 10.0, 10.0, 20.0]]


def test_an_unsupported_track_is_lost_after_lost_frames_and_a_track_at_the_border_ends():
    life = lifecycle(lost_frames=3, exit_frames=2, appearance_support=None)
    inside, border = np.array([[100.0, 40, 10, 20]]), np.array([[195.0, 40, 10, 20]])
    hidden, leaving = Life(), Life()
    assert [life.update([hidden], inside, np.array([-1]), np.zeros((0, 5))).lost for _ in range(3)] == [[], [], [0]]
    assert hidden.unsupported == 2 and hidden.age == 2              # not counted on in the frame it is lost
    assert [life.update([leaving], border, np.array([-1]), np.zeros((0, 5))).ended for _ in range(2)] == [[], [0]]
    assert leaving.leaving == 1
    # A candidate every other frame keeps a track alive.
    life = lifecycle(lost_frames=2, appearance_support=None)
    kept = Life()
    outcomes = [life.update([kept], inside, np.array([k % 2 - 1]), np.array([[100.0, 40, 10, 20, 1]]))
                for k in range(8)]
    assert not any(o.lost for o in outcomes)
    assert (kept.age, kept.hits, kept.unsupported) == (8, 4, 0)


def test_foreground_supports_a_track_only_where_no_other_track_took_a_candidate():
    mask = np.zeros((100, 200), bool)
    mask[40:60, 100:110] = True
    life = lifecycle(lost_frames=2, appearance_support=None)
    followed = np.array([[100.0, 40, 10, 20], [101, 41, 8, 18], [100, 40, 10, 20]])
    pair = [Life(), Life()]
    lost = [life.update(pair, followed[:2], np.array([0, -1]), np.array([[100.0, 40, 10, 20, 1]]),
                        foreground=mask).lost for _ in range(2)]
    assert lost == [[], [1]]                   # the second track sits on the person the first follows
    alone = lifecycle(lost_frames=2, appearance_support=None)
    single = [Life()]
    assert [alone.update(single, followed[2:], np.array([-1]), np.zeros((0, 5)), foreground=mask).lost
            for _ in range(3)] == [[], [], []]


def test_a_track_mostly_inside_an_older_one_ends_as_its_duplicate():
    life = lifecycle(duplicate_frames=3, appearance_support=None)
    pair = np.array([[100.0, 40, 20, 40], [104, 50, 10, 20]])                  # IoU 0.25, all inside
    lives = [Life(), Life()]
    ended = [life.update(lives, pair, np.array([0, 1]), np.array([[100.0, 40, 20, 40, 1], [104, 50, 10, 20, 1]]))
             .ended for _ in range(3)]
    assert ended == [[], [], [1]]                                              # the younger one
    assert lives[1].twins == 2 and lives[0].twins == 0


def test_no_chain_grows_while_births_are_not_allowed():
    life = lifecycle(appear_frames=2)
    candidate = np.array([[90.0, 40, 10, 20, 1]])
    life.update([], np.zeros((0, 4)), NONE, candidate)
    assert len(life.update([], np.zeros((0, 4)), NONE, candidate, births_allowed=False).births) == 0
    assert life.chains == []
    assert len(life.update([], np.zeros((0, 4)), NONE, candidate).births) == 0


# -- the detections cue -----------------------------------------------------------------------------
def observation(detections, assigned, centres=((50.0, 50.0), (10.0, 10.0))):
    return Observation(np.zeros((100, 100, 3), np.uint8), None, centres=list(centres),
                       sizes=[[20, 40]] * len(centres), previous_particles=np.zeros((0, 2)),
                       detections=detections, assigned=assigned)


def test_the_detections_cue_discounts_each_detection_by_its_score():
    cue = DetectionCue(DetectionConfig(sigma=0.25))
    states = np.array([[50.0, 50, 0, 0, 0], [55.0, 50, 0, 0, 0], [90, 90, 0, 0, 0]])
    scores = np.exp(cue.log_likelihoods(observation([[40, 30, 20, 40, 0.6]], [0, -1]), states, np.zeros(3, int)))
    gaussian = np.exp(-0.5 * (5 / (0.25 * 20)) ** 2)
    assert scores[:, 0] == pytest.approx([1.0, 0.6 * gaussian + 0.4, 0.4], abs=1e-6)
    assert (scores[:, 1] == 1.0).all()                                          # no detection: no say
    assert scores[:, 2] == pytest.approx([0.4, 1 - 0.6 * gaussian, 1.0], abs=1e-6)
    nothing = cue.log_likelihoods(observation(np.zeros((0, 5)), [-1, -1]), states, np.zeros(3, int))
    assert (nothing == 0).all()


def test_the_detections_cue_refuses_inconsistent_assignments():
    with pytest.raises(TrackingError, match="assigned"):
        observation([[40, 30, 20, 40, 0.6]], [1, -1])
    with pytest.raises(TrackingError, match="detections"):
        observation([[40, 30, -20, 40, 0.6]], [0, -1])


def test_a_tracker_refuses_bad_detections_naming_the_frame(rendered_scene):
    scene = rendered_scene(scenes.crossing(0))
    tracker = Tracker(TrackerConfig(particles=10, initiation=InitiationConfig()), None, np.random.default_rng(0))
    tracker.step(1, scene.frames[0], np.zeros((0, 5)))
    for bad in ([[1, 2, 3, 4]], [[1, 2, -3, 4, 0.5]], [[1, 2, 3, 4, 1.5]], [[np.nan, 2, 3, 4, 0.5]]):
        with pytest.raises(TrackingError, match="frame 2: detections must be finite rows"):
            tracker.step(2, scene.frames[1], np.array(bad, dtype=float))


# -- end to end -------------------------------------------------------------------------------------
def test_a_person_lost_behind_a_wall_takes_back_their_id_when_they_come_out(rendered_scene):
    scene = rendered_scene(scenes.lost_and_found(0))
    config = TrackerConfig.from_settings({"initiation": {}, "warm_up": 50, "particles": 50})
    tracker = Tracker(config, None, np.random.default_rng(0))
    picks = np.linspace(0, len(scene) - 1, 50).round().astype(int)
    tracker.warm_up(scene.frames[k] for k in picks)
    gt, visible = scene.ground_truth, scene.visibility
    ids_on_walker, lost_ever = [], set()
    for result in tracker.track(scene.frames):
        lost_ever |= set(tracker.store.lost)
        row = (gt[:, 0] == result.frame) & (gt[:, 1] == 1) & (visible == 1)
        if not row.any() or not result.estimates:
            continue
        truth = gt[row][0, 2:6] - [1, 1, 0, 0]
        overlaps = iou(np.array([e.box for e in result.estimates]), truth[None])[:, 0]
        if overlaps.max() >= 0.5:
            ids_on_walker.append(result.estimates[int(np.argmax(overlaps))].id)
    # Seen before and after the wall, under one id, although the track was lost in between.
    assert len(ids_on_walker) > 100 and set(ids_on_walker) == {ids_on_walker[0]}
    assert ids_on_walker[0] in lost_ever
