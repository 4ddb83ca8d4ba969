"""Scoring tracks against ground truth: CLEAR MOT (MOTA, MOTP), IDF1, HOTA, centre errors and identity swaps.

Tracks and ground truth are MOTChallenge rows (read by
:func:`~belief_tracking.motfiles.read_mot`): one box per row,
``frame,id,x,y,w,h,flag,...`` with the box's top-left corner ``(x, y)`` and size ``(w, h)``
in pixels.  :func:`evaluate` follows the usual MOTChallenge protocol:

* a hypothesis box and a ground-truth box may be paired only if their intersection over
  union (IoU) is at least 0.5 (:func:`iou_distance`);
* ground-truth rows whose flag (7th column) is 0 are not scored: in each frame the
  hypotheses are first matched (Hungarian algorithm on the IoU distance) against *all*
  ground-truth boxes, those matched to a flag-0 box are dropped, and the remaining
  hypotheses are scored against the flagged-in ground truth only;
* the frame-by-frame correspondences, identity switches, misses and false positives are
  those of ``motmetrics.MOTAccumulator``, and the summary numbers come from
  ``motmetrics.metrics``;
* HOTA and its parts (DetA, AssA, LocA, DetRe, DetPr, AssRe, AssPr) are TrackEval's, means over
  the IoU thresholds α = 0.05, …, 0.95 (:mod:`~belief_tracking.hota`): flag-0 rows are not
  scored there either, but, as in TrackEval with every row a pedestrian, the hypotheses on
  them are kept (they count as false positives of HOTA).

The IoU distances are computed here, not with ``motmetrics.distances.iou_matrix``: the
released motmetrics 1.4.0 calls ``np.asfarray``, which NumPy 2 removed.

:func:`identity_swaps` counts the frames in which a ground-truth target, paired with a track
by the same matching, is followed by a track that is not the target's own.

``motmetrics`` (and with it pandas) is imported only when a score is computed, so that
the ``belief`` command line starts without it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields
from typing import Any, NamedTuple

import numpy as np

from .boxes import check_boxes, checked_iou, iou
from .errors import TrackingError
from .extras import require
from .hota import HOTA_FIELDS, hota
from .motfiles import MAX_COORDINATE, MAX_FRAME

__all__ = [
    "Scores",
    "matched_pairs",
    "iou_distance",
    "evaluate",
    "IdentitySwaps",
    "identity_swaps",
]

_FRAME, _ID, _X, _Y, _W, _H, _FLAG = range(7)
_MIN_FIELDS, _MAX_FIELDS = 6, 10


# -- IoU distances ---------------------------------------------------------------------------------
def _boxes(boxes: Any, what: str) -> np.ndarray:
    return check_boxes(boxes, what, positive=False)


def iou_distance(gt_boxes: Any, hyp_boxes: Any, max_iou_distance: float = 0.5) -> np.ndarray:
    """IoU distance ``1 − IoU`` between every ground-truth box and every hypothesis box.

    Pairs whose distance exceeds ``max_iou_distance`` (by default: IoU below 0.5) get NaN,
    which :class:`motmetrics.MOTAccumulator` reads as "may not be paired".  A pair whose
    union has no area (two empty boxes) has IoU 0.  This replaces
    ``motmetrics.distances.iou_matrix``, which fails under NumPy 2, and returns the full
    ``(G, H)`` shape even when ``G`` or ``H`` is 0.

    Parameters
    ----------
    gt_boxes : array_like, shape (G, 4)
        Ground-truth boxes ``x, y, width, height`` (top-left corner and size).
    hyp_boxes : array_like, shape (H, 4)
        Hypothesis boxes, same layout.
    max_iou_distance : float, default 0.5
        Largest distance that still allows a pairing, in [0, 1].

    Returns
    -------
    distance : ndarray of float, shape (G, H)
        ``1 − IoU``, or NaN where ``1 − IoU > max_iou_distance``.

    Raises
    ------
    TrackingError
        Boxes of the wrong shape, not finite or with a negative size, or a threshold
        outside [0, 1].

    Examples
    --------
    >>> gt = [[0, 0, 10, 10], [100, 100, 10, 10]]
    >>> hyp = [[5, 0, 10, 10], [0, 0, 10, 10], [2, 0, 10, 10]]
    >>> iou_distance(gt, hyp)
    array([[       nan, 0.        , 0.33333333],
           [       nan,        nan,        nan]])
    """
    if not 0.0 <= max_iou_distance <= 1.0:
        raise TrackingError(f"max_iou_distance must be in [0, 1], got {max_iou_distance}")
    distance = 1.0 - iou(_boxes(gt_boxes, "ground-truth boxes"), _boxes(hyp_boxes, "hypothesis boxes"))
    distance[distance > max_iou_distance] = np.nan
    return distance


# -- scores ------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Scores:
    """The scores of a set of tracks against ground truth.

    Counts are over all frames.  Ratios with a zero denominator (e.g. MOTP without any
    matched pair) are NaN, and ``None`` in :meth:`to_dict`.

    Attributes
    ----------
    mota : float
        Multiple Object Tracking Accuracy, ``1 − (FN + FP + ID switches) / num_objects``;
        at most 1, may be negative.
    motp : float
        Multiple Object Tracking Precision **as a mean IoU**: the mean IoU of the matched
        pairs, ``1 − motmetrics' motp`` (motmetrics reports the mean IoU *distance*).
        1 is perfect.
    idf1 : float
        Identity F1 score of the global one-to-one id assignment (Ristani et al. 2016).
    hota, deta, assa, loca, detre, detpr, assre, asspr : float
        HOTA (higher-order tracking accuracy, ``sqrt(DetA · AssA)``), detection accuracy,
        association accuracy, localisation accuracy (mean IoU of the true positives),
        detection recall and precision, association recall and precision (Luiten et al.
        2021): each the mean over α = 0.05, 0.10, …, 0.95 of its value at IoU threshold α,
        as TrackEval computes them (:func:`~belief_tracking.hota.hota`).  Scored on the
        flagged-in ground truth and on *every* hypothesis box (``ignored_predictions``
        included, as TrackEval keeps them).  Without any hypothesis all are 0 but LocA,
        which TrackEval sets to 1 where nothing is matched.
    precision, recall : float
        ``matched_pairs / num_predictions`` and ``matched_pairs / num_objects``.
    id_switches : int
        Matches whose hypothesis id differs from the ground-truth object's previous one
        (CLEAR MOT identity switches).
    false_positives, false_negatives : int
        Unmatched hypotheses, and unmatched scored ground-truth boxes (misses).
    matched_pairs : int
        Ground-truth boxes paired with a hypothesis box (including identity switches).
    num_objects : int
        Scored ground-truth boxes (flag not 0).
    num_predictions : int
        Hypothesis boxes that were scored (after dropping ``ignored_predictions``).
    ignored_predictions : int
        Hypothesis boxes dropped because they matched a flag-0 ground-truth box.
    num_frames : int
        Frames with a ground-truth or hypothesis box.
    mean_centre_error, median_centre_error : float
        Euclidean distance in pixels between the centres of the boxes of the matched
        pairs.
    """

    mota: float
    motp: float
    idf1: float
    hota: float
    deta: float
    assa: float
    loca: float
    detre: float
    detpr: float
    assre: float
    asspr: float
    precision: float
    recall: float
    id_switches: int
    false_positives: int
    false_negatives: int
    matched_pairs: int
    num_objects: int
    num_predictions: int
    ignored_predictions: int
    num_frames: int
    mean_centre_error: float
    median_centre_error: float

    def to_dict(self) -> dict[str, float | int | None]:
        """The scores as a JSON-ready dict, in field order; NaN becomes ``None``.

        Returns
        -------
        scores : dict of str to float, int or None

        Examples
        --------
        >>> gt = np.array([[1, 1, 0, 0, 10, 10, 1]])
        >>> evaluate(gt, gt).to_dict()["mota"]
        1.0
        """
        return {name: (None if isinstance(value, float) and math.isnan(value) else value)
                for name, value in asdict(self).items()}

    def format_table(self) -> str:
        """A two-column, human-readable table of the scores.

        Returns
        -------
        table : str
            One line per score (plus a header), without a trailing newline.

        Examples
        --------
        >>> gt = np.array([[1, 1, 0, 0, 10, 10, 1]])
        >>> print(evaluate(gt, gt).format_table())
        metric                                  value
        -------------------------------------  ------
        MOTA                                   1.0000
        MOTP (mean IoU of matches)             1.0000
        IDF1                                   1.0000
        HOTA (higher-order tracking accuracy)  1.0000
        DetA (detection accuracy)              1.0000
        AssA (association accuracy)            1.0000
        LocA (localisation accuracy)           1.0000
        DetRe (detection recall)               1.0000
        DetPr (detection precision)            1.0000
        AssRe (association recall)             1.0000
        AssPr (association precision)          1.0000
        precision                              1.0000
        recall                                 1.0000
        ID switches                                 0
        false positives                             0
        false negatives (misses)                    0
        matched pairs                               1
        ground-truth boxes                          1
        hypothesis boxes                            1
        ignored hypothesis boxes                    0
        frames                                      1
        mean centre error (px)                 0.0000
        median centre error (px)               0.0000
        """
        rows = [(_LABELS[f.name], _format_value(getattr(self, f.name))) for f in fields(self)]
        header = ("metric", "value")
        left = max(len(header[0]), *(len(r[0]) for r in rows))
        right = max(len(header[1]), *(len(r[1]) for r in rows))
        lines = [f"{header[0].ljust(left)}  {header[1].rjust(right)}", f"{'-' * left}  {'-' * right}"]
        lines += [f"{label.ljust(left)}  {value.rjust(right)}" for label, value in rows]
        return "\n".join(lines)


_LABELS = {
    "mota": "MOTA",
    "motp": "MOTP (mean IoU of matches)",
    "idf1": "IDF1",
    "hota": "HOTA (higher-order tracking accuracy)",
    "deta": "DetA (detection accuracy)",
    "assa": "AssA (association accuracy)",
    "loca": "LocA (localisation accuracy)",
    "detre": "DetRe (detection recall)",
    "detpr": "DetPr (detection precision)",
    "assre": "AssRe (association recall)",
    "asspr": "AssPr (association precision)",
    "precision": "precision",
    "recall": "recall",
    "id_switches": "ID switches",
    "false_positives": "false positives",
    "false_negatives": "false negatives (misses)",
    "matched_pairs": "matched pairs",
    "num_objects": "ground-truth boxes",
    "num_predictions": "hypothesis boxes",
    "ignored_predictions": "ignored hypothesis boxes",
    "num_frames": "frames",
    "mean_centre_error": "mean centre error (px)",
    "median_centre_error": "median centre error (px)",
}


def _format_value(value: float | int) -> str:
    if isinstance(value, float):
        return "n/a" if math.isnan(value) else f"{value:.4f}"
    return str(value)


# -- evaluation ---------------------------------------------------------------------------------------
def _track_table(rows: Any, what: str, allow_empty: bool) -> np.ndarray:
    """Validate MOT rows; returns shape (N, 7) with flag 1 where the input has 6 columns."""
    array = np.asarray(rows, dtype=float)
    if array.size == 0:
        if not allow_empty:
            raise TrackingError(f"{what} has no rows")
        return np.zeros((0, 7))
    if array.ndim != 2 or not _MIN_FIELDS <= array.shape[1] <= _MAX_FIELDS:
        raise TrackingError(f"{what} must have shape (n, 6..10) (frame, id, x, y, w, h, flag, ...), "
                            f"got {array.shape}")
    array = array[:, :7] if array.shape[1] >= 7 else np.column_stack([array, np.ones(len(array))])
    if not np.isfinite(array).all():
        raise TrackingError(f"{what} holds a value that is not finite")
    if (array[:, :2] != np.round(array[:, :2])).any():
        raise TrackingError(f"{what} has a frame or id that is not an integer")
    if (np.abs(array[:, :2]) > MAX_FRAME).any():
        raise TrackingError(f"{what} has a frame or id beyond {MAX_FRAME}")
    if (np.abs(array[:, [_X, _Y, _W, _H]]) > MAX_COORDINATE).any():
        raise TrackingError(f"{what} has a box coordinate or size beyond {MAX_COORDINATE:g} pixels")
    if (array[:, [_W, _H]] < 0).any():
        raise TrackingError(f"{what} has a box with a negative width or height")
    # One int64 per (frame, id): a sort of N numbers rather than of N rows.
    keys = array[:, _FRAME].astype(np.int64) * 2**32 + (array[:, _ID].astype(np.int64) + MAX_FRAME)
    if len(np.unique(keys)) != len(array):
        raise TrackingError(f"{what} has the same id twice in one frame")
    return array


def _centres(table: np.ndarray) -> np.ndarray:
    return table[:, [_X, _Y]] + table[:, [_W, _H]] / 2.0


class _Matching(NamedTuple):
    """The CLEAR MOT correspondences of :func:`evaluate`, as ``motmetrics.MOTAccumulator`` makes them.

    ``pairs`` holds one row per MATCH or SWITCH event, in the accumulator's event order:
    frame, gt row, hypothesis row (indices into ``gt_rows`` and ``hyp_rows``), and whether it is a
    switch.  ``overlaps`` counts, per (target id, track id), the frames in which the two may be
    paired (IoU within the threshold): the "true positives" of the IDF1 assignment.
    """

    gt_rows: np.ndarray
    hyp_rows: np.ndarray
    pairs: np.ndarray
    distance_sum: float
    misses: int
    false_positives: int
    num_objects: int
    num_predictions: int
    ignored_predictions: int
    num_frames: int
    object_frames: dict
    track_frames: dict
    overlaps: dict


def _distances(gt_boxes: np.ndarray, hyp_boxes: np.ndarray, max_iou_distance: float) -> np.ndarray:
    """:func:`iou_distance` of boxes already checked (the same floats, without checking every frame again)."""
    distance = 1.0 - checked_iou(gt_boxes, hyp_boxes)
    distance[distance > max_iou_distance] = np.nan
    return distance


def _assignment(distance: np.ndarray, solve) -> tuple[np.ndarray, np.ndarray]:
    """The pairs of finite distance of motmetrics' Hungarian assignment on ``distance`` (NaN: may not pair)."""
    finite = np.isfinite(distance)
    if (finite.sum(axis=0) <= 1).all() and (finite.sum(axis=1) <= 1).all():
        # No row or column has a choice: the assignment takes every finite pair (the solver's
        # forbidden pairs cost more than all finite ones together), in row order as the solver returns them.
        return np.nonzero(finite)
    rows, cols = solve(distance)
    kept = np.isfinite(distance[rows, cols])
    return rows[kept], cols[kept]


def _accumulate(gt: Any, hyp: Any, max_iou_distance: float) -> _Matching:
    """The CLEAR MOT matching of :func:`evaluate`, frame by frame, with motmetrics' rules and solver.

    The events are those ``motmetrics.MOTAccumulator.update`` records (carry the previous frame's
    pairs over, pair the rest by the Hungarian algorithm, a pair whose target had another track
    before is a switch), kept as arrays: memory grows with the rows and the overlapping pairs,
    not with the product of the numbers of ids, and the per-frame cost with the frame's boxes.
    """
    try:
        require("motmetrics")
        from motmetrics.lap import linear_sum_assignment
    except ImportError as exc:  # pragma: no cover - motmetrics is a dependency
        raise TrackingError(f"evaluation needs the motmetrics package ({exc})") from None

    gt_rows = _track_table(gt, "the ground truth", allow_empty=False)
    hyp_rows = _track_table(hyp, "the hypotheses", allow_empty=True)
    if not (gt_rows[:, _FLAG] != 0).any():
        raise TrackingError("the ground truth has no scored row (every row has flag 0)")
    if not 0.0 <= max_iou_distance <= 1.0:
        raise TrackingError(f"max_iou_distance must be in [0, 1], got {max_iou_distance}")

    gt_rows = gt_rows[np.argsort(gt_rows[:, _FRAME], kind="stable")]
    hyp_rows = hyp_rows[np.argsort(hyp_rows[:, _FRAME], kind="stable")]
    frames = np.union1d(gt_rows[:, _FRAME], hyp_rows[:, _FRAME]).astype(int)
    gt_starts = np.searchsorted(gt_rows[:, _FRAME], frames, side="left").tolist()
    gt_stops = np.searchsorted(gt_rows[:, _FRAME], frames, side="right").tolist()
    hyp_starts = np.searchsorted(hyp_rows[:, _FRAME], frames, side="left").tolist()
    hyp_stops = np.searchsorted(hyp_rows[:, _FRAME], frames, side="right").tolist()
    gt_ids, hyp_ids = gt_rows[:, _ID].astype(np.int64), hyp_rows[:, _ID].astype(np.int64)
    gt_boxes, hyp_boxes = gt_rows[:, _X:_FLAG], hyp_rows[:, _X:_FLAG]
    scored_rows = gt_rows[:, _FLAG] != 0
    kept_rows = np.ones(len(hyp_rows), dtype=bool)

    previous: dict[int, int] = {}                       # target id -> track id of its last pair
    pairs: list[tuple[int, int, int, bool]] = []
    # The distances of the accumulator's events that are not RAW, in event order, 0 for a miss
    # or a false positive: motmetrics' MOTP sums this column, and so does this, to the same float.
    distances: list[np.ndarray] = []
    overlap_gt: list[np.ndarray] = []
    overlap_hyp: list[np.ndarray] = []
    misses = false_positives = 0
    for frame, g0, g1, h0, h1 in zip(frames.tolist(), gt_starts, gt_stops, hyp_starts, hyp_stops):
        scored = scored_rows[g0:g1]
        if g0 == g1 or h0 == h1:
            misses += int(scored.sum())
            false_positives += h1 - h0
            distances.append(np.zeros(int(scored.sum()) + h1 - h0))
            continue
        distance = _distances(gt_boxes[g0:g1], hyp_boxes[h0:h1], max_iou_distance)
        if not scored.all():
            # MOTChallenge protocol: match against all ground truth, drop what matched an ignored box.
            kept = np.ones(h1 - h0, dtype=bool)
            for i, j in zip(*_assignment(distance, linear_sum_assignment)):
                if not scored[i]:
                    kept[j] = False
            kept_rows[h0:h1] = kept
            gt_index, hyp_index = np.flatnonzero(scored) + g0, np.flatnonzero(kept) + h0
            distance = distance[np.ix_(scored, kept)]
        else:
            gt_index, hyp_index = np.arange(g0, g1), np.arange(h0, h1)
        oids, hids = gt_ids[gt_index], hyp_ids[hyp_index]
        finite_i, finite_j = np.nonzero(np.isfinite(distance))
        overlap_gt.append(oids[finite_i])
        overlap_hyp.append(hids[finite_j])
        frame_distances: list[float] = []
        gt_done = np.zeros(len(oids), dtype=bool)
        hyp_done = np.zeros(len(hids), dtype=bool)
        if len(finite_i):
            # 1. Pairs of the previous frames that are still within the threshold carry over.
            column_of = {h: j for j, h in enumerate(hids.tolist())}
            for i, o in enumerate(oids.tolist()):
                j = column_of.get(previous.get(o))
                if j is not None and not hyp_done[j] and np.isfinite(distance[i, j]):
                    gt_done[i] = hyp_done[j] = True
                    pairs.append((frame, int(gt_index[i]), int(hyp_index[j]), False))
                    frame_distances.append(distance[i, j])
            # 2. The others by the Hungarian algorithm; a target paired with another track before switches.
            rest = distance.copy()
            rest[gt_done, :] = np.nan
            rest[:, hyp_done] = np.nan
            if np.isfinite(rest).any():
                for i, j in zip(*_assignment(rest, linear_sum_assignment)):
                    o, h = int(oids[i]), int(hids[j])
                    pairs.append((frame, int(gt_index[i]), int(hyp_index[j]), o in previous and previous[o] != h))
                    frame_distances.append(rest[i, j])
                    gt_done[i] = hyp_done[j] = True
                    previous[o] = h
        frame_misses, frame_false = int((~gt_done).sum()), int((~hyp_done).sum())
        misses += frame_misses
        false_positives += frame_false
        distances.append(np.concatenate([np.asarray(frame_distances, dtype=np.float64),
                                         np.zeros(frame_misses + frame_false)]))

    scored_ids = gt_ids[scored_rows]
    kept_ids = hyp_ids[kept_rows]
    objects, object_counts = np.unique(scored_ids, return_counts=True)
    tracks, track_counts = np.unique(kept_ids, return_counts=True)
    overlaps: dict[tuple[int, int], int] = {}
    if overlap_gt:
        both = np.column_stack([np.concatenate(overlap_gt), np.concatenate(overlap_hyp)])
        if len(both):
            unique_pairs, pair_counts = np.unique(both, axis=0, return_counts=True)
            overlaps = {(int(o), int(h)): int(c) for (o, h), c in zip(unique_pairs.tolist(), pair_counts.tolist())}
    return _Matching(
        gt_rows=gt_rows, hyp_rows=hyp_rows,
        pairs=np.array(pairs, dtype=np.int64).reshape(-1, 4),
        distance_sum=float(np.concatenate(distances).sum()) if distances else 0.0,
        misses=misses, false_positives=false_positives,
        num_objects=len(scored_ids), num_predictions=len(kept_ids),
        ignored_predictions=int((~kept_rows).sum()), num_frames=len(frames),
        object_frames=dict(zip(objects.tolist(), object_counts.tolist())),
        track_frames=dict(zip(tracks.tolist(), track_counts.tolist())),
        overlaps=overlaps)


def _pairs(matching: _Matching) -> np.ndarray:
    """Rows ``frame, gt id, hypothesis id, centre error`` of the pairs of every frame."""
    frames, gt_pick, hyp_pick = matching.pairs[:, 0], matching.pairs[:, 1], matching.pairs[:, 2]
    gt_rows, hyp_rows = matching.gt_rows[gt_pick], matching.hyp_rows[hyp_pick]
    errors = np.linalg.norm(_centres(gt_rows) - _centres(hyp_rows), axis=1)
    return np.column_stack([frames, gt_rows[:, _ID], hyp_rows[:, _ID], errors]).astype(np.float64).reshape(-1, 4)


#: Up to this many target and track ids in all, the IDF1 assignment is solved on motmetrics' own dense
#: (targets + tracks)² cost matrix with its solver (at most 2048² costs, 32 MB), so that among
#: equally good assignments it picks the one motmetrics picks; beyond, on the overlapping pairs alone.
DENSE_IDENTITY_IDS = 2048


def _identity_assignment(matching: _Matching) -> tuple[dict[int, int], int]:
    """The IDF1 global one-to-one assignment of targets to tracks, and its true positives (IDTP).

    The assignment maximises the frames in which a target and its track may be paired
    (Ristani et al. 2016), as motmetrics' ``id_global_assignment``.  Up to
    :data:`DENSE_IDENTITY_IDS` ids it is that very computation (the same matrix and solver, so
    the same assignment also where several are optimal).  Beyond, only pairs that ever overlap
    can add to it, so it is solved on them alone as a sparse minimum-cost perfect matching
    (scipy's LAPJVsp) with the same costs: the same IDTP, and memory that grows with the
    overlapping pairs, not with the product of the numbers of ids.
    """
    if not matching.overlaps:
        return {}, 0
    if len(matching.object_frames) + len(matching.track_frames) <= DENSE_IDENTITY_IDS:
        return _dense_identity_assignment(matching)
    return _sparse_identity_assignment(matching)


def _dense_identity_assignment(matching: _Matching) -> tuple[dict[int, int], int]:
    """motmetrics' ``id_global_assignment``: a (targets + tracks)² matrix of false negatives plus false positives."""
    from motmetrics.lap import linear_sum_assignment

    objects, tracks = sorted(matching.object_frames), sorted(matching.track_frames)
    no, nh = len(objects), len(tracks)
    object_count = np.array([matching.object_frames[o] for o in objects], dtype=np.float64)
    track_count = np.array([matching.track_frames[h] for h in tracks], dtype=np.float64)
    costs = np.full((no + nh, no + nh), np.nan)
    costs[no:, nh:] = 0.0
    costs[:no, :nh] = object_count[:, None] + track_count[None, :]
    costs[np.arange(no), nh + np.arange(no)] = object_count
    costs[no + np.arange(nh), np.arange(nh)] = track_count
    object_index = {o: i for i, o in enumerate(objects)}
    track_index = {h: j for j, h in enumerate(tracks)}
    for (target, track), count in matching.overlaps.items():
        costs[object_index[target], track_index[track]] -= 2.0 * count
    identities, idtp = {}, 0
    for row, column in zip(*linear_sum_assignment(costs)):
        if row < no and column < nh:
            target, track = objects[row], tracks[column]
            # A pair that never overlaps costs the same assigned or not: it is no identity.
            count = matching.overlaps.get((target, track), 0)
            if count > 0:
                identities[int(target)] = int(track)
                idtp += count
    return identities, idtp


def _sparse_identity_assignment(matching: _Matching) -> tuple[dict[int, int], int]:
    """The assignment of :func:`_dense_identity_assignment` on the overlapping pairs alone (scipy's LAPJVsp)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import min_weight_full_bipartite_matching

    keys = np.array(list(matching.overlaps), dtype=np.int64)
    true_positives = np.array(list(matching.overlaps.values()), dtype=np.int64)
    objects, object_index = np.unique(keys[:, 0], return_inverse=True)
    tracks, track_index = np.unique(keys[:, 1], return_inverse=True)
    a, b = len(objects), len(tracks)
    object_cost = np.array([matching.object_frames[int(o)] for o in objects], dtype=np.float64)
    track_cost = np.array([matching.track_frames[int(h)] for h in tracks], dtype=np.float64)
    # Rows: targets, then one "no target" per track; columns: tracks, then one "no track" per target.
    # Every perfect matching has a + b edges, so the 1 added to each cost keeps the optimum and
    # keeps every edge a stored non-zero.
    rows = np.concatenate([object_index, np.arange(a), a + np.arange(b), a + track_index])
    cols = np.concatenate([track_index, b + np.arange(a), np.arange(b), b + object_index])
    costs = np.concatenate([object_cost[object_index] + track_cost[track_index] - 2.0 * true_positives,
                            object_cost, track_cost, np.zeros(len(keys))]) + 1.0
    graph = coo_matrix((costs, (rows, cols)), shape=(a + b, a + b)).tocsr()
    partner = min_weight_full_bipartite_matching(graph)[1]
    identities, idtp = {}, 0
    lookup = matching.overlaps
    for row in range(a):
        column = int(partner[row])
        if column < b:
            target, track = int(objects[row]), int(tracks[column])
            identities[target] = track
            idtp += lookup[(target, track)]
    return identities, idtp


def matched_pairs(gt: Any, hyp: Any, *, max_iou_distance: float = 0.5) -> np.ndarray:
    """The ground-truth boxes paired with a hypothesis by :func:`evaluate`, with their centre errors.

    Parameters
    ----------
    gt, hyp : array_like, shape (N, 6..10) and (M, 6..10)
        As in :func:`evaluate`.
    max_iou_distance : float, default 0.5
        Largest ``1 − IoU`` that still allows a pairing.

    Returns
    -------
    ndarray, shape (K, 4)
        Rows ``frame, gt id, hypothesis id, centre error`` (pixels), one per scored ground-truth
        box that has a partner in its frame (identity switches included), sorted by frame.

    Examples
    --------
    >>> gt = np.array([[1, 1, 0, 0, 10, 20, 1], [2, 1, 0, 0, 10, 20, 1]])
    >>> hyp = np.array([[1, 7, 0, 3, 10, 20, 1], [2, 7, 20, 0, 10, 20, 1]])   # frame 2: no overlap
    >>> matched_pairs(gt, hyp)
    array([[1., 1., 7., 3.]])
    """
    return _pairs(_accumulate(gt, hyp, max_iou_distance))


def evaluate(gt: Any, hyp: Any, *, max_iou_distance: float = 0.5) -> Scores:
    """Score hypothesis tracks against ground truth (CLEAR MOT, IDF1, HOTA, centre errors).

    Per frame: the hypotheses are matched (Hungarian algorithm on :func:`iou_distance`)
    against every ground-truth box; those matched to a box with flag 0 are dropped; the
    other hypotheses and the ground-truth boxes with a flag other than 0 go to a
    ``motmetrics.MOTAccumulator``, which carries matches over from the previous frames,
    then pairs the rest by the Hungarian algorithm, and counts identity switches, misses
    and false positives.  The summary comes from ``motmetrics.metrics``, except MOTP
    (reported as a mean IoU, see :class:`Scores`) and the centre errors, which are
    measured on the MATCH and SWITCH events of the accumulator.  HOTA and its parts are
    :func:`~belief_tracking.hota.hota` on the scored ground-truth rows and every hypothesis
    row (TrackEval's matching, independent of the CLEAR MOT one).

    Parameters
    ----------
    gt : array_like, shape (N, 6..10)
        Ground-truth rows ``frame, id, x, y, w, h[, flag, ...]`` as read by
        :func:`~belief_tracking.motfiles.read_mot`.  Rows whose flag is 0 are not
        scored; without a flag column, every row is.
    hyp : array_like, shape (M, 6..10)
        Tracker rows, same layout; the 7th column (a confidence) is not used.  May be
        empty (a run that found nobody): every scored box is then a miss, MOTA is 0 and
        IDF1 is 0.
    max_iou_distance : float, default 0.5
        Largest ``1 − IoU`` that still allows a pairing (0.5: IoU ≥ 0.5).

    Returns
    -------
    scores : Scores

    Raises
    ------
    TrackingError
        Malformed rows (wrong shape, non-finite values, non-integer frame or id, negative
        box size, one id twice in a frame), ground truth without any scored row, or
        motmetrics missing.

    Examples
    --------
    One object over three frames; the tracker follows it with id 5, then 6 in the last
    frame (one identity switch), and adds a false positive in frame 2:

    >>> gt = np.array([[1, 1, 0, 0, 10, 10, 1],
    ...                [2, 1, 2, 0, 10, 10, 1],
    ...                [3, 1, 4, 0, 10, 10, 1]])
    >>> hyp = np.array([[1, 5, 0, 0, 10, 10, 1],
    ...                 [2, 5, 2, 0, 10, 10, 1],
    ...                 [2, 9, 50, 50, 10, 10, 1],
    ...                 [3, 6, 5, 0, 10, 10, 1]])
    >>> scores = evaluate(gt, hyp)
    >>> scores.id_switches, scores.false_positives, scores.false_negatives
    (1, 1, 0)
    >>> round(scores.mota, 4)   # 1 - (0 + 1 + 1) / 3
    0.3333
    >>> scores.mean_centre_error   # 0, 0 and 1 pixel
    0.3333333333333333

    HOTA sees the same boxes over the IoU thresholds α: the third box (IoU 9/11) counts only up to
    α = 0.8, the false positive lowers DetA, and the track change halves the association of frame 3:

    >>> round(scores.deta, 4), round(scores.assa, 4), round(scores.hota, 4)
    (0.6947, 0.5731, 0.6251)

    No tracks at all miss every box:

    >>> nothing = evaluate(gt, np.zeros((0, 7)))
    >>> nothing.mota, nothing.idf1, nothing.hota, nothing.false_negatives, nothing.matched_pairs
    (0.0, 0.0, 0.0, 3, 0)
    """
    matching = _accumulate(gt, hyp, max_iou_distance)
    _, idtp = _identity_assignment(matching)
    switches = int(matching.pairs[:, 3].sum())
    detections = len(matching.pairs)
    objects, predictions = matching.num_objects, matching.num_predictions
    centre_errors = _pairs(matching)[:, 3]
    nan = float("nan")
    gt_rows, hyp_rows = matching.gt_rows[matching.gt_rows[:, _FLAG] != 0], matching.hyp_rows
    hota_means = hota(gt_rows[:, _FRAME], gt_rows[:, _ID], gt_rows[:, _X:_FLAG],
                      hyp_rows[:, _FRAME], hyp_rows[:, _ID], hyp_rows[:, _X:_FLAG]).means()

    def ratio(numerator: float, denominator: float) -> float:
        return numerator / denominator if denominator else nan

    return Scores(
        mota=1.0 - ratio(matching.misses + switches + matching.false_positives, objects),
        motp=1.0 - matching.distance_sum / detections if detections > 0 else nan,
        idf1=ratio(2 * idtp, objects + predictions),
        **{name: hota_means[name] for name in HOTA_FIELDS},
        precision=ratio(detections, matching.false_positives + detections),
        recall=ratio(detections, objects),
        id_switches=switches,
        false_positives=matching.false_positives,
        false_negatives=matching.misses,
        matched_pairs=detections,
        num_objects=objects,
        num_predictions=predictions,
        ignored_predictions=matching.ignored_predictions,
        num_frames=matching.num_frames,
        mean_centre_error=float(np.mean(centre_errors)) if len(centre_errors) else nan,
        median_centre_error=float(np.median(centre_errors)) if len(centre_errors) else nan,
    )


# -- identities ---------------------------------------------------------------------------------------
class IdentitySwaps(NamedTuple):
    """How often ground-truth targets are followed by a track that is not their own (:func:`identity_swaps`).

    Attributes
    ----------
    frames : int
        Frames in which at least one target is paired with a track other than its identity.
    pairs : int
        The (frame, target) pairs in which that happens; at least ``frames``.
    per_target : dict of int to int
        For every scored target, in increasing id order: the frames in which it is paired
        with a track other than its identity (0 for a target that never is).
    identities : dict of int to int or None
        For every scored target: the track id it should carry, or None when it has none
        (then every pairing of it counts).
    """

    frames: int
    pairs: int
    per_target: dict[int, int]
    identities: dict[int, int | None]


def _idf1_identities(matching: _Matching) -> dict[int, int | None]:
    """Target id -> track id of the IDF1 global one-to-one assignment, None if unassigned."""
    assigned, _ = _identity_assignment(matching)
    return {int(o): assigned.get(int(o)) for o in sorted(matching.object_frames)}


def _given_identities(identities: Any, targets: np.ndarray) -> dict[int, int | None]:
    """The identity of every scored target, for ``identities="gt"`` or a mapping of target ids to track ids."""
    if isinstance(identities, str):
        if identities != "gt":
            raise TrackingError(f'identities must be None, "gt" or a mapping of target ids to track ids, '
                                f'got {identities!r}')
        return {int(t): int(t) for t in targets}
    if not isinstance(identities, Mapping):
        raise TrackingError(f"identities must be None, \"gt\" or a mapping of target ids to track ids, "
                            f"got {type(identities).__name__}")
    for target, track in identities.items():
        for value in (target, track):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise TrackingError(f"identities maps integer target ids to integer track ids, "
                                    f"got {target!r}: {track!r}")
    return {int(t): (int(identities[int(t)]) if int(t) in identities else None) for t in targets}


def identity_swaps(gt: Any, hyp: Any, *, max_iou_distance: float = 0.5,
                   identities: str | Mapping[int, int] | None = None) -> IdentitySwaps:
    """Count the frames in which a ground-truth target is followed by a track that carries another identity.

    Each frame's pairs are those of :func:`evaluate` (and :func:`matched_pairs`): CLEAR MOT
    matching of the hypotheses to the ground truth at IoU ≥ 0.5 (Hungarian algorithm,
    matches carried over from the previous frame), hypotheses matched to a flag-0
    ground-truth box dropped, flag-0 boxes not scored.  Every scored target has an
    *identity*, the track id it should carry:

    * ``identities="gt"``: its own id.  This is the mode for tracks born from the ground
      truth (:func:`~belief_tracking.initiation.init_from_gt`), which keep its ids;
    * ``identities=None`` (the default): the track that the global one-to-one assignment
      of IDF1 (Ristani et al. 2016, as ``motmetrics`` computes it for :attr:`Scores.idf1`)
      gives it, so that the count does not depend on how the tracker numbers its tracks;
      a target that the assignment leaves without a track (or gives one it never
      overlaps) has none;
    * a mapping ``{target id: track id}``: as given; a target missing from it has none.

    A pair (frame, target, track) is *swapped* when the track id is not the target's
    identity.  A frame counts once however many of its pairs are swapped.  A track paired
    with nobody, and a target paired with nobody, count nothing: misses and false
    positives are MOTA's business, not this score's.

    Parameters
    ----------
    gt, hyp : array_like, shape (N, 6..10) and (M, 6..10)
        As in :func:`evaluate`.
    max_iou_distance : float, default 0.5
        Largest ``1 − IoU`` that still allows a pairing (0.5: IoU ≥ 0.5).
    identities : None, "gt" or mapping of int to int, default None
        Where the identities come from (see above).

    Returns
    -------
    IdentitySwaps
        The swapped frames, the swapped (frame, target) pairs, the swapped frames of every
        target and the identities used.

    Raises
    ------
    TrackingError
        As :func:`evaluate`, and for ``identities`` that are none of the above.

    Examples
    --------
    Two targets side by side for four frames; the tracks follow them, then trade places
    in the last frame:

    >>> gt = np.array([[f, i, 0 if i == 1 else 50, 0, 10, 10, 1] for f in (1, 2, 3, 4) for i in (1, 2)])
    >>> hyp = gt.copy()
    >>> hyp[6:, 1] = [2, 1]                                # frame 4: track 2 on target 1, track 1 on target 2
    >>> identity_swaps(gt, hyp, identities="gt")[:3]       # one frame, two pairs, one frame each
    (1, 2, {1: 1, 2: 1})

    Tracks numbered otherwise (7 and 8) carry the ground-truth ids nowhere, but the IDF1
    assignment gives target 1 track 7 and target 2 track 8, and finds the same swap:

    >>> hyp[:, 1] = np.where(hyp[:, 1] == 1, 7, 8)
    >>> identity_swaps(gt, hyp, identities="gt").frames
    4
    >>> swaps = identity_swaps(gt, hyp)
    >>> swaps.frames, swaps.pairs, swaps.identities
    (1, 2, {1: 7, 2: 8})
    """
    matching = _accumulate(gt, hyp, max_iou_distance)
    if identities is None:
        identity = _idf1_identities(matching)
    else:
        gt_rows = matching.gt_rows
        identity = _given_identities(identities, np.unique(gt_rows[gt_rows[:, _FLAG] != 0, _ID]))
    per_target = dict.fromkeys(sorted(identity), 0)
    swapped_frames = set()
    for frame, target, track, _ in _pairs(matching):
        if identity[int(target)] != int(track):
            per_target[int(target)] += 1
            swapped_frames.add(int(frame))
    return IdentitySwaps(frames=len(swapped_frames), pairs=sum(per_target.values()), per_target=per_target,
                         identities=identity)
