"""Image cues of the tracker: location, colour, foreground-masked colour and edges (SPEC B.2–B.5, Part D).

Every cue scores all particles of all targets at once against every hypothesis of the frame
{θ_1, …, θ_τ, FA} and returns *log*-likelihoods of shape ``(P, τ + 1)``, the last column
being the false alarm FA.  :class:`belief_tracking.fusion.CueFusion` turns each row
into a Bayesian mass function (W (20)–(21)) and combines the cues.

Four cues are provided, all registered in :data:`CUES` (see :func:`make_cue`):

* ``"location"`` — :class:`LocationCue`, distance to the previous estimates (W (22)–(24));
* ``"colour"`` — :class:`ColourCue`, Bhattacharyya similarity of kernel-weighted colour
  histograms to per-target templates and to a false-alarm histogram (W (16)–(19));
* ``"foreground"`` — :class:`ForegroundColourCue`, the same histograms counting only the
  foreground pixels of a background model (L (16)–(17));
* ``"edges"`` — :class:`EdgeCue`, the same similarity for histograms of oriented edges
  (HOE), each pixel weighted by its gradient magnitude (C (8)–(10), SPEC B.5).

Pixel geometry
--------------
Pixel (column i, row j) covers the square [i, i+1) × [j, j+1).  A box ``(x, y, w, h)`` in
0-based pixel coordinates therefore has centre ``(x + w/2, y + h/2)`` (:func:`~belief_tracking.boxes.box_centres`)
and half-sizes ``(w/2, h/2)``, and a point ``(px, py)`` falls in pixel ``(⌊px⌋, ⌊py⌋)``.
The box of particle p has size ``sizes[owner[p]] * exp(log_scale[p])``.

Appearance cues hold one template per target.  A tracker sets them all at once with
``set_templates`` or lets targets be born and die with ``add_target`` / ``remove_target``;
target j of every call to ``log_likelihoods`` is row j of the templates, so the tracker
keeps its targets and the cue's templates in the same order.  A template update (SPEC B.5,
C (16)) is the cue's own :meth:`ColourCue.follow_appearance`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from functools import lru_cache
from typing import ClassVar, NamedTuple, Protocol, runtime_checkable

import numpy as np

from . import checks
from .boxes import box_centres, check_boxes
from .detections import check_rows
from .errors import TrackingError, UnknownCueError

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


#: Joint RGB histograms have bins³ bins; 16³ = 4096 (the largest of the papers, C) keeps a
#: (P, B) float array of 800 particles near 26 MB.
MAX_BINS_PER_CHANNEL = 16

STATE_COLUMNS = 5  # cx, cy, vx, vy, log_scale

#: Residuals of W (18) at most this fraction of the scene are rounding, not colours.
RESIDUAL_TOLERANCE = 1e-12

#: At most this many orientation bins (one per degree); a (P, B) array stays small.
MAX_ORIENTATION_BINS = 360

#: Particles whose histograms a colour cue builds at once (:meth:`ColourCue.log_likelihoods`).
HISTOGRAM_BLOCK = 128

#: Log-scales are clipped to ±this before exp (see :func:`_particle_sizes`).
MAX_ABS_LOG_SCALE = 30.0


# -- the observation of one frame -----------------------------------------------------------------
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
    _bins: dict = field(default_factory=dict, init=False, repr=False)

    def __post_init__(self) -> None:
        image = _checked_image(self.image)
        object.__setattr__(self, "image", image)
        if self.foreground is not None:
            object.__setattr__(self, "foreground", _checked_mask(self.foreground, image.shape[:2]))
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

    @property
    def n_targets(self) -> int:
        """τ, the number of targets."""
        return self.centres.shape[0]

    def with_assignment(self, assigned) -> "Observation":
        """This observation with the frame's ``assigned`` detections, sharing the per-frame caches."""
        out = replace(self, assigned=assigned)
        object.__setattr__(out, "_bins", self._bins)
        return out

    def colour_bins(self, bins: int) -> np.ndarray:
        """:func:`colour_bins` of the image, computed once per frame however many cues ask."""
        if bins not in self._bins:
            self._bins[bins] = colour_bins(self.image, bins)
        return self._bins[bins]

    def orientation_bins(self, bins: int, unsigned: bool = False,
                         min_gradient: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
        """:func:`orientation_bins` of the image (bins, weights), computed once per frame and setting."""
        key = ("orientation", int(bins), bool(unsigned), float(min_gradient))
        if key not in self._bins:
            self._bins[key] = orientation_bins(self.image, bins, unsigned, min_gradient)
        return self._bins[key]


def _checked_image(image) -> np.ndarray:
    image = np.asarray(image)
    if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
        raise TrackingError(f"the image must be a (H, W, 3) uint8 array, got shape {image.shape} dtype {image.dtype}")
    if image.shape[0] == 0 or image.shape[1] == 0:
        raise TrackingError(f"the image is empty (shape {image.shape})")
    return image


def _checked_mask(mask, shape: tuple[int, int]) -> np.ndarray:
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


def _particles(obs: Observation, states, owner) -> tuple[np.ndarray, np.ndarray]:
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


# -- the cue interface ----------------------------------------------------------------------------
@runtime_checkable
class Cue(Protocol):
    """A cue scores every particle against every hypothesis {θ_1, …, θ_τ, FA} (SPEC Part D)."""

    name: str

    def log_likelihoods(self, obs: Observation, states: np.ndarray, owner: np.ndarray) -> np.ndarray:
        """Log-likelihoods of P particles.

        Parameters
        ----------
        obs : Observation
        states : ndarray, shape (P, 5)
            Columns cx, cy, vx, vy, log_scale, for all particles of all targets.
        owner : ndarray of int, shape (P,)
            The target index of each particle.

        Returns
        -------
        ndarray, shape (P, τ + 1)
            log p_1 … log p_τ, log p_FA.
        """
        ...


@runtime_checkable
class AppearanceCue(Cue, Protocol):
    """A cue with one appearance template per target, built when the target is born."""

    def set_templates(self, image: np.ndarray, boxes: np.ndarray, foreground: np.ndarray | None = None) -> None:
        """Replace all templates by those of ``boxes`` (τ, 4) ``x, y, w, h`` in ``image``."""
        ...

    def add_target(self, image: np.ndarray, box, foreground: np.ndarray | None = None) -> int:
        """Append the template of a new target; returns its index."""
        ...

    def remove_target(self, index: int) -> None:
        """Forget target ``index``; the later targets move down by one."""
        ...

    @property
    def templates(self) -> np.ndarray:
        """The current templates, shape (τ, B)."""
        ...

    @property
    def initial_templates(self) -> np.ndarray:
        """The templates as they were built when their targets were set or added, shape (τ, B)."""
        ...

    def replace_template(self, index: int, histogram) -> None:
        """Replace the current template of target ``index`` (normalised to sum 1)."""
        ...

    def follow_appearance(self, observed: np.ndarray, frozen: np.ndarray) -> None:
        """Let every template follow its target's appearance ``observed`` (C (16)), except the ``frozen`` ones."""
        ...

    def rebuild_template(self, index: int, image: np.ndarray, box, foreground: np.ndarray | None = None) -> None:
        """Take target ``index``'s current and initial template anew from ``box`` in ``image``."""
        ...


# -- configuration checks -------------------------------------------------------------------------
def _positive(owner: str, name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TrackingError(f"{owner}.{name} must be a positive number, got {value!r}")
    if not math.isfinite(value) or value <= 0:
        raise TrackingError(f"{owner}.{name} must be a positive finite number, got {value!r}")
    return float(value)


def _count(owner: str, name: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise TrackingError(f"{owner}.{name} must be a positive integer, got {value!r}")
    return int(value)


# -- location cue ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class LocationConfig:
    """Settings of the location cue.

    Attributes
    ----------
    sigma : float
        σ_loc in pixels of the Gaussians of W (22) and W (23) (SPEC default 10 px).
    gate : float
        The tracker's FA: certain beyond ``gate`` · σ from the nearest target (not read
        when ``literal``).
    literal : bool
        False (default): each target's Gaussian is centred on its estimate moved on by its
        estimated velocity (x̂ + v̂·dt), so that the cue does not pull a moving target back,
        and FA grows with the distance to the *nearest* target up to a fixed d_max = ``gate``
        · σ, so that FA is unlikely near every target and certain beyond the gate, however
        the targets spread over the image.  True: W (22)–(24) as printed, centred on the
        estimates at t − 1, FA from the centroid of the targets with d_max from the particles
        of t − 1.  The tracker supplies the centres.
    """

    sigma: float = 10.0
    gate: float = 3.0
    literal: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma", _positive("LocationConfig", "sigma", self.sigma))
        object.__setattr__(self, "gate", _positive("LocationConfig", "gate", self.gate))
        object.__setattr__(self, "literal", checks.flag("LocationConfig.literal", self.literal))


class LocationCue:
    """Where a particle lies with respect to the previous estimates (W (22)–(24)).

    Target j: log p_j = −‖x − ĉ_j‖² / (2σ²), the log of G(‖x − ĉ_j‖; σ) (W (22)), with x the
    particle's propagated centre and ĉ_j target j's estimate at t − 1.

    FA: log p_FA = −max(d_max − d, 0)² / (2σ²) (W (23)).  FA grows as a particle moves
    away from the targets; the clamp keeps it at its maximum, log p_FA = 0, outside the
    circle of radius d_max instead of letting it fall again (SPEC B.3).  By default d is the
    distance of x to the nearest centre and d_max = ``gate`` · σ; with ``literal`` d is the
    distance to the centroid c̄ of the τ centres (W (24)) and d_max the largest such distance
    among all particles of t − 1, floored at σ.

    Examples
    --------
    W (22)–(24): targets at (100, 50) and (140, 70), so c̄ = (120, 60); the particles of
    t − 1 reach (90, 45), so d_max = √1125 ≈ 33.5.  A particle on target 1 is at d = √500
    from c̄:

    >>> obs = Observation(np.zeros((120, 200, 3), np.uint8), None,
    ...                   centres=[[100, 50], [140, 70]], sizes=[[20, 40], [20, 40]],
    ...                   previous_particles=[[90, 45], [150, 75]])
    >>> cue = LocationCue(LocationConfig(sigma=10.0, literal=True))
    >>> states = np.array([[100.0, 50.0, 0, 0, 0], [300.0, 60.0, 0, 0, 0]])
    >>> cue.log_likelihoods(obs, states, owner=np.array([0, 1])).round(3)
    array([[   0.   ,  -10.   ,   -0.625],
           [-200.5  , -128.5  ,    0.   ]])

    The gate (3σ = 30 px): on its target the particle is 30 px from the gate, log p_FA = −4.5;
    the far one is beyond it:

    >>> LocationCue(LocationConfig(sigma=10.0)).log_likelihoods(obs, states, np.array([0, 1]))[:, 2].tolist()
    [-4.5, 0.0]
    """

    name: ClassVar[str] = "location"
    config_type: ClassVar[type] = LocationConfig

    def __init__(self, config: LocationConfig = LocationConfig()) -> None:
        if not isinstance(config, LocationConfig):
            raise TrackingError(f"LocationCue needs a LocationConfig, got {type(config).__name__}")
        self.config = config

    def __repr__(self) -> str:
        return f"LocationCue({self.config!r})"

    def log_likelihoods(self, obs: Observation, states: np.ndarray, owner: np.ndarray) -> np.ndarray:
        """log p_1 … log p_τ, log p_FA of every particle, shape (P, τ + 1) (W (22)–(24)).

        ``owner`` is only checked: location scores do not depend on a particle's own target.
        """
        states, owner = _particles(obs, states, owner)
        tau = obs.n_targets
        scores = np.empty((states.shape[0], tau + 1))
        if states.shape[0] == 0:
            return scores
        positions = states[:, :2]
        target_sq = _squared_distances(positions, obs.centres)                      # (P, τ)
        scores[:, :tau] = _log_gaussian(target_sq, self.config.sigma)
        if not self.config.literal:
            distance = np.sqrt(target_sq.min(axis=1, initial=np.inf))                # to the nearest target
            d_max = self.config.gate * self.config.sigma
        else:
            centroid = obs.centres.mean(axis=0)                                      # W (24)
            distance = np.linalg.norm(positions - centroid, axis=1)
            previous = np.linalg.norm(obs.previous_particles - centroid, axis=1)     # (Q,)
            # A circle thinner than σ would make FA jump from 0 to its maximum within a few
            # pixels of the targets; the floor keeps it as smooth as the target Gaussians.
            d_max = max(float(previous.max(initial=0.0)), self.config.sigma)
        gap = np.maximum(d_max - distance, 0.0)                                    # W (23) clamp
        scores[:, tau] = _log_gaussian(gap ** 2, self.config.sigma)
        return scores



def _log_gaussian(squared_distance: np.ndarray, sigma: float) -> np.ndarray:
    """log G(d; σ) = −d² / (2σ²) from d², without the constant that cancels in W (20)–(21)."""
    # 0 − d² rather than −d², so that d = 0 gives +0.0 (−0.0 would print as "-0.").
    return (0.0 - squared_distance) / (2.0 * sigma ** 2)


def _squared_distances(points: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """‖points_p − centres_j‖², shape (len(points), len(centres))."""
    # Per axis, (P, τ) arrays with long inner loops: several times faster than an einsum over
    # a (P, τ, 2) array, and the same sum dx² + dy².
    squared = points[:, 0:1] - centres[:, 0]
    squared *= squared
    dy = points[:, 1:2] - centres[:, 1]
    dy *= dy
    squared += dy
    return squared


# -- colour histograms (vectorised over particles) ------------------------------------------------
def colour_bins(image: np.ndarray, bins: int) -> np.ndarray:
    """The joint-RGB bin of every pixel: r·bins² + g·bins + b, each channel cut into ``bins``.

    A channel value v falls in bin ⌊v · bins / 256⌋, so the bins are equally wide.

    Parameters
    ----------
    image : ndarray of uint8, shape (H, W, 3)
        BGR, as OpenCV reads it.
    bins : int
        Bins per channel.

    Returns
    -------
    ndarray of uint16, shape (H, W)
        Values in 0 … bins³ − 1; intp for more than 40 bins per channel, whose bins³ does
        not fit in 16 bits.

    Examples
    --------
    >>> pixel = np.array([[[0, 0, 255], [255, 255, 255]]], np.uint8)     # red, white (BGR)
    >>> colour_bins(pixel, 8).tolist()
    [[448, 511]]
    """
    if bins > 40:
        channels = image.astype(np.intp) * bins >> 8                  # ⌊v·bins/256⌋, exact in integers
        blue, green, red = channels[..., 0], channels[..., 1], channels[..., 2]
        return (red * bins + green) * bins + blue
    # 16 bits hold v·bins and bins³ exactly.  The bin image is read at every sample point of
    # every particle, and a quarter of intp's size keeps it in cache and out of the
    # allocator's mapped blocks.
    if bins & (bins - 1) == 0:                                        # a power of two: ⌊v·bins/256⌋ = v >> shift
        shift = 8 - (bins.bit_length() - 1)
        channels = image >> shift                                     # uint8, a third of the passes' memory
        joint = channels[..., 2].astype(np.uint16)
        joint <<= 8 - shift
        joint |= channels[..., 1]
        joint <<= 8 - shift
        joint |= channels[..., 0]
        return joint
    channels = image.astype(np.uint16)
    channels *= bins
    channels >>= 8                                                    # ⌊v·bins/256⌋
    joint = channels[..., 2] * np.uint16(bins)
    joint += channels[..., 1]
    joint *= bins
    joint += channels[..., 0]
    return joint


def orientation_bins(image: np.ndarray, bins: int = 16, unsigned: bool = False,
                     min_gradient: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    """The gradient-orientation bin and the edge weight of every pixel (the HOE of SPEC B.5).

    The grey image 0.299 R + 0.587 G + 0.114 B is differentiated with the 3×3 Sobel kernels
    (borders replicated), x to the right and y *down*; the orientation θ = atan2(g_y, g_x),
    taken in [0, 2π) (in [0, π) when ``unsigned``, so that opposite gradients share a bin),
    is cut into ``bins`` equal bins starting at 0, and the weight is the magnitude
    g = √(g_x² + g_y²) where g ≥ ``min_gradient`` and 0 elsewhere.  The Sobel sums are
    divided by 4, the sum of a kernel's positive taps, so that g is in grey levels: a step of
    s grey levels gives g = s on each side of it, and the default threshold of 10 keeps the
    steps of 10 levels or more while the sensor noise of a few levels stays out.

    Parameters
    ----------
    image : ndarray of uint8, shape (H, W, 3)
        BGR, as OpenCV reads it.
    bins : int
        Orientation bins over the full circle (over a half circle when ``unsigned``).
    unsigned : bool
        Fold θ and θ + π together.
    min_gradient : float
        Pixels with a weaker gradient get weight 0 (SPEC: 10).

    Returns
    -------
    bin_image : ndarray of intp, shape (H, W)
        Values in 0 … bins − 1.
    weights : ndarray of float64, shape (H, W)
        g, or 0 below ``min_gradient``.

    Examples
    --------
    A dark left half and a bright right half (grey 200): the gradient points right,
    θ = 0, bin 0, and the two columns beside the step get g = 200:

    >>> image = np.zeros((3, 4, 3), np.uint8)
    >>> image[:, 2:] = 200
    >>> bin_image, weights = orientation_bins(image)
    >>> weights
    array([[  0., 200., 200.,   0.],
           [  0., 200., 200.,   0.],
           [  0., 200., 200.,   0.]])
    >>> bin_image[weights > 0]
    array([0, 0, 0, 0, 0, 0])

    Mirrored, the gradient points left (θ = π, bin 8 of 16), which ``unsigned`` folds back
    onto θ = 0; turned on its side, it points down (θ = π/2, bin 4):

    >>> orientation_bins(image[:, ::-1])[0][weights > 0]
    array([8, 8, 8, 8, 8, 8])
    >>> orientation_bins(image[:, ::-1], unsigned=True)[0][weights > 0]
    array([0, 0, 0, 0, 0, 0])
    >>> orientation_bins(image.transpose(1, 0, 2))[0][weights.T > 0]
    array([4, 4, 4, 4, 4, 4])
    """
    channels = image.astype(np.int64)
    # Integer weights in thousandths: a grey pixel (B = G = R) keeps its exact value.
    grey = (114 * channels[..., 0] + 587 * channels[..., 1] + 299 * channels[..., 2]) / 1000.0
    padded = np.pad(grey, 1, mode="edge")
    left, right = padded[:, :-2], padded[:, 2:]                                  # (H + 2, W)
    across = right - left
    gx = across[:-2] + 2.0 * across[1:-1] + across[2:]
    smooth = left + 2.0 * padded[:, 1:-1] + right
    gy = smooth[2:] - smooth[:-2]
    magnitude = 0.25 * np.sqrt(gx * gx + gy * gy)         # np.hypot and np.mod are several times slower
    period = np.pi if unsigned else 2.0 * np.pi
    # In turns, the axis directions (±π/2, π, …) are exact multiples of 1/4, so they do not
    # fall on the wrong side of a bin boundary by rounding.
    turns = np.arctan2(gy, gx) / period                   # [−1/2, 1/2], or [−1, 1] when unsigned
    turns += turns < 0                                    # [0, 1]
    bin_image = (turns * bins).astype(np.intp)
    bin_image[bin_image >= bins] = 0                      # one turn (θ = π unsigned, or −0 rounded) is 0
    weights = np.where(magnitude >= min_gradient, magnitude, 0.0)
    return bin_image, weights


@lru_cache(maxsize=32)
def kernel_grid(samples: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """The sample points of a box and their Epanechnikov weights (L (11), per-axis form).

    A ``w_samples × h_samples`` grid of cell centres u_i = (2i + 1)/n − 1 ∈ (−1, 1) along each
    axis, in units of the half-sizes; the weight is k(r) = 1 − r² with
    r² = u_x² + u_y² (SPEC B.2), and points with k = 0 (the box corners outside the inscribed
    ellipse) are dropped since they add nothing to any histogram.

    Parameters
    ----------
    samples : (int, int)
        Points across and down the box.

    Returns
    -------
    offsets : ndarray, shape (S, 2)
        (u_x, u_y) of the kept points; read-only (shared between calls).
    weights : ndarray, shape (S,)
        Their kernel weights, all > 0.

    Examples
    --------
    >>> offsets, weights = kernel_grid((2, 2))
    >>> offsets
    array([[-0.5, -0.5],
           [ 0.5, -0.5],
           [-0.5,  0.5],
           [ 0.5,  0.5]])
    >>> weights
    array([0.5, 0.5, 0.5, 0.5])
    """
    across, down = samples
    u = (2.0 * np.arange(across) + 1.0) / across - 1.0
    v = (2.0 * np.arange(down) + 1.0) / down - 1.0
    grid_u, grid_v = np.meshgrid(u, v)                                 # row-major: down, then across
    weights = 1.0 - grid_u ** 2 - grid_v ** 2
    keep = weights > 0
    offsets = np.stack([grid_u[keep], grid_v[keep]], axis=1)
    weights = weights[keep]
    offsets.flags.writeable = False
    weights.flags.writeable = False
    return offsets, weights


def kernel_histograms(bin_image: np.ndarray, centres: np.ndarray, box_sizes: np.ndarray, n_bins: int,
                      samples: tuple[int, int], foreground: np.ndarray | None = None, *,
                      pixel_weights: np.ndarray | None = None) -> np.ndarray:
    """Kernel-weighted histograms of P boxes at once (L (9)–(11); L (16)–(17) with a mask; C (8)).

    q(u) = f Σ_i k(r_i) g(x_i) δ[h(x_i) − u] ξ(x_i) with f = 1 / Σ_i k(r_i) g(x_i) (L (10)),
    over the sample points x_i of :func:`kernel_grid` placed in each box; ξ ≡ 1 without a
    mask and g ≡ 1 without pixel weights, which gives the plain f = 1 / Σ_i k(r_i).

    Sample points outside the image are moved to the nearest border pixel, so a box leaving
    the frame keeps a full histogram of the border colours (and of the border pixel weights).
    With a mask they count as background instead (ξ = 0): nothing outside the frame is
    foreground, and keeping them in f is what lowers the score of a box that leaves the
    frame.  The mask never enters f: Σ_u q(u) = F, the kernel-weighted foreground fraction of
    the box, ≤ 1 (SPEC B.4).

    Pixel weights (the gradient magnitudes of a histogram of oriented edges, SPEC B.5) do
    enter f, box by box: every histogram sums to 1 (to F with a mask), except that of a box
    whose sample points all have weight 0, which is all zero — its Bhattacharyya coefficient
    with any reference is then 0, never NaN.

    Parameters
    ----------
    bin_image : ndarray of int, shape (H, W)
        The bin of every pixel (:func:`colour_bins`).
    centres : ndarray, shape (P, 2)
        Box centres (cx, cy).
    box_sizes : ndarray, shape (P, 2)
        Box sizes (w, h), positive.
    n_bins : int
        B, the number of bins (values of ``bin_image`` lie in 0 … B − 1).
    samples : (int, int)
        The grid of :func:`kernel_grid`.
    foreground : ndarray of bool, shape (H, W), optional
        ξ of L (16).
    pixel_weights : ndarray of float, shape (H, W), optional
        g, a non-negative weight per pixel that multiplies the kernel weight of every sample
        point falling in that pixel.

    Returns
    -------
    ndarray, shape (P, B)
        One histogram per box; rows sum to 1 without a mask and to F with one (to 0 for a
        box without any weight).

    Examples
    --------
    The left half of a 4×4 image is in bin 0, the right half in bin 1; a box over the whole
    image splits evenly, and with the right half as foreground only that half is counted:

    >>> bins = np.repeat([[0, 0, 1, 1]], 4, axis=0)
    >>> kernel_histograms(bins, np.array([[2.0, 2.0]]), np.array([[4.0, 4.0]]), 2, (4, 4))
    array([[0.5, 0.5]])
    >>> kernel_histograms(bins, np.array([[2.0, 2.0]]), np.array([[4.0, 4.0]]), 2, (4, 4), foreground=bins == 1)
    array([[0. , 0.5]])

    Weighting the right half 3 times as much as the left moves the split to 1 : 3:

    >>> kernel_histograms(bins, np.array([[2.0, 2.0]]), np.array([[4.0, 4.0]]), 2, (4, 4),
    ...                   pixel_weights=np.where(bins == 1, 3.0, 1.0))
    array([[0.25, 0.75]])
    """
    counts, norms = _kernel_counts(bin_image, centres, box_sizes, n_bins, samples, foreground, pixel_weights)
    return counts.reshape(-1, n_bins) / norms


@lru_cache(maxsize=32)
def _grid_axes(samples: tuple[int, int]) -> tuple[np.ndarray, ...]:
    """The grid of :func:`kernel_grid` by axis: u (across,), v (down,), then each kept point's u and v index.

    The kept points are in the order of :func:`kernel_grid`; all four arrays are read-only.
    """
    across, down = samples
    u = (2.0 * np.arange(across) + 1.0) / across - 1.0
    v = (2.0 * np.arange(down) + 1.0) / down - 1.0
    grid_u, grid_v = np.meshgrid(u, v)
    keep = np.flatnonzero(1.0 - grid_u ** 2 - grid_v ** 2 > 0)
    down_index, across_index = np.divmod(keep, across)
    for array in (u, v, across_index, down_index):
        array.flags.writeable = False
    return u, v, across_index, down_index


def _tiled_weights(samples: tuple[int, int], n_boxes: int) -> np.ndarray:
    """The kernel weights of :func:`kernel_grid` for ``n_boxes`` boxes, sample-major and flat (S · n_boxes,).

    Read-only; point s of box b is entry s · n_boxes + b, the order of :class:`_Sampling`.
    """
    if n_boxes > HISTOGRAM_BLOCK:                        # not worth keeping
        return np.repeat(kernel_grid(samples)[1], n_boxes)
    return _kept_tiled_weights(samples, n_boxes)


@lru_cache(maxsize=8)
def _kept_tiled_weights(samples: tuple[int, int], n_boxes: int) -> np.ndarray:
    """:func:`_tiled_weights` for a block of boxes, built once per block size."""
    tiled = np.repeat(kernel_grid(samples)[1], n_boxes)
    tiled.flags.writeable = False
    return tiled


class _Sampling(NamedTuple):
    """Where the sample points of a block of n boxes fall, sample-major: point s of box b is at [s, b].

    Sample-major rows are as long as the block, and a histogram count still adds the weights
    of one box's points in the order of :func:`kernel_grid`, so nothing is transposed.
    """

    pixels: np.ndarray                  # (S, n) flat pixel index of every point
    inside: np.ndarray | None           # (S, n) which points lie in the image; None: all, or not asked
    weights: np.ndarray                 # (S · n,) kernel weight of every point, read-only
    n_boxes: int
    kernel_total: float                 # Σ_i k(r_i) over one box's points, the 1 / f of L (10)


def _sample(centres: np.ndarray, box_sizes: np.ndarray, samples: tuple[int, int], shape: tuple[int, int],
            inside: bool = False) -> _Sampling:
    """The :class:`_Sampling` of the boxes at ``centres`` (n, 2) of sizes ``box_sizes`` (n, 2) in an image of ``shape``.

    A box's sample points form a grid, so the coordinates are computed per axis (across +
    down values per box rather than 2 S), each by the same floating-point expression as
    point by point, and only the pixel indices are spread over the grid.  Which points lie
    in the image is found only when ``inside`` is asked (a mask counts the others out).
    """
    u, v, across_index, down_index = _grid_axes(samples)
    height, width = shape
    half = 0.5 * box_sizes
    xs = centres[:, 0] + u[:, None] * half[:, 0]                                   # (across, n)
    ys = centres[:, 1] + v[:, None] * half[:, 1]                                   # (down, n)
    # Truncating a coordinate clipped to [0, W − 1] gives the same pixel as clipping ⌊x⌋,
    # without a floor pass.
    clipped = np.maximum(xs, 0.0)
    columns = np.minimum(clipped, width - 1.0, out=clipped).astype(np.intp)
    clipped = np.maximum(ys, 0.0)
    rows = np.minimum(clipped, height - 1.0, out=clipped).astype(np.intp)
    rows *= width
    pixels = np.take(rows, down_index, axis=0)                                     # (S, n)
    pixels += np.take(columns, across_index, axis=0)
    weights = _tiled_weights(samples, centres.shape[0])
    within = None
    if inside:
        within_x = (xs >= 0) & (xs < width)
        within_y = (ys >= 0) & (ys < height)
        if not (within_x.all() and within_y.all()):
            within = np.take(within_y, down_index, axis=0) & np.take(within_x, across_index, axis=0)
    return _Sampling(pixels, within, weights, centres.shape[0], _kernel_total(samples))


@lru_cache(maxsize=32)
def _kernel_total(samples: tuple[int, int]) -> float:
    """Σ_i k(r_i) over the points of :func:`kernel_grid`."""
    return float(kernel_grid(samples)[1].sum())


def _slots(bin_image: np.ndarray, sampling: _Sampling, width: int, compact: np.ndarray | None = None) -> np.ndarray:
    """The histogram slot b · width + bin of every sample point, flat (S · n,).

    ``compact`` (optional, shape (B,)) renumbers the bins into 0 … width − 1 first.
    """
    bins = np.take(np.ravel(bin_image), sampling.pixels)
    if compact is not None:
        bins = np.take(compact, bins)
    return np.add(bins, np.arange(sampling.n_boxes, dtype=np.intp) * width, dtype=np.intp).ravel()


def _counts(slots: np.ndarray, sampling: _Sampling, width: int, foreground: np.ndarray | None = None,
            pixel_weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | float]:
    """The unnormalised histograms of the sampled boxes, flat (n · width,), and their 1 / f.

    1 / f is a number without pixel weights, and one per box, shape (n, 1), with them (1 for
    a box without weight, whose counts are all 0).  Each count adds its sample weights in
    the order of :func:`kernel_grid`, so the counts are those of a point-by-point sum.
    """
    n_boxes = sampling.n_boxes
    sample_weights = sampling.weights
    if pixel_weights is not None:
        sample_weights = sample_weights * np.take(np.ravel(pixel_weights), sampling.pixels).ravel()
        totals = sample_weights.reshape(-1, n_boxes).sum(axis=0)                   # 1 / f, box by box
    if foreground is not None:
        counted = np.take(np.ravel(foreground), sampling.pixels)
        if sampling.inside is not None:
            counted &= sampling.inside
        sample_weights = sample_weights * counted.ravel()
    counts = np.bincount(slots, weights=sample_weights, minlength=n_boxes * width)
    if pixel_weights is None:
        return counts, sampling.kernel_total                                       # f of L (10)
    # A box without any weight keeps its all-zero row rather than 0 / 0.
    return counts, np.where(totals > 0, totals, 1.0)[:, None]


def _kernel_counts(bin_image: np.ndarray, centres: np.ndarray, box_sizes: np.ndarray, n_bins: int,
                   samples: tuple[int, int], foreground: np.ndarray | None = None,
                   pixel_weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | float]:
    """The unnormalised histograms of :func:`kernel_histograms`, flat (n · B,), and their 1 / f (:func:`_counts`)."""
    if pixel_weights is not None:
        if np.shape(pixel_weights) != np.shape(bin_image):
            raise TrackingError(f"pixel_weights must have the shape {np.shape(bin_image)} of the bin image, "
                                f"got {np.shape(pixel_weights)}")
        pixel_weights = np.asarray(pixel_weights, dtype=np.float64)
    sampling = _sample(centres, box_sizes, tuple(samples), np.shape(bin_image), foreground is not None)
    return _counts(_slots(bin_image, sampling, n_bins), sampling, n_bins, foreground, pixel_weights)


def bhattacharyya(histograms: np.ndarray, references: np.ndarray) -> np.ndarray:
    """Bhattacharyya coefficients ρ[h_p, q_k] = Σ_u √(h_p(u) q_k(u)) of all pairs (L (12)–(13)).

    The sum runs over the non-zero bins of each h_p only: a box's histogram is built from a
    few hundred sample points, so it fills a few dozen of its B bins (B = 512 for 8 bins per
    channel).  No BLAS call is made, so the cost never depends on a BLAS thread pool, which
    a small product only slows down when the machine is busy.  Rounding is clipped into
    [0, 1] so that 1 − ρ = d² (W (17)) is never negative.

    Parameters
    ----------
    histograms : ndarray, shape (P, B)
    references : ndarray, shape (K, B)

    Returns
    -------
    ndarray, shape (P, K)

    Examples
    --------
    >>> bhattacharyya(np.array([[0.5, 0.5], [1.0, 0.0]]), np.array([[0.5, 0.5], [0.0, 1.0]]))
    array([[1.        , 0.70710678],
           [0.70710678, 0.        ]])
    """
    histograms = np.asarray(histograms, dtype=np.float64)
    references = np.asarray(references, dtype=np.float64)
    if histograms.ndim not in (1, 2) or references.ndim not in (1, 2) \
            or histograms.shape[-1] != references.shape[-1]:
        raise TrackingError(f"histograms (P, B) and references (K, B) need the same B, "
                            f"got shapes {histograms.shape} and {references.shape}")
    rows = np.ascontiguousarray(np.atleast_2d(histograms))
    rho = _sparse_rho(rows, 1.0, np.sqrt(np.atleast_2d(references)).T.copy())
    np.clip(rho, 0.0, 1.0, out=rho)
    # The shapes of a matrix product: a 1-D argument loses its axis.
    if references.ndim == 1:
        rho = rho[:, 0]
    return rho[0] if histograms.ndim == 1 else rho


class _Filled(NamedTuple):
    """Where the non-zero counts of n histograms of B bins are, box by box."""

    positions: np.ndarray               # (F,) flat positions in the (n, B) counts, increasing
    boxes: np.ndarray                   # (F,) the box of each
    bins: np.ndarray                    # (F,) the bin of each
    starts: np.ndarray                  # (n + 1,) the first entry of each box, then F
    nonempty: np.ndarray | None         # the boxes with an entry; None when every box has one


def _filled(counts: np.ndarray) -> _Filled:
    """The :class:`_Filled` of ``counts``, shape (n, B)."""
    n_boxes, n_bins = counts.shape
    positions = np.flatnonzero(counts != 0)            # a boolean pass: nonzero() on floats is slower
    boxes = positions // n_bins
    starts = np.searchsorted(boxes, np.arange(n_boxes + 1))
    has_entries = starts[1:] > starts[:-1]
    return _Filled(positions, boxes, positions - boxes * n_bins, starts,
                   None if has_entries.all() else np.flatnonzero(has_entries))


def _sparse_rho(counts: np.ndarray, norms, root_references: np.ndarray, filled: _Filled | None = None) -> np.ndarray:
    """Σ_u √(h_p(u)) r_k(u) for n histograms h_p = counts_p / norm_p, shape (n, K).

    ``counts`` has shape (n, B), C-contiguous; ``norms`` is one number for all, or one per box
    (shape (n, 1)); ``root_references`` is √q, shape (B, K).  Each h_p(u) is the quotient of
    the dense histogram, and each box's terms are added in the order of its bins, so only
    the order of the additions differs from a dense product.  ``filled`` (optional) may
    name more positions than the non-zero counts, such as those of histograms of the same
    points without a mask: a zero count adds a zero term (the sums agree to rounding).
    """
    n_boxes = counts.shape[0]
    if filled is None:
        filled = _filled(counts)
    if filled.positions.size == 0:
        return np.zeros((n_boxes, root_references.shape[1]))
    roots = counts.ravel()[filled.positions]
    roots /= norms if np.ndim(norms) == 0 else np.ravel(norms)[filled.boxes]
    np.sqrt(roots, out=roots)
    terms = np.take(root_references, filled.bins, axis=0)                          # (filled, K)
    terms *= roots[:, None]
    if filled.nonempty is None:                                                    # the usual case
        return np.add.reduceat(terms, filled.starts[:-1], axis=0)
    rho = np.zeros((n_boxes, root_references.shape[1]))
    rho[filled.nonempty] = np.add.reduceat(terms, filled.starts[filled.nonempty], axis=0)
    return rho


def false_alarm_histogram(scene_counts: np.ndarray, templates: np.ndarray) -> np.ndarray:
    """The colours of the scene that are not the targets', q_FA (W (18)).

    q_FA ∝ max(q_scene − Σ_j q_j, 0) with q_scene the normalised scene histogram, as W (18)
    prints it: a target's colour is removed from FA entirely.  The result is renormalised to
    sum 1, and is uniform if nothing is left (SPEC B.3) — as when the scene itself is empty,
    an edge histogram of a frame without edges.

    Parameters
    ----------
    scene_counts : ndarray, shape (B,)
        Pixel counts of every bin over the whole frame (no kernel); for weighted pixels, the
        sums of their weights.
    templates : ndarray, shape (τ, B)
        The target templates q_j, rows summing to 1.

    Returns
    -------
    ndarray, shape (B,)
        Sums to 1.

    Examples
    --------
    A scene of 90 background pixels (bin 0) and 10 target pixels (bin 1):

    >>> scene, target = np.array([90.0, 10.0, 0.0]), np.array([[0.0, 1.0, 0.0]])
    >>> false_alarm_histogram(scene, target)
    array([1., 0., 0.])
    """
    scene_counts = np.asarray(scene_counts, dtype=np.float64)
    if not scene_counts.sum() > 0:
        return np.full(scene_counts.shape, 1.0 / scene_counts.size)
    scene = scene_counts / scene_counts.sum()
    residual = scene - templates.sum(axis=0)
    # What survives the subtraction by rounding alone (~1e-17 of the scene) is not a colour of
    # the scene; renormalised, it would become a spurious FA histogram.  This also clamps at 0.
    residual[residual <= RESIDUAL_TOLERANCE * scene.sum()] = 0.0
    total = residual.sum()
    if total <= 0:
        return np.full(scene_counts.shape, 1.0 / scene_counts.size)
    return residual / total


# -- colour cues ----------------------------------------------------------------------------------
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
        Sample points across and down a box (:func:`kernel_grid`); the default suits upright
        people, twice as tall as wide.
    """

    bins: int = 8
    sigma: float = 0.15
    samples: tuple[int, int] = (12, 24)

    def __post_init__(self) -> None:
        bins = _count("ColourConfig", "bins", self.bins)
        if bins > MAX_BINS_PER_CHANNEL:
            raise TrackingError(f"ColourConfig.bins must be at most {MAX_BINS_PER_CHANNEL} per channel "
                                f"({MAX_BINS_PER_CHANNEL}³ joint bins), got {bins}")
        object.__setattr__(self, "bins", bins)
        object.__setattr__(self, "sigma", _positive("ColourConfig", "sigma", self.sigma))
        object.__setattr__(self, "samples", _samples("ColourConfig", self.samples))

    @property
    def n_bins(self) -> int:
        """B = bins³."""
        return self.bins ** 3


def _samples(owner: str, value) -> tuple[int, int]:
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
        raise TrackingError(f"{owner}.samples must be a pair (across, down), got {value!r}")
    return tuple(_count(owner, "samples", n) for n in value)


class ColourCue:
    """Colour similarity of every particle to every target and to the rest of the scene (W (16)–(19)).

    For the kernel-weighted histogram h of a particle's box (L (9)–(11)) and a reference q,
    d = √(1 − ρ[h, q]) (W (17), with the square root inside the sum) and
    log p = −d² / (2σ²) = −(1 − ρ) / (2σ²) (W (16), exponent corrected).  The references are
    the templates q_1 … q_τ and q_FA (W (18)), recomputed every frame from the whole frame.

    Templates are set from boxes ``(x, y, w, h)`` with :meth:`set_templates` or one at a time
    with :meth:`add_target` / :meth:`remove_target`.  A template is the histogram of its box
    sampled exactly as a particle's box, so a particle that sits on the box scores ρ = 1.
    W describes no template update, so they stay fixed unless :meth:`replace_template` is
    called (the update of C (16), SPEC B.5); :attr:`initial_templates` keeps them as built.

    Subclasses change what is counted by supplying the bin image and the pixel weights of a
    frame (``_image_features`` / ``_frame_features``); templates, q_FA and the scores follow.

    Examples
    --------
    A red target on a grey background; a particle on the target and one beside it:

    >>> image = np.full((60, 80, 3), 128, np.uint8)
    >>> image[20:40, 30:40] = (0, 0, 255)
    >>> cue = ColourCue(ColourConfig(samples=(6, 12)))
    >>> cue.set_templates(image, np.array([[30, 20, 10, 20]]))
    >>> obs = Observation(image, None, [[35.0, 30.0]], [[10.0, 20.0]], np.zeros((0, 2)))
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

    def __init__(self, config=None) -> None:
        if config is None:
            config = self.config_type()
        if not isinstance(config, self.config_type):
            wanted = self.config_type.__name__
            raise TrackingError(f"{type(self).__name__} needs {'an' if wanted[0] in 'AEIOU' else 'a'} {wanted}, "
                                f"got {type(config).__name__}")
        self.config = config
        self._templates = np.zeros((0, config.n_bins))
        self._initial = self._templates
        self._shared = False                                # a view of _templates was handed out

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.config!r}, targets={self.n_targets})"

    # -- what is counted ----------------------------------------------------------------------
    def _image_features(self, image: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """The bin image (H, W) of a frame and its pixel weights (None: every pixel counts 1)."""
        return colour_bins(image, self.config.bins), None

    def _frame_features(self, obs: Observation) -> tuple[np.ndarray, np.ndarray | None]:
        """:meth:`_image_features` of the observed frame, memoised on the observation."""
        return obs.colour_bins(self.config.bins), None

    # -- templates --------------------------------------------------------------------------
    @property
    def n_targets(self) -> int:
        """τ, the number of templates held."""
        return self._templates.shape[0]

    @property
    def templates(self) -> np.ndarray:
        """The current target templates q_j, shape (τ, B), rows summing to 1.

        (An edge template of a box without any edge is all zero.)  A read-only snapshot: a
        later :meth:`replace_template` does not change it.
        """
        self._shared = True
        view = self._templates.view()
        view.flags.writeable = False
        return view

    @property
    def initial_templates(self) -> np.ndarray:
        """The templates as built by :meth:`set_templates` / :meth:`add_target`, shape (τ, B) (read-only).

        :meth:`replace_template` leaves them alone; :meth:`remove_target` removes a row here
        too, so row j is always target j's q_init (C (16)).
        """
        view = self._initial.view()
        view.flags.writeable = False
        return view

    def set_templates(self, image: np.ndarray, boxes, foreground: np.ndarray | None = None) -> None:
        """Replace all templates by the histograms of ``boxes`` in ``image``.

        Parameters
        ----------
        image : ndarray of uint8, shape (H, W, 3)
            The frame the targets are taken from (BGR).
        boxes : array_like, shape (τ, 4)
            ``x, y, w, h`` in 0-based pixel coordinates; each must overlap the image.
        foreground : ndarray of bool, shape (H, W), optional
            The foreground mask of that frame (used by :class:`ForegroundColourCue` only).
        """
        templates = self._build_templates(image, boxes, foreground)
        self._templates, self._initial, self._shared = templates, templates.copy(), False

    def add_target(self, image: np.ndarray, box, foreground: np.ndarray | None = None) -> int:
        """Append the template of one new target, box ``(x, y, w, h)``; returns its index τ − 1."""
        template = self._build_templates(image, np.reshape(np.asarray(box, dtype=np.float64), (1, -1)), foreground)
        self._templates = np.concatenate([self._templates, template])
        self._initial = np.concatenate([self._initial, template])
        self._shared = False
        return self.n_targets - 1

    def remove_target(self, index: int) -> None:
        """Forget target ``index``; the templates after it move down by one, as the tracker's targets must."""
        index = self._target_index(index, "remove")
        self._templates = np.delete(self._templates, index, axis=0)
        self._initial = np.delete(self._initial, index, axis=0)
        self._shared = False

    def rebuild_template(self, index: int, image: np.ndarray, box, foreground: np.ndarray | None = None) -> None:
        """Take target ``index``'s template, current and initial, anew from ``box`` in ``image``.

        For a target first seen only in part (entering the image), once all of it is in view.
        """
        index = self._target_index(index, "rebuild the template of")
        template = self._build_templates(image, np.reshape(np.asarray(box, dtype=np.float64), (1, -1)), foreground)
        if self._shared:
            self._templates, self._shared = self._templates.copy(), False
        self._templates[index] = template[0]
        self._initial = self._initial.copy()
        self._initial[index] = template[0]

    def follow_appearance(self, observed: np.ndarray, frozen: np.ndarray) -> None:
        """Let every template follow its target's current appearance, frozen under occlusion (C (16)).

        The formula is :func:`belief_tracking.adaptive.update_templates`; the initial
        templates anchor it.

        Parameters
        ----------
        observed : ndarray, shape (τ, B)
            Each target's histogram at its estimate, p_i(x̂_t) (:meth:`histograms`).
        frozen : ndarray of bool, shape (τ,)
            Targets whose templates stay as they are (occluded: ρ_t < T).

        Examples
        --------
        >>> cue = ColourCue(ColourConfig(bins=1))
        >>> cue.set_templates(np.zeros((4, 4, 3), np.uint8), np.array([[0, 0, 4, 4]]))
        >>> cue.follow_appearance(np.array([[0.5]]), np.array([False]))
        >>> cue.templates.tolist()
        [[1.0]]
        """
        from .adaptive import update_templates

        updated = update_templates(self._initial, self._templates, observed, frozen)
        totals = updated.sum(axis=1, keepdims=True)
        # Rows summing to 1 up to rounding are normalised once more, as every template is.
        self._templates = np.divide(updated, totals, out=updated, where=totals > 0)
        self._shared = False                                # a new array: no snapshot of it was handed out

    def replace_template(self, index: int, histogram) -> None:
        """Make ``histogram``, normalised to sum 1, the current template of target ``index``.

        Parameters
        ----------
        index : int
            The target, 0 … τ − 1.
        histogram : array_like, shape (B,)
            Finite, non-negative, with a positive sum.

        Raises
        ------
        TrackingError
            A bad index, shape or value, or a histogram that sums to 0.
        """
        index = self._target_index(index, "replace the template of")
        try:
            histogram = np.asarray(histogram, dtype=np.float64)
        except (TypeError, ValueError):
            raise TrackingError(f"a template must be an array of {self.config.n_bins} numbers") from None
        if histogram.shape != (self.config.n_bins,):
            raise TrackingError(f"a template of the {self.name} cue must have shape ({self.config.n_bins},), "
                                f"got {histogram.shape}")
        if not np.isfinite(histogram).all() or (histogram < 0).any():
            raise TrackingError("a template must be finite and non-negative")
        total = histogram.sum()
        if not total > 0:
            raise TrackingError("a template must have a positive sum; an all-zero histogram cannot be normalised")
        if self._shared:                                    # keep the snapshots handed out intact
            self._templates, self._shared = self._templates.copy(), False
        self._templates[index] = histogram / total

    def _target_index(self, index, action: str) -> int:
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or not 0 <= index < self.n_targets:
            raise TrackingError(f"no target {index!r} to {action}; the cue holds targets 0..{self.n_targets - 1}")
        return int(index)

    def _build_templates(self, image, boxes, foreground) -> np.ndarray:
        image = _checked_image(image)
        if foreground is not None:
            foreground = _checked_mask(foreground, image.shape[:2])
        boxes = check_boxes(boxes, "template boxes", image_shape=image.shape[:2])
        return self._template_histograms(self._image_features(image), boxes, foreground)

    def _template_histograms(self, features: tuple, boxes: np.ndarray, foreground) -> np.ndarray:
        bin_image, weights = features
        return kernel_histograms(bin_image, box_centres(boxes), boxes[:, 2:], self.config.n_bins, self.config.samples,
                                 pixel_weights=weights)

    # -- scoring ----------------------------------------------------------------------------
    def histograms(self, obs: Observation, states: np.ndarray, owner: np.ndarray) -> np.ndarray:
        """The candidate histograms h of all particles' boxes, shape (P, B) (L (9)–(11))."""
        states, owner = _particles(obs, states, owner)
        return self._candidate_histograms(obs, self._frame_features(obs), states, owner)

    def _candidate_histograms(self, obs: Observation, features: tuple, states: np.ndarray,
                              owner: np.ndarray) -> np.ndarray:
        self._check_observation(obs)
        bin_image, _ = features
        sampling = _sample(states[:, :2], _particle_sizes(obs, states, owner), self.config.samples,
                           bin_image.shape, self._masked)
        counts, norms = self._block_counts(obs, features, sampling, _slots(bin_image, sampling, self.config.n_bins),
                                           self.config.n_bins)
        return counts.reshape(-1, self.config.n_bins) / norms

    #: Whether the candidate histograms count the foreground only (which points lie in the image matters).
    _masked: ClassVar[bool] = False

    def _check_observation(self, obs: Observation) -> None:
        """Refuse an observation that lacks what this cue reads."""

    def _block_counts(self, obs: Observation, features: tuple, sampling: _Sampling, slots: np.ndarray,
                      width: int) -> tuple[np.ndarray, np.ndarray | float]:
        """:func:`_counts` of a block of sampled boxes in this frame, ``width`` slots per box."""
        return _counts(slots, sampling, width, pixel_weights=features[1])

    def false_alarm_histogram(self, obs: Observation) -> np.ndarray:
        """q_FA of this frame, shape (B,) (W (18)); A_j = w_j · h_j from ``obs.sizes``.

        With pixel weights, the scene counts are the weights summed per bin, and A_j is the
        weight within target j's box (``obs.sizes`` at ``obs.centres``).
        """
        self._check_targets(obs)
        return self._false_alarm(obs, self._frame_features(obs))

    def _false_alarm(self, obs: Observation, features: tuple) -> np.ndarray:
        bin_image, weights = features
        scene = _scene_counts(obs, bin_image, weights, self.config.n_bins)       # kernel-free, whole frame
        return false_alarm_histogram(scene, self._templates)

    def log_likelihoods(self, obs: Observation, states: np.ndarray, owner: np.ndarray) -> np.ndarray:
        """log p_1 … log p_τ, log p_FA = −(1 − ρ) / (2σ²) of every particle, shape (P, τ + 1) (W (16)–(19))."""
        states, owner = _particles(obs, states, owner)
        rho = _rho_together([self], obs, states, owner)[0]
        return _log_gaussian(1.0 - rho, self.config.sigma)                          # d² = 1 − ρ (W (17))

    def _check_targets(self, obs: Observation) -> None:
        if obs.n_targets != self.n_targets:
            raise TrackingError(f"the {self.name} cue holds {self.n_targets} target templates but the observation "
                                f"has {obs.n_targets} targets; add or remove templates with the targets")


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
    template methods are required.

    Examples
    --------
    A red target (foreground) on grey; one particle on it, one on the background:

    >>> image = np.full((60, 80, 3), 128, np.uint8)
    >>> image[20:40, 30:40] = (0, 0, 255)
    >>> mask = np.zeros((60, 80), bool)
    >>> mask[20:40, 30:40] = True
    >>> cue = ForegroundColourCue(ColourConfig(samples=(6, 12)))
    >>> cue.set_templates(image, np.array([[30, 20, 10, 20]]), foreground=mask)
    >>> obs = Observation(image, mask, [[35.0, 30.0]], [[10.0, 20.0]], np.zeros((0, 2)))
    >>> states = np.array([[35.0, 30.0, 0, 0, 0], [60.0, 30.0, 0, 0, 0]])
    >>> cue.histograms(obs, states, np.array([0, 0])).sum(axis=1)       # F
    array([1., 0.])
    """

    name: ClassVar[str] = "foreground"

    def _template_histograms(self, features: tuple, boxes: np.ndarray, foreground) -> np.ndarray:
        if foreground is None:
            raise TrackingError("the foreground cue builds its templates from the foreground mask; pass foreground=")
        bin_image, weights = features
        plain = super()._template_histograms(features, boxes, None)
        masked = kernel_histograms(bin_image, box_centres(boxes), boxes[:, 2:], self.config.n_bins,
                                   self.config.samples, foreground, pixel_weights=weights)
        mass = masked.sum(axis=1, keepdims=True)
        # The template describes the target, not how much of its box it fills: normalise to 1.
        return np.where(mass > 0, masked / np.where(mass > 0, mass, 1.0), plain)

    _masked: ClassVar[bool] = True

    def _check_observation(self, obs: Observation) -> None:
        if obs.foreground is None:
            raise TrackingError("the foreground cue needs Observation.foreground, the background model's mask; "
                                "got None")

    def _block_counts(self, obs: Observation, features: tuple, sampling: _Sampling, slots: np.ndarray,
                      width: int) -> tuple[np.ndarray, np.ndarray | float]:
        return _counts(slots, sampling, width, obs.foreground, pixel_weights=features[1])


# -- edge cue -------------------------------------------------------------------------------------
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
        bins = _count("EdgeConfig", "bins", self.bins)
        if bins > MAX_ORIENTATION_BINS:
            raise TrackingError(f"EdgeConfig.bins must be at most {MAX_ORIENTATION_BINS}, got {bins}")
        object.__setattr__(self, "bins", bins)
        object.__setattr__(self, "sigma", _positive("EdgeConfig", "sigma", self.sigma))
        object.__setattr__(self, "samples", _samples("EdgeConfig", self.samples))
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
    whole frame.  The ``foreground`` arguments of the template methods are ignored.

    Examples
    --------
    A bright square on a dark background, sampled at every pixel of its 24×24 box: its four
    sides give four orientations, 0, π/2, π and 3π/2, a quarter each (the corners lie outside
    the kernel's ellipse).  One particle sits on the box, one on the flat background:

    >>> image = np.zeros((60, 80, 3), np.uint8)
    >>> image[20:40, 30:50] = 200
    >>> cue = EdgeCue(EdgeConfig(samples=(24, 24)))
    >>> cue.set_templates(image, np.array([[28, 18, 24, 24]]))
    >>> cue.templates[0, ::4]
    array([0.25, 0.25, 0.25, 0.25])
    >>> obs = Observation(image, None, [[40.0, 30.0]], [[24.0, 24.0]], np.zeros((0, 2)))
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

    def _image_features(self, image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return orientation_bins(image, self.config.bins, min_gradient=self.config.min_gradient)

    def _frame_features(self, obs: Observation) -> tuple[np.ndarray, np.ndarray]:
        return obs.orientation_bins(self.config.bins, min_gradient=self.config.min_gradient)


def score_cues(cues, obs: Observation, states: np.ndarray, owner: np.ndarray) -> tuple[np.ndarray, ...]:
    """Every cue's ``log_likelihoods(obs, states, owner)``, in the order of ``cues``.

    Colour cues (:class:`ColourCue` and the subclasses that keep its scoring) that read the
    same bin image with the same bins and sample grid place the sample points of every box
    once between them, which is most of their cost: the colour and foreground cues of the
    default tracker share it.  The scores are those of each cue on its own.

    Parameters
    ----------
    cues : sequence of Cue
    obs : Observation
    states : ndarray, shape (P, 5)
    owner : ndarray of int, shape (P,)

    Returns
    -------
    tuple of ndarray, each of shape (P, τ + 1) (or what the cue returns)

    Examples
    --------
    >>> image = np.full((60, 80, 3), 128, np.uint8)
    >>> image[20:40, 30:40] = (0, 0, 255)
    >>> mask = image[..., 2] == 255
    >>> config = ColourConfig(samples=(6, 12))
    >>> colour, foreground = ColourCue(config), ForegroundColourCue(config)
    >>> for cue in (colour, foreground):
    ...     cue.set_templates(image, np.array([[30, 20, 10, 20]]), foreground=mask)
    >>> obs = Observation(image, mask, [[35.0, 30.0]], [[10.0, 20.0]], np.zeros((0, 2)))
    >>> states, owner = np.array([[35.0, 30.0, 0, 0, 0], [60.0, 30.0, 0, 0, 0]]), np.array([0, 0])
    >>> together = score_cues([colour, foreground], obs, states, owner)
    >>> alone = [cue.log_likelihoods(obs, states, owner) for cue in (colour, foreground)]
    >>> all(np.array_equal(t, a) for t, a in zip(together, alone))
    True
    """
    states, owner = _particles(obs, states, owner)
    scores: list = [None] * len(cues)
    groups, others = _sampling_groups(cues, obs)
    for index in others:
        scores[index] = cues[index].log_likelihoods(obs, states, owner)
    for members in groups:
        rhos = _rho_together([cues[i] for i in members], obs, states, owner)
        for index, rho in zip(members, rhos):
            scores[index] = _log_gaussian(1.0 - rho, cues[index].config.sigma)       # d² = 1 − ρ (W (17))
    return tuple(scores)


def template_similarity(cues, obs: Observation, states: np.ndarray, owner: np.ndarray) -> np.ndarray:
    """ρ (L (12)) of every box with its owner's current template, the smallest over the appearance ``cues``.

    How much a target's window still looks like the target; the colour cues share their
    sampling as in :func:`score_cues`.

    Parameters
    ----------
    cues : sequence of AppearanceCue
        At least one.
    obs : Observation
    states : ndarray, shape (P, 5)
    owner : ndarray of int, shape (P,)

    Returns
    -------
    ndarray, shape (P,)

    Examples
    --------
    >>> image = np.full((60, 80, 3), 128, np.uint8)
    >>> image[20:40, 30:40] = (0, 0, 255)
    >>> cue = ColourCue(ColourConfig(samples=(6, 12)))
    >>> cue.set_templates(image, np.array([[30, 20, 10, 20]]))
    >>> obs = Observation(image, None, [[35.0, 30.0]], [[10.0, 20.0]], np.zeros((0, 2)))
    >>> template_similarity([cue], obs, np.array([[35.0, 30.0, 0, 0, 0], [60.0, 30.0, 0, 0, 0]]), np.array([0, 0]))
    array([1., 0.])
    """
    if not cues:
        raise TrackingError("template_similarity needs at least one appearance cue")
    states, owner = _particles(obs, states, owner)
    rows = np.arange(owner.size)
    found = []
    groups, others = _sampling_groups(cues, obs)
    for index in others:
        cue = cues[index]
        found.append(bhattacharyya(cue.histograms(obs, states, owner), cue.templates)[rows, owner])
    for members in groups:
        found.extend(rho[rows, owner] for rho in _rho_together([cues[i] for i in members], obs, states, owner))
    return np.min(found, axis=0)


def _sampling_groups(cues, obs: Observation) -> tuple[list[list[int]], list[int]]:
    """The indices of the colour cues that can share their sampling, by group, and those of the other cues."""
    groups: dict[tuple, list[int]] = {}
    others = []
    for index, cue in enumerate(cues):
        if isinstance(cue, ColourCue) and type(cue).log_likelihoods is ColourCue.log_likelihoods \
                and type(cue).histograms is ColourCue.histograms:
            bin_image, weights = cue._frame_features(obs)          # memoised on obs: the ids stay valid
            groups.setdefault((id(bin_image), id(weights), cue.config.n_bins, cue.config.samples), []).append(index)
        else:
            others.append(index)
    return list(groups.values()), others


def _rho_together(cues: list, obs: Observation, states: np.ndarray, owner: np.ndarray) -> list[np.ndarray]:
    """ρ of every box with every reference (τ templates, then q_FA) of colour cues that share their features and grid.

    One (P, τ + 1) array per cue, in [0, 1]; each box is sampled once for all the cues.

    The bins that no pixel of the frame fills (with a positive weight) cannot be in any box,
    so the histograms are counted over the frame's own bins only, in their order (plus one
    slot, read against zero, for weightless points), which keeps the dense counts of a block
    a few times smaller and gives the same sums.
    """
    first = cues[0]
    features = first._frame_features(obs)
    bin_image, weights = features
    n_bins = first.config.n_bins
    present = np.flatnonzero(_scene_counts(obs, bin_image, weights, n_bins) > 0)
    compact = np.full(n_bins, present.size, np.intp)
    compact[present] = np.arange(present.size)
    width = present.size + 1
    roots, rhos = [], []
    for cue in cues:
        cue._check_targets(obs)
        cue._check_observation(obs)
        references = np.concatenate([cue._templates, cue._false_alarm(obs, features)[None, :]])    # (τ + 1, B)
        root = np.zeros((width, references.shape[0]))                       # (width, τ + 1), rows gathered
        root[:-1] = np.sqrt(references[:, present]).T
        roots.append(root)
        rhos.append(np.empty((states.shape[0], references.shape[0])))
    centres, sizes = states[:, :2], _particle_sizes(obs, states, owner)
    masked = any(cue._masked for cue in cues)
    # Blocks keep every temporary of a block (its samples, its dense counts) small enough
    # for the allocator to serve from memory it already holds, whatever P.
    for start in range(0, states.shape[0], HISTOGRAM_BLOCK):
        block = slice(start, start + HISTOGRAM_BLOCK)
        sampling = _sample(centres[block], sizes[block], first.config.samples, bin_image.shape, masked)
        slots = _slots(bin_image, sampling, width, compact)
        counted = [cue._block_counts(obs, features, sampling, slots, width) for cue in cues]
        # A mask only removes points, so the filled bins of an unmasked cue cover those of all.
        shared = next((_filled(counts.reshape(-1, width)) for cue, (counts, _) in zip(cues, counted)
                       if not cue._masked), None) if len(cues) > 1 else None
        for (counts, norms), root, rho in zip(counted, roots, rhos):
            rho[block] = _sparse_rho(counts.reshape(-1, width), norms, root, shared)
    for rho in rhos:
        np.clip(rho, 0.0, 1.0, out=rho)
    return rhos


def _scene_counts(obs: Observation, bin_image: np.ndarray, weights: np.ndarray | None, n_bins: int) -> np.ndarray:
    """The whole frame's count (or weight) per bin, computed once per frame for the cues that share a bin image."""
    key = ("scene", n_bins, id(bin_image), id(weights))
    known = obs._bins.get(key)
    # The arrays are kept with their counts, so an id is never taken for that of a newer array.
    if known is None or known[0] is not bin_image or known[1] is not weights:
        counts = np.bincount(bin_image.ravel(), weights=None if weights is None else weights.ravel(),
                             minlength=n_bins)
        counts.flags.writeable = False
        known = obs._bins[key] = (bin_image, weights, counts)
    return known[2]


def _particle_sizes(obs: Observation, states: np.ndarray, owner: np.ndarray) -> np.ndarray:
    """Box sizes (w, h) of the particles, ``sizes[owner] * exp(log_scale)``, shape (P, 2)."""
    # A scale beyond e^±30 ≈ 10^±13 already covers or misses any image; clipping keeps exp
    # finite, so no sample coordinate becomes inf − inf = NaN.
    log_scale = np.clip(states[:, 4:5], -MAX_ABS_LOG_SCALE, MAX_ABS_LOG_SCALE)
    return obs.sizes[owner] * np.exp(log_scale)


@dataclass(frozen=True)
class DetectionConfig:
    """Settings of the detections cue.

    Attributes
    ----------
    sigma : float
        σ_det of the Gaussian of a particle's distance to a detection, in units of the
        detection's own width (horizontally) and height (vertically): 0.25 means a particle
        a quarter of the box width beside the box centre is one σ away.
    reliability : float in [0, 1]
        Trust in the detector on top of its scores: a detection of score s discounts its
        evidence by the reliability r·s (1: the scores as they are).
    """

    sigma: float = 0.25
    reliability: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma", _positive("DetectionConfig", "sigma", self.sigma))
        object.__setattr__(self, "reliability", checks.fraction("DetectionConfig.reliability", self.reliability))


class DetectionCue:
    """How well a particle agrees with the frame's detections, each discounted by its score.

    Each detection i with box centre (x_i, y_i), size (w_i, h_i) and score s_i is a source of
    reliability r_i = r·s_i (r of :class:`DetectionConfig`); its support for a window centred
    on (x, y) is the Gaussian

        G_i(x, y) = exp(−½ [((x − x_i) / (σ w_i))² + ((y − y_i) / (σ h_i))²]).

    Discounting a source by its reliability keeps 1 − r_i of its mass on the whole frame
    (Shafer's discounting), which reads as a likelihood of at least 1 − r_i for every
    hypothesis:

    * target j with detection d_j (:attr:`Observation.assigned`): p_j = r_d·G_d + (1 − r_d);
    * target j with no detection this frame: p_j = 1, so the cue says nothing about it and
      the other cues carry the target (a missed detection, an occlusion);
    * FA: p_FA = 1 − max_i r_i·G_i, small on any detection and 1 far from all of them.

    A frame without detections gives every particle p = 1 for every hypothesis.

    Examples
    --------
    One detection of score 0.8, taken by target 0; target 1 has none.  A particle on the
    detection supports target 0 fully and FA little; one far away supports target 0 only
    by the 1 − 0.8 that the detector's doubt leaves:

    >>> obs = Observation(np.zeros((100, 100, 3), np.uint8), None, centres=[[50, 50], [10, 10]],
    ...                   sizes=[[20, 40], [20, 40]], previous_particles=np.zeros((0, 2)),
    ...                   detections=[[40, 30, 20, 40, 0.8]], assigned=[0, -1])
    >>> states = np.array([[50.0, 50.0, 0, 0, 0], [90.0, 90.0, 0, 0, 0]])
    >>> np.exp(DetectionCue().log_likelihoods(obs, states, np.array([0, 0]))).round(3)
    array([[1. , 1. , 0.2],
           [0.2, 1. , 1. ]])
    """

    name: ClassVar[str] = "detections"
    config_type: ClassVar[type] = DetectionConfig

    def __init__(self, config: DetectionConfig = DetectionConfig()) -> None:
        if not isinstance(config, DetectionConfig):
            raise TrackingError(f"DetectionCue needs a DetectionConfig, got {type(config).__name__}")
        self.config = config

    def __repr__(self) -> str:
        return f"DetectionCue({self.config!r})"

    def log_likelihoods(self, obs: Observation, states: np.ndarray, owner: np.ndarray) -> np.ndarray:
        """log p_1 … log p_τ, log p_FA of every particle, shape (P, τ + 1)."""
        states, owner = _particles(obs, states, owner)
        tau = obs.n_targets
        scores = np.zeros((states.shape[0], tau + 1))
        detections = obs.detections
        if detections is None or detections.shape[0] == 0 or states.shape[0] == 0:
            return scores
        centres = detections[:, :2] + detections[:, 2:4] / 2.0
        spread = self.config.sigma * detections[:, 2:4]
        dx = (states[:, 0:1] - centres[:, 0]) / spread[:, 0]
        dy = (states[:, 1:2] - centres[:, 1]) / spread[:, 1]
        reliability = self.config.reliability * detections[:, 4]
        support = reliability * np.exp(-0.5 * (dx * dx + dy * dy))                   # (P, n): r_i·G_i
        # log1p(−x) keeps 1 − r·G accurate when r·G is tiny; a certain detection (r·G = 1)
        # gives −inf, a likelihood of zero, which the mass functions accept.
        with np.errstate(divide="ignore"):
            scores[:, tau] = np.log1p(-support.max(axis=1))
            taken = np.flatnonzero(obs.assigned >= 0)
            chosen = obs.assigned[taken]
            scores[:, taken] = np.log1p(support[:, chosen] - reliability[chosen])
        return scores


# -- registry -------------------------------------------------------------------------------------
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
    EdgeCue(EdgeConfig(bins=8, sigma=0.15, samples=(12, 24), min_gradient=10.0), targets=0)
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
