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
  ``imDir/000001`` … ``imDir/<seqLength>`` with the extension ``imExt``, at ``frameRate``,
  or the frames of the video file ``imDir`` names (``imDir=video.avi``); a folder without
  ``seqinfo.ini`` that holds no image itself but an ``img1`` folder is a sequence too, of
  the images of ``img1`` at 25 frames per second.  The public detections at ``det/det.txt``
  are not used unless they are asked for
  (:func:`~belief_tracking.detections.read_detections`); the ground truth at ``gt/gt.txt``
  is found by :func:`sequence_ground_truth` (``belief track`` scores against it);
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
import stat
from collections.abc import Callable, Iterable, Iterator, Sequence
from os import PathLike
from pathlib import Path

import numpy as np

from . import limits
from .errors import TrackingError, VideoError
from .limits import shown

__all__ = ["FrameSource", "open_source", "IMAGE_EXTENSIONS", "is_sequence_folder", "sequence_ground_truth",
           "sequence_detections", "SEQUENCE_GROUND_TRUTH", "SEQUENCE_DETECTIONS"]

#: Where a MOTChallenge sequence folder keeps its ground truth, tried in this order: the benchmark's place, and the
#: file beside ``seqinfo.ini`` of a folder that keeps a video and its ground truth together.
SEQUENCE_GROUND_TRUTH = ("gt/gt.txt", "gt.txt")
#: Where a MOTChallenge sequence folder keeps its public detections (used only when given as detections).
SEQUENCE_DETECTIONS = ("det/det.txt", "det.txt")

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
    text = limits.path_text(source)
    if text is not None:
        path = Path(text)
        try:
            info = os.stat(text)
        except (FileNotFoundError, NotADirectoryError):
            info = None
        except OSError as exc:         # a name too long, a loop of links, no permission
            raise VideoError(f"cannot read {shown(text)}: {exc.strerror or exc}") from None
        if info is not None and stat.S_ISDIR(info.st_mode):
            if os.path.lexists(path / "seqinfo.ini"):
                return _sequence(path)
            return _image_folder(path)
        if info is None and "%" in text:
            return _pattern(text)
        from .video import VideoReader

        reader = VideoReader(text)
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
    """The regular image files of ``folder`` in natural order; more than :data:`limits.MAX_FRAMES` is refused."""
    files = []
    try:
        with os.scandir(folder) as entries:
            for entry in entries:
                name = entry.name
                if name.startswith(".") or os.path.splitext(name)[1].lower() not in extensions:
                    continue
                # entry.is_file follows links and is False for FIFOs and devices, which a read would block on.
                if entry.is_file():
                    files.append(Path(entry.path))
                    if len(files) > limits.MAX_FRAMES:
                        limits.check_frames(len(files), f"the folder {shown(str(folder))}",
                                            "images or more")
    except OSError as exc:
        raise VideoError(f"cannot read the folder {shown(str(folder))}: {exc.strerror or exc}") from None
    return sorted(files, key=_natural_key)


def _image_folder(folder: Path) -> FrameSource:
    files = _listed_images(folder)
    if not files and (folder / "img1").is_dir():
        # A MOTChallenge sequence without its seqinfo.ini: the frames of img1, at the default rate.
        files = _listed_images(folder / "img1")
        if not files:
            raise VideoError(f"cannot read the sequence folder {shown(str(folder))}: it has no seqinfo.ini, and "
                             f"its img1 folder holds no image file ({', '.join(IMAGE_EXTENSIONS[:7])}, ...)")
        return _images(files, str(folder), "sequence")
    if not files:
        raise VideoError(f"cannot read the folder {shown(str(folder))}: it holds no image file "
                         f"({', '.join(IMAGE_EXTENSIONS[:7])}, ...)")
    return _images(files, str(folder), "images")


def is_sequence_folder(source) -> bool:
    """Whether ``source`` is a path to a MOTChallenge sequence folder: one with a ``seqinfo.ini``, or with an
    ``img1`` folder and no image of its own (:func:`open_source` reads both as a sequence).

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> is_sequence_folder(folder), is_sequence_folder(np.zeros((1, 2, 2, 3), np.uint8))
    (False, False)
    >>> (folder / "img1").mkdir()
    >>> is_sequence_folder(folder), is_sequence_folder(str(folder))
    (True, True)
    """
    text = limits.path_text(source)
    if text is None:
        return False
    folder = Path(text)
    try:
        if not folder.is_dir():
            return False
        if os.path.lexists(folder / "seqinfo.ini"):
            return True
        return (folder / "img1").is_dir() and not _listed_images(folder)
    except (OSError, TrackingError):
        return False


def sequence_ground_truth(source) -> Path | None:
    """The ground-truth file of a MOTChallenge sequence folder, or None (not a sequence folder, or no such file).

    The file is the first of :data:`SEQUENCE_GROUND_TRUTH` (``gt/gt.txt``, then ``gt.txt``) that is a regular
    file (a link to one included) in the folder.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> (folder / "img1").mkdir()
    >>> print(sequence_ground_truth(folder))
    None
    >>> (folder / "gt").mkdir()
    >>> _ = (folder / "gt" / "gt.txt").write_text("1,1,10,10,5,10,1\\n")
    >>> sequence_ground_truth(folder) == folder / "gt" / "gt.txt"
    True
    """
    return _sequence_file(source, SEQUENCE_GROUND_TRUTH)


def sequence_detections(source) -> Path | None:
    """The public detection file of a MOTChallenge sequence folder (:data:`SEQUENCE_DETECTIONS`), or None."""
    return _sequence_file(source, SEQUENCE_DETECTIONS)


def _sequence_file(source, names: Sequence[str]) -> Path | None:
    if not is_sequence_folder(source):
        return None
    folder = Path(limits.path_text(source))
    for name in names:
        # os.path.isfile follows links and is False for FIFOs and devices, which a read would block on.
        if os.path.isfile(folder / name):
            return folder / name
    return None


#: One printf-style integer conversion of an image pattern, with its flags, width and precision.
_CONVERSION = re.compile(r"%(?P<flags>[-+ 0#]*)(?P<width>\d*)(?:\.(?P<precision>\d*))?(?P<type>[diu])")


def _pattern_number(pattern: str) -> bool:
    """Whether ``pattern`` has exactly one integer conversion (``%06d``) and otherwise only ``%%``.

    The pattern is checked before it is formatted: ``%300000000d`` would make a name of 300
    million characters for every frame tried.
    """
    numbers = 0
    k = 0
    while True:
        k = pattern.find("%", k)
        if k < 0:
            return numbers == 1
        if pattern.startswith("%%", k):
            k += 2
            continue
        match = _CONVERSION.match(pattern, k)
        if match is None:
            return False
        for part in ("width", "precision"):
            digits = match.group(part) or "0"
            if len(digits) > 3 or int(digits) > limits.MAX_PATTERN_WIDTH:
                raise VideoError(f"cannot read the image pattern {shown(pattern)}: a number {part} of "
                                 f"{limits.clipped(digits)}, more than {limits.MAX_PATTERN_WIDTH} digits")
        numbers += 1
        k = match.end()


def _pattern(pattern: str) -> FrameSource:
    if not _pattern_number(pattern):
        raise VideoError(f"cannot read {shown(pattern)}: no such file, and not an image pattern with one number "
                         "(such as img1/%06d.jpg)")
    names = pattern % 0, pattern % 1
    start = next((k for k, name in enumerate(names) if os.path.isfile(name)), None)
    if start is None:
        raise VideoError(f"cannot read the image pattern {shown(pattern)}: neither {shown(names[0])} nor "
                         f"{shown(names[1])} exists")
    files = []
    # Counting the files is a stat each, cheap next to decoding, and gives the run its length;
    # os.path.isfile is False for FIFOs and devices.
    while os.path.isfile(pattern % (start + len(files))):
        files.append(pattern % (start + len(files)))
        if len(files) > limits.MAX_FRAMES:
            limits.check_frames(len(files), f"the image pattern {shown(pattern)}", "images or more")
    return _images(files, pattern, "pattern")


#: A whole number of seqinfo.ini: digits only (Python's int would take ``1_000`` and `` +1``).
_WHOLE = re.compile(r"\+?[0-9]{1,100}")
#: A decimal number of seqinfo.ini (no ``inf``, ``nan``, underscores or hexadecimal).
_DECIMAL = re.compile(r"\+?(?:[0-9]{1,19}(?:\.[0-9]{0,19})?|\.[0-9]{1,19})(?:[eE][-+]?[0-9]{1,3})?")


def _sequence(folder: Path) -> FrameSource:
    ini = folder / "seqinfo.ini"
    where = limits.clipped(str(ini))
    parser = configparser.ConfigParser(interpolation=None)
    text = limits.read_small_text(ini, "sequence description", VideoError, encoding="utf-8-sig")
    try:
        parser.read_string(text, source=where)
    except configparser.Error as exc:
        raise VideoError(f"{where}: not a valid INI file ({limits.clipped(str(exc).splitlines()[0])})") from None
    if not parser.has_section("Sequence"):
        raise VideoError(f"{where}: no [Sequence] section")
    info = parser["Sequence"]  # keys are case-insensitive: imDir, imdir and IMDIR are the same

    def number(key: str, kind: type, default=None, maximum: float | None = None):
        text = info.get(key)
        if text is None or not text.strip():
            return default
        text = text.strip()
        pattern = _WHOLE if kind is int else _DECIMAL
        value = kind(text) if pattern.fullmatch(text) else None
        if value is None or not value > 0:
            raise VideoError(f"{where}: {key} must be a positive {'whole ' if kind is int else ''}number, "
                             f"got {shown(text)}")
        if maximum is not None and value > maximum:
            raise VideoError(f"{where}: {key} = {text} is more than {maximum:g}")
        return value

    im_dir = (info.get("imDir") or "").strip()
    if not im_dir:
        raise VideoError(f"{where}: no imDir (the folder of the frames, as in imDir=img1)")
    fps = number("frameRate", float, 25.0, limits.MAX_FPS)
    length = number("seqLength", int)
    width, height = number("imWidth", int), number("imHeight", int)
    if length is not None:
        limits.check_frames(length, where, "frames (seqLength)")
    if width is not None and height is not None:
        limits.check_pixels(width, height, where)
    extension = (info.get("imExt") or ".jpg").strip()
    extension = extension if extension.startswith(".") else "." + extension
    if len(extension) > 16 or any(c in extension for c in "/\\%\x00"):
        raise VideoError(f"{where}: imExt must be a file extension such as .jpg, got {shown(extension)}")
    images = folder / im_dir
    if images.is_file():
        return _sequence_video(folder, images, where, fps if (info.get("frameRate") or "").strip() else None, length,
                               (width, height) if width is not None and height is not None else None)
    if not images.is_dir():
        raise VideoError(f"{where}: imDir={limits.clipped(im_dir)} but {shown(str(images))} is not a folder "
                         "(of images) or a video file")
    if length is not None:
        files = []
        # One stat a frame, stopping at the first missing one: a seqLength of 10^7 with no frames ends at once.
        for k in range(1, length + 1):
            file = images / f"{k:06d}{extension}"
            if not file.is_file():
                raise VideoError(f"{where}: seqLength={length} but the frame {shown(str(file))} is missing")
            files.append(file)
    else:
        files = _listed_images(images, (extension.lower(),))
        if not files:
            raise VideoError(f"{where}: no {extension} image in {shown(str(images))}")
    size = (width, height) if width is not None and height is not None else None
    return _images(files, str(folder), "sequence", fps=fps, size=size)


def _sequence_video(folder: Path, video: Path, where: str, fps: float | None, length: int | None,
                    size: tuple[int, int] | None) -> FrameSource:
    """A sequence whose ``imDir`` names a video file: its frames, at the sequence's ``frameRate`` if it gives one.

    ``seqLength``, ``imWidth`` and ``imHeight``, when given, must be the video's.
    """
    from .video import VideoReader

    reader = VideoReader(video)
    try:
        if size is not None and size != (reader.width, reader.height):
            raise VideoError(f"{where}: the video {shown(str(video))} is {reader.width}x{reader.height}, but "
                             f"imWidth and imHeight say {size[0]}x{size[1]}")
        if length is not None and reader.frame_count and length != reader.frame_count:
            raise VideoError(f"{where}: seqLength={length} but the video {shown(str(video))} announces "
                             f"{reader.frame_count} frames")
    except BaseException:
        reader.close()
        raise
    return FrameSource(reader, name=str(folder), width=reader.width, height=reader.height,
                       fps=fps if fps is not None else reader.fps, count=reader.frame_count or length,
                       reader=reader, path=str(video), kind="sequence")
