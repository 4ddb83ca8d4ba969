"""Where the frames come from: a video file, a rendered scene or an array of frames.

:func:`open_source` gives a :class:`FrameSource`, which yields BGR ``uint8`` frames one by
one (a video is decoded lazily, so it never has to fit in memory) and knows the frame rate,
the size and, when the container says, the number of frames.  :meth:`FrameSource.spread`
picks frames evenly over the whole source, for the background model's warm-up.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from os import PathLike

import numpy as np

from plugins.video_tracking.errors import TrackingError

__all__ = ["FrameSource", "open_source"]


class FrameSource:
    """The frames of one source, with what a run needs to know about them.

    Use :func:`open_source` to make one.

    Attributes
    ----------
    name : str
        How messages and the run's summary name the source.
    width, height : int
        Frame size in pixels.
    fps : float
        Frame rate (25 when the source gives none).
    count : int or None
        Number of frames, if known.
    """

    def __init__(self, frames: Iterable[np.ndarray], *, name: str, width: int, height: int, fps: float,
                 count: int | None, reader=None, path: str | None = None) -> None:
        self._frames = frames
        self.name = name
        self.width, self.height = width, height
        self.fps = fps
        self.count = count
        self._reader = reader
        self._path = path

    def __iter__(self) -> Iterator[np.ndarray]:
        return iter(self._frames)

    @property
    def decode_seconds(self) -> float:
        """Time spent decoding the video so far (0 for frames already in memory)."""
        return self._reader.decode_seconds if self._reader is not None else 0.0

    def spread(self, count: int) -> Iterable[np.ndarray]:
        """Up to ``count`` frames spread evenly over the source (the first ones if its length is unknown).

        A video file is opened a second time for them, so the frames of the run are untouched.
        """
        total = self.count
        if total:
            picks = set(np.linspace(0, total - 1, num=min(count, total)).round().astype(int).tolist())
        else:
            picks = set(range(count))
        if self._path is None:
            frames = self._frames
            return (frames[k] for k in sorted(picks) if k < len(frames))  # type: ignore[index]
        from plugins.video_tracking.video import VideoReader

        path = self._path

        def read():
            with VideoReader(path) as reader:
                for k, image in enumerate(reader):
                    if k in picks:
                        yield image
                    if k >= max(picks):
                        break
        return read()

    def close(self) -> None:
        """Release the video file, if any."""
        if self._reader is not None:
            self._reader.close()

    def __enter__(self) -> FrameSource:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def open_source(source) -> FrameSource:
    """A :class:`FrameSource` for a video path, a rendered :class:`~plugins.video_tracking.scenes.Scene` or frames.

    Parameters
    ----------
    source : path, Scene or ndarray of uint8, shape (T, H, W, 3)

    Raises
    ------
    VideoError
        A video that cannot be opened or decoded.
    TrackingError
        Frames that are not a non-empty (T, H, W, 3) uint8 array.

    Examples
    --------
    >>> source = open_source(np.zeros((4, 6, 8, 3), np.uint8))
    >>> source.name, source.width, source.height, source.count, len(list(source))
    ('frames', 8, 6, 4, 4)
    >>> len(list(source.spread(2)))
    2
    """
    if isinstance(source, (str, PathLike)):
        from plugins.video_tracking.video import VideoReader

        reader = VideoReader(source)
        return FrameSource(reader, name=str(source), width=reader.width, height=reader.height, fps=reader.fps,
                           count=reader.frame_count, reader=reader, path=str(source))
    scene_config = getattr(source, "config", None)
    frames = np.asarray(getattr(source, "frames", source))
    if frames.ndim != 4 or frames.shape[3] != 3 or frames.dtype != np.uint8 or 0 in frames.shape:
        raise TrackingError(f"frames must be a (T, H, W, 3) uint8 array, got shape {frames.shape}")
    name = f"scene {scene_config.name!r}" if scene_config is not None else "frames"
    return FrameSource(frames, name=name, width=frames.shape[2], height=frames.shape[1], fps=25.0,
                       count=frames.shape[0])
