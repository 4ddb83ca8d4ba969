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
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import lru_cache, reduce
from math import fsum
from operator import add
from typing import Any, Union

import numpy as np

from belief import bayesian
from belief import plan as limits
from belief.batch import SUM_TOLERANCE, MassBatch, check_refines
from belief.bayesian import ENGINES
from belief.errors import BeliefError, FrameError, InvalidMassError, ModelError, TotalConflictError
from belief.frame import Element
from belief.mass import MassFunction, _set, _union_context
from belief.model import Model
from belief.plan import (Encoding, FoldBudget, Scatter, TuplePlan, _exclusive, canonical_codes, check_joint,
                         coded_fast, decode, encode, evict, gather_product, plan_lookup, row_chunks, sighted,
                         tuple_codes, tuple_plan, union_ranks)

__all__ = ["combine", "sequential", "inconsistency", "RULES", "RuleInfo", "get_rule", "register_rule",
           "unregister_rule", "rule_names", "UnknownRuleError", "ENGINES", "R_MODES", "EMPTY_MODES"]


class UnknownRuleError(BeliefError, KeyError):
    """A rule name that the registry does not know."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0])


RuleFunction = Callable[..., MassBatch]


@dataclass(frozen=True)
class RuleInfo:
    """A registered combination rule.

    Attributes
    ----------
    name : str
    function : callable
        ``function(sources: list[MassBatch], model: Model, **options) -> MassBatch``.
    summary : str
        One line for ``belief rules``.
    associative : bool
        Whether folding pairwise gives the joint result.
    keeps_conflict : bool
        Whether the result may hold mass on ∅.
    aliases : tuple of str
    options : tuple of str
        Keyword options the rule accepts.
    """

    name: str
    function: RuleFunction
    summary: str
    associative: bool
    keeps_conflict: bool = False
    aliases: tuple[str, ...] = ()
    options: tuple[str, ...] = field(default=())


RULES: dict[str, RuleInfo] = {}
_ALIASES: dict[str, str] = {}


def register_rule(name: str, *, summary: str, associative: bool, keeps_conflict: bool = False,
                  aliases: Sequence[str] = (), options: Sequence[str] = ()):
    """Decorator that adds a rule function to the registry under ``name`` and ``aliases``."""

    def decorate(function: RuleFunction) -> RuleFunction:
        info = RuleInfo(name, function, summary, associative, keeps_conflict, tuple(aliases), tuple(options))
        RULES[name] = info
        for key in (name, *aliases):
            # The spelling get_rule looks names up by: case and "-" / "_" do not matter.
            _ALIASES[key.lower().replace("-", "_")] = name
        return function

    return decorate


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
    for key in [k for k, target in _ALIASES.items() if target == info.name]:
        del _ALIASES[key]
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
    key = _ALIASES.get(name.lower().replace("-", "_"))
    if key is None:
        raise UnknownRuleError(f"unknown rule {name!r}; known rules: {', '.join(RULES)}")
    return RULES[key]


# -- entry points ---------------------------------------------------------------------------------
Source = Union[MassFunction, MassBatch]


def _prepare(sources: Sequence[Source], model: Model | None) -> tuple[list[MassBatch], Model, bool]:
    if len(sources) == 1 and isinstance(sources[0], (list, tuple)):
        sources = list(sources[0])
    if len(sources) < 2:
        raise InvalidMassError(f"combination needs at least two sources, got {len(sources)}")
    single = all(isinstance(s, MassFunction) for s in sources)
    batches: list[MassBatch] = []
    for k, s in enumerate(sources):
        if isinstance(s, MassFunction):
            batches.append(s.batch())
        elif isinstance(s, MassBatch):
            batches.append(s)
        else:
            raise TypeError(f"source {k + 1} is a {type(s).__name__}, not a MassFunction or MassBatch")
    source_model = batches[0].model
    for k, b in enumerate(batches[1:], start=2):
        if b.model != source_model:
            if b.frame != source_model.frame:
                raise FrameError(f"source {k} has the frame {list(b.frame.hypotheses)}, "
                                 f"source 1 has {list(source_model.frame.hypotheses)}")
            raise ModelError(f"source {k} was elicited under the {b.model.kind} model and source 1 under the "
                             f"{source_model.kind} model; read them under one model first (MassFunction.under)")
    rows = {len(b) for b in batches} - {1}
    if len(rows) > 1:
        raise InvalidMassError(f"batches have different numbers of rows: {sorted(rows)}")
    if model is None:
        model = source_model
    else:
        check_refines(source_model, model)
    return batches, model, single


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
    MassFunction({'c': 1.0}, model=Model.shafer(Frame(['a', 'b', 'c'])))
    >>> {e: round(v, 12) for e, v in combine(m1, m2, rule="pcr6").to_mapping().items()}
    {'a': 0.486, 'b': 0.486, 'c': 0.028}
    >>> from belief import MassBatch
    >>> cues = [MassBatch.bayesian([[0.9, 0.0, 0.1]], model=shafer),
    ...         MassBatch.bayesian([[0.0, 0.9, 0.1]], model=shafer)]
    >>> combine(*cues, rule="pcr6").betp(["a", "b", "c"]).round(12)      # closed forms, same numbers
    array([[0.486, 0.486, 0.028]])
    """
    key = _ALIASES.get(rule) if type(rule) is str else None
    info = RULES[key] if key is not None else get_rule(rule)     # an exact name skips the normalisation
    if engine == "auto" or engine == "general":
        if not options:
            fused = _single(info, sources, model)
            if fused is not None:
                return fused
    else:
        bayesian.check_engine(engine)
    unknown = set(options) - set(info.options)
    if unknown:
        accepted = ", ".join(info.options) if info.options else "none"
        raise InvalidMassError(f"rule {info.name!r} takes no option {', '.join(sorted(unknown))} (options: {accepted})")
    batches, fusion_model, single = _prepare(sources, model)
    if engine != "general" and not (single and engine == "auto"):
        if info.name == "r_rule":
            _check_r_options(**options)
        fused, reason = bayesian.closed_form(info.name, batches, fusion_model, options,
                                             lambda *args, **kwargs: _renormalised(info.function(*args, **kwargs),
                                                                                   len(batches)))
        if fused is None:
            if engine == "bayesian":
                raise bayesian.not_applicable(reason)
        elif not single:
            return fused
    result = _renormalised(info.function(batches, fusion_model, **options), len(batches))
    return result[0] if single else result


#: A result whose masses sum to one within this is left as it is; others are rescaled to sum to one.
RESULT_TOLERANCE = 1e-13


def _renormalised(result: Source, sources: int) -> Source:
    """The result with every row rescaled to sum to one where it is off by more than :data:`RESULT_TOLERANCE`.

    Sources are accepted when they sum to one within
    :data:`~belief.batch.SUM_TOLERANCE`, and the masses of a combination sum to the
    product of the sources' sums: left alone, the error would compound over repeated
    combinations until a result is no longer a valid input.  Rows within the tolerance
    are returned bit for bit, and so are rows off by more than the ``sources`` sums can
    explain: that is a fault of the rule, which :func:`belief.testing.check_rule` must see.
    """
    reach = 2 * sources * SUM_TOLERANCE
    if type(result) is MassFunction:
        floats = result._floats
        if floats is not None:
            total = fsum(floats)
            if not RESULT_TOLERANCE < abs(total - 1.0) <= reach:
                return result
            if result._masks is not None:
                return MassFunction._from_masks(result.model, result._masks, tuple([x / total for x in floats]),
                                                result._loose)
        else:
            total = fsum(result.values.tolist())
            if not RESULT_TOLERANCE < abs(total - 1.0) <= reach:
                return result
            if result._masks is not None:
                return MassFunction._from_masks(result.model, result._masks, result.values / total)
        return _renormalised(result.batch(), sources)[0]
    values = result.values
    if values.shape[0] == 1 and values.shape[1] <= 64:
        if not RESULT_TOLERANCE < abs(fsum(values[0].tolist()) - 1.0) <= reach:
            return result
    totals = values.sum(axis=1)
    error = np.abs(totals - 1.0)
    off = (error > RESULT_TOLERANCE) & (error <= reach)
    if not off.any():
        return result
    scale = np.where(off, totals, 1.0)
    return MassBatch._trusted(result.model, result.focal, values / scale[:, None], canonical=result._canonical)


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


# -- shared machinery ----------------------------------------------------------------------------
def _values(batches: Sequence[MassBatch]) -> tuple[int, list[np.ndarray]]:
    n = max(len(b) for b in batches)
    return n, [b.values if len(b) == n else np.broadcast_to(b.values, (n, b.values.shape[1])) for b in batches]


def _plan(batches: Sequence[MassBatch], model: Model, rule: str = "") -> TuplePlan:
    sizes = [len(b.focal) for b in batches]
    if math.prod(sizes) > limits.MAX_TUPLES:
        check_joint(rule or "the", sizes, max(len(b) for b in batches), "targets")
    return tuple_plan(batches[0].model, model, tuple(b.focal_key for b in batches))


def _check_joint(batches: Sequence[MassBatch], model: Model, rule: str, kind: str) -> None:
    """Refuse a joint combination of these sources that would exceed the limits of :mod:`belief.plan`."""
    check_joint(rule, [len(b.focal) for b in batches], max(len(b) for b in batches), kind,
                lambda: coded_fast(model, [b.focal for b in batches]), rule == "pcr5")


def _budget(batches: Sequence[MassBatch], model: Model, rule: str) -> FoldBudget:
    """The :class:`~belief.plan.FoldBudget` of an associative rule folded over these sources."""
    return FoldBudget(rule, len(batches), max(len(b) for b in batches),
                      lambda: coded_fast(model, [b.focal for b in batches]))


# -- the direct path: focal elements seen for the first time -------------------------------------------
#: A single row with at most this many tuples is combined by a Python loop over the tuples.
LOOP_TUPLES = 256
#: A single row whose codes do not fit 64 bits is looped over up to this many tuples.
WIDE_LOOP_TUPLES = 4096


@dataclass(frozen=True, eq=False)
class _Direct:
    """What the direct path needs of one combination: the focal elements under the fusion model and their codes."""

    projected: tuple[tuple[Element, ...], ...]
    encoding: Encoding
    loop: bool                          # a Python loop over the tuples of one row, else numpy over all tuples

    @property
    def sizes(self) -> tuple[int, ...]:
        return tuple(len(c) for c in self.encoding.codes)


def _direct(batches: Sequence[MassBatch], model: Model, purpose: str) -> _Direct | None:
    """How to combine these sources without a plan, or None where the plan serves the call.

    A compiled plan costs more than one direct evaluation and pays only when its focal
    elements come back, so the plan serves a call when it is cached already or when these
    focal lists were met before (it is compiled then); so does a combination whose codes
    are too wide for numpy and too many to loop over.  The choice never changes a result:
    the direct path adds the same products in the same order.
    """
    count = 1
    for b in batches:
        count *= len(b.focal)
    if count > limits.MAX_TUPLES:
        return None                     # the plan path refuses it, with its message
    source_model = batches[0].model
    keys = tuple(b.focal_key for b in batches)
    if plan_lookup(source_model, model, keys) is not None or sighted(source_model, model, keys, purpose):
        return None
    if source_model == model:
        projected = tuple(b.focal for b in batches)      # already in their form under the model
    else:
        projected = tuple(tuple(model.reduce(x) for x in b.focal) for b in batches)
    encoding = encode(model, projected)
    if encoding is None:
        return None
    single = all(len(b) == 1 for b in batches)
    if single and count <= LOOP_TUPLES:
        return _Direct(projected, encoding, True)
    if encoding.width <= 64:
        return _Direct(projected, encoding, False)
    if single and count <= WIDE_LOOP_TUPLES:
        return _Direct(projected, encoding, True)
    return None


def _segment_sum(values: list[float]) -> float:
    """The sum ``np.add.reduceat`` gives for one segment: the first value plus numpy's pairwise sum of the rest.

    The loops of the direct path add with it, so that their results equal the plan's to the last bit.
    """
    n = len(values)
    if n == 1:
        return values[0]
    if n <= 8:
        # Fewer than eight after the first: numpy adds them one by one (``sum`` may compensate).
        return values[0] + reduce(add, values[1:])
    return values[0] + _pairwise(values, 1, n - 1)


def _pairwise(values: list[float], start: int, n: int) -> float:
    """numpy's pairwise summation of ``values[start:start + n]`` (eight partial sums, blocks of 128)."""
    if n < 8:
        total = 0.0
        for i in range(start, start + n):
            total += values[i]
        return total
    if n <= 128:
        r0, r1, r2, r3, r4, r5, r6, r7 = values[start:start + 8]
        i = start + 8
        stop = start + n - n % 8
        while i < stop:
            r0 += values[i]
            r1 += values[i + 1]
            r2 += values[i + 2]
            r3 += values[i + 3]
            r4 += values[i + 4]
            r5 += values[i + 5]
            r6 += values[i + 6]
            r7 += values[i + 7]
            i += 8
        total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
        for k in range(i, start + n):
            total += values[k]
        return total
    half = n // 2
    half -= half % 8
    return _pairwise(values, start, half) + _pairwise(values, start + half, n - half)


def _tuples(sizes: Sequence[int]):
    """Every tuple of columns, in row-major order (the order of :attr:`TuplePlan.columns`)."""
    return itertools.product(*(range(k) for k in sizes))


def _canonical(direct: _Direct, elements: list[Element]) -> list[int]:
    """The positions of ``elements`` in canonical order."""
    if direct.encoding.kind == "exclusive":
        # Unions of hypotheses: fewer hypotheses first, then by their positions (Element.sort_key).
        keys = [(len(e.terms), e.terms) for e in elements]
    else:
        keys = [e.sort_key for e in elements]
    return sorted(range(len(elements)), key=keys.__getitem__)


def _loop_targets(batches: Sequence[MassBatch], model: Model, key: str, direct: _Direct) -> MassBatch | None:
    """One row, a few tuples: each tuple's product goes to one element, summed per element in plain Python."""
    codes = direct.encoding.codes
    rows = [b.values[0].tolist() for b in batches]
    groups: dict[int, list[float]] = {}
    first: dict[int, tuple[tuple[int, ...], str]] = {}
    if len(batches) == 2 and key in ("meet", "join"):
        c1, c2 = codes
        v1, v2 = rows
        meet = key == "meet"
        for i, a in enumerate(c1):
            p = v1[i]
            for j, b in enumerate(c2):
                c = a & b if meet else a | b
                group = groups.get(c)
                if group is None:
                    groups[c] = [p * v2[j]]
                    first[c] = ((i, j), key)
                else:
                    group.append(p * v2[j])
    else:
        for columns in _tuples(direct.sizes):
            meet = join = None
            if key != "join":
                meet = -1
                for c, k in zip(codes, columns):
                    meet &= c[k]
            if key != "meet":
                join = 0
                for c, k in zip(codes, columns):
                    join |= c[k]
            if key == "meet" or (key != "join" and meet):
                code, op = meet, "meet"
            elif key == "join" or join or key == "dubois_prade":
                code, op = join, "join"
            else:
                return None                 # DSmH's S2: every element vanished (the plan path places it)
            p = rows[0][columns[0]]
            for row, k in zip(rows[1:], columns[1:]):
                p *= row[k]
            group = groups.get(code)
            if group is None:
                groups[code] = [p]
                first[code] = (columns, op)
            else:
                group.append(p)
    unique = list(groups)
    elements = decode(model, direct.encoding, direct.projected, unique,
                      [first[c][0] for c in unique], [first[c][1] for c in unique])
    order = _canonical(direct, elements)
    values = np.array([[_segment_sum(groups[unique[k]]) for k in order]])
    return MassBatch._trusted(model, tuple(elements[k] for k in order), values, canonical=True)


def _array_targets(batches: Sequence[MassBatch], model: Model, key: str, direct: _Direct) -> MassBatch | None:
    """Each tuple's product to one element, on all tuples at once; the arithmetic of the plan path."""
    arrays = [np.array(c, dtype=np.uint64) for c in direct.encoding.codes]
    meet = tuple_codes(arrays, np.bitwise_and) if key != "join" else None
    join = tuple_codes(arrays, np.bitwise_or) if key != "meet" else None
    if key == "meet":
        targets, use_meet = meet, None
    elif key == "join":
        targets, use_meet = join, None
    else:
        use_meet = meet != 0
        if key == "dsmh" and not (use_meet | (join != 0)).all():
            return None                     # DSmH's S2: every element vanished (the plan path places it)
        targets = np.where(use_meet, meet, join)
    elements, ranks = canonical_codes(model, direct.encoding, direct.projected, targets,
                                      key if use_meet is None else use_meet)
    scatter = Scatter.from_ranks(elements, ranks)
    columns = tuple(c.astype(np.int64, copy=False) for c in np.unravel_index(scatter.order, direct.sizes))
    return _scatter_products(batches, model, scatter, columns, len(targets))


def _scatter_products(batches: Sequence[MassBatch], model: Model, scatter: Scatter,
                      columns: tuple[np.ndarray, ...], count: int) -> MassBatch:
    n, values = _values(batches)
    out = np.empty((n, len(scatter.elements)))
    for rows in row_chunks(n, count):
        out[rows] = scatter.apply(gather_product([v[rows] for v in values], columns))
    return MassBatch._trusted(model, scatter.elements, out, canonical=True)


def _require_normal(batches: Sequence[MassBatch], rule: str) -> None:
    for k, b in enumerate(batches, start=1):
        if b.empty_mass.any():
            raise InvalidMassError(f"{rule} needs normal sources, but source {k} has mass on ∅; normalise it first")


def _require_kept(batch: MassBatch, model: Model, rule: str, number: int) -> None:
    """Refuse a focal element that vanishes under the fusion model: the rule has nowhere to send its mass."""
    for x in batch.focal:
        if x.terms and model.is_empty(x):
            raise ModelError(
                f"{rule} cannot give mass to {x} of source {number}, which is empty under the {model.kind} "
                "fusion model; use dsmh for such dynamic fusion"
            )


def _require_nonempty(focal, projected, model: Model, rule: str) -> None:
    for k, (orig, proj) in enumerate(zip(focal, projected), start=1):
        for x, y in zip(orig, proj):
            if x.terms and not y.terms:
                raise ModelError(
                    f"{rule} cannot give mass to {x} of source {k}, which is empty under the {model.kind} "
                    "fusion model; use dsmh for such dynamic fusion"
                )


@lru_cache(maxsize=512)
def _kernel(plan: TuplePlan, key: str) -> tuple[Scatter, tuple[np.ndarray, ...]]:
    """The scatter of a one-target-per-tuple rule, and each source's columns in scatter order."""
    if key == "meet":
        scatter = Scatter.from_codes(*plan.meet_table)
    elif key == "join":
        scatter = Scatter.from_codes(*plan.join_table)
    else:
        scatter = Scatter(_TARGETS[key](plan))
    return scatter, tuple(c[scatter.order] for c in plan.columns)


def _tuple_targets_rule(batches: Sequence[MassBatch], model: Model, key: str) -> MassBatch:
    """Rules that send each tuple's whole product to one element."""
    direct = _direct(batches, model, "targets")
    if direct is not None:
        result = (_loop_targets if direct.loop else _array_targets)(batches, model, key, direct)
        if result is not None:
            return result
    plan = _plan(batches, model)
    scatter, columns = _kernel(plan, key)
    return _scatter_products(batches, model, scatter, columns, plan.count)


#: Two sources whose tuples × rows are at most this many are combined without a cost estimate.
SMALL_PAIR = 4096


def _prune(batch: MassBatch) -> MassBatch:
    """Drop the columns that are zero in every row (they would only widen the next fold)."""
    live = np.flatnonzero((batch.values != 0).any(axis=0))
    if live.size == len(batch.focal):
        return batch
    return MassBatch._trusted(batch.model, tuple(batch.focal[i] for i in live.tolist()), batch.values[:, live],
                              canonical=batch._canonical)


def _fold(batches: Sequence[MassBatch], model: Model, key: str, rule: str = "conjunctive") -> MassBatch:
    """Combine pairwise, left to right, each step checked against the limits of :mod:`belief.plan` first."""
    if len(batches) == 2 and len(batches[0].focal) * len(batches[1].focal) * len(batches[0]) * len(batches[1]) \
            <= SMALL_PAIR:
        return _tuple_targets_rule(batches, model, key)        # far below every limit: not worth the check
    budget = _budget(batches, model, rule)
    budget.step(len(batches[0].focal), len(batches[1].focal), 2)
    result = _tuple_targets_rule(batches[:2], model, key)
    if len(batches) == 2:
        return result
    result = _prune(result)
    for number, b in enumerate(batches[2:], start=3):
        budget.step(len(result.focal), len(b.focal), number)
        result = _prune(_tuple_targets_rule([result, b.under(model) if b.model != model else b], model, key))
    return result


def _dubois_prade_targets(plan: TuplePlan) -> list[Element]:
    return [m if m.terms else j for m, j in zip(plan.meets, plan.joins)]


def _hyper_union(element: Element) -> Element:
    """u(X): the union of the hypotheses that appear in X (u(a∩b) = a ∪ b)."""
    frame = element.frame
    mask = element.hypotheses
    return Element._make(frame, tuple(1 << i for i in range(len(frame)) if mask >> i & 1))


def _dsmh_targets(plan: TuplePlan) -> list[Element]:
    model = plan.model
    targets = []
    for t, meet, join in zip(plan.tuples, plan.meets, plan.joins):
        if meet.terms:
            targets.append(meet)                         # S1
        elif join.terms:
            targets.append(join)                         # S3
        else:                                            # S2: every focal element vanished
            u = model.frame.empty
            for source, i in enumerate(t):
                u = u | _hyper_union(plan.focal[source][i])
            u = model.reduce(u)
            targets.append(u if u.terms else model.total)
    return targets


_TARGETS: dict[str, Callable[[TuplePlan], list[Element]]] = {
    "dubois_prade": _dubois_prade_targets,
    "dsmh": _dsmh_targets,
}


def _move_empty(result: MassBatch, to: Element | None, model: Model, rule: str) -> MassBatch:
    """Remove the ∅ column: renormalise (``to=None``, Dempster) or add it to ``to`` (Yager)."""
    focal = result.focal
    if result._canonical:                      # ∅ sorts first
        if not focal or focal[0].terms:
            return result
        k = 0
    else:
        if all(e.terms for e in focal):
            return result
        k = next(i for i, e in enumerate(focal) if not e.terms)
    values = result.values
    if to is None:
        kept = values[:, 1:] if k == 0 else np.delete(values, k, axis=1)
        scale = kept.sum(axis=1)
        if not (scale > WIDE_SCALE).all():
            return None                         # the non-empty mass may have underflowed: see _wide_dempster
        return MassBatch._trusted(model, focal[:k] + focal[k + 1:], kept / scale[:, None], canonical=result._canonical)
    new_focal = list(focal[:k] + focal[k + 1:])
    new_values = np.delete(values, k, axis=1)
    if to in new_focal:
        new_values[:, new_focal.index(to)] += values[:, k]
    else:
        new_focal.append(to)
        new_values = np.hstack([new_values, values[:, k:k + 1]])
    order = sorted(range(len(new_focal)), key=lambda i: new_focal[i].sort_key)
    return MassBatch._trusted(model, tuple(new_focal[i] for i in order), new_values[:, order], canonical=True)


# -- single mass functions of unions of hypotheses -------------------------------------------------------
#: A single combination of at most this many tuples is summed by a Python loop (numpy's calls cost more).
SINGLE_LOOP_TUPLES = 96
#: The same for the conflicting tuples of PCR5 and PCR6.
PCR_LOOP_TUPLES = 128
#: How many single-row tables (:func:`_single_table`) are kept for focal elements that come back.
SINGLE_CACHE_SIZE = 1024

_PAIR_KINDS = frozenset(("meet", "dempster", "join"))
_JOINT_KINDS = frozenset(("pcr5", "pcr6", "dubois_prade", "dsmh"))
_SINGLE_TABLES: dict[tuple, tuple] = {}
_SINGLE_SIGHTINGS: dict[tuple, bool] = {}


def _single(info: RuleInfo, sources: Sequence[Source], model: Model | None) -> MassFunction | None:
    """Combine mass functions whose focal elements are unions of exclusive hypotheses, or None.

    This is the direct path at its leanest: the focal elements are hypothesis bit masks
    (:meth:`MassFunction._union_masks`), their intersections and unions ``&`` and ``|``, the
    canonical order a look-up in :func:`~belief.plan.union_ranks`, and no element is made
    (the result's are made when it is read).  It takes Shafer's model, or any model that
    forbids every pair of the hypotheses in use, frames of up to
    :data:`~belief.plan.RANK_TABLE_WIDTH` hypotheses, the sources' own model for the fusion,
    and the built-in rules of :data:`_SINGLE_RULES`; anything else, every error, and
    Dempster's rule with a non-empty mass below :data:`WIDE_SCALE` (total conflict, or
    products that may have underflowed) go the general way (None).  Each step adds the same
    products in the same order as the plan of :mod:`belief.plan`, so the results are the
    same to the last bit.  The result is final: rescaled as :func:`_renormalised` says.
    """
    kind = _SINGLE_RULES.get(info.function)
    if kind is None:
        return None
    if len(sources) == 2 and kind in _PAIR_KINDS:
        # The commonest call, two mass functions just built from unions of hypotheses, checked first.
        a, b = sources
        if type(a) is MassFunction and type(b) is MassFunction:
            source_model = a.model
            masks1 = a._masks
            masks2 = b._masks
            if (b.model is source_model and (model is None or model is source_model) and masks1 is not None
                    and masks2 is not None and len(masks1) * len(masks2) <= SINGLE_LOOP_TUPLES
                    and source_model._unions and source_model.kind == "shafer"):
                return _pair_loop(source_model, kind, masks1, a._floats or a._union_floats(), masks2,
                                  b._floats or b._union_floats(), a)
    fused = _single_any(kind, info, sources, model)
    if fused is None:
        return None
    # A pair of a few tuples there is final already; renormalising it again leaves it as it is.
    return _renormalised(fused, len(sources[0]) if len(sources) == 1 else len(sources))


def _single_any(kind: str, info: RuleInfo, sources: Sequence[Source], model: Model | None) -> MassFunction | None:
    """:func:`_single` past its commonest call: a result to renormalise, or None."""
    if len(sources) == 1 and isinstance(sources[0], (list, tuple)):
        sources = sources[0]
    if len(sources) < 2 or type(sources[0]) is not MassFunction:
        return None
    source_model = sources[0].model
    for m in sources:
        if type(m) is not MassFunction or (m.model is not source_model and m.model != source_model):
            return None
    if model is not None and model is not source_model and model != source_model:
        return None
    context = source_model._unions
    if context is None:
        context = _union_context(source_model)
    if not context:
        return None
    n = len(source_model.frame._names)
    masks = []
    count = 1
    for m in sources:
        mk = m._masks                           # possibly not in canonical order yet (see _MassSlots)
        if mk is None:
            mk = m._union_masks()
            if mk is None:
                return None
        masks.append(mk)
        count *= len(mk)
    if kind in _JOINT_KINDS and (count > PCR_LOOP_TUPLES or count > limits.MAX_TUPLES):
        check_joint(info.name, [len(mk) for mk in masks], 1, "pcr" if kind in ("pcr5", "pcr6") else "targets",
                    True, kind == "pcr5")
    if source_model.kind != "shafer":
        used = 0
        for mk in masks:
            for x in mk:
                used |= x
        if not _exclusive(source_model, used):
            return None
    if count <= SINGLE_LOOP_TUPLES and len(masks) == 2 and kind in ("meet", "dempster", "join"):
        a, b = sources
        return _pair_loop(source_model, kind, masks[0], a._floats or a._union_floats(), masks[1],
                          b._floats or b._union_floats(), a)
    if count <= PCR_LOOP_TUPLES and kind in ("pcr5", "pcr6"):
        if any(0 in mk for mk in masks):
            return None                         # mass on ∅: the general path refuses it
        return _pcr_joint_loop(source_model, kind, masks, [m._floats or m._union_floats() for m in sources])
    # The other evaluations follow the canonical order, as the plan does.
    masks = [m._union_masks() for m in sources]
    # Few tuples go through a Python loop on the floats, more through numpy on the arrays.
    if kind in ("pcr5", "pcr6"):
        loop = count <= PCR_LOOP_TUPLES
    elif kind in ("dubois_prade", "dsmh"):
        loop = count <= SINGLE_LOOP_TUPLES
    else:
        loop = len(masks[0]) * len(masks[1]) <= SINGLE_LOOP_TUPLES     # the first step of the fold
    if loop:
        values = [m._union_floats() for m in sources]
    else:
        values = [m.values for m in sources]
    if kind in ("pcr5", "pcr6", "yager", "dubois_prade", "dsmh"):
        for mk in masks:
            if mk[0] == 0:                      # mass on ∅ (it sorts first): the general path refuses it
                return None
        if kind in ("pcr5", "pcr6"):
            return _single_pcr(source_model, n, masks, values, kind)
    if kind in ("dubois_prade", "dsmh"):
        out = _single_targets(n, masks, values, kind)
    else:
        out = _single_fold(n, masks, values, "join" if kind == "join" else "meet", FoldBudget(info.name, len(masks)))
    if out is None:
        return None
    focal, row = out
    if focal[0] == 0:
        if kind == "dempster":
            # _move_empty: the rest rescaled by its sum (numpy's pairwise sum, also in the loop's lists).
            if type(row) is list:
                kept = row[1:]
                scale = _pairwise(kept, 0, len(kept))
                if not scale > WIDE_SCALE:
                    return None                 # underflow or total conflict: the general path tells which
                focal, row = focal[1:], [x / scale for x in kept]
            else:
                kept = row[1:]
                scale = kept.sum()
                if not scale > WIDE_SCALE:
                    return None
                focal, row = focal[1:], kept / scale
        elif kind == "yager":
            focal, row = _single_to_total(source_model, n, focal, np.asarray(row))
    if type(row) is np.ndarray and kind in ("meet", "dempster", "join"):
        # Every mass of a mass function is positive: if the product of the smallest ones is,
        # so is every product and every sum of them (rounding is monotone), and there is no
        # zero to drop.
        least = 1.0
        for m in sources:
            least *= min(m._union_floats())
        if least > 0:
            return MassFunction._from_masks(source_model, focal if type(focal) is tuple else tuple(focal),
                                            row if row.base is None else row.copy())
    return _single_result(source_model, focal, row)


def _pair_loop(model: Model, kind: str, masks1: tuple[int, ...], values1: tuple[float, ...], masks2: tuple[int, ...],
               values2: tuple[float, ...], owner: MassFunction | None = None) -> MassFunction | None:
    """Two mass functions, a few tuples, a rule of the ∩ or ∪ kind: :func:`_single` in one Python function.

    The products that reach one element are added by ``math.fsum``, and Dempster's
    normalisation divides by the ``fsum`` of the non-empty masses: correctly rounded sums,
    which do not depend on the order of the focal elements, so that the sources need not
    be sorted first and the result is left to sort itself when read.  They agree with the
    plan's sums within a few units in the last place.

    ``owner`` (the first mass function) remembers its partner's focal elements: when the
    same two meet again, the grouping of the tuples is made once and kept on it
    (:func:`_pair_table`), and later calls only multiply and add.

    The result is final: normalised for Dempster's rule, else rescaled where
    :func:`_renormalised` would rescale it, zeros dropped.
    """
    key = "join" if kind == "join" else "meet"
    if owner is not None:
        memo = owner._memo
        if memo is not None and memo[0] is masks1 and memo[1] is masks2 and memo[2] == key:
            table = memo[3]
            if table is None:
                table = _pair_table(masks1, masks2, key)
                _set(owner, "_memo", (masks1, masks2, key, table))
            return _pair_from_table(model, kind, table, values1, values2)
        _set(owner, "_memo", (masks1, masks2, key, None))
    groups: dict = {}
    get = groups.get
    if kind == "join":
        for a, p in zip(masks1, values1):
            for b, q in zip(masks2, values2):
                c = a | b
                group = get(c)
                if group is None:
                    groups[c] = p * q           # one product: no list
                elif type(group) is float:
                    groups[c] = [group, p * q]
                else:
                    group.append(p * q)
    else:
        for a, p in zip(masks1, values1):
            for b, q in zip(masks2, values2):
                c = a & b
                group = get(c)
                if group is None:
                    groups[c] = p * q
                elif type(group) is float:
                    groups[c] = [group, p * q]
                else:
                    group.append(p * q)
    normalise = kind == "dempster" and 0 in groups
    if normalise:
        del groups[0]
    sums = [group if type(group) is float else group[0] + group[1] if len(group) == 2 else fsum(group)
            for group in groups.values()]
    return _pair_result(model, list(groups), sums, normalise, min(values1) * min(values2) > 0)


#: What :func:`_renormalised` rescales in the result of two sources.
_PAIR_REACH = 4 * SUM_TOLERANCE


def _pair_result(model: Model, focal: list, sums: list, normalise: bool, positive: bool) -> MassFunction | None:
    """The mass function of a pair's sums per target, final (see :func:`_pair_loop`).

    None where Dempster's normalisation would divide by a non-empty mass below
    :data:`WIDE_SCALE` (underflow or total conflict: the general path tells which).
    ``positive``: the product of the smallest masses of the two sources is positive.
    """
    scale = fsum(sums)
    if normalise:
        if not scale > WIDE_SCALE:
            return None
        sums = [x / scale for x in sums]
    elif RESULT_TOLERANCE < abs(scale - 1.0) <= _PAIR_REACH:
        sums = [x / scale for x in sums]
    # Masses are positive: if the product of the smallest two is, so is every product, every sum
    # and every quotient by a scale of at most 1 + _PAIR_REACH (rounding is monotone), and no
    # zero is dropped.
    if not positive and not all(x > 0 for x in sums):
        pairs = [(f, x) for f, x in zip(focal, sums) if x > 0]
        return MassFunction._from_masks(model, [f for f, _ in pairs], [x for _, x in pairs], True)
    return MassFunction._from_masks(model, focal, sums, True)


def _pair_table(masks1, masks2, key: str) -> tuple:
    """How the tuples of two focal lists group by target: the targets, the columns of each group's tuples, the sizes."""
    groups: dict[int, list[tuple[int, int]]] = {}
    for i, a in enumerate(masks1):
        for j, b in enumerate(masks2):
            groups.setdefault(a | b if key == "join" else a & b, []).append((i, j))
    focal = list(groups)
    rows = [i for group in groups.values() for i, _ in group]
    columns = [j for group in groups.values() for _, j in group]
    sizes = [len(group) for group in groups.values()]
    empty = focal.index(0) if 0 in groups else None
    return focal, rows, columns, sizes, empty


def _pair_from_table(model: Model, kind: str, table: tuple, values1, values2) -> MassFunction | None:
    """:func:`_pair_loop` on the grouping of :func:`_pair_table`: the same sums."""
    focal, rows, columns, sizes, empty = table
    products = [values1[i] * values2[j] for i, j in zip(rows, columns)]
    sums = []
    start = 0
    for size in sizes:
        if size == 1:
            sums.append(products[start])
        elif size == 2:
            sums.append(products[start] + products[start + 1])
        else:
            sums.append(fsum(products[start:start + size]))
        start += size
    focal = list(focal)
    normalise = kind == "dempster" and empty is not None
    if normalise:
        del focal[empty], sums[empty]
    return _pair_result(model, focal, sums, normalise, min(values1) * min(values2) > 0)


def _pcr_joint_loop(model: Model, rule: str, masks: list, values: list) -> MassFunction:
    """PCR5 / PCR6 of a few tuples of unions of hypotheses, in one Python loop over the tuples.

    A tuple whose focal elements meet gives its product to the intersection (the
    consensus); a conflicting one shares it among its elements, by the masses (PCR6) or
    by the product of the masses of each distinct element (PCR5).  What reaches one
    element is added by ``math.fsum``, so the result does not depend on the order of the
    focal elements and agrees with the plan's (consensus folded pairwise, then the
    shares) within a few units in the last place.
    """
    groups: dict = {}
    get = groups.get
    pcr5 = rule == "pcr5"

    def put(c, v):
        group = get(c)
        if group is None:
            groups[c] = v
        elif type(group) is float:
            groups[c] = [group, v]
        else:
            group.append(v)

    if len(masks) == 2:
        tuples = ((a, b, p, q) for a, p in zip(masks[0], values[0]) for b, q in zip(masks[1], values[1]))
        for a, b, p, q in tuples:
            product = p * q
            if a & b:
                put(a & b, product)
            else:                               # two distinct elements: PCR5 and PCR6 coincide
                factor = product / (p + q)
                put(a, factor * p)
                put(b, factor * q)
    else:
        for columns in _tuples([len(mk) for mk in masks]):
            elements = [mk[k] for mk, k in zip(masks, columns)]
            masses = [v[k] for v, k in zip(values, columns)]
            meet = -1
            for x in elements:
                meet &= x
            product = masses[0]
            for m in masses[1:]:
                product *= m
            if meet:
                put(meet, product)
                continue
            if pcr5:
                weights: dict = {}
                for x, m in zip(elements, masses):
                    weights[x] = weights[x] * m if x in weights else m
                total = 0.0
                for w in weights.values():
                    total += w
                factor = product / total
                for x, w in weights.items():
                    put(x, factor * w)
            else:
                total = 0.0
                for m in masses:
                    total += m
                factor = product / total
                for x, m in zip(elements, masses):
                    put(x, factor * m)
    focal = []
    sums = []
    for c, group in groups.items():
        x = group if type(group) is float else (group[0] + group[1] if len(group) == 2 else fsum(group))
        if x > 0:
            focal.append(c)
            sums.append(x)
    return MassFunction._from_masks(model, tuple(focal), tuple(sums), True)


def _single_result(model: Model, focal: list[int], row: list | np.ndarray) -> MassFunction:
    """The mass function of a result row, without its zero masses (as ``MassBatch.__getitem__``)."""
    if type(row) is list:
        if all(x > 0 for x in row):
            return MassFunction._from_masks(model, tuple(focal), tuple(row))
        pairs = [(f, x) for f, x in zip(focal, row) if x > 0]
        return MassFunction._from_masks(model, tuple([f for f, _ in pairs]), tuple([x for _, x in pairs]))
    if row.min() > 0:
        return MassFunction._from_masks(model, focal if type(focal) is tuple else tuple(focal),
                                        row if row.base is None else row.copy())
    kept = np.flatnonzero(row > 0)
    return MassFunction._from_masks(model, tuple([focal[i] for i in kept.tolist()]), row[kept])


def _single_to_total(model: Model, n: int, focal: list[int], row: np.ndarray) -> tuple[list[int], np.ndarray]:
    """Yager: the ∅ mass (first) added to total ignorance, as :func:`_move_empty` does."""
    total = sum(model.total.terms)
    new_focal = list(focal[1:])
    new_values = row[1:].copy()
    if total in new_focal:
        new_values[new_focal.index(total)] += row[0]
        return new_focal, new_values
    rank = union_ranks(n)[2]
    new_focal.append(total)
    new_values = np.append(new_values, row[0])
    order = sorted(range(len(new_focal)), key=lambda i: rank[new_focal[i]])
    return [new_focal[i] for i in order], new_values[order]


def _single_fold(n: int, masks: list, values: list, key: str,
                 budget: FoldBudget | None = None) -> tuple[list[int], list | np.ndarray] | None:
    """:func:`_fold` on masks: pairwise, the zero masses of each partial result dropped."""
    if budget is not None:
        budget.step(len(masks[0]), len(masks[1]), 2)
    out = _single_targets(n, masks[:2], values[:2], key)
    for number, (mk, v) in enumerate(zip(masks[2:], values[2:]), start=3):
        focal, row = _single_prune(*out)
        if budget is not None:
            budget.step(len(focal), len(mk), number)
        out = _single_targets(n, [tuple(focal), mk], [row, v], key)
    return _single_prune(*out) if len(masks) > 2 else out


def _single_prune(focal: list[int], row: list | np.ndarray) -> tuple[list[int], list | np.ndarray]:
    """:func:`_prune` of one row."""
    if type(row) is not np.ndarray:
        if all(x != 0 for x in row):
            return focal, row
        pairs = [(f, x) for f, x in zip(focal, row) if x != 0]
        return [f for f, _ in pairs], [x for _, x in pairs]
    live = np.flatnonzero(row)
    if live.size == len(focal):
        return focal, row
    return [focal[i] for i in live.tolist()], row[live]


def _single_seen(key: tuple, table) -> None:
    """Keep ``table`` if ``key`` was met before (its focal elements came back); else remember ``key``."""
    if _SINGLE_SIGHTINGS.pop(key, False):
        if len(_SINGLE_TABLES) >= SINGLE_CACHE_SIZE:
            evict(_SINGLE_TABLES)
        _SINGLE_TABLES[key] = table
        return
    if len(_SINGLE_SIGHTINGS) >= SINGLE_CACHE_SIZE:
        evict(_SINGLE_SIGHTINGS)
    _SINGLE_SIGHTINGS[key] = True


def _outer(values: Sequence[np.ndarray]) -> np.ndarray:
    """Π_i values[i][X_i] for every tuple, row-major, multiplied left to right as :func:`gather_product`."""
    if len(values) == 2:
        return np.multiply.outer(values[0], values[1]).ravel()
    s = len(values)
    out = values[0].reshape((-1,) + (1,) * (s - 1))
    for i, v in enumerate(values[1:], start=1):
        out = out * v.reshape((1,) * i + (-1,) + (1,) * (s - 1 - i))
    return out.ravel()


def _single_targets(n: int, masks: list, values: list, key: str) -> tuple[list[int], list | np.ndarray] | None:
    """Each tuple's product to one union of hypotheses: the targets in canonical order and their sums."""
    count = 1
    for mk in masks:
        count *= len(mk)
    if count <= SINGLE_LOOP_TUPLES:
        return _single_loop(n, masks, values, key)
    memo = (n, key, tuple(masks))
    table = _SINGLE_TABLES.get(memo)
    if table is None:
        table = _single_table(n, masks, key)
        if table is None:
            return None
        _single_seen(memo, table)
    order, starts, focal = table
    values = [v if type(v) is np.ndarray else np.array(v) for v in values]
    return focal, np.add.reduceat(_outer(values)[order], starts)


def _single_table(n: int, masks: list, key: str) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]] | None:
    """The order that sorts the tuples by target (stable), where each target's run starts, and the targets."""
    if len(masks) == 2 and key in ("meet", "join"):
        ufunc = np.bitwise_and if key == "meet" else np.bitwise_or
        codes = ufunc.outer(np.array(masks[0]), np.array(masks[1]))
    else:
        arrays = [np.array(mk, dtype=np.int64) for mk in masks]
        if key == "meet":
            codes = tuple_codes(arrays, np.bitwise_and)
        elif key == "join":
            codes = tuple_codes(arrays, np.bitwise_or)
        else:
            meet = tuple_codes(arrays, np.bitwise_and)
            join = tuple_codes(arrays, np.bitwise_or)
            if key == "dsmh" and not ((meet != 0) | (join != 0)).all():
                return None
            codes = np.where(meet != 0, meet, join)
    ranked = _narrow_ranks(n)[codes].ravel()
    order = ranked.argsort(kind="stable")
    sorted_ranks = ranked[order]
    step = np.empty(len(sorted_ranks), dtype=bool)
    step[0] = True
    np.not_equal(sorted_ranks[1:], sorted_ranks[:-1], out=step[1:])
    starts = step.nonzero()[0]
    return order, starts, tuple(union_ranks(n)[1][sorted_ranks[starts]].tolist())


@lru_cache(maxsize=None)
def _narrow_ranks(n: int) -> np.ndarray:
    """:func:`~belief.plan.union_ranks` in the narrowest unsigned type (small keys sort by radix)."""
    return union_ranks(n)[0].astype(np.uint8 if n <= 8 else np.uint16)


def _single_loop(n: int, masks: list, values: list, key: str) -> tuple[list[int], list[float]] | None:
    """:func:`_single_targets` for a few tuples, in Python, with numpy's order of additions (sums as a list)."""
    rows = [v if type(v) is not np.ndarray else v.tolist() for v in values]
    groups: dict[int, list[float]] = {}
    get = groups.get
    if len(masks) == 2 and key in ("meet", "join"):
        c1, c2 = masks
        v1, v2 = rows
        meet = key == "meet"
        for a, p in zip(c1, v1):
            for b, q in zip(c2, v2):
                c = a & b if meet else a | b
                group = get(c)
                if group is None:
                    groups[c] = [p * q]
                else:
                    group.append(p * q)
    else:
        for columns in _tuples([len(mk) for mk in masks]):
            meet = -1
            join = 0
            for mk, k in zip(masks, columns):
                meet &= mk[k]
                join |= mk[k]
            if key == "meet":
                c = meet
            elif key == "join":
                c = join
            else:
                c = meet or join
                if key == "dsmh" and not c:
                    return None
            p = rows[0][columns[0]]
            for row, k in zip(rows[1:], columns[1:]):
                p *= row[k]
            group = get(c)
            if group is None:
                groups[c] = [p]
            else:
                group.append(p)
    focal = sorted(groups, key=union_ranks(n)[2].__getitem__)
    sums = []
    for c in focal:
        group = groups[c]
        sums.append(group[0] if len(group) == 1 else _segment_sum(group))
    return focal, sums


def _single_pcr(model: Model, n: int, masks: list, values: list, rule: str) -> MassFunction:
    """PCR5 / PCR6 of mass functions of unions of hypotheses: :func:`_pcr` on masks."""
    focal, consensus = _single_fold(n, masks, values, "meet")
    rank = union_ranks(n)[2]
    count = 1
    for mk in masks:
        count *= len(mk)
    memo = (n, rule, tuple(masks))
    tables = _SINGLE_TABLES.get(memo)
    if tables is None and count <= PCR_LOOP_TUPLES:
        targets, shares = _pcr_loop(masks, [v if type(v) is not np.ndarray else v.tolist() for v in values], rule,
                                    rank.__getitem__)
    else:
        if tables is None:
            tables = _single_pcr_tables(n, masks, rule)
            _single_seen(memo, tables)
        targets, shares = _pcr_share_values(1, [np.asarray(v).reshape(1, -1) for v in values], tables)
    # _add: the consensus without ∅, plus the shares.
    keep = [i for i, x in enumerate(focal) if x]
    union = sorted({focal[i] for i in keep} | set(targets), key=rank.__getitem__)
    index = {x: k for k, x in enumerate(union)}
    out = np.zeros((1, len(union)))
    out[:, [index[focal[i]] for i in keep]] += np.asarray(consensus)[keep]
    out[:, [index[x] for x in targets]] += shares
    return _single_result(model, union, out[0])


def _single_pcr_tables(n: int, masks: list, rule: str):
    """:func:`_pcr_tables` of mass functions of unions of hypotheses."""
    arrays = [np.array(mk, dtype=np.int64) for mk in masks]
    conflict = np.flatnonzero(tuple_codes(arrays, np.bitwise_and) == 0)
    columns = tuple(c.astype(np.int64, copy=False) for c in np.unravel_index(conflict, [len(mk) for mk in masks]))
    rank = union_ranks(n)[2]
    unique = sorted({x for mk in masks for x in mk}, key=rank.__getitem__)
    index = {x: k for k, x in enumerate(unique)}
    per_source = [np.array([index[x] for x in mk], dtype=np.int64) for mk in masks]
    return _pcr_tables(columns, unique, per_source, rule, ranked=True)


# -- the rules ----------------------------------------------------------------------------------------
@register_rule("conjunctive", summary="unnormalised conjunctive rule (Smets' TBM); conflict stays on ∅",
               associative=True, keeps_conflict=True, aliases=("smets", "tbm", "unnormalized"))
def conjunctive(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """m(A) = Σ_{X_1∩…∩X_s=A} Π m_i(X_i), with the products of empty intersections on ∅ (W (2))."""
    return _fold(sources, model, "meet", "conjunctive")


@register_rule("dsmc", summary="classic DSm rule: conjunctive on D^Θ (no conflict on the free model)",
               associative=True, keeps_conflict=True, aliases=("dsm_classic",))
def dsmc(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """The classic DSm rule W (2): the conjunctive consensus on the hyper-power set.

    On the free model no intersection is empty, so the result carries no conflict.  Under
    a hybrid model (such as the tracking model of SPEC Part D, where it is the ``table``
    rule) the products that land on an empty intersection stay on ∅.
    """
    return _fold(sources, model, "meet", "dsmc")


@register_rule("dempster", summary="Dempster's rule: conjunctive, renormalised by 1 - conflict",
               associative=True, aliases=("ds", "dempster_shafer"))
def dempster(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """m(A) = m∩(A) / Σ_{B≠∅} m∩(B) for A ≠ ∅ (SPEC A.3).

    The denominator is the sum of the non-empty masses rather than 1 - K, so that a
    conflict K close to one still yields masses that sum to one.
    """
    result = _move_empty(_fold(sources, model, "meet", "dempster"), None, model, "dempster")
    return result if result is not None else _wide_dempster(sources, model)


#: Dempster's rule normalises by the non-empty mass; below this, products that underflowed may matter,
#: and the combination is made again with exponents kept apart (:func:`_wide_dempster`).
WIDE_SCALE = 2.0 ** -40
#: The exponent of a zero mass in :func:`_wide_dempster`: below any sum of real exponents.
_ZERO_EXPONENT = -(1 << 40)


def _split(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Masses as mantissas in [½, 1) and int64 exponents (zeros get :data:`_ZERO_EXPONENT`)."""
    mantissas, exponents = np.frexp(values)
    exponents = exponents.astype(np.int64)
    exponents[mantissas == 0] = _ZERO_EXPONENT
    return mantissas, exponents


def _wide_dempster(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """Dempster's rule where the non-empty mass is tiny: products kept as mantissa × 2^exponent, never underflowing.

    Each pairwise step multiplies mantissas and adds exponents, drops the products that
    reach ∅, and sums each target's products scaled to the largest of them, so that a sum
    loses only what is below 2^-1074 of itself.  The final rows are scaled to their
    largest mass and normalised.  Total conflict is reported only when every product
    that reaches a non-empty element has a zero factor, that is when K = 1 exactly.
    """
    n, values = _values(sources)
    parts = [_split(v) for v in values]
    mantissas, exponents = parts[0]
    focal = sources[0].focal
    source_model = sources[0].model
    for b, (m2, e2) in zip(sources[1:], parts[1:]):
        if b.model != model:
            b = b.under(model)
            m2, e2 = _split(b.values if len(b) == n else np.broadcast_to(b.values, (n, len(b.focal))))
        plan = tuple_plan(source_model, model, (tuple(focal), b.focal))
        scatter, (c1, c2) = _kernel(plan, "meet")
        product = mantissas.take(c1, axis=1) * m2.take(c2, axis=1)        # in [¼, 1): no underflow
        exponent = exponents.take(c1, axis=1) + e2.take(c2, axis=1)
        top = np.maximum.reduceat(exponent, scatter.starts, axis=1)
        runs = np.diff(np.append(scatter.starts, exponent.shape[1]))
        shift = np.maximum(exponent - np.repeat(top, runs, axis=1), -1100)
        sums = np.add.reduceat(np.ldexp(product, shift.astype(np.int32)), scatter.starts, axis=1)
        mantissas, exponents = _split(sums)
        exponents = np.where(mantissas == 0, _ZERO_EXPONENT, exponents + top)
        keep = [i for i, e in enumerate(scatter.elements) if e.terms]
        focal = tuple(scatter.elements[i] for i in keep)
        mantissas, exponents = mantissas[:, keep], exponents[:, keep]
        source_model = model
    top = exponents.max(axis=1, initial=_ZERO_EXPONENT)
    dead = top <= _ZERO_EXPONENT // 2
    if dead.any():
        row = int(np.flatnonzero(dead)[0])
        where = f" (row {row})" if n > 1 else ""
        raise TotalConflictError(f"dempster: total conflict between the sources{where}, m(∅) = 1; "
                                 "Dempster's rule is undefined (try yager, dubois_prade, dsmh or pcr6)")
    scaled = np.ldexp(mantissas, np.maximum(exponents - top[:, None], -1100).astype(np.int32))
    out = scaled / scaled.sum(axis=1)[:, None]
    return _prune(MassBatch._trusted(model, focal, out, canonical=True))


@register_rule("disjunctive", summary="disjunctive rule: products go to the union of the focal elements",
               associative=True, keeps_conflict=True, aliases=("union",))
def disjunctive(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """m(A) = Σ_{X_1∪…∪X_s=A} Π m_i(X_i) (Dubois & Prade 1986; Smets 1993)."""
    return _fold(sources, model, "join", "disjunctive")


@register_rule("yager", summary="Yager's rule: the conflict goes to total ignorance",
               associative=False)
def yager(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """m(A) = m∩(A) for ∅ ≠ A ≠ Θ and m(Θ) = m∩(Θ) + m∩(∅) (Yager 1987)."""
    _require_normal(sources, "yager")
    return _move_empty(_fold(sources, model, "meet", "yager"), model.total, model, "yager")


@register_rule("dubois_prade", summary="Dubois–Prade: each conflicting product goes to the union of its elements",
               associative=False, keeps_conflict=True, aliases=("dp", "duboisprade"))
def dubois_prade(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """m(A) = Σ_{∩X_i=A} Π m_i(X_i) + Σ_{∩X_i=∅, ∪X_i=A} Π m_i(X_i), jointly over s sources.

    Under dynamic fusion a product whose union is empty in the fusion model has no
    element to go to; as the formula says, it stays on ∅ (DSmH places it instead).
    """
    _require_normal(sources, "dubois_prade")
    _check_joint(sources, model, "dubois_prade", "targets")
    return _tuple_targets_rule(sources, model, "dubois_prade")


@register_rule("dsmh", summary="hybrid DSm rule (S1 + S2 + S3), static or dynamic",
               associative=False, aliases=("hybrid", "dsm_hybrid"))
def dsmh(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """The hybrid DSm rule, m(A) = φ(A)[S1(A) + S2(A) + S3(A)], jointly over s sources.

    Each tuple's product goes to its intersection if that is non-empty under the fusion
    model (S1); else to the union of its elements (S3); and if every element of the tuple
    is empty under the fusion model, to u(X_1) ∪ … ∪ u(X_s), where u(X) is the union of
    the hypotheses that make up X, or to total ignorance if that is empty too (S2)
    (Smarandache & Dezert, Advances and Applications of DSmT, vol. 1, ch. 4).
    """
    _require_normal(sources, "dsmh")
    _check_joint(sources, model, "dsmh", "targets")
    return _tuple_targets_rule(sources, model, "dsmh")


def _pcr(sources: Sequence[MassBatch], model: Model, rule: str) -> MassBatch:
    """Consensus (the conjunctive rule without ∅) plus the redistribution of every conflicting tuple."""
    _require_normal(sources, rule)
    _check_joint(sources, model, rule, "pcr")
    direct = _direct(sources, model, "pcr")
    if direct is not None:
        _require_nonempty([b.focal for b in sources], direct.projected, model, rule)
        consensus = _fold(sources, model, "meet")
        if direct.loop:
            elements, shares = _loop_pcr(sources, direct, rule)
        else:
            elements, shares = _pcr_shares(sources, _array_pcr_tables(direct, rule))
        return _add(model, consensus, elements, shares)
    plan = _plan(sources, model, rule)
    _require_nonempty(plan.focal, plan.projected, model, rule)
    consensus = _fold(sources, model, "meet")
    elements, shares = _pcr_shares(sources, _pcr_kernel(plan, rule))
    return _add(model, consensus, elements, shares)


def _pcr_shares(sources: Sequence[MassBatch], tables) -> tuple[tuple[Element, ...], np.ndarray]:
    """The conflict each element gets back, from the tables of :func:`_pcr_tables`."""
    n, values = _values(sources)
    return _pcr_share_values(n, values, tables)


def _pcr_share_values(n: int, values: Sequence[np.ndarray], tables) -> tuple[tuple, np.ndarray]:
    """:func:`_pcr_shares` on the sources' (n, K_i) arrays."""
    scatter, columns, positions, representative = tables
    s = len(values)
    count = len(columns[0])
    shares = np.empty((n, len(scatter.elements)))
    for rows in row_chunks(n, count * (s + 2)):
        masses = [np.take(v[rows], c, axis=1) for v, c in zip(values, columns)]      # each (n, Tc)
        product = masses[0].copy()
        for m in masses[1:]:
            product *= m
        if representative is None:                      # PCR6: weight m_i(X_i)
            weights = masses
        else:                                           # PCR5: product of each group's masses, on its first slot
            weights = []
            for j in range(s):
                w = np.broadcast_to((representative[:, j] == j).astype(np.float64), product.shape).copy()
                for i in range(j, s):
                    member = representative[:, i] == j
                    if member.any():
                        w[:, member] *= masses[i][:, member]
                weights.append(w)
        total = weights[0].copy()
        for w in weights[1:]:
            total += w
        factor = np.divide(product, total, out=np.zeros_like(product), where=total > 0)
        entries = np.empty((product.shape[0], count * s))
        for i in range(s):
            entries[:, positions[i]] = factor * weights[i]
        shares[rows] = scatter.apply(entries)
    return scatter.elements, shares


def _loop_pcr(sources: Sequence[MassBatch], direct: _Direct, rule: str) -> tuple[tuple[Element, ...], np.ndarray]:
    """:func:`_pcr_shares` for one row and a few tuples, in plain Python, with the same operations in the same order."""
    element_of: dict[int, Element] = {}
    for source_codes, projected in zip(direct.encoding.codes, direct.projected):
        for c, x in zip(source_codes, projected):
            element_of.setdefault(c, x)
    codes, shares = _pcr_loop(direct.encoding.codes, [b.values[0].tolist() for b in sources], rule,
                              lambda c: element_of[c].sort_key)
    return tuple(element_of[c] for c in codes), shares


def _pcr_loop(codes: Sequence[Sequence[int]], rows: Sequence[list[float]], rule: str,
              key) -> tuple[list[int], np.ndarray]:
    """The conflict shares of one row: the targets' codes in canonical order (``key``) and their (1, E) sums.

    ``codes`` identify the sources' focal elements (equal codes, equal elements; ∩ is ``&``).
    """
    s = len(codes)
    entries: list[list[tuple[int, float]]] = [[] for _ in range(s)]
    pcr5 = rule == "pcr5"
    for columns in _tuples([len(c) for c in codes]):
        meet = -1
        for c, k in zip(codes, columns):
            meet &= c[k]
        if meet:
            continue
        masses = [row[k] for row, k in zip(rows, columns)]
        prod = masses[0]
        for m in masses[1:]:
            prod *= m
        targets = [c[k] for c, k in zip(codes, columns)]
        if pcr5:
            weights = []
            for j in range(s):
                w = 1.0 if targets.index(targets[j]) == j else 0.0
                if w:
                    for i in range(j, s):
                        if targets[i] == targets[j]:
                            w *= masses[i]
                weights.append(w)
        else:
            weights = masses
        total = weights[0]
        for w in weights[1:]:
            total += w
        factor = prod / total if total > 0 else 0.0
        for i in range(s):
            entries[i].append((targets[i], factor * weights[i]))
    groups: dict[int, list[float]] = {}
    for slot in entries:
        for target, value in slot:
            group = groups.get(target)
            if group is None:
                groups[target] = [value]
            else:
                group.append(value)
    present = sorted(groups, key=key)
    return present, np.array([[_segment_sum(groups[c]) for c in present]])


def _add(model: Model, base: MassBatch, elements: Sequence[Element], values: np.ndarray) -> MassBatch:
    """``base`` without its ∅ column, plus ``values`` over ``elements``, as one batch."""
    keep = [i for i, e in enumerate(base.focal) if e.terms]
    focal = sorted({base.focal[i] for i in keep} | set(elements), key=lambda e: e.sort_key)
    index = {e: k for k, e in enumerate(focal)}
    out = np.zeros((max(len(base), len(values)), len(focal)))
    out[:, [index[base.focal[i]] for i in keep]] += base.values[:, keep]
    out[:, [index[e] for e in elements]] += values
    return MassBatch._trusted(model, tuple(focal), out, canonical=True)


@lru_cache(maxsize=512)
def _pcr_kernel(plan: TuplePlan, rule: str):
    """:func:`_pcr_tables` of a plan (cached with it)."""
    conflict = np.flatnonzero(plan.conflicting)
    unique, per_source = _element_codes(plan)
    return _pcr_tables(tuple(c[conflict] for c in plan.columns), unique, per_source, rule)


def _array_pcr_tables(direct: _Direct, rule: str):
    """:func:`_pcr_tables` from the codes of the direct path (no plan)."""
    arrays = [np.array(c, dtype=np.uint64) for c in direct.encoding.codes]
    conflict = np.flatnonzero(tuple_codes(arrays, np.bitwise_and) == 0)
    columns = tuple(c.astype(np.int64, copy=False) for c in np.unravel_index(conflict, direct.sizes))
    index: dict[int, int] = {}
    unique: list[Element] = []
    per_source = []
    for source_codes, projected in zip(direct.encoding.codes, direct.projected):
        row = []
        for c, x in zip(source_codes, projected):
            k = index.get(c)
            if k is None:
                k = index[c] = len(unique)
                unique.append(x)
            row.append(k)
        per_source.append(np.array(row, dtype=np.int64))
    return _pcr_tables(columns, unique, per_source, rule)


def _pcr_tables(columns: tuple[np.ndarray, ...], unique: list, per_source: list[np.ndarray], rule: str,
                ranked: bool = False):
    """Tables for redistributing the conflicting tuples.

    ``columns`` holds each source's column at every conflicting tuple, ``unique`` the
    distinct focal elements under the fusion model and ``per_source`` the index of each
    source's focal elements into it.  Returns the scatter over (conflicting tuple, slot)
    entries, the columns, the positions of each slot's entries in scatter order, and
    (PCR5) the group representative of every slot.  With ``ranked``, ``unique`` is in
    canonical order already (its items need not be elements).
    """
    s = len(columns)
    size = len(columns[0])
    slot_codes = [per_source[i][columns[i]] for i in range(s)]          # each (Tc,)
    codes = np.concatenate(slot_codes) if s else np.zeros(0, np.int64)
    scatter = Scatter.from_ranks(unique, codes) if ranked else Scatter.from_codes(unique, codes)
    total = size * s
    rank = np.empty(total, dtype=np.int64)
    rank[scatter.order] = np.arange(total)
    positions = tuple(rank[i * size:(i + 1) * size] for i in range(s))
    representative = None
    if rule == "pcr5":
        # rep[t, i]: the first slot of tuple t whose element equals slot i's element.
        representative = np.empty((size, s), dtype=np.int64)
        for i in range(s):
            rep = np.full(size, i, dtype=np.int64)
            for j in range(i - 1, -1, -1):
                rep = np.where(slot_codes[j] == slot_codes[i], j, rep)
            representative[:, i] = rep
    return scatter, columns, positions, representative


def _element_codes(plan: TuplePlan) -> tuple[list[Element], list[np.ndarray]]:
    """The distinct projected focal elements of all sources, and per source the code of each column."""
    index: dict[Element, int] = {}
    per_source = [np.array([index.setdefault(x, len(index)) for x in elements], dtype=np.int64)
                  for elements in plan.projected]
    return list(index), per_source


@register_rule("pcr5", summary="PCR5: conflicting products go back to the elements involved, by mass products",
               associative=False)
def pcr5(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """Proportional conflict redistribution rule no. 5, joint s-source form.

    Each conflicting product Π m_i(X_i) is shared among the distinct elements of the
    tuple in proportion to the product of the masses that the sources committed to each:
    element Y gets Π m_i(X_i) · P_Y / Σ_Z P_Z with P_Y = Π_{i: X_i = Y} m_i(Y).  This is
    the general PCR5 formula of Smarandache & Dezert (Advances and Applications of DSmT,
    vol. 2, ch. 1, 2006), in the focal-element form of Dezert, Dezert & Smarandache
    (JAIF 2021, eq. 14); for two sources it reduces to SPEC A.3.
    """
    return _pcr(sources, model, "pcr5")


@register_rule("pcr6", summary="PCR6: each source's element gets back a share proportional to its mass",
               associative=False)
def pcr6(sources: Sequence[MassBatch], model: Model) -> MassBatch:
    """Proportional conflict redistribution rule no. 6 (Martin & Osswald, 2006), joint s-source form.

    Each conflicting product Π m_i(X_i) goes back to every X_i in proportion to m_i(X_i):
    X_i gets Π_j m_j(X_j) · m_i(X_i) / Σ_j m_j(X_j); shares reaching the same element add
    up (Dezert & Smarandache, An introduction to DSmT, 2009, eqs. 16–17).  Equals PCR5
    for two sources.
    """
    return _pcr(sources, model, "pcr6")


#: The built-in rules that :func:`_single` evaluates, by function (a rule registered anew under a name keeps its own).
_SINGLE_RULES: dict[Callable, str] = {conjunctive: "meet", dsmc: "meet", dempster: "dempster", disjunctive: "join",
                                      yager: "yager", dubois_prade: "dubois_prade", dsmh: "dsmh", pcr5: "pcr5",
                                      pcr6: "pcr6"}


# -- the R-weighted rule (SPEC A.4) ----------------------------------------------------------------
#: The values of the R-weighted rule's ``r_mode`` (how W (10) measures R) and ``empty_mode`` (SPEC A.4).
R_MODES = ("paper", "euclid", "jousselme")
EMPTY_MODES = ("union", "empty")


@register_rule("r_rule", summary="R-weighted local-conflict rule of the DSmT tracking paper, folded in source order",
               associative=False, keeps_conflict=True, aliases=("r", "rrule", "wang"),
               options=("r_mode", "empty_mode"))
def r_rule(sources: Sequence[MassBatch], model: Model, r_mode: str = "paper", empty_mode: str = "union") -> MassBatch:
    """The R-weighted conflict rule of SPEC A.4 (W (10)–(14) with the missing W (12′)).

    Two sources: the inconsistency R ∈ [0, 1] (W (10); ``r_mode`` "paper" as printed,
    "euclid", or "jousselme") splits each local conflict k of a pair {A, B} (W (11)):
    R·k stays on A ∩ B (W (14)), or, when A ∩ B is empty under the model, goes to A ∪ B
    (``empty_mode="union"``) or to ∅ (``"empty"``); (1 - R)·k goes to A, B and A ∪ B in
    proportion to m0, Dempster's combination of the sources' Shafer projections (W (12),
    (12′), (13)).  More sources are folded in the given order: the rule is not associative.
    """
    _check_r_options(r_mode, empty_mode)
    _require_normal(sources, "r_rule")
    for k, b in enumerate(sources, start=1):
        _require_kept(b, model, "r_rule", k)
    # Read every source under the fusion model first, so that elements it identifies are merged.
    mapped = [b if b.model == model else b.under(model) for b in sources]
    budget = FoldBudget("r_rule", len(mapped), max(len(b) for b in mapped), False,
                        "the R-weighted rule sorts its pairs in Python")
    result = mapped[0]
    for number, b in enumerate(mapped[1:], start=2):
        budget.step(len(result.focal), len(b.focal), number)
        result = _r_pair(result, b, model, r_mode, empty_mode)
    return result


def _check_r_options(r_mode: str = "paper", empty_mode: str = "union") -> None:
    if r_mode not in R_MODES:
        raise InvalidMassError(f"r_mode must be one of {', '.join(R_MODES)}, got {r_mode!r}")
    if empty_mode not in EMPTY_MODES:
        raise InvalidMassError(f"empty_mode must be one of {', '.join(EMPTY_MODES)}, got {empty_mode!r}")


def _shafer_projection(element: Element) -> int:
    """π0(X) as a bit mask of hypotheses: the singleton regions of X (SPEC A.2)."""
    mask = 0
    for t in element.terms:
        if t.bit_count() == 1:
            mask |= t
    return mask


@dataclass(frozen=True, eq=False)
class _RPlan:
    """Index tables of the R-weighted rule for one pair of focal-element lists."""

    consensus: tuple[np.ndarray, np.ndarray]   # source columns of the consensus tuples
    scatter: Scatter                           # targets of [consensus tuples | kept, A, B, A∪B of every pair]
    consensus_positions: np.ndarray            # where the consensus entries sit in scatter order
    conflict: tuple[np.ndarray, np.ndarray]    # source columns of conflicting tuples, sorted by pair
    pair_starts: np.ndarray                    # where each pair's run starts, shape (C,)
    projection: tuple[np.ndarray, np.ndarray]  # tuples whose Shafer projections meet, sorted by that meet
    projection_starts: np.ndarray              # shape (P,)
    m0_index: np.ndarray                       # (C, 3): m0 column of π0(A), π0(B), π0(A∪B), or P if none
    support: tuple[np.ndarray, np.ndarray]     # (C, 3): columns of A, B, A∪B in each source, or K_i if absent
    pair_positions: tuple[np.ndarray, ...]     # four (C,) arrays: where each slot's entries sit in scatter order
    aligned: tuple[np.ndarray, np.ndarray]     # columns of the union of focal elements in each source, or K_i
    union_focal: tuple[Element, ...]


def _grouped(codes: list[int], columns: tuple[np.ndarray, ...]):
    """Columns sorted by code, and the start of each code's run."""
    codes_array = np.array(codes, dtype=np.int64)
    order = np.argsort(codes_array, kind="stable")
    sorted_codes = codes_array[order]
    starts = np.flatnonzero(np.r_[True, sorted_codes[1:] != sorted_codes[:-1]]) if len(codes) else np.zeros(0, np.int64)
    return tuple(c[order] for c in columns), starts


@lru_cache(maxsize=512)
def _r_plan(plan: TuplePlan, empty_mode: str) -> _RPlan:
    model = plan.model
    first, second = plan.projected
    c1, c2 = plan.columns
    pairs: dict[frozenset, int] = {}
    pair_elements: list[tuple[Element, Element]] = []
    consensus, consensus_targets = [], []
    conflict, conflict_pair = [], []
    projected, projected_key = [], []
    keys: dict[int, int] = {}
    for t, (i, j) in enumerate(plan.tuples):
        x, y, z = first[i], second[j], plan.meets[t]
        px, py = _shafer_projection(x), _shafer_projection(y)
        if px & py:
            projected.append(t)
            projected_key.append(keys.setdefault(px & py, len(keys)))
        if not x.terms or not y.terms:
            is_conflict = False                      # ∅ carried by a running result stays on ∅
        elif not z.terms:
            is_conflict = True
        elif x <= y or y <= x:
            is_conflict = False
        else:
            is_conflict = bool(px and py and not px & py)   # paradox: distinct singletons that may overlap
        if is_conflict:
            key = frozenset((x, y))
            if key not in pairs:
                pairs[key] = len(pairs)
                pair_elements.append((x, y))
            conflict.append(t)
            conflict_pair.append(pairs[key])
        else:
            consensus.append(t)
            consensus_targets.append(z)
    cons = np.array(consensus, dtype=np.int64)
    conflict_columns, pair_starts = _grouped(conflict_pair, (c1[conflict], c2[conflict]))
    projection_columns, projection_starts = _grouped(projected_key, (c1[projected], c2[projected]))
    n_pairs = len(pairs)
    m0_index = np.full((n_pairs, 3), len(keys), dtype=np.int64)
    columns1 = {e: c for c, e in enumerate(first)}
    columns2 = {e: c for c, e in enumerate(second)}
    support1 = np.full((n_pairs, 3), len(first), dtype=np.int64)
    support2 = np.full((n_pairs, 3), len(second), dtype=np.int64)
    slot_targets: list[list[Element]] = [[], [], [], []]
    for c, (a, b) in enumerate(pair_elements):
        union = model.reduce(a | b)
        meet = model.reduce(a & b)
        kept = meet if meet.terms else (union if empty_mode == "union" else model.frame.empty)
        for slot, e in enumerate((kept, a, b, union)):
            slot_targets[slot].append(e)
        for slot, e in enumerate((a, b, union)):
            p = _shafer_projection(e)
            if p in keys:
                m0_index[c, slot] = keys[p]
            support1[c, slot] = columns1.get(e, len(first))
            support2[c, slot] = columns2.get(e, len(second))
    n_cons = len(consensus)
    scatter = Scatter(consensus_targets + [e for slot in slot_targets for e in slot])
    rank = np.empty(n_cons + 4 * n_pairs, dtype=np.int64)
    rank[scatter.order] = np.arange(rank.size)
    consensus_positions = rank[:n_cons]
    positions = tuple(rank[n_cons + slot * n_pairs:n_cons + (slot + 1) * n_pairs] for slot in range(4))
    union_focal = tuple(sorted(set(first) | set(second), key=lambda e: e.sort_key))
    aligned = (np.array([columns1.get(e, len(first)) for e in union_focal], dtype=np.int64),
               np.array([columns2.get(e, len(second)) for e in union_focal], dtype=np.int64))
    return _RPlan((c1[cons], c2[cons]), scatter, consensus_positions, conflict_columns, pair_starts,
                  projection_columns, projection_starts, m0_index, (support1, support2), positions, aligned,
                  union_focal)


def inconsistency(first, second, *aligned, r_mode: str = "paper") -> np.ndarray:
    """The inconsistency R of W (10) between two batches, row by row, shape (N,).

    ``paper``: R = sqrt(Σ_A |m1(A) - m2(A)| / 2) as printed; ``euclid``:
    sqrt(½ Σ_A (m1(A) - m2(A))²); ``jousselme``: sqrt(½ Δᵀ D Δ) with D_AB = C(A∩B)/C(A∪B)
    (SPEC A.4).  The sums run over the focal elements of either batch.

    For Bayesian batches on the models of :func:`~belief.bayesian.exclusive_split` this costs
    O(n) per row whatever the mode: between singletons D is 1/3 for two free hypotheses and
    0 otherwise off the diagonal.

    ``paper`` gives exactly R = 1 when no element has mass in both rows (disjoint focal
    sets, SPEC A.4), whatever the rounding of the sum: the rule is discontinuous where m0
    vanishes, so a spurious (1 - R)·k of 1e-17 would change later folds.

    Parameters
    ----------
    first, second : MassBatch or MassFunction
        Under one model; a one-row batch (or a mass function) is broadcast.  For rows
        already aligned on a common focal list, pass two ndarrays of shape (N, K) followed
        by the focal elements and the model: ``inconsistency(m1, m2, focal, model)``.
    r_mode : {"paper", "euclid", "jousselme"}
        May also be given as the third positional argument.

    Returns
    -------
    ndarray, shape (N,)

    Raises
    ------
    InvalidMassError
        For an unknown ``r_mode``, or batches of different numbers of rows.
    FrameError, ModelError
        For batches of different frames or models.

    Examples
    --------
    SPEC A.4: paper R = 0.632 and euclid R = 0.400.

    >>> from belief import MassBatch, Model
    >>> model = Model.for_targets(2)
    >>> a = MassBatch.bayesian([0.6, 0.3, 0.1], model=model)
    >>> b = MassBatch.bayesian([0.2, 0.7, 0.1], model=model)
    >>> inconsistency(a, b).round(4), inconsistency(a, b, r_mode="euclid").round(4)
    (array([0.6325]), array([0.4]))
    """
    if isinstance(first, np.ndarray) or isinstance(second, np.ndarray):
        if len(aligned) not in (2, 3):
            raise InvalidMassError("aligned arrays need the focal elements and the model: "
                                   "inconsistency(m1, m2, focal, model[, r_mode])")
        if len(aligned) == 3:
            r_mode = aligned[2]
        _check_r_options(r_mode)
        return _aligned_inconsistency(np.asarray(first, dtype=np.float64), np.asarray(second, dtype=np.float64),
                                      aligned[0], aligned[1], r_mode)[0]
    if len(aligned) > 1:
        raise TypeError("inconsistency(first, second, r_mode) takes at most three positional arguments for batches")
    if aligned:
        r_mode = aligned[0]
    _check_r_options(r_mode)
    (b1, b2), model, _ = _prepare([first, second], None)
    n = max(len(b1), len(b2))
    split = bayesian.exclusive_split(model)
    layouts = [bayesian._layout(b.focal_key) for b in (b1, b2)]
    if split is not None and all(layout is not None and layout.empty is None for layout in layouts):
        m1, m2 = (np.broadcast_to(bayesian._dense(b, layout, split.size)[0], (n, split.size))
                  for b, layout in zip((b1, b2), layouts))
        return bayesian.bayesian_inconsistency(m1, m2, split, r_mode)
    focal = tuple(sorted(set(b1.focal) | set(b2.focal), key=lambda e: e.sort_key))
    index1 = {e: i for i, e in enumerate(b1.focal)}
    index2 = {e: i for i, e in enumerate(b2.focal)}
    p1, p2 = _padded(b1.values), _padded(b2.values)
    v1 = np.take(p1, [index1.get(e, len(b1.focal)) for e in focal], axis=1)
    v2 = np.take(p2, [index2.get(e, len(b2.focal)) for e in focal], axis=1)
    return _aligned_inconsistency(np.broadcast_to(v1, (n, len(focal))), np.broadcast_to(v2, (n, len(focal))),
                                  focal, model, r_mode)[0]


def _aligned_inconsistency(m1: np.ndarray, m2: np.ndarray, focal: Sequence[Element], model: Model,
                           r_mode: str = "paper") -> tuple[np.ndarray, np.ndarray]:
    """R of W (10) between rows of two arrays aligned on ``focal``, and 1 − R; shapes (N,)."""
    def jousselme(delta: np.ndarray) -> np.ndarray:
        matrix = _jousselme_matrix(model, tuple(focal))
        return 0.5 * np.einsum("na,ab,nb->n", delta, matrix, delta)

    return bayesian.aligned_inconsistency(m1, m2, r_mode, jousselme)


@lru_cache(maxsize=256)
def _jousselme_matrix(model: Model, focal: tuple[Element, ...]) -> np.ndarray:
    size = len(focal)
    matrix = np.zeros((size, size))
    for a in range(size):
        for b in range(size):
            union = model.cardinality(focal[a] | focal[b])
            matrix[a, b] = model.cardinality(focal[a] & focal[b]) / union if union else 0.0
    return matrix


def _padded(values: np.ndarray) -> np.ndarray:
    """values with a column of zeros appended (index K stands for "absent")."""
    return np.concatenate([values, np.zeros((values.shape[0], 1))], axis=1)


def _r_pair(b1: MassBatch, b2: MassBatch, model: Model, r_mode: str, empty_mode: str) -> MassBatch:
    plan = _plan([b1, b2], model)
    rp = _r_plan(plan, empty_mode)
    n, (v1, v2) = _values([b1, b2])
    out = np.empty((n, len(rp.scatter.elements)))
    width = len(rp.consensus_positions) + 4 * len(rp.pair_starts)
    for rows in row_chunks(n, plan.count + width):
        out[rows] = rp.scatter.apply(_r_pair_entries(rp, v1[rows], v2[rows], model, r_mode, width))
    return _prune(MassBatch._trusted(model, rp.scatter.elements, out, canonical=True))


def _r_pair_entries(rp: _RPlan, v1: np.ndarray, v2: np.ndarray, model: Model, r_mode: str,
                    width: int) -> np.ndarray:
    """Every contribution of some rows, in scatter order: consensus products and shared local conflicts."""
    n = v1.shape[0]
    entries = np.empty((n, width))
    entries[:, rp.consensus_positions] = gather_product([v1, v2], rp.consensus)
    n_pairs = len(rp.pair_starts)
    if not n_pairs:
        return entries
    p1, p2 = _padded(v1), _padded(v2)
    r, rho = _aligned_inconsistency(np.take(p1, rp.aligned[0], axis=1), np.take(p2, rp.aligned[1], axis=1),
                                    rp.union_focal, model, r_mode)                       # W (10)
    k = np.add.reduceat(gather_product([v1, v2], rp.conflict), rp.pair_starts, axis=1)   # W (11)
    if len(rp.projection_starts):
        m0 = _padded(np.add.reduceat(gather_product([v1, v2], rp.projection), rp.projection_starts, axis=1))
    else:
        m0 = np.zeros((n, 1))
    weights = [np.take(m0, rp.m0_index[:, slot], axis=1) for slot in range(3)]
    total = weights[0] + weights[1] + weights[2]
    missing = ~(total > 0)
    if missing.any():
        # SPEC A.4: weight by the sources' own support of A, B and A ∪ B; failing that, all to A ∪ B.
        cols = np.flatnonzero(missing.any(axis=0))
        sub = missing[:, cols]
        support = [np.take(p1, rp.support[0][cols, slot], axis=1) + np.take(p2, rp.support[1][cols, slot], axis=1)
                   for slot in range(3)]
        for slot in range(3):
            weights[slot][:, cols] = np.where(sub, support[slot], weights[slot][:, cols])
        sub_total = weights[0][:, cols] + weights[1][:, cols] + weights[2][:, cols]
        none = ~(sub_total > 0)
        if none.any():
            weights[2][:, cols] = np.where(none, 1.0, weights[2][:, cols])
            sub_total = np.where(none, 1.0, sub_total)
        total[:, cols] = sub_total
    # (1 - R)·k·w/Σw, with the ratio taken first: w ≤ Σw, so a subnormal Σw cannot overflow k/Σw.
    share = k * rho[:, None]
    entries[:, rp.pair_positions[0]] = r[:, None] * k                                    # W (14)
    for slot in range(3):
        entries[:, rp.pair_positions[slot + 1]] = share * (weights[slot] / total)        # W (12), (12′), (13)
    return entries
