"""Video input and output with OpenCV, kept at the edge of the plugin.

:class:`VideoReader` decodes a file frame by frame (BGR ``uint8`` arrays) and times the
decoding, so a run can report its tracking speed without it; :class:`ImageSequenceReader`
does the same for a list of image files (a folder of images, a MOTChallenge sequence or a
numbered file pattern); :class:`AnnotatedVideoWriter` draws the tracked boxes and ids on the
frames and writes a Motion-JPEG ``.avi``.
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
import time
from collections.abc import Iterator, Sequence
from os import PathLike
from pathlib import Path

import numpy as np

from . import limits
from .errors import VideoError
from .extras import require
from .limits import shown

cv2 = require("cv2")

__all__ = ["VideoReader", "ImageSequenceReader", "AnnotatedVideoWriter", "track_colour"]


class VideoReader:
    """Frames of a video file, decoded lazily.

    The first frame is decoded on opening, so a missing, unreadable or empty file fails
    at once with a one-line :class:`VideoError`, before any output is written.  Iteration
    stops at the first frame that cannot be decoded (the end of a truncated file, or a
    corrupt frame: the frames after it cannot be numbered with certainty); :attr:`decoded`
    then tells how many frames came out, to compare with :attr:`frame_count`.  FFmpeg's own
    messages about the broken data are kept off standard error
    (:data:`belief_tracking.extras.FFMPEG_QUIET`), and so are those that OpenCV's other
    readers write straight to it while they try a file that FFmpeg refused.

    Parameters
    ----------
    path : str or path-like

    Attributes
    ----------
    width, height : int
        Frame size in pixels.
    fps : float
        Frame rate stored in the file (25 if the file gives none).
    frame_count : int or None
        Number of frames the container announces (may be None or approximate).
    decode_seconds : float
        Time spent decoding so far.
    decoded : int
        Frames decoded so far.
    """

    def __init__(self, path: str | PathLike[str]) -> None:
        self.path = str(path)
        name = shown(self.path)
        # A FIFO would block OpenCV's open and /dev/zero would be read without end: regular files only.
        limits.regular_file(path, "video", VideoError)
        self._capture = None
        with _quiet_native_stderr():
            self._capture = cv2.VideoCapture(self.path)
        if not self._capture.isOpened():
            raise VideoError(f"cannot read video {name}: OpenCV cannot open it (not a video, or an "
                             "unsupported codec)")
        self.decode_seconds = 0.0
        self.decoded = 0
        try:
            # The container's size is checked before a frame is decoded: one frame of 10 000 x 10 000 is 300 MB.
            width, height = (_property(self._capture, prop) for prop in (cv2.CAP_PROP_FRAME_WIDTH,
                                                                          cv2.CAP_PROP_FRAME_HEIGHT))
            if width and height:
                limits.check_pixels(int(width), int(height), f"video {name}")
            count = _property(self._capture, cv2.CAP_PROP_FRAME_COUNT)
            self.frame_count = int(count) if count and count >= 1 else None
            if self.frame_count is not None:
                limits.check_frames(self.frame_count, f"video {name}", "frames announced by its container")
            first = self._read()
            if first is None:
                raise VideoError(f"cannot read video {name}: no frame could be decoded")
            self.height, self.width = first.shape[:2]
            limits.check_pixels(self.width, self.height, f"video {name}")
        except BaseException:
            self.close()
            raise
        self._first: np.ndarray | None = first
        fps = _property(self._capture, cv2.CAP_PROP_FPS)
        # A damaged container may claim any rate; an absurd one is taken for none.
        self.fps = fps if fps and 0 < fps <= limits.MAX_FPS else 25.0

    def _read(self) -> np.ndarray | None:
        start = time.perf_counter()
        with _quiet_native_stderr():
            ok, frame = self._capture.read()
        self.decode_seconds += time.perf_counter() - start
        if not ok or frame is None:
            return None
        self.decoded += 1
        if frame.ndim == 2:
            frame = cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR)
        return np.ascontiguousarray(frame[:, :, :3], dtype=np.uint8)

    def __iter__(self) -> Iterator[np.ndarray]:
        if self._first is not None:
            first, self._first = self._first, None
            yield first
        while True:
            frame = self._read()
            if frame is None:
                return
            if frame.shape[:2] != (self.height, self.width):
                raise VideoError(f"{limits.clipped(self.path)}: a frame of size {frame.shape[1]}x{frame.shape[0]} in a "
                                 f"{self.width}x{self.height} video")
            yield frame

    def close(self) -> None:
        """Release the file."""
        if self._capture is not None:
            self._capture.release()

    def __enter__(self) -> VideoReader:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _property(capture, prop: int) -> float:
    """A property of a capture as a finite float, 0 when OpenCV gives none or a non-finite one."""
    try:
        value = float(capture.get(prop) or 0.0)
    except (TypeError, ValueError, OverflowError):
        return 0.0
    return value if math.isfinite(value) else 0.0


@contextlib.contextmanager
def _quiet_native_stderr() -> Iterator[None]:
    """Send what native code writes to file descriptor 2 to the null device for the time of the block.

    OpenCV's readers of other containers (its Motion-JPEG AVI parser, for one) print to the
    process's standard error when they meet a damaged file, past Python and past any log
    level; the command line owes its user one line.  Python's own ``sys.stderr`` is left
    alone, and nothing is silenced where descriptor 2 cannot be duplicated.
    """
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError, AttributeError):
        yield
        return
    try:
        null = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(null, 2)
        finally:
            os.close(null)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


class ImageSequenceReader:
    """Frames of a list of image files, decoded lazily, one file a frame.

    The first image is decoded on opening, so an unreadable first image fails at once; a
    later image that cannot be decoded, or whose size differs from the first one, raises a
    one-line :class:`VideoError` naming that file when its turn comes.  Iterating again
    starts from the first image again.

    Parameters
    ----------
    files : sequence of str or path-like
        The images, in frame order (at least one).
    name : str
        How messages name the sequence (its folder or pattern).
    fps : float
        Frame rate to report (image files carry none).
    size : (int, int), optional
        ``(width, height)`` that the images must have (a MOTChallenge ``seqinfo.ini`` says);
        by default the size of the first image.

    Attributes
    ----------
    width, height : int
        Frame size in pixels.
    fps : float
    frame_count : int
        Number of files.
    decode_seconds : float
        Time spent decoding so far.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> for k in (1, 2):
    ...     _ = cv2.imwrite(str(folder / f"{k:06d}.png"), np.full((6, 8, 3), 10 * k, np.uint8))
    >>> reader = ImageSequenceReader(sorted(folder.iterdir()), name=str(folder))
    >>> reader.width, reader.height, reader.frame_count, [int(f[0, 0, 0]) for f in reader]
    (8, 6, 2, [10, 20])
    >>> int(reader.read(1)[0, 0, 0])
    20
    """

    def __init__(self, files, name: str, fps: float = 25.0, size: tuple[int, int] | None = None) -> None:
        self.files = [str(f) for f in files]
        if not self.files:
            raise VideoError(f"{name}: no image to read")
        self.name = name
        self.fps = float(fps)
        self.frame_count = len(self.files)
        self.decode_seconds = 0.0
        self.width = self.height = 0
        first = self._decode(0)
        height, width = first.shape[:2]
        if size is not None and tuple(size) != (width, height):
            raise VideoError(f"{limits.clipped(self.files[0])}: image of size {width}x{height}, but "
                             f"{limits.clipped(name)} says "
                             f"{size[0]}x{size[1]}")
        self.width, self.height = width, height

    def _decode(self, index: int) -> np.ndarray:
        file = self.files[index]
        name = shown(file)
        start = time.perf_counter()
        info = limits.regular_file(file, "image", VideoError)
        limits.check_image_file(file, info.st_size)
        # imdecode of the bytes rather than imread: imread prints its own warnings to the
        # terminal and cannot tell a missing file from one it cannot decode.
        try:
            data = np.fromfile(file, dtype=np.uint8, count=limits.image_bytes_limit() + 1)
        except OSError as exc:
            raise VideoError(f"cannot read image {name}: {exc.strerror or exc}") from None
        # OpenCV allocates the whole image before it decodes a pixel: the header's size is checked first.
        size = limits.image_size(data[:1 << 16].tobytes())
        if size is None:
            self.decode_seconds += time.perf_counter() - start
            raise VideoError(f"cannot read image {name}: OpenCV cannot decode it (not an image, or an "
                             "unsupported format: its header is not one of PNG, JPEG, BMP, TIFF, WebP, JPEG 2000 "
                             "or Netpbm)")
        limits.check_pixels(size[0], size[1], f"image {name}")
        if self.width and size != (self.width, self.height):
            raise VideoError(f"image {name} has size {size[0]}x{size[1]}, the earlier "
                             f"images of {limits.clipped(self.name)} {self.width}x{self.height}")
        with _quiet_native_stderr():     # OpenCV's warning about a damaged image: the error below says it
            image = cv2.imdecode(data, cv2.IMREAD_COLOR) if data.size else None
        self.decode_seconds += time.perf_counter() - start
        if image is None:
            raise VideoError(f"cannot read image {name}: OpenCV cannot decode it (not an image, or "
                             "an unsupported format)")
        if self.width and image.shape[:2] != (self.height, self.width):
            raise VideoError(f"image {name} has size {image.shape[1]}x{image.shape[0]}, the earlier "
                             f"images of {limits.clipped(self.name)} {self.width}x{self.height}")
        limits.check_pixels(image.shape[1], image.shape[0], f"image {name}")
        return np.ascontiguousarray(image, dtype=np.uint8)

    def read(self, index: int) -> np.ndarray:
        """The frame of 0-based ``index``."""
        return self._decode(index)

    def __len__(self) -> int:
        return self.frame_count

    def __iter__(self) -> Iterator[np.ndarray]:
        for index in range(self.frame_count):
            yield self._decode(index)

    def close(self) -> None:
        """Nothing to release (each image file is closed once read)."""


def track_colour(track_id: int) -> tuple[int, int, int]:
    """A distinct, stable BGR colour for a track id (golden-ratio hues).

    Examples
    --------
    >>> track_colour(1) == track_colour(1), track_colour(1) != track_colour(2)
    (True, True)
    """
    hue = int((track_id * 0.618033988749895 % 1.0) * 180)
    pixel = cv2.cvtColor(np.array([[[hue, 220, 255]]], dtype=np.uint8), cv2.COLOR_HSV2BGR)[0, 0]
    return int(pixel[0]), int(pixel[1]), int(pixel[2])


class AnnotatedVideoWriter:
    """Writes frames with the tracked boxes and ids drawn on them (Motion-JPEG ``.avi``).

    Parameters
    ----------
    path : str or path-like
        Output file; it should end in ``.avi``.
    fps : float
        Frame rate stored in the file.
    """

    def __init__(self, path: str | PathLike[str], fps: float = 25.0) -> None:
        self.path = str(path)
        self.fps = float(fps)
        self._writer: cv2.VideoWriter | None = None
        self._size: tuple[int, int] | None = None
        self.frames = 0

    def write(self, image: np.ndarray, frame: int, boxes: Sequence[tuple[int, Sequence[float]]]) -> None:
        """Draw ``boxes`` — ``(id, (x, y, w, h))`` in 0-based pixels — on a copy of ``image`` and write it."""
        canvas = np.array(image, dtype=np.uint8, copy=True)
        height, width = canvas.shape[:2]
        if self._writer is None:
            self._writer = cv2.VideoWriter(self.path, cv2.VideoWriter_fourcc(*"MJPG"), self.fps, (width, height))
            if not self._writer.isOpened():
                raise VideoError(f"cannot write video {self.path!r}: OpenCV cannot open it for writing")
            self._size = (height, width)
        elif (height, width) != self._size:
            raise VideoError(f"frame {frame} has size {width}x{height}, the video {self._size[1]}x{self._size[0]}")
        for track_id, (x, y, w, h) in boxes:
            colour = track_colour(track_id)
            top_left = (int(round(x)), int(round(y)))
            bottom_right = (int(round(x + w)) - 1, int(round(y + h)) - 1)
            cv2.rectangle(canvas, top_left, bottom_right, colour, 1)
            cv2.putText(canvas, str(track_id), (top_left[0], max(top_left[1] - 3, 10)), cv2.FONT_HERSHEY_SIMPLEX,
                        0.4, colour, 1, cv2.LINE_AA)
        cv2.putText(canvas, str(frame), (4, height - 6), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1,
                    cv2.LINE_AA)
        self._writer.write(canvas)
        self.frames += 1

    def close(self) -> None:
        """Finish the file."""
        if self._writer is not None:
            self._writer.release()
            self._writer = None

    def __enter__(self) -> AnnotatedVideoWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
