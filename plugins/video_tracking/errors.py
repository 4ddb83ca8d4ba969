"""Exceptions of the video-tracking plugin.

They belong to the :class:`belief.errors.BeliefError` family, so the ``belief`` command
line turns them into one-line messages, and also derive from ``ValueError`` so that
generic ``except ValueError`` code keeps working.
"""

from __future__ import annotations

from belief.errors import BeliefError, OutputPathError

__all__ = ["TrackingError", "TrackFileError", "DetectionFileError", "UnknownCueError", "VideoError", "InitError",
           "MissingExtraError", "OutputFolderError"]


class TrackingError(BeliefError, ValueError):
    """Bad input to the tracking plugin (malformed boxes, tracks or settings)."""


class TrackFileError(TrackingError):
    """A track or ground-truth file is missing, unreadable, empty or malformed."""


class DetectionFileError(TrackFileError):
    """A detection file is missing, unreadable, empty or malformed, or does not fit the video."""


class UnknownCueError(TrackingError):
    """A cue name that the cue registry does not know; the message lists the known names."""


class VideoError(TrackingError):
    """A video is missing, cannot be opened or decoded, or cannot be written."""


class InitError(TrackingError):
    """Target initialisation is unusable: an empty or malformed init file, or a box outside the image."""


class MissingExtraError(BeliefError, ModuleNotFoundError):
    """A package of the plugin's ``tracking`` extra is not installed; the message says how to install it."""


class OutputFolderError(TrackingError, OutputPathError):
    """``--out`` cannot take the run's files: it holds an input or files no run wrote there, or it cannot be written."""
