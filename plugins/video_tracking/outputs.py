"""The files of a tracking run: tracks, diagnostics, summary and the diagnostics plot.

* ``tracks.txt`` — MOTChallenge CSV ``frame,id,x,y,w,h,-1,-1,-1,-1`` (1-based frame and corner);
* ``diagnostics.csv`` — per frame and target, the means of W (33)–(35) and more
  (:func:`belief_tracking.tracker.diagnostic_columns`);
* ``summary.json`` — frames, speed, parameters, seed, version and scores;
* ``diagnostics.png`` — the curves of W's Fig. 10, one line per target.

A run stages them in its output folder and renames them into place once it is known to be
good, ``summary.json`` last (:class:`~belief_tracking.outdir.OutputFolder`).

The run's writers (:mod:`~belief_tracking.writers`) keep what each frame gives and write these
files with the functions here once the run is known to be good.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Mapping, Sequence
from os import PathLike
from typing import Any

import numpy as np

from .extras import require

__all__ = ["RUN_OUTPUTS", "write_diagnostics", "write_summary", "plot_diagnostics"]

#: The files that a tracking run may write into its output directory.
RUN_OUTPUTS = ("tracks.txt", "diagnostics.csv", "diagnostics.png", "annotated.avi", "summary.json")


def write_diagnostics(path: str | PathLike[str], records: Sequence[Mapping[str, float]],
                      header: Sequence[str]) -> None:
    """Write one CSV line per frame and target, columns ``header``.

    A run passes ``("frame", "id")`` and its tracker's
    :func:`~belief_tracking.tracker.diagnostic_columns`.
    """
    with open(path, "w", encoding="ascii", newline="") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(header)
        for record in records:
            writer.writerow([_cell(record[name]) for name in header])


def _cell(value: float) -> str:
    if isinstance(value, (int, np.integer)) or (isinstance(value, float) and value.is_integer() and abs(value) < 1e15):
        return str(int(value))
    return f"{float(value):.6g}"


def write_summary(path: str | PathLike[str], summary: Mapping[str, Any]) -> None:
    """Write the run summary as indented JSON (NaN becomes null).

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "summary.json")
    >>> write_summary(path, {"frames": np.int64(3), "mota": float("nan")})
    >>> json.load(open(path, encoding="utf-8"))
    {'frames': 3, 'mota': None}
    """
    with open(path, "w", encoding="utf-8") as handle:
        json.dump(_json_ready(summary), handle, indent=2, allow_nan=False)
        handle.write("\n")


def _json_ready(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_ready(v) for v in value]
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return None if not math.isfinite(value) else float(value)
    if isinstance(value, (np.bool_,)):
        return bool(value)
    return value


def plot_diagnostics(path: str | PathLike[str], records: Sequence[Mapping[str, float]], title: str = "",
                     threshold: float | None = 0.6) -> None:
    """The diagnostics curves of W's Fig. 10 and C's Fig. 2 and 5, one line per target, as a PNG.

    Eight panels over the frames: mean m(θ_j) (W (33)), mean mass on intersections with θ_j
    (W (34)), mean Bel(θ_j) (W (35)), mean m(∅), the total similarity ρ_t (C (15)) with the
    occlusion threshold ``threshold`` and the occluded frames marked, the feature confidences
    λ (C (13), mean over the live targets, one line per cue), the particle count and the
    effective sample size.  Uses matplotlib's Agg canvas directly, so no global backend is
    touched.  Keys missing from the records leave their panel empty.
    """
    require("matplotlib")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    panels = (("mean_m_target", "mean m(θj)  [W (33)]"),
              ("mean_m_intersection", "mean m(θj ∩ …)  [W (34)]"),
              ("mean_bel", "mean Bel(θj)  [W (35)]"),
              ("mean_m_empty", "mean m(∅)"),
              ("similarity", "total similarity ρt  [C (15)]"),
              (None, "feature confidence λ, mean over targets  [C (13)]"),
              ("particles", "particles"),
              ("ess", "effective sample size"))
    figure = Figure(figsize=(10, 12), layout="constrained")
    FigureCanvasAgg(figure)
    axes = figure.subplots(4, 2, sharex=True)
    ids = sorted({int(r["id"]) for r in records})
    many = len(ids) > 10
    bounded = {"mean_m_target", "mean_m_intersection", "mean_bel", "mean_m_empty", "similarity"}
    for ax, (key, label) in zip(axes.ravel(), panels):
        ax.set_title(label)
        ax.grid(True, alpha=0.3)
        if key is None:
            _plot_confidences(ax, records)
            continue
        for track_id in ids:
            own = [r for r in records if int(r["id"]) == track_id and key in r]
            line, = ax.plot([r["frame"] for r in own], [r[key] for r in own], linewidth=0.9 if many else 1.3,
                            label=f"target {track_id}")
            if key == "similarity":
                hidden = [r for r in own if r.get("occluded", 0) >= 0.5]
                ax.plot([r["frame"] for r in hidden], [r[key] for r in hidden], "x", color=line.get_color(),
                        markersize=4)
        if key in bounded:
            ax.set_ylim(-0.02, 1.02)
        if key == "similarity" and threshold is not None:
            ax.axhline(threshold, color="black", linestyle="--", linewidth=0.8, label=f"T = {threshold:g}")
    for ax in axes[-1]:
        ax.set_xlabel("frame")
    if ids and not many:
        axes[0, 0].legend(fontsize="small")
    if title:
        figure.suptitle(title)
    figure.savefig(path, dpi=100, format="png")


def _plot_confidences(ax, records: Sequence[Mapping[str, float]]) -> None:
    """One line per cue: the mean over the targets of each frame of ``confidence_<cue>``."""
    cues = sorted({key[len("confidence_"):] for r in records for key in r if key.startswith("confidence_")})
    for cue in cues:
        key = f"confidence_{cue}"
        sums: dict[float, list[float]] = {}
        for r in records:
            if key in r:
                sums.setdefault(r["frame"], []).append(r[key])
        frames = sorted(sums)
        ax.plot(frames, [sum(sums[f]) / len(sums[f]) for f in frames], label=cue)
    ax.set_ylim(-0.02, 1.02)
    if cues:
        ax.legend(fontsize="small")
