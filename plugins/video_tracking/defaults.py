"""Defaults that the command line, experiments and the Python runner share, in a module light enough for ``--help``."""

__all__ = ["AUTOMATIC_WARM_UP"]

#: Frames the background model learns from before an automatic run (``belief track --warm-up``), where none is set.
AUTOMATIC_WARM_UP = 50
