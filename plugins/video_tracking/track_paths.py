"""``tracks.png``: where every track went, drawn over a frame of the video.

Each track's path is the bottom centre of its box (where a person's feet are) frame by frame,
one colour per id: the hue of its boxes in ``annotated.avi`` and of its lines in
``diagnostics.png`` (:func:`~belief_tracking.outputs.track_colour`).  Three kinds of
:class:`TrackEvent` are marked on it: a *birth* at a track's first point, a *death* at the
last point of a track that ended before the run did, and a *re-identification* where an id
comes back after frames in which it was not output (a track lost and found again, or one that
coasted unseen).  The frames in between are a gap in the path, bridged by a dotted line.

:func:`track_paths` and :func:`track_events` compute the paths and the markers from the rows
of ``tracks.txt``; :func:`tracks_figure` draws them; :class:`TrackPathsPicture` is the run's
writer of the file, which keeps the frame drawn under the paths.
"""

from __future__ import annotations

from dataclasses import dataclass
from os import PathLike
from typing import TYPE_CHECKING

import numpy as np

from .extras import require
from .outputs import track_colour, with_gaps
from .writers import FrameWriter, TrackRows

if TYPE_CHECKING:  # pragma: no cover - annotations only
    from matplotlib.figure import Figure

    from .tracker import FrameResult

__all__ = ["TrackPath", "TrackEvent", "EVENT_KINDS", "foot_points", "track_paths", "track_events",
           "tracks_figure", "plot_track_paths", "TrackPathsPicture"]

#: The kinds of :class:`TrackEvent`, in the order the legend explains them.
EVENT_KINDS = ("birth", "death", "reidentified")

#: How each kind of event is drawn (a matplotlib marker and its size) and explained in the legend.
_EVENT_STYLE = {
    "birth": ("o", 7, "track starts (birth), its id beside it"),
    "death": ("X", 8, "track ends before the last frame (death); a path without one was followed to the end"),
    "reidentified": ("*", 13, "same id found again after a gap (re-identification)"),
}


@dataclass(frozen=True, eq=False)
class TrackPath:
    """The path of one track over every frame from its first to its last.

    Attributes
    ----------
    track_id : int
    frames : ndarray of int, shape (F,)
        Every frame number from the track's first to its last.
    points : ndarray of float, shape (F, 2)
        The bottom centre (x, y) of the box in 0-based pixel coordinates (pixel i spans
        [i, i + 1)); NaN on the frames the track was not output, so that a line drawn through
        them breaks there.
    """

    track_id: int
    frames: np.ndarray
    points: np.ndarray

    @property
    def gaps(self) -> list[tuple[int, int]]:
        """The frames around each gap: (last frame before it, first frame after it).

        Examples
        --------
        >>> path = track_paths(np.array([[f, 1, 10, 10, 4, 8] for f in (1, 2, 5, 6, 9)]))[0]
        >>> path.gaps
        [(2, 5), (6, 9)]
        """
        seen = np.isfinite(self.points[:, 0])
        seen_frames = self.frames[seen]
        jumps = np.flatnonzero(np.diff(seen_frames) > 1)
        return [(int(seen_frames[k]), int(seen_frames[k + 1])) for k in jumps]


@dataclass(frozen=True)
class TrackEvent:
    """A marked point of ``tracks.png``.

    Attributes
    ----------
    kind : str
        One of :data:`EVENT_KINDS`.
    track_id : int
    frame : int
    x, y : float
        The bottom centre of the track's box at ``frame`` (0-based pixel coordinates).
    """

    kind: str
    track_id: int
    frame: int
    x: float
    y: float


def foot_points(rows: np.ndarray) -> np.ndarray:
    """The bottom centre of each MOTChallenge box, in 0-based pixel coordinates.

    Parameters
    ----------
    rows : ndarray, shape (M, 6) or more
        ``frame, id, x, y, w, h, …`` with the 1-based corner of ``tracks.txt``.

    Returns
    -------
    ndarray of float, shape (M, 2)

    Examples
    --------
    >>> foot_points(np.array([[1, 7, 11, 21, 10, 40]]))
    array([[15., 60.]])
    """
    rows = _table(rows)
    return np.column_stack([rows[:, 2] - 1 + rows[:, 4] / 2, rows[:, 3] - 1 + rows[:, 5]])


def _table(rows: np.ndarray) -> np.ndarray:
    """``rows`` as a float array of shape (M, K), K >= 6; no rows at all give shape (0, 10)."""
    rows = np.asarray(rows, dtype=np.float64)
    if rows.size == 0:
        return np.zeros((0, 10))
    return np.atleast_2d(rows)


def track_paths(rows: np.ndarray) -> list[TrackPath]:
    """One :class:`TrackPath` per id of ``rows``, by increasing id.

    Parameters
    ----------
    rows : ndarray, shape (M, 6) or more
        The rows of ``tracks.txt`` (``frame, id, x, y, w, h, …``), in any order; an id has at
        most one row per frame.

    Examples
    --------
    >>> rows = np.array([[1, 2, 11, 21, 10, 40], [3, 2, 13, 21, 10, 40]])
    >>> path, = track_paths(rows)
    >>> path.track_id, path.frames, path.points[:, 0]
    (2, array([1, 2, 3]), array([15., nan, 17.]))
    """
    rows = _table(rows)
    if len(rows) == 0:
        return []
    points = foot_points(rows)
    paths = []
    for track_id in np.unique(rows[:, 1].astype(np.int64)):
        own = np.flatnonzero(rows[:, 1] == track_id)
        own = own[np.argsort(rows[own, 0], kind="stable")]
        frames, filled = with_gaps(rows[own, 0].astype(np.int64), points[own])
        paths.append(TrackPath(int(track_id), frames, filled))
    return paths


def track_events(rows: np.ndarray, last_frame: int | None = None) -> list[TrackEvent]:
    """The births, deaths and re-identifications of the tracks of ``rows``, by id then frame.

    Parameters
    ----------
    rows : ndarray, shape (M, 6) or more
        The rows of ``tracks.txt``.
    last_frame : int, optional
        The run's last frame (default: the last frame of ``rows``).  A track still output
        there has not died: the run ended, not the track.

    Returns
    -------
    list of TrackEvent
        Per id: a ``"birth"`` at its first row; a ``"reidentified"`` at the first row after
        each gap (the id is output again after frames without it); a ``"death"`` at its last
        row when that is before ``last_frame``.

    Examples
    --------
    >>> rows = np.array([[1, 1, 11, 11, 4, 8], [2, 1, 13, 11, 4, 8], [5, 1, 19, 11, 4, 8],
    ...                  [2, 2, 41, 11, 4, 8], [3, 2, 43, 11, 4, 8]])
    >>> [(e.kind, e.track_id, e.frame) for e in track_events(rows, last_frame=5)]
    [('birth', 1, 1), ('reidentified', 1, 5), ('birth', 2, 2), ('death', 2, 3)]
    """
    events = []
    paths = track_paths(rows)
    if last_frame is None:
        last_frame = max((int(path.frames[-1]) for path in paths), default=0)
    for path in paths:
        events.append(_event("birth", path, int(path.frames[0])))
        events += [_event("reidentified", path, after) for _, after in path.gaps]
        if path.frames[-1] < last_frame:
            events.append(_event("death", path, int(path.frames[-1])))
    return events


def _event(kind: str, path: TrackPath, frame: int) -> TrackEvent:
    """The event ``kind`` of ``path`` at ``frame``, where the track was output."""
    x, y = path.points[frame - path.frames[0]]
    return TrackEvent(kind, path.track_id, frame, float(x), float(y))


def tracks_figure(rows: np.ndarray, image: np.ndarray | None = None, *, size: tuple[int, int] | None = None,
                  last_frame: int | None = None, image_frame: int | None = None, title: str = "") -> Figure:
    """The figure of ``tracks.png``: every track's path over ``image``, its events marked, a legend in words.

    Parameters
    ----------
    rows : ndarray, shape (M, 6) or more
        The rows of ``tracks.txt``.
    image : ndarray of uint8, shape (H, W, 3) or (H, W), optional
        A BGR frame of the video (as the sources give them) or a grey one, drawn faded under
        the paths.
    size : (int, int), optional
        The frame's (width, height) when there is no image (default: what the paths cover).
    last_frame : int, optional
        The run's last frame (:func:`track_events`).
    image_frame : int, optional
        The frame number of ``image``, named under the picture.
    title : str

    Returns
    -------
    matplotlib.figure.Figure
        On an Agg canvas of its own.

    Examples
    --------
    >>> rows = np.array([[f, 1, 10 + 3 * f, 20, 10, 30] for f in (1, 2, 3, 6, 7)])
    >>> figure = tracks_figure(rows, np.zeros((60, 80, 3), np.uint8), last_frame=9)
    >>> figure.axes[0].get_xlabel()
    'x (pixels)'
    """
    require("matplotlib")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patheffects import withStroke

    rows = _table(rows)
    paths = track_paths(rows)
    events = track_events(rows, last_frame)
    if image is not None:
        height, width = image.shape[:2]
    elif size is not None:
        width, height = size
    else:
        feet = foot_points(rows)
        width = int(np.ceil(feet[:, 0].max())) + 1 if len(feet) else 1
        height = int(np.ceil(feet[:, 1].max())) + 1 if len(feet) else 1
    inches = 9.0
    figure = Figure(figsize=(inches, inches * height / width + 1.6), layout="constrained")
    FigureCanvasAgg(figure)
    ax = figure.add_subplot()
    if image is not None:
        image = np.asarray(image, dtype=np.float32) / 255.0
        rgb = image[..., ::-1] if image.ndim == 3 else np.repeat(image[..., None], 3, axis=2)   # BGR or grey
        # Faded towards white, so that the coloured paths stand out on any scene.
        ax.imshow(0.5 * rgb + 0.5, extent=(0, width, height, 0), interpolation="nearest")
    ax.set_xlim(0, width)
    ax.set_ylim(height, 0)
    ax.set_aspect("equal")
    ax.set_xlabel("x (pixels)", fontsize="small")
    ax.set_ylabel("y (pixels)", fontsize="small")
    ax.tick_params(labelsize="x-small")
    outline = [withStroke(linewidth=2.5, foreground="white")]
    labelled = len(paths) <= 60   # beyond that the ids would hide the paths
    for path in paths:
        colour = track_colour(path.track_id)
        ax.plot(path.points[:, 0], path.points[:, 1], color=colour, linewidth=1.8, solid_capstyle="round")
        for before, after in path.gaps:
            ends = path.points[[before - path.frames[0], after - path.frames[0]]]
            ax.plot(ends[:, 0], ends[:, 1], color=colour, linewidth=1.0, linestyle=":")
        if labelled:
            x, y = path.points[0]
            ax.annotate(str(path.track_id), (x, y), xytext=(4, 4), textcoords="offset points", fontsize="small",
                        fontweight="bold", color=colour, path_effects=outline)
    for kind in EVENT_KINDS:
        own = [e for e in events if e.kind == kind]
        if own:
            marker, size_points, _ = _EVENT_STYLE[kind]
            ax.scatter([e.x for e in own], [e.y for e in own], marker=marker, s=size_points ** 2,
                       c=[track_colour(e.track_id) for e in own], edgecolors="black", linewidths=0.8, zorder=3)
    counts = {kind: sum(e.kind == kind for e in events) for kind in EVENT_KINDS}
    grey = "0.45"
    handles = [Line2D([], [], color=grey, linewidth=1.8,
                      label="path of a track: the bottom centre of its box, one colour per id (that of its box in "
                            "annotated.avi)"),
               Line2D([], [], color=grey, linewidth=1.0, linestyle=":",
                      label="gap: frames in which the track was not output")]
    handles += [Line2D([], [], color=grey, marker=_EVENT_STYLE[kind][0], markersize=_EVENT_STYLE[kind][1],
                       markeredgecolor="black", linestyle="none", label=f"{_EVENT_STYLE[kind][2]}: {counts[kind]}")
                for kind in EVENT_KINDS]
    figure.legend(handles=handles, loc="outside lower center", ncols=1, fontsize="small", frameon=False)
    shown = f"frame {image_frame}" if image is not None and image_frame is not None else \
        "a frame of the video" if image is not None else "no frame kept"
    heading = f"Where the tracks went: {len(paths)} tracks; background: {shown}"
    figure.suptitle(f"{title}\n{heading}" if title else heading, fontsize="medium")
    return figure


def plot_track_paths(path: str | PathLike[str], rows: np.ndarray, image: np.ndarray | None = None, **options) -> None:
    """Write :func:`tracks_figure` of ``rows`` over ``image`` as a PNG at ``path`` (``options`` go to it)."""
    tracks_figure(rows, image, **options).savefig(path, dpi=100, format="png")


class TrackPathsPicture(FrameWriter):
    """``tracks.png`` (:func:`plot_track_paths`) of what ``tracks`` kept, over the middle frame of the run.

    Parameters
    ----------
    path : path
    tracks : TrackRows
        A writer before this one, whose rows are drawn.
    size : (int, int)
        The frames' (width, height), for a run that hands no images.
    expected_frames : int or None
        The frames the source announces: the image kept is that of the middle one, or of the
        last frame when the count is unknown or the source ends before its middle.
    title : str

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> picture = TrackPathsPicture("tracks.png", TrackRows(), (8, 6), expected_frames=5)
    >>> for frame in range(1, 6):
    ...     picture.write(SimpleNamespace(frame=frame), np.full((6, 8, 3), frame, np.uint8))
    >>> picture.image_frame, int(picture.image[0, 0, 0])
    (3, 3)
    """

    def __init__(self, path: str | PathLike[str], tracks: TrackRows, size: tuple[int, int],
                 expected_frames: int | None = None, title: str = "") -> None:
        self.path = path
        self.tracks = tracks
        self.size = size
        self.middle = (expected_frames + 1) // 2 if expected_frames else None
        self.title = title
        self.frames = 0
        self._middle: tuple[int, np.ndarray] | None = None
        self._last: tuple[int, np.ndarray] | None = None

    def write(self, result: FrameResult, image: np.ndarray | None) -> None:
        self.frames = max(self.frames, int(result.frame))
        if image is None:
            return
        if result.frame == self.middle:
            self._middle = (int(result.frame), np.array(image, copy=True))  # the source may reuse its buffer
        elif self._middle is None:
            # Only a reference: kept in case the middle never comes (unknown count, truncated video).
            self._last = (int(result.frame), image)

    @property
    def image_frame(self) -> int | None:
        """The frame number of :attr:`image`."""
        kept = self._middle or self._last
        return kept[0] if kept is not None else None

    @property
    def image(self) -> np.ndarray | None:
        """The frame drawn under the paths: the middle one, else the last one handed."""
        kept = self._middle or self._last
        return kept[1] if kept is not None else None

    def finish(self) -> None:
        plot_track_paths(self.path, self.tracks.array(), self.image, size=self.size, last_frame=self.frames,
                         image_frame=self.image_frame, title=self.title)
