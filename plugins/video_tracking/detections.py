"""Detections: a person detector's boxes and scores, frame by frame.

A :class:`Detections` holds, for each 1-based frame, an array of rows ``x, y, w, h, score``
in the tracker's 0-based pixels (top-left corner ``(x, y)``), with scores in [0, 1].  The
tracker reads them one frame at a time with :meth:`Detections.at`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import numpy as np

from plugins.video_tracking.errors import TrackingError

__all__ = ["Detections", "DETECTION_COLUMNS"]

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
            array = np.asarray(rows, dtype=np.float64).reshape(-1, len(DETECTION_COLUMNS))
            if not np.isfinite(array).all() or (array[:, 2:4] <= 0).any() \
                    or (array[:, 4] < 0).any() or (array[:, 4] > 1).any():
                raise TrackingError(f"{source}: frame {frame} has a detection with a non-finite value, "
                                    f"a size that is not positive or a score outside [0, 1]")
            if len(array):
                array.flags.writeable = False
                frames[int(frame)] = array
        self._frames = dict(sorted(frames.items()))

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
