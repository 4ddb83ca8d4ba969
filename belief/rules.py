"""Combination rules: a registry of plain functions over batches, and :func:`combine`.

Every rule takes a list of s ≥ 2 :class:`~belief.batch.MassBatch` sources (one row per
mass function, all with the same number of rows or a single row to broadcast) and the
fusion model, and returns a :class:`~belief.batch.MassBatch`.  :func:`combine` is the
entry point for single mass functions and batches alike::

    combine(m1, m2, m3, rule="pcr6")

Associative rules (conjunctive, DSmC, Dempster, disjunctive, Yager's conjunctive core) are
evaluated by folding pairwise; the non-associative ones (Dubois–Prade, DSmH, PCR5, PCR6)
are evaluated jointly over all tuples of focal elements, as their s-source definitions
require; the R-weighted rule is folded in the given source order, as SPEC A.4 defines it.
:func:`sequential` folds any rule pairwise on request.

Dynamic fusion: sources carry the model they were elicited under; ``model=`` may name a
stricter model for the fusion (see :meth:`belief.model.Model.is_refined_by`).

This module looks rules up and combines with them.  The table of rules is
:mod:`belief.rules_registry`; the built-in rules are :mod:`belief.rules_classic`,
:mod:`belief.rules_pcr` and :mod:`belief.rules_r`, on the machinery of :mod:`belief.rules_tuples`
(tuples of focal elements), :mod:`belief.rules_single` (single mass functions of unions of
hypotheses) and :mod:`belief.rules_common` (the sources read as batches, the results rescaled).
The rules, their constants and :func:`inconsistency` can be imported from here as well.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Union

import belief.bayesian as bayesian
import belief.dask_batches as dask_batches
from belief.batch import MassBatch
from belief.bayesian import ENGINES
from belief.errors import BeliefError, InvalidMassError
from belief.mass import MassFunction
from belief.model import Model
# The built-in rules register themselves when their modules are first imported, which is here, in this order:
# the order of RULES, which ``belief rules`` lists and the message of UnknownRuleError repeats.  Their public
# names (and those of the machinery, below) are imported to be importable from belief.rules, as they were
# before the rules had modules of their own.
from belief.rules_classic import WIDE_SCALE, conjunctive, dempster, disjunctive, dsmc, dsmh, dubois_prade, yager
from belief.rules_pcr import pcr5, pcr6
from belief.rules_r import EMPTY_MODES, R_MODES, check_r_options, inconsistency, r_rule
from belief.rules_common import RESULT_TOLERANCE, Source, prepare_sources, renormalised
from belief.rules_registry import ALIASES, RULES, RuleFunction, RuleInfo, register_rule
from belief.singletons import SINGLETON_RULES, combine_singletons, singleton_sources
from belief.rules_single import (PCR_LOOP_TUPLES, SINGLE_CACHE_SIZE, SINGLE_LOOP_TUPLES, combine_again,
                                 combine_single)
from belief.rules_tuples import LOOP_TUPLES, SMALL_PAIR, WIDE_LOOP_TUPLES

__all__ = ["combine", "sequential", "inconsistency", "RULES", "RuleInfo", "get_rule", "register_rule",
           "unregister_rule", "rule_names", "UnknownRuleError", "ENGINES", "R_MODES", "EMPTY_MODES"]


class UnknownRuleError(BeliefError, KeyError):
    """A rule name that the registry does not know."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0])


def unregister_rule(name: str) -> RuleInfo:
    """Remove a registered rule and its aliases from the registry; returns its :class:`RuleInfo`.

    For rules registered for a while, as a test registers a toy rule and removes it again.

    >>> @register_rule("toy", summary="a toy rule", associative=False, aliases=("toy-rule",))
    ... def toy(sources, model):
    ...     return sources[0]
    >>> unregister_rule("toy-rule").name
    'toy'
    >>> "toy" in RULES, get_rule("conjunctive").name
    (False, 'conjunctive')
    """
    info = get_rule(name)
    del RULES[info.name]
    for key in [k for k, target in ALIASES.items() if target == info.name]:
        del ALIASES[key]
    return info


def rule_names() -> list[str]:
    """The registered rule names (without aliases), in registration order."""
    return list(RULES)


def get_rule(name: Union[str, RuleInfo]) -> RuleInfo:
    """Look a rule up by name or alias (case-insensitive); unknown names list the known ones."""
    if isinstance(name, RuleInfo):
        return name
    if not isinstance(name, str):
        raise TypeError(f"rule must be a name, got {type(name).__name__}")
    key = ALIASES.get(name.lower().replace("-", "_"))
    if key is None:
        raise UnknownRuleError(f"unknown rule {name!r}; known rules: {', '.join(RULES)}")
    return RULES[key]


# -- entry points ---------------------------------------------------------------------------------
def combine(*sources: Source, rule: Union[str, RuleInfo] = "dempster", model: Model | None = None,
            engine: str = "auto", **options: Any) -> Source:
    """Combine two or more sources of evidence with a rule of the registry.

    Parameters
    ----------
    *sources : MassFunction or MassBatch
        At least two, under one frame and model.  Batches must have the same number of
        rows N (a one-row batch or a single mass function is broadcast).
    rule : str
        A name of :data:`RULES` or an alias (``belief rules`` lists them).
    model : Model, optional
        The fusion model; by default the sources' model.  A stricter model gives
        dynamic fusion.
    engine : {"auto", "general", "bayesian"}
        How to compute.  ``"general"`` builds every focal element of the result from the
        compiled plan of :mod:`belief.plan`.  ``"bayesian"`` uses the closed forms of
        :mod:`belief.bayesian` for Bayesian sources (singleton focal elements) and raises
        if they do not apply; the result is then a :class:`~belief.bayesian.ClosedFormBatch`,
        whose Bel, Pls, BetP and masses of singletons need no focal element and whose
        ``values`` are combined on first access.  ``"auto"`` (the default) takes the closed
        forms whenever they apply to batches, and the general path otherwise.
    **options
        Rule options, e.g. ``r_mode`` and ``empty_mode`` of the R-weighted rule.

    Returns
    -------
    MassFunction or MassBatch
        A mass function if every source is one, else a batch of N rows.

    Raises
    ------
    UnknownRuleError
        For a name the registry does not know (the message lists the known rules).
    InvalidMassError
        For an unknown engine or option.
    TotalConflictError
        Dempster's rule on totally conflicting sources (with either engine).
    ModelError, InvalidMassError
        ``engine="bayesian"`` where the closed forms do not apply (the message says why).

    Examples
    --------
    >>> from belief import Frame, MassFunction, Model
    >>> shafer = Model.shafer(Frame(["a", "b", "c"]))
    >>> m1 = MassFunction({"a": 0.9, "c": 0.1}, model=shafer)
    >>> m2 = MassFunction({"b": 0.9, "c": 0.1}, model=shafer)
    >>> combine(m1, m2, rule="dempster")   # Zadeh's example
    MassFunction({'c': 1.0}, frame=['a', 'b', 'c'])
    >>> {e: round(v, 12) for e, v in combine(m1, m2, rule="pcr6").to_mapping().items()}
    {'a': 0.486, 'b': 0.486, 'c': 0.028}
    >>> from belief import MassBatch
    >>> cues = [MassBatch.bayesian([[0.9, 0.0, 0.1]], model=shafer),
    ...         MassBatch.bayesian([[0.0, 0.9, 0.1]], model=shafer)]
    >>> combine(*cues, rule="pcr6").betp(["a", "b", "c"]).round(12)      # closed forms, same numbers
    array([[0.486, 0.486, 0.028]])
    """
    if dask_batches.made and dask_batches.any_lazy(sources):
        # Batches on dask arrays: this same function per chunk of rows (belief.dask_batches).
        return dask_batches.combine_lazy(combine, sources, get_rule(rule), model, engine, options)
    key = ALIASES.get(rule) if type(rule) is str else None
    info = RULES[key] if key is not None else get_rule(rule)     # an exact name skips the normalisation
    if engine == "auto" or engine == "general":
        if not options:
            for family in SINGLE_FAMILIES:
                fused = family(info, sources, model)
                if fused is not None:
                    return fused
    else:
        bayesian.check_engine(engine)
    unknown = set(options) - set(info.options)
    if unknown:
        accepted = ", ".join(info.options) if info.options else "none"
        raise InvalidMassError(f"rule {info.name!r} takes no option {', '.join(sorted(unknown))} (options: {accepted})")
    batches, fusion_model, single = prepare_sources(sources, model)
    if engine != "general" and not (single and engine == "auto"):
        if info.name == "r_rule":
            check_r_options(**options)
        fused, reason = bayesian.closed_form(info.name, batches, fusion_model, options,
                                             lambda *args, **kwargs: renormalised(info.function(*args, **kwargs),
                                                                                  len(batches)))
        if fused is None:
            if engine == "bayesian":
                raise bayesian.not_applicable(reason)
        elif not single:
            return fused
    result = renormalised(info.function(batches, fusion_model, **options), len(batches))
    return result[0] if single else result


def _many_singletons(info: RuleInfo, sources: Sequence[Source], model: Model | None) -> MassFunction | None:
    """Mass functions of many single hypotheses under Shafer's model (:mod:`belief.singletons`), or None."""
    kind = SINGLETON_RULES.get(info.function)
    if kind is None:
        return None
    if len(sources) == 1 and isinstance(sources[0], (list, tuple)):
        sources = sources[0]
    read = singleton_sources(sources, model)
    if read is None:
        return None
    fused = combine_singletons(kind, read, sources[0].model)
    return None if fused is None else renormalised(fused, len(sources))


#: How single mass functions are combined, tried in this order; the first family that accepts the sources gives
#: the final result (None: not for it).  Batches, and whatever no family takes, go on to the Bayesian closed forms
#: (:mod:`belief.bayesian`, batches only) and then to the rule's own function over the compiled plans
#: (:mod:`belief.rules_tuples`, :mod:`belief.plan`).
#:
#: ======================  ===========================================================  ======================
#: family                  sources                                                      kernels
#: ======================  ===========================================================  ======================
#: the same sources again  joint PCR5 / PCR6 of mass functions combined before          :mod:`belief.joint_code`
#: many singletons         single hypotheses under Shafer's model, ≥ 4 096 tuples       :mod:`belief.singletons`
#: unions of hypotheses    unions of exclusive hypotheses, frames of ≤ 16 hypotheses    :mod:`belief.rules_single`
#: ======================  ===========================================================  ======================
SINGLE_FAMILIES = (combine_again, _many_singletons, combine_single)


def sequential(*sources: Source, rule: Union[str, RuleInfo] = "pcr6", model: Model | None = None,
               **options: Any) -> Source:
    """Fold a rule pairwise, left to right: ((m1 ⊕ m2) ⊕ m3) ⊕ …

    For associative rules this equals :func:`combine`.  For PCR5, PCR6, DSmH and
    Dubois–Prade it is a different (order-dependent) rule, offered for those who want
    a fold; :func:`combine` uses their joint s-source definitions.

    >>> from belief import Frame, MassFunction, Model
    >>> shafer = Model.shafer(Frame(["a", "b"]))
    >>> ms = [MassFunction({"a": 0.6, "b": 0.4}, model=shafer), MassFunction({"a": 0.2, "b": 0.8}, model=shafer),
    ...       MassFunction({"a": 0.7, "b": 0.3}, model=shafer)]
    >>> sequential(*ms, rule="pcr5").isclose(combine(*ms, rule="pcr5"))
    False
    """
    info = get_rule(rule)
    if len(sources) == 1 and isinstance(sources[0], (list, tuple)):
        sources = tuple(sources[0])
    if len(sources) < 2:
        raise InvalidMassError(f"combination needs at least two sources, got {len(sources)}")
    result = combine(sources[0], sources[1], rule=info, model=model, **options)
    for source in sources[2:]:
        if model is not None and isinstance(source, (MassFunction, MassBatch)) and source.model != model:
            source = source.under(model)
        result = combine(result, source, rule=info, **options)
    return result
