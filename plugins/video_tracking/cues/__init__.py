"""Image cues of the tracker: location, colour, foreground-masked colour, edges and detections (SPEC B.2–B.5, Part D).

Every cue scores all particles of all targets at once against every hypothesis of the frame
{θ_1, …, θ_τ, FA} and returns *log*-likelihoods of shape ``(P, τ + 1)``, the last column
being the false alarm FA.  :class:`belief_tracking.fusion.CueFusion` turns each row
into a Bayesian mass function (W (20)–(21)) and combines the cues.

A cue is stateless: a function of the frame's :class:`Observation` (the image and its
features, computed once per frame, and what the cues read of the tracks: previous centres,
window sizes, the detection each took, the current templates) and of the particles.  The
tracks keep their own appearance templates (:class:`~belief_tracking.store.Track`); an
appearance cue only builds them (:meth:`ColourCue.build_templates`).  One module per cue,
all registered in :data:`CUES` (see :func:`make_cue`):

* ``"location"`` — :class:`LocationCue` (:mod:`.location`), distance to the previous
  estimates (W (22)–(24));
* ``"colour"`` — :class:`ColourCue` (:mod:`.colour`), Bhattacharyya similarity of
  kernel-weighted colour histograms to per-target templates and to a false-alarm histogram
  (W (16)–(19));
* ``"foreground"`` — :class:`ForegroundColourCue` (:mod:`.foreground`), the same histograms
  counting only the foreground pixels of a background model (L (16)–(17));
* ``"edges"`` — :class:`EdgeCue` (:mod:`.edges`), the same similarity for histograms of
  oriented edges (HOE), each pixel weighted by its gradient magnitude (C (8)–(10), SPEC B.5);
* ``"detections"`` — :class:`DetectionCue` (:mod:`.detections`), agreement with the frame's
  detector boxes, each discounted by its score.

The histograms they share are in :mod:`.histograms`; :func:`score_cues` scores with every
cue at once, sampling each window once for the colour cues that can share it.

Pixel geometry
--------------
Pixel (column i, row j) covers the square [i, i+1) × [j, j+1).  A box ``(x, y, w, h)`` in
0-based pixel coordinates therefore has centre ``(x + w/2, y + h/2)`` (:func:`~belief_tracking.boxes.box_centres`)
and half-sizes ``(w/2, h/2)``, and a point ``(px, py)`` falls in pixel ``(⌊px⌋, ⌊py⌋)``.
The box of particle p has size ``sizes[owner[p]] * exp(log_scale[p])``.
"""

from __future__ import annotations

from dataclasses import fields

from ..errors import TrackingError, UnknownCueError
from .base import AppearanceCue, Cue
from .colour import ColourConfig, ColourCue
from .detections import DetectionConfig, DetectionCue
from .edges import EdgeConfig, EdgeCue
from .foreground import ForegroundColourCue
from .histograms import (
    bhattacharyya,
    colour_bins,
    false_alarm_histogram,
    kernel_grid,
    kernel_histograms,
    orientation_bins,
)
from .location import LocationConfig, LocationCue
from .observation import Observation
from .scoring import score_cues, template_similarity

__all__ = [
    "Observation",
    "Cue",
    "AppearanceCue",
    "LocationConfig",
    "LocationCue",
    "ColourConfig",
    "ColourCue",
    "ForegroundColourCue",
    "EdgeConfig",
    "EdgeCue",
    "DetectionConfig",
    "DetectionCue",
    "CUES",
    "make_cue",
    "score_cues",
    "template_similarity",
    "colour_bins",
    "orientation_bins",
    "kernel_grid",
    "kernel_histograms",
    "bhattacharyya",
    "false_alarm_histogram",
]

#: The cues by name; each class takes its ``config_type`` settings.
CUES: dict[str, type] = {"colour": ColourCue, "location": LocationCue, "foreground": ForegroundColourCue,
                         "edges": EdgeCue, "detections": DetectionCue}


def make_cue(name: str, **options) -> Cue:
    """Build a cue of :data:`CUES` by name, its settings given as keywords.

    Examples
    --------
    >>> make_cue("location", sigma=5.0)
    LocationCue(LocationConfig(sigma=5.0, gate=3.0, literal=False))
    >>> make_cue("edges", bins=8)
    EdgeCue(EdgeConfig(bins=8, sigma=0.15, samples=(12, 24), min_gradient=10.0))
    >>> make_cue("sound")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    belief_tracking.errors.UnknownCueError: unknown cue 'sound'; known cues: colour, location, foreground, ...
    """
    cue_type = CUES.get(name) if isinstance(name, str) else None
    if cue_type is None:
        raise UnknownCueError(f"unknown cue {name!r}; known cues: {', '.join(CUES)}")
    known = [f.name for f in fields(cue_type.config_type)]
    unknown = sorted(set(options) - set(known))
    if unknown:
        raise TrackingError(f"cue {name!r} has no option {', '.join(unknown)}; its options are {', '.join(known)}")
    return cue_type(cue_type.config_type(**options))
