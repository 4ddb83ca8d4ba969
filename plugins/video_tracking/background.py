"""Per-pixel Gaussian-mixture background model: the foreground mask of the cues (SPEC B.4, L (1)–(6), L (16)).

Every pixel's colour is modelled by a mixture of Gaussians (L (1)–(4)); the heavy, narrow
components whose weights add up to the background ratio are the background (L (5)–(6)),
and a pixel that none of them explains is foreground, ξ = 1 of L (16).  The mixtures are
learnt online, so a background that changes slowly is absorbed.

The model is OpenCV's MOG2 (Zivkovic's adaptive mixture, a refinement of the
Stauffer–Grimson model of SPEC B.4 that also picks the number of components per pixel):
a well-kept implementation, run in C++.  Pixels that MOG2 calls shadows (darker, same
chromaticity) count as background, as SPEC B.4's shadow post-filter asks.  OpenCV stays at
this edge: the cues that use the mask are numpy only.

Without detections the mask is all that finds people, so four things keep it usable:

* **A warm-up from the median.**  :meth:`BackgroundModel.warm_up` takes the per-pixel
  median of its frames (spread over the video) as a first background, or, where people
  cover a pixel in more than half of them, the colour that most frames share; it
  replaces the pixels of each frame that differ from it before the mixtures learn from
  them.  People who are in view in every frame, but never long at one place, then stay
  foreground; fed as they are, with MOG2's fast schedule of the first frames, they would
  become part of the background.
* **Gain compensation.**  Each frame is divided by its brightness relative to the
  background (the median ratio over a sparse grid of pixels that were background in
  the previous frame) before the mixtures see it, so that the sun coming out or the
  camera's exposure changing does not reach the mask.
* **Protected pixels.**  ``apply(image, protect=mask)`` classifies every pixel but does not
  learn the protected ones (the pixels under confirmed tracks), so that a person who
  stands still stays foreground.
* **Lighting changes.**  A frame whose brightness moves fast, or whose mask is mostly
  foreground even so (a change the gain cannot explain), sets
  :attr:`BackgroundModel.lighting_change`: its mask is not people, and no track should be
  born from it.  After a mostly-foreground mask the model re-learns the background fast
  for a few frames.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from .errors import TrackingError
from .extras import require
from .limits import shown as _shown

cv2 = require("cv2")

__all__ = ["BackgroundConfig", "BackgroundModel"]

#: The value MOG2 gives foreground pixels; shadows get a lower one (127) and background 0.
_MOG2_FOREGROUND = 255

#: About this many pixels of a sparse grid estimate the gain of a frame: the median of a
#: few thousand ratios is exact to a fraction of a percent and costs far less than a frame.
_GAIN_SAMPLES = 4000

#: A gain this close to 1 is left alone: 2 % moves a grey level of 128 by 2.6, well inside
#: the noise the mixtures allow, and dividing costs a pass over the frame.
_GAIN_TOLERANCE = 0.02

#: Ratios of pixels darker or brighter than these (per channel) say little about the gain:
#: dark ones are mostly noise, and bright ones may be saturated.
_DARK, _BRIGHT = 8, 250

#: Weight of a new frame in the running mean of the gain that :attr:`BackgroundModel.lighting_change`
#: compares the frame's gain with.
_GAIN_SMOOTHING = 0.2

#: The model needs this many frames before a mostly-foreground mask means a lighting change
#: rather than a young model.
_MATURE_FRAMES = 10

#: The background image used under protected pixels is taken from the mixtures again after
#: this many frames; the background changes slowly, and taking it costs half a frame's model.
_BACKGROUND_REFRESH = 25

#: A warm-up with fewer frames than this has no reliable median and learns as before.
_MEDIAN_MIN_FRAMES = 5

#: At most this many warm-up frames propose a background colour where the median is doubtful.
_MODE_CANDIDATES = 50

#: Median of a chi-square variable with 1 and with 3 degrees of freedom: a robust per-channel
#: noise variance is the median of the squared colour distances divided by it.  (Channel
#: sums would not do: the noise of a compressed video is much the same in every channel.)
_CHI2_MEDIAN = {1: 0.4549, 3: 2.3660}


#: The longest memory of the model, in frames (its learning rate is then 10^-5; MOG2 keeps it as an int).
MAX_HISTORY = 100_000
#: The most mixture components per pixel: each costs 20 bytes a pixel, and OpenCV's default is 5.
MAX_MIXTURES = 16
#: The largest shrink factor of the frames the mixtures see.
MAX_DOWNSCALE = 64
#: The largest squared colour distance that makes sense (3 x 255^2 = 195 075, with room to spare).
MAX_VAR_THRESHOLD = 1e6


@dataclass(frozen=True)
class BackgroundConfig:
    """Settings of the background model.

    Attributes
    ----------
    history : int
        Frames the model remembers; the learning rate settles at α = 1 / history (SPEC B.4:
        α = 0.01, hence 100).
    var_threshold : float
        Squared Mahalanobis distance under which a background component explains a pixel
        (OpenCV's default 16, i.e. 4σ, which keeps sensor noise out of the mask).
    mixtures : int
        K_g, the largest number of components per pixel (SPEC default 3).
    background_ratio : float
        M_bg of L (6) in (0, 1]: the weight the background components must reach (SPEC default 0.7).
    detect_shadows : bool
        Classify shadows, which then count as background; otherwise a cast shadow is foreground.
    learning_rate : float or None
        α in [0, 1] for every frame, or None for MOG2's schedule 1 / min(frames seen, history),
        which learns fast on the first frames.
    compensate_gain : bool
        Divide each frame by its global brightness relative to the background before the
        mixtures see it (default True).
    gain_change : float
        A frame whose gain differs from the recent running mean of the gains by more than
        this relative amount (default 0.05) is a lighting change.
    max_foreground : float
        A mask with more than this fraction of foreground pixels (default 0.4) is a lighting
        change, not people; in (0, 1].
    relearn_frames : int
        After such a mask, the model learns at rate at least 1 / relearn_frames for this many
        frames (default 5): the old background fades within them.
    median_warm_up : bool
        Start the background of :meth:`BackgroundModel.warm_up` from the median of its
        frames (default True); False feeds the frames to the mixtures as they are.
    downscale : int
        The mixtures see frames shrunk this many times in each direction (block means),
        and the mask is scaled back (default 2; 1: full size).  2 quarters the cost of the
        model; a person 20 px wide is still 10 px wide.

    Examples
    --------
    >>> BackgroundConfig().max_foreground
    0.4
    >>> BackgroundConfig(max_foreground=0)
    Traceback (most recent call last):
    ...
    belief_tracking.errors.TrackingError: BackgroundConfig.max_foreground must lie in (0, 1], got 0
    """

    history: int = 100
    var_threshold: float = 16.0
    mixtures: int = 3
    background_ratio: float = 0.7
    detect_shadows: bool = True
    learning_rate: float | None = None
    compensate_gain: bool = True
    gain_change: float = 0.05
    max_foreground: float = 0.4
    relearn_frames: int = 5
    median_warm_up: bool = True
    downscale: int = 2

    def __post_init__(self) -> None:
        for name, largest in (("history", MAX_HISTORY), ("mixtures", MAX_MIXTURES),
                              ("relearn_frames", MAX_HISTORY), ("downscale", MAX_DOWNSCALE)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise TrackingError(f"BackgroundConfig.{name} must be a positive integer, got {_shown(value)}")
            if value > largest:
                raise TrackingError(f"BackgroundConfig.{name} must be at most {largest:,}, got {_shown(value)}")
        for name in ("var_threshold", "gain_change"):
            value = getattr(self, name)
            if _is_number(value) and math.isfinite(value) and value > MAX_VAR_THRESHOLD:
                raise TrackingError(f"BackgroundConfig.{name} must be at most {MAX_VAR_THRESHOLD:g}, got {_shown(value)}")
        if not _is_number(self.var_threshold) or not self.var_threshold > 0:
            raise TrackingError(f"BackgroundConfig.var_threshold must be a positive number, got {_shown(self.var_threshold)}")
        for name in ("background_ratio", "max_foreground"):
            value = getattr(self, name)
            if not _is_number(value) or not 0 < value <= 1:
                raise TrackingError(f"BackgroundConfig.{name} must lie in (0, 1], got {_shown(value)}")
        if not _is_number(self.gain_change) or not self.gain_change > 0:
            raise TrackingError(f"BackgroundConfig.gain_change must be a positive number, got {_shown(self.gain_change)}")
        for name in ("detect_shadows", "compensate_gain", "median_warm_up"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise TrackingError(f"BackgroundConfig.{name} must be True or False, got {_shown(getattr(self, name))}")
        if self.learning_rate is not None and (not _is_number(self.learning_rate) or not 0 <= self.learning_rate <= 1):
            raise TrackingError(f"BackgroundConfig.learning_rate must be None or lie in [0, 1], "
                                f"got {_shown(self.learning_rate)}")


def _is_number(value) -> bool:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:        # an int beyond any float
        return False


def _check_frame(image) -> np.ndarray:
    image = np.asarray(image)
    if image.dtype != np.uint8 or image.ndim not in (2, 3) or (image.ndim == 3 and image.shape[2] != 3) \
            or 0 in image.shape:
        raise TrackingError(f"frames must be (H, W, 3) or (H, W) uint8 arrays, got shape {image.shape} "
                            f"dtype {image.dtype}")
    return image


class BackgroundModel:
    """A learning background model that gives the foreground mask of every frame.

    Parameters
    ----------
    config : BackgroundConfig

    Attributes
    ----------
    frames_seen : int
        Frames learnt so far (warm-up frames included).
    gain : float
        Brightness of the last frame relative to the background; the frame was divided by
        it before the mixtures saw it (1 without gain compensation).
    foreground_fraction : float
        Fraction of the pixels of the last mask that are foreground.
    lighting_change : bool
        Whether the last frame's light changed too much or too fast for its mask to show
        people only: its gain moved by more than ``gain_change`` from the recent ones, its
        mask is more than ``max_foreground`` foreground, or the model is still re-learning
        after such a mask.  No track should be born from such a mask.

    Examples
    --------
    A still grey scene, learnt on a few frames, then a white square appears:

    >>> model = BackgroundModel()
    >>> scene = np.full((40, 60, 3), 90, np.uint8)
    >>> model.warm_up([scene] * 10)
    10
    >>> frame = scene.copy()
    >>> frame[10:20, 30:40] = 250
    >>> mask = model.apply(frame)
    >>> mask.shape, mask.dtype, int(mask.sum()), bool(mask[10:20, 30:40].all())
    ((40, 60), dtype('bool'), 100, True)

    The square stands still.  Protected, it is never learnt and stays foreground; the
    light then brightens by a third, which the gain takes out of the mask:

    >>> protect = np.zeros((40, 60), bool)
    >>> protect[8:22, 28:42] = True
    >>> masks = [model.apply(frame, protect=protect) for _ in range(300)]
    >>> int(masks[-1].sum()), model.lighting_change
    (100, False)
    >>> brighter = np.rint(frame * np.float32(4 / 3)).clip(0, 255).astype(np.uint8)
    >>> mask = model.apply(brighter, protect=protect)
    >>> int(mask.sum()), round(model.gain, 2), model.lighting_change
    (100, 1.33, True)
    """

    def __init__(self, config: BackgroundConfig = BackgroundConfig()) -> None:
        if not isinstance(config, BackgroundConfig):
            raise TrackingError(f"BackgroundModel needs a BackgroundConfig, got {type(config).__name__}")
        self.config = config
        self._subtractor = cv2.createBackgroundSubtractorMOG2(
            history=config.history, varThreshold=float(config.var_threshold), detectShadows=bool(config.detect_shadows))
        self._subtractor.setNMixtures(int(config.mixtures))
        self._subtractor.setBackgroundRatio(float(config.background_ratio))
        self._shape: tuple[int, ...] | None = None
        self._small: tuple[int, int] | None = None         # (H, W) the mixtures see
        self._labels: np.ndarray | None = None             # MOG2's per-frame output, reused
        self._step = 1                                     # of the grid the gain is measured on
        self._reference: np.ndarray | None = None          # the background's channel sums on the grid, (h, w)
        self._channels = 3
        self._was_foreground: np.ndarray | None = None     # the last mask on the grid
        self._background: np.ndarray | None = None         # the mixtures' background image, for protected pixels
        self._background_age = 0
        self._noise: float | None = None                   # per-channel noise variance, for protected pixels
        self._mean_gain: float | None = None
        self._relearn_left = 0
        self.frames_seen = 0
        self.gain = 1.0
        self.foreground_fraction = 0.0
        self.lighting_change = False

    def __repr__(self) -> str:
        return f"BackgroundModel({self.config!r}, frames_seen={self.frames_seen})"

    # -- public ---------------------------------------------------------------------------------
    def apply(self, image: np.ndarray, protect: np.ndarray | None = None) -> np.ndarray:
        """Classify the pixels of one frame, then learn from it.

        Parameters
        ----------
        image : ndarray of uint8, shape (H, W, 3) or (H, W)
            A BGR or grey frame, of the same shape as every earlier frame.
        protect : ndarray of bool, shape (H, W), optional
            Pixels that are classified but not learnt this frame (those under confirmed
            tracks): the mixtures learn the background image there instead, so a person
            who stands still is never absorbed.

        Returns
        -------
        ndarray of bool, shape (H, W)
            True where the pixel is foreground (ξ of L (16)); shadows are background.

        Raises
        ------
        TrackingError
            If the frame is not a uint8 (H, W, 3) or (H, W) array of the model's shape, or
            ``protect`` is not a bool array of shape (H, W).
        """
        image = _check_frame(image)
        if protect is not None:
            protect = np.asarray(protect)
            if protect.dtype != np.bool_ or protect.shape != image.shape[:2]:
                raise TrackingError(f"protect must be a bool array of shape {image.shape[:2]}, got shape "
                                    f"{protect.shape} dtype {protect.dtype}")
        full_shape = image.shape[:2]
        image = self._start(image)
        scale = self.config.downscale
        if protect is not None and scale > 1:
            protect = protect[scale // 2::scale, scale // 2::scale][:image.shape[0], :image.shape[1]]
        config = self.config
        sample, brightest = self._sample(image)
        mature = self.frames_seen >= _MATURE_FRAMES
        if config.compensate_gain:
            self.gain = self._estimate_gain(sample, brightest)
            if abs(self.gain - 1.0) > _GAIN_TOLERANCE:
                image = cv2.convertScaleAbs(image, alpha=1.0 / self.gain)
                sample /= np.float32(self.gain)
        relearning = self._relearn_left > 0
        rate = self._rate(relearning)

        protected = np.flatnonzero(protect) if protect is not None else None
        if protected is not None and protected.size:
            background = self._background_image(force=relearning)
            composite = image.copy()
            cv2.copyTo(background, np.ascontiguousarray(protect).view(np.uint8), composite)
            labels = self._subtractor.apply(composite, self._labels, learningRate=rate)
            mask = labels == _MOG2_FOREGROUND
            mask.reshape(-1)[protected] = self._differs(image, background, protected)
        else:
            labels = self._subtractor.apply(image, self._labels, learningRate=rate)
            mask = labels == _MOG2_FOREGROUND
        self.frames_seen += 1
        self._background_age += 1

        self.foreground_fraction = np.count_nonzero(mask) / mask.size
        flooded = mature and self.foreground_fraction > config.max_foreground
        swing = self._gain_swing(mature)
        self.lighting_change = bool(flooded or relearning or swing)
        self._relearn_left = config.relearn_frames if flooded else max(self._relearn_left - 1, 0)
        self._learn_reference(sample, mask, rate, everywhere=relearning or flooded)
        if scale > 1:
            mask = cv2.resize(mask.view(np.uint8), full_shape[::-1], interpolation=cv2.INTER_NEAREST).view(np.bool_)
        return mask

    def warm_up(self, frames: Iterable[np.ndarray]) -> int:
        """Learn the background from frames (typically spread over the video); returns how many.

        With ``median_warm_up`` and at least five frames, the per-pixel median of the
        frames (each divided by its gain) is the first background; where fewer than half
        the frames are within the mixtures' threshold of it, the mean of the largest group
        of frames that agree is taken instead.  The pixels of each frame that differ from
        this background by more than the threshold are replaced by it before the mixtures
        learn the frame: people who walk about in every frame are not learnt.  The masks
        are dropped: while the model is young they mark most changes as foreground.
        This costs about a second for 50 frames of 480 × 360.

        Examples
        --------
        A dark square sits at a different place in each of 20 frames, and in the frame
        that follows:

        >>> rng = np.random.default_rng(0)
        >>> scene = rng.integers(60, 200, (40, 60, 3)).astype(np.uint8)
        >>> def with_square(k):
        ...     frame = scene.copy()
        ...     frame[10:20, 2 * k:2 * k + 10] = 20
        ...     return frame
        >>> model = BackgroundModel()
        >>> model.warm_up(with_square(k) for k in range(20))
        20
        >>> bool(model.apply(with_square(3))[10:20, 6:16].all())
        True
        """
        frames = [self._start(_check_frame(frame)) for frame in frames]
        if not frames:
            return 0
        if not self.config.median_warm_up or len(frames) < _MEDIAN_MIN_FRAMES:
            for frame in frames:
                self._learn(frame)
            return len(frames)
        median = _median(frames)
        if self.config.compensate_gain:
            reference = self._sample(median)[0]
            gains = [self._gain_against(*self._sample(frame), reference, self._channels) for frame in frames]
            if max(abs(g - 1.0) for g in gains) > _GAIN_TOLERANCE:
                # The median of frames under different light is no background: take it again
                # from frames brought to one light.
                frames = [frame if abs(g - 1.0) <= _GAIN_TOLERANCE else cv2.convertScaleAbs(frame, alpha=1.0 / g)
                          for frame, g in zip(frames, gains)]
                median = _median(frames)
        noise = self._noise_variance(frames, median, None)
        threshold = self.config.var_threshold * noise
        background = _mode_background(frames, median, threshold)
        for frame in frames:
            cleaned = frame.copy()
            moved = _squared_distance(frame, background) > threshold
            cv2.copyTo(background, moved.view(np.uint8), cleaned)
            self._learn(cleaned)
        if self._reference is None or self.frames_seen == len(frames):
            self._reference = self._sample(background)[0]
        self._was_foreground = None
        self._mean_gain = None
        return len(frames)

    # -- steps of apply ------------------------------------------------------------------------------
    def _start(self, image: np.ndarray) -> np.ndarray:
        """Check the frame's shape (the first frame fixes it); the frame the mixtures see, maybe smaller."""
        scale = self.config.downscale
        if self._shape is None:
            height, width = image.shape[:2]
            if scale > 1 and (height < scale or width < scale):
                raise TrackingError(f"frames of {width}x{height} pixels cannot be shrunk {scale} times")
            self._shape = image.shape
            self._small = (max(1, height // scale), max(1, width // scale))
            # MOG2 writes its labels into the buffer it is given: no new image per frame.
            self._labels = np.empty(self._small, np.uint8)
            self._step = max(1, int(math.sqrt(self._small[0] * self._small[1] / _GAIN_SAMPLES)))
        elif image.shape != self._shape:
            # MOG2 would reinitialise itself silently on a new size, losing all it has learnt.
            raise TrackingError(f"frame shape {image.shape} differs from the model's {self._shape}")
        if scale > 1:
            # Area averaging: each pixel the mixtures see is the mean of a scale x scale block.
            return cv2.resize(image, self._small[::-1], interpolation=cv2.INTER_AREA)
        return np.ascontiguousarray(image)

    def _learn(self, image: np.ndarray) -> None:
        """Feed one frame to the mixtures, mask dropped (the warm-up)."""
        self._subtractor.apply(image, self._labels, learningRate=self._rate(False))
        self.frames_seen += 1
        self._background_age = _BACKGROUND_REFRESH

    def _rate(self, relearning: bool) -> float:
        """The learning rate of this frame; -1 asks MOG2 for its own schedule."""
        configured = self.config.learning_rate
        if not relearning:
            return -1.0 if configured is None else float(configured)
        schedule = 1.0 / min(self.frames_seen + 1, self.config.history) if configured is None else configured
        return max(float(schedule), 1.0 / self.config.relearn_frames)

    def _sample(self, image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The grid's pixels: their channel sums (h, w) float32, and their brightest channels (h, w)."""
        step = self._step
        grid = image[step // 2::step, step // 2::step]
        if grid.ndim == 2:
            self._channels = 1
            return grid.astype(np.float32), grid
        # Channel by channel: numpy reduces over a short last axis far more slowly.
        blue, green, red = grid[:, :, 0], grid[:, :, 1], grid[:, :, 2]
        total = blue.astype(np.float32)
        total += green
        total += red
        return total, np.maximum(np.maximum(blue, green), red)

    def _estimate_gain(self, sample: np.ndarray, brightest: np.ndarray) -> float:
        """The frame's brightness relative to the background, from the grid pixels that were background."""
        if self._reference is None:
            self._reference = sample.copy()
            return 1.0
        usable = None if self._was_foreground is None else ~self._was_foreground
        return self._gain_against(sample, brightest, self._reference, self._channels, usable, default=self.gain)

    @staticmethod
    def _gain_against(sample: np.ndarray, brightest: np.ndarray, reference: np.ndarray, channels: int,
                      usable: np.ndarray | None = None, default: float = 1.0) -> float:
        """Median ratio of the grid's brightness to the reference's, over trustworthy pixels."""
        fair = (reference > channels * _DARK) & (brightest < _BRIGHT) & (sample > channels * _DARK)
        chosen = fair if usable is None else fair & usable
        # When most of the grid was foreground the previous mask is no guide: all fair pixels vote.
        if np.count_nonzero(chosen) < max(16, np.count_nonzero(fair) // 4):
            chosen = fair
        if np.count_nonzero(chosen) < 16:
            return default
        ratios = sample[chosen] / reference[chosen]
        return _middle(ratios)

    def _gain_swing(self, mature: bool) -> bool:
        """Whether the gain moved fast; updates the running mean of the gains."""
        if self._mean_gain is None or not mature:
            self._mean_gain = self.gain
            return False
        swing = abs(math.log(self.gain / self._mean_gain)) > math.log1p(self.config.gain_change)
        self._mean_gain += _GAIN_SMOOTHING * (self.gain - self._mean_gain)
        return swing

    def _learn_reference(self, sample: np.ndarray, mask: np.ndarray, rate: float, everywhere: bool) -> None:
        """Let the grid's background follow the frame where it is background (everywhere while re-learning)."""
        if self._reference is None:            # without gain compensation nothing has set it yet
            self._reference = sample.copy()
            return
        step = self._step
        foreground = mask[step // 2::step, step // 2::step]
        self._was_foreground = foreground
        rate = 1.0 / min(self.frames_seen, self.config.history) if rate < 0 else rate
        weight = np.where(foreground & (not everywhere), np.float32(0), np.float32(rate))
        self._reference += weight * (sample - self._reference)

    def _background_image(self, force: bool) -> np.ndarray:
        """The mixtures' background image, taken again every few frames."""
        if self._background is None or force or self._background_age >= _BACKGROUND_REFRESH:
            self._background = np.ascontiguousarray(self._subtractor.getBackgroundImage())
            self._background_age = 0
            self._noise = None
        return self._background

    def _differs(self, image: np.ndarray, background: np.ndarray, pixels: np.ndarray) -> np.ndarray:
        """MOG2's test against the background image alone, for the protected pixels (flat indices)."""
        channels = 1 if image.ndim == 2 else 3
        # One flat take per image gives the channels first, (C, n), at a tenth of a row gather's cost.
        flat = pixels * channels + np.arange(channels)[:, None]
        values = image.reshape(-1).take(flat).astype(np.float32)
        means = background.reshape(-1).take(flat).astype(np.float32)
        if self._noise is None:
            # The noise changes slowly: measured again with each new background image.
            self._noise = self._noise_variance([image], background, self._was_foreground)
        threshold = self.config.var_threshold * self._noise
        foreground = ((values - means) ** 2).sum(axis=0) > threshold
        if self.config.detect_shadows:
            # MOG2's shadow: a darker copy of the background, a·μ with τ ≤ a ≤ 1, within the threshold.
            scale = (values * means).sum(axis=0) / np.maximum((means * means).sum(axis=0), 1.0)
            distortion = ((values - scale * means) ** 2).sum(axis=0)
            shadow = (scale >= self._subtractor.getShadowThreshold()) & (scale <= 1.0) \
                & (distortion < threshold * scale * scale)
            foreground &= ~shadow
        return foreground

    def _noise_variance(self, frames: list[np.ndarray], background: np.ndarray,
                        foreground: np.ndarray | None) -> float:
        """Per-channel noise variance of frames about the background, on the grid, in MOG2's bounds."""
        step = self._step
        reference = background[step // 2::step, step // 2::step].astype(np.float32)
        distances = []
        for frame in frames:
            difference = frame[step // 2::step, step // 2::step].astype(np.float32) - reference
            distance = difference * difference if difference.ndim == 2 else _squares(difference)
            distances.append(distance if foreground is None else distance[~foreground])
        distances = np.concatenate([d.reshape(-1) for d in distances])
        variance = _middle(distances) / _CHI2_MEDIAN[self._channels] if distances.size else 0.0
        return float(np.clip(variance, self._subtractor.getVarMin(), self._subtractor.getVarMax()))


def _middle(values: np.ndarray) -> float:
    """The (upper) median of a non-empty array: a partition, several times faster than np.median here."""
    values = values.reshape(-1)
    middle = values.size // 2
    return float(np.partition(values, middle)[middle])


def _median(frames: list[np.ndarray]) -> np.ndarray:
    """Per-pixel (lower) median of frames of one shape, as uint8, a band of rows at a time."""
    median = np.empty_like(frames[0])
    middle = (len(frames) - 1) // 2
    band = max(1, (1 << 22) // max(1, frames[0][0].size * len(frames)))   # about 4 MB of pixels at a time
    for top in range(0, median.shape[0], band):
        stack = np.stack([frame[top:top + band] for frame in frames])
        median[top:top + band] = np.partition(stack, middle, axis=0)[middle]
    return median


def _mode_background(frames: list[np.ndarray], median: np.ndarray, threshold: float) -> np.ndarray:
    """The colour most frames agree on at each pixel, where the median is not one that half of them share.

    Where people cover a pixel in more than half the frames (two people crossing, one after
    the other), the per-channel median is a person's colour or a mix.  There the
    background is the mean of the largest group of frames within ``threshold`` (a squared
    colour distance) of one of them: the background is seen in the most frames even when
    that is less than half of them.
    """
    count = len(frames)
    agree = np.zeros(median.shape[:2], np.int32)
    for frame in frames:
        agree += _squared_distance(frame, median) <= threshold
    doubtful = np.flatnonzero(2 * agree < count)
    background = median.copy()
    if doubtful.size == 0:
        return background
    channels = 1 if median.ndim == 2 else median.shape[2]
    flat = background.reshape(-1, channels)
    agree = agree.reshape(-1)[doubtful]
    stack = np.stack([frame.reshape(-1, channels)[doubtful] for frame in frames]).astype(np.int32)
    # The colours of up to 50 frames spread over the warm-up are the candidates, each
    # against every frame, a chunk of pixels at a time (about 4 M distances).
    candidates = np.unique(np.linspace(0, count - 1, min(count, _MODE_CANDIDATES)).round().astype(np.intp))
    chunk = max(1, (1 << 22) // (count * candidates.size))
    for start in range(0, doubtful.size, chunk):
        values = stack[:, start:start + chunk]                       # (frames, pixels, C)
        close = _squares(values[candidates, None] - values[None, :]) <= threshold
        support = close.sum(axis=1)                                  # (candidates, pixels)
        best = support.argmax(axis=0)
        columns = np.arange(values.shape[1])
        better = support[best, columns] > agree[start:start + chunk]
        members = close[best, :, columns].T                          # (frames, pixels)
        mean = (values * members[:, :, None]).sum(axis=0) / members.sum(axis=0)[:, None]
        flat[doubtful[start:start + chunk][better]] = np.rint(mean[better]).astype(np.uint8)
    return background


def _squared_distance(frame: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Squared colour distance of every pixel of a uint8 frame to a uint8 reference, (H, W) float32."""
    difference = cv2.absdiff(frame, reference)
    squares = cv2.multiply(difference, difference, dtype=cv2.CV_32F)
    if squares.ndim == 2:
        return squares
    # A 1 x 3 transform sums the channels in one pass.
    return cv2.transform(squares, np.ones((1, 3), np.float32))


def _squares(difference: np.ndarray) -> np.ndarray:
    """Sum of squares over the last axis (the channels)."""
    # Channel by channel: numpy reduces over a short last axis far more slowly.
    total = difference[..., 0] * difference[..., 0]
    for channel in range(1, difference.shape[-1]):
        total += difference[..., channel] * difference[..., channel]
    return total
