"""Box size from the image row: a ground-plane perspective model fitted to the targets' boxes.

With a static camera looking down on a flat ground, a person's height in the image grows
linearly with the row of their feet, h = a·foot + b (the row where h would vanish is the
horizon).  Fitted to the boxes the targets are born with, this model gives every particle
its window size from its own position, so the window shrinks as a target walks away from
the camera without a scale state that the cues would have to estimate.  (An appearance cue
cannot estimate scale well: the foreground-masked colour of SPEC B.4 scores ρ ≤ √F, and a
window inside the silhouette has F = 1, so it rewards shrinking windows.)

The scale of a particle of target J at centre row ``cy`` is h(cy) / h(cy_J), where cy_J is
the centre row of J's birth box: J keeps its own size and aspect ratio at birth, and follows
the model's relative change.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["PerspectiveScale", "MAX_SCALE_CHANGE"]

#: The model may change a box's size by at most this factor either way.
MAX_SCALE_CHANGE = 4.0


@dataclass(frozen=True)
class PerspectiveScale:
    """Box height h = a·foot + b as a function of the foot row (0-based pixels).

    Attributes
    ----------
    a, b : float
        Slope and intercept; ``0 ≤ a < 2`` (a box whose centre moves down one row has its
        foot move down 1 + a/2 rows).

    Examples
    --------
    Three people: 40 px tall with feet at row 100, 60 px at 200, 80 px at 300:

    >>> model = PerspectiveScale.fit([[0, 60, 15, 40], [50, 140, 20, 60], [90, 220, 30, 80]])
    >>> round(model.a, 3), round(model.b, 3)
    (0.2, 20.0)
    >>> float(model.height(np.array([170.0]))[0])            # centre row 170: feet at 200
    60.0
    >>> round(float(model.log_scale(np.array([260.0]), 170.0)[0]), 4) == round(math.log(80 / 60), 4)
    True
    >>> PerspectiveScale.fit([[0, 60, 15, 40]]) is None       # one box: no model
    True
    """

    a: float
    b: float

    @classmethod
    def fit(cls, boxes, min_spread: float = 2.0) -> PerspectiveScale | None:
        """Least-squares fit to boxes ``(x, y, w, h)``; None when the boxes cannot support one.

        Parameters
        ----------
        boxes : array_like, shape (n, 4)
            Top-left corner and size of each box, in pixels.
        min_spread : float
            The foot rows must have a standard deviation of at least this many pixels.

        Returns
        -------
        PerspectiveScale or None
            None for fewer than two boxes, feet on (nearly) one row, or a fit that is not a
            camera looking down on a ground plane (a < 0 or a ≥ 2, or a height ≤ 0 at a
            box's own row).
        """
        boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
        if boxes.shape[0] < 2:
            return None
        foot = boxes[:, 1] + boxes[:, 3]
        if foot.std() < min_spread:
            return None
        a, b = np.polyfit(foot, boxes[:, 3], 1)
        if not (math.isfinite(a) and math.isfinite(b)) or not 0.0 <= a < 2.0:
            return None
        if ((a * foot + b) <= 0).any():
            return None
        return cls(float(a), float(b))

    def height(self, cy: np.ndarray) -> np.ndarray:
        """Box height of a box centred on row(s) ``cy``: h = (a·cy + b) / (1 − a/2), at least 1 px."""
        return np.maximum((self.a * np.asarray(cy, dtype=np.float64) + self.b) / (1.0 - self.a / 2.0), 1.0)

    def log_scale(self, cy: np.ndarray, reference_cy: float) -> np.ndarray:
        """log(h(cy) / h(reference_cy)), clipped to ±log :data:`MAX_SCALE_CHANGE`; shape of ``cy``."""
        ratio = np.log(self.height(cy)) - math.log(float(self.height(np.array([reference_cy]))[0]))
        limit = math.log(MAX_SCALE_CHANGE)
        return np.clip(ratio, -limit, limit)
