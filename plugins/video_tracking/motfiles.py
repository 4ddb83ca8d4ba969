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
import re
from collections.abc import Callable, Iterator, Sequence
from os import PathLike

import numpy as np

from .errors import TrackFileError
from .limits import regular_file

__all__ = ["MOT_COLUMNS", "MAX_FRAME", "MAX_ID", "MAX_COORDINATE", "MIN_BOX_SIZE", "MAX_TEXT_BYTES", "read_mot",
           "write_tracks", "text_lines", "check_frame", "check_box", "check_ground_truth", "parse_number",
           "read_table_text"]

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

#: The smallest width or height, in pixels, of a box that is not empty: the precision to which
#: boxes are written (0.001 px).  A box of 1e-300 px is no person, and would be written as 0 x 0.
MIN_BOX_SIZE = 1e-3

#: The largest text file, in bytes, that the readers of this module (and of
#: :mod:`~belief_tracking.detections`) accept: about five million rows, read in well under 2 GB.
#: The size is checked before the file is read; assign to it to raise the limit.
MAX_TEXT_BYTES = 256 * 2**20

# A number as the MOTChallenge files write it.  Python's float() also takes underscores between
# digits ("1_0" is 10), digits of other scripts and surrounding white space, none of which a
# detector writes: such a field is refused rather than read as a different number.
_NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
# Spelt-out infinities and NaN are read, so that the message says "not finite" rather than "not a number".
_NOT_FINITE = re.compile(r"[+-]?(?:inf|infinity|nan)", re.IGNORECASE)
# Line breaks of str.splitlines() other than \n and \r: a file holding one is read line by line.
_RARE_BREAKS = re.compile("[\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029]")


def parse_number(field: str) -> float:
    """A field of a MOTChallenge file as a float, read strictly; ValueError if it is not a number.

    Examples
    --------
    >>> parse_number("-1.5e2"), parse_number("inf")
    (-150.0, inf)
    >>> parse_number("1_0")
    Traceback (most recent call last):
    ...
    ValueError: not a number: '1_0'
    """
    if not (_NUMBER.fullmatch(field) or _NOT_FINITE.fullmatch(field)):
        raise ValueError(f"not a number: {field!r}")
    return float(field)


def read_table_text(path: str | PathLike[str], what: str, error: type[Exception] = TrackFileError) -> str:
    """The text of a regular file of at most :data:`MAX_TEXT_BYTES` bytes, or ``error`` naming ``what`` and the path.

    The file's kind and size are checked before it is opened, so a FIFO, a device such as
    ``/dev/zero`` or a file of gigabytes is refused at once rather than read until the memory is
    full; a file that grows while it is read is refused at the limit.  The text is UTF-8, with
    or without a byte-order mark.

    Examples
    --------
    >>> read_table_text("no-such-file.txt", "track file")
    Traceback (most recent call last):
    ...
    belief_tracking.errors.TrackFileError: cannot read track file 'no-such-file.txt': no such file
    """
    name = str(path)
    status = regular_file(path, what, error)
    if status.st_size > MAX_TEXT_BYTES:
        raise error(_too_large(what, name, f"{status.st_size:,} bytes"))
    try:
        with open(path, "rb") as handle:
            data = handle.read(MAX_TEXT_BYTES + 1)
    except OSError as exc:
        raise error(f"cannot read {what} {name!r}: {exc.strerror or exc}") from None
    if len(data) > MAX_TEXT_BYTES:
        raise error(_too_large(what, name, "more bytes than that"))
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise error(f"cannot read {what} {name!r}: not UTF-8 text") from None


def _too_large(what: str, name: str, size: str) -> str:
    return (f"cannot read {what} {name!r}: it holds {size}, more than "
            f"belief_tracking.motfiles.MAX_TEXT_BYTES = {MAX_TEXT_BYTES:,}; split the file or raise the limit")


def _fields(stripped: str) -> list[str]:
    return [f.strip() for f in stripped.split(",")] if "," in stripped else stripped.split()


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
            yield line_number, f"{name}, line {line_number}", _fields(stripped)


# -- vectorised reading ------------------------------------------------------------------------------
# A file is read in blocks of whole lines of about this many characters: the arrays of one
# block's scan take a few times its size, so the memory of a read is the text and its rows.
_BLOCK = 1 << 21

# Character classes of the scan: a byte of another class sends its block to the line-by-line reader.
_OTHER, _DIGIT, _DOT, _SIGN, _EXP, _BLANK, _COMMA, _NEWLINE = range(8)
_CLASSES = np.zeros(256, dtype=np.uint8)
_CLASSES[np.frombuffer(b"0123456789", np.uint8)] = _DIGIT
_CLASSES[ord(".")], _CLASSES[ord("+")], _CLASSES[ord("-")] = _DOT, _SIGN, _SIGN
_CLASSES[ord("e")] = _CLASSES[ord("E")] = _EXP
_CLASSES[ord(" ")] = _CLASSES[ord("\t")] = _BLANK
_CLASSES[ord(",")], _CLASSES[ord("\n")] = _COMMA, _NEWLINE
# A mantissa of at most 18 digits fits an int64, and 10^k is exact in a float for k <= 22.
_POW10_INT = np.array([10**k for k in range(18)], dtype=np.int64)
_POW10 = np.array([float(10**k) for k in range(23)])


def _scan(block: str) -> tuple[np.ndarray, np.ndarray] | None:
    """The numbers of a block of whole lines and the count of fields of each line, or None.

    ``block`` ends with a newline.  Returns ``(values, counts)``: every field's value in
    order, and for each line (blank ones included) its number of fields.  None when a byte is not
    of a number, a blank, a comma or a newline, a line is not numbers separated either by
    commas (with optional blanks) or by blanks, or a field is not a number; such a block is read
    line by line, which names the error.
    """
    if not block.isascii():
        return None
    data = np.frombuffer(block.encode("ascii"), dtype=np.uint8)
    kind = np.take(_CLASSES, data)
    if not kind.all():                                 # _OTHER is 0
        return None
    in_token = kind <= _EXP
    first = in_token.copy()
    first[1:] &= ~in_token[:-1]
    starts = np.flatnonzero(first)
    is_newline = kind == _NEWLINE
    newlines = np.flatnonzero(is_newline)
    # Running counts of newlines and commas, read at each field's first byte and at each newline.
    line_of_token = np.cumsum(is_newline, dtype=np.int32)[starts]
    counts = np.bincount(line_of_token, minlength=len(newlines))

    # A line with a comma: exactly one comma between two fields, and one fewer commas than fields.
    is_comma = kind == _COMMA
    if is_comma.any():
        running = np.cumsum(is_comma, dtype=np.int32)
        per_line = np.diff(running[newlines], prepend=0)
        if ((per_line > 0) & (per_line != counts - 1)).any():
            return None
        between = np.diff(running[starts])
        same_line = line_of_token[1:] == line_of_token[:-1]
        if (same_line & (between != (per_line[line_of_token[1:]] > 0))).any():
            return None
    if len(starts) == 0:
        return np.zeros(0), counts
    values = _numbers(block, data, kind, first, starts)
    return None if values is None else (values, counts)


def _numbers(block: str, data: np.ndarray, kind: np.ndarray, first: np.ndarray, starts: np.ndarray) -> np.ndarray | None:
    """The value of every field of a block whose bytes are of numbers, blanks, commas and newlines, or None.

    A field is ``[+-]? (digits [. digits?] | . digits) ([eE] [+-]? digits)?``, else None.  A
    mantissa of at most 18 digits is formed exactly as an int64; if it is at most 2^53 and its
    power of ten at most 22, one IEEE multiplication or division by that power gives the correctly
    rounded float (Clinger's fast path), which is what float() gives.  Other fields are given to
    float() one by one.
    """
    in_token = kind <= _EXP
    last = in_token.copy()
    last[:-1] &= ~in_token[1:]
    ends = np.flatnonzero(last) + 1
    tokens = len(starts)
    # Signs only first or right after the exponent mark, at most one point and one mark, the point first.
    sign_at = np.flatnonzero(kind == _SIGN)
    if len(sign_at) and not (first[sign_at] | (kind[np.maximum(sign_at - 1, 0)] == _EXP)).all():
        return None
    dot_at = np.flatnonzero(kind == _DOT)
    exp_at = np.flatnonzero(kind == _EXP)
    dot_token = np.searchsorted(starts, dot_at, side="right") - 1
    if (dot_token[1:] == dot_token[:-1]).any():
        return None
    has_sign = kind[starts] == _SIGN
    dot_position = np.full(tokens, -1, dtype=np.int64)
    dot_position[dot_token] = dot_at
    mantissa_end = ends.astype(np.int64)
    exponent_digits = np.zeros(tokens, dtype=np.int64)
    if len(exp_at):
        exp_token = np.searchsorted(starts, exp_at, side="right") - 1
        if (exp_token[1:] == exp_token[:-1]).any() or (dot_position[exp_token] > exp_at).any():
            return None
        mantissa_end[exp_token] = exp_at
        exponent_digits[exp_token] = ends[exp_token] - exp_at - 1 - (kind[exp_at + 1] == _SIGN)
        if (exponent_digits[exp_token] < 1).any():
            return None
    mantissa_digits = mantissa_end - starts - has_sign - (dot_position >= 0)
    if (mantissa_digits < 1).any():
        return None
    fraction_digits = np.where(dot_position >= 0, mantissa_end - dot_position - 1, 0)

    # Each digit times ten to the number of digits after it, in its mantissa or exponent.
    fast = (mantissa_digits <= 18) & (exponent_digits <= 4)
    digits = mantissa_digits + exponent_digits
    digit_at = np.flatnonzero(kind == _DIGIT)
    digit_token = np.repeat(np.arange(tokens), digits)
    end_of_part = mantissa_end[digit_token]
    rank = end_of_part - digit_at - 1 - (dot_position[digit_token] > digit_at)
    if len(exp_at):
        in_mantissa = digit_at < end_of_part
        rank = np.where(in_mantissa, rank, ends[digit_token] - digit_at - 1)
    usable = np.repeat(fast, digits)
    rank[~usable] = 0
    value_of_digit = (data[digit_at] - 48).astype(np.int64) * _POW10_INT[rank]
    first_digit = np.cumsum(digits) - digits
    if len(exp_at):
        mantissa = np.add.reduceat(np.where(in_mantissa, value_of_digit, 0), first_digit)
        exponent = np.add.reduceat(np.where(in_mantissa, 0, value_of_digit), first_digit)
        with_exp = np.flatnonzero(exponent_digits > 0)
        exponent[with_exp] *= np.where(data[mantissa_end[with_exp] + 1] == ord("-"), -1, 1)
        scale = exponent - fraction_digits
    else:
        mantissa = np.add.reduceat(value_of_digit, first_digit)
        scale = -fraction_digits
    fast &= (mantissa <= 2**53) & (np.abs(scale) <= 22)
    magnitude = mantissa.astype(np.float64)
    power = _POW10[np.minimum(np.abs(scale), 22)]
    values = np.where(scale >= 0, magnitude * power, magnitude / power)
    values = np.where(has_sign & (data[starts] == ord("-")), -values, values)
    slow = np.flatnonzero(~fast)
    if len(slow):
        values[slow] = [float(block[a:b]) for a, b in zip(starts[slow].tolist(), ends[slow].tolist())]
    return values


class _Table:
    """How one kind of file is read: its fields, the strict reading of a line, the check of many rows at once."""

    def __init__(self, min_fields: int, max_fields: int | None, columns: int, pad: float,
                 line: Callable[[str, list[str]], list[float]],
                 bad_rows: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> None:
        self.min_fields, self.max_fields, self.columns, self.pad = min_fields, max_fields, columns, pad
        self.line, self.bad_rows = line, bad_rows


def _read_lines(block: str, first_line: int, name: str, table: _Table):
    """The rows of a block read line by line: (rows, line numbers, the error of the first bad line or None)."""
    rows, numbers = [], []
    for line_number, line in enumerate(block.splitlines(), start=first_line):
        stripped = line.strip()
        if not stripped:
            continue
        try:
            rows.append(table.line(f"{name}, line {line_number}", _fields(stripped)))
        except TrackFileError as exc:
            return rows, numbers, exc
        numbers.append(line_number)
    return rows, numbers, None


def _read_block(block: str, first_line: int, name: str, table: _Table):
    """The rows of a block of whole lines (ending with a newline): vectorised, else line by line."""
    scanned = _scan(block)
    if scanned is not None:
        values, counts = scanned
        filled = np.flatnonzero(counts)
        used = counts[filled]
        if (used >= table.min_fields).all() and (table.max_fields is None or (used <= table.max_fields).all()):
            offsets = np.cumsum(used) - used
            rows = np.full((len(filled), table.columns), table.pad)
            for column in range(table.columns):
                has = used > column
                rows[has, column] = values[offsets[has] + column]
            # Fields after the kept columns: a row whose every one is finite.
            extra = np.ones(len(filled), dtype=bool)
            if (used > table.columns).any():
                bad = ~np.isfinite(values)
                position = np.arange(len(values)) - np.repeat(offsets, used)
                owner = np.repeat(np.arange(len(filled)), used)
                extra = np.bincount(owner[bad & (position >= table.columns)], minlength=len(filled)) == 0
            if not table.bad_rows(rows, extra).any():
                return rows, filled + first_line, None
    rows, numbers, error = _read_lines(block, first_line, name, table)
    return (np.asarray(rows, dtype=np.float64).reshape(-1, table.columns), np.asarray(numbers, dtype=np.int64),
            error)


def _read_table(text: str, name: str, table: _Table, repeats: Callable | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The rows of a whole file and their line numbers; raises the error of the first bad line.

    ``repeats(rows, lines)``, if given, returns the error of the first line that repeats an
    earlier one (the id twice in one frame), or None; a repeat before a bad line is the error.
    """
    if _RARE_BREAKS.search(text):
        blocks = [text]                                # only str.splitlines() numbers such lines as before
    else:
        if "\r" in text:
            text = text.replace("\r\n", "\n").replace("\r", "\n")
        blocks = []
        start = 0
        while start < len(text):
            stop = text.find("\n", min(start + _BLOCK, len(text)) - 1)
            stop = len(text) if stop < 0 else stop + 1
            blocks.append(text[start:stop])
            start = stop
    all_rows, all_lines = [], []
    first_line = 1
    for block in blocks:
        ended = block if block.endswith("\n") else block + "\n"
        rows, lines, error = _read_block(ended, first_line, name, table)
        all_rows.append(rows)
        all_lines.append(lines)
        if error is not None:
            if repeats is not None:
                repeat = repeats(np.concatenate(all_rows), np.concatenate(all_lines))
                if repeat is not None:
                    raise repeat
            raise error
        first_line += ended.count("\n")
    rows = np.concatenate(all_rows) if all_rows else np.zeros((0, table.columns))
    lines = np.concatenate(all_lines) if all_lines else np.zeros(0, dtype=np.int64)
    if repeats is not None:
        repeat = repeats(rows, lines)
        if repeat is not None:
            raise repeat
    return rows, lines


# -- track and ground-truth files --------------------------------------------------------------------
def _mot_line(where: str, fields_: list[str]) -> list[float]:
    """One line of a track or ground-truth file read strictly: its 7 columns, or TrackFileError."""
    if not _MIN_FIELDS <= len(fields_) <= _MAX_FIELDS:
        raise TrackFileError(
            f"{where}: expected {_MIN_FIELDS} to {_MAX_FIELDS} fields "
            f"(frame,id,x,y,w,h,flag,...), got {len(fields_)}")
    values = []
    for column, field in enumerate(fields_, start=1):
        try:
            value = parse_number(field)
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
    if 0 < width < MIN_BOX_SIZE or 0 < height < MIN_BOX_SIZE:
        raise TrackFileError(f"{where}: the box size {fields_[4]} x {fields_[5]} is above 0 but below "
                             f"{MIN_BOX_SIZE:g} px, the precision of a MOTChallenge file")
    check_box(x, y, width, height, where)
    return values[:7] if len(values) > 6 else values + [1.0]


def _bad_mot_rows(rows: np.ndarray, extra_finite: np.ndarray) -> np.ndarray:
    frame, track_id, size = rows[:, _FRAME], rows[:, _ID], rows[:, [_W, _H]]
    with np.errstate(invalid="ignore"):
        bad = ~extra_finite | ~np.isfinite(rows).all(axis=1)
        bad |= (frame != np.floor(frame)) | (frame < 1) | (frame > MAX_FRAME)
        bad |= (track_id != np.floor(track_id)) | (np.abs(track_id) > MAX_ID)
        bad |= (size < 0).any(axis=1) | ((size > 0) & (size < MIN_BOX_SIZE)).any(axis=1)
        bad |= (np.abs(rows[:, _X:_FLAG]) > MAX_COORDINATE).any(axis=1)
    return bad


_MOT_TABLE = _Table(_MIN_FIELDS, _MAX_FIELDS, len(MOT_COLUMNS), 1.0, _mot_line, _bad_mot_rows)


def _repeated_id(name: str) -> Callable[[np.ndarray, np.ndarray], TrackFileError | None]:
    """The check of :func:`_read_table` for an id given twice in one frame."""
    def repeats(rows: np.ndarray, lines: np.ndarray) -> TrackFileError | None:
        if len(rows) < 2:
            return None
        keys = rows[:, _FRAME].astype(np.int64) * 2**32 + (rows[:, _ID].astype(np.int64) + MAX_ID)
        order = np.argsort(keys, kind="stable")
        ordered = keys[order]
        repeated = np.zeros(len(keys), dtype=bool)
        repeated[order[1:]] = ordered[1:] == ordered[:-1]
        if not repeated.any():
            return None
        row = int(np.flatnonzero(repeated)[0])
        first = int(order[np.searchsorted(ordered, keys[row])])
        return TrackFileError(f"{name}, line {int(lines[row])}: frame {int(rows[row, _FRAME])} has id "
                              f"{int(rows[row, _ID])} twice (first on line {int(lines[first])})")
    return repeats


def read_mot(path: str | PathLike[str], *, allow_empty: bool = False, what: str = "track file") -> np.ndarray:
    """Read a MOTChallenge track or ground-truth file.

    Each non-blank line is ``frame,id,x,y,w,h[,flag[,a[,b[,c]]]]``: 6 to 10 numbers
    separated by commas (or, if a line has no comma, by white space).  Columns past the
    7th (class and visibility, or world coordinates) are checked to be numbers and
    dropped.  Numbers are read strictly (``1_0`` is not a number, as it is for Python), and
    the whole file at once (a million rows in about a second).

    Parameters
    ----------
    path : str or path-like
        The file to read: a regular file of at most :data:`MAX_TEXT_BYTES` bytes.
    allow_empty : bool, default False
        Accept a file without any box (tracks of a run that found nobody) and return no
        rows; a ground truth without boxes stays an error.
    what : str, default "track file"
        What the file is, in messages ("ground-truth file", say).

    Returns
    -------
    rows : ndarray of float, shape (N, 7)
        One row per box, columns :data:`MOT_COLUMNS`: frame, id, x, y, width, height,
        flag (1 where the file has only 6 columns), in file order.

    Raises
    ------
    TrackFileError
        The file is missing, unreadable, not a regular file or larger than :data:`MAX_TEXT_BYTES`,
        holds no rows (unless ``allow_empty``), or a line (named with its
        number) has the wrong number of fields, a field that is not a finite number, a
        frame that is not an integer from 1 to :data:`MAX_FRAME`, an id that is not an
        integer of magnitude at most :data:`MAX_ID`, a negative width or height, or one above 0
        but below :data:`MIN_BOX_SIZE`, a box
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
    text = read_table_text(path, what, TrackFileError)
    rows, _ = _read_table(text, name, _MOT_TABLE, _repeated_id(name))
    if not len(rows) and not allow_empty:
        raise TrackFileError(f"{name}: no boxes in the file (it is empty)")
    return np.ascontiguousarray(rows, dtype=np.float64).reshape(-1, len(MOT_COLUMNS))


def check_ground_truth(rows: np.ndarray, frame_count: int | None, source: str = "the ground truth") -> None:
    """Refuse ground-truth rows after the last frame of the video (``frame_count`` frames; None: unknown).

    Examples
    --------
    >>> gt = np.array([[1, 7, 10, 20, 30, 40, 1], [5, 7, 12, 20, 30, 40, 1]])
    >>> check_ground_truth(gt, 5)
    >>> check_ground_truth(gt, 4, "gt.txt")
    Traceback (most recent call last):
    ...
    belief_tracking.errors.TrackFileError: gt.txt: frame 5 is after the end of the video (4 frames)
    """
    rows = np.asarray(rows, dtype=np.float64)
    if frame_count is not None and rows.ndim == 2 and len(rows) and rows[:, _FRAME].max() > frame_count:
        raise TrackFileError(f"{source}: frame {int(rows[:, _FRAME].max())} is after the end of the video "
                             f"({int(frame_count)} frames)")


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
