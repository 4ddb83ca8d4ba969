"""How belief is installed: its name on the package index and the command that adds an extra.

The import name is ``belief``; the distribution is published as :data:`DISTRIBUTION`, since
``belief`` on the package index is an unrelated project. Every hint that names an install
command is made here, so that none can name a package pip would not find.

>>> install_command("plot")
"pip install 'belief-dsmt[plot]'"
"""

from __future__ import annotations

__all__ = ["DISTRIBUTION", "EXTRAS", "install_command"]

#: The distribution name (``pip install belief-dsmt``); the package imports as ``belief``.
DISTRIBUTION = "belief-dsmt"

#: The optional extras of the distribution, as pyproject.toml declares them.
EXTRAS = ("tracking", "plot", "testing", "test", "docs", "dask", "bench")


def install_command(extra: str) -> str:
    """The pip command that installs ``extra`` of :data:`DISTRIBUTION`.

    Raises
    ------
    ValueError
        For a name that is not one of :data:`EXTRAS` (the message lists them).
    """
    if extra not in EXTRAS:
        raise ValueError(f"{DISTRIBUTION} has no extra {extra!r}; its extras: {', '.join(EXTRAS)}")
    return f"pip install '{DISTRIBUTION}[{extra}]'"
