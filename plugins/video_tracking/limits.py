"""The limits of a tracking run, its memory estimate, and the gates of the files it reads.

A run is refused before any work when its input or settings would exceed one of the
limits below.  Each raisable limit is a module attribute, read when the check runs, and has
an option of ``belief track`` (:data:`LIMIT_FLAGS`); a refusal is a
:class:`TrackingLimitError`, one line naming the value, the limit and that option:

=====================  ==============  =================================================  ==================
Limit                  Default         What it bounds                                     Option
=====================  ==============  =================================================  ==================
:data:`MAX_PIXELS`     8,294,400       pixels of one frame (3840 x 2160, 4K UHD), read     ``--max-pixels N``
                                       from the file's header or the video's properties
                                       before anything is decoded
:data:`MAX_FRAMES`     1,000,000       frames of a source (images of a folder or            ``--max-frames N``
                                       pattern, ``seqLength``, a video's announced count)
:data:`MAX_MEMORY`     1 GiB           the run's estimated memory (:func:`estimate_memory`)  ``--max-memory N``
=====================  ==============  =================================================  ==================

Fixed bounds, which no option raises because no sensible input comes near them:
:data:`MAX_SETTINGS_DEPTH` (nesting of a settings table), :data:`MAX_SETTING_TEXT` (a text
setting), :data:`MAX_SETTING_ITEMS` (a list setting), :data:`MAX_SPREAD` (a spread of the
motion model in pixels), :data:`MAX_TEXT_BYTES` (``seqinfo.ini`` and TOML files),
:data:`MAX_PATTERN_WIDTH` (the field width of an image pattern) and :data:`MAX_FPS`.

From Python a limit is raised by assigning to it (``belief_tracking.limits.MAX_PIXELS = 10**8``)
or for a block with :func:`applied`.

Examples
--------
>>> from belief_tracking.config import TrackerConfig
>>> estimate = estimate_memory(TrackerConfig(), 320, 240)
>>> estimate.total < MAX_MEMORY
True
>>> check_pixels(20000, 20000, "image 'big.png'")
Traceback (most recent call last):
...
belief_tracking.limits.TrackingLimitError: image 'big.png': a frame of 20000 x 20000 = 400,000,000 pixels, more than the limit of 8,294,400 pixels; raise it with --max-pixels N
"""

from __future__ import annotations

import contextlib
import math
import os
import reprlib
import struct
import sys
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from belief.errors import BeliefError, ResourceLimitError
from belief.textfiles import regular_file

from .errors import TrackingError

__all__ = ["MAX_PIXELS", "MAX_FRAMES", "MAX_MEMORY", "LIMIT_FLAGS", "TrackingLimitError", "MemoryEstimate",
           "estimate_memory", "estimate_seconds", "duration", "long_run_notice", "run_targets",
           "LONG_RUN_SECONDS", "check_config", "add_options", "given", "check_run", "check_pixels", "check_frames", "applied", "shown", "clipped",
           "regular_file", "image_size", "read_small_text", "load_toml", "toml_value", "check_settings_tree"]

#: Pixels of one frame (4K UHD, 3840 x 2160).
MAX_PIXELS = 3840 * 2160
#: Frames of one source (11 hours at 25 frames per second).
MAX_FRAMES = 1_000_000
#: The estimated memory of a run, in bytes.
MAX_MEMORY = 1 << 30

#: The options of ``belief track`` that raise (or lower) a limit, and the attribute each sets.
LIMIT_FLAGS = {"max-pixels": "MAX_PIXELS", "max-frames": "MAX_FRAMES", "max-memory": "MAX_MEMORY"}

#: How deep tables and lists of a settings mapping may nest (the deepest real setting is two).
MAX_SETTINGS_DEPTH = 8
#: Characters of a text setting (cue, rule and mode names are a few words).
MAX_SETTING_TEXT = 200
#: Items of a list setting (the cues, the keyframes of a setting).
MAX_SETTING_ITEMS = 1000
#: A spread in pixels (motion noise, particle spread, location sigma): MOT coordinates stay within ±10^6.
MAX_SPREAD = 1e6
#: Bytes of a ``seqinfo.ini`` or of a TOML file.
MAX_TEXT_BYTES = 1 << 22
#: The field width of the number of an image pattern (``%06d``).
MAX_PATTERN_WIDTH = 32
#: A frame rate in frames per second, above which a source's rate is taken for unknown.
MAX_FPS = 1000.0
#: Characters of a user's value quoted in a message.
SHOWN_CHARACTERS = 240

# The constants of the memory estimate, measured on the demo scene and on a 1920 x 1080 video
# (peak resident memory, tracemalloc does not see OpenCV's buffers).  A particle of one target
# costs its states and weights, about 600 bytes with three cues and four targets.
_BASE_BYTES = 120 << 20          # the interpreter, numpy, OpenCV and the belief library
_FRAME_COPIES = 8                # the frame, its conversions, masks and gradients, the annotated copy
_MOG2_COMPONENT_BYTES = 20       # weight, variance and three means of a mixture component, float32
_PARTICLE_BYTES = 256            # states (5 float64) in three copies, weights, indices
_CUE_BYTES = 128                 # a cue's likelihood and its mass function per particle
_PAIR_BYTES = 16                 # a particle's score against every other target


# The cost model of a run's time, measured on the synthetic scenes (two walkers, 320 x 240) on one core: a start
# of about a second (imports, rendering), then per frame about 0.26 µs per pixel (background model, cues) and
# 10 µs per particle and target.  It is rough (within a factor of about two): it tells a run of seconds from one
# of hours.
_START_SECONDS = 1.0
_SECONDS_PER_PIXEL = 2.6e-7
_SECONDS_PER_PARTICLE = 1.0e-5
#: A run estimated longer than this says so, with its estimate, before it starts.
LONG_RUN_SECONDS = 120.0


class TrackingLimitError(TrackingError, ResourceLimitError):
    """A run over a limit of :mod:`belief_tracking.limits`; :attr:`limit` names it (``"MAX_PIXELS"``)."""

    def __init__(self, message: str, limit: str | None = None) -> None:
        super().__init__(message)
        self.limit = limit


def _option(limit: str) -> str:
    return "--" + next(flag for flag, name in LIMIT_FLAGS.items() if name == limit)


def _limit(name: str) -> int:
    return int(getattr(sys.modules[__name__], name))


def _over(message: str, limit: str, unit: str = "") -> TrackingLimitError:
    value = _limit(limit)
    shown_limit = _bytes(value) if limit == "MAX_MEMORY" else f"{value:,}{unit}"
    return TrackingLimitError(f"{message}, more than the limit of {shown_limit}; raise it with {_option(limit)} N",
                              limit)


def _bytes(count: float) -> str:
    for unit, size in (("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if count >= size:
            return f"{count / size:,.1f} {unit}"
    return f"{count:,.0f} bytes"


_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxstring, _REPR.maxother, _REPR.maxlong = 3, SHOWN_CHARACTERS, SHOWN_CHARACTERS, 40
_REPR.maxlist = _REPR.maxtuple = _REPR.maxdict = _REPR.maxset = 8


def shown(value: Any) -> str:
    """``repr(value)`` cut to about :data:`SHOWN_CHARACTERS` (240) and three levels, for messages.

    A message quotes what the user gave, but a 300-million-character pattern or a list nested
    10 000 deep must not make a line of that size (or a RecursionError).

    Examples
    --------
    >>> shown("img/%06d.png")
    "'img/%06d.png'"
    >>> text = shown("%" + "9" * 300000000 + "d")
    >>> len(text) < 300, text[-28:]
    (True, "9d' (300,000,002 characters)")
    >>> shown([[[[[1]]]]])
    '[[[[...]]]]'
    """
    text = _REPR.repr(value)
    if isinstance(value, str) and len(value) > SHOWN_CHARACTERS:
        text += f" ({len(value):,} characters)"
    return text


def clipped(text: str) -> str:
    """``text`` unquoted, its middle cut when it is longer than :data:`SHOWN_CHARACTERS` (a path in a message).

    Examples
    --------
    >>> clipped("a/b.png")
    'a/b.png'
    >>> clipped("x" * 1000)[-30:]
    'xxxxxxxxxxx (1,000 characters)'
    """
    text = str(text)
    if len(text) <= SHOWN_CHARACTERS:
        return text
    half = SHOWN_CHARACTERS // 2 - 2
    return f"{text[:half]}...{text[-half:]} ({len(text):,} characters)"


@contextlib.contextmanager
def applied(values: Mapping[str, int | None]) -> Iterator[None]:
    """Set limits for the time of the block: ``{"max-pixels": N, ...}`` as the options give them (None: unchanged).

    Examples
    --------
    >>> from belief_tracking import limits
    >>> with applied({"max-pixels": 10**8, "max-frames": None}):
    ...     limits.MAX_PIXELS
    100000000
    >>> limits.MAX_PIXELS
    8294400
    """
    module = sys.modules[__name__]
    saved = []
    try:
        for flag, value in values.items():
            if value is None:
                continue
            name = LIMIT_FLAGS[flag.lstrip("-").replace("_", "-")]
            if isinstance(value, bool) or not isinstance(value, int) or not 0 < value < 2 ** 63:
                raise TrackingError(f"--{flag.lstrip('-')} must be a positive whole number below 2**63, "
                                    f"got {shown(value)}")
            saved.append((name, getattr(module, name)))
            setattr(module, name, value)
        yield
    finally:
        for name, value in reversed(saved):
            setattr(module, name, value)


def _positive_whole(text: str) -> int:
    """A limit given on the command line: a positive whole number, as ``4000000``, ``4_000_000`` or ``4e6``."""
    import argparse

    try:
        value = float(text.replace("_", "")) if any(c in text for c in ".eE") else int(text.replace("_", ""))
    except (ValueError, OverflowError):
        value = None
    if value is None or not 0 < value < 2 ** 63 or value != int(value):
        raise argparse.ArgumentTypeError(f"a limit must be a positive whole number below 2**63, got {shown(text)}")
    return int(value)


def add_options(parser) -> None:
    """Add ``--max-pixels``, ``--max-frames`` and ``--max-memory`` to an argparse parser (``belief track``).

    Examples
    --------
    >>> import argparse
    >>> parser = argparse.ArgumentParser()
    >>> add_options(parser)
    >>> given(parser.parse_args(["--max-pixels", "1e8"]))
    {'max-pixels': 100000000, 'max-frames': None, 'max-memory': None}
    """
    helps = {"max-pixels": f"the most pixels of a frame (default {MAX_PIXELS:,}, 3840 x 2160)",
             "max-frames": f"the most frames of a source (default {MAX_FRAMES:,})",
             "max-memory": f"the most memory, in bytes, the run is estimated to need (default {MAX_MEMORY:,})"}
    for flag, text in helps.items():
        parser.add_argument(f"--{flag}", type=_positive_whole, metavar="N", help=text)


def given(args) -> dict[str, int | None]:
    """The limits an argparse namespace of :func:`add_options` sets, for :func:`applied`."""
    return {flag: getattr(args, flag.replace("-", "_"), None) for flag in LIMIT_FLAGS}


# -- sizes -----------------------------------------------------------------------------------------
def check_pixels(width: int, height: int, where: str) -> None:
    """Refuse a frame of more than :data:`MAX_PIXELS` pixels, or without a positive size."""
    if width < 1 or height < 1:
        raise TrackingError(f"{where}: a frame of {width} x {height} pixels")
    if width * height > _limit("MAX_PIXELS"):
        raise _over(f"{where}: a frame of {width} x {height} = {width * height:,} pixels", "MAX_PIXELS", " pixels")


def check_frames(count: int, where: str, what: str = "frames") -> None:
    """Refuse a source of more than :data:`MAX_FRAMES` frames."""
    if count > _limit("MAX_FRAMES"):
        raise _over(f"{where}: {count:,} {what}", "MAX_FRAMES", " frames")


@dataclass(frozen=True)
class MemoryEstimate:
    """The estimated peak memory of a run, in bytes, by part.

    Attributes
    ----------
    frames : int
        Decoded frames and their working copies.
    background : int
        The mixtures of the background model and the frames its warm-up holds.
    particles : int
        The particles of every target at once, with the cues' values per particle.
    targets : int
        The number of targets the particle part assumes.
    """

    frames: int
    background: int
    particles: int
    targets: int

    @property
    def total(self) -> int:
        """Every part, and the interpreter with its libraries."""
        return _BASE_BYTES + self.frames + self.background + self.particles


def estimate_memory(config, width: int = 0, height: int = 0, targets: int | None = None,
                    frames: int | None = None) -> MemoryEstimate:
    """The memory a run of ``config`` needs on frames of ``width`` x ``height`` (0: the particles only).

    Parameters
    ----------
    config : TrackerConfig
    width, height : int
        Frame size in pixels.
    targets : int, optional
        Targets tracked at once (default ``config.max_targets``, the most the run may start).
    frames : int, optional
        Frames of the source, when known: the warm-up holds at most that many.

    Returns
    -------
    MemoryEstimate
    """
    targets = config.max_targets if targets is None else max(1, min(int(targets), config.max_targets))
    pixels = int(width) * int(height)
    frame_part = pixels * 3 * _FRAME_COPIES
    background = 0
    if config.uses_background and pixels:
        scale = config.background.downscale
        small = max(1, width // scale) * max(1, height // scale)
        held = config.warm_up if frames is None else min(config.warm_up, int(frames))
        background = small * (config.background.mixtures * _MOG2_COMPONENT_BYTES + 3 * held + 8)
    per_particle = _PARTICLE_BYTES + _CUE_BYTES * len(config.cues) + _PAIR_BYTES * targets
    particles = config.particles * targets * per_particle
    return MemoryEstimate(frame_part, background, particles, targets)


def estimate_seconds(config, width: int, height: int, frames: int, targets: int | None = None) -> float:
    """The time a run of ``config`` takes on ``frames`` frames of ``width`` x ``height``, in seconds (rough).

    Parameters
    ----------
    config : TrackerConfig
    width, height, frames : int
    targets : int, optional
        Targets tracked at once (default ``config.max_targets``, the most the run may start).

    Examples
    --------
    >>> from belief_tracking.config import TrackerConfig
    >>> round(estimate_seconds(TrackerConfig(), 320, 240, 100, targets=2), 1)
    3.2
    """
    targets = config.max_targets if targets is None else max(1, min(int(targets), config.max_targets))
    per_frame = int(width) * int(height) * _SECONDS_PER_PIXEL + config.particles * targets * _SECONDS_PER_PARTICLE
    return _START_SECONDS + int(frames) * per_frame


def duration(seconds: float) -> str:
    """A time in words: ``"45 s"``, ``"12 min"``, ``"3.5 h"``, ``"2.0 days"``.

    >>> duration(45), duration(720), duration(12600)
    ('45 s', '12 min', '3.5 h')
    """
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    if seconds < 172800:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / 86400:.1f} days"


def long_run_notice(config, source, targets: int | None, memory: MemoryEstimate | None = None) -> str | None:
    """One line stating a run's estimated time and memory, when it is estimated over :data:`LONG_RUN_SECONDS`.

    ``targets`` is the most tracked at once when known (an init plan); otherwise the line gives
    the time of one target and of ``config.max_targets`` at once.  ``memory`` is the run's
    estimate where :func:`check_run` has made it already.
    """
    if not source.count:
        return None
    size = f"{source.count:,} frames of {source.width} x {source.height}"
    low = estimate_seconds(config, source.width, source.height, source.count, targets or 1)
    if low < LONG_RUN_SECONDS:
        return None
    if memory is None:
        memory = estimate_memory(config, source.width, source.height, targets, source.count)
    total = _bytes(memory.total)
    if targets is None:
        high = estimate_seconds(config, source.width, source.height, source.count)
        time = (f"about {duration(low)} with one target, {duration(high)} with {config.max_targets:,} at once "
                "(max_targets)")
    else:
        time = f"about {duration(low)} with {targets:,} targets at once"
    return f"{source.name}: {size} with {config.particles:,} particles a target: {time}, up to {total} of memory"


def _refuse_memory(estimate: MemoryEstimate, where: str, config) -> None:
    if estimate.total <= _limit("MAX_MEMORY"):
        return
    total, limit = _bytes(estimate.total), _bytes(_limit("MAX_MEMORY"))
    if estimate.particles >= estimate.frames + estimate.background:
        what = (f"{config.particles:,} particles x {estimate.targets:,} targets at once (max_targets) need about "
                f"{total} of memory")
        advice = "use fewer particles (--particles N) or fewer targets at once (--set max_targets=N)"
    else:
        what = f"frames of this size with the background model need about {total} of memory"
        advice = "use fewer warm-up frames (--warm-up N) or a larger --set background.downscale=N"
    raise TrackingLimitError(f"{where}: {what}, more than the limit of {limit}; {advice}, or raise the limit "
                             f"with --max-memory N", "MAX_MEMORY")


def check_config(config, where: str = "TrackerConfig.particles") -> None:
    """Refuse settings whose particles alone would exceed :data:`MAX_MEMORY`, at ``config.max_targets`` targets."""
    _refuse_memory(estimate_memory(config), where, config)


def check_run(config, source, init=None) -> MemoryEstimate:
    """Refuse a run of ``config`` on ``source`` whose estimated memory exceeds :data:`MAX_MEMORY`.

    With an init plan and no automatic initiation, the targets are those the plan has at once;
    otherwise ``config.max_targets``.  The spreads of the motion model and of the particles
    must also stay within the frame's diagonal, where a spread larger than the image places
    every particle on its border.

    Returns
    -------
    MemoryEstimate
    """
    targets = run_targets(config, init)
    diagonal = math.hypot(source.width, source.height)
    for name, value in (("motion.sigma_pos", config.motion.sigma_pos), ("motion.sigma_vel", config.motion.sigma_vel),
                        ("init_sigma", config.init_sigma), ("location.sigma", config.location.sigma)):
        if value > diagonal:
            raise TrackingError(f"{source.name}: {name} = {value:g} px is larger than the frame's diagonal "
                                f"({diagonal:.0f} px of a {source.width} x {source.height} frame)")
    estimate = estimate_memory(config, source.width, source.height, targets, source.count)
    _refuse_memory(estimate, str(source.name), config)
    return estimate


def run_targets(config, init=None) -> int | None:
    """The most targets a run tracks at once when its init plan says so (no automatic initiation), else None."""
    if init is not None and config.initiation is None:
        return max(1, int(init.peak()[0]))
    return None


# -- files -----------------------------------------------------------------------------------------
def read_small_text(path: str | os.PathLike[str], what: str, error: type[BeliefError] = TrackingError,
                    encoding: str = "utf-8") -> str:
    """The text of a regular file of at most :data:`MAX_TEXT_BYTES` bytes, else ``error``."""
    info = regular_file(path, what, error)
    name = shown(os.fspath(path))
    if info.st_size > MAX_TEXT_BYTES:
        raise error(f"cannot read {what} {name}: {info.st_size:,} bytes, more than the {MAX_TEXT_BYTES:,} such a "
                    "file may hold")
    try:
        with open(path, "rb") as handle:
            data = handle.read(MAX_TEXT_BYTES + 1)
    except OSError as exc:
        raise error(f"cannot read {what} {name}: {exc.strerror or exc}") from None
    try:
        return data.decode(encoding)
    except UnicodeDecodeError:
        raise error(f"cannot read {what} {name}: not {encoding.upper().replace('-SIG', '')} text") from None


def _toml():
    try:
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover - Python 3.10
        from .extras import require
        tomllib = require("tomli")
    return tomllib


def _nesting(text: str) -> int:
    """The deepest nesting of ``[`` and ``{`` in TOML text, outside strings and comments (an upper bound)."""
    depth = deepest = 0
    quote = None
    k, n = 0, len(text)
    while k < n:
        c = text[k]
        if quote is not None:
            if c == "\\" and quote == '"':
                k += 2
                continue
            if text.startswith(quote, k):
                k += len(quote)
                quote = None
                continue
        elif c in "\"'":
            quote = c * 3 if text.startswith(c * 3, k) else c
            k += len(quote)
            continue
        elif c == "#":
            end = text.find("\n", k)
            k = n if end < 0 else end
            continue
        elif c in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif c in "]}":
            depth = max(0, depth - 1)
        k += 1
    return deepest


def toml_value(text: str, where: str) -> Any:
    """A TOML value (``--set``'s right-hand side), or the text itself when it is not one.

    Nesting deeper than :data:`MAX_SETTINGS_DEPTH` is refused before the parser, which
    recurses, sees it.

    Examples
    --------
    >>> toml_value("[1, 2]", "--set x=[1, 2]"), toml_value("normalised", "--set m=normalised")
    ([1, 2], 'normalised')
    """
    if len(text) > MAX_TEXT_BYTES:
        raise TrackingError(f"{where}: a value of {len(text):,} characters")
    if _nesting(text) > MAX_SETTINGS_DEPTH:
        raise TrackingError(f"{where}: values nest more than {MAX_SETTINGS_DEPTH} deep")
    tomllib = _toml()
    try:
        return tomllib.loads(f"value = {text.strip()}")["value"]
    except (tomllib.TOMLDecodeError, RecursionError):
        return text.strip()


def load_toml(path: str | os.PathLike[str], what: str, error: type[BeliefError] = TrackingError) -> dict:
    """A TOML file as a dict: a regular UTF-8 file of at most :data:`MAX_TEXT_BYTES`, nesting within bounds.

    Raises
    ------
    error
        A missing, non-regular, too large, binary or malformed file, or one that nests tables
        or arrays more than :data:`MAX_SETTINGS_DEPTH` deep; the message names the file.
    """
    text = read_small_text(path, what, error)
    name = shown(os.fspath(path))
    if _nesting(text) > MAX_SETTINGS_DEPTH:
        raise error(f"{name}: arrays or tables nest more than {MAX_SETTINGS_DEPTH} deep")
    tomllib = _toml()
    try:
        mapping = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{name}: not valid TOML ({clipped(str(exc))})") from None
    except RecursionError:
        raise error(f"{name}: arrays or tables nest more than {MAX_SETTINGS_DEPTH} deep") from None
    check_settings_tree(mapping, name, error)
    return mapping


def check_settings_tree(value: Any, where: str, error: type[BeliefError] = TrackingError) -> None:
    """Refuse a settings mapping nested too deep, with too long texts or lists, or integers beyond 64 bits.

    The walk is iterative, so no nesting makes it recurse.

    Examples
    --------
    >>> check_settings_tree({"cues": ["colour"], "particles": 100}, "settings")
    >>> deep = []
    >>> for _ in range(20):
    ...     deep = [deep]
    >>> check_settings_tree({"cues": deep}, "settings")
    Traceback (most recent call last):
    ...
    belief_tracking.errors.TrackingError: settings: cues nests more than 8 deep
    """
    stack: list[tuple[str, Any, int]] = [("", value, 0)]
    while stack:
        key, item, depth = stack.pop()
        label = key or "the settings"
        if depth > MAX_SETTINGS_DEPTH:
            raise error(f"{where}: {label} nests more than {MAX_SETTINGS_DEPTH} deep")
        if isinstance(item, str):
            if len(item) > MAX_SETTING_TEXT:
                raise error(f"{where}: {label} is a text of {len(item):,} characters, more than the "
                            f"{MAX_SETTING_TEXT} a setting may have ({shown(item)})")
        elif isinstance(item, bool):
            continue
        elif isinstance(item, int):
            if not -2 ** 63 <= item < 2 ** 63:
                raise error(f"{where}: {label} = {shown(item)} is beyond the 64-bit integers")
        elif isinstance(item, Mapping):
            if len(item) > MAX_SETTING_ITEMS:
                raise error(f"{where}: {label} has {len(item):,} keys")
            for name, inner in item.items():
                if not isinstance(name, str):
                    raise error(f"{where}: a key of {label} is not a text: {shown(name)}")
                stack.append((f"{key}.{name}" if key else name, inner, depth + 1))
        elif isinstance(item, (list, tuple)):
            if len(item) > MAX_SETTING_ITEMS:
                raise error(f"{where}: {label} has {len(item):,} items, more than the {MAX_SETTING_ITEMS} a "
                            "setting may have")
            stack.extend((key, inner, depth + 1) for inner in item)


# -- image headers ---------------------------------------------------------------------------------
def image_size(data: bytes) -> tuple[int, int] | None:
    """``(width, height)`` from the header of an image file's first bytes, or None if it is not recognised.

    OpenCV has no header-only read: it allocates the whole image before it finds out whether
    it can decode it, so a 20 000 x 20 000 PNG of a few kilobytes takes 1.2 GB.  The header
    tells the size first.  PNG (IHDR), JPEG (the SOF marker), BMP, TIFF (the first IFD),
    WebP (VP8, VP8L, VP8X), JPEG 2000 (the ihdr box or the SIZ marker) and the Netpbm
    formats are read.

    Examples
    --------
    >>> import struct, zlib
    >>> png = b"\\x89PNG\\r\\n\\x1a\\n" + struct.pack(">I4sIIBBBBB", 13, b"IHDR", 20000, 20000, 8, 2, 0, 0, 0)
    >>> image_size(png)
    (20000, 20000)
    >>> image_size(b"not an image") is None
    True
    """
    try:
        return _header_size(data)
    except (struct.error, IndexError, ValueError):
        return None


def _header_size(data: bytes) -> tuple[int, int] | None:
    if data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR":
        return struct.unpack(">II", data[16:24])
    if data[:2] == b"\xff\xd8":
        return _jpeg_size(data)
    if data[:2] == b"BM":
        header = struct.unpack("<I", data[14:18])[0]
        if header == 12:
            return struct.unpack("<HH", data[18:22])
        width, height = struct.unpack("<ii", data[18:26])
        return abs(width), abs(height)
    if data[:4] in (b"II*\x00", b"MM\x00*"):
        return _tiff_size(data)
    if data[:4] == b"RIFF" and data[8:12] == b"WEBP":
        return _webp_size(data)
    if data[:12] == b"\x00\x00\x00\x0cjP  \r\n\x87\n":
        at = data.find(b"ihdr")
        if at < 0:
            return None
        height, width = struct.unpack(">II", data[at + 4:at + 12])
        return width, height
    if data[:4] == b"\xff\x4f\xff\x51":       # a raw JPEG 2000 codestream: SIZ follows SOC
        xsiz, ysiz, xo, yo = struct.unpack(">IIII", data[8:24])
        return xsiz - xo, ysiz - yo
    if data[:1] == b"P" and data[1:2] in b"123456":
        return _pnm_size(data)
    if data[:2] == b"P7":
        text = data[:4096].decode("ascii", "replace").split()
        fields = {text[k]: text[k + 1] for k in range(len(text) - 1) if text[k] in ("WIDTH", "HEIGHT")}
        return int(fields["WIDTH"]), int(fields["HEIGHT"])
    return None


def _jpeg_size(data: bytes) -> tuple[int, int] | None:
    k = 2
    while k + 4 <= len(data):
        if data[k] != 0xFF:
            return None
        marker = data[k + 1]
        if marker == 0xFF:                     # fill bytes before a marker
            k += 1
            continue
        if marker in (0x01, *range(0xD0, 0xD8)):
            k += 2
            continue
        length = struct.unpack(">H", data[k + 2:k + 4])[0]
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
            height, width = struct.unpack(">HH", data[k + 5:k + 9])
            return width, height
        if marker == 0xDA or length < 2:       # the scan starts before any frame header: not a valid file
            return None
        k += 2 + length
    return None


def _tiff_size(data: bytes) -> tuple[int, int] | None:
    order = "<" if data[:2] == b"II" else ">"
    offset = struct.unpack(order + "I", data[4:8])[0]
    count = struct.unpack(order + "H", data[offset:offset + 2])[0]
    size: dict[int, int] = {}
    for k in range(count):
        entry = data[offset + 2 + 12 * k:offset + 14 + 12 * k]
        tag, kind = struct.unpack(order + "HH", entry[:4])
        if tag in (256, 257):
            size[tag] = struct.unpack(order + ("H" if kind == 3 else "I"), entry[8:10 if kind == 3 else 12])[0]
    if 256 in size and 257 in size:
        return size[256], size[257]
    return None


def _webp_size(data: bytes) -> tuple[int, int] | None:
    chunk = data[12:16]
    if chunk == b"VP8X":
        width = int.from_bytes(data[24:27], "little") + 1
        height = int.from_bytes(data[27:30], "little") + 1
        return width, height
    if chunk == b"VP8L":
        bits = int.from_bytes(data[21:25], "little")
        return (bits & 0x3FFF) + 1, ((bits >> 14) & 0x3FFF) + 1
    if chunk == b"VP8 ":
        width, height = struct.unpack("<HH", data[26:30])
        return width & 0x3FFF, height & 0x3FFF
    return None


def _pnm_size(data: bytes) -> tuple[int, int] | None:
    words: list[bytes] = []
    for line in data[2:4096].splitlines():
        words += line.split(b"#", 1)[0].split()
        if len(words) >= 2:
            return int(words[0]), int(words[1])
    return None


def image_bytes_limit() -> int:
    """The largest image file read: 8 bytes a pixel of :data:`MAX_PIXELS` (16-bit RGBA, uncompressed), and 1 MiB."""
    return _limit("MAX_PIXELS") * 8 + (1 << 20)


def check_image_file(path: str, data_size: int) -> None:
    """Refuse an image file too large to be a frame within :data:`MAX_PIXELS` (before it is read)."""
    if data_size > image_bytes_limit():
        raise _over(f"image {shown(path)}: a file of {data_size:,} bytes, more than 8 bytes a pixel of "
                    f"--max-pixels", "MAX_PIXELS", " pixels")


def path_text(source: Any) -> str | None:
    """The text of a path-like ``source`` (None if it is not one); an empty path is refused."""
    if not isinstance(source, (str, os.PathLike)):
        return None
    text = os.fspath(source)
    if isinstance(text, bytes):
        text = os.fsdecode(text)
    if not text.strip():
        raise TrackingError("the source is an empty path: name a video, a folder of images, an image pattern or a "
                            "MOTChallenge sequence folder (use . for the working folder)")
    if "\x00" in text:
        raise TrackingError(f"the source {shown(text)} holds a NUL character")
    return text


def is_path(value: Any) -> bool:
    """Whether ``value`` is a path (text or path-like)."""
    return isinstance(value, (str, os.PathLike, Path))
