"""Exception hierarchy of :mod:`belief`.

Every error that bad input can cause derives from :class:`BeliefError`, so a caller
(or the command line) can catch the whole family at once.  The concrete classes also
derive from the closest built-in exception (``ValueError``, ``KeyError``-like cases are
``ValueError`` here) so that generic ``except ValueError`` code keeps working.
"""

from __future__ import annotations

__all__ = [
    "BeliefError",
    "FrameError",
    "UnknownHypothesisError",
    "ParseError",
    "ModelError",
    "InvalidMassError",
    "ResourceLimitError",
    "LatticeTooLargeError",
    "CombinationTooLargeError",
    "TotalConflictError",
    "FormatError",
    "UndefinedTransformError",
    "MeasureOptionError",
    "UnknownMeasureError",
    "UndefinedMeasureError",
    "OutputPathError",
]


class BeliefError(Exception):
    """Base class of every error raised by :mod:`belief` on bad input."""


class FrameError(BeliefError, ValueError):
    """A frame of discernment is malformed, or two objects use different frames."""


class UnknownHypothesisError(FrameError):
    """A proposition names a hypothesis that the frame does not have."""


class ParseError(BeliefError, ValueError):
    """A proposition string is not well formed."""


class ModelError(BeliefError, ValueError):
    """A constraint model is malformed, or does not fit the operation asked for."""


class InvalidMassError(BeliefError, ValueError):
    """Masses are not finite, negative, do not sum to one, or sit on an empty element."""


class ResourceLimitError(BeliefError, ValueError):
    """A job would take more time or memory than a configurable limit allows; the message names the limit.

    Attributes
    ----------
    limit : str or None
        The full name of the limit exceeded, e.g. ``"belief.batch.MAX_TABLE_ENTRIES"``.
    """

    def __init__(self, message: str, limit: str | None = None) -> None:
        super().__init__(message)
        self.limit = limit


class LatticeTooLargeError(ResourceLimitError):
    """Enumerating the hyper-power set (or a graph of it) would not fit in memory or time."""


class CombinationTooLargeError(ResourceLimitError, InvalidMassError):
    """A combination would visit too many tuples of focal elements, or need too much time or memory.

    The message names the limit of :mod:`belief.plan` that the job exceeds (``MAX_TUPLES``,
    ``MAX_WORK``, ``MAX_BYTES`` or ``MAX_ELEMENT_TUPLES``) and its estimate of the job.  It is
    also an :class:`InvalidMassError`, which such refusals used to be, so that code catching
    that keeps working.

    Attributes
    ----------
    limit : str or None
        The full name of the limit exceeded, e.g. ``"belief.plan.MAX_TUPLES"``.
    """


class TotalConflictError(BeliefError, ArithmeticError):
    """A normalisation divides by a total conflict of one (all mass on the empty set)."""


class FormatError(BeliefError, ValueError):
    """A serialised mass function or model (JSON) is malformed."""


class UndefinedTransformError(BeliefError, ArithmeticError):
    """A transformation is undefined for this input (e.g. DSmP with ε = 0 and no singleton mass)."""


class MeasureOptionError(BeliefError, ValueError):
    """An option of a decision, distance or uncertainty measure is not acceptable (e.g. a negative tolerance)."""


class UnknownMeasureError(MeasureOptionError):
    """A decision criterion, distance or uncertainty measure that is not known; the message lists the known ones."""


class UndefinedMeasureError(UndefinedTransformError):
    """A measure is undefined for this input: a model it is not defined on, or mass on ∅ where it allows none."""


class OutputPathError(BeliefError, ValueError):
    """An output cannot be written where it was asked: a missing or unwritable folder, a name too long, a folder
    in the way, or a folder that holds the command's inputs or files it did not write."""
