"""The tables of an experiment: one row per run, RMS error per target and frame, means over the seeds.

The files an experiment writes into its output folder:

``results.csv``
    One row per run (tidy): the sequence, the method and its rule, fusion and cues, the
    seed, the CLEAR MOT and identity scores, HOTA with its detection and association
    parts (DetA, AssA), the centre errors, the RMS error of the run,
    the mean particle count, the share of target-frames flagged as occluded (empty when the
    run did not follow the appearance), and the timings (:data:`TIMING_COLUMNS`, the only
    columns that differ between two runs of the same grid).
``rms.csv``
    The RMS position error of every target at every frame over the seeds, W (36):
    ``RMS_t = sqrt(1/n_runs · Σ_k [(x_k(t) − x̂_k(t))² + (y_k(t) − ŷ_k(t))²])``, with box
    centres.  When the tracks start from the ground truth a target's estimate is the track
    with its id; with the automatic initiation it is the track paired with it in that frame
    (IoU ≥ 0.5).  ``runs`` counts the runs that had an estimate.
``summary.csv``
    Per sequence and method: the mean and standard deviation over the seeds of
    :data:`SUMMARY_METRICS`.

Every file is written under a temporary name and renamed into place, so an interruption
never leaves half a table.
"""

from __future__ import annotations

import contextlib
import csv
import io
import math
import os
import secrets
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["SCORE_COLUMNS", "TIMING_COLUMNS", "RESULT_COLUMNS", "RMS_COLUMNS", "SUMMARY_METRICS",
           "summary_columns", "rms_per_frame", "summarise", "format_summary", "write_csv", "write_text"]

#: Columns of ``results.csv`` that hold scores (identical for identical seeds).
SCORE_COLUMNS = ("mota", "motp", "idf1", "hota", "deta", "assa", "precision", "recall", "id_switches",
                 "false_positives", "false_negatives", "matched_pairs", "num_objects", "mean_centre_error", "median_centre_error",
                 "rms_error", "mean_particles", "occluded_share")

#: Columns of ``results.csv`` that hold timings (the only ones that vary from run to run).
TIMING_COLUMNS = ("seconds", "tracking_fps", "overall_fps")

#: The columns of ``results.csv``.
RESULT_COLUMNS = ("sequence", "method", "rule", "fusion", "cues", "seed", "particles", "frames") \
    + SCORE_COLUMNS + TIMING_COLUMNS

#: The columns of ``rms.csv`` (W (36)).
RMS_COLUMNS = ("sequence", "method", "target", "frame", "runs", "rms_error")

#: The scores averaged over the seeds in ``summary.csv``.
SUMMARY_METRICS = ("mota", "idf1", "hota", "id_switches", "median_centre_error", "rms_error", "mean_particles",
                   "tracking_fps")


def rms_per_frame(runs: Sequence[tuple[str, str, Mapping[str, Any]]]) -> list[dict[str, Any]]:
    """The RMS position error of each target at each frame over the seeds (W (36)).

    Parameters
    ----------
    runs : sequence of (sequence name, method name, record)
        Finished runs; those of one sequence and method are the runs k = 1..n_runs.  A
        record's ``errors`` maps a target id to its ``[frame, centre error]`` pairs
        (:func:`belief_tracking.runs.run_cell`).

    Returns
    -------
    list of dict
        Rows ``sequence, method, target, frame, runs, rms_error`` with
        ``rms_error = sqrt(Σ_k e_k(t)² / runs)`` over the runs that had an estimate.

    Examples
    --------
    >>> runs = [("s", "m", {"errors": {"1": [[1, 3.0]]}}), ("s", "m", {"errors": {"1": [[1, 4.0]]}})]
    >>> rms_per_frame(runs)     # sqrt((9 + 16) / 2)
    [{'sequence': 's', 'method': 'm', 'target': 1, 'frame': 1, 'runs': 2, 'rms_error': 3.5355339059327378}]
    """
    groups: dict[tuple[str, str], dict[tuple[int, int], list[float]]] = {}
    for sequence, method, record in runs:
        squares = groups.setdefault((sequence, method), {})
        for target, pairs in record["errors"].items():
            for frame, error in pairs:
                squares.setdefault((int(target), int(frame)), []).append(float(error) ** 2)
    rows = []
    for (sequence, method), squares in groups.items():
        for (target, frame), values in sorted(squares.items()):
            rows.append({"sequence": sequence, "method": method, "target": target, "frame": frame,
                         "runs": len(values), "rms_error": math.sqrt(math.fsum(values) / len(values))})
    return rows


def summary_columns() -> tuple[str, ...]:
    """The columns of ``summary.csv``: the method's labels, the run count, then mean and std per metric."""
    return ("sequence", "method", "rule", "fusion", "cues", "runs") + tuple(
        f"{metric}_{stat}" for metric in SUMMARY_METRICS for stat in ("mean", "std"))


def summarise(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Mean and standard deviation over the seeds of every sequence and method (``summary.csv``).

    Parameters
    ----------
    rows : sequence of dict
        Rows of ``results.csv``; None (a score without a value, e.g. no occlusion test) is left out.

    Examples
    --------
    >>> rows = [{"sequence": "s", "method": "m", "rule": "r_rule", "fusion": "belief", "cues": "colour",
    ...          "mota": mota, **{k: 0.0 for k in SUMMARY_METRICS if k != "mota"}} for mota in (0.5, 0.7)]
    >>> row = summarise(rows)[0]
    >>> round(row["mota_mean"], 12), round(row["mota_std"], 6), row["runs"]
    (0.6, 0.141421, 2)
    """
    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for row in rows:
        groups.setdefault((row["sequence"], row["method"]), []).append(row)
    summary = []
    for (sequence, method), own in groups.items():
        line: dict[str, Any] = {"sequence": sequence, "method": method, "rule": own[0]["rule"],
                                "fusion": own[0]["fusion"], "cues": own[0]["cues"], "runs": len(own)}
        for metric in SUMMARY_METRICS:
            values = np.array([np.nan if r[metric] is None else r[metric] for r in own], dtype=np.float64)
            finite = values[np.isfinite(values)]
            line[f"{metric}_mean"] = float(finite.mean()) if len(finite) else math.nan
            line[f"{metric}_std"] = float(finite.std(ddof=1)) if len(finite) > 1 else math.nan
        summary.append(line)
    return summary


def format_summary(rows: Sequence[Mapping[str, Any]]) -> str:
    """The summary as a fixed-width text table: MOTA, IDF1, HOTA, median and RMS error, tracking speed.

    >>> print(format_summary([{"sequence": "s", "method": "m", "runs": 2, "mota_mean": 0.5, "idf1_mean": None,
    ...                        "hota_mean": 0.25, "median_centre_error_mean": 3.0, "rms_error_mean": 4.0,
    ...                        "tracking_fps_mean": 90.0}]))
    sequence           method               runs    MOTA    IDF1    HOTA median px   RMS px     fps
    s                  m                       2   0.500       -   0.250      3.00     4.00    90.0
    """
    lines = [f"{'sequence':<18} {'method':<20} {'runs':>4} {'MOTA':>7} {'IDF1':>7} {'HOTA':>7} {'median px':>9} "
             f"{'RMS px':>8} {'fps':>7}"]
    for r in rows:
        def num(name: str, digits: int) -> str:
            value = r[f"{name}_mean"]
            return "-" if value is None or not math.isfinite(value) else f"{value:.{digits}f}"
        lines.append(f"{r['sequence']:<18} {r['method']:<20} {r['runs']:>4} {num('mota', 3):>7} "
                     f"{num('idf1', 3):>7} {num('hota', 3):>7} {num('median_centre_error', 2):>9} "
                     f"{num('rms_error', 2):>8} "
                     f"{num('tracking_fps', 1):>7}")
    return "\n".join(lines)


def write_text(path: Path, text: str) -> None:
    """Write ``path`` whole: to a new hidden name in its folder, then renamed over ``path``.

    An interruption never leaves half a file.  The temporary name is created with ``O_EXCL`` and
    ``O_NOFOLLOW``, so never through an existing file or symbolic link, and :func:`os.replace`
    replaces a link at ``path`` instead of following it.  OSError is left to the caller, which
    knows what the file is.
    """
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
    partial = path.with_name(f".{path.name}.{secrets.token_hex(4)}.partial")
    descriptor = os.open(partial, flags, 0o644)
    try:
        with open(descriptor, "w", encoding="utf-8", newline="") as handle:
            handle.write(text)
        os.replace(partial, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(partial)
        raise


def csv_text(columns: Sequence[str], rows: Sequence[Mapping[str, Any]]) -> str:
    """``rows`` under ``columns`` as CSV text; missing values and NaN as empty cells."""
    def cell(value: Any) -> str:
        if value is None:
            return ""
        if isinstance(value, float):
            return "" if not math.isfinite(value) else repr(value)
        return str(value)

    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(columns)
    for row in rows:
        writer.writerow([cell(row.get(c)) for c in columns])
    return buffer.getvalue()


def write_csv(path: Path, columns: Sequence[str], rows: Sequence[Mapping[str, Any]]) -> None:
    """Write ``rows`` under ``columns`` (:func:`csv_text`) as :func:`write_text` does."""
    write_text(path, csv_text(columns, rows))
