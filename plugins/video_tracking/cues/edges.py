"""The edge cue: histograms of oriented edges against the targets' templates and the scene (C (8)–(10), SPEC B.5)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..errors import TrackingError
from .base import count_setting, positive_setting, samples_setting
from .colour import ColourCue
from .histograms import MAX_ORIENTATION_BINS, orientation_bins
from .observation import Observation

__all__ = ["EdgeConfig", "EdgeCue"]


@dataclass(frozen=True)
class EdgeConfig:
    """Settings of the edge cue (the HOE of SPEC B.5).

    Attributes
    ----------
    bins : int
        Orientation bins (C: 16), at most 360.
    sigma : float
        σ of C (10) (SPEC default 0.15).
    samples : (int, int)
        Sample points across and down a box (:func:`kernel_grid`).
    min_gradient : float
        Pixels whose gradient, in grey levels (:func:`orientation_bins`), is below this are
        ignored (SPEC: 10; ≥ 0).
    """

    bins: int = 16
    sigma: float = 0.15
    samples: tuple[int, int] = (12, 24)
    min_gradient: float = 10.0

    def __post_init__(self) -> None:
        bins = count_setting("EdgeConfig", "bins", self.bins)
        if bins > MAX_ORIENTATION_BINS:
            raise TrackingError(f"EdgeConfig.bins must be at most {MAX_ORIENTATION_BINS}, got {bins}")
        object.__setattr__(self, "bins", bins)
        object.__setattr__(self, "sigma", positive_setting("EdgeConfig", "sigma", self.sigma))
        object.__setattr__(self, "samples", samples_setting("EdgeConfig", self.samples))
        gradient = self.min_gradient
        if isinstance(gradient, bool) or not isinstance(gradient, (int, float, np.integer, np.floating)) \
                or not math.isfinite(gradient) or gradient < 0:
            raise TrackingError(f"EdgeConfig.min_gradient must be a non-negative finite number, got {gradient!r}")
        object.__setattr__(self, "min_gradient", float(gradient))

    @property
    def n_bins(self) -> int:
        """B = bins."""
        return self.bins


class EdgeCue(ColourCue):
    """Edge-orientation similarity of every particle to every target and to the scene (C (8)–(10)).

    As :class:`ColourCue`, with the histogram of oriented edges (HOE, SPEC B.5) in place of
    the colour histogram: every sample point adds K(r) · g to the bin of its pixel's gradient
    orientation (:func:`orientation_bins`), g being the Sobel magnitude (0 below
    ``min_gradient``), and the histogram is normalised by Σ K · g over the box, so it sums
    to 1.  A box without any edge gets an all-zero histogram, whose ρ with every reference is
    0: its particle scores the same, −1 / (2σ²), for every hypothesis, and the edge cue stays
    out of that particle's decision.  A template of such a box is all zero too.

    q_FA subtracts the templates from the magnitude-weighted orientation histogram of the
    whole frame.  The ``foreground`` argument of :meth:`build_templates` is ignored.

    Examples
    --------
    A bright square on a dark background, sampled at every pixel of its 24×24 box: its four
    sides give four orientations, 0, π/2, π and 3π/2, a quarter each (the corners lie outside
    the kernel's ellipse).  One particle sits on the box, one on the flat background:

    >>> image = np.zeros((60, 80, 3), np.uint8)
    >>> image[20:40, 30:50] = 200
    >>> cue = EdgeCue(EdgeConfig(samples=(24, 24)))
    >>> templates = cue.build_templates(image, np.array([[28, 18, 24, 24]]))
    >>> templates[0, ::4]
    array([0.25, 0.25, 0.25, 0.25])
    >>> obs = Observation(image, None, [[40.0, 30.0]], [[24.0, 24.0]], np.zeros((0, 2)),
    ...                   templates={"edges": templates})
    >>> states = np.array([[40.0, 30.0, 0, 0, 0], [10.0, 50.0, 0, 0, 0]])
    >>> cue.histograms(obs, states, np.array([0, 0])).sum(axis=1)         # normalised; no edges
    array([1., 0.])
    >>> logs = cue.log_likelihoods(obs, states, np.array([0, 0]))         # columns θ1, FA
    >>> (1.0 + 2 * 0.15 ** 2 * logs).round(6)                             # ρ
    array([[1., 0.],
           [0., 0.]])

    q_FA holds what the frame has and the template lacks, here the diagonal corners.
    """

    name: ClassVar[str] = "edges"
    config_type: ClassVar[type] = EdgeConfig

    def image_features(self, image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return orientation_bins(image, self.config.bins, min_gradient=self.config.min_gradient)

    def frame_features(self, obs: Observation) -> tuple[np.ndarray, np.ndarray]:
        return obs.orientation_bins(self.config.bins, min_gradient=self.config.min_gradient)
