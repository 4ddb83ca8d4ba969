"""The cue interface, and the checks its settings share.

A cue is a function of one frame's :class:`~belief_tracking.cues.observation.Observation`
and the particles of every track: it holds only its settings, never a track's state.  An
appearance cue also builds the templates that the tracks keep (one per track and cue, in
:class:`~belief_tracking.store.Track`) and the histograms the template update reads.
"""

from __future__ import annotations

import math
from typing import Protocol, runtime_checkable

import numpy as np

from ..errors import TrackingError
from .observation import Observation

__all__ = ["Cue", "AppearanceCue", "ConfiguredCue", "positive_setting", "count_setting", "samples_setting", "log_gaussian"]


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
    """A cue that compares windows with per-track appearance templates (histograms of B bins)."""

    def build_templates(self, image: np.ndarray, boxes, foreground: np.ndarray | None = None) -> np.ndarray:
        """The templates of ``boxes`` (n, 4) ``x, y, w, h`` in ``image``, shape (n, B), rows summing to 1."""
        ...

    def histograms(self, obs: Observation, states: np.ndarray, owner: np.ndarray) -> np.ndarray:
        """The histograms of the windows of P particles, shape (P, B), as the templates are built."""
        ...


class ConfiguredCue:
    """What every cue shares: its frozen settings of type ``config_type``, checked once, and its repr.

    >>> from belief_tracking.cues import LocationCue
    >>> LocationCue("sigma=3")
    Traceback (most recent call last):
    ...
    belief_tracking.errors.TrackingError: LocationCue needs a LocationConfig, got str
    """

    config_type: type

    def __init__(self, config=None) -> None:
        if config is None:
            config = self.config_type()
        if not isinstance(config, self.config_type):
            wanted = self.config_type.__name__
            raise TrackingError(f"{type(self).__name__} needs {'an' if wanted[0] in 'AEIOU' else 'a'} {wanted}, "
                                f"got {type(config).__name__}")
        self.config = config

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.config!r})"


def positive_setting(owner: str, name: str, value) -> float:
    """``value`` as a positive finite float, or an error naming ``owner.name``."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TrackingError(f"{owner}.{name} must be a positive number, got {value!r}")
    if not math.isfinite(value) or value <= 0:
        raise TrackingError(f"{owner}.{name} must be a positive finite number, got {value!r}")
    return float(value)


def count_setting(owner: str, name: str, value) -> int:
    """``value`` as a positive int, or an error naming ``owner.name``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise TrackingError(f"{owner}.{name} must be a positive integer, got {value!r}")
    return int(value)


def samples_setting(owner: str, value) -> tuple[int, int]:
    """A pair (across, down) of positive sample counts, or an error naming ``owner.samples``."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
        raise TrackingError(f"{owner}.samples must be a pair (across, down), got {value!r}")
    return tuple(count_setting(owner, "samples", n) for n in value)


def log_gaussian(squared_distance: np.ndarray, sigma: float) -> np.ndarray:
    """log G(d; σ) = −d² / (2σ²) from d², without the constant that cancels in W (20)–(21).

    >>> log_gaussian(np.array([0.0, 4.0]), 2.0).tolist()
    [0.0, -0.5]
    """
    # 0 − d² rather than −d², so that d = 0 gives +0.0 (−0.0 would print as "-0.").
    return (0.0 - squared_distance) / (2.0 * sigma ** 2)
