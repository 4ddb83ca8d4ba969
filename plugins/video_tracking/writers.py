"""The parts of a tracking run that consume the tracker's frame results, one job each.

As in Stone Soup, where the tracker is an iterator and readers and writers are separate
components, a run (:func:`~belief_tracking.runner.run`) is a loop over writers: :func:`feed`
hands every :class:`~belief_tracking.tracker.FrameResult`, with the image it was computed
on, to each :class:`FrameWriter` in turn, and closes them all when the frames end, however
they end.  Once the run is known to be good, :meth:`FrameWriter.finish` writes each one's
file, in the order of the writers, so that a writer may read what those before it kept (the
scores read the tracks, the summary reads everything).

Some writers only keep what the frames give and write no file: :class:`Timing`,
:class:`TrackRows` and :class:`DiagnosticRows` (an experiment's cell,
:func:`~belief_tracking.runs.run_cell`, uses them as they are).  The others write one of the
files of :mod:`~belief_tracking.outputs` each: :class:`TracksWriter` (``tracks.txt``),
:class:`DiagnosticsWriter` (``diagnostics.csv``), :class:`DiagnosticsPlot`
(``diagnostics.png``), :class:`~belief_tracking.track_paths.TrackPathsPicture` (``tracks.png``), :class:`AnnotatedVideo` (``annotated.avi``, drawn frame by frame),
:class:`ExtraFile` (a file of the caller's), :class:`Scoring` (the scores against a ground
truth, for the summary) and :class:`SummaryWriter` (``summary.json``, last); and
:class:`ProgressBar` shows the progress.
"""

from __future__ import annotations

import contextlib
import math
import sys
import time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from os import PathLike
from typing import TYPE_CHECKING, Any

import numpy as np

from . import outputs
from .errors import TrackingError
from .evaluation import evaluate
from .extras import require
from .motfiles import write_tracks

if TYPE_CHECKING:  # pragma: no cover - annotations only: the writers need no tracker internals
    from .evaluation import Scores
    from .sources import FrameSource
    from .tracker import FrameResult

__all__ = ["FrameWriter", "feed", "Timing", "TrackRows", "TracksWriter", "DiagnosticRows", "DiagnosticsWriter",
           "DiagnosticsPlot", "AnnotatedVideo", "ProgressBar", "ExtraFile", "Scoring", "SummaryWriter"]


class FrameWriter:
    """One job over the frame results of a run; every step of this base class does nothing.

    A writer is given each frame's result (:meth:`write`), then closed when the frames end,
    whether the run failed or not (:meth:`close`); only a run that succeeded then has it
    write its file (:meth:`finish`).
    """

    def write(self, result: FrameResult, image: np.ndarray | None) -> None:
        """Take one frame's result and the image it was computed on (None where no image is kept)."""

    def close(self) -> None:
        """Release what the frames needed (a file being written, a progress bar), on success or failure."""

    def finish(self) -> None:
        """Write the file, once the run is known to be good (the writers before this one have finished)."""


def feed(track: Callable[[Iterable[np.ndarray]], Iterable[FrameResult]], frames: Iterable[np.ndarray],
         writers: Sequence[FrameWriter]) -> None:
    """Hand every result of ``track(frames)``, with its image, to each writer in order; then close them all.

    Parameters
    ----------
    track : callable
        Frames to frame results: a tracker's :meth:`~belief_tracking.tracker.Tracker.track`
        (``functools.partial`` gives it the detections).
    frames : iterable of ndarray
    writers : sequence of FrameWriter
        Closed in reverse order when the frames end, or when a writer or the tracker raises.

    Examples
    --------
    >>> import dataclasses
    >>> from belief_tracking import scenes
    >>> from belief_tracking.config import TrackerConfig
    >>> from belief_tracking.initiation import init_from_gt
    >>> from belief_tracking.tracker import Tracker
    >>> scene = scenes.render(dataclasses.replace(scenes.crossing(0), n_frames=3))
    >>> tracker = Tracker(TrackerConfig(particles=20), init_from_gt(scene.ground_truth), np.random.default_rng(0))
    >>> timing, tracks = Timing(), TrackRows()
    >>> feed(tracker.track, scene.frames, [timing, tracks])
    >>> timing.frames, tracks.array().shape, tracks.targets()
    (3, (6, 10), 2)
    """
    shown: list[np.ndarray | None] = [None]

    def remembered() -> Iterator[np.ndarray]:
        # The tracker takes a frame and yields its result before it takes the next one, so the
        # last image handed out is the one that result was computed on.
        for image in frames:
            shown[0] = image
            yield image

    with contextlib.ExitStack() as stack:
        for writer in writers:
            stack.callback(writer.close)
        for result in track(remembered()):
            image = shown[0]
            for writer in writers:
                writer.write(result, image)


class Timing(FrameWriter):
    """The frames of a run, the seconds the tracker spent on them, and the whole run's seconds.

    Parameters
    ----------
    started : float, optional
        When the run started (:func:`time.perf_counter`); default now.

    Attributes
    ----------
    frames : int
    tracking_seconds : float
        The sum of the results' ``seconds`` (decoding and output excluded).
    overall_seconds : float or None
        From ``started`` to :meth:`stop`; None before.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> timing = Timing(started=time.perf_counter())
    >>> for seconds in (0.25, 0.25):
    ...     timing.write(SimpleNamespace(seconds=seconds), None)
    >>> timing.frames, timing.tracking_fps
    (2, 4.0)
    >>> timing.stop() > 0, timing.overall_fps > 0
    (True, True)
    """

    def __init__(self, started: float | None = None) -> None:
        self.started = time.perf_counter() if started is None else started
        self.frames = 0
        self.tracking_seconds = 0.0
        self.overall_seconds: float | None = None

    def write(self, result: FrameResult, image: np.ndarray | None) -> None:
        self.frames += 1
        self.tracking_seconds += result.seconds

    def stop(self) -> float:
        """End the run's clock; returns :attr:`overall_seconds`."""
        self.overall_seconds = time.perf_counter() - self.started
        return self.overall_seconds

    @property
    def tracking_fps(self) -> float:
        """Frames per second of the tracker alone (infinite when it took no measurable time)."""
        return self.frames / self.tracking_seconds if self.tracking_seconds > 0 else math.inf

    @property
    def overall_fps(self) -> float:
        """Frames per second of the whole run, up to :meth:`stop` (infinite before)."""
        overall = self.overall_seconds
        return self.frames / overall if overall is not None and overall > 0 else math.inf


class TrackRows(FrameWriter):
    """The MOTChallenge rows of the estimates; a non-finite estimate is refused, naming its frame and target.

    Attributes
    ----------
    rows : list of list of float
        ``frame, id, x, y, w, h, -1, -1, -1, -1`` (:meth:`~belief_tracking.tracker.FrameResult.mot_rows`).
    """

    def __init__(self) -> None:
        self.rows: list[list[float]] = []

    def write(self, result: FrameResult, image: np.ndarray | None) -> None:
        rows = result.mot_rows()
        for row, estimate in zip(rows, result.estimates):
            if not all(map(math.isfinite, row)):
                raise TrackingError(f"frame {result.frame}: target {estimate.id} has a non-finite estimate")
        self.rows += rows

    def array(self) -> np.ndarray:
        """The rows as an array of shape (M, 10)."""
        return np.array(self.rows, dtype=np.float64).reshape(-1, 10)

    def targets(self) -> int:
        """How many ids the rows hold."""
        return len({int(row[1]) for row in self.rows})


class TracksWriter(TrackRows):
    """:class:`TrackRows` written to ``path`` as ``tracks.txt`` (:func:`~belief_tracking.motfiles.write_tracks`)."""

    def __init__(self, path: str | PathLike[str]) -> None:
        super().__init__()
        self.path = path

    def finish(self) -> None:
        write_tracks(self.path, self.rows)


class DiagnosticRows(FrameWriter):
    """The diagnostics of every frame and target (:meth:`~belief_tracking.tracker.FrameDiagnostics.rows`), unrounded.

    Attributes
    ----------
    records : list of dict
        ``frame``, ``id`` and the tracker's diagnostic columns.
    """

    def __init__(self) -> None:
        self.records: list[dict[str, float]] = []

    def write(self, result: FrameResult, image: np.ndarray | None) -> None:
        self.records += result.diagnostics.rows(result.frame)


class DiagnosticsWriter(DiagnosticRows):
    """:class:`DiagnosticRows` written to ``path`` as ``diagnostics.csv``.

    Parameters
    ----------
    path : path
    columns : sequence of str
        The tracker's :attr:`~belief_tracking.tracker.Tracker.diagnostic_columns`, after
        ``frame`` and ``id``.
    """

    def __init__(self, path: str | PathLike[str], columns: Sequence[str]) -> None:
        super().__init__()
        self.path = path
        self.header = ("frame", "id", *columns)

    def finish(self) -> None:
        outputs.write_diagnostics(self.path, self.records, self.header)


class DiagnosticsPlot(FrameWriter):
    """``diagnostics.png`` (:func:`~belief_tracking.outputs.plot_diagnostics`) of what ``diagnostics`` kept.

    Parameters
    ----------
    path : path
    diagnostics : DiagnosticRows
        A writer before this one, whose records are drawn.
    title : str
    threshold : float or None
        The occlusion threshold drawn on the similarity panel.
    """

    def __init__(self, path: str | PathLike[str], diagnostics: DiagnosticRows, title: str = "",
                 threshold: float | None = None) -> None:
        self.path = path
        self.diagnostics = diagnostics
        self.title = title
        self.threshold = threshold

    def finish(self) -> None:
        outputs.plot_diagnostics(self.path, self.diagnostics.records, title=self.title, threshold=self.threshold)


class AnnotatedVideo(FrameWriter):
    """``annotated.avi``: each frame with its estimates' boxes and ids, written as it comes.

    Parameters
    ----------
    path : path
    fps : float
        The source's frame rate.
    """

    def __init__(self, path: str | PathLike[str], fps: float) -> None:
        from .video import AnnotatedVideoWriter  # OpenCV stays at the edges: out of the import path

        self._video = AnnotatedVideoWriter(path, fps)

    def write(self, result: FrameResult, image: np.ndarray | None) -> None:
        self._video.write(image, result.frame, [(e.id, e.box) for e in result.estimates])

    def close(self) -> None:
        self._video.close()


class ProgressBar(FrameWriter):
    """A tqdm progress bar on standard error, shown only when it is a terminal; one step per frame.

    Parameters
    ----------
    total : int or None
        The number of steps, if known.
    show : bool
        False hides the bar whatever standard error is.
    unit, desc : str
        The bar's unit and label.

    Attributes
    ----------
    shown : bool
        Whether the bar is drawn: ``show`` and standard error is a terminal.

    Examples
    --------
    >>> bar = ProgressBar(2, show=False)
    >>> bar.advance(); bar.advance(); bar.close()
    >>> bar.shown
    False
    """

    def __init__(self, total: int | None, show: bool = True, unit: str = "frame", desc: str = "tracking") -> None:
        tqdm = require("tqdm").tqdm
        # A bar written into a log file or a pipe would be a line of noise per update.
        self.shown = bool(show) and sys.stderr.isatty()
        self._bar = tqdm(total=total, unit=unit, desc=desc, file=sys.stderr, leave=False, disable=not self.shown)

    def write(self, result: FrameResult, image: np.ndarray | None) -> None:
        self._bar.update(1)

    def advance(self) -> None:
        """One step done (for steps that are not frames, such as an experiment's runs)."""
        self._bar.update(1)

    def close(self) -> None:
        self._bar.close()


class ExtraFile(FrameWriter):
    """A file of the caller's, ``write(path)``, written and committed with the run's own."""

    def __init__(self, path: str | PathLike[str], write: Callable[[str | PathLike[str]], Any]) -> None:
        self.path = path
        self._write = write

    def finish(self) -> None:
        self._write(self.path)


class Scoring(FrameWriter):
    """The scores of the tracks against a ground truth (:func:`~belief_tracking.evaluation.evaluate`).

    Parameters
    ----------
    gt : ndarray
        MOTChallenge ground-truth rows.
    tracks : TrackRows
        A writer before this one.

    Attributes
    ----------
    scores : Scores or None
        Once finished.
    """

    def __init__(self, gt: np.ndarray, tracks: TrackRows) -> None:
        self.gt = gt
        self.tracks = tracks
        self.scores: Scores | None = None

    def finish(self) -> None:
        self.scores = evaluate(self.gt, self.tracks.array())


class SummaryWriter(FrameWriter):
    """``summary.json``: the source, frames, targets, speed, the run's settings and its scores.

    Written last: finishing it stops the run's clock (:meth:`Timing.stop`).

    Parameters
    ----------
    path : path
    source : FrameSource
        The source tracked (its name, announced frame count and decoding time).
    timing : Timing
    tracks : TrackRows
    scoring : Scoring or None
        None when there is no ground truth (``"scores": null``).
    settings : mapping
        What the run was asked (seed, init, detections, parameters, version), recorded
        between the speed and the scores.
    """

    def __init__(self, path: str | PathLike[str], source: FrameSource, timing: Timing, tracks: TrackRows,
                 scoring: Scoring | None, settings: Mapping[str, Any]) -> None:
        self.path = path
        self.source = source
        self.timing = timing
        self.tracks = tracks
        self.scoring = scoring
        self.settings = settings

    def finish(self) -> None:
        timing = self.timing
        timing.stop()
        scores = self.scoring.scores if self.scoring is not None else None
        summary = {
            "source": self.source.name,
            "frames": timing.frames,
            "expected_frames": self.source.count,
            "complete": not self.source.missing(timing.frames),
            "targets": self.tracks.targets(),
            "track_rows": len(self.tracks.rows),
            "fps": {"tracking": timing.tracking_fps, "overall": timing.overall_fps,
                    "decoding_seconds": self.source.decode_seconds, "tracking_seconds": timing.tracking_seconds,
                    "overall_seconds": timing.overall_seconds},
            **self.settings,
            "scores": scores.to_dict() if scores is not None else None,
        }
        outputs.write_summary(self.path, summary)
