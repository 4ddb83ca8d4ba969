"""A whole tracking run: frames in, files out (``belief track``).

:func:`run` opens the source, makes a :class:`~belief_tracking.tracker.Tracker`,
consumes its frame results while showing progress and timing the tracker's own work, and
writes the run's files (:mod:`~belief_tracking.outputs`), scored against a ground
truth when one is given.  The tracker itself never touches a file.
"""

from __future__ import annotations

import sys
import time
from dataclasses import asdict, dataclass, field
from os import PathLike

import numpy as np

from . import outputs
from .config import TrackerConfig
from .detections import Detections, check_detections
from .errors import DetectionFileError, InitError, TrackingError
from .extras import require
from .initiation import InitPlan
from .motfiles import read_mot, write_tracks
from .sources import open_source
from .tracker import Tracker

__all__ = ["Summary", "run"]


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


def run(source, init: InitPlan | None, config: TrackerConfig = TrackerConfig(), out_dir: str | PathLike[str] = "track",
        seed: int = 0, write_video: bool = True, progress: bool = True, gt: np.ndarray | str | None = None,
        extra_outputs: dict | None = None, write_plot: bool = True, detections: Detections | None = None) -> Summary:
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
        the automatic initiation (``config.initiation``).
    config : TrackerConfig
        With ``config.warm_up`` > 0 the background model first learns from that many frames
        spread over the whole source (a video file is then decoded twice).
    out_dir : path
        Receives ``tracks.txt``, ``diagnostics.csv``, ``diagnostics.png`` (unless
        ``write_plot`` is false), ``annotated.avi`` (unless ``write_video`` is false) and
        ``summary.json``, written last.  Of these names, those that the run does not write
        (``annotated.avi`` with ``write_video`` false, say) are removed from the directory when
        the run succeeds, so that it holds the outputs of one run only; other files are left.
    seed : int
        Seed of the run's only random generator.
    progress : bool
        Show a progress bar on standard error (only when it is a terminal).
    gt : ndarray or path, optional
        Ground truth to score the tracks against (:func:`~belief_tracking.evaluation.evaluate`).
    extra_outputs : dict of str to callable, optional
        Further files ``name -> write(path)``, committed with the others.
    write_plot : bool
        Draw ``diagnostics.png``.
    detections : Detections, optional
        A detector's boxes by frame (:func:`~belief_tracking.detections.read_detections`),
        given to the tracker frame by frame; the summary records their source.  Detections
        after the last frame or wholly outside the image are refused before anything is
        written.

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
    """
    tqdm = require("tqdm").tqdm

    from belief import __version__
    from .evaluation import evaluate
    from .video import AnnotatedVideoWriter

    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise TrackingError(f"the seed must be a non-negative integer, got {seed!r}")
    if init is not None and not isinstance(init, InitPlan):
        raise TrackingError(f"init must be an InitPlan or None, got {type(init).__name__}")
    if not isinstance(config, TrackerConfig):
        raise TrackingError(f"config must be a TrackerConfig, got {type(config).__name__}")
    if init is None and config.initiation is None:
        raise InitError("nothing to track: give an init plan or turn on the automatic initiation")
    if detections is not None and not isinstance(detections, Detections):
        raise TrackingError(f"detections must be Detections or None, got {type(detections).__name__}")
    started = time.perf_counter()
    frames = open_source(source)
    try:
        gt_rows = None
        if gt is not None:
            gt_rows = read_mot(gt) if isinstance(gt, (str, PathLike)) else np.asarray(gt, dtype=np.float64)
        if init is not None:
            init.check_image(frames.width, frames.height)
        if detections is not None:
            check_detections(detections, frame_count=frames.count, image_size=(frames.width, frames.height))
        owned = outputs.RUN_OUTPUTS + tuple(extra_outputs or ())
        staged = outputs.StagedOutputs(out_dir, owned=owned)
    except BaseException:
        frames.close()
        raise
    try:
        tracker = Tracker(config, init, np.random.default_rng(int(seed)))
        if config.warm_up > 0 and tracker.background is not None:
            tracker.warm_up(frames.spread(config.warm_up))
        writer = AnnotatedVideoWriter(staged.path("annotated.avi"), frames.fps) if write_video else None
        rows: list[list[float]] = []
        records: list[dict[str, float]] = []
        tracking_seconds = 0.0
        count = 0
        bar = tqdm(total=frames.count, unit="frame", desc="tracking", file=sys.stderr, leave=False,
                   disable=not progress or not sys.stderr.isatty())
        shown: list[np.ndarray] = []

        def remembered():
            # The annotated video draws each result on the frame it came from.
            for image in frames:
                shown[:] = [image]
                yield image

        try:
            for result in tracker.track(remembered(), detections=detections):
                tracking_seconds += result.seconds
                frame_rows = result.mot_rows()
                for row, estimate in zip(frame_rows, result.estimates):
                    if not np.isfinite(row).all():
                        raise TrackingError(f"frame {result.frame}: target {estimate.id} has a non-finite estimate")
                rows += frame_rows
                records += result.diagnostics.rows(result.frame)
                if writer is not None:
                    writer.write(shown[0], result.frame, [(e.id, e.box) for e in result.estimates])
                count += 1
                bar.update(1)
        finally:
            bar.close()
            if writer is not None:
                writer.close()
        if count == 0:
            raise TrackingError(f"{frames.name}: no frame to track")
        missing = frames.missing(count)
        if not missing and detections is not None and detections.frames and detections.frames[-1] > count:
            # A container may announce more frames than it holds, so the check before the run can miss this.
            raise DetectionFileError(f"{detections.source}: frame {detections.frames[-1]} is after the end of "
                                     f"the video ({count} frames)")
        tracks = np.array(rows, dtype=np.float64).reshape(-1, 10)
        write_tracks(staged.path("tracks.txt"), rows)
        outputs.write_diagnostics(staged.path("diagnostics.csv"), records, ("frame", "id") + tracker.diagnostic_columns)
        if write_plot:
            outputs.plot_diagnostics(staged.path("diagnostics.png"), records,
                                     title=f"{frames.name}: {config.describe()}",
                                     threshold=config.adaptive_fusion.threshold)
        for name, write in (extra_outputs or {}).items():
            write(staged.path(name))
        scores = evaluate(gt_rows, tracks) if gt_rows is not None else None
        overall = time.perf_counter() - started
        tracking_fps = count / tracking_seconds if tracking_seconds > 0 else float("inf")
        overall_fps = count / overall if overall > 0 else float("inf")
        summary = {
            "source": frames.name,
            "frames": count,
            "expected_frames": frames.count,
            "complete": not missing,
            "targets": len({int(row[1]) for row in rows}),
            "track_rows": len(rows),
            "fps": {"tracking": tracking_fps, "overall": overall_fps, "decoding_seconds": frames.decode_seconds,
                    "tracking_seconds": tracking_seconds, "overall_seconds": overall},
            "seed": int(seed),
            "init": init.source if init is not None else "automatic initiation",
            "detections": detections.source if detections is not None else None,
            "parameters": asdict(config),
            "version": __version__,
            "scores": scores.to_dict() if scores is not None else None,
        }
        outputs.write_summary(staged.path("summary.json"), summary)
        files = staged.commit()
    except BaseException:
        staged.abort()
        raise
    finally:
        frames.close()
    return Summary(count, tracking_fps, overall_fps, tracks, scores, files, records,
                   expected_frames=frames.count)
