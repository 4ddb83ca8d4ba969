"""Scoring tracks against ground truth: CLEAR MOT (MOTA, MOTP), IDF1 and centre errors.

Tracks and ground truth are MOTChallenge text files (:func:`read_mot`): one box per line,
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
  ``motmetrics.metrics``.

The IoU distances are computed here, not with ``motmetrics.distances.iou_matrix``: the
released motmetrics 1.4.0 calls ``np.asfarray``, which NumPy 2 removed.

``motmetrics`` (and with it pandas) is imported only when :func:`evaluate` runs, so that
registering the ``belief eval`` command costs nothing for the other commands.
"""

from __future__ import annotations

import argparse
import json
import math
from dataclasses import asdict, dataclass, fields
from os import PathLike
from typing import Any

import numpy as np

from belief.textfiles import read_text
from plugins.video_tracking.errors import TrackFileError, TrackingError

__all__ = [
    "MOT_COLUMNS",
    "Scores",
    "matched_pairs",
    "read_mot",
    "iou_distance",
    "evaluate",
    "register_eval",
]

#: Columns of the array returned by :func:`read_mot`.  ``flag`` is the 7th column of the
#: file: for ground truth, 0 means "not scored"; for tracker output it is a confidence,
#: which the evaluation does not use.  Files with only 6 columns get a flag of 1.
MOT_COLUMNS = ("frame", "id", "x", "y", "width", "height", "flag")

_FRAME, _ID, _X, _Y, _W, _H, _FLAG = range(len(MOT_COLUMNS))
_MIN_FIELDS, _MAX_FIELDS = 6, 10


# -- reading -------------------------------------------------------------------------------------
def read_mot(path: str | PathLike[str]) -> np.ndarray:
    """Read a MOTChallenge track or ground-truth file.

    Each non-blank line is ``frame,id,x,y,w,h[,flag[,a[,b[,c]]]]``: 6 to 10 numbers
    separated by commas (or, if a line has no comma, by white space).  Columns past the
    7th (class and visibility, or world coordinates) are checked to be numbers and
    dropped.

    Parameters
    ----------
    path : str or path-like
        The file to read.

    Returns
    -------
    rows : ndarray of float, shape (N, 7)
        One row per box, columns :data:`MOT_COLUMNS`: frame, id, x, y, width, height,
        flag (1 where the file has only 6 columns), in file order.

    Raises
    ------
    TrackFileError
        The file is missing or unreadable, holds no rows, or a line (named with its
        number) has the wrong number of fields, a field that is not a finite number, a
        frame or id that is not an integer, a negative width or height, or repeats the
        id of an earlier line of the same frame.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = pathlib.Path(folder) / "gt.txt"
    ...     _ = path.write_text("1,7,10,20,30,40,1,-1,-1,-1\\n2,7,12,20,30,40,0,-1,-1,-1\\n")
    ...     read_mot(path)
    array([[ 1.,  7., 10., 20., 30., 40.,  1.],
           [ 2.,  7., 12., 20., 30., 40.,  0.]])
    """
    name = str(path)
    text = read_text(path, "track file", TrackFileError, encoding="utf-8-sig")

    rows: list[list[float]] = []
    first_line_of: dict[tuple[int, int], int] = {}
    for line_number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped:
            continue
        where = f"{name}, line {line_number}"
        fields_ = [f.strip() for f in stripped.split(",")] if "," in stripped else stripped.split()
        if not _MIN_FIELDS <= len(fields_) <= _MAX_FIELDS:
            raise TrackFileError(
                f"{where}: expected {_MIN_FIELDS} to {_MAX_FIELDS} fields "
                f"(frame,id,x,y,w,h,flag,...), got {len(fields_)}")
        values = []
        for column, field in enumerate(fields_, start=1):
            try:
                value = float(field)
            except ValueError:
                raise TrackFileError(f"{where}: field {column} is not a number: {field!r}") from None
            if not math.isfinite(value):
                raise TrackFileError(f"{where}: field {column} is not finite: {field!r}")
            values.append(value)
        frame, track_id, _, _, width, height = values[:6]
        for label, value in (("frame", frame), ("id", track_id)):
            if value != int(value):
                raise TrackFileError(f"{where}: the {label} must be an integer, got {value:g}")
        if width < 0 or height < 0:
            raise TrackFileError(f"{where}: negative box size {width:g} x {height:g}")
        key = (int(frame), int(track_id))
        if key in first_line_of:
            raise TrackFileError(
                f"{where}: frame {key[0]} has id {key[1]} twice (first on line {first_line_of[key]})")
        first_line_of[key] = line_number
        rows.append(values[:7] if len(values) > 6 else values + [1.0])
    if not rows:
        raise TrackFileError(f"{name}: no boxes in the file (it is empty)")
    return np.asarray(rows, dtype=float)


# -- IoU distances ---------------------------------------------------------------------------------
def _boxes(boxes: Any, what: str) -> np.ndarray:
    array = np.asarray(boxes, dtype=float)
    if array.size == 0:
        return array.reshape(0, 4)
    if array.ndim != 2 or array.shape[1] != 4:
        raise TrackingError(f"{what} must have shape (n, 4) (x, y, width, height), got {array.shape}")
    if not np.isfinite(array).all():
        raise TrackingError(f"{what} hold a value that is not finite")
    if (array[:, 2:] < 0).any():
        raise TrackingError(f"{what} hold a negative width or height")
    return array


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
    gt = _boxes(gt_boxes, "ground-truth boxes")[:, None, :]
    hyp = _boxes(hyp_boxes, "hypothesis boxes")[None, :, :]
    left = np.maximum(gt[..., 0], hyp[..., 0])
    right = np.minimum(gt[..., 0] + gt[..., 2], hyp[..., 0] + hyp[..., 2])
    top = np.maximum(gt[..., 1], hyp[..., 1])
    bottom = np.minimum(gt[..., 1] + gt[..., 3], hyp[..., 1] + hyp[..., 3])
    intersection = np.maximum(right - left, 0.0) * np.maximum(bottom - top, 0.0)
    union = gt[..., 2] * gt[..., 3] + hyp[..., 2] * hyp[..., 3] - intersection
    iou = np.divide(intersection, union, out=np.zeros_like(intersection), where=union > 0)
    distance = 1.0 - iou
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
        metric                       value
        --------------------------  ------
        MOTA                        1.0000
        MOTP (mean IoU of matches)  1.0000
        IDF1                        1.0000
        precision                   1.0000
        recall                      1.0000
        ID switches                      0
        false positives                  0
        false negatives (misses)         0
        matched pairs                    1
        ground-truth boxes               1
        hypothesis boxes                 1
        ignored hypothesis boxes         0
        frames                           1
        mean centre error (px)      0.0000
        median centre error (px)    0.0000
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
    if (array[:, [_W, _H]] < 0).any():
        raise TrackingError(f"{what} has a box with a negative width or height")
    keys = np.unique(array[:, :2], axis=0)
    if len(keys) != len(array):
        raise TrackingError(f"{what} has the same id twice in one frame")
    return array


def _centres(table: np.ndarray) -> np.ndarray:
    return table[:, [_X, _Y]] + table[:, [_W, _H]] / 2.0


def _accumulate(gt: Any, hyp: Any, max_iou_distance: float):
    """The motmetrics accumulator of :func:`evaluate`, the sorted rows, and the dropped hypotheses."""
    try:
        import motmetrics
        from motmetrics.lap import linear_sum_assignment
    except ImportError as exc:  # pragma: no cover - motmetrics is a dependency
        raise TrackingError(f"evaluation needs the motmetrics package ({exc})") from None

    gt_rows = _track_table(gt, "the ground truth", allow_empty=False)
    hyp_rows = _track_table(hyp, "the hypotheses", allow_empty=True)
    if not (gt_rows[:, _FLAG] != 0).any():
        raise TrackingError("the ground truth has no scored row (every row has flag 0)")

    gt_rows = gt_rows[np.argsort(gt_rows[:, _FRAME], kind="stable")]
    hyp_rows = hyp_rows[np.argsort(hyp_rows[:, _FRAME], kind="stable")]
    frames = np.union1d(gt_rows[:, _FRAME], hyp_rows[:, _FRAME]).astype(int)
    gt_starts = np.searchsorted(gt_rows[:, _FRAME], frames, side="left")
    gt_stops = np.searchsorted(gt_rows[:, _FRAME], frames, side="right")
    hyp_starts = np.searchsorted(hyp_rows[:, _FRAME], frames, side="left")
    hyp_stops = np.searchsorted(hyp_rows[:, _FRAME], frames, side="right")

    accumulator = motmetrics.MOTAccumulator(auto_id=False)
    ignored_predictions = 0
    for frame, g0, g1, h0, h1 in zip(frames, gt_starts, gt_stops, hyp_starts, hyp_stops):
        frame_gt = gt_rows[g0:g1]
        frame_hyp = hyp_rows[h0:h1]
        distance = iou_distance(frame_gt[:, _X:_FLAG], frame_hyp[:, _X:_FLAG], max_iou_distance)
        scored = frame_gt[:, _FLAG] != 0
        kept = np.ones(len(frame_hyp), dtype=bool)
        if not scored.all() and len(frame_hyp):
            # MOTChallenge protocol: match against all ground truth, drop what matched an ignored box.
            for i, j in zip(*linear_sum_assignment(distance)):
                if np.isfinite(distance[i, j]) and not scored[i]:
                    kept[j] = False
            ignored_predictions += int((~kept).sum())
        accumulator.update(
            frame_gt[scored, _ID].astype(int),
            frame_hyp[kept, _ID].astype(int),
            distance[np.ix_(scored, kept)],
            frameid=int(frame),
        )

    return accumulator, gt_rows, hyp_rows, ignored_predictions


def _pairs(accumulator, gt_rows: np.ndarray, hyp_rows: np.ndarray) -> np.ndarray:
    """Rows ``frame, gt id, hypothesis id, centre error`` of the pairs of every frame."""
    # The event table also repeats a pair as a TRANSFER / ASCEND / MIGRATE event; only MATCH
    # and SWITCH are the pairs of the frame.
    events = accumulator.mot_events
    pairs = events[events["Type"].isin(["MATCH", "SWITCH"])]
    frames = pairs.index.get_level_values("FrameId").to_numpy(dtype=int)
    gt_ids, hyp_ids = pairs["OId"].to_numpy(dtype=int), pairs["HId"].to_numpy(dtype=int)
    gt_index = {(int(f), int(i)): k for k, (f, i) in enumerate(gt_rows[:, :2])}
    hyp_index = {(int(f), int(i)): k for k, (f, i) in enumerate(hyp_rows[:, :2])}
    gt_pick = np.array([gt_index[(f, o)] for f, o in zip(frames, gt_ids)], dtype=int)
    hyp_pick = np.array([hyp_index[(f, h)] for f, h in zip(frames, hyp_ids)], dtype=int)
    errors = np.linalg.norm(_centres(gt_rows[gt_pick]) - _centres(hyp_rows[hyp_pick]), axis=1)
    return np.column_stack([frames, gt_ids, hyp_ids, errors]).astype(np.float64).reshape(-1, 4)


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
    accumulator, gt_rows, hyp_rows, _ = _accumulate(gt, hyp, max_iou_distance)
    return _pairs(accumulator, gt_rows, hyp_rows)


def evaluate(gt: Any, hyp: Any, *, max_iou_distance: float = 0.5) -> Scores:
    """Score hypothesis tracks against ground truth (CLEAR MOT, IDF1, centre errors).

    Per frame: the hypotheses are matched (Hungarian algorithm on :func:`iou_distance`)
    against every ground-truth box; those matched to a box with flag 0 are dropped; the
    other hypotheses and the ground-truth boxes with a flag other than 0 go to a
    ``motmetrics.MOTAccumulator``, which carries matches over from the previous frames,
    then pairs the rest by the Hungarian algorithm, and counts identity switches, misses
    and false positives.  The summary comes from ``motmetrics.metrics``, except MOTP
    (reported as a mean IoU, see :class:`Scores`) and the centre errors, which are
    measured on the MATCH and SWITCH events of the accumulator.

    Parameters
    ----------
    gt : array_like, shape (N, 6..10)
        Ground-truth rows ``frame, id, x, y, w, h[, flag, ...]`` as read by
        :func:`read_mot`.  Rows whose flag is 0 are not scored; without a flag column,
        every row is.
    hyp : array_like, shape (M, 6..10)
        Tracker rows, same layout; the 7th column (a confidence) is not used.  May be
        empty.
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
    """
    accumulator, gt_rows, hyp_rows, ignored_predictions = _accumulate(gt, hyp, max_iou_distance)
    import motmetrics

    names = ["mota", "motp", "idf1", "precision", "recall", "num_switches", "num_false_positives",
             "num_misses", "num_detections", "num_objects", "num_predictions", "num_frames"]
    summary = motmetrics.metrics.create().compute(accumulator, metrics=names, name="tracks").iloc[0]

    centre_errors = _pairs(accumulator, gt_rows, hyp_rows)[:, 3]
    nan = float("nan")

    return Scores(
        mota=float(summary["mota"]),
        motp=1.0 - float(summary["motp"]) if summary["num_detections"] > 0 else nan,
        idf1=float(summary["idf1"]),
        precision=float(summary["precision"]),
        recall=float(summary["recall"]),
        id_switches=int(summary["num_switches"]),
        false_positives=int(summary["num_false_positives"]),
        false_negatives=int(summary["num_misses"]),
        matched_pairs=int(summary["num_detections"]),
        num_objects=int(summary["num_objects"]),
        num_predictions=int(summary["num_predictions"]),
        ignored_predictions=ignored_predictions,
        num_frames=int(summary["num_frames"]),
        mean_centre_error=float(np.mean(centre_errors)) if len(centre_errors) else nan,
        median_centre_error=float(np.median(centre_errors)) if len(centre_errors) else nan,
    )


# -- command line ----------------------------------------------------------------------------------------
def _cmd_eval(args: argparse.Namespace) -> int:
    tracks = read_mot(args.tracks)
    gt = read_mot(args.gt)
    scores = evaluate(gt, tracks)
    if args.json:
        print(json.dumps(scores.to_dict(), indent=2))
    else:
        print(scores.format_table())
    return 0


def register_eval(subparsers: Any) -> None:
    """Add the ``eval`` subcommand to a ``belief`` sub-parser collection.

    ``belief eval TRACKS.txt GT.txt [--json]`` prints the :class:`Scores` of the tracks
    against the ground truth, as a table or as JSON (:meth:`Scores.to_dict`).  Bad files
    raise :class:`~plugins.video_tracking.errors.TrackFileError`, which the ``belief``
    command line reports in one line.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        What ``ArgumentParser.add_subparsers`` returned.

    Examples
    --------
    >>> parser = argparse.ArgumentParser(prog="belief")
    >>> register_eval(parser.add_subparsers(dest="command"))
    >>> args = parser.parse_args(["eval", "tracks.txt", "gt.txt", "--json"])
    >>> args.tracks, args.gt, args.json
    ('tracks.txt', 'gt.txt', True)
    """
    p = subparsers.add_parser(
        "eval", help="score tracks against ground truth (MOTA, MOTP, IDF1, centre error)",
        description="Score MOTChallenge tracks against ground truth: CLEAR MOT (IoU >= 0.5), IDF1, "
                    "ID switches, false positives, misses and box-centre errors. Ground-truth rows "
                    "with flag 0 are not scored, and hypotheses matched to them are dropped. "
                    "MOTP is the mean IoU of the matched pairs.")
    p.add_argument("tracks", metavar="TRACKS.txt", help="tracker output, MOTChallenge CSV")
    p.add_argument("gt", metavar="GT.txt", help="ground truth, MOTChallenge CSV")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_eval)
