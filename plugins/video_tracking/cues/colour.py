"""The colour cue: kernel-weighted colour histograms against the targets' templates and the scene (W (16)–(19))."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..boxes import box_centres, check_boxes
from ..errors import TrackingError
from .base import ConfiguredCue, count_setting, log_gaussian, positive_setting, samples_setting
from .histograms import (
    MAX_BINS_PER_CHANNEL,
    Sampling,
    colour_bins,
    false_alarm_histogram,
    kernel_histograms,
    sample_boxes,
    sample_counts,
    sample_slots,
)
from .observation import Observation, checked_image, checked_mask, checked_particles, particle_sizes
from .similarity import window_similarities

__all__ = ["ColourConfig", "ColourCue"]


@dataclass(frozen=True)
class ColourConfig:
    """Settings of the colour cues.

    Attributes
    ----------
    bins : int
        Bins per channel of the joint RGB histogram (bins³ in all; W: 8, C: 16), at most 16.
    sigma : float
        σ_col of W (16) and W (19) (SPEC default 0.15; dimensionless, like d).
    samples : (int, int)
        Sample points across and down a box (:func:`~belief_tracking.cues.histograms.kernel_grid`);
        the default suits upright people, twice as tall as wide.
    """

    bins: int = 8
    sigma: float = 0.15
    samples: tuple[int, int] = (12, 24)

    def __post_init__(self) -> None:
        bins = count_setting("ColourConfig", "bins", self.bins)
        if bins > MAX_BINS_PER_CHANNEL:
            raise TrackingError(f"ColourConfig.bins must be at most {MAX_BINS_PER_CHANNEL} per channel "
                                f"({MAX_BINS_PER_CHANNEL}³ joint bins), got {bins}")
        object.__setattr__(self, "bins", bins)
        object.__setattr__(self, "sigma", positive_setting("ColourConfig", "sigma", self.sigma))
        object.__setattr__(self, "samples", samples_setting("ColourConfig", self.samples))

    @property
    def n_bins(self) -> int:
        """B = bins³."""
        return self.bins ** 3


class ColourCue(ConfiguredCue):
    """Colour similarity of every particle to every target and to the rest of the scene (W (16)–(19)).

    For the kernel-weighted histogram h of a particle's box (L (9)–(11)) and a reference q,
    d = √(1 − ρ[h, q]) (W (17), with the square root inside the sum) and
    log p = −d² / (2σ²) = −(1 − ρ) / (2σ²) (W (16), exponent corrected).  The references are
    the targets' templates q_1 … q_τ (``obs.templates["colour"]``) and q_FA (W (18)),
    recomputed every frame from the whole frame.

    The cue holds no target: the tracks keep their templates (:class:`~belief_tracking.store.Track`).
    :meth:`build_templates` makes them: a template is the histogram of its box sampled
    exactly as a particle's box, so a particle that sits on the box scores ρ = 1.

    Subclasses change what is counted by supplying the bin image and the pixel weights of a
    frame (:meth:`image_features` / :meth:`frame_features`); templates, q_FA and the scores follow.

    Examples
    --------
    A red target on a grey background; a particle on the target and one beside it:

    >>> image = np.full((60, 80, 3), 128, np.uint8)
    >>> image[20:40, 30:40] = (0, 0, 255)
    >>> cue = ColourCue(ColourConfig(samples=(6, 12)))
    >>> templates = cue.build_templates(image, np.array([[30, 20, 10, 20]]))
    >>> obs = Observation(image, None, [[35.0, 30.0]], [[10.0, 20.0]], np.zeros((0, 2)),
    ...                   templates={"colour": templates})
    >>> states = np.array([[35.0, 30.0, 0, 0, 0], [60.0, 30.0, 0, 0, 0]])
    >>> logs = cue.log_likelihoods(obs, states, np.array([0, 0]))      # columns θ1, FA
    >>> np.exp(logs).round(6)                                             # ρ = 1 gives p = 1
    array([[1., 0.],
           [0., 1.]])
    >>> round(float(logs[0, 1]), 2)                                       # ρ = 0: −1 / (2 · 0.15²)
    -22.22
    """

    name: ClassVar[str] = "colour"
    config_type: ClassVar[type] = ColourConfig

    #: Whether the window histograms count the foreground only (which points lie in the image matters).
    masked: ClassVar[bool] = False

    # -- what is counted ----------------------------------------------------------------------
    def image_features(self, image: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """The bin image (H, W) of a frame and its pixel weights (None: every pixel counts 1)."""
        return colour_bins(image, self.config.bins), None

    def frame_features(self, obs: Observation) -> tuple[np.ndarray, np.ndarray | None]:
        """:meth:`image_features` of the observed frame, computed once per observation."""
        return obs.colour_bins(self.config.bins), None

    def check_observation(self, obs: Observation) -> None:
        """Refuse an observation that lacks what this cue reads."""

    # -- templates --------------------------------------------------------------------------
    def build_templates(self, image: np.ndarray, boxes, foreground: np.ndarray | None = None) -> np.ndarray:
        """The templates of ``boxes`` in ``image``, shape (n, B), rows summing to 1.

        Parameters
        ----------
        image : ndarray of uint8, shape (H, W, 3)
            The frame the targets are taken from (BGR).
        boxes : array_like, shape (n, 4)
            ``x, y, w, h`` in 0-based pixel coordinates; each must overlap the image.
        foreground : ndarray of bool, shape (H, W), optional
            The foreground mask of that frame (read by the foreground cue only).
        """
        image = checked_image(image)
        if foreground is not None:
            foreground = checked_mask(foreground, image.shape[:2])
        boxes = check_boxes(boxes, "template boxes", image_shape=image.shape[:2])
        return self.template_histograms(self.image_features(image), boxes, foreground)

    def template_histograms(self, features: tuple, boxes: np.ndarray, foreground) -> np.ndarray:
        """The templates of checked ``boxes`` from an image's :meth:`image_features`, shape (n, B)."""
        bin_image, weights = features
        return kernel_histograms(bin_image, box_centres(boxes), boxes[:, 2:], self.config.n_bins, self.config.samples,
                                 pixel_weights=weights)

    def templates(self, obs: Observation) -> np.ndarray:
        """The targets' current templates q_1 … q_τ of this cue in ``obs``, shape (τ, B)."""
        templates = obs.templates_of(self.name)
        if templates.shape[1] != self.config.n_bins:
            raise TrackingError(f"the {self.name} templates have {templates.shape[1]} bins, the cue "
                                f"{self.config.n_bins}")
        return templates

    # -- scoring ----------------------------------------------------------------------------
    def histograms(self, obs: Observation, states: np.ndarray, owner: np.ndarray) -> np.ndarray:
        """The candidate histograms h of all particles' boxes, shape (P, B) (L (9)–(11))."""
        states, owner = checked_particles(obs, states, owner)
        self.check_observation(obs)
        bin_image, _ = features = self.frame_features(obs)
        sampling = sample_boxes(states[:, :2], particle_sizes(obs, states, owner), self.config.samples,
                                bin_image.shape, self.masked)
        counts, norms = self.block_counts(obs, features, sampling, sample_slots(bin_image, sampling,
                                                                                 self.config.n_bins),
                                          self.config.n_bins)
        return counts.reshape(-1, self.config.n_bins) / norms

    def block_counts(self, obs: Observation, features: tuple, sampling: Sampling, slots: np.ndarray,
                     width: int) -> tuple[np.ndarray, np.ndarray | float]:
        """:func:`~belief_tracking.cues.histograms.sample_counts` of a block of sampled boxes, ``width`` slots per box."""
        return sample_counts(slots, sampling, width, pixel_weights=features[1])

    def false_alarm_histogram(self, obs: Observation) -> np.ndarray:
        """q_FA of this frame, shape (B,) (W (18)): the scene's bins that the targets' templates do not explain.

        With pixel weights, the scene counts are the weights summed per bin.
        """
        return self.references(obs, self.frame_features(obs))[-1]

    def references(self, obs: Observation, features: tuple) -> np.ndarray:
        """The templates q_1 … q_τ, then q_FA of this frame, shape (τ + 1, B)."""
        templates = self.templates(obs)
        bin_image, weights = features
        scene = obs.scene_counts(bin_image, weights, self.config.n_bins)           # kernel-free, whole frame
        return np.concatenate([templates, false_alarm_histogram(scene, templates)[None, :]])

    def log_likelihoods(self, obs: Observation, states: np.ndarray, owner: np.ndarray) -> np.ndarray:
        """log p_1 … log p_τ, log p_FA = −(1 − ρ) / (2σ²) of every particle, shape (P, τ + 1) (W (16)–(19))."""
        states, owner = checked_particles(obs, states, owner)
        rho = window_similarities([self], obs, states, owner)[0]
        return log_gaussian(1.0 - rho, self.config.sigma)                           # d² = 1 − ρ (W (17))
