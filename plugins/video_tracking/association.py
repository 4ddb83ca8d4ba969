"""Which candidate box belongs to which track: a one-to-one assignment on box overlap.

A frame's *candidates* are the boxes a detector gives (or, without a detector, the person
blobs of the foreground mask).  Each track may take at most one candidate and each
candidate may go to at most one track, and pairs that overlap less than a gate are never
matched.  Among all such matchings :func:`assign` takes the one that maximises the number
of pairs plus their total overlap, k + Σ IoU: a linear assignment on the cost 1 − IoU (the
Hungarian method, SciPy's ``linear_sum_assignment``), as in SORT.  One more pair above the
gate is worth more than any gain of overlap, so as many tracks as can be are supported.  A
track with no candidate is *unsupported* this frame, and a candidate that no track takes
may start a new one.
"""

from __future__ import annotations

import numpy as np

from plugins.video_tracking.boxes import check_boxes, iou
from plugins.video_tracking.errors import TrackingError

__all__ = ["assign", "UNASSIGNED"]

#: The assignment of a track that takes no candidate.
UNASSIGNED = -1


def assign(tracks, candidates, min_iou: float = 0.3) -> np.ndarray:
    """The candidate of each track under the one-to-one matching of largest k + Σ IoU.

    Parameters
    ----------
    tracks : array_like, shape (τ, 4)
        The tracks' boxes ``x, y, w, h`` (their predictions for this frame).
    candidates : array_like, shape (n, 4) or (n, 5)
        The candidate boxes ``x, y, w, h`` (a fifth column, a score, is ignored).
    min_iou : float in (0, 1]
        The gate: a pair that overlaps less is never matched.

    Returns
    -------
    ndarray of int, shape (τ,)
        The row of ``candidates`` taken by each track, or :data:`UNASSIGNED` (−1).

    Raises
    ------
    TrackingError
        Boxes that are not finite (n, 4) arrays with positive sizes, or a gate outside (0, 1].

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
    """
    from scipy.optimize import linear_sum_assignment

    if isinstance(min_iou, bool) or not isinstance(min_iou, (int, float, np.integer, np.floating)) \
            or not 0 < min_iou <= 1:
        raise TrackingError(f"min_iou must lie in (0, 1], got {min_iou!r}")
    tracks = check_boxes(tracks, "track boxes").reshape(-1, 4)
    candidates = np.asarray(candidates, dtype=np.float64)
    candidates = check_boxes(candidates[:, :4] if candidates.ndim == 2 else candidates,
                             "candidate boxes").reshape(-1, 4)
    result = np.full(len(tracks), UNASSIGNED, dtype=np.intp)
    if len(tracks) == 0 or len(candidates) == 0:
        return result
    overlap = iou(tracks, candidates)
    # Pairs below the gate cost more than any pair above it, so the solver never prefers
    # them; they are dropped after the solve.
    cost = np.where(overlap >= min_iou, 1.0 - overlap, 2.0)
    rows, cols = linear_sum_assignment(cost)
    kept = overlap[rows, cols] >= min_iou
    result[rows[kept]] = cols[kept]
    return result
