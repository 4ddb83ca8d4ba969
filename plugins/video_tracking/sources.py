"""Where the frames come from: a video, a folder of images, an image pattern, a MOTChallenge sequence, frames.

:func:`open_source` gives a :class:`FrameSource`, which yields BGR ``uint8`` frames one by
one (files are decoded lazily, so a video never has to fit in memory) and knows the frame
rate, the size and, when it can tell, the number of frames.  :meth:`FrameSource.spread`
picks frames evenly over the whole source, for the background model's warm-up.

A source is any of

* a video file that OpenCV decodes (``walk.avi``);
* a folder of images, taken in the order of their names, numbers compared by value
  (``frame2.png`` before ``frame10.png``); the extensions are :data:`IMAGE_EXTENSIONS`;
* an image pattern with one printf-style number (``img1/%06d.jpg``), counted from 0 or 1
  up to the first missing file;
* a MOTChallenge sequence folder (one with a ``seqinfo.ini``): its frames are
  ``imDir/000001`` … ``imDir/<seqLength>`` with the extension ``imExt``, at ``frameRate``;
  the public detections at ``det/det.txt`` are not used unless they are asked for
  (:func:`~belief_tracking.detections.read_detections`);
* a rendered :class:`~belief_tracking.scenes.Scene` or a (T, H, W, 3) ``uint8`` array.

Each is tracked frame by frame from Python as well as by ``belief track``:

>>> import tempfile
>>> import cv2
>>> from belief_tracking import scenes
>>> from belief_tracking.config import TrackerConfig
>>> from belief_tracking.detections import read_detections
>>> from belief_tracking.initiation import init_from_gt
>>> from belief_tracking.tracker import Tracker
>>> scene = scenes.render(scenes.crossing(0))
>>> folder = Path(tempfile.mkdtemp())
>>> for k, image in enumerate(scene.frames[:3], start=1):   # any folder of images will do
...     _ = cv2.imwrite(str(folder / f"{k:06d}.png"), image)
>>> gt = scene.ground_truth[scene.ground_truth[:, 0] <= 3]
>>> _ = (folder / "det.txt").write_text("".join(f"{f},-1,{x},{y},{w},{h},0.9\\n" for f, _, x, y, w, h, *_ in gt))
>>> tracker = Tracker(TrackerConfig(particles=30), init_from_gt(gt), np.random.default_rng(0))
>>> with open_source(folder) as frames:
...     detections = read_detections(folder / "det.txt", frame_count=frames.count,
...                                  image_size=(frames.width, frames.height))
...     for result in tracker.track(frames, detections=detections):
...         print(result.frame, [estimate.id for estimate in result.estimates])
1 [1, 2]
2 [1, 2]
3 [1, 2]

The same loop reads ``open_source(folder / "%06d.png")``, a video file or a sequence folder.
"""

from __future__ import annotations

import configparser
import os
import re
from collections.abc import Callable, Iterable, Iterator, Sequence
from os import PathLike
from pathlib import Path

import numpy as np

from .errors import TrackingError, VideoError

__all__ = ["FrameSource", "open_source", "IMAGE_EXTENSIONS"]

#: File extensions (lower case) that make a file of a folder a frame.
IMAGE_EXTENSIONS = (".jpg", ".jpeg", ".jpe", ".png", ".bmp", ".dib", ".tif", ".tiff", ".webp", ".jp2", ".ppm",
                    ".pgm", ".pbm", ".pnm")


class FrameSource:
    """The frames of one source, with what a run needs to know about them.

    Use :func:`open_source` to make one.

    Attributes
    ----------
    name : str
        How messages and the run's summary name the source.
    kind : str
        ``"video"``, ``"images"`` (a folder), ``"pattern"``, ``"sequence"`` (MOTChallenge) or ``"frames"``.
    width, height : int
        Frame size in pixels.
    fps : float
        Frame rate (25 when the source gives none).
    count : int or None
        Number of frames, if known (a video's container may announce it only approximately).
    """

    def __init__(self, frames: Iterable[np.ndarray], *, name: str, width: int, height: int, fps: float,
                 count: int | None, reader=None, path: str | None = None, kind: str = "frames",
                 pick: Callable[[Sequence[int]], Iterable[np.ndarray]] | None = None) -> None:
        self._frames = frames
        self.name = name
        self.kind = kind
        self.width, self.height = width, height
        self.fps = fps
        self.count = count
        self._reader = reader
        self._path = path
        self._pick = pick

    def __iter__(self) -> Iterator[np.ndarray]:
        return iter(self._frames)

    @property
    def decode_seconds(self) -> float:
        """Time spent decoding the frames so far (0 for frames already in memory)."""
        return self._reader.decode_seconds if self._reader is not None else 0.0

    def spread(self, count: int) -> Iterable[np.ndarray]:
        """Up to ``count`` frames spread evenly over the source (the first ones if its length is unknown).

        A video file is opened a second time for them, and image files are decoded again, so
        the frames of the run are untouched.
        """
        total = self.count
        if total:
            picks = set(np.linspace(0, total - 1, num=min(count, total)).round().astype(int).tolist())
        else:
            picks = set(range(count))
        if not picks:
            return iter(())
        if self._pick is not None:
            return self._pick(sorted(picks))
        if self._path is None:
            frames = self._frames
            return (frames[k] for k in sorted(picks) if k < len(frames))  # type: ignore[index]
        from .video import VideoReader

        path = self._path

        def read():
            with VideoReader(path) as reader:
                for k, image in enumerate(reader):
                    if k in picks:
                        yield image
                    if k >= max(picks):
                        break
        return read()

    def missing(self, decoded: int) -> int:
        """How many of the frames the source announces were not among the ``decoded`` first ones (0 if unknown).

        A truncated or corrupt video file decodes fewer frames than its container announces
        (:attr:`count`); a run compares the frames it tracked with it.

        Examples
        --------
        >>> source = open_source(np.zeros((4, 6, 8, 3), np.uint8))
        >>> source.missing(4), source.missing(3)
        (0, 1)
        """
        return max(int(self.count) - int(decoded), 0) if self.count else 0

    def close(self) -> None:
        """Release the video file, if any."""
        if self._reader is not None:
            self._reader.close()

    def __enter__(self) -> FrameSource:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def open_source(source) -> FrameSource:
    """A :class:`FrameSource` for a path (video, image folder, image pattern, sequence folder), a Scene or frames.

    Parameters
    ----------
    source : path, FrameSource, Scene or ndarray of uint8, shape (T, H, W, 3)
        See the module's description for the kinds of path.  A :class:`FrameSource` is
        returned as it is.

    Raises
    ------
    VideoError
        A missing path; a video that cannot be opened or decoded; a folder without images; an
        image that cannot be decoded or whose size differs from the first one (found when its
        frame is read); a ``seqinfo.ini`` without ``imDir`` or with a bad value, or a frame
        it lists that is missing.
    TrackingError
        Frames that are not a non-empty (T, H, W, 3) uint8 array.

    Examples
    --------
    >>> source = open_source(np.zeros((4, 6, 8, 3), np.uint8))
    >>> source.name, source.width, source.height, source.count, len(list(source))
    ('frames', 8, 6, 4, 4)
    >>> len(list(source.spread(2)))
    2
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = (folder / "seqinfo.ini").write_text("[Sequence]\\nname=walk\\nframeRate=30\\n")
    >>> open_source(folder)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    belief_tracking.errors.VideoError: .../seqinfo.ini: no imDir (the folder of the frames, as in imDir=img1)
    """
    if isinstance(source, FrameSource):
        return source
    if isinstance(source, (str, PathLike)):
        text = os.fspath(source)
        path = Path(text)
        if path.is_dir():
            if (path / "seqinfo.ini").is_file():
                return _sequence(path)
            return _image_folder(path)
        if not path.exists() and "%" in text:
            return _pattern(text)
        from .video import VideoReader

        reader = VideoReader(source)
        return FrameSource(reader, name=text, width=reader.width, height=reader.height, fps=reader.fps,
                           count=reader.frame_count, reader=reader, path=text, kind="video")
    scene_config = getattr(source, "config", None)
    frames = np.asarray(getattr(source, "frames", source))
    if frames.ndim != 4 or frames.shape[3] != 3 or frames.dtype != np.uint8 or 0 in frames.shape:
        raise TrackingError(f"frames must be a (T, H, W, 3) uint8 array, got shape {frames.shape}")
    name = f"scene {scene_config.name!r}" if scene_config is not None else "frames"
    return FrameSource(frames, name=name, width=frames.shape[2], height=frames.shape[1], fps=25.0,
                       count=frames.shape[0])


def _images(files: Sequence[Path | str], name: str, kind: str, fps: float = 25.0,
            size: tuple[int, int] | None = None) -> FrameSource:
    from .video import ImageSequenceReader

    reader = ImageSequenceReader(files, name=name, fps=fps, size=size)

    def pick(indices: Sequence[int]) -> Iterator[np.ndarray]:
        return (reader.read(k) for k in indices if k < reader.frame_count)

    return FrameSource(reader, name=name, width=reader.width, height=reader.height, fps=reader.fps,
                       count=reader.frame_count, reader=reader, kind=kind, pick=pick)


def _natural_key(path: Path) -> list:
    """Sort key of a file name with its runs of digits compared as numbers (frame2 before frame10)."""
    return [(0, int(part), part) if part.isdigit() else (1, 0, part) for part in re.split(r"(\d+)", path.name)]


def _listed_images(folder: Path, extensions: Sequence[str] = IMAGE_EXTENSIONS) -> list[Path]:
    try:
        entries = list(folder.iterdir())
    except OSError as exc:
        raise VideoError(f"cannot read the folder {str(folder)!r}: {exc.strerror or exc}") from None
    files = [f for f in entries if f.suffix.lower() in extensions and not f.name.startswith(".") and f.is_file()]
    return sorted(files, key=_natural_key)


def _image_folder(folder: Path) -> FrameSource:
    files = _listed_images(folder)
    if not files:
        hint = " (a MOTChallenge sequence folder needs its seqinfo.ini)" if (folder / "img1").is_dir() else ""
        raise VideoError(f"cannot read the folder {str(folder)!r}: it holds no image file "
                         f"({', '.join(IMAGE_EXTENSIONS[:7])}, ...){hint}")
    return _images(files, str(folder), "images")


def _pattern(pattern: str) -> FrameSource:
    try:
        names = pattern % 0, pattern % 1
    except (TypeError, ValueError, OverflowError):
        names = (pattern, pattern)
    if names[0] == names[1]:
        raise VideoError(f"cannot read {pattern!r}: no such file, and not an image pattern with one number "
                         "(such as img1/%06d.jpg)")
    start = next((k for k, name in enumerate(names) if os.path.isfile(name)), None)
    if start is None:
        raise VideoError(f"cannot read the image pattern {pattern!r}: neither {names[0]!r} nor {names[1]!r} exists")
    files = []
    # Counting the files is a stat each, cheap next to decoding, and gives the run its length.
    while os.path.isfile(pattern % (start + len(files))):
        files.append(pattern % (start + len(files)))
    return _images(files, pattern, "pattern")


def _sequence(folder: Path) -> FrameSource:
    from belief.textfiles import read_text

    ini = folder / "seqinfo.ini"
    where = str(ini)
    parser = configparser.ConfigParser(interpolation=None)
    try:
        parser.read_string(read_text(ini, "sequence description", VideoError, encoding="utf-8-sig"), source=where)
    except configparser.Error as exc:
        raise VideoError(f"{where}: not a valid INI file ({str(exc).splitlines()[0]})") from None
    if not parser.has_section("Sequence"):
        raise VideoError(f"{where}: no [Sequence] section")
    info = parser["Sequence"]  # keys are case-insensitive: imDir, imdir and IMDIR are the same

    def number(key: str, kind: type, default=None):
        text = info.get(key)
        if text is None or not text.strip():
            return default
        try:
            value = kind(text.strip())
        except ValueError:
            value = None
        if value is None or not np.isfinite(value) or value <= 0:
            raise VideoError(f"{where}: {key} must be a positive {'whole ' if kind is int else ''}number, "
                             f"got {text.strip()!r}")
        return value

    im_dir = (info.get("imDir") or "").strip()
    if not im_dir:
        raise VideoError(f"{where}: no imDir (the folder of the frames, as in imDir=img1)")
    fps = number("frameRate", float, 25.0)
    length = number("seqLength", int)
    width, height = number("imWidth", int), number("imHeight", int)
    extension = (info.get("imExt") or ".jpg").strip()
    extension = extension if extension.startswith(".") else "." + extension
    images = folder / im_dir
    if not images.is_dir():
        raise VideoError(f"{where}: imDir={im_dir} but {str(images)!r} is not a folder")
    if length is not None:
        files = [images / f"{k:06d}{extension}" for k in range(1, length + 1)]
        missing = next((f for f in files if not f.is_file()), None)
        if missing is not None:
            raise VideoError(f"{where}: seqLength={length} but the frame {str(missing)!r} is missing")
    else:
        files = _listed_images(images, (extension.lower(),))
        if not files:
            raise VideoError(f"{where}: no {extension} image in {str(images)!r}")
    size = (width, height) if width is not None and height is not None else None
    return _images(files, str(folder), "sequence", fps=fps, size=size)
