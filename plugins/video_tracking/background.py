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
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import cv2
import numpy as np

from plugins.video_tracking.errors import TrackingError

__all__ = ["BackgroundConfig", "BackgroundModel"]

#: The value MOG2 gives foreground pixels; shadows get a lower one (127) and background 0.
_MOG2_FOREGROUND = 255


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
    """

    history: int = 100
    var_threshold: float = 16.0
    mixtures: int = 3
    background_ratio: float = 0.7
    detect_shadows: bool = True
    learning_rate: float | None = None

    def __post_init__(self) -> None:
        for name in ("history", "mixtures"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise TrackingError(f"BackgroundConfig.{name} must be a positive integer, got {value!r}")
        if not _is_number(self.var_threshold) or not self.var_threshold > 0:
            raise TrackingError(f"BackgroundConfig.var_threshold must be a positive number, got {self.var_threshold!r}")
        if not _is_number(self.background_ratio) or not 0 < self.background_ratio <= 1:
            raise TrackingError(f"BackgroundConfig.background_ratio must lie in (0, 1], got {self.background_ratio!r}")
        if not isinstance(self.detect_shadows, (bool, np.bool_)):
            raise TrackingError(f"BackgroundConfig.detect_shadows must be True or False, got {self.detect_shadows!r}")
        if self.learning_rate is not None and (not _is_number(self.learning_rate) or not 0 <= self.learning_rate <= 1):
            raise TrackingError(f"BackgroundConfig.learning_rate must be None or lie in [0, 1], got {self.learning_rate!r}")


def _is_number(value) -> bool:
    return not isinstance(value, bool) and isinstance(value, (int, float, np.integer, np.floating)) and math.isfinite(value)


class BackgroundModel:
    """A learning background model that gives the foreground mask of every frame.

    Parameters
    ----------
    config : BackgroundConfig

    Attributes
    ----------
    frames_seen : int
        Frames learnt so far.

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
        self._labels: np.ndarray | None = None             # MOG2's per-frame output, reused
        self.frames_seen = 0

    def __repr__(self) -> str:
        return f"BackgroundModel({self.config!r}, frames_seen={self.frames_seen})"

    def apply(self, image: np.ndarray) -> np.ndarray:
        """Classify the pixels of one frame, then learn from it.

        Parameters
        ----------
        image : ndarray of uint8, shape (H, W, 3) or (H, W)
            A BGR or grey frame, of the same shape as every earlier frame.

        Returns
        -------
        ndarray of bool, shape (H, W)
            True where the pixel is foreground (ξ of L (16)); shadows are background.
        """
        image = np.asarray(image)
        if image.dtype != np.uint8 or image.ndim not in (2, 3) or (image.ndim == 3 and image.shape[2] != 3) \
                or 0 in image.shape:
            raise TrackingError(f"frames must be (H, W, 3) or (H, W) uint8 arrays, got shape {image.shape} "
                                f"dtype {image.dtype}")
        if self._shape is None:
            self._shape = image.shape
            self._labels = np.empty(image.shape[:2], np.uint8)
        elif image.shape != self._shape:
            # MOG2 would reinitialise itself silently on a new size, losing all it has learnt.
            raise TrackingError(f"frame shape {image.shape} differs from the model's {self._shape}")
        rate = -1.0 if self.config.learning_rate is None else float(self.config.learning_rate)
        # MOG2 writes its labels into the buffer it is given: no new image per frame.
        labels = self._subtractor.apply(np.ascontiguousarray(image), self._labels, learningRate=rate)
        self.frames_seen += 1
        return labels == _MOG2_FOREGROUND

    def warm_up(self, frames: Iterable[np.ndarray]) -> int:
        """Learn the background from frames (typically the first ones of the video); returns how many.

        The masks are dropped: while the model is young they mark most changes as foreground.
        """
        count = 0
        for frame in frames:
            self.apply(frame)
            count += 1
        return count
