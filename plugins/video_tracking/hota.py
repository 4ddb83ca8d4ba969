"""HOTA (higher-order tracking accuracy) of tracks against ground truth, as TrackEval computes it.

HOTA (Luiten et al., "HOTA: A Higher Order Metric for Evaluating Multi-Object Tracking",
IJCV 2021) scores detection and association at once.  The similarity of a ground-truth box
and a track box is their IoU.  For each localisation threshold α in
:data:`ALPHAS` = 0.05, 0.10, …, 0.95, a matched pair whose IoU is at least α is a true
positive (TP); the other ground-truth boxes are misses (FN), the other track boxes false
positives (FP).  Per α:

* ``DetA = |TP| / (|TP| + |FN| + |FP|)``, ``DetRe = |TP| / (|TP| + |FN|)``,
  ``DetPr = |TP| / (|TP| + |FP|)``;
* for a true positive c of target g and track h, ``TPA(c)``, ``FNA(c)`` and ``FPA(c)`` are
  the true positives of the pair (g, h), the boxes of g not matched to h, and the boxes of h
  not matched to g (over the whole sequence); then
  ``AssA = 1/|TP| · Σ_c TPA(c) / (TPA(c) + FNA(c) + FPA(c))``,
  ``AssRe = 1/|TP| · Σ_c TPA(c) / (TPA(c) + FNA(c))``,
  ``AssPr = 1/|TP| · Σ_c TPA(c) / (TPA(c) + FPA(c))``;
* ``HOTA = sqrt(DetA · AssA)``, and ``LocA`` is the mean IoU of the true positives.

Every reported score is the mean of its 19 values over α.

The matching is TrackEval's (``trackeval/metrics/hota.py``, the MOTChallenge reference code),
step by step, so that the figures are its figures:

1. every frame's IoU matrix ``S`` (targets × tracks) gives the "soft" overlaps
   ``S / (row sum + column sum − S)``, summed over frames per (target, track) pair into
   ``P``; with ``n_g`` and ``n_h`` the boxes of target g and track h, the pair's global
   alignment is ``A = P / (n_g + n_h − P)``;
2. each frame is matched once by the Hungarian algorithm on the score ``A · S`` (which
   prefers pairs that stay together over the whole sequence), with no threshold;
3. a matched pair counts at α when its IoU is at least ``α − ε`` (ε the float epsilon).

A score whose denominator is 0 is 0, except LocA, which TrackEval sets to 1 where there is
no true positive (``max(1e-10, Σ IoU) / max(1e-10, |TP|)``) — so that tracks with no box at all
have LocA 1, and the mean LocA counts 1 for every α above the largest matched IoU.

The ground truth is taken as TrackEval's ``MotChallenge2DBox`` takes it with its
preprocessing on and every row a pedestrian: the caller passes only the scored rows (flag
not 0) and every track row.  A track box on a flag-0 box is therefore *not* dropped here:
TrackEval drops a track box only when it matches a ground-truth box of a distractor class,
and with every row a pedestrian there is none, so such a box is a false positive of HOTA (the
CLEAR MOT scores of :func:`~belief_tracking.evaluation.evaluate` drop it instead).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .boxes import checked_iou
from .errors import TrackingError
from .extras import require

__all__ = ["ALPHAS", "HOTA_FIELDS", "Hota", "hota"]

#: The localisation thresholds α, shape (19,): TrackEval's ``np.arange(0.05, 0.99, 0.05)``, the very
#: floats (0.15000000000000002, ...), so that an IoU on a threshold falls on the same side.
ALPHAS = np.arange(0.05, 0.99, 0.05)

#: The scores of :class:`Hota`, in the order of TrackEval's tables; their means are the fields of
#: :class:`~belief_tracking.evaluation.Scores` of the same names.
HOTA_FIELDS = ("hota", "deta", "assa", "loca", "detre", "detpr", "assre", "asspr")

_EPS = np.finfo(float).eps


@dataclass(frozen=True)
class Hota:
    """The HOTA scores of one sequence, per localisation threshold α (:data:`ALPHAS`).

    Every score attribute is an ndarray of float, shape (19,), one value per α; the
    properties ``mean_*`` are what the tables report (the mean over α, as TrackEval's
    summary).

    Attributes
    ----------
    hota : ndarray, shape (19,)
        ``sqrt(deta · assa)``.
    deta, detre, detpr : ndarray, shape (19,)
        Detection accuracy, recall and precision.
    assa, assre, asspr : ndarray, shape (19,)
        Association accuracy, recall and precision.
    loca : ndarray, shape (19,)
        Mean IoU of the true positives (1 where there is none).
    tp, fn, fp : ndarray of int, shape (19,)
        True positives, misses and false positives.
    """

    hota: np.ndarray
    deta: np.ndarray
    assa: np.ndarray
    loca: np.ndarray
    detre: np.ndarray
    detpr: np.ndarray
    assre: np.ndarray
    asspr: np.ndarray
    tp: np.ndarray
    fn: np.ndarray
    fp: np.ndarray

    def means(self) -> dict[str, float]:
        """The mean over α of every score of :data:`HOTA_FIELDS`, as Python floats.

        Returns
        -------
        dict of str to float
            Keys ``hota, deta, assa, loca, detre, detpr, assre, asspr``.
        """
        return {name: float(np.mean(getattr(self, name))) for name in HOTA_FIELDS}


def _frame_slices(frames: np.ndarray, wanted: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and stop of each frame of ``wanted`` in the sorted array ``frames``."""
    return np.searchsorted(frames, wanted, side="left"), np.searchsorted(frames, wanted, side="right")


def _check(frames: Any, ids: Any, boxes: Any, what: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    frames = np.asarray(frames, dtype=np.int64).reshape(-1)
    ids = np.asarray(ids, dtype=np.int64).reshape(-1)
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    if not len(frames) == len(ids) == len(boxes):
        raise TrackingError(f"{what}: {len(frames)} frames, {len(ids)} ids and {len(boxes)} boxes; "
                            f"one of each per row")
    order = np.argsort(frames, kind="stable")      # a frame's rows keep their file order, as TrackEval's
    return frames[order], ids[order], boxes[order]


def hota(gt_frames: Any, gt_ids: Any, gt_boxes: Any, hyp_frames: Any, hyp_ids: Any, hyp_boxes: Any) -> Hota:
    """HOTA, DetA, AssA, LocA and their recalls and precisions per α, as TrackEval's ``HOTA`` metric.

    Parameters
    ----------
    gt_frames, gt_ids : array_like of int, shape (G,)
        Frame and target id of each scored ground-truth box (flag-0 rows left out by the caller).
    gt_boxes : array_like of float, shape (G, 4)
        ``x, y, w, h`` (top-left corner and size), checked by
        :func:`~belief_tracking.boxes.check_boxes` (finite, non-negative sizes).
    hyp_frames, hyp_ids : array_like of int, shape (H,)
        Frame and track id of each track box; H may be 0.
    hyp_boxes : array_like of float, shape (H, 4)
        Same layout.  A target or track id appears at most once per frame.

    Returns
    -------
    Hota
        The scores per α; :meth:`Hota.means` gives the reported means.

    Raises
    ------
    TrackingError
        Arrays of different lengths.
    MissingExtraError
        scipy is not installed.

    Notes
    -----
    Cost: one IoU matrix per frame (rows × columns of the frame) and one Hungarian
    assignment per frame in which a box overlaps two others; everything over the pairs and
    the thresholds is one numpy expression over all frames.

    Examples
    --------
    One target over four frames, followed exactly by track 7 in frames 1–2 and by track 8
    in frames 3–4: every box is found (DetA 1), but each track covers half of the target
    (AssA 1/2 at every α), so HOTA is sqrt(1/2):

    >>> frames = [1, 2, 3, 4]
    >>> boxes = [[0, 0, 10, 10]] * 4
    >>> scores = hota(frames, [1, 1, 1, 1], boxes, frames, [7, 7, 8, 8], boxes)
    >>> means = scores.means()
    >>> means["deta"], means["assa"], round(means["hota"], 6), means["loca"]
    (1.0, 0.5, 0.707107, 1.0)
    >>> bool(np.allclose(scores.hota ** 2, scores.deta * scores.assa))
    True
    """
    # scipy (a dependency of motmetrics, in the tracking extra) is imported when a score is computed, as
    # motmetrics is, so that the command line starts without it; its solver is TrackEval's.
    require("scipy")
    from scipy.optimize import linear_sum_assignment

    gt_frames, gt_ids, gt_boxes = _check(gt_frames, gt_ids, gt_boxes, "the ground truth")
    hyp_frames, hyp_ids, hyp_boxes = _check(hyp_frames, hyp_ids, hyp_boxes, "the tracks")
    # Ids as 0..n-1 (TrackEval relabels them so too), and each id's box count (n_g, n_h), as floats
    # because TrackEval adds them as floats.
    gt_labels, gt_index = np.unique(gt_ids, return_inverse=True)
    hyp_labels, hyp_index = np.unique(hyp_ids, return_inverse=True)
    gt_count = np.bincount(gt_index, minlength=len(gt_labels)).astype(np.float64)
    hyp_count = np.bincount(hyp_index, minlength=len(hyp_labels)).astype(np.float64)
    n_hyp_ids = max(len(hyp_labels), 1)

    # 1. Per frame with boxes on both sides: the IoU matrix, kept as its non-zero entries (an entry
    # of IoU 0 adds nothing to any sum and can never be a true positive), and the soft overlaps.
    frames = np.intersect1d(gt_frames, hyp_frames)
    g_starts, g_stops = _frame_slices(gt_frames, frames)
    h_starts, h_stops = _frame_slices(hyp_frames, frames)
    rows, cols, sims, soft = [], [], [], []
    for g0, g1, h0, h1 in zip(g_starts.tolist(), g_stops.tolist(), h_starts.tolist(), h_stops.tolist()):
        similarity = checked_iou(gt_boxes[g0:g1], hyp_boxes[h0:h1])
        # TrackEval's expression, on the whole frame matrix, so that the sums are the same floats.
        denominator = similarity.sum(0)[np.newaxis, :] + similarity.sum(1)[:, np.newaxis] - similarity
        i, j = np.nonzero(similarity)
        rows.append(i + g0)
        cols.append(j + h0)
        sims.append(similarity[i, j])
        share = denominator[i, j]
        soft.append(np.where(share > _EPS, similarity[i, j] / np.where(share > _EPS, share, 1.0), 0.0))
    rows = np.concatenate(rows) if rows else np.zeros(0, dtype=np.intp)
    cols = np.concatenate(cols) if cols else np.zeros(0, dtype=np.intp)
    sims = np.concatenate(sims) if sims else np.zeros(0)
    soft = np.concatenate(soft) if soft else np.zeros(0)

    # Global alignment A = P / (n_g + n_h − P) of every (target, track) pair that ever overlaps.
    # bincount adds in input order, i.e. frame by frame, as TrackEval's running sum.
    pair_key = gt_index[rows] * n_hyp_ids + hyp_index[cols]
    pairs, pair_of = np.unique(pair_key, return_inverse=True)
    potential = np.bincount(pair_of, weights=soft, minlength=len(pairs))
    pair_gt, pair_hyp = pairs // n_hyp_ids, pairs % n_hyp_ids
    alignment = potential / (gt_count[pair_gt] + hyp_count[pair_hyp] - potential)
    score = alignment[pair_of] * sims

    # 2. The matching of each frame.  Where no row and no column of a frame holds two positive
    # scores, the maximum-score assignment takes every positive entry, so the Hungarian algorithm
    # runs only on the frames with a choice (on the full frame matrix, as TrackEval, so that it
    # breaks ties the same way).
    positive = score > 0
    matched = positive.copy()
    crowded_rows = np.bincount(rows[positive], minlength=len(gt_frames)) > 1
    crowded_cols = np.bincount(cols[positive], minlength=len(hyp_frames)) > 1
    choice = np.union1d(gt_frames[crowded_rows], hyp_frames[crowded_cols])
    if len(choice):
        entry_frame = gt_frames[rows]                   # ascending: the entries were gathered frame by frame
        in_choice = np.isin(entry_frame, choice)
        matched[in_choice] = False
        entries = np.flatnonzero(in_choice)
        bounds = np.searchsorted(entry_frame[entries], choice, side="left").tolist() + [len(entries)]
        c_g0, c_g1 = _frame_slices(gt_frames, choice)
        c_h0, c_h1 = _frame_slices(hyp_frames, choice)
        for k, (g0, g1, h0, h1) in enumerate(zip(c_g0.tolist(), c_g1.tolist(), c_h0.tolist(), c_h1.tolist())):
            mine = entries[bounds[k]:bounds[k + 1]]
            matrix = np.zeros((g1 - g0, h1 - h0))
            matrix[rows[mine] - g0, cols[mine] - h0] = score[mine]
            match_rows, match_cols = linear_sum_assignment(-matrix)
            entry_of = np.full(matrix.shape, -1, dtype=np.intp)
            entry_of[rows[mine] - g0, cols[mine] - h0] = mine
            chosen = entry_of[match_rows, match_cols]
            matched[chosen[chosen >= 0]] = True     # a pair of IoU 0 is no true positive at any α
    match_sim = sims[matched]
    match_pair = pair_of[matched]

    # 3. Every α at once: (K matches) × (19 thresholds).
    counts = match_sim[:, None] >= ALPHAS[None, :] - _EPS
    tp = counts.sum(axis=0)
    fn = len(gt_frames) - tp
    fp = len(hyp_frames) - tp
    loca_sum = (match_sim[:, None] * counts).sum(axis=0)
    # TPA of every (pair, α): the pair's true positives at α.
    tpa = np.zeros((len(pairs), len(ALPHAS)))
    np.add.at(tpa, match_pair, counts.astype(np.float64))
    g_n, h_n = gt_count[pair_gt][:, None], hyp_count[pair_hyp][:, None]
    # Σ over the true positives c of TPA(c)/(...) = Σ over pairs of TPA · TPA/(...), as TrackEval sums it.
    per_tp = np.maximum(1, tp)
    assa = np.sum(tpa * (tpa / np.maximum(1, g_n + h_n - tpa)), axis=0) / per_tp
    assre = np.sum(tpa * (tpa / np.maximum(1, g_n)), axis=0) / per_tp
    asspr = np.sum(tpa * (tpa / np.maximum(1, h_n)), axis=0) / per_tp
    loca = np.maximum(1e-10, loca_sum) / np.maximum(1e-10, tp)
    deta = tp / np.maximum(1, tp + fn + fp)
    return Hota(hota=np.sqrt(deta * assa), deta=deta, assa=assa, loca=loca,
                detre=tp / np.maximum(1, tp + fn), detpr=tp / np.maximum(1, tp + fp),
                assre=assre, asspr=asspr, tp=tp, fn=fn, fp=fp)
