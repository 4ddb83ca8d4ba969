"""The track store: one record per target, keyed by its track id, holding everything about it.

A :class:`Track` is a target's one home: its particles and log-weights, its motion state
(estimate, window size), each appearance cue's templates, its lifecycle counters, the total
similarity that C's adaptive fusion reads the next frame, and where a candidate last
supported it.  :class:`TrackStore` keeps the live tracks in birth order (an older track
comes first, which is how duplicates are told apart) and the memory of the lost ones
(:class:`LostTrack`) that a newborn track may take back by re-identification.  Births,
deaths, losses and re-identification are operations on the store; nothing is matched by list
position.  What to do each frame is decided elsewhere (:mod:`~belief_tracking.tracks`,
:mod:`~belief_tracking.lifecycle`).

Examples
--------
>>> store = TrackStore()
>>> for track_id in (3, 5):
...     _ = store.add(Track.born(track_id, (10.0 * track_id, 20.0, 8.0, 16.0), np.zeros((4, 5)), {}))
>>> store.ids, len(store), 5 in store
([3, 5], 2, True)
>>> lost = store.lose(3, frame=7)
>>> store.ids, sorted(store.lost), lost.box.tolist()
([5], [3], [30.0, 20.0, 8.0, 16.0])
>>> store.reidentify(5, 3).id, store.ids, store.lost
(3, [3], {})
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field

import numpy as np

from .adaptive import AdaptiveConfig
from .errors import InitError, TrackingError
from .particles import CX, CY, LOG_SCALE, VX, VY, ParticleSet

__all__ = ["Life", "Track", "LostTrack", "TrackStore"]


@dataclass
class Life:
    """A track's lifecycle counters, updated once a frame by :class:`~belief_tracking.lifecycle.Lifecycle`.

    Attributes
    ----------
    age : int
        Frames the track has gone through the lifecycle since its birth.
    hits : int
        Of those, the frames in which it took a candidate (a detection or a person blob).
    unsupported : int
        Consecutive frames without support (no candidate, no foreground, no likeness).
    leaving : int
        Consecutive unsupported frames with the centre in the border zone.
    twins : int
        Consecutive frames overlapping an older track as its duplicate.
    """

    age: int = 0
    hits: int = 0
    unsupported: int = 0
    leaving: int = 0
    twins: int = 0


@dataclass(eq=False)
class Track:
    """Everything about one target.

    Attributes
    ----------
    id : int
        The track id, stable for the track's life (a re-identified track takes back a lost id).
    particles : ParticleSet
        Its particles and log-weights (W (5)).
    estimate : ndarray, shape (5,)
        The estimated state of the last frame (W (6)): cx, cy, vx, vy, log_scale.
    size : ndarray, shape (2,)
        Base window size ``w, h``; a particle's window is size × exp(log_scale).
    birth_cy : float
        Centre row of the birth box, the reference row of the perspective scale.
    templates : dict of str to ndarray, each shape (B,)
        The current appearance template of each appearance cue, by cue name.
    initial_templates : dict of str to ndarray, each shape (B,)
        The templates as built at birth, q_init of C (16).
    similarity : float
        The total similarity ρ_{t−1} of C (15) that C's adaptive fusion reads next (C (14)).
    life : Life
        The lifecycle counters.
    last_frame : int or None
        The plan's last frame of a planned target (None: until the initiation ends it).
    planned : bool
        Whether the user gave this target (always output, even while unsupported).
    last_seen : (int, ndarray) or None
        The frame and box ``x, y, w, h`` of the last candidate that supported the track.
    """

    id: int
    particles: ParticleSet
    estimate: np.ndarray
    size: np.ndarray
    birth_cy: float
    templates: dict[str, np.ndarray]
    initial_templates: dict[str, np.ndarray]
    similarity: float = AdaptiveConfig.rho0
    life: Life = field(default_factory=Life)
    last_frame: int | None = None
    planned: bool = False
    last_seen: tuple[int, np.ndarray] | None = None

    @classmethod
    def born(cls, track_id: int, box, states: np.ndarray, templates: Mapping[str, np.ndarray], *,
             similarity: float = AdaptiveConfig.rho0, last_frame: int | None = None, planned: bool = False) -> Track:
        """A new track at ``box`` ``x, y, w, h``, its particles ``states`` (N, 5) uniformly weighted (W-S1).

        ``templates`` become both its current and its initial templates; the estimate is the
        box centre at rest.
        """
        x, y, w, h = (float(v) for v in box)
        centre = (x + w / 2.0, y + h / 2.0)
        return cls(int(track_id), ParticleSet(states), np.array([centre[0], centre[1], 0.0, 0.0, 0.0]),
                   np.array([w, h]), centre[1], dict(templates), {name: t.copy() for name, t in templates.items()},
                   similarity=similarity, last_frame=last_frame, planned=planned)

    def scale(self, state: np.ndarray | None = None) -> float:
        """exp(log_scale) of ``state`` (default: the estimate): its window is the base size times this."""
        state = self.estimate if state is None else state
        return math.exp(min(max(float(state[LOG_SCALE]), -30.0), 30.0))

    def box(self, state: np.ndarray | None = None) -> tuple[float, float, float, float]:
        """The window ``x, y, w, h`` of ``state`` (default: the estimate), in 0-based pixels."""
        state = self.estimate if state is None else state
        w, h = self.size * self.scale(state)
        return (float(state[CX] - w / 2.0), float(state[CY] - h / 2.0), float(w), float(h))

    def predicted_box(self, dt: float) -> np.ndarray:
        """The window moved on by the estimated velocity for ``dt`` frames, shape (4,)."""
        box = np.array(self.box())
        box[:2] += dt * self.estimate[[VX, VY]]
        return box


@dataclass(frozen=True)
class LostTrack:
    """What a lost track looked like, and where and when a candidate last supported it.

    Attributes
    ----------
    id : int
    frame : int
        The frame it was last seen (supported by a candidate), else the frame it was lost.
    box : ndarray, shape (4,)
        Its box then.
    velocity : ndarray, shape (2,)
        Its estimated velocity when lost.
    templates : dict of str to ndarray
        Its current templates when lost.
    planned : bool
        Whether the user gave it.
    """

    id: int
    frame: int
    box: np.ndarray
    velocity: np.ndarray
    templates: dict[str, np.ndarray]
    planned: bool = False


class TrackStore:
    """The live tracks by id, in birth order, and the memory of the lost ones.

    Attributes
    ----------
    lost : dict of int to LostTrack
        The lost tracks that can still be re-identified, by id.
    """

    def __init__(self) -> None:
        self._live: dict[int, Track] = {}
        self.lost: dict[int, LostTrack] = {}

    def __len__(self) -> int:
        return len(self._live)

    def __bool__(self) -> bool:
        return bool(self._live)

    def __contains__(self, track_id: object) -> bool:
        return track_id in self._live

    def __iter__(self) -> Iterator[Track]:
        return iter(list(self._live.values()))

    def __getitem__(self, track_id: int) -> Track:
        try:
            return self._live[track_id]
        except KeyError:
            raise TrackingError(f"no live track {track_id!r}") from None

    @property
    def tracks(self) -> list[Track]:
        """The live tracks, oldest first."""
        return list(self._live.values())

    @property
    def ids(self) -> list[int]:
        """The live tracks' ids, oldest first."""
        return list(self._live)

    def add(self, track: Track) -> Track:
        """Start keeping ``track`` (the youngest); an id already live is refused."""
        if track.id in self._live:
            raise InitError(f"target {track.id} is already being tracked")
        self._live[track.id] = track
        return track

    def remove(self, track_id: int) -> Track:
        """Stop tracking ``track_id`` (a death); returns its record."""
        track = self[track_id]
        del self._live[track_id]
        return track

    def lose(self, track_id: int, frame: int) -> LostTrack:
        """Stop tracking ``track_id`` but remember it for re-identification; returns the memory."""
        track = self.remove(track_id)
        # Where a candidate last supported the track: after that the particles only guessed.
        seen, box = track.last_seen if track.last_seen is not None else (frame, np.array(track.box()))
        lost = LostTrack(track.id, seen, box, track.estimate[[VX, VY]].copy(),
                         {name: np.array(t) for name, t in track.templates.items()}, track.planned)
        self.lost[track_id] = lost
        return lost

    def forget(self, frame: int, memory: int) -> None:
        """Drop the lost tracks last seen more than ``memory`` frames before ``frame``."""
        for track_id in [i for i, lost in self.lost.items() if frame - lost.frame > memory]:
            del self.lost[track_id]

    def reidentify(self, track_id: int, lost_id: int) -> Track:
        """Give live track ``track_id`` the id of lost track ``lost_id``, which is forgotten; returns the track.

        The track keeps its place in the birth order.
        """
        lost = self.lost.pop(lost_id)
        track = self[track_id]
        track.id = lost.id
        track.planned = lost.planned
        self._live = {(lost.id if key == track_id else key): value for key, value in self._live.items()}
        return track
