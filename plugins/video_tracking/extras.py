"""The optional packages the plugin needs, with one line saying how to install them.

``pip install belief-dsmt`` gives the fusion library alone (numpy and networkx); the tracking
plugin's own dependencies come with the ``tracking`` extra.  A module that needs one of
them imports it through :func:`require`, so that a missing package names the extra to
install instead of ending in a bare ``No module named 'cv2'``.

Before OpenCV is first imported here, FFmpeg's log level (read by OpenCV from
``OPENCV_FFMPEG_LOGLEVEL`` when its video backend starts) is set to quiet, unless the
environment already sets it: a truncated or corrupt video would otherwise print a line of
decoder noise per bad frame on standard error, where the reader's own one-line message
says what happened (:class:`~belief_tracking.video.VideoReader`).  Set
``OPENCV_FFMPEG_LOGLEVEL=24`` (warnings) to see FFmpeg's messages again.
"""

from __future__ import annotations

import importlib
import os
from types import ModuleType

from belief.install import install_command

from .errors import MissingExtraError

__all__ = ["require", "EXTRA", "INSTALL"]

#: The extra that brings the plugin's dependencies.
EXTRA = "tracking"
#: The command that installs it.
INSTALL = install_command(EXTRA)

#: The import name of each optional package, and the distribution pip installs.
PACKAGES = {"cv2": "opencv-python-headless", "motmetrics": "motmetrics", "matplotlib": "matplotlib", "tqdm": "tqdm",
            "tomli": "tomli"}

#: FFmpeg's quiet log level (AV_LOG_QUIET), given to OpenCV through ``OPENCV_FFMPEG_LOGLEVEL``.
#: OpenCV's own ``cv2.utils.logging.setLogLevel`` and ``OPENCV_LOG_LEVEL`` do not reach
#: FFmpeg's decoder messages; this variable does, if it is set before the first video is
#: opened or written in the process.
FFMPEG_QUIET = "-8"


def require(name: str) -> ModuleType:
    """Import the optional package ``name``, or raise :class:`MissingExtraError` naming the extra.

    The error is a ``ModuleNotFoundError`` and a :class:`belief.errors.BeliefError`, so the
    ``belief`` command prints it as one line.

    Examples
    --------
    >>> require("numpy").__name__
    'numpy'
    """
    if name == "cv2":
        os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", FFMPEG_QUIET)
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as exc:
        if exc.name != name.split(".")[0]:
            raise
        package = PACKAGES.get(name, name)
        raise MissingExtraError(f"video tracking needs {package}, which is not installed: {INSTALL}",
                                name=exc.name) from None
