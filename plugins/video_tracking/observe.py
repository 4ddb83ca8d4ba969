"""Reading one frame: the input gate, the foreground mask and the candidate boxes.

:class:`FrameObserver` is the first stage of a frame.  It checks the frame at the boundary
(the first one fixes the image size of the run), runs the background model when a cue or
the automatic initiation needs its foreground, and gives the frame's *candidates*, the boxes
where a person may be: a detector's boxes, else the person blobs of the foreground
(:class:`~belief_tracking.candidates.BlobCandidates`).  Its result, a :class:`FrameView`,
is what every later stage reads of the frame.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .background import BackgroundModel
from .blobs import box_mask
from .candidates import BlobCandidates
from .config import TrackerConfig
from .detections import check_rows
from .errors import TrackingError

__all__ = ["FrameView", "FrameObserver"]


@dataclass(frozen=True, eq=False)
class FrameView:
    """One frame as the tracker sees it.

    Attributes
    ----------
    number : int
        1-based frame number.
    image : ndarray of uint8, shape (H, W, 3)
        The BGR frame.
    foreground : ndarray of bool, shape (H, W), or None
        The background model's mask, when something reads it.
    candidates : ndarray, shape (n, 5), or None
        ``x, y, w, h, score`` of the boxes where a person may be (None: the run has no
        detector and no automatic initiation).
    detector : bool
        Whether the candidates come from a detector (else from the foreground).
    births_allowed : bool
        False when this frame's candidates must not start tracks (a lighting change).
    """

    number: int
    image: np.ndarray
    foreground: np.ndarray | None
    candidates: np.ndarray | None
    detector: bool = False
    births_allowed: bool = True


class FrameObserver:
    """The frame gate, the foreground and the candidates of each frame.

    Parameters
    ----------
    config : TrackerConfig
    background : BackgroundModel or None
        The run's background model (None when no cue and no initiation needs one).

    Attributes
    ----------
    image_shape : (int, int) or None
        (H, W) of the run's frames, fixed by the first frame.

    Examples
    --------
    >>> observer = FrameObserver(TrackerConfig(), None)
    >>> view = observer(1, np.zeros((4, 6, 3), np.uint8), np.array([[1, 1, 2, 2, 0.9]]), [])
    >>> view.candidates.tolist(), view.detector, observer.image_shape
    ([[1.0, 1.0, 2.0, 2.0, 0.9]], True, (4, 6))
    >>> observer(2, np.zeros((5, 6, 3), np.uint8), None, [])
    Traceback (most recent call last):
    ...
    belief_tracking.errors.TrackingError: frame 2 has size (5, 6), the first had (4, 6)
    """

    def __init__(self, config: TrackerConfig, background: BackgroundModel | None) -> None:
        self.config = config
        self.background = background
        self.image_shape: tuple[int, int] | None = None
        self._automatic = config.initiation is not None
        self._blobs: BlobCandidates | None = None

    def __call__(self, frame: int, image: np.ndarray, detections: np.ndarray | None,
                 track_boxes: Sequence[tuple[float, float, float, float]]) -> FrameView:
        """The :class:`FrameView` of 1-based ``frame``; ``track_boxes`` are the live tracks' boxes at t − 1."""
        image = self._admit(frame, image)
        detector = detections is not None
        if detector:
            detections = check_rows(detections, f"frame {frame}")
        foreground = None
        # With a detector the candidates come from it: the mask is needed only by a cue.
        if self.background is not None and ("foreground" in self.config.cues or not detector):
            # Automatic tracks keep their people in the foreground: a person who stands still
            # must not be learnt into the background under their own track.
            protect = box_mask(image.shape, list(track_boxes)) if self._automatic and len(track_boxes) else None
            foreground = self.background.apply(image, protect)
        births_allowed = not getattr(self.background, "lighting_change", False)
        return FrameView(frame, image, foreground, self._candidates(detections, foreground), detector, births_allowed)

    def _admit(self, frame: int, image: np.ndarray) -> np.ndarray:
        """Check a frame at the boundary; the first one fixes the image size of the run."""
        image = np.asarray(image)
        if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8 or 0 in image.shape:
            raise TrackingError(f"frame {frame}: frames must be (H, W, 3) uint8 arrays, got shape {image.shape} "
                                f"dtype {image.dtype}")
        if self.image_shape is None:
            self.image_shape = image.shape[:2]
        elif image.shape[:2] != self.image_shape:
            raise TrackingError(f"frame {frame} has size {image.shape[:2]}, the first had {self.image_shape}")
        return image

    def _candidates(self, detections: np.ndarray | None, foreground: np.ndarray | None) -> np.ndarray | None:
        """The frame's candidate boxes ``x, y, w, h, score``: the detections, else the foreground's person blobs."""
        if detections is not None:
            return detections
        if not self._automatic or foreground is None:
            return None
        if self._blobs is None:
            self._blobs = BlobCandidates(self.config.initiation, foreground.shape)
        return self._blobs(foreground)
