"""The files of a tracking run: tracks, diagnostics, summary and two pictures.

* ``tracks.txt`` — MOTChallenge CSV ``frame,id,x,y,w,h,-1,-1,-1,-1`` (1-based frame and corner);
* ``diagnostics.csv`` — per frame and target, the means of W (33)–(35) and more
  (:func:`belief_tracking.tracker.diagnostic_columns`);
* ``summary.json`` — frames, speed, parameters, seed, version and scores;
* ``diagnostics.png`` — the curves of W's Fig. 10, one line per track, one panel per diagnostic
  that varies (:func:`diagnostics_figure`);
* ``tracks.png`` — every track's path over a frame of the video, with its births, deaths and
  re-identifications marked (:mod:`~belief_tracking.track_paths`).

A run stages them in its output folder and renames them into place once it is known to be
good, ``summary.json`` last (:class:`~belief_tracking.outdir.OutputFolder`).

The run's writers (:mod:`~belief_tracking.writers`) keep what each frame gives and write these
files with the functions here once the run is known to be good.
"""

from __future__ import annotations

import colorsys
import csv
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from os import PathLike
from typing import TYPE_CHECKING, Any

import numpy as np

from .diagnostics import CONFIDENCE_PREFIX, QUANTITIES, Quantity
from .extras import require
from .labels import LABELS_NOTE

if TYPE_CHECKING:  # pragma: no cover - annotations only: matplotlib is imported when a picture is drawn
    from matplotlib.figure import Figure

__all__ = ["RUN_OUTPUTS", "PICTURES", "write_diagnostics", "write_summary", "plot_diagnostics", "diagnostics_figure",
           "diagnostic_panels", "with_gaps", "track_colour", "Panel"]

#: The files that a tracking run may write into its output directory.
RUN_OUTPUTS = ("tracks.txt", "diagnostics.csv", "diagnostics.png", "tracks.png", "annotated.avi", "summary.json")

#: The pictures among them: a run that does not plot (``write_plot=False``) writes neither.
PICTURES = ("diagnostics.png", "tracks.png")


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




@dataclass(frozen=True)
class Panel:
    """One panel of ``diagnostics.png``: a diagnostic column (or the cues' confidences) and what it measures.

    Attributes
    ----------
    key : str
        A key of :data:`~belief_tracking.diagnostics.QUANTITIES`: a column of ``diagnostics.csv``,
        or ``"confidence"`` for every ``confidence_<cue>`` column.
    quantity : Quantity
    """

    key: str
    quantity: Quantity


def diagnostic_panels(records: Sequence[Mapping[str, float]]) -> list[Panel]:
    """The panels of ``diagnostics.png`` that have something to show, in the order of ``QUANTITIES``.

    A panel whose column is absent from ``records``, or whose finite values are all equal
    (all zero included: m(∅) under a rule that redistributes all conflict, a fixed particle
    count), is left out: a flat line says nothing a reader needs a panel for.

    Parameters
    ----------
    records : sequence of mapping
        The rows of ``diagnostics.csv``: ``frame``, ``id`` and the diagnostic columns.

    Examples
    --------
    >>> records = [{"frame": f, "id": 1, "mean_m_empty": 0.0, "particles": 100.0, "ess": 40.0 + f}
    ...            for f in (1, 2, 3)]
    >>> [panel.key for panel in diagnostic_panels(records)]
    ['ess']
    """
    panels = []
    for key, quantity in QUANTITIES.items():
        columns = _confidence_columns(records) if key == "confidence" else [key]
        values = np.array([r[c] for r in records for c in columns if c in r], dtype=np.float64)
        values = values[np.isfinite(values)]
        if values.size and np.ptp(values) > 1e-9 * max(1.0, float(np.max(np.abs(values)))):
            panels.append(Panel(key, quantity))
    return panels


def with_gaps(frames: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``values`` on every frame from the first to the last of ``frames``, NaN on the frames missing.

    matplotlib breaks a line at NaN, so a track that is not output for some frames is drawn
    with a gap there rather than a straight line across the frames it was not seen.

    Parameters
    ----------
    frames : ndarray of int, shape (F,)
        Frame numbers, increasing, without repeats.
    values : ndarray, shape (F,) or (F, K)

    Returns
    -------
    all_frames : ndarray of int, shape (G,)
        ``frames[0]``, ``frames[0] + 1``, …, ``frames[-1]`` (G = 0 when F = 0).
    filled : ndarray of float, shape (G,) or (G, K)
        ``values`` at their frames, NaN elsewhere.

    Examples
    --------
    >>> with_gaps(np.array([3, 4, 7]), np.array([0.5, 0.6, 0.9]))
    (array([3, 4, 5, 6, 7]), array([0.5, 0.6, nan, nan, 0.9]))
    """
    frames = np.asarray(frames, dtype=np.int64)
    values = np.asarray(values, dtype=np.float64)
    if frames.size == 0:
        return frames, values
    all_frames = np.arange(frames[0], frames[-1] + 1)
    filled = np.full((len(all_frames), *values.shape[1:]), np.nan)
    filled[frames - frames[0]] = values
    return all_frames, filled


def track_colour(track_id: int, value: float = 0.8) -> tuple[float, float, float]:
    """The RGB colour (0 to 1) of a track id in the pictures: the hue of its boxes in ``annotated.avi``.

    The golden-ratio hues of :func:`belief_tracking.video.track_colour`, computed without
    OpenCV, so that one person has one hue in the video and in both pictures; ``value``
    darkens it (the video's is 1), for lines that must read on white.

    Examples
    --------
    >>> track_colour(1) == track_colour(1), track_colour(1) != track_colour(2)
    (True, True)
    """
    hue = int((track_id * 0.618033988749895 % 1.0) * 180) / 180   # OpenCV's hues are 0..179
    return colorsys.hsv_to_rgb(hue, 220 / 255, value)


def diagnostics_figure(records: Sequence[Mapping[str, float]], title: str = "",
                       threshold: float | None = 0.6) -> Figure:
    """The figure of ``diagnostics.png``: one panel per diagnostic that varies, one line per track.

    The panels (:func:`diagnostic_panels`) follow W's Fig. 10 and C's Fig. 2 and 5: the
    mean masses and belief of W (33)–(35), m(∅), the disagreement R of the first two cues
    (W (10)), the total similarity ρ_t (C (15)) with the occlusion threshold ``threshold``
    and the occluded frames marked, the feature confidences λ (C (13), mean over the tracks,
    one line per cue), the particle count and the effective sample size.  Each is titled with
    the quantity's name, then its equation label; x is the frame number, y the quantity with
    its unit.  A track missing from some frames has a gap there.  Two columns of panels,
    as many rows as needed.

    Parameters
    ----------
    records : sequence of mapping
        The rows of ``diagnostics.csv``.
    title : str
        The figure's title (the run: source and settings).
    threshold : float or None
        The occlusion threshold T drawn on the similarity panel.

    Returns
    -------
    matplotlib.figure.Figure
        Drawn on an Agg canvas of its own, so that no global backend is touched.

    Examples
    --------
    >>> records = [{"frame": f, "id": 1, "particles": 100.0, "ess": 30.0 + f} for f in (1, 2, 4)]
    >>> [ax.get_title() for ax in diagnostics_figure(records).axes]
    ['Effective sample size of the weights']
    """
    require("matplotlib")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    panels = diagnostic_panels(records)
    columns = 1 if len(panels) <= 1 else 2
    rows = max(1, math.ceil(len(panels) / columns))
    figure = Figure(figsize=(6 * columns, 1.4 + 2.7 * rows), layout="constrained")
    FigureCanvasAgg(figure)
    ids = sorted({int(r["id"]) for r in records})
    if not panels:
        ax = figure.add_subplot()
        ax.set_axis_off()
        ax.text(0.5, 0.5, f"Nothing to draw: no diagnostic varied over the {len({r['frame'] for r in records})} "
                          f"frames and {len(ids)} tracks of this run", ha="center", va="center", wrap=True)
    else:
        axes = figure.subplots(rows, columns, sharex=True, squeeze=False).ravel()
        by_track: dict[int, list[Mapping[str, float]]] = {track_id: [] for track_id in ids}
        for record in records:  # one pass: a long video has thousands of tracks
            by_track[int(record["id"])].append(record)
        for ax, panel in zip(axes, panels):
            _draw_panel(ax, panel, records, by_track, threshold, thin=len(ids) > 10)
        for ax in axes[len(panels):]:
            figure.delaxes(ax)
        per_track = next((ax for ax, panel in zip(axes, panels) if panel.key != "confidence"), None)
        handles, labels = per_track.get_legend_handles_labels() if per_track is not None else ([], [])
        notes = [LABELS_NOTE] if columns == 2 else LABELS_NOTE.split(": ", 1)   # one column is too narrow a line
        if handles and len(ids) <= 10:
            figure.legend(handles, labels, loc="outside lower center", ncols=min(len(labels), 6), fontsize="small",
                          frameon=False)
        elif handles:
            notes.insert(0, f"One line per track ({len(ids)} tracks), coloured as in tracks.png and annotated.avi")
        # Placed by the layout under the legend: a reader who meets "W (33)" learns where to look it up.
        figure.supxlabel("\n".join(notes), fontsize="x-small", color="0.35")
    if title:
        figure.suptitle(title, fontsize="medium")
    return figure


def _draw_panel(ax, panel: Panel, records: Sequence[Mapping[str, float]],
                by_track: Mapping[int, Sequence[Mapping[str, float]]], threshold: float | None, thin: bool) -> None:
    """One panel: a line per track (or per cue for the confidences), titled and labelled."""
    quantity = panel.quantity
    ax.set_title(quantity.title, fontsize="medium")
    ax.set_xlabel("frame number", fontsize="small")
    ax.set_ylabel(quantity.axis, fontsize="small")
    ax.tick_params(labelbottom=True, labelsize="small")  # every panel reads on its own, shared x or not
    ax.grid(True, alpha=0.3)
    if panel.key == "confidence":
        _plot_confidences(ax, records)
    else:
        for track_id, own in by_track.items():
            own = sorted((r for r in own if panel.key in r), key=lambda r: r["frame"])
            if not own:
                continue
            frames = np.array([r["frame"] for r in own], dtype=np.int64)
            x, y = with_gaps(frames, np.array([r[panel.key] for r in own]))
            line, = ax.plot(x, y, linewidth=0.9 if thin else 1.3, color=track_colour(track_id),
                            label=f"track {track_id}")
            if panel.key == "similarity":
                hidden = [r for r in own if r.get("occluded", 0) >= 0.5]
                if hidden:
                    ax.plot([r["frame"] for r in hidden], [r["similarity"] for r in hidden], "x",
                            color=line.get_color(), markersize=4)
        if panel.key == "similarity" and threshold is not None:
            ax.axhline(threshold, color="black", linestyle="--", linewidth=0.8)
            ax.annotate(f"occlusion threshold T = {threshold:g} (x: occluded frames)", (0.01, threshold),
                        xycoords=("axes fraction", "data"), xytext=(0, 3), textcoords="offset points",
                        fontsize="x-small")
    if quantity.bounds is not None:
        low, high = quantity.bounds
        margin = 0.02 * (high - low)
        ax.set_ylim(low - margin, high + margin)


def plot_diagnostics(path: str | PathLike[str], records: Sequence[Mapping[str, float]], title: str = "",
                     threshold: float | None = 0.6) -> None:
    """Write :func:`diagnostics_figure` of ``records`` as a PNG at ``path``."""
    figure = diagnostics_figure(records, title=title, threshold=threshold)
    figure.savefig(path, dpi=100, format="png")


def _confidence_columns(records: Sequence[Mapping[str, float]]) -> list[str]:
    """The ``confidence_<cue>`` columns of ``records``, in the order of their cues' names."""
    return sorted({key for r in records for key in r if key.startswith(CONFIDENCE_PREFIX)})


def _plot_confidences(ax, records: Sequence[Mapping[str, float]]) -> None:
    """One line per cue: the mean over the tracks of each frame of ``confidence_<cue>``, with gaps."""
    for key in _confidence_columns(records):
        by_frame: dict[int, list[float]] = {}
        for r in records:
            if key in r:
                by_frame.setdefault(int(r["frame"]), []).append(r[key])
        frames = np.array(sorted(by_frame), dtype=np.int64)
        x, y = with_gaps(frames, np.array([np.mean(by_frame[f]) for f in frames]))
        ax.plot(x, y, linestyle="--", label=f"cue {key[len(CONFIDENCE_PREFIX):]}")
    ax.legend(fontsize="x-small", loc="best")
