"""Cue masses that keep particle weights informative, the location gate and the perspective scale."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from belief_tracking.cues import LocationConfig, LocationCue, Observation
from belief_tracking.errors import TrackingError
from belief_tracking.fusion import CueFusion, FusionConfig, cue_masses, relative_likelihoods
from belief_tracking.perspective import MAX_SCALE_CHANGE, PerspectiveScale
from belief_tracking.config import TrackerConfig
from belief_tracking.initiation import init_from_boxes
from belief_tracking.tracker import Tracker

log_likelihood_rows = st.lists(st.lists(st.floats(-50.0, 0.0), min_size=3, max_size=3), min_size=1, max_size=8)


@settings(max_examples=100, deadline=None)
@given(log_likelihood_rows)
def test_absolute_masses_sum_to_one_and_keep_likelihoods_that_fit(rows):
    values = np.array(rows)
    masses = cue_masses(values, "absolute")
    assert np.allclose(masses.sum(axis=1), 1.0) and (masses >= 0).all()
    p = np.exp(values)
    fits = p.sum(axis=1) <= 1.0
    assert np.allclose(masses[fits, :-1], p[fits, :-1])
    assert np.allclose(masses[~fits], cue_masses(values[~fits], "normalised"))


def test_absolute_masses_reject_likelihoods_above_one_and_unknown_modes():
    with pytest.raises(TrackingError, match=r"\[0, 1\]"):
        cue_masses(np.array([[0.5, -1.0]]), "absolute")
    with pytest.raises(TrackingError, match="normalised, absolute"):
        cue_masses(np.array([[0.0, -1.0]]), "odd")
    with pytest.raises(TrackingError, match="FusionConfig.masses must be one of relative, normalised"):
        FusionConfig(masses="absolute")


@settings(max_examples=100, deadline=None)
@given(log_likelihood_rows, st.integers(0, 2**32 - 1))
def test_relative_likelihoods_put_each_sets_best_particle_at_one(rows, seed):
    values = np.array(rows)
    owner = np.random.default_rng(seed).integers(0, 2, size=len(rows))
    relative = relative_likelihoods(values, owner)
    assert (relative <= 0).all()
    own = relative[np.arange(len(rows)), owner]
    for j in np.unique(owner):
        assert own[owner == j].max() == pytest.approx(0.0, abs=1e-12)
    # Within a set the order of the own-target likelihoods is kept.
    raw_own = values[np.arange(len(rows)), owner]
    for j in np.unique(owner):
        mine = owner == j
        assert (np.argsort(raw_own[mine], kind="stable") == np.argsort(own[mine], kind="stable")).all()


def test_relative_masses_give_weights_that_follow_the_fit_where_normalised_masses_saturate():
    # One target; its particles fit it better and better (log p_J from −12 to −1) and fit FA
    # far worse (log p_FA = −20), for two cues.
    own = np.linspace(-12.0, -1.0, 12)
    scores = np.column_stack([own, np.full(12, -20.0)])
    owner = np.zeros(12, dtype=np.int64)
    literal = CueFusion(1, FusionConfig(masses="normalised")).fuse([scores, scores], owner).weights
    relative = CueFusion(1, FusionConfig(masses="relative")).fuse([scores, scores], owner).weights
    assert literal.min() > 0.999                       # every particle looks perfect
    assert (np.diff(relative) > 0).all()               # the better the fit, the larger the weight
    assert relative[-1] / relative[0] > 1e3


def test_gate_location_makes_false_alarm_unlikely_near_every_target_only():
    obs = Observation(np.zeros((200, 400, 3), np.uint8), None, centres=[[50.0, 100.0], [350.0, 100.0]],
                      sizes=[[20.0, 40.0], [20.0, 40.0]], previous_particles=np.zeros((0, 2)))
    cue = LocationCue(LocationConfig(sigma=10.0, gate=3.0))
    states = np.array([[50.0, 100.0, 0, 0, 0], [350.0, 100.0, 0, 0, 0], [200.0, 100.0, 0, 0, 0]])
    logs = cue.log_likelihoods(obs, states, np.array([0, 1, 0]))
    assert logs[0, 2] == pytest.approx(-4.5) and logs[1, 2] == pytest.approx(-4.5)   # G(3σ; σ) at each target
    assert logs[2, 2] == 0.0                                                          # beyond the gate: FA
    centroid = LocationCue(LocationConfig(sigma=10.0, literal=True)).log_likelihoods(obs, states,
                                                                                   np.array([0, 1, 0]))
    assert centroid[0, 2] == 0.0          # W (23) with the centroid calls a lone outer target FA
    with pytest.raises(TrackingError, match="literal"):
        LocationConfig(literal="ahead")
    with pytest.raises(TrackingError, match="gate"):
        LocationConfig(gate=0.0)


def test_predicted_reference_centres_the_location_cue_ahead_of_a_moving_target():
    image = np.zeros((100, 200, 3), np.uint8)
    config = TrackerConfig(particles=5, cues=("location",))
    tracker = Tracker(config, init_from_boxes([(40, 30, 10, 20)]), np.random.default_rng(0))
    tracker.step(1, image)
    tracker.targets[0].estimate[2:4] = (4.0, -2.0)
    assert np.allclose(tracker._observation(tracker.observe(2, image, None, []), tracker.targets).centres,
                       [[49.0, 38.0]])
    literal = Tracker(TrackerConfig(particles=5, cues=("location",), location=LocationConfig(literal=True)),
                      init_from_boxes([(40, 30, 10, 20)]), np.random.default_rng(0))
    literal.step(1, image)
    literal.targets[0].estimate[2:4] = (4.0, -2.0)
    assert np.allclose(literal._observation(literal.observe(2, image, None, []), literal.targets).centres,
                       [[45.0, 40.0]])                                     # W (22): the previous estimate


def test_perspective_fit_recovers_a_ground_plane_and_refuses_what_is_not_one():
    rng = np.random.default_rng(3)
    foot = rng.uniform(100, 300, 6)
    h = 0.25 * foot + 5.0
    boxes = np.column_stack([rng.uniform(0, 300, 6), foot - h, 0.4 * h, h])
    model = PerspectiveScale.fit(boxes)
    assert model.a == pytest.approx(0.25) and model.b == pytest.approx(5.0)
    assert np.allclose(model.height(foot - h / 2), h)
    assert PerspectiveScale.fit(boxes[:1]) is None                         # one box
    assert PerspectiveScale.fit(boxes[:, [0, 1, 2, 3]] * [1, 0, 1, 0] + [0, 50, 0, 40]) is None   # one row
    upside_down = boxes.copy()
    upside_down[:, 3] = 80.0 - 0.2 * foot
    upside_down[:, 1] = foot - upside_down[:, 3]
    assert PerspectiveScale.fit(upside_down) is None                       # a < 0
    far = model.log_scale(np.array([-1e6, 1e6]), 150.0)
    assert np.allclose(np.abs(far), math.log(MAX_SCALE_CHANGE))


def test_tracker_sizes_windows_by_perspective_once_two_rows_are_known():
    image = np.zeros((240, 320, 3), np.uint8)
    plan = init_from_boxes([(40, 20, 10, 30), (200, 120, 20, 60)])
    tracker = Tracker(TrackerConfig(particles=10, cues=("location",)), plan, np.random.default_rng(0))
    tracker.step(1, image)
    perspective = tracker.manager.perspective
    assert perspective is not None
    estimates = tracker.step(2, image).estimates
    for estimate, target in zip(estimates, tracker.targets):
        expected = perspective.log_scale(np.array([estimate.state[1]]), target.birth_cy)[0]
        assert estimate.state[4] == pytest.approx(expected, abs=0.05)
    # One birth box: no ground plane yet, so every window keeps its birth size.
    single = Tracker(TrackerConfig(particles=10, cues=("location",)), init_from_boxes([(40, 20, 10, 30)]),
                     np.random.default_rng(0))
    single.step(1, image)
    assert single.manager.perspective is None
    assert all(e.state[4] == 0.0 and e.box[2:] == (10.0, 30.0) for e in single.step(2, image).estimates)
    with pytest.raises(TrackingError, match="masses must be one of"):
        TrackerConfig(belief=FusionConfig(masses="odd"))
