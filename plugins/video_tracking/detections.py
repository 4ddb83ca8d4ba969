"""Detections: a person detector's boxes and scores, frame by frame.

A :class:`Detections` holds, for each 1-based frame, an array of rows ``x, y, w, h, score``
in the tracker's 0-based pixels (top-left corner ``(x, y)``), with scores in [0, 1].  The
tracker reads them one frame at a time with :meth:`Detections.at`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from os import PathLike

import numpy as np

from .errors import DetectionFileError, TrackingError

__all__ = ["Detections", "DETECTION_COLUMNS", "read_detections", "write_detections", "check_detections",
           "check_rows"]

#: The columns of one frame's detections, 0-based pixels.
DETECTION_COLUMNS = ("x", "y", "w", "h", "score")

_EMPTY = np.zeros((0, len(DETECTION_COLUMNS)))
_EMPTY.flags.writeable = False


class Detections:
    """Boxes and scores of a detector, by 1-based frame.

    Parameters
    ----------
    by_frame : mapping of int to array_like, shape (n, 5)
        Each frame's rows ``x, y, w, h, score`` (0-based pixels, positive sizes, scores in
        [0, 1]).  Frames left out have no detection.
    source : str
        How messages name the detections (a file name, say).

    Examples
    --------
    >>> dets = Detections({2: [[10.0, 20.0, 8.0, 16.0, 0.9]]})
    >>> dets.at(2).tolist(), dets.at(1).shape, len(dets), dets.frames
    ([[10.0, 20.0, 8.0, 16.0, 0.9]], (0, 5), 1, (2,))
    """

    def __init__(self, by_frame: Mapping[int, Iterable] | None = None, source: str = "detections") -> None:
        self.source = source
        frames: dict[int, np.ndarray] = {}
        for frame, rows in (by_frame or {}).items():
            # A copy: the rows are made read-only, which must not reach the caller's own array.
            array = check_rows(np.array(rows, dtype=np.float64).reshape(-1, len(DETECTION_COLUMNS)),
                               f"{source}: frame {frame}")
            if len(array):
                array.flags.writeable = False
                frames[int(frame)] = array
        self._frames = dict(sorted(frames.items()))

    @classmethod
    def _checked(cls, frames: np.ndarray, rows: np.ndarray, source: str) -> "Detections":
        """Detections from rows ``x, y, w, h, score`` that the caller has checked, and the frame of each row.

        The rows of a frame keep their order; every frame's array is a read-only view of one array, so
        that a million detections take one allocation rather than one per frame.
        """
        order = np.argsort(frames, kind="stable")
        frames, rows = frames[order], np.ascontiguousarray(rows[order], dtype=np.float64)
        rows.flags.writeable = False
        starts = np.flatnonzero(np.concatenate([[True], frames[1:] != frames[:-1]]))
        stops = np.append(starts[1:], len(frames))
        detections = cls.__new__(cls)
        detections.source = source
        detections._frames = {int(frames[a]): rows[a:b] for a, b in zip(starts.tolist(), stops.tolist())}
        return detections

    def at(self, frame: int) -> np.ndarray:
        """The detections of 1-based ``frame``, shape (n, 5) (read-only; (0, 5) when there are none)."""
        return self._frames.get(int(frame), _EMPTY)

    @property
    def frames(self) -> tuple[int, ...]:
        """The frames that have at least one detection, in order."""
        return tuple(self._frames)

    def __len__(self) -> int:
        """The number of detections over all frames."""
        return sum(len(rows) for rows in self._frames.values())

    def __repr__(self) -> str:
        return f"Detections({len(self)} boxes over {len(self._frames)} frames from {self.source!r})"


def check_rows(rows, where: str) -> np.ndarray:
    """One frame's detections as a float (n, 5) array, or an error that says ``where`` and what is wrong.

    Rows are ``x, y, w, h, score``: finite, with positive sizes and scores in [0, 1].

    Examples
    --------
    >>> check_rows([[1, 2, 3, 4, 0.5]], "frame 1").tolist()
    [[1.0, 2.0, 3.0, 4.0, 0.5]]
    >>> check_rows([[1, 2, 3, 4, 1.5]], "frame 1")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    belief_tracking.errors.TrackingError: frame 1: detections must be finite rows x, y, w, h, score ...
    """
    array = np.asarray(rows, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != len(DETECTION_COLUMNS) or not np.isfinite(array).all() \
            or (array[:, 2:4] <= 0).any() or (array[:, 4] < 0).any() or (array[:, 4] > 1).any():
        raise TrackingError(f"{where}: detections must be finite rows x, y, w, h, score with positive sizes "
                            f"and scores in [0, 1]")
    return array


#: Fields a detection line must have: frame, id (unused, -1), x, y, w, h, score.
_DETECTION_FIELDS = 7


def _outside(x: float, y: float, w: float, h: float, width: int, height: int) -> bool:
    """Whether the 0-based box shares no pixel area with a ``width`` x ``height`` image."""
    return x + w <= 0 or y + h <= 0 or x >= width or y >= height


def _detection_table(frame_count: int | None, image_size: tuple[int, int] | None):
    """How :func:`read_detections` reads a line, and checks many rows at once, for a video of this size."""
    from .motfiles import MAX_COORDINATE, MAX_FRAME, MIN_BOX_SIZE, _Table, check_box, check_frame, parse_number

    def line(where: str, fields_: list[str]) -> list[float]:
        if len(fields_) < _DETECTION_FIELDS:
            raise DetectionFileError(f"{where}: expected at least {_DETECTION_FIELDS} fields "
                                     f"(frame,-1,x,y,w,h,score,...), got {len(fields_)}")
        values = []
        for column, field in enumerate(fields_[:_DETECTION_FIELDS], start=1):
            try:
                values.append(parse_number(field))
            except ValueError:
                raise DetectionFileError(f"{where}: field {column} is not a number: {field!r}") from None
        frame, _, x, y, w, h, score = values
        check_frame(frame, where, DetectionFileError, text=fields_[0])
        if frame_count is not None and frame > frame_count:
            raise DetectionFileError(f"{where}: frame {int(frame)} is after the end of the video "
                                     f"({int(frame_count)} frames)")
        if not (math.isfinite(x) and math.isfinite(y)):
            raise DetectionFileError(f"{where}: the corner {fields_[2]},{fields_[3]} is not finite")
        if not (math.isfinite(w) and math.isfinite(h) and w > 0 and h > 0):
            raise DetectionFileError(f"{where}: the box size {fields_[4]} x {fields_[5]} is not positive and finite")
        if w < MIN_BOX_SIZE or h < MIN_BOX_SIZE:
            raise DetectionFileError(f"{where}: the box size {fields_[4]} x {fields_[5]} is below {MIN_BOX_SIZE:g} px, "
                                     "the precision of a MOTChallenge file")
        check_box(x, y, w, h, where, DetectionFileError)
        if not 0.0 <= score <= 1.0:  # NaN fails both comparisons
            raise DetectionFileError(f"{where}: the score {fields_[6]} is outside [0, 1] (a detector's own "
                                     "scale must be mapped to [0, 1] first)")
        if image_size is not None and _outside(x - 1.0, y - 1.0, w, h, *image_size):
            raise DetectionFileError(f"{where}: the box {fields_[2]},{fields_[3]},{fields_[4]},{fields_[5]} is "
                                     f"wholly outside the {image_size[0]}x{image_size[1]} image")
        return values

    def bad_rows(rows: np.ndarray, _extra_finite: np.ndarray) -> np.ndarray:
        # The same tests as `line`, on every row at once; the fields after the score are not used.
        frame, x, y, w, h, score = rows[:, 0], rows[:, 2], rows[:, 3], rows[:, 4], rows[:, 5], rows[:, 6]
        with np.errstate(invalid="ignore"):
            bad = ~np.isfinite(frame) | (frame != np.floor(frame)) | (frame < 1) | (frame > MAX_FRAME)
            if frame_count is not None:
                bad |= frame > frame_count
            bad |= ~(np.isfinite(rows[:, 2:6]).all(axis=1) & (w > 0) & (h > 0))
            bad |= (w < MIN_BOX_SIZE) | (h < MIN_BOX_SIZE) | (np.abs(rows[:, 2:6]) > MAX_COORDINATE).any(axis=1)
            bad |= ~((score >= 0.0) & (score <= 1.0))
            if image_size is not None:
                width, height = image_size
                bad |= ((x - 1.0) + w <= 0) | ((y - 1.0) + h <= 0) | (x - 1.0 >= width) | (y - 1.0 >= height)
        return bad

    return _Table(_DETECTION_FIELDS, None, _DETECTION_FIELDS, math.nan, line, bad_rows)


def read_detections(path: str | PathLike[str], *, frame_count: int | None = None,
                    image_size: tuple[int, int] | None = None) -> Detections:
    """Read a MOTChallenge detection file (``det.txt``).

    Each non-blank line is ``frame,id,x,y,w,h,score[,...]``: at least 7 numbers separated by
    commas (or, if a line has no comma, by white space).  The id (-1 in MOTChallenge files)
    and the fields after the score are not used.  ``(x, y)`` is the 1-based top-left corner,
    as in every MOTChallenge file; the result is 0-based, as the tracker counts.  Numbers are
    read strictly (``1_0`` is not a number, as it is for Python), and the whole file at once
    (a million rows in about a second).

    Parameters
    ----------
    path : str or path-like
        A regular file of at most :data:`~belief_tracking.motfiles.MAX_TEXT_BYTES` bytes.
    frame_count : int, optional
        Number of frames of the video: a detection after it is an error.
    image_size : (int, int), optional
        ``(width, height)`` of the video's frames: a box wholly outside is an error.

    Returns
    -------
    Detections
        Named by the file's path.

    Raises
    ------
    DetectionFileError
        The file is missing, unreadable, not a regular file, larger than
        :data:`~belief_tracking.motfiles.MAX_TEXT_BYTES` or holds no detection, or a line (named with its
        number) has fewer than 7 fields, a field that is not a number, a frame that is not
        an integer from 1 to :data:`~belief_tracking.motfiles.MAX_FRAME` or is after
        ``frame_count``, a corner that is not finite, a width or height that is not a positive
        finite number or is below :data:`~belief_tracking.motfiles.MIN_BOX_SIZE`, a coordinate or size beyond
        :data:`~belief_tracking.motfiles.MAX_COORDINATE` pixels, a score outside [0, 1], or
        a box wholly outside the image.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "det.txt"
    >>> _ = path.write_text("1,-1,11,21,10,20,0.9,-1,-1,-1\\n\\n3,-1,1,1,5,8,0.25\\n")
    >>> dets = read_detections(path, frame_count=3, image_size=(64, 48))
    >>> dets.at(1).tolist(), dets.at(3).tolist(), dets.frames
    ([[10.0, 20.0, 10.0, 20.0, 0.9]], [[0.0, 0.0, 5.0, 8.0, 0.25]], (1, 3))
    >>> _ = path.write_text("1,-1,11,21,10,20,1.5\\n")
    >>> read_detections(path)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    belief_tracking.errors.DetectionFileError: .../det.txt, line 1: the score 1.5 is outside [0, 1] ...
    """
    from .motfiles import _read_table, read_table_text

    name = str(path)
    if frame_count is not None and (isinstance(frame_count, bool) or not isinstance(frame_count, (int, np.integer))
                                    or frame_count < 1):
        raise TrackingError(f"frame_count must be a positive integer or None, got {frame_count!r}")
    text = read_table_text(path, "detection file", DetectionFileError)
    rows, _ = _read_table(text, name, _detection_table(frame_count, image_size))
    if not len(rows):
        raise DetectionFileError(f"{name}: no detections in the file (it is empty)")
    return Detections._checked(rows[:, 0].astype(np.int64), rows[:, 2:7] - [1.0, 1.0, 0.0, 0.0, 0.0], name)


def write_detections(path: str | PathLike[str], detections: Detections) -> None:
    """Write detections as a MOTChallenge detection file, ``frame,-1,x,y,w,h,score,-1,-1,-1``.

    The corner is written 1-based, boxes to 0.001 px and scores to 1e-6, frame by frame, so
    :func:`read_detections` gives the detections back to that precision (and writing them
    again gives the same file).

    Raises
    ------
    TrackingError
        Not :class:`Detections`, or a box under 0.0005 px wide or high (it would be written
        as 0, which no reader accepts).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "det.txt"
    >>> write_detections(path, Detections({2: [[10.0, 20.5, 8.0, 16.0, 0.9]]}))
    >>> path.read_text()
    '2,-1,11.000,21.500,8.000,16.000,0.900000,-1,-1,-1\\n'
    >>> read_detections(path).at(2).tolist()
    [[10.0, 20.5, 8.0, 16.0, 0.9]]
    """
    if not isinstance(detections, Detections):
        raise TrackingError(f"write_detections needs Detections, got {type(detections).__name__}")
    for frame in detections.frames:
        if (detections.at(frame)[:, 2:4] < 0.0005).any():
            raise TrackingError(f"{detections.source}: frame {frame} has a box narrower or lower than 0.0005 px, "
                                "which the file's 0.001 px would write as 0")
    with open(path, "w", encoding="ascii", newline="\n") as handle:
        for frame in detections.frames:
            for x, y, w, h, score in detections.at(frame).tolist():
                handle.write(f"{frame},-1,{x + 1.0:.3f},{y + 1.0:.3f},{w:.3f},{h:.3f},{score:.6f},-1,-1,-1\n")


def check_detections(detections: Detections, *, frame_count: int | None = None,
                     image_size: tuple[int, int] | None = None) -> None:
    """Refuse detections that do not fit a video: after its last frame, or wholly outside its image.

    Parameters
    ----------
    detections : Detections
    frame_count : int, optional
        Number of frames of the video, if known.
    image_size : (int, int), optional
        ``(width, height)`` of the frames.

    Raises
    ------
    TrackingError
        Not :class:`Detections`, or the first detection that does not fit (named with its
        frame and the detections' source).

    Examples
    --------
    >>> dets = Detections({4: [[10.0, 20.0, 8.0, 16.0, 0.9]]}, source="det.txt")
    >>> check_detections(dets, frame_count=4, image_size=(64, 48))
    >>> check_detections(dets, frame_count=3)
    Traceback (most recent call last):
    ...
    belief_tracking.errors.DetectionFileError: det.txt: frame 4 is after the end of the video (3 frames)
    """
    if not isinstance(detections, Detections):
        raise TrackingError(f"detections must be Detections or None, got {type(detections).__name__}")
    frames = detections.frames
    if frame_count is not None and frames and frames[-1] > frame_count:
        raise DetectionFileError(f"{detections.source}: frame {frames[-1]} is after the end of the video "
                                 f"({int(frame_count)} frames)")
    if frames and frames[0] < 1:
        raise DetectionFileError(f"{detections.source}: frame {frames[0]} is before the first frame (1)")
    if image_size is not None:
        width, height = image_size
        for frame in frames:
            for x, y, w, h, _ in detections.at(frame).tolist():
                if _outside(x, y, w, h, width, height):
                    raise DetectionFileError(f"{detections.source}: frame {frame} has the box {x:g},{y:g},{w:g},"
                                             f"{h:g} (0-based) wholly outside the {width}x{height} image")
