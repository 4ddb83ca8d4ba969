"""The optional packages the plugin needs, with one line saying how to install them.

``pip install belief`` gives the fusion library alone (numpy and networkx); the tracking
plugin's own dependencies come with the ``tracking`` extra.  A module that needs one of
them imports it through :func:`require`, so that a missing package names the extra to
install instead of ending in a bare ``No module named 'cv2'``.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from belief_tracking.errors import MissingExtraError

__all__ = ["require", "EXTRA", "INSTALL"]

#: The extra that brings the plugin's dependencies.
EXTRA = "tracking"
#: The command that installs it.
INSTALL = f"pip install 'belief[{EXTRA}]'"

#: The import name of each optional package, and the distribution pip installs.
PACKAGES = {"cv2": "opencv-python-headless", "motmetrics": "motmetrics", "matplotlib": "matplotlib", "tqdm": "tqdm",
            "tomli": "tomli"}


def require(name: str) -> ModuleType:
    """Import the optional package ``name``, or raise :class:`MissingExtraError` naming the extra.

    The error is a ``ModuleNotFoundError`` and a :class:`belief.errors.BeliefError`, so the
    ``belief`` command prints it as one line.

    Examples
    --------
    >>> require("numpy").__name__
    'numpy'
    """
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as exc:
        if exc.name != name.split(".")[0]:
            raise
        package = PACKAGES.get(name, name)
        raise MissingExtraError(f"video tracking needs {package}, which is not installed: {INSTALL}",
                                name=exc.name) from None
