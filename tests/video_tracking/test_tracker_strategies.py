"""The tracker's automatic initiation, fusion strategies, occlusion flag, template update and adaptive N."""

from __future__ import annotations

import numpy as np
import pytest

from belief_tracking import scenes
from belief_tracking.adaptive import AdaptiveConfig
from belief_tracking.boxes import iou
from belief_tracking.config import TrackerConfig
from belief_tracking.errors import InitError, TrackingError
from belief_tracking.evaluation import evaluate
from belief_tracking.initiation import InitiationConfig, init_from_gt
from belief_tracking.tracker import Tracker, diagnostic_columns
from belief_tracking.weighting import WEIGHTINGS

FUSIONS = tuple(WEIGHTINGS)


def run_scene(scene, config, seed=0, plan=None, watch=None):
    """The frame results of a scene; ``watch(tracker, frame)`` is called before each step."""
    tracker = Tracker(config, plan, np.random.default_rng(seed))
    per_frame = []
    for t in range(len(scene)):
        if watch is not None:
            watch(tracker, t + 1)
        per_frame.append(tracker.step(t + 1, scene.frame(t)))
    return tracker, per_frame


def diagnostics_by_frame(per_frame):
    """{(frame, id): diagnostics} of every target that was filtered."""
    return {(result.frame, row["id"]): row for result in per_frame for row in result.diagnostics.rows(result.frame)}


# -- automatic initiation -------------------------------------------------------------------------
@pytest.fixture(scope="module")
def entering(rendered_scene):
    scene = rendered_scene(scenes.entering_leaving(0))
    _, per_frame = run_scene(scene, TrackerConfig(particles=40, initiation=InitiationConfig()))
    return scene, per_frame


def test_people_entering_are_found_within_a_few_frames_without_an_init_file(entering):
    scene, per_frame = entering
    gt = scene.ground_truth
    for walker in np.unique(gt[:, 1]):
        own = gt[gt[:, 1] == walker]
        first = int(own[:, 0].min())
        found = None
        for row in own:
            frame = int(row[0])
            boxes = np.array([e.box for e in per_frame[frame - 1].estimates]).reshape(-1, 4)
            truth = np.array([[row[2] - 1, row[3] - 1, row[4], row[5]]])
            if len(boxes) and iou(truth, boxes).max() >= 0.5:
                found = frame
                break
        assert found is not None and found - first <= 5, (walker, first, found)


def test_no_track_is_left_on_a_person_who_left(entering):
    scene, per_frame = entering
    gt = scene.ground_truth
    for walker in np.unique(gt[:, 1]):
        last_row = gt[(gt[:, 1] == walker)][-1]
        exit_box = np.array([[last_row[2] - 1, last_row[3] - 1, last_row[4], last_row[5]]])
        for result in per_frame[int(last_row[0]) + 5:]:
            boxes = np.array([e.box for e in result.estimates]).reshape(-1, 4)
            assert not len(boxes) or iou(exit_box, boxes).max() == 0.0
    assert per_frame[-1].estimates == ()                          # everybody left before the end
    ids = {e.id for result in per_frame for e in result.estimates}
    assert len(ids) == 3                                          # one track per person, nothing spurious
    rows = np.array([row for result in per_frame for row in result.mot_rows()])
    assert evaluate(gt, rows).mota >= 0.8


def test_a_tracker_without_plan_needs_the_initiation():
    with pytest.raises(InitError, match="nothing to track"):
        Tracker(TrackerConfig(), None, np.random.default_rng(0))


# -- occlusion flag and template update -----------------------------------------------------------
# The two people of this scene are dressed alike, so the hidden one's total similarity at its
# estimate falls from about 0.98 only to about 0.8; T = 0.9 separates the two regimes here
# (C's T = 0.6 is a setting for real footage).
OCCLUSION = AdaptiveConfig(threshold=0.9)


@pytest.mark.parametrize("fusion, update", [("adaptive", False), ("belief", True)])
def test_an_occluded_target_keeps_its_template(fusion, update, rendered_scene):
    scene = rendered_scene(scenes.similar_colours(0))
    config = TrackerConfig(particles=60, cues=("colour", "location"), fusion=fusion, template_update=update,
                           adaptive_fusion=OCCLUSION)
    assert config.updates_templates
    before = {}

    def watch(tracker, frame):
        before[frame] = [{name: t.copy() for name, t in track.templates.items()} for track in tracker.store]

    tracker, per_frame = run_scene(scene, config, plan=init_from_gt(scene.ground_truth), watch=watch)
    flags = {key: row["occluded"] for key, row in diagnostics_by_frame(per_frame).items()}
    # Walker 1 is fully hidden from frame index 47 to 53 (frames 48-54).
    assert any(flags[(frame, 1)] == 1.0 for frame in range(48, 55))
    assert not any(flags[(frame, k)] for frame in range(10, 36) for k in (1, 2))
    changed = 0
    for frame in range(2, len(scene)):
        after = before[frame + 1]
        for j, target_id in enumerate((1, 2)):
            same = before[frame][j].keys() == after[j].keys() == {"colour"} \
                and all(np.array_equal(before[frame][j][name], after[j][name]) for name in after[j])
            if flags[(frame, target_id)] == 1.0:
                assert same, (frame, target_id)
            else:
                changed += not same
    assert changed > 0                                            # the templates do follow visible targets


def test_fixed_templates_by_default_for_the_belief_rules(rendered_scene):
    scene = rendered_scene(scenes.crossing(0))
    config = TrackerConfig(particles=20, cues=("colour", "location"))
    assert not config.updates_templates and TrackerConfig(fusion="adaptive").updates_templates
    assert TrackerConfig(fusion="adaptive", template_update=False).updates_templates     # C's method includes it
    tracker, _ = run_scene(scenes.Scene(scene.config, scene.frames[:6], scene.ground_truth, scene.visibility),
                           config, plan=init_from_gt(scene.ground_truth[scene.ground_truth[:, 0] <= 6]))
    assert len(tracker.store) == 2
    for track in tracker.store:
        assert np.array_equal(track.templates["colour"], track.initial_templates["colour"])


# -- adaptive particle count ----------------------------------------------------------------------
def test_the_particle_count_rises_during_the_occlusion_and_falls_after(rendered_scene):
    scene = rendered_scene(scenes.crossing(0))
    config = TrackerConfig(particles=80, cues=("colour", "location"), adaptive_particles=True)
    _, per_frame = run_scene(scene, config, plan=init_from_gt(scene.ground_truth))
    counts = {frame: row["particles"] for (frame, target), row in diagnostics_by_frame(per_frame).items()
              if target == 1}
    before = np.mean([counts[f] for f in range(10, 31)])
    during = np.mean([counts[f] for f in range(46, 56)])
    after = np.mean([counts[f] for f in range(75, 96)])
    assert min(counts.values()) >= 40 and max(counts.values()) <= 80     # N_min = ⌈80 / 2⌉, N_max = 80
    assert during >= before + 3 and during >= after + 3, (before, during, after)


def test_a_fixed_count_keeps_n(rendered_scene):
    scene = rendered_scene(scenes.crossing(0))
    short = scenes.Scene(scene.config, scene.frames[:5], scene.ground_truth, scene.visibility)
    _, per_frame = run_scene(short, TrackerConfig(particles=30), plan=init_from_gt(scene.ground_truth))
    assert {row["particles"] for row in diagnostics_by_frame(per_frame).values()} == {30.0}


# -- strategies and diagnostics ----------------------------------------------------------------------
@pytest.mark.parametrize("fusion", FUSIONS)
def test_every_fusion_strategy_tracks_and_reports_the_same_diagnostics_on_request(fusion, rendered_scene):
    scene = rendered_scene(scenes.crossing(0))
    short = scenes.Scene(scene.config, scene.frames[:12], scene.ground_truth, scene.visibility)
    cues = ("colour", "location", "edges")
    config = TrackerConfig(particles=30, cues=cues, fusion=fusion, diagnostics="all")
    _, per_frame = run_scene(short, config, plan=init_from_gt(scene.ground_truth))
    everything = diagnostic_columns(TrackerConfig(cues=cues, diagnostics="all"))
    for result in per_frame[1:]:
        assert result.diagnostics.columns == everything
        for row in result.diagnostics.rows(result.frame):
            assert all(np.isfinite(v) for v in row.values())
            assert abs(sum(row[f"confidence_{c}"] for c in cues) - 1.0) < 1e-9
            assert row["occluded"] in (0.0, 1.0)
            assert 0.0 <= row["mean_m_target"] <= row["mean_bel"] + 1e-12
    rows = np.array([row for result in per_frame for row in result.mot_rows()])
    truth = scene.ground_truth[scene.ground_truth[:, 0] <= 12]
    assert evaluate(truth, rows).mota >= 0.8


@pytest.mark.parametrize("fusion, columns", [
    ("belief", ("mean_m_target", "mean_m_intersection", "mean_bel", "mean_m_empty", "mean_r", "particles", "ess")),
    ("adaptive", ("particles", "ess", "similarity", "occluded", "confidence_colour", "confidence_location")),
    ("sum", ("particles", "ess")),
    ("product", ("particles", "ess")),
])
def test_only_the_active_strategy_runs_by_default(fusion, columns, monkeypatch, rendered_scene):
    # The belief fusion and C's confidences run only for the strategy that uses them.
    from belief_tracking import adaptive, weighting

    calls = []
    monkeypatch.setattr(weighting.BeliefWeighting, "fuse",
                        lambda self, evidence, real=weighting.BeliefWeighting.fuse: calls.append("belief")
                        or real(self, evidence))
    monkeypatch.setattr(adaptive, "_spreads",
                        lambda *a, real=adaptive._spreads, **k: calls.append("spreads") or real(*a, **k))
    scene = rendered_scene(scenes.crossing(0))
    short = scenes.Scene(scene.config, scene.frames[:4], scene.ground_truth, scene.visibility)
    config = TrackerConfig(particles=20, cues=("colour", "location"), fusion=fusion)
    _, per_frame = run_scene(short, config, plan=init_from_gt(scene.ground_truth))
    assert per_frame[-1].diagnostics.columns == columns
    assert set(calls) == {"belief": {"belief"}, "adaptive": {"spreads"}}.get(fusion, set())


def test_strategies_weigh_particles_differently(rendered_scene):
    scene = rendered_scene(scenes.crossing(0))
    short = scenes.Scene(scene.config, scene.frames[:4], scene.ground_truth, scene.visibility)
    states = {}
    for fusion in FUSIONS:
        _, per_frame = run_scene(short, TrackerConfig(particles=30, cues=("colour", "location"), fusion=fusion),
                                 plan=init_from_gt(scene.ground_truth))
        states[fusion] = np.array([e.state for e in per_frame[-1].estimates])
    values = list(states.values())
    assert all(not np.array_equal(values[0], other) for other in values[1:])


@pytest.mark.parametrize("kwargs, message", [
    ({"fusion": "vote"}, "unknown fusion 'vote'; known fusions: belief, adaptive, sum, product"),
    ({"kappa": "entropy"}, "TrackerConfig.kappa must be one of mass, r"),
    ({"warm_up": -1}, "TrackerConfig.warm_up must be an integer >= 0"),
    ({"template_update": "yes"}, "TrackerConfig.template_update must be True or False"),
    ({"adaptive_particles": 1}, "TrackerConfig.adaptive_particles must be True or False"),
    ({"initiation": {"border": 5}}, "TrackerConfig.initiation must be an InitiationConfig"),
    ({"adaptive_fusion": {"threshold": 0.5}}, "TrackerConfig.adaptive_fusion must be an AdaptiveConfig"),
    ({"diagnostics": "some"}, "TrackerConfig.diagnostics must be one of strategy, all"),
    ({"belief": "absolute"}, "TrackerConfig.belief must be a FusionConfig"),
])
def test_bad_settings_name_the_field(kwargs, message):
    with pytest.raises(TrackingError, match=message.replace("(", r"\(").replace(")", r"\)")):
        TrackerConfig(**kwargs)


def test_warm_up_learns_the_background_before_the_first_frame(rendered_scene):
    scene = rendered_scene(scenes.crossing(0))
    tracker = Tracker(TrackerConfig(particles=10, initiation=InitiationConfig()), None, np.random.default_rng(0))
    assert tracker.warm_up(scene.frames[::2]) == 50
    estimates = tracker.step(1, scene.frame(0)).estimates
    # The background is known, so both walkers are foreground blobs of the first frame.
    assert len(estimates) == 2
    assert Tracker(TrackerConfig(cues=("colour",)), init_from_gt(scene.ground_truth),
                   np.random.default_rng(0)).warm_up(scene.frames[:3]) == 0
