"""Each stage of a frame on its own, on hand-built inputs: observe, predict, associate, estimate, appearance,
adaptive particle count, resample, track management, diagnostics."""

from __future__ import annotations

import math

import numpy as np
import pytest

from belief import MassFunction, Model, combine
from belief_tracking import scenes
from belief_tracking.adaptive import AdaptiveConfig
from belief_tracking.appearance import AppearanceFollower, stacked_templates
from belief_tracking.association import Association
from belief_tracking.config import TrackerConfig
from belief_tracking.cues import ColourConfig, ColourCue, LocationCue, Observation
from belief_tracking.diagnostics import DiagnosticsCollector, FrameDiagnostics
from belief_tracking.evidence import Evidence, Weighing
from belief_tracking.filtering import ParticleCount, Prediction, estimate, location_centres, resample
from belief_tracking.fusion import FusionConfig
from belief_tracking.initiation import InitiationConfig, TargetInit, init_from_boxes, init_from_gt
from belief_tracking.observe import FrameObserver, FrameView
from belief_tracking.particles import MotionConfig, ParticleSet
from belief_tracking.perspective import PerspectiveScale
from belief_tracking.store import Track, TrackStore
from belief_tracking.tracker import Tracker
from belief_tracking.tracks import Estimate, TrackManager
from belief_tracking.weighting import BeliefWeighting

RED, BLUE, GREY = (0, 0, 255), (255, 0, 0), (128, 128, 128)


def two_people():
    """A grey frame with a red person at (20, 20, 10, 30) and a blue one at (60, 20, 10, 30)."""
    image = np.full((80, 120, 3), GREY, np.uint8)
    image[20:50, 20:30] = RED
    image[20:50, 60:70] = BLUE
    return image, [(20.0, 20.0, 10.0, 30.0), (60.0, 20.0, 10.0, 30.0)]


def track_at(track_id, box, image=None, cues=(), n=4, **options):
    x, y, w, h = box
    states = np.tile([x + w / 2, y + h / 2, 0.0, 0.0, 0.0], (n, 1))
    templates = {cue.name: cue.build_templates(image, [box])[0] for cue in cues}
    return Track.born(track_id, box, states, templates, **options)


def observation_of(image, tracks, cues, **options):
    return Observation(image, None, location_centres(tracks, 1.0, True), np.array([t.size for t in tracks]),
                       np.zeros((0, 2)), templates=stacked_templates(tracks, cues), **options)


# -- observe ---------------------------------------------------------------------------------------
def test_the_observer_reads_the_foreground_only_when_something_needs_it():
    image = np.zeros((40, 60, 3), np.uint8)
    detections = np.array([[5.0, 5, 10, 20, 0.8]])

    class CountingBackground:
        lighting_change = False
        calls = 0

        def apply(self, image, protect=None):
            CountingBackground.calls += 1
            self.protect = protect
            return np.zeros(image.shape[:2], bool)

    background = CountingBackground()
    with_detector = FrameObserver(TrackerConfig(initiation=InitiationConfig(), cues=("colour", "location")),
                                  background)
    view = with_detector(1, image, detections, [])
    assert view.foreground is None and CountingBackground.calls == 0          # the detector gives the candidates
    assert view.detector and view.candidates.tolist() == detections.tolist() and view.births_allowed
    blobs = FrameObserver(TrackerConfig(initiation=InitiationConfig(), cues=("colour", "location")), background)
    view = blobs(1, image, None, [(10.0, 10.0, 5.0, 10.0)])
    assert CountingBackground.calls == 1 and not view.detector
    assert view.candidates.shape == (0, 5)                                    # an empty mask: nobody
    assert background.protect.sum() == 5 * 10                                  # the track's box is protected
    cue_reads = FrameObserver(TrackerConfig(initiation=InitiationConfig()), background)   # the foreground cue
    assert cue_reads(1, image, detections, []).foreground is not None and CountingBackground.calls == 2
    planned_only = FrameObserver(TrackerConfig(cues=("colour", "location")), None)
    view = planned_only(1, image, None, [(10.0, 10.0, 5.0, 10.0)])
    assert view.foreground is None and view.candidates is None


def test_the_observer_is_the_frames_gate():
    observer = FrameObserver(TrackerConfig(), None)
    with pytest.raises(Exception, match="frame 3: frames must be"):
        observer(3, np.zeros((4, 6), np.uint8), None, [])
    with pytest.raises(Exception, match="frame 1: detections must be finite rows"):
        observer(1, np.zeros((4, 6, 3), np.uint8), np.array([[1.0, 1, -2, 2, 0.5]]), [])
    observer(1, np.zeros((4, 6, 3), np.uint8), None, [])
    assert observer.image_shape == (4, 6)


# -- predict ---------------------------------------------------------------------------------------
def test_prediction_moves_each_track_and_sizes_its_windows_by_the_perspective_of_their_row():
    prediction = Prediction(MotionConfig(sigma_pos=0.0, sigma_vel=0.0), (200, 300))
    near = track_at(1, (100, 100, 20, 60))
    near.particles = ParticleSet(np.array([[110.0, 130.0, 2.0, 10.0, 0.0]]))
    perspective = PerspectiveScale.fit([(40, 20, 10, 30), (200, 120, 20, 60)])
    (moved,) = prediction([near], perspective, np.random.default_rng(0))
    assert moved.states[0, :4].tolist() == [112.0, 140.0, 2.0, 10.0]
    expected = math.log(perspective.height(np.array([140.0]))[0] / perspective.height(np.array([130.0]))[0])
    assert moved.states[0, 4] == pytest.approx(expected)
    assert near.particles.states[0, 0] == 110.0                                # the track is not changed
    (fixed,) = prediction([near], None, np.random.default_rng(0))
    assert fixed.states[0, 4] == 0.0                                           # no model: the birth size


def test_the_location_centres_are_the_estimates_moved_on_by_their_velocity_unless_literal():
    moving = track_at(1, (10, 10, 4, 8))
    moving.estimate = np.array([12.0, 14.0, 3.0, -2.0, 0.0])
    assert location_centres([moving], 2.0, literal=False).tolist() == [[18.0, 10.0]]
    assert location_centres([moving], 2.0, literal=True).tolist() == [[12.0, 14.0]]
    assert location_centres([], 1.0, literal=False).shape == (0, 2)


# -- associate -------------------------------------------------------------------------------------
def test_association_weighs_contested_detections_by_appearance():
    image = np.full((80, 120, 3), GREY, np.uint8)
    image[20:50, 20:30] = RED
    image[20:50, 32:42] = BLUE
    red_box, blue_box = (20.0, 20.0, 10.0, 30.0), (32.0, 20.0, 10.0, 30.0)
    cue = ColourCue(ColourConfig(samples=(6, 12)))
    tracks = [track_at(1, red_box, image, [cue]), track_at(2, blue_box, image, [cue])]
    obs = observation_of(image, tracks, [cue])
    # Each track's predicted box overlaps the other person's detection more: IoU 1/3 against 3/17.
    predicted = np.array([[27.0, 20, 10, 30], [25.0, 20, 10, 30]])
    detections = np.array([[*red_box, 1.0], [*blue_box, 1.0]])
    overlap_only = Association(InitiationConfig(match_iou=0.1, appearance_weight=0.0), [cue])
    by_appearance = Association(InitiationConfig(match_iou=0.1, appearance_weight=2.0), [cue])
    assert overlap_only(obs, predicted, detections, detector=True).tolist() == [1, 0]
    assert by_appearance(obs, predicted, detections, detector=True).tolist() == [0, 1]
    assert by_appearance(obs, predicted, detections, detector=False).tolist() == [1, 0]   # blobs: overlap alone
    assert by_appearance(obs, predicted, None, detector=False) is None


# -- estimate, particle count, resample ------------------------------------------------------------
def test_estimate_is_the_weighted_mean_of_each_set_with_its_own_weights():
    tracks = [track_at(1, (0, 0, 2, 2)), track_at(2, (10, 0, 2, 2))]
    moved = [ParticleSet(np.array([[0.0, 0, 0, 0, 0], [6.0, 0, 0, 0, 0]])),
             ParticleSet(np.array([[10.0, 2, 0, 0, 0], [12.0, 4, 0, 0, 0], [14.0, 6, 0, 0, 0]]))]
    log_weights = np.log([1.0, 2.0, 1.0, 1.0, 2.0])
    weighted = estimate(tracks, moved, Weighing(log_weights), np.array([2, 3]))
    assert tracks[0].estimate[0] == pytest.approx(4.0)
    assert tracks[1].estimate[:2] == pytest.approx([12.5, 4.5])
    assert weighted[1].weights() == pytest.approx([0.25, 0.25, 0.5])


def test_the_particle_count_reads_the_belief_conflict_of_each_track():
    # Two cues over θ1, θ2 and FA: κ is the mean over a track's particles of m(θ1 ∩ θ2) + m(∅)
    # of the cues fused by the R-weighted rule, computed here mass function by mass function.
    location = np.log([[0.6, 0.3, 0.1], [0.5, 0.4, 0.1], [0.2, 0.2, 0.6]])
    colour = np.log([[0.2, 0.7, 0.1], [0.3, 0.6, 0.1], [0.1, 0.1, 0.8]])
    owner = np.array([0, 0, 1])
    beliefs = BeliefWeighting(FusionConfig(masses="normalised"))
    count = ParticleCount(10, "mass", beliefs)
    evidence = Evidence((location, colour), owner, np.zeros((3, 2)))
    model = Model.for_targets(2)
    t1, t2, fa = (str(x) for x in model.frame.singletons)
    expected = []
    for row in range(3):
        sources = [MassFunction({t1: p[0], t2: p[1], fa: p[2]}, model=model)
                   for p in (np.exp(location[row]) / np.exp(location[row]).sum(),
                             np.exp(colour[row]) / np.exp(colour[row]).sum())]
        fused = combine(*sources, rule="r_rule").to_mapping()
        expected.append(fused.get(f"{t1}&{t2}", 0.0) + fused.get("∅", 0.0))
    kappa = count.kappa(evidence)
    assert kappa == pytest.approx([(expected[0] + expected[1]) / 2, expected[2]], abs=1e-12)
    assert count(evidence) == [5 + math.ceil(5 * k - 1e-9) for k in kappa]
    assert beliefs.fuse(evidence) is beliefs.fuse(evidence)                    # fused once per frame
    r_count = ParticleCount(10, "r", beliefs)
    assert r_count.kappa(evidence) == pytest.approx(
        [(beliefs.fuse(evidence).inconsistency[0] + beliefs.fuse(evidence).inconsistency[1]) / 2,
         beliefs.fuse(evidence).inconsistency[2]])


def test_resampling_draws_each_set_anew_to_its_count():
    tracks = [track_at(1, (0, 0, 2, 2)), track_at(2, (10, 0, 2, 2))]
    weighted = [ParticleSet(np.array([[1.0, 0, 0, 0, 0], [3.0, 0, 0, 0, 0]]), np.array([0.0, -np.inf])),
                ParticleSet(np.array([[5.0, 0, 0, 0, 0]]))]
    resample(tracks, weighted, np.random.default_rng(0), "systematic", 1.0, [3, 2])
    assert tracks[0].particles.states[:, 0].tolist() == [1.0, 1.0, 1.0]
    assert tracks[1].particles.states[:, 0].tolist() == [5.0, 5.0]
    resample(tracks, weighted, np.random.default_rng(0), "systematic", 0.0, None)   # N_eff ≥ 0: kept as is
    assert tracks[0].particles is weighted[0]


# -- appearance ------------------------------------------------------------------------------------
def test_the_appearance_stage_writes_rho_into_each_record_and_freezes_an_occluded_template():
    image, (red_box, blue_box) = two_people()
    cue = ColourCue(ColourConfig(samples=(6, 12)))
    red, blue = track_at(1, red_box, image, [cue]), track_at(2, blue_box, image, [cue])
    blue.estimate[:2] = (25.0, 35.0)                                         # blue's window now shows red
    before = {t.id: t.templates["colour"].copy() for t in (red, blue)}
    follower = AppearanceFollower(AdaptiveConfig(threshold=0.6), [cue, LocationCue()], update=True)
    appearance = follower.follow(observation_of(image, [red, blue], [cue]), [red, blue])
    assert appearance.similarity[0] == pytest.approx(1.0) and appearance.similarity[1] < 0.6
    assert appearance.occluded.tolist() == [False, True]
    assert (red.similarity, blue.similarity) == (pytest.approx(1.0), pytest.approx(appearance.similarity[1]))
    # Frozen under occlusion (renormalised, as every template is: equal to rounding).
    assert np.allclose(blue.templates["colour"], before[2], rtol=0, atol=1e-15)
    assert np.allclose(red.templates["colour"], before[1])                    # seen as it was: C (16) keeps it
    # Red shifted half a window: its template moves towards what it sees now, anchored at the initial one.
    red.estimate[:2] = (30.0, 35.0)
    follower.follow(observation_of(image, [red], [cue]), [red])
    assert not np.allclose(red.templates["colour"], before[1])
    assert red.templates["colour"].sum() == pytest.approx(1.0)
    assert np.array_equal(red.initial_templates["colour"], before[1])


def test_the_appearance_stage_weighs_the_cues_by_the_strategys_confidences():
    image, (red_box, _) = two_people()
    colour = ColourCue(ColourConfig(samples=(6, 12)))
    track = track_at(1, red_box, image, [colour])
    track.estimate[:2] = (27.0, 35.0)
    follower = AppearanceFollower(AdaptiveConfig(), [LocationCue(), colour], update=False)
    alone = follower.follow(observation_of(image, [track], [colour]), [track]).similarity[0]
    weighted = follower.follow(observation_of(image, [track], [colour]), [track],
                               confidences=np.array([[0.9, 0.1]])).similarity[0]
    assert weighted == pytest.approx(alone)           # λ renormalised over the appearance cues: colour alone
    none = AppearanceFollower(AdaptiveConfig(), [LocationCue()], update=True)
    assert none.follow(observation_of(image, [track], []), [track]).similarity.tolist() == [1.0]


# -- track management ------------------------------------------------------------------------------
def manager(store, plan=None, cues=(), **initiation):
    config = TrackerConfig(particles=4, initiation=InitiationConfig(**initiation) if initiation else None)
    tracks = TrackManager(config, plan, list(cues), np.random.default_rng(0), store)
    tracks.start((80, 120))
    return tracks


def test_planned_births_and_ends_follow_the_plan():
    gt = np.array([[1, 3, 10, 10, 8, 16], [2, 3, 11, 10, 8, 16], [2, 5, 50, 10, 8, 16]], dtype=float)
    store = TrackStore()
    tracks = manager(store, init_from_gt(gt))
    image = np.zeros((80, 120, 3), np.uint8)
    first = tracks.births_and_deaths(FrameView(1, image, None, None), [])
    assert [e.id for e in first] == [3] and store.ids == [3] and store[3].planned and store[3].last_frame == 2
    second = tracks.births_and_deaths(FrameView(2, image, None, None), [Estimate.of(store[3], 2)])
    assert [e.id for e in second] == [3, 5]
    tracks.end_planned(3)
    assert store.ids == []


def test_a_track_that_took_a_candidate_moves_towards_it():
    store = TrackStore()
    tracks = manager(store, centre_gain=0.5, size_smoothing=0.3)
    followed, alone = store.add(track_at(1, (10, 10, 10, 20))), store.add(track_at(2, (50, 10, 10, 20)))
    candidates = np.array([[14.0, 10.0, 12.0, 20.0, 0.8]])
    tracks.follow_candidates(7, [followed, alone], np.array([0, -1]), candidates)
    assert followed.estimate[:2].tolist() == pytest.approx([15.0 + 0.5 * 0.8 * 5.0, 20.0])
    assert followed.particles.states[:, 0] == pytest.approx(17.0)
    assert followed.size.tolist() == pytest.approx([0.7 * 10 + 0.3 * 12, 20.0])
    assert followed.last_seen[0] == 7 and followed.last_seen[1].tolist() == [14.0, 10.0, 12.0, 20.0]
    assert alone.estimate[:2].tolist() == [55.0, 20.0] and alone.last_seen is None
    tracks.follow_candidates(8, [followed], np.array([0]), np.array([[0.0, 10.0, 40.0, 20.0, 1.0]]), detector=True)
    assert followed.size[0] == pytest.approx(0.85 * 10.6 + 0.15 * 10.0)       # a detection's width: ≤ 0.5 h


def test_a_newborn_track_like_a_lost_one_near_where_it_went_takes_back_its_id():
    image, (red_box, blue_box) = two_people()
    cue = ColourCue(ColourConfig(samples=(6, 12)))
    store = TrackStore()
    tracks = manager(store, cues=[cue], lost_frames=1, first_frame=False, appear_frames=1, appearance_support=None,
                     exit_frames=100)
    for track_id, box in ((4, red_box), (5, blue_box)):
        tracks.add(TargetInit(track_id, 10, None, box), 10, image, planned=False)
    red, blue = store[4], store[5]
    view = FrameView(10, image, None, np.zeros((0, 5)), detector=True)
    out = tracks.births_and_deaths(view, [Estimate.of(red, 10), Estimate.of(blue, 10)], np.array([-1, -1]))
    assert out == [] and sorted(store.lost) == [4, 5] and store.ids == []
    # Two frames later red reappears where it was, blue far from where it went.
    back = np.array([[21.0, 20, 10, 30, 1.0], [60.0, 50, 10, 30, 1.0]])
    view = FrameView(12, image, None, back, detector=True)
    born = tracks.births_and_deaths(view, [], None)
    # Red (newborn 6) takes back 4; the other newborn keeps its own new id 7 (ids are never reused).
    assert [e.id for e in born] == [4, 7] and store.ids == [4, 7] and sorted(store.lost) == [5]


def test_no_automatic_birth_beyond_max_targets():
    store = TrackStore()
    config = TrackerConfig(particles=4, max_targets=2, initiation=InitiationConfig(appear_frames=1))
    tracks = TrackManager(config, None, [], np.random.default_rng(0), store)
    tracks.start((80, 120))
    candidates = np.array([[10.0 + 25 * k, 10, 10, 20, 1.0] for k in range(4)])
    born = tracks.births_and_deaths(FrameView(1, np.zeros((80, 120, 3), np.uint8), None, candidates, True), [])
    assert [e.id for e in born] == [1, 2] and len(store) == 2


# -- diagnostics: they read, they never steer -------------------------------------------------------
def test_the_collector_lays_out_the_columns_and_keeps_the_tracks_still_alive():
    config = TrackerConfig(fusion="sum")
    collector = DiagnosticsCollector(config, None, np.random.default_rng(0))
    weighted = [ParticleSet(np.zeros((3, 5))), ParticleSet(np.zeros((2, 5)), np.log([1.0, 3.0]))]
    evidence = Evidence((np.zeros((5, 3)),), np.array([0, 0, 0, 1, 1]), np.zeros((5, 2)))
    frame = collector.collect([8, 9], evidence, Weighing(np.zeros(5)), weighted, None)
    assert frame.columns == ("particles", "ess") and frame.ids == (8, 9)
    assert frame.values == pytest.approx(np.array([[3.0, 3.0], [2.0, 1.6]]))
    kept = DiagnosticsCollector.of_alive(frame, {9})
    assert kept.ids == (9,) and kept.values == pytest.approx(np.array([[2.0, 1.6]]))
    assert DiagnosticsCollector.of_alive(frame, {8, 9}) is frame
    assert collector.empty().values.shape == (0, 2)
    assert FrameDiagnostics(("a",), (), np.zeros((0, 1))).rows(1) == []


@pytest.mark.parametrize("fusion", ["belief", "sum"])
def test_recording_every_diagnostic_changes_no_track(fusion, rendered_scene):
    scene = rendered_scene(scenes.crossing(0))
    plan = init_from_gt(scene.ground_truth)
    runs = {}
    for diagnostics in ("strategy", "all"):
        config = TrackerConfig(particles=20, cues=("colour", "location"), fusion=fusion, diagnostics=diagnostics)
        results = list(Tracker(config, plan, np.random.default_rng(3)).track(scene.frames[:25]))
        runs[diagnostics] = results
    assert len(runs["all"][-1].diagnostics.columns) > len(runs["strategy"][-1].diagnostics.columns)
    for plain, recorded in zip(runs["strategy"], runs["all"]):
        assert [(e.id, e.box) for e in plain.estimates] == [(e.id, e.box) for e in recorded.estimates]


def test_a_tracker_exposes_its_store_and_a_target_has_one_home(rendered_scene):
    scene = rendered_scene(scenes.crossing(0))
    tracker = Tracker(TrackerConfig(particles=10, cues=("colour", "location")), init_from_boxes(
        [tuple(scene.ground_truth[0, 2:6] - [1, 1, 0, 0])], ids=[6]), np.random.default_rng(0))
    result = tracker.step(1, scene.frames[0])
    assert tracker.store.ids == [6] and result.estimates[0].id == 6
    record = tracker.store[6]
    result = tracker.step(2, scene.frames[1])
    assert tracker.store[6] is record and np.array_equal(result.estimates[0].state, record.estimate)
    assert sorted(record.templates) == ["colour"] and len(record.particles) == 10
