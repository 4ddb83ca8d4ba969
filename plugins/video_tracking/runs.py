"""One run of an experiment's grid: track a cell's sequence with its settings and seed, and score it.

:func:`run_cell` hands the tracker's frame results to the writers that only keep them
(:mod:`~belief_tracking.writers`: timing, track rows, diagnostics; no file is written) and
returns a JSON-ready record: the row of ``results.csv``, the centre errors of every target
for ``rms.csv`` (W (36)), the per-frame curves of W (33)–(35) and C (15), and the tracks.
It runs on a worker (a local process or a Dask worker): a synthetic scene is rendered
there, and a recorded video (and its detection file, if any) must be readable at the same
path.  A sequence with a detection file gives each frame's boxes to the tracker
(``Tracker.track(frames, detections=...)``); its cells fuse the ``"detections"`` cue
(:meth:`belief_tracking.experiment.Cell.settings`).
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from .config import TrackerConfig
from .errors import VideoError
from .evaluation import Scores, evaluate, matched_pairs
from .experiment import CELL_FORMAT, Cell
from .initiation import init_from_gt
from .runner import start_tracker
from .sources import open_source
from .writers import DiagnosticRows, Timing, TrackRows, feed

__all__ = ["run_cell", "CURVE_COLUMNS"]

#: The diagnostics a record keeps per frame and target (W (33)–(35) and C (15)); None where a
#: run does not compute one.
CURVE_COLUMNS = ("mean_m_target", "mean_m_intersection", "mean_bel", "similarity")


def run_cell(cell: Cell) -> dict[str, Any]:
    """Track one cell and score it.

    Parameters
    ----------
    cell : Cell

    Returns
    -------
    dict
        ``row``, the row of ``results.csv``
        (:data:`~belief_tracking.tables.RESULT_COLUMNS`); ``errors`` (target id →
        list of ``[frame, centre error]``); ``curves`` (rows ``frame, id`` and
        :data:`CURVE_COLUMNS`); ``tracks`` (the rows of ``tracks.txt``); ``format`` and
        ``key`` (which cell, in which file format).

    Raises
    ------
    TrackingError
        The sequence cannot be read (a video, ground-truth or detection file; the message
        names it), a video decodes fewer frames than it announces (truncated or corrupt), or
        a setting is bad.
    """
    timing = Timing()
    config = cell.config()
    frames, gt = cell.sequence.load()
    detections = cell.sequence.load_detections()
    plan = init_from_gt(gt, source=f"ground truth of {cell.sequence.name}") if cell.sequence.init == "gt" else None
    tracks, diagnostics = TrackRows(), DiagnosticRows()
    with open_source(frames) as source:
        tracker = start_tracker(config, plan, cell.seed, source)
        feed(functools.partial(tracker.track, detections=detections), source, (timing, tracks, diagnostics))
        if source.missing(timing.frames):
            raise VideoError(f"{source.name}: decoded {timing.frames} of the {source.count} frames the file "
                             f"announces (truncated or corrupt after frame {timing.frames})")
    timing.stop()
    track_rows = tracks.array()
    errors = _centre_errors(gt, track_rows, by_id=cell.sequence.init == "gt")
    row = _results_row(cell, config, timing, evaluate(gt, track_rows), errors, diagnostics.records)
    curves = [[int(r["frame"]), int(r["id"])] + [_finite(r.get(c)) for c in CURVE_COLUMNS]
              for r in diagnostics.records]
    return {"format": CELL_FORMAT, "key": cell.key, "row": row,
            "errors": {str(k): v for k, v in errors.items()}, "curves": curves,
            "tracks": [[float(v) for v in r] for r in track_rows]}


def _results_row(cell: Cell, config: TrackerConfig, timing: Timing, scores: Scores,
                 errors: dict[int, list[list[float]]], diagnostics: list[dict[str, float]]) -> dict[str, Any]:
    """The cell's row of ``results.csv``; NaN is saved as None (a ratio without a denominator, e.g. MOTP without
    any match)."""
    squared = [e * e for pairs in errors.values() for _, e in pairs]

    def mean_of(column: str) -> float:
        values = [row[column] for row in diagnostics if column in row and math.isfinite(row[column])]
        return float(np.mean(values)) if values else math.nan

    row = {
        "sequence": cell.sequence.name,
        "method": cell.method.name,
        "rule": config.belief.rule if config.fusion == "belief" else "",
        "fusion": config.fusion,
        "cues": "+".join(config.cues),
        "seed": cell.seed,
        "particles": config.particles,
        "frames": timing.frames,
        "mota": scores.mota, "motp": scores.motp, "idf1": scores.idf1,
        "hota": scores.hota, "deta": scores.deta, "assa": scores.assa,
        "precision": scores.precision, "recall": scores.recall,
        "id_switches": scores.id_switches, "false_positives": scores.false_positives,
        "false_negatives": scores.false_negatives, "matched_pairs": scores.matched_pairs,
        "num_objects": scores.num_objects,
        "mean_centre_error": scores.mean_centre_error, "median_centre_error": scores.median_centre_error,
        "rms_error": math.sqrt(math.fsum(squared) / len(squared)) if squared else math.nan,
        "mean_particles": mean_of("particles"),
        "occluded_share": mean_of("occluded"),
        "seconds": timing.overall_seconds,
        "tracking_fps": timing.tracking_fps,
        "overall_fps": timing.overall_fps,
    }
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in row.items()}


def _finite(value: Any) -> float | None:
    if value is None or not math.isfinite(value):
        return None
    return float(value)


def _centre_errors(gt: np.ndarray, tracks: np.ndarray, by_id: bool) -> dict[int, list[list[float]]]:
    """Per scored ground-truth target: ``[frame, centre error]`` of each frame it has an estimate.

    ``by_id``: the estimate is the track with the target's id, whatever its overlap; otherwise
    it is the track paired with the target in that frame by the scoring (IoU ≥ 0.5,
    :func:`~belief_tracking.evaluation.matched_pairs`).
    """
    gt = np.asarray(gt, dtype=np.float64)
    tracks = np.asarray(tracks, dtype=np.float64).reshape(-1, 10)
    if by_id:
        if gt.shape[1] > 6:
            gt = gt[gt[:, 6] != 0]

        def centres(rows: np.ndarray) -> np.ndarray:
            return rows[:, 2:4] + rows[:, 4:6] / 2.0

        estimate = {(int(f), int(i)): c for (f, i), c in zip(tracks[:, :2], centres(tracks))}
        rows = [(int(f), int(i), float(np.hypot(*(estimate[int(f), int(i)] - c))))
                for (f, i), c in zip(gt[:, :2], centres(gt)) if (int(f), int(i)) in estimate]
    else:
        rows = [(int(f), int(i), float(e)) for f, i, _, e in matched_pairs(gt, tracks)]
    errors: dict[int, list[list[float]]] = {}
    for frame, target, error in sorted(rows):
        errors.setdefault(target, []).append([frame, error])
    return dict(sorted(errors.items()))
