"""Births, losses and deaths of automatic tracks, from each frame's candidate boxes.

A frame's *candidates* are a detector's boxes, or the person blobs of the foreground mask
when there is no detector.  Before the cues score the particles, every track takes at most
one candidate (:func:`~belief_tracking.association.assign`); :class:`Lifecycle`
then reads the outcome:

* A track that took a candidate is *supported*; so is a track whose window still looks
  like its appearance templates (``appearance_support``), and, without a detector, a track
  whose box still holds foreground (a person standing among others, whose blob merged
  with theirs).  A track unsupported for ``lost_frames`` consecutive frames is *lost*: it is no
  longer output, and the tracker keeps what it looked like for ``memory`` frames.
* A track whose centre is in the border zone (or outside the image) while unsupported for
  ``exit_frames`` frames has left the image and ends.  Of two tracks that overlap with IoU
  at least ``duplicate_iou`` for ``duplicate_frames`` frames, the younger ends.
* A candidate that no track took and that no track box covers starts a *chain*; a chain
  continues with the best-overlapping free candidate of the next frame (IoU at least
  ``match_iou``), and one that lasts ``appear_frames`` frames is born.  Chains start
  anywhere in the image (``anywhere``) or only in the border zone (SPEC B.4 as printed).
  On the first frame every free candidate is born at once (``first_frame``).

Each track's counters live in its record (:class:`~belief_tracking.store.Life`, in
:class:`~belief_tracking.store.Track`); :class:`Lifecycle` updates them and keeps only the
chains, which belong to no track yet.  Taking back a lost id by appearance is the
:class:`~belief_tracking.tracks.TrackManager`'s.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from collections.abc import Sequence

from .association import UNASSIGNED
from .boxes import box_centres, intersections, iou
from .initiation import COVERED_FRACTION, InitiationConfig, foreground_fraction
from .store import Life

__all__ = ["Lifecycle", "FrameOutcome", "DUPLICATE_INSIDE"]

#: A track whose box lies this much inside an older track's box counts as its duplicate.
DUPLICATE_INSIDE = 0.7


class FrameOutcome(NamedTuple):
    """What :meth:`Lifecycle.update` decided for one frame.

    Attributes
    ----------
    births : ndarray, shape (k, 4)
        Boxes of the chains that are born.
    lost : list of int
        The tracks that are lost this frame (no longer output; remembered), as positions in
        the ``lives`` given to :meth:`Lifecycle.update`.
    ended : list of int
        The tracks that end this frame (left the image, or duplicates), likewise.
    """

    births: np.ndarray
    lost: list[int]
    ended: list[int]


class Lifecycle:
    """The counters of the live tracks and the chains of candidates that may become tracks.

    Parameters
    ----------
    config : InitiationConfig
    image_shape : (int, int)
        (H, W) of the frames.

    Examples
    --------
    A candidate seen on three consecutive frames is born; the track then misses its
    candidate and is lost after ``lost_frames`` frames:

    >>> lifecycle = Lifecycle(InitiationConfig(appear_frames=3, lost_frames=2, first_frame=False), (100, 100))
    >>> none = np.zeros(0, np.intp)
    >>> for x in (40, 41, 42):
    ...     outcome = lifecycle.update([], np.zeros((0, 4)), none, np.array([[x, 30, 10, 20, 0.9]]))
    >>> outcome.births.tolist()
    [[42.0, 30.0, 10.0, 20.0]]
    >>> life, box = Life(), np.array([[43.0, 30, 10, 20]])
    >>> lifecycle.update([life], box, np.array([-1]), np.zeros((0, 5))).lost, life
    ([], Life(age=1, hits=0, unsupported=1, leaving=0, twins=0))
    >>> lifecycle.update([life], box, np.array([-1]), np.zeros((0, 5))).lost      # the track at position 0
    [0]
    """

    def __init__(self, config: InitiationConfig, image_shape: tuple[int, int]) -> None:
        self.config = config
        self.image_shape = (int(image_shape[0]), int(image_shape[1]))
        self._frames = 0
        self._chains = np.zeros((0, 4))
        self._chain_lengths = np.zeros(0, dtype=np.intp)

    @property
    def chains(self) -> list[tuple[tuple[float, ...], int]]:
        """The chains after the last frame: ``(last box, frames seen)``."""
        return [(tuple(float(v) for v in box), int(n)) for box, n in zip(self._chains, self._chain_lengths)]

    def in_border_zone(self, boxes: np.ndarray) -> np.ndarray:
        """Whether any pixel of each box ``(x, y, w, h)`` lies within ``border`` px of an image edge."""
        height, width = self.image_shape
        b = self.config.border
        boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
        return ((boxes[:, 0] < b) | (boxes[:, 1] < b)
                | (boxes[:, 0] + boxes[:, 2] > width - b) | (boxes[:, 1] + boxes[:, 3] > height - b))

    def update(self, lives: Sequence[Life], boxes: np.ndarray, assigned: np.ndarray, candidates: np.ndarray,
               foreground: np.ndarray | None = None, births_allowed: bool = True,
               likeness: np.ndarray | None = None) -> FrameOutcome:
        """Read one frame.

        Parameters
        ----------
        lives : sequence of Life
            The counters of the live tracks, in increasing age (an older track comes
            first); those of the tracks that go on are updated in place.
        boxes : ndarray, shape (τ, 4)
            Their boxes in this frame.
        assigned : ndarray of int, shape (τ,)
            The candidate each track took (−1: none).
        candidates : ndarray, shape (n, 4) or (n, 5)
            The frame's candidate boxes (a score column is ignored here).
        foreground : ndarray of bool, shape (H, W), optional
            Without a detector, the foreground mask: a track box whose foreground fraction
            is at least ``exit_foreground`` counts as supported.
        births_allowed : bool
            False on frames whose candidates cannot be trusted (a lighting change): no chain
            grows or is born.
        likeness : ndarray, shape (τ,), optional
            How much each track's window looks like its appearance templates (the
            Bhattacharyya coefficient ρ); ρ ≥ ``appearance_support`` supports the track.
            NaN for a track that took a candidate: the candidate supports it.

        Returns
        -------
        FrameOutcome
        """
        config = self.config
        first = self._frames == 0
        self._frames += 1
        boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
        candidates = np.asarray(candidates, dtype=np.float64)
        candidates = candidates[:, :4] if candidates.ndim == 2 else candidates.reshape(-1, 4)
        assigned = np.asarray(assigned)
        took = assigned != UNASSIGNED
        supported = took.copy()
        # Foreground and appearance support a track only where no other track took a
        # candidate: a second track on someone already followed sees their pixels too.
        own = ~self._covered_by(boxes, took)
        if foreground is not None and len(boxes):
            supported |= own & (foreground_fraction(foreground, boxes) >= config.exit_foreground)
        if likeness is not None and config.appearance_support is not None and len(boxes):
            supported |= own & (np.asarray(likeness) >= config.appearance_support)
        lost, ended = self._count(lives, boxes, supported, took)

        taken = np.zeros(len(candidates), dtype=bool)
        taken[assigned[took]] = True
        live = np.ones(len(lives), dtype=bool)
        live[lost + ended] = False
        free = ~taken & ~self._covered(candidates, boxes[live])
        if not births_allowed:
            self._chains = np.zeros((0, 4))
            self._chain_lengths = np.zeros(0, dtype=np.intp)
            births = np.zeros((0, 4))
        elif first and config.first_frame:
            births = candidates[free]
        else:
            if not config.anywhere:
                free &= self.in_border_zone(candidates)
            births = self._grow_chains(candidates[free])
        return FrameOutcome(births, lost, ended)

    # -- steps ----------------------------------------------------------------------------------
    def _count(self, lives: Sequence[Life], boxes: np.ndarray, supported: np.ndarray,
               took: np.ndarray) -> tuple[list[int], list[int]]:
        """Update the counters of the tracks that go on; the positions of those lost and of those ended."""
        config = self.config
        height, width = self.image_shape
        b = config.border
        centres = box_centres(boxes) if len(boxes) else np.zeros((0, 2))
        at_border = (centres[:, 0] < b) | (centres[:, 0] >= width - b) | (centres[:, 1] < b) \
            | (centres[:, 1] >= height - b)
        duplicate = self._duplicates(boxes)
        lost, ended = [], []
        for k, life in enumerate(lives):
            missed = 0 if supported[k] else life.unsupported + 1
            out = life.leaving + 1 if at_border[k] and not supported[k] else 0
            twin = life.twins + 1 if duplicate[k] else 0
            # Without births of its own (births=False) the plan says when a track ends.
            if config.births and (out >= config.exit_frames or (config.duplicate_frames is not None
                                                                and twin >= config.duplicate_frames)):
                ended.append(k)
            elif config.lost_frames is not None and missed >= config.lost_frames:
                lost.append(k)
            else:
                life.unsupported, life.leaving, life.twins = missed, out, twin
                life.age += 1
                life.hits += int(took[k])
        return lost, ended

    def _duplicates(self, boxes: np.ndarray) -> np.ndarray:
        """Whether each box follows the same person as an older track's box, shape (τ,)."""
        if not len(boxes):
            return np.zeros(0, dtype=bool)
        overlaps = iou(boxes, boxes)
        # A box mostly inside an older track's box follows the same person as much as one
        # that overlaps it by IoU: a fragment (legs, a head) of someone already followed.
        inside = intersections(boxes, boxes) / np.maximum(boxes[:, 2] * boxes[:, 3], 1e-12)[:, None]
        twin = (overlaps >= self.config.duplicate_iou) | (inside >= DUPLICATE_INSIDE)
        return np.array([twin[k, :k].any() for k in range(len(boxes))], dtype=bool)

    @staticmethod
    def _covered_by(boxes: np.ndarray, took: np.ndarray) -> np.ndarray:
        """Whether at least half of each box lies in the box of another track that took a candidate."""
        if len(boxes) < 2 or not took.any():
            return np.zeros(len(boxes), dtype=bool)
        inside = intersections(boxes, boxes[took])
        others = np.flatnonzero(took)
        inside[others, np.arange(len(others))] = 0.0          # a track does not cover itself
        return (inside >= COVERED_FRACTION * (boxes[:, 2] * boxes[:, 3])[:, None]).any(axis=1)

    def _covered(self, candidates: np.ndarray, boxes: np.ndarray) -> np.ndarray:
        """Whether each candidate overlaps a track box enough to belong to it (``max_iou``, or mostly inside)."""
        if len(boxes) == 0 or len(candidates) == 0:
            return np.zeros(len(candidates), dtype=bool)
        overlap = iou(candidates, boxes) >= self.config.max_iou
        inside = intersections(candidates, boxes) >= COVERED_FRACTION * (candidates[:, 2] * candidates[:, 3])[:, None]
        return (overlap | inside).any(axis=1)

    def _grow_chains(self, free: np.ndarray) -> np.ndarray:
        """Continue the chains with this frame's free candidates; return the boxes of those born."""
        lengths = np.ones(len(free), dtype=np.intp)
        previous, previous_lengths = self._chains, self._chain_lengths
        if len(free) and len(previous):
            overlaps = iou(free, previous)
            rows, cols = np.nonzero(overlaps >= self.config.match_iou)
            order = np.argsort(-overlaps[rows, cols], kind="stable")
            free_taken = np.zeros(len(free), dtype=bool)
            previous_taken = np.zeros(len(previous), dtype=bool)
            for k in order:
                i, j = rows[k], cols[k]
                if not free_taken[i] and not previous_taken[j]:
                    free_taken[i] = previous_taken[j] = True
                    lengths[i] = previous_lengths[j] + 1
        born = lengths >= self.config.appear_frames
        self._chains = free[~born]
        self._chain_lengths = lengths[~born]
        return free[born]
