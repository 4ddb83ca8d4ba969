"""The track store: one record per target keyed by its id; births, deaths, losses and re-identification."""

from __future__ import annotations

import numpy as np
import pytest

from belief_tracking.errors import InitError, TrackingError
from belief_tracking.particles import ParticleSet
from belief_tracking.store import Life, LostTrack, Track, TrackStore


def track(track_id: int, box=(10.0, 20.0, 8.0, 16.0), templates=None, **options) -> Track:
    states = np.tile([box[0] + box[2] / 2, box[1] + box[3] / 2, 0.0, 0.0, 0.0], (3, 1))
    return Track.born(track_id, box, states, templates or {"colour": np.array([0.25, 0.75])}, **options)


def test_a_newborn_track_starts_at_its_box_at_rest_with_its_templates_as_the_initial_ones():
    born = track(4, (10.0, 20.0, 8.0, 16.0), similarity=0.7, last_frame=9, planned=True)
    assert born.estimate.tolist() == [14.0, 28.0, 0.0, 0.0, 0.0]
    assert born.size.tolist() == [8.0, 16.0] and born.birth_cy == 28.0
    assert born.box() == (10.0, 20.0, 8.0, 16.0)
    assert born.similarity == 0.7 and born.last_frame == 9 and born.planned
    assert born.life == Life() and born.last_seen is None
    assert np.array_equal(born.templates["colour"], born.initial_templates["colour"])
    born.templates["colour"][0] = 1.0                  # the current template may change ...
    assert born.initial_templates["colour"][0] == 0.25  # ... its initial one does not
    assert len(born.particles) == 3 and np.allclose(born.particles.weights(), 1 / 3)


def test_a_track_box_follows_its_estimate_and_scale_and_its_prediction_its_velocity():
    moving = track(1, (10.0, 20.0, 8.0, 16.0))
    moving.estimate = np.array([30.0, 40.0, 2.0, -1.0, np.log(2.0)])
    assert moving.box() == pytest.approx((22.0, 24.0, 16.0, 32.0))
    assert moving.predicted_box(3.0).tolist() == pytest.approx([28.0, 21.0, 16.0, 32.0])
    moving.estimate[4] = 1e9                             # a scale beyond e^30 is clipped, never inf
    assert np.isfinite(moving.box()).all()


def test_the_store_keeps_tracks_by_id_oldest_first_and_refuses_a_second_home():
    store = TrackStore()
    for track_id in (7, 2, 9):
        store.add(track(track_id))
    assert store.ids == [7, 2, 9] and [t.id for t in store.tracks] == [7, 2, 9]
    assert len(store) == 3 and bool(store) and 2 in store and 5 not in store
    assert store[2].id == 2
    with pytest.raises(InitError, match="target 2 is already being tracked"):
        store.add(track(2))
    assert store.remove(2).id == 2 and store.ids == [7, 9]
    with pytest.raises(TrackingError, match="no live track 2"):
        store.remove(2)
    for record in store:                                 # iteration may remove as it goes
        store.remove(record.id)
    assert not store and store.ids == []


def test_a_lost_track_is_remembered_where_a_candidate_last_saw_it_or_where_it_was():
    store = TrackStore()
    seen = store.add(track(1, templates={"colour": np.array([1.0, 0.0]), "edges": np.array([0.5, 0.5])}))
    seen.last_seen = (4, np.array([11.0, 21.0, 8.0, 16.0]))
    seen.estimate[2:4] = (1.5, -0.5)
    store.add(track(2, (50.0, 20.0, 8.0, 16.0), planned=True))
    memory = store.lose(1, frame=9)
    assert isinstance(memory, LostTrack) and store.lost == {1: memory} and store.ids == [2]
    assert memory.frame == 4 and memory.box.tolist() == [11.0, 21.0, 8.0, 16.0]
    assert memory.velocity.tolist() == [1.5, -0.5] and sorted(memory.templates) == ["colour", "edges"]
    seen.templates["colour"][0] = 0.0                    # the memory is a copy of how it looked
    seen.estimate[2] = 9.0
    assert memory.templates["colour"].tolist() == [1.0, 0.0] and memory.velocity[0] == 1.5
    other = store.lose(2, frame=9)
    assert other.frame == 9 and other.box.tolist() == [50.0, 20.0, 8.0, 16.0] and other.planned


def test_lost_tracks_are_forgotten_after_the_memory_and_re_identified_by_name():
    store = TrackStore()
    for track_id in (1, 2):
        store.add(track(track_id))
    store.lose(1, frame=10)
    store.lose(2, frame=20)
    store.forget(frame=40, memory=25)                    # 1 was lost 30 frames ago, 2 only 20
    assert sorted(store.lost) == [2]
    store.add(track(3))
    store.add(track(8))
    back = store.reidentify(3, 2)
    assert back.id == 2 and store.ids == [2, 8] and store.lost == {}   # keeps its place in the birth order
    assert store[2] is back and 3 not in store
    with pytest.raises(KeyError):
        store.reidentify(8, 2)                           # no memory left of 2


def test_a_re_identified_track_takes_back_the_planned_flag_of_its_id():
    store = TrackStore()
    store.add(track(1, planned=True))
    store.lose(1, frame=3)
    store.add(track(5))
    assert store.reidentify(5, 1).planned


def test_a_newborn_record_owns_its_template_table_and_initial_templates():
    given = {"colour": np.array([0.25, 0.75])}
    record = Track.born(1, (0.0, 0.0, 2.0, 2.0), np.zeros((2, 5)), given)
    given["edges"] = np.array([1.0, 0.0])                # the caller's table is not the record's
    given["colour"][0] = 0.5                             # nor is the initial template a view of its array
    assert sorted(record.templates) == ["colour"]
    assert record.initial_templates["colour"].tolist() == [0.25, 0.75]
