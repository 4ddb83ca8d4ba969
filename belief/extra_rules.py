"""More combination rules, registered in :data:`belief.rules.RULES` on import.

* ``cautious`` and ``bold`` (Denœux 2008): the minimum of the conjunctive (disjunctive)
  weights; commutative, associative and idempotent, for sources that may share evidence;
  on Shafer's model only (:mod:`belief.representations`).
* ``average`` and ``murphy`` (Murphy 2000): the mean of the sources, and that mean combined
  s - 1 times with itself by Dempster's rule.
* ``pcr5_plus`` and ``pcr6_plus`` (Dezert, Dezert & Smarandache, JAIF 2021): PCR5 and
  PCR6 where a conflicting product goes only to the focal elements that take part in the
  conflict (binary keeping index); on every model.

Every rule is a plain function ``rule(sources, model)`` over :class:`~belief.batch.MassBatch`
sources, called by :func:`belief.rules.combine`:

>>> from belief import Frame, MassFunction, Model, combine
>>> shafer = Model.shafer(Frame(["a", "b"]))
>>> m = MassFunction({"a": 0.6, "a|b": 0.4}, model=shafer)
>>> combine(m, m, rule="cautious") == m          # idempotent
True
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

import belief.representations as rep
from belief.batch import MassBatch
from belief.errors import CombinationTooLargeError, InvalidMassError, ModelError
from belief.frame import Element
from belief.model import Model
from belief.plan import check_joint, count_text
from belief.rules import combine, register_rule

__all__ = ["cautious", "bold", "average", "murphy", "pcr5_plus", "pcr6_plus", "keeping_index", "MAX_PLUS_TUPLES"]

#: The joint PCR5+ / PCR6+ combination visits at most this many tuples of focal elements.
MAX_PLUS_TUPLES = 500_000


def _under(batch: MassBatch, model: Model) -> MassBatch:
    return batch if batch.model == model else batch.under(model)


def _rows(batches: Sequence[MassBatch]) -> int:
    return max(len(b) for b in batches)


def _row_note(values: np.ndarray, bad: np.ndarray) -> str:
    return f" (row {int(np.flatnonzero(bad)[0])})" if values.shape[0] > 1 else ""


# -- cautious and bold ----------------------------------------------------------------------------------
@register_rule("cautious", summary="cautious rule (Denœux 2008): min of the conjunctive weights; idempotent, "
                                   "conflict on ∅; Shafer's model, m(Θ) > 0",
               associative=True, keeps_conflict=True, aliases=("cautious_conjunctive",))
def cautious(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """The cautious conjunctive rule: w_{1∧2}(A) = min(w_1(A), w_2(A)) for every A ⊂ Θ (Denœux 2008).

    Each source is decomposed into its conjunctive weights w_i (Smets 1995; see
    :func:`~belief.representations.conjunctive_weights`); the result is
    ∩_{A⊂Θ} A^{min_i w_i(A)}.  It is the least committed mass function (for the order of the
    w) that is more committed than every source, so it is commutative, associative and
    idempotent (m ∧ m = m), which suits sources whose evidence may overlap.  Like the
    conjunctive rule it is unnormalised: the conflict stays on ∅.

    Parameters
    ----------
    sources : list of MassBatch
        Non-dogmatic sources (m(Θ) > 0 in every row); mass on ∅ is allowed.
    model : Model
        Shafer's model of a frame of at most :data:`~belief.representations.MAX_HYPOTHESES`
        hypotheses (the sources may be elicited under a looser model).

    Returns
    -------
    MassBatch

    Raises
    ------
    InvalidMassError
        A dogmatic source (m(Θ) = 0).
    ModelError
        A fusion model other than Shafer's.

    Examples
    --------
    Two separable sources, {a}^.4 ∩ {a,b}^.5 and {a}^.6 ∩ {b,c}^.3: the weights are
    min(.4, .6) = .4 for {a}, .5 for {a, b} and .3 for {b, c}, so the result is
    {a}^.4 ∩ {a,b}^.5 ∩ {b,c}^.3.

    >>> from belief import Frame, MassFunction, Model, combine
    >>> shafer = Model.shafer(Frame(["a", "b", "c"]))
    >>> m1 = MassFunction({"a": 0.6, "a|b": 0.2, "a|b|c": 0.2}, model=shafer)
    >>> m2 = MassFunction({"empty": 0.28, "a": 0.12, "b|c": 0.42, "a|b|c": 0.18}, model=shafer, subnormal=True)
    >>> {e: round(v, 12) for e, v in combine(m1, m2, rule="cautious").to_mapping().items()}
    {'empty': 0.42, 'a': 0.18, 'b': 0.14, 'a|b': 0.06, 'b|c': 0.14, 'a|b|c': 0.06}
    """
    rep._require_shafer(model, "the cautious rule")
    logs = []
    for k, batch in enumerate(sources, start=1):
        dense = rep._dense(_under(batch, model), "the cautious rule")
        dogmatic = ~(dense[:, -1] > 0)
        if dogmatic.any():
            raise InvalidMassError(f"the cautious rule needs non-dogmatic sources (m(Θ) > 0), but source {k} has "
                                   f"m(Θ) = 0{_row_note(dense, dogmatic)}; discount it first")
        logs.append(rep._log_conjunctive_weights(dense, "the cautious rule"))
    rows = _rows(sources)
    log_w = np.minimum.reduce([np.broadcast_to(x, (rows, x.shape[1])) for x in logs])
    return rep._result(rep._masses_from_log_conjunctive_weights(log_w), model, False, "the cautious rule")


@register_rule("bold", summary="bold disjunctive rule (Denœux 2008): min of the disjunctive weights; idempotent; "
                               "Shafer's model, m(∅) > 0",
               associative=True, keeps_conflict=True, aliases=("bold_disjunctive",))
def bold(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """The bold disjunctive rule: v_{1∨2}(A) = min(v_1(A), v_2(A)) for every A ≠ ∅ (Denœux 2008).

    The dual of the cautious rule: each source is decomposed into its disjunctive weights v_i
    (:func:`~belief.representations.disjunctive_weights`) and the result is
    ∪_{A≠∅} A_{min_i v_i(A)}.  Commutative, associative and idempotent, for unreliable
    sources whose evidence may overlap.  The disjunctive weights exist only for subnormal
    mass functions, so every source needs m(∅) > 0, and so does the result.

    Parameters
    ----------
    sources : list of MassBatch
        Subnormal sources (m(∅) > 0 in every row).
    model : Model
        Shafer's model of a frame of at most :data:`~belief.representations.MAX_HYPOTHESES`
        hypotheses.

    Returns
    -------
    MassBatch

    Raises
    ------
    InvalidMassError
        A source with m(∅) = 0.
    ModelError
        A fusion model other than Shafer's.

    Examples
    --------
    {a}_.6 ∪ {b}_.5 bold-combined with {a}_.8 ∪ {b}_.2 is {a}_.6 ∪ {b}_.2: m(∅) = .12,
    m(a) = .4 · .2 = .08, m(b) = .6 · .8 = .48 and m(a ∪ b) = .4 · .8 = .32.

    >>> from belief import Frame, MassFunction, Model, combine
    >>> shafer = Model.shafer(Frame(["a", "b"]))
    >>> m1 = MassFunction({"empty": 0.3, "a": 0.2, "b": 0.3, "a|b": 0.2}, model=shafer, subnormal=True)
    >>> m2 = MassFunction({"empty": 0.16, "a": 0.04, "b": 0.64, "a|b": 0.16}, model=shafer, subnormal=True)
    >>> {e: round(v, 12) for e, v in combine(m1, m2, rule="bold").to_mapping().items()}
    {'empty': 0.12, 'a': 0.08, 'b': 0.48, 'a|b': 0.32}
    """
    rep._require_shafer(model, "the bold rule")
    logs = []
    for k, batch in enumerate(sources, start=1):
        dense = rep._dense(_under(batch, model), "the bold rule")
        normal = ~(dense[:, 0] > 0)
        if normal.any():
            raise InvalidMassError(f"the bold rule needs subnormal sources (m(∅) > 0), but source {k} has "
                                   f"m(∅) = 0{_row_note(dense, normal)}")
        logs.append(rep._log_disjunctive_weights(dense, "the bold rule"))
    rows = _rows(sources)
    log_v = np.minimum.reduce([np.broadcast_to(x, (rows, x.shape[1])) for x in logs])
    return rep._result(rep._masses_from_log_disjunctive_weights(log_v), model, False, "the bold rule")


# -- averaging -------------------------------------------------------------------------------------------
@register_rule("average", summary="the mean of the sources' masses", associative=False, keeps_conflict=True,
               aliases=("mean", "averaging"))
def average(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """The plain mean m(A) = (1/s) Σ_i m_i(A) of the s sources, on every model.

    Each source is first read under the fusion model (an element that vanishes there gives
    its mass to ∅); mass on ∅ is averaged like any other, so subnormal sources give a
    subnormal mean.  Not associative: the mean of a mean and a third source weighs them
    1/2, 1/4, 1/4.

    Parameters
    ----------
    sources : list of MassBatch
    model : Model

    Returns
    -------
    MassBatch

    Examples
    --------
    >>> from belief import Frame, MassFunction, Model, combine
    >>> shafer = Model.shafer(Frame(["A", "B", "C"]))
    >>> m1 = MassFunction({"A": 0.5, "B": 0.2, "C": 0.3}, model=shafer)
    >>> m2 = MassFunction({"B": 0.9, "C": 0.1}, model=shafer)
    >>> combine(m1, m2, rule="average").to_mapping()
    {'A': 0.25, 'B': 0.55, 'C': 0.2}
    """
    mapped = [_under(b, model) for b in sources]
    focal = sorted({e for b in mapped for e in b.focal}, key=lambda e: e.sort_key)
    column = {e: k for k, e in enumerate(focal)}
    out = np.zeros((_rows(mapped), len(focal)))
    for b in mapped:
        for k, e in enumerate(b.focal):
            out[:, column[e]] += b.values[:, k]
    out /= len(mapped)
    return MassBatch(focal, out, model=model, subnormal=True, validate=False)


@register_rule("murphy", summary="Murphy (2000): the mean of the s sources combined s - 1 times with itself by "
                                 "Dempster's rule",
               associative=False, aliases=("murphy_average",))
def murphy(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """Murphy's rule: average the s sources, then combine the mean s - 1 times with Dempster's rule.

    m = m̄ ⊕ m̄ ⊕ … ⊕ m̄ (s times), m̄ the mean of :func:`average` (Murphy, "Combining belief
    functions when evidence conflicts", Decision Support Systems 29, 2000).

    Parameters
    ----------
    sources : list of MassBatch
    model : Model

    Returns
    -------
    MassBatch
        Normal: Dempster's rule removes m(∅).

    Raises
    ------
    TotalConflictError
        If the mean combined with itself is in total conflict (all its mass on ∅).

    Examples
    --------
    Murphy's two first sources: the mean {A: .25, B: .55, C: .2} combined with itself gives
    A .0625, B .3025, C .04 over 1 - K = .405.

    >>> from belief import Frame, MassFunction, Model, combine
    >>> shafer = Model.shafer(Frame(["A", "B", "C"]))
    >>> m1 = MassFunction({"A": 0.5, "B": 0.2, "C": 0.3}, model=shafer)
    >>> m2 = MassFunction({"B": 0.9, "C": 0.1}, model=shafer)
    >>> {e: round(v, 4) for e, v in combine(m1, m2, rule="murphy").to_mapping().items()}
    {'A': 0.1543, 'B': 0.7469, 'C': 0.0988}
    """
    mean = average(sources, model)
    return combine(*([mean] * len(sources)), rule="dempster", engine="general")


# -- PCR5+ and PCR6+ ----------------------------------------------------------------------------------------
def keeping_index(elements, model: Model) -> frozenset:
    """The focal elements of a conflicting tuple whose binary keeping index is 1 (JAIF 2021, eq. (24)).

    The distinct elements are visited by decreasing DSm cardinality (|X| on Shafer's model).
    An element is kept if a strictly larger one was kept; otherwise it is dropped exactly
    when it contains every other element of no greater cardinality, for then it takes no
    part in the conflict (A ∪ B against A and B: the conflict is A ∩ B = ∅).  The index
    depends only on the elements, not on their masses.

    Parameters
    ----------
    elements : iterable of Element
        The focal elements of one tuple, reduced under ``model`` (repeats are ignored).
    model : Model

    Returns
    -------
    frozenset of Element

    Examples
    --------
    >>> from belief import Frame, Model
    >>> shafer = Model.shafer(Frame(["A", "B", "C"]))
    >>> sorted(str(e) for e in keeping_index([shafer.element(x) for x in ("A", "B", "A|B")], shafer))
    ['A', 'B']
    >>> sorted(str(e) for e in keeping_index([shafer.element(x) for x in ("A", "C", "A|B")], shafer))
    ['A', 'A|B', 'C']
    """
    distinct = frozenset(elements)
    return _keeping(model, distinct)


@lru_cache(maxsize=4096)
def _keeping(model: Model, elements: frozenset) -> frozenset:
    size = {e: model.cardinality(e) for e in elements}
    kept: set = set()
    larger_kept = False
    for level in sorted(set(size.values()), reverse=True):
        chosen = [e for e in elements if size[e] == level
                  and (larger_kept or any(o != e and size[o] <= level and not o <= e for o in elements))]
        kept.update(chosen)
        larger_kept = larger_kept or bool(chosen)
    return frozenset(kept)


@dataclass(frozen=True, eq=False)
class _PlusPlan:
    """Index tables of PCR5+/PCR6+ for one list of focal elements per source."""

    consensus: tuple[np.ndarray, ...]     # per source, its column in each non-conflicting tuple, (Tc,)
    conflict: tuple[np.ndarray, ...]      # per source, its column in each conflicting tuple, (Tf,)
    entry_tuple: np.ndarray               # the conflicting tuple of each (tuple, kept element) entry, (E,)
    member: np.ndarray                    # (E, s): slot i holds the entry's element
    entry_starts: np.ndarray              # where each conflicting tuple's entries start, (Tf,)
    order: np.ndarray                     # [consensus | entries] sorted by target element
    target_starts: np.ndarray             # where each target's run starts in that order
    targets: tuple[Element, ...]          # the result's focal elements, canonical order


@lru_cache(maxsize=256)
def _plus_plan(model: Model, focal: tuple[tuple[Element, ...], ...]) -> _PlusPlan:
    s = len(focal)
    meets: dict = {}
    consensus, consensus_target = [], []
    conflict, entry_tuple, member, entry_target, entry_starts = [], [], [], [], []
    for columns in itertools.product(*(range(len(f)) for f in focal)):
        elements = [focal[i][c] for i, c in enumerate(columns)]
        meet = elements[0]
        for e in elements[1:]:
            key = (meet, e)
            if key not in meets:
                meets[key] = model.reduce(meet & e)
            meet = meets[key]
        if meet.terms:
            consensus.append(columns)
            consensus_target.append(meet)
            continue
        kept = _keeping(model, frozenset(elements))
        entry_starts.append(len(entry_tuple))
        for e in dict.fromkeys(elements):
            if e in kept:
                entry_tuple.append(len(conflict))
                member.append([x == e for x in elements])
                entry_target.append(e)
        conflict.append(columns)
    targets = tuple(sorted(set(consensus_target) | set(entry_target), key=lambda e: e.sort_key))
    code = {e: k for k, e in enumerate(targets)}
    codes = np.array([code[e] for e in consensus_target + entry_target], dtype=np.int64)
    order = np.argsort(codes, kind="stable")
    sorted_codes = codes[order]
    target_starts = np.flatnonzero(np.r_[True, sorted_codes[1:] != sorted_codes[:-1]])

    def by_source(rows: list) -> tuple[np.ndarray, ...]:
        array = np.array(rows, dtype=np.int64).reshape(len(rows), s)
        return tuple(array[:, i].copy() for i in range(s))

    return _PlusPlan(by_source(consensus), by_source(conflict), np.array(entry_tuple, dtype=np.int64),
                     np.array(member, dtype=bool).reshape(len(member), s), np.array(entry_starts, dtype=np.int64),
                     order, target_starts, targets)


def _pcr_plus(sources: Sequence[MassBatch], model: Model, rule: str) -> MassBatch:
    focal, values = [], []
    rows = _rows(sources)
    for k, b in enumerate(sources, start=1):
        if b.empty_mass.any():
            raise InvalidMassError(f"{rule} needs normal sources, but source {k} has mass on ∅; normalise it first")
        keep = [i for i, x in enumerate(b.focal) if x.terms]
        projected = tuple(model.reduce(b.focal[i]) for i in keep)
        for i, y in zip(keep, projected):
            if not y.terms:
                raise ModelError(f"{rule} cannot give mass to {b.focal[i]} of source {k}, which is empty under the "
                                 f"{model.kind} fusion model; use dsmh for such dynamic fusion")
        focal.append(projected)
        values.append(np.broadcast_to(b.values[:, keep], (rows, len(keep))))
    count = 1
    for f in focal:
        count *= len(f)
    if count > MAX_PLUS_TUPLES:
        raise CombinationTooLargeError(
            f"joint {rule} combination of {len(sources)} sources visits {count_text(count)} tuples of focal elements, more than "
            f"belief.extra_rules.MAX_PLUS_TUPLES = {MAX_PLUS_TUPLES:,}; use fewer focal elements or sources, or raise "
            "belief.extra_rules.MAX_PLUS_TUPLES", limit="belief.extra_rules.MAX_PLUS_TUPLES")
    check_joint(rule, [len(f) for f in focal], rows, "pcr", True, rule == "pcr5_plus")
    plan = _plus_plan(model, tuple(focal))
    out = np.empty((rows, len(plan.targets)))
    width = len(plan.order) + len(plan.entry_tuple) * 2 + len(plan.entry_starts) * (len(sources) + 2)
    step = max(1, 4_000_000 // max(width, 1))
    for start in range(0, rows, step):
        part = [v[start:start + step] for v in values]
        out[start:start + step] = _plus_rows(plan, part, rule == "pcr5_plus")
    return MassBatch(plan.targets, out, model=model, validate=False)


def _plus_rows(plan: _PlusPlan, values: list[np.ndarray], product_weights: bool) -> np.ndarray:
    """The result rows for some source rows: consensus products, then the conflicting products shared."""
    pieces = []
    consensus = np.take(values[0], plan.consensus[0], axis=1)
    for v, c in zip(values[1:], plan.consensus[1:]):
        consensus = consensus * np.take(v, c, axis=1)
    pieces.append(consensus)
    if plan.entry_tuple.size:
        masses = [np.take(v, c, axis=1) for v, c in zip(values, plan.conflict)]     # each (r, Tf)
        product = masses[0].copy()
        for m in masses[1:]:
            product *= m
        at = plan.entry_tuple
        with np.errstate(divide="ignore", invalid="ignore"):
            if product_weights:
                # PCR5+: Π of the masses each kept element received, scaled in log space per tuple
                log_w = np.zeros((product.shape[0], at.size))
                for i, m in enumerate(masses):
                    mine = plan.member[:, i]
                    log_w[:, mine] += np.log(m[:, at[mine]])
                top = np.maximum.reduceat(log_w, plan.entry_starts, axis=1)[:, at]
                weights = np.where(np.isfinite(top), np.exp(log_w - top), 0.0)
            else:
                # PCR6+: Σ of the masses each kept element received
                weights = np.zeros((product.shape[0], at.size))
                for i, m in enumerate(masses):
                    mine = plan.member[:, i]
                    weights[:, mine] += m[:, at[mine]]
            total = np.add.reduceat(weights, plan.entry_starts, axis=1)[:, at]
            shares = np.where(total > 0, product[:, at] * (weights / total), 0.0)
        pieces.append(shares)
    entries = np.concatenate(pieces, axis=1)[:, plan.order]
    return np.add.reduceat(entries, plan.target_starts, axis=1)


@register_rule("pcr5_plus", summary="PCR5+: PCR5 where a conflicting product goes only to the elements involved "
                                    "in the conflict (JAIF 2021)",
               associative=False, aliases=("pcr5+",))
def pcr5_plus(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """The improved PCR5 rule PCR5+, joint s-source form (Dezert, Dezert & Smarandache, JAIF 16(1), 2021).

    As :func:`belief.rules.pcr5`, each tuple with a non-empty intersection gives its product
    to that intersection; a conflicting product Π m_i(X_i) is shared in proportion to
    P_Y = Π_{i: X_i = Y} m_i(Y), but only among the distinct elements Y of the tuple whose
    binary keeping index is 1 (:func:`keeping_index`, eqs. (23)–(25)): an element that merely
    contains the others of the tuple gets nothing.  So the vacuous mass function is neutral,
    which it is not for PCR5, and for two sources PCR5+ is PCR5 (no element of a conflicting
    pair contains the other).  Sources must be normal; under a stricter fusion model an
    element that vanishes raises :class:`~belief.errors.ModelError`, as for PCR5.

    Examples
    --------
    JAIF 2021, Example 2 (three sources on {A, B}): A ∪ B keeps only its consensus
    .3 · .2 · .5 = .03, where PCR5 gives it .094259.

    >>> from belief import Frame, MassFunction, Model, combine
    >>> shafer = Model.shafer(Frame(["A", "B"]))
    >>> ms = [MassFunction({"A": 0.6, "B": 0.1, "A|B": 0.3}, model=shafer),
    ...       MassFunction({"A": 0.5, "B": 0.3, "A|B": 0.2}, model=shafer),
    ...       MassFunction({"A": 0.4, "B": 0.1, "A|B": 0.5}, model=shafer)]
    >>> {e: round(v, 6) for e, v in combine(*ms, rule="pcr5_plus").to_mapping().items()}
    {'A': 0.768631, 'B': 0.201369, 'A|B': 0.03}
    """
    return _pcr_plus(sources, model, "pcr5_plus")


@register_rule("pcr6_plus", summary="PCR6+: PCR6 where a conflicting product goes only to the elements involved "
                                    "in the conflict (JAIF 2021)",
               associative=False, aliases=("pcr6+",))
def pcr6_plus(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """The improved PCR6 rule PCR6+, joint s-source form (Dezert, Dezert & Smarandache, JAIF 16(1), 2021).

    As :func:`belief.rules.pcr6`, but a conflicting product is shared only among the distinct
    elements of the tuple whose binary keeping index is 1 (:func:`keeping_index`), each in
    proportion to the sum of the masses the sources committed to it (eq. (26)).  The vacuous
    mass function is neutral; for two sources PCR6+ = PCR5+ = PCR5 = PCR6.

    Examples
    --------
    JAIF 2021, Example 2 again:

    >>> from belief import Frame, MassFunction, Model, combine
    >>> shafer = Model.shafer(Frame(["A", "B"]))
    >>> ms = [MassFunction({"A": 0.6, "B": 0.1, "A|B": 0.3}, model=shafer),
    ...       MassFunction({"A": 0.5, "B": 0.3, "A|B": 0.2}, model=shafer),
    ...       MassFunction({"A": 0.4, "B": 0.1, "A|B": 0.5}, model=shafer)]
    >>> {e: round(v, 6) for e, v in combine(*ms, rule="pcr6_plus").to_mapping().items()}
    {'A': 0.788847, 'B': 0.181153, 'A|B': 0.03}
    """
    return _pcr_plus(sources, model, "pcr6_plus")
