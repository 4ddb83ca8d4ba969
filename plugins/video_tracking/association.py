"""Which candidate box belongs to which track: a one-to-one assignment on box overlap.

A frame's *candidates* are the boxes a detector gives (or, without a detector, the person
blobs of the foreground mask).  Each track may take at most one candidate and each
candidate may go to at most one track, and pairs that overlap less than a gate are never
matched.  Among all such matchings :func:`assign` takes the one that maximises the number
of pairs plus their total overlap, k + Σ IoU: a linear assignment on the cost 1 − IoU (the
Hungarian method, as in SORT, solved here by :func:`min_cost_assignment`).  One more pair above the
gate is worth more than any gain of overlap, so as many tracks as can be are supported.
Given how much each candidate's window looks like each track (``likeness``), a pair scores
IoU + w·ρ instead, as appearance-aware trackers (DeepSORT) weigh motion and appearance: of
two people standing close together, whose tracks both overlap the one detection, the one it
shows takes it.  A track with no candidate is *unsupported* this frame, and a candidate
that no track takes may start a new one.
"""

from __future__ import annotations

import math

import numpy as np

from collections.abc import Sequence

from . import checks
from .boxes import check_boxes, intersections, iou
from .cues import Observation, template_similarity
from .errors import TrackingError
from .initiation import COVERED_FRACTION, InitiationConfig
from .particles import CX, CY, STATE_DIM

__all__ = ["assign", "contested_pairs", "min_cost_assignment", "take_covering", "UNASSIGNED", "Association"]

#: The assignment of a track that takes no candidate.
UNASSIGNED = -1


def assign(tracks, candidates, min_iou: float = 0.3, likeness=None, appearance_weight: float = 0.0) -> np.ndarray:
    """The candidate of each track under the one-to-one matching of largest k + Σ (IoU + w·ρ).

    Parameters
    ----------
    tracks : array_like, shape (τ, 4)
        The tracks' boxes ``x, y, w, h`` (their predictions for this frame).
    candidates : array_like, shape (n, 4) or (n, 5)
        The candidate boxes ``x, y, w, h`` (a fifth column, a score, is ignored).
    min_iou : float in (0, 1]
        The gate: a pair that overlaps less is never matched.
    likeness : array_like, shape (τ, n), optional
        ρ in [0, 1], how much candidate k's window looks like track j (the Bhattacharyya
        coefficient with its templates); without it the score is the overlap alone.
    appearance_weight : float >= 0
        w, the weight of ρ in a pair's score IoU + w·ρ (0: the overlap alone).

    Returns
    -------
    ndarray of int, shape (τ,)
        The row of ``candidates`` taken by each track, or :data:`UNASSIGNED` (−1).

    Raises
    ------
    TrackingError
        Boxes that are not finite (n, 4) arrays with positive sizes, a gate outside (0, 1],
        a likeness that is not a (τ, n) array of values in [0, 1], or a negative weight.

    Examples
    --------
    Two tracks and three candidates: track 0 takes the second candidate, which it overlaps
    most; the first overlaps track 1 too little for the gate of 0.3, and the third is free.

    >>> tracks = [[0, 0, 10, 20], [30, 0, 10, 20]]
    >>> candidates = [[6, 0, 10, 20], [1, 0, 10, 20], [100, 0, 10, 20]]
    >>> assign(tracks, candidates).tolist()
    [1, -1]
    >>> assign(tracks, [[31, 1, 10, 20]]).tolist()
    [-1, 0]

    Two tracks overlap one detection, the first a little more; the detection looks like the
    second track's person, and with appearance it goes to that track:

    >>> two = [[0, 0, 10, 20], [3, 0, 10, 20]]
    >>> assign(two, [[1, 0, 10, 20]]).tolist()
    [0, -1]
    >>> assign(two, [[1, 0, 10, 20]], likeness=[[0.4], [0.9]], appearance_weight=0.75).tolist()
    [-1, 0]
    """
    tracks, candidates, min_iou = _gated_boxes(tracks, candidates, min_iou)
    appearance_weight = checks.number("appearance_weight", appearance_weight, minimum=0.0)
    if likeness is not None:
        likeness = np.asarray(likeness, dtype=np.float64)
        if likeness.shape != (len(tracks), len(candidates)) or not ((likeness >= 0) & (likeness <= 1)).all():
            raise TrackingError(f"likeness must be a ({len(tracks)}, {len(candidates)}) array of values in [0, 1], "
                                f"got shape {likeness.shape}")
    result = np.full(len(tracks), UNASSIGNED, dtype=np.intp)
    if len(tracks) == 0 or len(candidates) == 0:
        return result
    overlap = iou(tracks, candidates)
    allowed = overlap >= min_iou
    weight = float(appearance_weight) if likeness is not None else 0.0
    score = overlap + weight * likeness if weight else overlap
    # Pairs below the gate cost more than any pair above it, so the solver never prefers
    # them; they are dropped after the solve.
    cost = np.where(allowed, (1.0 + weight) - score, 2.0 * (1.0 + weight))
    rows, cols = min_cost_assignment(cost)
    kept = allowed[rows, cols]
    result[rows[kept]] = cols[kept]
    return result


def contested_pairs(tracks, candidates, min_iou: float = 0.3) -> tuple[np.ndarray, np.ndarray]:
    """The (track, candidate) pairs within the gate where the scores can change :func:`assign`'s matching.

    Where no track has two candidates within the gate and no candidate two tracks, every
    such pair is matched whatever its score, so a likeness is needed nowhere and both
    arrays are empty; otherwise every pair within the gate is returned.

    Parameters
    ----------
    tracks : ndarray, shape (τ, 4)
    candidates : ndarray, shape (n, 4) or (n, 5)
    min_iou : float in (0, 1]

    Returns
    -------
    rows, cols : ndarray of int
        Track and candidate of each pair.

    Raises
    ------
    TrackingError
        As :func:`assign`, for boxes that are not finite (n, 4) arrays with positive sizes
        or a gate outside (0, 1].

    Examples
    --------
    >>> contested_pairs(np.array([[0, 0, 10, 20], [3, 0, 10, 20]]), np.array([[1, 0, 10, 20]]))
    (array([0, 1]), array([0, 0]))
    >>> contested_pairs(np.array([[0, 0, 10, 20]]), np.array([[1, 0, 10, 20], [50, 0, 10, 20]]))
    (array([], dtype=int64), array([], dtype=int64))
    """
    tracks, candidates, min_iou = _gated_boxes(tracks, candidates, min_iou)
    within = iou(tracks, candidates) >= min_iou
    if (within.sum(axis=0) <= 1).all() and (within.sum(axis=1) <= 1).all():
        return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
    return np.nonzero(within)


def _gated_boxes(tracks, candidates, min_iou) -> tuple[np.ndarray, np.ndarray, float]:
    """The tracks (τ, 4), the candidates' boxes (n, 4) and the gate, checked."""
    min_iou = checks.fraction("min_iou", min_iou, allow_zero=False)
    tracks = check_boxes(tracks, "track boxes").reshape(-1, 4)
    candidates = np.asarray(candidates, dtype=np.float64)
    candidates = check_boxes(candidates[:, :4] if candidates.ndim == 2 else candidates,
                             "candidate boxes").reshape(-1, 4)
    return tracks, candidates, min_iou


def min_cost_assignment(cost) -> tuple[np.ndarray, np.ndarray]:
    """The one-to-one pairing of rows and columns of least total cost (the Hungarian method).

    Every row is paired when there are no more rows than columns, and every column
    otherwise.  The solver is the shortest-augmenting-path form of the Hungarian method with
    row and column potentials, O(n² m) for n ≤ m; a frame's handful of tracks and candidates
    is solved in microseconds, with no solver library to load.

    Parameters
    ----------
    cost : array_like, shape (n, m)
        Finite costs.

    Returns
    -------
    rows, cols : ndarray of int, shape (min(n, m),)
        The pairs ``(rows[i], cols[i])``, rows in increasing order.

    Examples
    --------
    >>> rows, cols = min_cost_assignment([[4, 1, 3], [2, 0, 5], [3, 2, 2]])
    >>> rows.tolist(), cols.tolist()
    ([0, 1, 2], [1, 0, 2])
    >>> min_cost_assignment([[1.0], [0.5]])[0].tolist()
    [1]
    """
    cost = np.asarray(cost, dtype=np.float64)
    if cost.ndim != 2 or not np.isfinite(cost).all():
        raise TrackingError(f"an assignment needs a finite 2-D cost matrix, got shape {cost.shape}")
    transposed = cost.shape[0] > cost.shape[1]
    if transposed:
        cost = cost.T
    n, m = cost.shape
    if n == 0:
        empty = np.zeros(0, dtype=np.intp)
        return empty, empty
    # Plain Python lists: for the few rows of a frame they are ten times faster than numpy
    # calls.  Index 0 of the column lists is a virtual column holding the row being inserted.
    rows_cost = cost.tolist()
    row_potential = [0.0] * (n + 1)
    column_potential = [0.0] * (m + 1)
    row_of_column = [0] * (m + 1)                   # 1-based rows; 0 = a free column
    previous = [0] * (m + 1)
    for row in range(1, n + 1):
        row_of_column[0] = row
        column = 0
        slack = [math.inf] * (m + 1)
        used = [False] * (m + 1)
        while True:
            used[column] = True
            current = row_of_column[column]
            costs, potential = rows_cost[current - 1], row_potential[current]
            delta, following = math.inf, 0
            for j in range(1, m + 1):
                if not used[j]:
                    reduced = costs[j - 1] - potential - column_potential[j]
                    if reduced < slack[j]:
                        slack[j], previous[j] = reduced, column
                    if slack[j] < delta:
                        delta, following = slack[j], j
            for j in range(m + 1):
                if used[j]:
                    row_potential[row_of_column[j]] += delta
                    column_potential[j] -= delta
                else:
                    slack[j] -= delta
            column = following
            if row_of_column[column] == 0:
                break
        while column:
            before = previous[column]
            row_of_column[column] = row_of_column[before]
            column = before
    row_of_column = np.asarray(row_of_column)
    columns = np.flatnonzero(row_of_column[1:])
    rows = row_of_column[1:][columns] - 1
    if transposed:
        rows, columns = columns, rows
    order = np.argsort(rows)
    return rows[order].astype(np.intp), columns[order].astype(np.intp)


class Association:
    """The association stage: the candidate each track takes this frame, −1 for none (:func:`assign`).

    Detections are weighed by appearance too (``InitiationConfig.appearance_weight``): ρ of
    the window of each track's size at each detection's centre with the track's templates,
    formed only for :func:`contested_pairs`, where it can change the matching.  Foreground
    blobs go by overlap alone.

    Parameters
    ----------
    initiation : InitiationConfig or None
        The gate ``match_iou`` and ``appearance_weight`` (without an initiation: a gate of
        0.3 and overlap alone).
    appearance_cues : sequence of AppearanceCue
        The cues whose templates the likeness reads.

    Examples
    --------
    >>> association = Association(InitiationConfig(), [])
    >>> obs = Observation(np.zeros((40, 60, 3), np.uint8), None, [[15.0, 20.0]], [[10.0, 20.0]], np.zeros((0, 2)))
    >>> association(obs, np.array([[10.0, 10, 10, 20]]), np.array([[40.0, 10, 10, 20, 1], [11.0, 10, 10, 20, 1]]),
    ...             detector=True).tolist()
    [1]
    """

    def __init__(self, initiation: InitiationConfig | None, appearance_cues: Sequence) -> None:
        self.gate = initiation.match_iou if initiation is not None else 0.3
        self.weight = initiation.appearance_weight if initiation is not None else 0.0
        self.appearance_cues = list(appearance_cues)
        # Where the plan gives every birth (births=False), every person is a planned track's.
        self.planned_only = initiation is not None and not initiation.births

    def __call__(self, obs: Observation, predicted: np.ndarray, candidates: np.ndarray | None,
                 detector: bool) -> np.ndarray | None:
        """The candidate row each track takes, shape (τ,); None without candidates.

        Parameters
        ----------
        obs : Observation
            The frame, with the tracks' templates.
        predicted : ndarray, shape (τ, 4)
            Each track's box moved on by its velocity.
        candidates : ndarray, shape (n, 5), or None
            ``x, y, w, h, score``.
        detector : bool
            Whether the candidates are detections (weighed by appearance) or blobs.
        """
        if candidates is None:
            return None
        assigned = self._matched(obs, predicted, candidates, detector)
        return take_covering(predicted, candidates, assigned) if self.planned_only else assigned

    def _matched(self, obs: Observation, predicted: np.ndarray, candidates: np.ndarray, detector: bool) -> np.ndarray:
        """:func:`assign` by overlap, and for contested detections by appearance too."""
        if not (detector and self.weight > 0 and self.appearance_cues and len(candidates)):
            return assign(predicted, candidates, self.gate)
        rows, cols = contested_pairs(predicted, candidates, self.gate)
        if not rows.size:
            return assign(predicted, candidates, self.gate)
        states = np.zeros((rows.size, STATE_DIM))
        states[:, CX] = candidates[cols, 0] + candidates[cols, 2] / 2.0
        states[:, CY] = candidates[cols, 1] + candidates[cols, 3] / 2.0
        likeness = np.zeros((len(predicted), len(candidates)))
        likeness[rows, cols] = np.clip(template_similarity(self.appearance_cues, obs, states, rows), 0.0, 1.0)
        return assign(predicted, candidates, self.gate, likeness, self.weight)


def take_covering(predicted: np.ndarray, candidates: np.ndarray, assigned: np.ndarray) -> np.ndarray:
    """Where the plan knows every person: a free candidate that holds one track's box alone goes to that track.

    The overlap gate of the assignment keeps a track far smaller than its person (born at the
    image border, where the first box is a sliver of the person coming in) from every
    candidate of that person.  A candidate that no track took and that holds at least
    :data:`~belief_tracking.initiation.COVERED_FRACTION` of one unassigned track's box, and
    that much of no other track's box, is that track's person (a candidate holding two
    tracks' boxes may be a group, and goes to neither).

    Shapes: ``predicted`` (τ, 4), ``candidates`` (n, 5), ``assigned`` and the result (τ,).

    Examples
    --------
    >>> predicted = np.array([[0.0, 0, 4, 10], [50.0, 0, 10, 20]])    # a sliver of a person entering at x = 0
    >>> candidates = np.array([[0.0, 0, 12, 30, 1], [50.0, 0, 10, 20, 1]])
    >>> take_covering(predicted, candidates, np.array([-1, 1])).tolist()
    [0, 1]
    """
    if not len(candidates) or (assigned != UNASSIGNED).all():
        return assigned
    boxes = np.asarray(candidates, dtype=np.float64)[:, :4]
    inside = intersections(predicted, boxes) >= COVERED_FRACTION * (predicted[:, 2] * predicted[:, 3])[:, None]
    free = np.ones(len(boxes), dtype=bool)
    free[assigned[assigned != UNASSIGNED]] = False
    assigned = assigned.copy()
    for k in np.flatnonzero(free & (inside.sum(axis=0) == 1)):
        track = int(np.flatnonzero(inside[:, k])[0])
        if assigned[track] == UNASSIGNED:
            assigned[track] = k
    return assigned
