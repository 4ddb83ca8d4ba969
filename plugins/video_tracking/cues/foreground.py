"""The foreground cue: the colour of the foreground pixels of every window (L (16)–(17))."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ..boxes import box_centres
from ..errors import TrackingError
from .colour import ColourCue
from .histograms import Sampling, kernel_histograms, sample_counts
from .observation import Observation

__all__ = ["ForegroundColourCue"]


class ForegroundColourCue(ColourCue):
    """Colour of the *foreground* pixels of every particle's box (L (16)–(17)).

    As :class:`ColourCue`, but a candidate histogram counts only the pixels that the
    background model marks as foreground, while still normalising over all sample points of
    the box (the f of L (10)), so Σ_u h(u) = F, the kernel-weighted foreground fraction.  As
    ρ ≤ √F (Cauchy–Schwarz), a particle that covers little foreground is crushed, whatever
    the colour of its few foreground pixels (SPEC B.4).  Renormalising over the foreground
    pixels would reward exactly those particles, so it is not done.

    A target template is the masked histogram of its box at initiation, normalised to 1; if
    the mask is empty there, the unmasked histogram is used.  q_FA is that of
    :class:`ColourCue`.  ``Observation.foreground`` and the ``foreground`` argument of the
    :meth:`build_templates` are required.

    Examples
    --------
    A red target (foreground) on grey; one particle on it, one on the background:

    >>> image = np.full((60, 80, 3), 128, np.uint8)
    >>> image[20:40, 30:40] = (0, 0, 255)
    >>> mask = np.zeros((60, 80), bool)
    >>> mask[20:40, 30:40] = True
    >>> from belief_tracking.cues import ColourConfig
    >>> cue = ForegroundColourCue(ColourConfig(samples=(6, 12)))
    >>> templates = cue.build_templates(image, np.array([[30, 20, 10, 20]]), foreground=mask)
    >>> obs = Observation(image, mask, [[35.0, 30.0]], [[10.0, 20.0]], np.zeros((0, 2)),
    ...                   templates={"foreground": templates})
    >>> states = np.array([[35.0, 30.0, 0, 0, 0], [60.0, 30.0, 0, 0, 0]])
    >>> cue.histograms(obs, states, np.array([0, 0])).sum(axis=1)       # F
    array([1., 0.])
    """

    name: ClassVar[str] = "foreground"

    def template_histograms(self, features: tuple, boxes: np.ndarray, foreground) -> np.ndarray:
        if foreground is None:
            raise TrackingError("the foreground cue builds its templates from the foreground mask; pass foreground=")
        bin_image, weights = features
        plain = super().template_histograms(features, boxes, None)
        masked = kernel_histograms(bin_image, box_centres(boxes), boxes[:, 2:], self.config.n_bins,
                                   self.config.samples, foreground, pixel_weights=weights)
        mass = masked.sum(axis=1, keepdims=True)
        # The template describes the target, not how much of its box it fills: normalise to 1.
        return np.where(mass > 0, masked / np.where(mass > 0, mass, 1.0), plain)

    masked: ClassVar[bool] = True

    def check_observation(self, obs: Observation) -> None:
        if obs.foreground is None:
            raise TrackingError("the foreground cue needs Observation.foreground, the background model's mask; "
                                "got None")

    def block_counts(self, obs: Observation, features: tuple, sampling: Sampling, slots: np.ndarray,
                     width: int) -> tuple[np.ndarray, np.ndarray | float]:
        return sample_counts(slots, sampling, width, obs.foreground, pixel_weights=features[1])
