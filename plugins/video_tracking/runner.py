"""A whole tracking run: frames in, files out (``belief track``).

:func:`run` checks its output folder and its inputs
(:class:`~belief_tracking.outdir.OutputFolder`: nothing of the user's is replaced), opens
the source, makes a
:class:`~belief_tracking.tracker.Tracker` (:func:`start_tracker`), and hands its frame
results to the run's writers (:mod:`~belief_tracking.writers`: tracks, diagnostics, plot,
annotated video, progress bar, timing, scores and summary), which write the files once the
frames are known to be complete; then the staged files are committed.  The tracker itself
never touches a file.
"""

from __future__ import annotations

import dataclasses
import functools
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from os import PathLike

import numpy as np

from . import limits, outputs
from .config import TrackerConfig
from .defaults import AUTOMATIC_WARM_UP
from .detections import Detections, check_detections
from .errors import DetectionFileError, InitError, TrackingError
from .extras import require
from .initiation import FOLLOW_PLAN, InitiationConfig, InitPlan
from .motfiles import check_ground_truth, read_mot
from .outdir import OutputFolder, input_paths
from .sources import FrameSource, open_source
from .track_paths import TrackPathsPicture
from .tracker import Tracker
from .writers import (
    AnnotatedVideo,
    DiagnosticsPlot,
    DiagnosticsWriter,
    ExtraFile,
    FrameWriter,
    ProgressBar,
    Scoring,
    SummaryWriter,
    Timing,
    TracksWriter,
    feed,
)

__all__ = ["Summary", "run", "run_config", "start_tracker", "output_names"]


@dataclass(frozen=True)
class Summary:
    """What a :func:`run` did.

    Attributes
    ----------
    frames : int
        Frames processed.
    tracking_fps : float
        Frames per second of the tracker alone (decoding and output excluded).
    overall_fps : float
        Frames per second of the whole run (decoding and writing included).
    tracks : ndarray, shape (M, 10)
        The rows of ``tracks.txt``.
    scores : Scores or None
        The evaluation against the ground truth, when it is known.
    files : dict of str to Path
        The output files by name.
    diagnostics : list of dict
        The rows of ``diagnostics.csv`` (frame, id and the diagnostic columns), unrounded.
    expected_frames : int or None
        The number of frames the source announces (a video's container), if known.
    """

    frames: int
    tracking_fps: float
    overall_fps: float
    tracks: np.ndarray
    scores: object | None
    files: dict
    diagnostics: list = field(default_factory=list, repr=False)
    expected_frames: int | None = None

    @property
    def complete(self) -> bool:
        """Whether every frame the source announces was tracked (False for a truncated or corrupt video)."""
        return self.expected_frames is None or self.frames >= self.expected_frames

    def to_dict(self) -> dict:
        """The JSON-ready part (no arrays)."""
        return {"frames": self.frames, "expected_frames": self.expected_frames, "complete": self.complete,
                "tracking_fps": self.tracking_fps, "overall_fps": self.overall_fps,
                "scores": None if self.scores is None else self.scores.to_dict(),
                "files": {k: str(v) for k, v in self.files.items()}}


def output_names(write_video: bool = True, write_plot: bool = True, extra: tuple[str, ...] | dict = ()) -> tuple[str, ...]:
    """The names of the files a :func:`run` writes, ``summary.json`` last.

    ``write_plot`` false leaves out both pictures, ``diagnostics.png`` and ``tracks.png``.

    Examples
    --------
    >>> output_names(write_video=False, extra=("gt.txt",))
    ('tracks.txt', 'diagnostics.csv', 'diagnostics.png', 'tracks.png', 'gt.txt', 'summary.json')
    >>> output_names(write_plot=False)
    ('tracks.txt', 'diagnostics.csv', 'annotated.avi', 'summary.json')
    """
    left = {"annotated.avi": write_video, **{name: write_plot for name in outputs.PICTURES}}
    names = [name for name in outputs.RUN_OUTPUTS if left.get(name, True) and name != "summary.json"]
    return (*names, *extra, "summary.json")


def run(source, init: InitPlan | None, config: TrackerConfig = TrackerConfig(),
        out_dir: str | PathLike[str] | OutputFolder = "track", seed: int = 0, write_video: bool = True,
        progress: bool = True, gt: np.ndarray | str | None = None, extra_outputs: dict | None = None,
        write_plot: bool = True, detections: Detections | None = None, force: bool = False,
        announce: Callable[[str], None] | None = None) -> Summary:
    """Track ``source`` and write the outputs into ``out_dir``.

    Parameters
    ----------
    source : path, FrameSource, Scene or ndarray of uint8, shape (T, H, W, 3)
        Anything :func:`~belief_tracking.sources.open_source` opens: a video file, a
        folder of images, an image pattern or a MOTChallenge sequence folder (all decoded
        frame by frame), a source already open, a rendered synthetic scene, or frames.
    init : InitPlan or None
        Births and deaths of the targets (:func:`~belief_tracking.initiation.init_from_gt`,
        :func:`~belief_tracking.initiation.read_init_boxes`); None leaves them all to
        the automatic initiation.  Where ``config.initiation`` is None, the run learns the
        background first and reads the frames' candidates, as on the command line
        (:func:`run_config`): a plan's tracks follow the candidates they take (with the
        foreground cue), and without a plan the tracker finds the people itself from the first
        frame on.
    config : TrackerConfig
        With ``config.warm_up`` > 0 the background model first learns from that many frames
        spread over the whole source (a video file is then decoded twice).
    out_dir : path or OutputFolder
        Receives ``tracks.txt``, ``diagnostics.csv``, ``diagnostics.png`` and ``tracks.png``
        (unless ``write_plot`` is false), ``annotated.avi`` (unless ``write_video`` is false), the
        ``extra_outputs`` and ``summary.json``, written last (:func:`output_names`).  It is
        checked before any work (:class:`~belief_tracking.outdir.OutputFolder`): refused if it
        is, lies inside or holds the source or the ground-truth file, or, unless ``force``,
        if it holds files that no run wrote there.  The files of an earlier run there that
        this one does not write (``annotated.avi`` with ``write_video`` false, say) are
        removed when the run succeeds, so that it holds the outputs of one run only.  An
        :class:`~belief_tracking.outdir.OutputFolder` already checked (by a command line that
        knows every input) is used as it is.
    seed : int
        Seed of the run's only random generator.
    progress : bool
        Show a progress bar on standard error (only when it is a terminal).
    gt : ndarray or path, optional
        Ground truth to score the tracks against (:func:`~belief_tracking.evaluation.evaluate`).
    extra_outputs : dict of str to callable, optional
        Further files ``name -> write(path)``, committed with the others.
    write_plot : bool
        Draw the pictures: ``diagnostics.png`` (the diagnostics over the frames) and
        ``tracks.png`` (every track's path over the middle frame,
        :mod:`~belief_tracking.track_paths`).
    detections : Detections, optional
        A detector's boxes by frame (:func:`~belief_tracking.detections.read_detections`),
        given to the tracker frame by frame; the summary records their source.  Detections
        after the last frame or wholly outside the image are refused before anything is
        written.
    force : bool
        Write into ``out_dir`` even if it holds files that no run wrote there (those of the
        run's names are replaced, the others left).
    announce : callable, optional
        Receives one line before the work starts when the run is estimated to take more than
        :data:`~belief_tracking.limits.LONG_RUN_SECONDS` (:func:`~belief_tracking.limits.long_run_notice`):
        its frames, particles, estimated time and memory.

    Returns
    -------
    Summary
        A video that decodes fewer frames than its container announces (truncated, or a
        corrupt frame, where decoding stops) is tracked up to its last decoded frame and its
        outputs are written: ``summary.complete`` is then False, ``summary.expected_frames``
        gives the announced count, and ``summary.json`` records both (``belief track`` then
        exits with status 1, naming the decoded and expected frames).

    Raises
    ------
    TrackingError
        Unreadable video (:class:`VideoError`), boxes outside the image (:class:`InitError`),
        detections that do not fit the video (:class:`DetectionFileError`), …
        On any error the staged files are deleted: nothing that looks complete is left.
    OutputFolderError
        ``out_dir`` may not receive the run's files (the message says why).
    """
    for package in ("tqdm", "cv2"):
        require(package)  # a missing extra is one line, before any input is read or any file written
    _check_arguments(seed, init, config, detections)
    config = run_config(config, init)
    started = time.perf_counter()
    names = output_names(write_video, write_plot, tuple(extra_outputs or ()))
    staged = _output_folder(out_dir, names, input_paths(source, gt), force)
    try:
        frames = open_source(source)
    except BaseException:
        staged.abort()
        raise
    try:
        gt_rows = _ground_truth(gt)
        if gt_rows is not None:
            check_ground_truth(gt_rows, frames.count, str(gt) if isinstance(gt, (str, PathLike)) else "the ground truth")
        _check_fit(frames, init, detections)
        memory = limits.check_run(config, frames, init)
        notice = limits.long_run_notice(config, frames, limits.run_targets(config, init), memory)
        if notice is not None and announce is not None:
            announce(notice)
        tracker = start_tracker(config, init, seed, frames)
        timing = Timing(started)
        tracks = TracksWriter(staged.path("tracks.txt"))
        diagnostics = DiagnosticsWriter(staged.path("diagnostics.csv"), tracker.diagnostic_columns)
        scoring = Scoring(gt_rows, tracks) if gt_rows is not None else None
        writers = _writers(staged, frames, config, timing, tracks, diagnostics, scoring,
                           settings=_settings_record(seed, init, detections, config), write_video=write_video,
                           write_plot=write_plot, progress=progress, extra_outputs=extra_outputs or {})
        feed(functools.partial(tracker.track, detections=detections), frames, writers)
        _check_length(frames, timing.frames, detections)
        for writer in writers:
            writer.finish()
        files = staged.commit()
    except BaseException:
        staged.abort()
        raise
    finally:
        frames.close()
    return Summary(timing.frames, timing.tracking_fps, timing.overall_fps, tracks.array(),
                   scoring.scores if scoring is not None else None, files, diagnostics.records,
                   expected_frames=frames.count)


def run_config(config: TrackerConfig, init: InitPlan | None) -> TrackerConfig:
    """The settings a :func:`run` of ``config`` and ``init`` tracks with, as on the command line.

    A config with an initiation is used as it is.  Without one, the run's tracks learn the
    background from :data:`~belief_tracking.defaults.AUTOMATIC_WARM_UP` frames (unless
    ``config.warm_up`` is set) and read the frame's candidates:

    * no plan: the tracker finds the people itself, from the first frame on
      (``InitiationConfig(first_frame=True)``);
    * a plan and the foreground cue: the plan's births and deaths are all there are
      (:data:`~belief_tracking.initiation.FOLLOW_PLAN`), and the foreground's blobs (or a
      detector's boxes) support and correct its tracks, lose them and find them again.
      Knowing the births is more than an automatic run knows: its tracks must not see less
      than automatic ones see.

    A plan without the foreground cue keeps no background model: its tracks are the particle
    filters alone, as the cues ask (an ablation of the cues).  The summary of the run records
    the settings used.

    Examples
    --------
    >>> from belief_tracking.initiation import FOLLOW_PLAN, init_from_boxes
    >>> config = run_config(TrackerConfig(), init_from_boxes([(10, 20, 8, 16)]))
    >>> config.initiation == FOLLOW_PLAN, config.warm_up
    (True, 50)
    >>> config = run_config(TrackerConfig(warm_up=10), None)
    >>> config.initiation.first_frame, config.initiation.births, config.warm_up
    (True, True, 10)
    >>> run_config(TrackerConfig(cues=("colour", "location")), init_from_boxes([(10, 20, 8, 16)])).initiation is None
    True
    """
    if config.initiation is not None or (init is not None and "foreground" not in config.cues):
        return config
    initiation = InitiationConfig(first_frame=True) if init is None else FOLLOW_PLAN
    return dataclasses.replace(config, initiation=initiation, warm_up=config.warm_up or AUTOMATIC_WARM_UP)


def start_tracker(config: TrackerConfig, init: InitPlan | None, seed: int, source: FrameSource) -> Tracker:
    """A tracker seeded with ``seed``, its background model warmed up on ``source`` when ``config.warm_up`` asks.

    The frames of the warm-up are spread over the whole source
    (:meth:`~belief_tracking.sources.FrameSource.spread`), read apart from those of the run.
    """
    tracker = Tracker(config, init, np.random.default_rng(int(seed)))
    if config.warm_up > 0 and tracker.background is not None:
        tracker.warm_up(source.spread(config.warm_up))
    return tracker


def _output_folder(out_dir, names: tuple[str, ...], inputs: list[str], force: bool) -> OutputFolder:
    """``out_dir`` checked for a run writing ``names`` (an OutputFolder given is trusted to be checked already)."""
    if not isinstance(out_dir, OutputFolder):
        return OutputFolder(out_dir, names, inputs=inputs, force=force)
    if not set(names) <= set(out_dir.names):
        raise TrackingError(f"the output folder was checked for {', '.join(out_dir.names)}, not for "
                            f"{', '.join(sorted(set(names) - set(out_dir.names)))}")
    return out_dir


def _check_arguments(seed, init, config, detections) -> None:
    """Refuse arguments of the wrong type before any input is opened."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise TrackingError(f"the seed must be a non-negative integer, got {seed!r}")
    if init is not None and not isinstance(init, InitPlan):
        raise TrackingError(f"init must be an InitPlan or None, got {type(init).__name__}")
    if not isinstance(config, TrackerConfig):
        raise TrackingError(f"config must be a TrackerConfig, got {type(config).__name__}")
    if detections is not None and not isinstance(detections, Detections):
        raise TrackingError(f"detections must be Detections or None, got {type(detections).__name__}")


def _ground_truth(gt: np.ndarray | str | PathLike[str] | None) -> np.ndarray | None:
    """The rows of a ground truth given as a MOTChallenge file or as rows (None when there is none)."""
    if gt is None:
        return None
    return read_mot(gt) if isinstance(gt, (str, PathLike)) else np.asarray(gt, dtype=np.float64)


def _check_fit(frames: FrameSource, init: InitPlan | None, detections: Detections | None) -> None:
    """Refuse init boxes outside the image, and detections after the source's frames or outside its image."""
    if init is not None:
        init.check_image(frames.width, frames.height)
    if detections is not None:
        check_detections(detections, frame_count=frames.count, image_size=(frames.width, frames.height))


def _writers(staged: OutputFolder, frames: FrameSource, config: TrackerConfig, timing: Timing,
             tracks: TracksWriter, diagnostics: DiagnosticsWriter, scoring: Scoring | None, *,
             settings: dict, write_video: bool, write_plot: bool, progress: bool,
             extra_outputs: dict) -> list[FrameWriter]:
    """The writers of a run, in the order they are handed each frame and then finished, ``summary.json`` last."""
    writers: list[FrameWriter] = [timing]
    if write_video:
        writers.append(AnnotatedVideo(staged.path("annotated.avi"), frames.fps))
    writers += [tracks, diagnostics]
    if write_plot:
        writers.append(DiagnosticsPlot(staged.path("diagnostics.png"), diagnostics,
                                       title=f"{frames.name}: {config.describe()}",
                                       threshold=config.adaptive_fusion.threshold))
        writers.append(TrackPathsPicture(staged.path("tracks.png"), tracks, (frames.width, frames.height),
                                         expected_frames=frames.count, title=frames.name))
    writers.append(ProgressBar(frames.count, show=progress))
    writers += [ExtraFile(staged.path(name), write) for name, write in extra_outputs.items()]
    if scoring is not None:
        writers.append(scoring)
    writers.append(SummaryWriter(staged.path("summary.json"), frames, timing, tracks, scoring, settings))
    return writers


def _check_length(frames: FrameSource, count: int, detections: Detections | None) -> None:
    """Refuse a run of no frame, and detections after the last frame the source turned out to hold."""
    if count == 0:
        raise TrackingError(f"{frames.name}: no frame to track")
    if not frames.missing(count) and detections is not None and detections.frames and detections.frames[-1] > count:
        # A container may announce more frames than it holds, so the check before the run can miss this.
        raise DetectionFileError(f"{detections.source}: frame {detections.frames[-1]} is after the end of "
                                 f"the video ({count} frames)")


def _settings_record(seed: int, init: InitPlan | None, detections: Detections | None,
                     config: TrackerConfig) -> dict:
    """What ``summary.json`` records of the run's request: seed, init, detections, parameters, version."""
    from belief import __version__

    return {"seed": int(seed), "init": init.source if init is not None else "automatic initiation",
            "detections": detections.source if detections is not None else None,
            "parameters": asdict(config), "version": __version__}
