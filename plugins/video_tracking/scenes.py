"""Synthetic video scenes with exact ground truth, for tests and for the embedded demo.

A scene is a textured static background with people walking across it, each drawn
as a head, a shirt and trousers (three flat-coloured blocks).  The people walk in
straight lines at constant velocity and may grow or shrink at a constant rate.  The
difficulties of the experiments the trackers are compared on (SPEC Part C) are staged
on purpose: people crossing each other with partial and then full occlusion, static
objects in front of people, people with similar clothing, a change of brightness, a
shadow, and people walking towards or away from the camera (scale change).

Because the scene is drawn here, the ground truth is exact.  Every box is the extent of
the pixels that the person covers in the image, and every visibility is counted from
the drawing.  A scene is fully determined by its :class:`SceneConfig`.  The
configuration includes a seed, so the same configuration always gives byte-identical
frames and ground truth.

Conventions
-----------
* Frame indices ``t`` are 0-based in the Python API (``scene.frame(0)`` is the first
  frame).  Pixel boxes ``(x, y, w, h)`` are 0-based as well, so that
  ``frame[y:y + h, x:x + w]`` is the box.
* The ground-truth table follows MOTChallenge: ``frame, id, x, y, w, h, flag, -1, -1, -1``,
  with 1-based frame numbers and a 1-based top-left corner (``x_mot = x + 1``).
  ``motmetrics.io.loadtxt`` subtracts the 1 again.  The flag is always 1 ("consider
  this box").
* A box is the person's extent, clipped to the image.  A person who is hidden behind
  somebody else keeps their full box and gets a visibility of 0, as in MOTChallenge.
  A person who is entirely outside the image gets no row.
* The visibility of a box is the fraction of the person's in-image pixels that are not
  hidden by a nearer person or by a static occluder.  Being cut off by the image
  border does not count as being hidden.

Invalid settings raise :class:`~belief_tracking.errors.TrackingError`, which is
a ``ValueError``, as soon as a configuration object is made.  OpenCV is used only by
:func:`write_video`.

This module gathers the names of three others: the parts of a scene
(:mod:`~belief_tracking.scene_config`), the renderer and the file writers
(:mod:`~belief_tracking.scene_render`), and the library of scenes
(:mod:`~belief_tracking.scene_presets`): the presets of :data:`PRESETS` and the crowds of
:data:`CROWDS`.
"""

from __future__ import annotations

# This module is the front of its three parts: it re-exports what each part exports, so the
# names stay where code has always imported them from, and a name a part adds comes along.
from . import scene_config, scene_presets, scene_render
from .scene_config import *  # noqa: F403
from .scene_config import Box, Colour  # noqa: F401  (the annotations' types, not in __all__)
from .scene_presets import *  # noqa: F403
from .scene_render import *  # noqa: F403

__all__ = [*scene_config.__all__, *scene_presets.__all__, *scene_render.__all__]
