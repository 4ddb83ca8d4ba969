"""A frame's candidate boxes: where a person may be, from a detector or from the foreground.

With a detector the candidates are its boxes and scores.  Without one they are the person
boxes of the foreground mask (:func:`~belief_tracking.blobs.person_boxes`): blobs
merged, cut and split with a :class:`~belief_tracking.perspective.PersonSize` that
:class:`BlobCandidates` fits on the blobs of the first frames and refits as more come in,
so that the size model adapts to the video without a calibration step.
"""

from __future__ import annotations

import numpy as np

from .blobs import person_boxes
from .initiation import InitiationConfig
from .perspective import PersonSize

__all__ = ["BlobCandidates", "BLOB_SCORE"]

#: The score of a foreground candidate: a blob is weaker evidence of a person than a detection.
BLOB_SCORE = 0.5


class BlobCandidates:
    """Person boxes from the foreground masks, with a person-size model learnt along the way.

    Parameters
    ----------
    config : InitiationConfig
        ``min_area`` and ``opening`` of the blobs.
    image_shape : (int, int)
        (H, W) of the frames.
    fit_every : int
        The size model is refitted on the blobs seen so far every this many frames ...
    fit_until : int
        ... until this many frames have been seen; then it is kept.

    Attributes
    ----------
    size : PersonSize or None
        The current size model (None until the blobs support one).

    Examples
    --------
    A person 10 × 30 px walks right over an empty 60 × 100 image:

    >>> finder = BlobCandidates(InitiationConfig(min_area=0.01), (60, 100), fit_every=2)
    >>> for x in range(5, 45, 5):
    ...     mask = np.zeros((60, 100), bool)
    ...     mask[20:50, x:x + 10] = True
    ...     boxes = finder(mask)
    >>> boxes.tolist(), finder.size
    ([[40.0, 20.0, 10.0, 30.0, 0.5]], PersonSize(a=0.0, b=30.0, aspect=0.3333333333333333))
    """

    def __init__(self, config: InitiationConfig, image_shape: tuple[int, int], fit_every: int = 10,
                 fit_until: int = 50) -> None:
        self.config = config
        self.image_shape = (int(image_shape[0]), int(image_shape[1]))
        self.min_area_pixels = config.min_area_pixels(self.image_shape)
        self.fit_every = fit_every
        self.fit_until = fit_until
        self.size: PersonSize | None = None
        self._frames = 0
        self._seen: list[np.ndarray] = []

    def __call__(self, mask: np.ndarray) -> np.ndarray:
        """The candidates ``x, y, w, h, score`` of one foreground mask, shape (n, 5)."""
        if self._frames < self.fit_until:
            self._seen.append(person_boxes(mask, None, min_area_pixels=self.min_area_pixels,
                                           opening=self.config.opening))
            self._frames += 1
            if self._frames % self.fit_every == 0:
                fitted = PersonSize.fit(np.concatenate(self._seen), self.image_shape)
                self.size = fitted if fitted is not None else self.size
            if self._frames == self.fit_until:
                self._seen.clear()
        boxes = person_boxes(mask, self.size, min_area_pixels=self.min_area_pixels, opening=self.config.opening)
        return np.column_stack([boxes, np.full(len(boxes), BLOB_SCORE)])
