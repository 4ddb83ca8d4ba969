"""What the cues see of one frame: the image, its features, and what they read of the tracks.

An :class:`Observation` is made once per frame by the tracker.  It holds the frame (image,
foreground mask, detections) and, for the τ tracks in store order, what the cues compare the
particles with: the previous centres, the base window sizes, the particles of t − 1, the
detection each track took and the current appearance templates.  The features several cues
read (bin images, the scene's bin counts) are computed on first use and kept, so a frame's
features are computed once however many cues read them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from ..detections import check_rows
from ..errors import TrackingError
from .histograms import colour_bins, orientation_bins

__all__ = ["Observation", "checked_image", "checked_mask", "checked_particles", "particle_sizes",
           "STATE_COLUMNS", "MAX_ABS_LOG_SCALE"]

STATE_COLUMNS = 5  # cx, cy, vx, vy, log_scale

#: Log-scales are clipped to ±this before exp (see :func:`particle_sizes`).
MAX_ABS_LOG_SCALE = 30.0


@dataclass(frozen=True, eq=False)
class Observation:
    """What the cues see of one frame.

    Attributes
    ----------
    image : ndarray of uint8, shape (H, W, 3)
        The current frame, BGR (OpenCV order).
    foreground : ndarray of bool, shape (H, W), or None
        The background model's foreground mask (needed by the foreground cue only).
    centres : ndarray, shape (τ, 2)
        The previous estimated centres ``(cx, cy)`` of all targets.
    sizes : ndarray, shape (τ, 2)
        The base box sizes ``(w, h)`` of all targets; a particle scales them by ``exp(log_scale)``.
    previous_particles : ndarray, shape (Q, 2)
        Centres of all particles of all targets at t − 1 after resampling (for d_max, W (23)).
    detections : ndarray, shape (n, 5), or None
        The frame's detector boxes ``x, y, w, h, score`` (needed by the detections cue only;
        None when the run has no detector, (0, 5) when it found nobody in this frame).
    assigned : ndarray of int, shape (τ,), or None
        The detection each target took in this frame's one-to-one assignment
        (:func:`~belief_tracking.association.assign`), −1 for none.
    templates : mapping of str to ndarray, each shape (τ, B)
        The current appearance templates of the targets, by cue name, row j for target j
        (read by the appearance cues; the tracks hold them, :mod:`~belief_tracking.store`).

    The image features that several cues read (the bin images, the scene's bin counts) are
    computed once per observation, on first use.

    Examples
    --------
    >>> obs = Observation(np.zeros((4, 6, 3), np.uint8), None, [[2.0, 2.0]], [[2.0, 2.0]], np.zeros((0, 2)))
    >>> obs.n_targets, obs.centres.dtype
    (1, dtype('float64'))
    """

    image: np.ndarray
    foreground: np.ndarray | None
    centres: np.ndarray
    sizes: np.ndarray
    previous_particles: np.ndarray
    detections: np.ndarray | None = None
    assigned: np.ndarray | None = None
    templates: Mapping[str, np.ndarray] = field(default_factory=dict)
    _features: dict = field(default_factory=dict, init=False, repr=False)

    def __post_init__(self) -> None:
        image = checked_image(self.image)
        object.__setattr__(self, "image", image)
        if self.foreground is not None:
            object.__setattr__(self, "foreground", checked_mask(self.foreground, image.shape[:2]))
        centres = _points("centres", self.centres)
        sizes = _points("sizes", self.sizes)
        if centres.shape != sizes.shape:
            raise TrackingError(f"centres and sizes must both have shape (τ, 2), got {centres.shape} and {sizes.shape}")
        if (sizes <= 0).any():
            raise TrackingError("box sizes must be positive")
        object.__setattr__(self, "centres", centres)
        object.__setattr__(self, "sizes", sizes)
        object.__setattr__(self, "previous_particles", _points("previous_particles", self.previous_particles))
        if self.detections is not None:
            detections = check_rows(self.detections, "Observation")
            object.__setattr__(self, "detections", detections)
            assigned = np.full(centres.shape[0], -1, np.intp) if self.assigned is None \
                else np.asarray(self.assigned)
            if assigned.shape != (centres.shape[0],) or not np.issubdtype(assigned.dtype, np.integer) \
                    or (assigned.size and (assigned.min() < -1 or assigned.max() >= detections.shape[0])):
                raise TrackingError(f"assigned must hold one detection row (or -1) per target, got {assigned!r}")
            object.__setattr__(self, "assigned", assigned.astype(np.intp))
        for name, rows in self.templates.items():
            if np.ndim(rows) != 2 or np.shape(rows)[0] != centres.shape[0]:
                raise TrackingError(f"the {name} templates must have one row per target ({centres.shape[0]}), "
                                    f"got shape {np.shape(rows)}")

    @property
    def n_targets(self) -> int:
        """τ, the number of targets."""
        return self.centres.shape[0]

    def with_assignment(self, assigned) -> "Observation":
        """This observation with the frame's ``assigned`` detections, sharing the per-frame caches."""
        out = replace(self, assigned=assigned)
        object.__setattr__(out, "_features", self._features)
        return out

    def with_templates(self, templates: Mapping[str, np.ndarray]) -> "Observation":
        """This observation with other ``templates`` (after an update), sharing the per-frame caches."""
        out = replace(self, templates=templates)
        object.__setattr__(out, "_features", self._features)
        return out

    def colour_bins(self, bins: int) -> np.ndarray:
        """:func:`colour_bins` of the image, computed once per frame however many cues ask."""
        if bins not in self._features:
            self._features[bins] = colour_bins(self.image, bins)
        return self._features[bins]

    def orientation_bins(self, bins: int, unsigned: bool = False,
                         min_gradient: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
        """:func:`orientation_bins` of the image (bins, weights), computed once per frame and setting."""
        key = ("orientation", int(bins), bool(unsigned), float(min_gradient))
        if key not in self._features:
            self._features[key] = orientation_bins(self.image, bins, unsigned, min_gradient)
        return self._features[key]

    def scene_counts(self, bin_image: np.ndarray, weights: np.ndarray | None, n_bins: int) -> np.ndarray:
        """The whole frame's count (or weight) per bin of a bin image of this frame, shape (B,), computed once."""
        key = ("scene", n_bins, id(bin_image), id(weights))
        known = self._features.get(key)
        # The arrays are kept with their counts, so an id is never taken for that of a newer array.
        if known is None or known[0] is not bin_image or known[1] is not weights:
            counts = np.bincount(bin_image.ravel(), weights=None if weights is None else weights.ravel(),
                                 minlength=n_bins)
            counts.flags.writeable = False
            known = self._features[key] = (bin_image, weights, counts)
        return known[2]

    def templates_of(self, cue_name: str) -> np.ndarray:
        """The (τ, B) templates of the appearance cue ``cue_name``; an error names what is missing."""
        templates = self.templates.get(cue_name)
        if templates is None:
            raise TrackingError(f"the {cue_name} cue needs the targets' templates: Observation(templates="
                                f"{{{cue_name!r}: ...}}), one row per target")
        return templates


def checked_image(image) -> np.ndarray:
    image = np.asarray(image)
    if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
        raise TrackingError(f"the image must be a (H, W, 3) uint8 array, got shape {image.shape} dtype {image.dtype}")
    if image.shape[0] == 0 or image.shape[1] == 0:
        raise TrackingError(f"the image is empty (shape {image.shape})")
    return image


def checked_mask(mask, shape: tuple[int, int]) -> np.ndarray:
    mask = np.asarray(mask)
    if mask.shape != shape or mask.dtype != np.bool_:
        raise TrackingError(f"the foreground mask must be a bool array of shape {shape}, got shape {mask.shape} "
                            f"dtype {mask.dtype} (use mask > 0 for a 0/255 image)")
    return mask


def _points(name: str, values) -> np.ndarray:
    points = np.asarray(values, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 2:
        raise TrackingError(f"{name} must have shape (n, 2), got {points.shape}")
    if not np.isfinite(points).all():
        raise TrackingError(f"{name} must be finite")
    return points


def checked_particles(obs: Observation, states, owner) -> tuple[np.ndarray, np.ndarray]:
    """Checked float states (P, 5) and integer owners (P,)."""
    states = np.asarray(states, dtype=np.float64)
    if states.ndim != 2 or states.shape[1] != STATE_COLUMNS:
        raise TrackingError(f"states must have shape (P, 5) (cx, cy, vx, vy, log_scale), got {states.shape}")
    if not np.isfinite(states).all():
        raise TrackingError("particle states must be finite")
    owner = np.asarray(owner)
    if owner.shape != (states.shape[0],) or (owner.size and not np.issubdtype(owner.dtype, np.integer)):
        raise TrackingError(f"owner must be {states.shape[0]} integer target indices, "
                            f"got shape {owner.shape} dtype {owner.dtype}")
    owner = owner.astype(np.intp)
    if owner.size and (owner.min() < 0 or owner.max() >= obs.n_targets):
        raise TrackingError(f"particle owners must be target indices 0..{obs.n_targets - 1}")
    return states, owner


def particle_sizes(obs: Observation, states: np.ndarray, owner: np.ndarray) -> np.ndarray:
    """Box sizes (w, h) of the particles, ``sizes[owner] * exp(log_scale)``, shape (P, 2)."""
    # A scale beyond e^±30 ≈ 10^±13 already covers or misses any image; clipping keeps exp
    # finite, so no sample coordinate becomes inf − inf = NaN.
    log_scale = np.clip(states[:, 4:5], -MAX_ABS_LOG_SCALE, MAX_ABS_LOG_SCALE)
    return obs.sizes[owner] * np.exp(log_scale)
