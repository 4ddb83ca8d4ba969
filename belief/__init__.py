"""belief: fusing uncertain, conflicting evidence with belief functions (DST and DSmT).

The core objects:

* :class:`Frame`: named hypotheses; :class:`Element`: a member of the hyper-power set D^Θ;
* :class:`Model`: free DSm, Shafer, hybrid or tracking constraints;
* :func:`hyper_power_set`: D^Θ enumerated (n ≤ 6 on the free model);
* :class:`MassFunction`: one mass function; :class:`MassBatch`: N of them as an (N, K) array;
* :func:`combine`: the rules of :data:`RULES`, with closed forms for Bayesian sources
  (:class:`ClosedFormBatch`, :func:`exclusive_split`) and :func:`inconsistency`, R of W (10);
  :func:`get_rule` looks a rule up, :data:`R_MODES` and :data:`EMPTY_MODES` are the options of the
  R-weighted rule;
* :func:`decide`, :func:`distance` and :func:`conflict`: decisions, distances between sources and their
  conflict (the uncertainty measures are in the module :mod:`belief.uncertainty`, which that name keeps).

>>> from belief import Frame, MassFunction
>>> m = MassFunction({"a": 0.6, "a|b": 0.4}, frame=["a", "b"])
>>> m.bel("a"), m.pls("a")
(0.6, 1.0)
"""

from belief.batch import MassBatch
from belief.bayesian import ClosedFormBatch, exclusive_split
from belief.errors import (
    BeliefError,
    CombinationTooLargeError,
    FormatError,
    FrameError,
    InvalidMassError,
    LatticeTooLargeError,
    MeasureOptionError,
    ModelError,
    OutputPathError,
    ParseError,
    ResourceLimitError,
    TotalConflictError,
    UndefinedMeasureError,
    UndefinedTransformError,
    UnknownHypothesisError,
    UnknownMeasureError,
)
from belief.frame import Element, Frame
from belief.lattice import HyperPowerSet, hyper_power_set
from belief.mass import MassFunction
from belief.model import Model
from belief.rules import (EMPTY_MODES, ENGINES, R_MODES, RULES, UnknownRuleError, combine, get_rule, inconsistency,
                          sequential)
from belief import extra_rules, representations  # importing extra_rules registers its rules in RULES

__version__ = "0.1.0"

#: The everyday functions of other modules, imported on first use so that ``import belief`` stays quick.
_LAZY = {"decide": "belief.decisions", "distance": "belief.distances", "conflict": "belief.distances"}


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'belief' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))

__all__ = [
    "BeliefError",
    "ClosedFormBatch",
    "CombinationTooLargeError",
    "EMPTY_MODES",
    "ENGINES",
    "Element",
    "FormatError",
    "Frame",
    "FrameError",
    "HyperPowerSet",
    "InvalidMassError",
    "LatticeTooLargeError",
    "MeasureOptionError",
    "OutputPathError",
    "UndefinedMeasureError",
    "UnknownMeasureError",
    "MassBatch",
    "MassFunction",
    "Model",
    "ModelError",
    "ParseError",
    "ResourceLimitError",
    "TotalConflictError",
    "UndefinedTransformError",
    "UnknownHypothesisError",
    "UnknownRuleError",
    "RULES",
    "R_MODES",
    "combine",
    "decide",
    "distance",
    "conflict",
    "exclusive_split",
    "get_rule",
    "inconsistency",
    "sequential",
    "hyper_power_set",
    "extra_rules",
    "representations",
    "__version__",
]
