"""MOTChallenge text files: reading track, ground-truth and box rows, writing tracks.

A MOTChallenge file has one box per line, ``frame,id,x,y,w,h[,flag,...]``, with 1-based
frames and the box's top-left corner ``(x, y)`` and size ``(w, h)`` in pixels (1-based:
the top-left pixel of the image is at (1, 1)).  The tracker works in 0-based pixels and
converts at these readers and writers.

Every value is checked to lie in a sane range (:data:`MAX_FRAME`, :data:`MAX_ID`,
:data:`MAX_COORDINATE`): a frame or id that no array of machine integers holds, or a box of
1e308 pixels, is an error naming the file, the line and the value, not an overflow later.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from os import PathLike

import numpy as np

from belief.textfiles import read_text
from .errors import TrackFileError

__all__ = ["MOT_COLUMNS", "MAX_FRAME", "MAX_ID", "MAX_COORDINATE", "read_mot", "write_tracks", "text_lines",
           "check_frame", "check_box"]

#: Columns of the array returned by :func:`read_mot`.  ``flag`` is the 7th column of the
#: file: for ground truth, 0 means "not scored"; for tracker output it is a confidence,
#: which the evaluation does not use.  Files with only 6 columns get a flag of 1.
MOT_COLUMNS = ("frame", "id", "x", "y", "width", "height", "flag")

_FRAME, _ID, _X, _Y, _W, _H, _FLAG = range(len(MOT_COLUMNS))

#: The largest frame number of a file (frames count from 1): 2^31 - 1.
MAX_FRAME = 2**31 - 1
#: The largest magnitude of an id: ids are integers in [-MAX_ID, MAX_ID].
MAX_ID = 2**31 - 1
#: The largest magnitude, in pixels, of a box corner coordinate, width or height.  Far beyond
#: any image, and small enough that sums and products of coordinates never overflow.
MAX_COORDINATE = 1e6


def check_frame(value: float, where: str, error: type[Exception] = TrackFileError, text: str | None = None) -> int:
    """A frame number of a file as an int: an integer from 1 to :data:`MAX_FRAME`, else ``error`` naming ``where``.

    Examples
    --------
    >>> check_frame(3.0, "f.txt, line 1")
    3
    >>> check_frame(0.0, "f.txt, line 1")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    belief_tracking.errors.TrackFileError: f.txt, line 1: the frame must be an integer of at least 1, got 0 (...)
    """
    if not (math.isfinite(value) and value == int(value) and 1 <= value <= MAX_FRAME):
        shown = text if text is not None else f"{value:g}"
        bound = f"at most {MAX_FRAME}" if math.isfinite(value) and value > MAX_FRAME else "frames count from 1"
        raise error(f"{where}: the frame must be an integer of at least 1, got {shown} ({bound})")
    return int(value)


def check_box(x: float, y: float, w: float, h: float, where: str, error: type[Exception] = TrackFileError) -> None:
    """Raise ``error`` naming ``where`` if a coordinate or size of a box exceeds :data:`MAX_COORDINATE` pixels."""
    for label, value in (("x", x), ("y", y), ("width", w), ("height", h)):
        if not math.isfinite(value) or abs(value) > MAX_COORDINATE:
            raise error(f"{where}: the box {label} {value:g} is beyond {MAX_COORDINATE:g} pixels")


_MIN_FIELDS, _MAX_FIELDS = 6, 10


def text_lines(text: str, name: str) -> Iterator[tuple[int, str, list[str]]]:
    """The fields of each non-blank line of a MOTChallenge text file, with where the line is.

    Fields are separated by commas (or, in a file without commas, by blanks).  Yields
    ``(N, where, fields)`` with the 1-based line number N and ``where`` = ``"NAME, line N"``,
    for messages.

    Examples
    --------
    >>> list(text_lines("1, 2,3\\n\\n4 5", "f.txt"))
    [(1, 'f.txt, line 1', ['1', '2', '3']), (3, 'f.txt, line 3', ['4', '5'])]
    """
    for line_number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if stripped:
            fields = [f.strip() for f in stripped.split(",")] if "," in stripped else stripped.split()
            yield line_number, f"{name}, line {line_number}", fields


def read_mot(path: str | PathLike[str], *, allow_empty: bool = False) -> np.ndarray:
    """Read a MOTChallenge track or ground-truth file.

    Each non-blank line is ``frame,id,x,y,w,h[,flag[,a[,b[,c]]]]``: 6 to 10 numbers
    separated by commas (or, if a line has no comma, by white space).  Columns past the
    7th (class and visibility, or world coordinates) are checked to be numbers and
    dropped.

    Parameters
    ----------
    path : str or path-like
        The file to read.
    allow_empty : bool, default False
        Accept a file without any box (tracks of a run that found nobody) and return no
        rows; a ground truth without boxes stays an error.

    Returns
    -------
    rows : ndarray of float, shape (N, 7)
        One row per box, columns :data:`MOT_COLUMNS`: frame, id, x, y, width, height,
        flag (1 where the file has only 6 columns), in file order.

    Raises
    ------
    TrackFileError
        The file is missing or unreadable, holds no rows (unless ``allow_empty``), or a line (named with its
        number) has the wrong number of fields, a field that is not a finite number, a
        frame that is not an integer from 1 to :data:`MAX_FRAME`, an id that is not an
        integer of magnitude at most :data:`MAX_ID`, a negative width or height, a box
        coordinate or size beyond :data:`MAX_COORDINATE` pixels, or repeats the id of an
        earlier line of the same frame.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = pathlib.Path(folder) / "gt.txt"
    ...     _ = path.write_text("1,7,10,20,30,40,1,-1,-1,-1\\n2,7,12,20,30,40,0,-1,-1,-1\\n")
    ...     read_mot(path)
    array([[ 1.,  7., 10., 20., 30., 40.,  1.],
           [ 2.,  7., 12., 20., 30., 40.,  0.]])
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = pathlib.Path(folder) / "tracks.txt"
    ...     _ = path.write_text("")
    ...     read_mot(path, allow_empty=True).shape
    (0, 7)
    """
    name = str(path)
    text = read_text(path, "track file", TrackFileError, encoding="utf-8-sig")

    rows: list[list[float]] = []
    first_line_of: dict[tuple[int, int], int] = {}
    for line_number, where, fields_ in text_lines(text, name):
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
        frame, track_id, x, y, width, height = values[:6]
        check_frame(frame, where, text=fields_[0])
        if track_id != int(track_id) or abs(track_id) > MAX_ID:
            raise TrackFileError(f"{where}: the id must be an integer from {-MAX_ID} to {MAX_ID}, "
                                 f"got {fields_[1]}")
        if width < 0 or height < 0:
            raise TrackFileError(f"{where}: negative box size {width:g} x {height:g}")
        check_box(x, y, width, height, where)
        key = (int(frame), int(track_id))
        if key in first_line_of:
            raise TrackFileError(
                f"{where}: frame {key[0]} has id {key[1]} twice (first on line {first_line_of[key]})")
        first_line_of[key] = line_number
        rows.append(values[:7] if len(values) > 6 else values + [1.0])
    if not rows and not allow_empty:
        raise TrackFileError(f"{name}: no boxes in the file (it is empty)")
    return np.asarray(rows, dtype=float).reshape(-1, len(MOT_COLUMNS))


def write_tracks(path: str | PathLike[str], rows: Sequence[Sequence[float]]) -> None:
    """Write MOTChallenge rows ``frame,id,x,y,w,h,-1,-1,-1,-1`` (frames and ids as integers, boxes to 0.001 px).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = pathlib.Path(folder) / "tracks.txt"
    ...     write_tracks(path, [[1, 7, 10.0, 20.5, 30.0, 40.0]])
    ...     path.read_text()
    '1,7,10.000,20.500,30.000,40.000,-1,-1,-1,-1\\n'
    """
    with open(path, "w", encoding="ascii", newline="\n") as handle:
        for row in rows:
            frame, track_id, x, y, w, h = row[:6]
            handle.write(f"{int(frame)},{int(track_id)},{x:.3f},{y:.3f},{w:.3f},{h:.3f},-1,-1,-1,-1\n")
