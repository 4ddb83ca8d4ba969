"""Property-based testing for users of :mod:`belief`: Hypothesis strategies and a law checker for rules.

Hypothesis is an optional dependency (``pip install 'belief[testing]'``); this module
imports it at once and raises :class:`ImportError` without it.

Strategies
----------
:func:`frames`, :func:`models`, :func:`elements`, :func:`mass_functions`,
:func:`mass_batches` and :func:`bayesian_sources` draw the library's own objects.  Every
mass is a small integer weight (1 to :data:`MAX_WEIGHT`) divided by the sum of the
weights, so no mass is tiny, no sum cancels and laws can be compared with a tolerance of
1e-9.  The choices are made so that Hypothesis shrinks a counterexample towards something
a person reads at a glance:

* frames shrink towards the fewest hypotheses (``t1``, ``t2``, …);
* models towards the first kind asked for (the free model by default), hybrid models
  towards one exclusivity constraint between two hypotheses, tracking models towards
  ``t1`` as the false alarm;
* elements towards a single hypothesis, then towards few conjunctions of few hypotheses;
* mass functions towards one focal element (a categorical mass function), and weights
  towards 1, that is towards equal masses.

:func:`simplest` shows where a strategy shrinks to.

The law checker
---------------
:func:`check_rule` runs Hypothesis over the laws that a combination rule of the registry
claims (mass conservation, no negative mass, commutativity, associativity, neutrality of the
vacuous mass function, idempotence, and batch = row by row).  A failing law raises
:class:`AssertionError` naming the law, with the shrunk counterexample.

>>> from belief.testing import check_rule
>>> check_rule("conjunctive", vacuous_neutral=True, max_examples=5)
RuleReport(rule='conjunctive', laws=('mass conservation', 'no negative mass', 'commutativity', 'associativity', \
'vacuous neutrality', 'batch = row by row'))
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from contextlib import nullcontext
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any, Union

try:
    import hypothesis
    from hypothesis import strategies as st
    from hypothesis.errors import FailedHealthCheck, Unsatisfiable
    from hypothesis.strategies import SearchStrategy
except ImportError as exc:  # pragma: no cover - exercised in a subprocess by the tests
    raise ImportError("belief.testing needs Hypothesis, an optional dependency: pip install 'belief[testing]'") from exc

import numpy as np

from belief.batch import MassBatch
from belief.errors import BeliefError
from belief.frame import Element, Frame
from belief.mass import MassFunction
from belief.model import Model
from belief.rules import RuleInfo, combine, get_rule

try:  # Hypothesis prints some reports (how to reproduce a failure); they go into the error instead.
    from hypothesis.reporting import with_reporter
except ImportError:  # pragma: no cover - an older or newer Hypothesis without it
    with_reporter = None

__all__ = ["KINDS", "LAWS", "MAX_WEIGHT", "RuleReport", "bayesian_sources", "check_rule", "elements", "frames",
           "mass_batches", "mass_functions", "models", "simplest"]

#: The kinds of model that :func:`models` draws.
KINDS = ("free", "shafer", "hybrid", "tracking")

#: The laws :func:`check_rule` knows, in the order it checks them.
LAWS = ("mass conservation", "no negative mass", "commutativity", "associativity", "vacuous neutrality",
        "idempotence", "batch = row by row")

#: Masses are integer weights from 1 (0 for the rows of a batch) to this, divided by their sum.
MAX_WEIGHT = 10

#: Above this many hypotheses the conjunctions allowed by a model are drawn at random instead of listed.
_LISTED_HYPOTHESES = 12

ModelLike = Union[Model, SearchStrategy, None]


# -- frames and models ---------------------------------------------------------------------------------------
def frames(min_n: int = 1, max_n: int = 4) -> SearchStrategy:
    """Frames ``t1 .. tn`` of ``min_n`` to ``max_n`` hypotheses, shrinking towards ``min_n``.

    Parameters
    ----------
    min_n, max_n : int
        Bounds on the number of hypotheses, 1 ≤ min_n ≤ max_n.

    Returns
    -------
    SearchStrategy of Frame

    Examples
    --------
    >>> simplest(frames(2, 4))
    Frame(['t1', 't2'])
    """
    _check_range("min_n", "max_n", min_n, max_n, lowest=1)
    return st.integers(min_n, max_n).map(Frame.numbered)


def simplest(strategy: SearchStrategy, condition: Callable[[Any], bool] | None = None) -> Any:
    """The simplest value of a strategy (that satisfies ``condition``): where Hypothesis shrinks to.

    Hypothesis's ``find`` without its example database and its explain phase, which would
    only slow it down here.

    Parameters
    ----------
    strategy : SearchStrategy
    condition : callable, optional
        A predicate on the values; by default every value qualifies.

    Returns
    -------
    object
        The shrunk value.

    Raises
    ------
    hypothesis.errors.NoSuchExample
        If no value drawn satisfies ``condition``.

    Examples
    --------
    >>> from belief import Frame, Model
    >>> simplest(mass_functions(Model.shafer(Frame(["a", "b"]))), lambda m: m.bel("a") < 1)
    MassFunction({'b': 1.0}, model=Model.shafer(Frame(['a', 'b'])))
    """
    quick = hypothesis.settings(database=None, phases=[hypothesis.Phase.generate, hypothesis.Phase.shrink])
    return hypothesis.find(strategy, condition if condition is not None else lambda value: True, settings=quick)


def models(frame_or_strategy: Union[Frame, SearchStrategy, None] = None,
           kinds: Sequence[str] = KINDS) -> SearchStrategy:
    """Models of the given kinds over a frame (or over frames drawn from a strategy).

    Hybrid models declare one or two conjunctions empty (an exclusivity constraint between
    two hypotheses first, then larger conjunctions, then single hypotheses that do not
    exist); a model that would leave nothing non-empty is never drawn.  Tracking models need
    two hypotheses and take one of them as the false alarm.  On a one-hypothesis frame only
    the free model and Shafer's (the same) are drawn.

    Parameters
    ----------
    frame_or_strategy : Frame or SearchStrategy of Frame, optional
        The frame, or where to draw it from; by default :func:`frames` (two hypotheses at
        least if ``kinds`` is only ``("tracking",)``).
    kinds : sequence of str
        Among ``"free"``, ``"shafer"``, ``"hybrid"`` and ``"tracking"``; the first is the one
        a counterexample shrinks towards.

    Returns
    -------
    SearchStrategy of Model

    Examples
    --------
    >>> from belief import Frame
    >>> simplest(models(Frame(["a", "b", "c"])))
    Model.free(Frame(['a', 'b', 'c']))
    >>> simplest(models(Frame(["a", "b", "c"]), kinds=("hybrid",)))
    Model.hybrid(Frame(['a', 'b', 'c']), empty=['a&b'])
    """
    kinds = _check_kinds(kinds)
    if frame_or_strategy is None:
        frame_strategy = frames(2 if set(kinds) == {"tracking"} else 1, 4)
    elif isinstance(frame_or_strategy, Frame):
        if len(frame_or_strategy) < 2 and set(kinds) <= {"tracking", "hybrid"}:
            raise ValueError(f"no {' or '.join(kinds)} model over a one-hypothesis frame; "
                             "use a larger frame or other kinds")
        frame_strategy = st.just(frame_or_strategy)
    elif isinstance(frame_or_strategy, SearchStrategy):
        frame_strategy = frame_or_strategy
    else:
        raise TypeError(f"models() takes a Frame or a strategy of frames, got {type(frame_or_strategy).__name__}")
    return frame_strategy.flatmap(lambda frame: _models_over(frame, kinds))


# Strategies are built once per model and options (lru_cache): building one anew for every draw costs
# Hypothesis more than drawing from it.
@lru_cache(maxsize=1024)
def _models_over(frame: Frame, kinds: tuple[str, ...]) -> SearchStrategy:
    # On one hypothesis a hybrid model can only forbid it, and a tracking model needs two.
    usable = [k for k in kinds if len(frame) >= 2 or k in ("free", "shafer")]
    if not usable:
        return st.nothing()
    return st.sampled_from(usable).flatmap(lambda kind: _model_of_kind(frame, kind))


@lru_cache(maxsize=1024)
def _model_of_kind(frame: Frame, kind: str) -> SearchStrategy:
    if kind == "free":
        return st.just(Model.free(frame))
    if kind == "shafer":
        return st.just(Model.shafer(frame))
    if kind == "tracking":
        return st.sampled_from(frame.hypotheses).map(lambda false_alarm: Model.tracking(frame, false_alarm))
    constraints = st.lists(st.sampled_from(_constraint_masks(len(frame))), min_size=1, max_size=2, unique=True)
    return (constraints.map(lambda masks: Model(frame, masks, kind="hybrid"))
            .filter(lambda model: bool(model.total.terms)))


@lru_cache(maxsize=64)
def _constraint_masks(n: int) -> tuple[int, ...]:
    """Conjunction masks for hybrid constraints: pairs first (the usual exclusivity), then larger, then singles."""
    masks = range(1, 1 << n) if n <= _LISTED_HYPOTHESES else [1 << i | 1 << j for i in range(n) for j in range(i)]
    return tuple(sorted(masks, key=lambda m: (m.bit_count() == 1, m.bit_count(), m)))


# -- elements -------------------------------------------------------------------------------------------------
def elements(model: Model, *, max_terms: int | None = None) -> SearchStrategy:
    """Elements of D^Θ that are not empty under ``model``, in their form under it.

    An element is the union of 1 to ``max_terms`` conjunctions that the model allows
    (unions of hypotheses on Shafer's model, any union of intersections on the free model).

    Parameters
    ----------
    model : Model
    max_terms : int, optional
        At most this many conjunctions; by default the number of hypotheses, at most 4.

    Returns
    -------
    SearchStrategy of Element

    Examples
    --------
    >>> from belief import Frame, Model
    >>> shafer = Model.shafer(Frame(["a", "b", "c"]))
    >>> simplest(elements(shafer))
    Element('a')
    >>> simplest(elements(shafer), lambda element: len(element.terms) == 3)
    Element('a|b|c')
    """
    if not isinstance(model, Model):
        raise TypeError(f"elements() takes a Model, got {type(model).__name__}")
    if not model.total.terms:
        raise ValueError(f"every element is empty under {model!r}")
    size = min(len(model.frame), 4) if max_terms is None else max_terms
    _check_positive("max_terms", size)
    return _elements_of(model, size)


@lru_cache(maxsize=1024)
def _elements_of(model: Model, size: int) -> SearchStrategy:
    frame = model.frame
    n = len(frame)
    terms = _allowed_terms(model)
    if terms is not None:
        term = st.sampled_from(terms)
    else:
        # Too many conjunctions to list: draw up to three hypotheses and keep the conjunctions the model allows.
        term = (st.sets(st.integers(0, n - 1), min_size=1, max_size=3)
                .map(lambda bits: sum(1 << b for b in bits))
                .filter(lambda mask: not model.is_forbidden(mask)))
    return st.lists(term, min_size=1, max_size=size, unique=True).map(lambda ts: model.reduce(Element(frame, ts)))


@lru_cache(maxsize=256)
def _allowed_terms(model: Model) -> tuple[int, ...] | None:
    """The conjunctions the model allows, fewest hypotheses first (where shrinking goes), or None if too many."""
    n = len(model.frame)
    if n > _LISTED_HYPOTHESES:
        return None
    return tuple(sorted((t for t in range(1, 1 << n) if not model.is_forbidden(t)), key=lambda t: (t.bit_count(), t)))


# -- mass functions and batches ---------------------------------------------------------------------------------
def mass_functions(model: ModelLike = None, *, max_focal: int = 4, subnormal: bool | None = False,
                   nondogmatic: bool = False, max_weight: int = MAX_WEIGHT) -> SearchStrategy:
    """Mass functions with 1 to ``max_focal`` focal elements (more with ``subnormal`` or ``nondogmatic``).

    Each focal element gets an integer weight from 1 to ``max_weight`` and the masses are
    the weights over their sum: every mass is at least 1 / (max_weight · number of focal
    elements), and a shrunk counterexample has equal masses.

    Parameters
    ----------
    model : Model or SearchStrategy of Model, optional
        The model, or where to draw it from; by default :func:`models`.
    max_focal : int
        At most this many focal elements drawn by :func:`elements`.
    subnormal : bool or None
        False: no mass on ∅; True: always some mass on ∅; None: either.
    nondogmatic : bool
        True: always some mass on total ignorance (m(Θ) > 0, as the cautious rule needs).
    max_weight : int
        The largest weight.

    Returns
    -------
    SearchStrategy of MassFunction

    Examples
    --------
    >>> from belief import Frame, Model
    >>> shafer = Model.shafer(Frame(["a", "b", "c"]))
    >>> simplest(mass_functions(shafer))
    MassFunction({'a': 1.0}, model=Model.shafer(Frame(['a', 'b', 'c'])))
    >>> simplest(mass_functions(shafer), lambda m: m.bel("a") < 1)
    MassFunction({'b': 1.0}, model=Model.shafer(Frame(['a', 'b', 'c'])))
    >>> simplest(mass_functions(shafer, subnormal=True, nondogmatic=True))
    MassFunction({'empty': 0.3333333333333333, 'a': 0.3333333333333333, 'a|b|c': 0.3333333333333333}, \
model=Model.shafer(Frame(['a', 'b', 'c'])))
    """
    _check_positive("max_focal", max_focal)
    _check_positive("max_weight", max_weight)
    return _model_strategy(model).flatmap(
        lambda m: _mass_function_under(m, max_focal, subnormal, nondogmatic, max_weight))


@lru_cache(maxsize=1024)
def _element_lists(model: Model, max_focal: int) -> SearchStrategy:
    return st.lists(elements(model), min_size=1, max_size=max_focal, unique=True)


@lru_cache(maxsize=256)
def _integers(low: int, high: int) -> SearchStrategy:
    return st.integers(low, high)


@lru_cache(maxsize=1024)
@st.composite
def _focal_list(draw, model: Model, max_focal: int, subnormal: bool | None, nondogmatic: bool) -> list[Element]:
    focal = draw(_element_lists(model, max_focal))
    if nondogmatic and model.total not in focal:
        focal.append(model.total)
    if draw(_integers(0, 1)) if subnormal is None else subnormal:
        focal.insert(0, model.frame.empty)
    return focal


@lru_cache(maxsize=1024)
@st.composite
def _mass_function_under(draw, model: Model, max_focal: int, subnormal: bool | None, nondogmatic: bool,
                         max_weight: int) -> MassFunction:
    focal = draw(_focal_list(model, max_focal, subnormal, nondogmatic))
    weight = _integers(1, max_weight)
    weights = [draw(weight) for _ in focal]
    total = sum(weights)
    return MassFunction({e: w / total for e, w in zip(focal, weights)}, model=model,
                        subnormal=not focal[0].terms)


def mass_batches(model: ModelLike = None, *, rows: Union[int, tuple[int, int]] = (1, 4), max_focal: int = 4,
                 subnormal: bool | None = False, nondogmatic: bool = False,
                 max_weight: int = MAX_WEIGHT) -> SearchStrategy:
    """Batches of mass functions whose rows share one list of focal elements.

    A row gives each focal element a weight from 0 to ``max_weight`` (a row of zeros puts
    weight 1 on the first element), so a focal element of the batch may have no mass in
    some rows, as in a batch stacked from several mass functions.

    Parameters
    ----------
    model : Model or SearchStrategy of Model, optional
        By default :func:`models`.
    rows : int or (int, int)
        The number of rows, or its bounds; shrinks towards the lower bound.
    max_focal : int
        At most this many focal elements drawn by :func:`elements`.
    subnormal : bool or None
        False: no column for ∅; True: m(∅) > 0 in every row; None: a column for ∅ whose
        mass may be zero in some rows.
    nondogmatic : bool
        True: m(Θ) > 0 in every row.
    max_weight : int

    Returns
    -------
    SearchStrategy of MassBatch

    Examples
    --------
    >>> from belief import Frame, Model
    >>> shafer = Model.shafer(Frame(["a", "b"]))
    >>> batch = simplest(mass_batches(shafer, rows=3, subnormal=True))
    >>> [str(e) for e in batch.focal], batch.values.tolist()
    (['empty', 'a'], [[1.0, 0.0], [1.0, 0.0], [1.0, 0.0]])
    """
    low, high = _bounds("rows", rows)
    _check_positive("max_focal", max_focal)
    _check_positive("max_weight", max_weight)
    return _model_strategy(model).flatmap(
        lambda m: _mass_batch_under(m, low, high, max_focal, subnormal, nondogmatic, max_weight))


@lru_cache(maxsize=1024)
@st.composite
def _mass_batch_under(draw, model: Model, low: int, high: int, max_focal: int, subnormal: bool | None,
                      nondogmatic: bool, max_weight: int) -> MassBatch:
    focal = draw(_focal_list(model, max_focal, None if subnormal is None else subnormal, nondogmatic))
    # Columns that must hold mass in every row: ∅ (subnormal=True) and Θ (nondogmatic).
    required = [(subnormal is True and not e.terms) or (nondogmatic and e == model.total) for e in focal]
    count = draw(_integers(low, high))
    values = []
    for _ in range(count):
        weights = [draw(_integers(1 if need else 0, max_weight)) for need in required]
        if not any(weights):
            weights[0] = 1
        total = sum(weights)
        values.append([w / total for w in weights])
    return MassBatch(focal, values, model=model, subnormal=not focal[0].terms)


def bayesian_sources(model: ModelLike = None, *, count: Union[int, tuple[int, int]] = (2, 3),
                     rows: Union[int, tuple[int, int]] = (1, 4), max_weight: int = MAX_WEIGHT) -> SearchStrategy:
    """Lists of Bayesian batches under one model, made by :meth:`MassBatch.bayesian`, ready for ``combine``.

    Each source is an (N, n) array of probability vectors over the n hypotheses (N rows, the
    same for every source): integer weights from 0 to ``max_weight`` over their sum, a row
    of zeros giving its mass to the first hypothesis.  A hypothesis that the model declares
    empty gets no mass.  These are the sources for which :func:`~belief.rules.combine` uses
    the closed forms of :mod:`belief.bayesian`.

    Parameters
    ----------
    model : Model or SearchStrategy of Model, optional
        By default :func:`models`.
    count : int or (int, int)
        The number of sources, or its bounds.
    rows : int or (int, int)
        The number of rows of every source, or its bounds.
    max_weight : int

    Returns
    -------
    SearchStrategy of list of MassBatch

    Examples
    --------
    >>> from belief import Model
    >>> sources = simplest(bayesian_sources(Model.for_targets(2), rows=2))
    >>> len(sources), [b.values.tolist() for b in sources]
    (2, [[[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]], [[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]])
    """
    low, high = _bounds("count", count)
    row_low, row_high = _bounds("rows", rows)
    _check_positive("max_weight", max_weight)
    return _model_strategy(model).flatmap(
        lambda m: _bayesian_under(m, low, high, row_low, row_high, max_weight))


@lru_cache(maxsize=1024)
@st.composite
def _bayesian_under(draw, model: Model, low: int, high: int, row_low: int, row_high: int,
                    max_weight: int) -> list[MassBatch]:
    allowed = [not model.is_empty(x) for x in model.frame.singletons]
    first = allowed.index(True)
    count = draw(_integers(low, high))
    n_rows = draw(_integers(row_low, row_high))
    weight = _integers(0, max_weight)
    sources = []
    for _ in range(count):
        values = []
        for _ in range(n_rows):
            weights = [draw(weight) if ok else 0 for ok in allowed]
            if not any(weights):
                weights[first] = 1
            total = sum(weights)
            values.append([w / total for w in weights])
        sources.append(MassBatch.bayesian(np.array(values), model=model))
    return sources


# -- the law checker ----------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RuleReport:
    """What :func:`check_rule` verified: the laws that held, and on how many inputs.

    Attributes
    ----------
    rule : str
        The rule's name in the registry.
    laws : tuple of str
        The laws checked (every one held), in the order of :data:`LAWS`.
    examples : dict
        For each law, the number of inputs the rule accepted and the law was checked on.
    refused : dict
        For each law, the number of inputs the rule refused (skipped, not failures).
    """

    rule: str
    laws: tuple[str, ...]
    examples: Mapping[str, int] = field(default_factory=dict, repr=False, compare=False)
    refused: Mapping[str, int] = field(default_factory=dict, repr=False, compare=False)

    def __str__(self) -> str:
        width = max(len(law) for law in self.laws)
        count = len(self.laws)
        lines = [f"rule {self.rule!r}: {count} law{'s hold' if count != 1 else ' holds'}"]
        for law in self.laws:
            lines.append(f"  {law:<{width}}  {self.examples.get(law, 0)} inputs, "
                         f"{self.refused.get(law, 0)} refused")
        return "\n".join(lines)


def check_rule(rule: Union[str, RuleInfo], *, associative: bool | None = None, commutative: bool = True,
               vacuous_neutral: bool | None = None, idempotent: bool = False, kinds: Sequence[str] = KINDS,
               max_hypotheses: int = 3, max_sources: int = 3, max_focal: int = 3, subnormal: bool | None = False,
               nondogmatic: bool = False, options: Mapping[str, Any] | None = None,
               may_raise: Union[type[BaseException], tuple[type[BaseException], ...]] = BeliefError,
               max_examples: int = 100, tol: float = 1e-9, settings: hypothesis.settings | None = None) -> RuleReport:
    """Check with Hypothesis the laws that a combination rule claims; raise AssertionError on the first that fails.

    The sources are mass functions of :func:`mass_functions` under one model of
    :func:`models` (frames of 1 to ``max_hypotheses`` hypotheses), 2 to ``max_sources`` of
    them.  The laws, each run on ``max_examples`` inputs:

    * **mass conservation**: every result's masses sum to one within ``tol``, m(∅)
      included if the rule keeps conflict (``RuleInfo.keeps_conflict``), else m(∅) = 0;
    * **no negative mass**: no mass below -``tol`` (read from the values of a batch result,
      which keep what a MassFunction drops);
    * **commutativity**: the order of the sources does not change the result;
    * **associativity**: ``combine(m1, m2, m3)`` equals both pairwise folds
      ``combine(combine(m1, m2), m3)`` and ``combine(m1, combine(m2, m3))``;
    * **vacuous neutrality**: adding the vacuous mass function (first or last) to one or
      more sources changes nothing;
    * **idempotence**: ``combine(m, m)`` (and ``combine(m, m, m)``) is m;
    * **batch = row by row**: combining batches (of N rows, or one row broadcast, including
      Bayesian batches that take the closed forms) gives, row by row, what combining the
      rows' mass functions gives, masses and Bel, Pls, BetP of the hypotheses alike.

    Mass conservation and no negative mass are checked on every result of every law.  An
    input that the rule refuses with an exception of ``may_raise`` (Dempster's rule at total
    conflict, a dogmatic source for the cautious rule) is skipped, not a failure; but a law
    whose every input is refused fails, for then nothing was checked, and so does a rule
    that accepts an input in one form and refuses it in another (one order of the sources
    but not the other, a batch but not its rows).  Any other exception propagates.

    Parameters
    ----------
    rule : str or RuleInfo
        A name of the registry (:func:`belief.rules.register_rule`) or a RuleInfo.
    associative : bool, optional
        Claim associativity; by default what the registry says (``RuleInfo.associative``).
    commutative : bool
        Claim commutativity (every rule of the library is, for two sources).
    vacuous_neutral : bool, optional
        Claim that the vacuous mass function is neutral; None (the registry records no
        neutral element) or False: not checked.
    idempotent : bool
        Claim idempotence.
    kinds : sequence of str
        The kinds of model the sources are drawn under (see :func:`models`).
    max_hypotheses : int
        Frames of 1 to this many hypotheses.
    max_sources : int
        2 to this many sources (associativity needs 3).
    max_focal : int
        Focal elements per source, see :func:`mass_functions`.
    subnormal : bool or None
        Mass on ∅ in the sources: never (False), always (True, as the bold rule needs) or
        either (None).
    nondogmatic : bool
        Every source has m(Θ) > 0 (as the cautious rule needs).
    options : mapping, optional
        Keyword options of the rule, passed to every :func:`~belief.rules.combine`.
    may_raise : exception class or tuple of them
        How the rule may refuse an input; by default any
        :class:`~belief.errors.BeliefError`.  Name the ones it should raise (e.g.
        ``TotalConflictError`` for Dempster's rule) to see any other as a failure: a rule
        that checks its own result with ``MassBatch(..., validate=True)`` turns lost mass
        into an :class:`~belief.errors.InvalidMassError`, a refusal by default.
    max_examples : int
        Inputs per law.
    tol : float
        Absolute tolerance on every mass and measure compared.
    settings : hypothesis.settings, optional
        Further Hypothesis settings (``derandomize``, ``phases``, ``database``, …); check_rule
        sets ``max_examples``, no deadline and one reported failure on top of them, and leaves
        out the explain phase (it would only point at lines of the checker).

    Returns
    -------
    RuleReport
        The rule and the laws that held; ``str()`` of it tells on how many inputs.

    Raises
    ------
    AssertionError
        A law fails (the message names it and shows the counterexample), or the rule
        refused every input of a law.
    UnknownRuleError
        ``rule`` is not in the registry.
    ValueError
        Claims or bounds that cannot be checked (associativity with ``max_sources`` < 3).

    Examples
    --------
    The cautious rule on Shafer's model, with the non-dogmatic sources it accepts:

    >>> report = check_rule("cautious", idempotent=True, kinds=("shafer",), nondogmatic=True, max_examples=10)
    >>> report.laws
    ('mass conservation', 'no negative mass', 'commutativity', 'associativity', 'idempotence', 'batch = row by row')

    Claiming a law that does not hold: PCR6 is not associative.

    >>> try:
    ...     check_rule("pcr6", associative=True, max_examples=100)
    ... except AssertionError as error:
    ...     print(str(error).splitlines()[0])
    associativity fails for rule 'pcr6': combine(m1, m2, m3) differs from combine(combine(m1, m2), m3)
    """
    info = get_rule(rule)
    if associative is None:
        associative = info.associative
    kinds = _check_kinds(kinds)
    if isinstance(max_sources, bool) or not isinstance(max_sources, int) or max_sources < 2:
        raise ValueError(f"max_sources must be an integer of at least 2, got {max_sources!r}")
    _check_positive("max_hypotheses", max_hypotheses)
    _check_positive("max_focal", max_focal)
    _check_positive("max_examples", max_examples)
    if associative and max_sources < 3:
        raise ValueError("associativity needs three sources: max_sources must be at least 3")
    if not tol >= 0:
        raise ValueError(f"tol must be a non-negative number, got {tol!r}")
    if isinstance(may_raise, type):
        may_raise = (may_raise,)
    may_raise = tuple(may_raise)
    if not all(isinstance(error, type) and issubclass(error, BaseException) for error in may_raise):
        raise TypeError(f"may_raise must be an exception class or a tuple of them, got {may_raise!r}")
    checker = _Checker(info, dict(options or {}), tol, max_sources, may_raise)
    model_strategy = models(frames(1, max_hypotheses), kinds)

    def sources(low: int, high: int) -> SearchStrategy:
        return model_strategy.flatmap(lambda model: _source_tuples(model, low, high, max_focal, subnormal,
                                                                   nondogmatic))

    # The laws claimed first: mass conservation and no negative mass are checked on their results too, and a
    # claim that does not hold shows at once.
    runs: list[tuple[str, SearchStrategy, Callable]] = []
    if commutative:
        runs.append(("commutativity", _permuted(sources(2, max_sources)), checker.commutativity))
    if associative:
        runs.append(("associativity", sources(3, 3), checker.associativity))
    if vacuous_neutral:
        runs.append(("vacuous neutrality", sources(1, max_sources - 1), checker.vacuous_neutrality))
    if idempotent:
        runs.append(("idempotence", sources(1, 1), checker.idempotence))
    runs.append(("mass conservation", sources(2, max_sources), checker.conservation))
    bayesian_too = not nondogmatic and subnormal is not True
    runs.append(("batch = row by row",
                 model_strategy.flatmap(lambda model: _batch_sources(model, max_sources, max_focal, subnormal,
                                                                     nondogmatic, bayesian_too)),
                 checker.batch_rows))
    base = settings if settings is not None else hypothesis.settings()
    run_settings = hypothesis.settings(
        base, max_examples=max_examples, deadline=None, report_multiple_bugs=False,
        # The explain phase would only point at lines of the checker, and it takes time.
        phases=[phase for phase in base.phases if phase != hypothesis.Phase.explain],
        # Not filter_too_much: a rule that refuses nearly every input fails early, for nothing would be checked.
        suppress_health_check=sorted(set(base.suppress_health_check) | {
            hypothesis.HealthCheck.too_slow, hypothesis.HealthCheck.data_too_large}, key=lambda h: h.name))
    for law, strategy, check in runs:
        checker.run(law, strategy, check, run_settings)
    laws = tuple(law for law in LAWS if law in checker.examples or law == "no negative mass")
    total = sum(checker.examples.values())
    examples = {**checker.examples, "no negative mass": total}
    refused = {**checker.refused, "no negative mass": sum(checker.refused.values())}
    return RuleReport(info.name, laws, examples, refused)


@lru_cache(maxsize=1024)
def _source_tuples(model: Model, low: int, high: int, max_focal: int, subnormal: bool | None,
                   nondogmatic: bool) -> SearchStrategy:
    return st.lists(_mass_function_under(model, max_focal, subnormal, nondogmatic, MAX_WEIGHT),
                    min_size=low, max_size=high).map(tuple)


@lru_cache(maxsize=64)
def _orders(count: int, moved: bool) -> SearchStrategy:
    """Permutations of range(count); ``moved``: not the identity.  They shrink towards swapping the first two."""
    orders = st.permutations(range(count))
    return orders.filter(lambda order: list(order) != sorted(order)) if moved else orders


@st.composite
def _permuted(draw, sources: SearchStrategy) -> tuple[tuple, tuple]:
    """(sources, the same in another order)."""
    ms = draw(sources)
    order = draw(_orders(len(ms), True))
    return ms, tuple(ms[k] for k in order)


@lru_cache(maxsize=1024)
def _broadcast_sources(model: Model, n_rows: int, max_focal: int, subnormal: bool | None,
                       nondogmatic: bool) -> tuple[SearchStrategy, SearchStrategy]:
    """An N-row batch, and one of: an N-row batch, a one-row batch, a mass function (the last two broadcast)."""
    batch = _mass_batch_under(model, n_rows, n_rows, max_focal, subnormal, nondogmatic, MAX_WEIGHT)
    one_row = _mass_batch_under(model, 1, 1, max_focal, subnormal, nondogmatic, MAX_WEIGHT)
    single = _mass_function_under(model, max_focal, subnormal, nondogmatic, MAX_WEIGHT)
    return batch, st.one_of(batch, one_row, single)


@lru_cache(maxsize=1024)
@st.composite
def _batch_sources(draw, model: Model, max_sources: int, max_focal: int, subnormal: bool | None,
                   nondogmatic: bool, bayesian_too: bool) -> tuple:
    """2 to max_sources sources for the batch law: N-row batches, one-row batches and mass functions (broadcast)."""
    n_rows = draw(_integers(1, 3))
    if bayesian_too and draw(_integers(0, 1)):
        return _Shown(draw(_bayesian_under(model, 2, max_sources, n_rows, n_rows, MAX_WEIGHT)))
    count = draw(_integers(2, max_sources))
    batch, any_source = _broadcast_sources(model, n_rows, max_focal, subnormal, nondogmatic)
    out = [draw(batch)]                        # one N-row batch at least, so that the result is a batch
    out += [draw(any_source) for _ in range(count - 1)]
    order = draw(_orders(count, False))
    return _Shown(out[k] for k in order)


class _Shown(tuple):
    """Sources that print as the calls that build them: a MassBatch's own repr gives only its shape."""

    def __repr__(self) -> str:
        return "(" + ", ".join(_source_repr(source) for source in self) + ")"


def _source_repr(source) -> str:
    if not isinstance(source, MassBatch):
        return repr(source)
    subnormal = ", subnormal=True" if any(not e.terms for e in source.focal) else ""
    return (f"MassBatch({[str(e) for e in source.focal]!r}, {source.values.tolist()!r}, "
            f"model={source.model!r}{subnormal})")


@dataclass(frozen=True)
class _Refusal:
    """A combination the rule refused (with an exception of ``may_raise``), or a measure that is undefined."""

    error: BaseException

    def __str__(self) -> str:
        return f"refused ({type(self.error).__name__}: {self.error})"


class _Checker:
    """The law checks of one rule: each takes one drawn input, rejects it if refused, and raises AssertionError."""

    def __init__(self, info: RuleInfo, options: dict, tol: float, max_sources: int,
                 may_raise: tuple[type[BaseException], ...]) -> None:
        self.info = info
        self.may_raise = may_raise
        self.max_sources = max_sources
        self.options = options
        self.tol = tol
        self.law = ""
        self.examples: dict[str, int] = {}
        self.refused: dict[str, int] = {}
        self.last_refusal: _Refusal | None = None

    # -- running one law ------------------------------------------------------------------------------------
    def run(self, law: str, strategy: SearchStrategy, check: Callable, run_settings: hypothesis.settings) -> None:
        self.law = law
        self.examples[law] = 0
        self.refused[law] = 0
        self.last_refusal = None

        def law_holds(case):
            check(case)
            self.examples[law] += 1

        # Failures print as a call of this name; the digest keeps the rules and laws apart in the example database.
        law_holds.__name__ = law_holds.__qualname__ = "check_" + "_".join(law.replace("=", "equals").split())
        law_holds._hypothesis_internal_add_digest = f"{self.info.name}|{law}".encode()
        law_holds = run_settings(hypothesis.given(strategy)(law_holds))
        reports: list[str] = []
        capture = with_reporter(reports.append) if with_reporter is not None else nullcontext()
        try:
            with capture:
                law_holds()
        except (Unsatisfiable, FailedHealthCheck) as error:
            if isinstance(error, FailedHealthCheck) and "filter_too_much" not in str(error):
                raise
            how = "every" if isinstance(error, Unsatisfiable) or not self.examples[law] else "nearly every"
            refusal = f" ({type(self.last_refusal.error).__name__}: {self.last_refusal.error})" \
                if self.last_refusal else ""
            raise AssertionError(
                f"{law}: rule {self.info.name!r} refused {how} input generated to check it{refusal}; draw inputs "
                "it accepts (kinds=, subnormal=, nondogmatic=, options=) or do not claim the law") from None
        except AssertionError as error:
            for line in reports:
                if hasattr(error, "add_note"):
                    error.add_note(line)
            raise

    def combine(self, *sources):
        """The result, or a _Refusal; materialised (a lazy closed-form batch may refuse only when read)."""
        try:
            result = combine(*sources, rule=self.info, **self.options)
            if isinstance(result, MassBatch):
                result.values
            return result
        except self.may_raise as error:
            return _Refusal(error)

    def skip(self, refusal: _Refusal) -> None:
        self.last_refusal = refusal
        self.refused[self.law] += 1
        hypothesis.reject()

    def fail(self, law: str, message: str) -> None:
        raise AssertionError(f"{law} fails for rule {self.info.name!r}: {message}")

    # -- what every result must satisfy ------------------------------------------------------------------------
    def valid(self, result, what: str, sources: tuple = ()) -> None:
        """Mass conservation and no negative mass, for a MassFunction or every row of a MassBatch.

        A MassFunction result keeps only the positive masses, so when its masses do not sum to one,
        the same ``sources`` are combined as batches to see whether negative masses were dropped.
        """
        if isinstance(result, MassFunction) and sources and not abs(math.fsum(result.values) - 1.0) <= self.tol:
            raw = self.combine(*(s.batch() if isinstance(s, MassFunction) else s for s in sources))
            if not isinstance(raw, _Refusal):
                for k, value in enumerate(raw.values[0].tolist()):
                    if not value >= -self.tol:
                        self.fail("no negative mass", f"{what} gives m({raw.focal[k]}) = {value:.12g}")
        rows = result.values.reshape(1, -1) if isinstance(result, MassFunction) else result.values
        empty = [k for k, e in enumerate(result.focal) if not e.terms]
        for k, row in enumerate(rows.tolist()):
            where = f"{what}, row {k}" if isinstance(result, MassBatch) else what
            negative = [(result.focal[j], v) for j, v in enumerate(row) if not v >= -self.tol]
            if negative:
                element, value = negative[0]
                self.fail("no negative mass", f"{where} gives m({element}) = {value:.12g}")
            total = math.fsum(row)
            if not abs(total - 1.0) <= self.tol:
                self.fail("mass conservation", f"the masses of {where} sum to {total:.12g}, not 1"
                          + (" (m(∅) included)" if self.info.keeps_conflict else ""))
            if empty and not self.info.keeps_conflict and not row[empty[0]] <= self.tol:
                self.fail("mass conservation", f"{where} puts {row[empty[0]]:.12g} on ∅, but the rule is registered "
                          "with keeps_conflict=False (its masses must sum to 1 without m(∅))")

    def outcome(self, *sources, what: str):
        result = self.combine(*sources)
        if not isinstance(result, _Refusal):
            self.valid(result, what, sources)
        return result

    def same(self, law: str, first, second, first_text: str, second_text: str) -> None:
        """Fail unless two outcomes agree: both refused, or mass functions equal within tol."""
        if isinstance(first, _Refusal) and isinstance(second, _Refusal):
            self.skip(first)
        if isinstance(first, _Refusal) or isinstance(second, _Refusal):
            self.fail(law, f"{first_text} is {_show(first)} but {second_text} is {_show(second)}")
        difference = _difference(first, second)
        if difference is not None and not difference[0] <= self.tol:
            self.fail(law, f"{first_text} differs from {second_text}\n  {first_text} = {_show(first)}\n"
                           f"  {second_text} = {_show(second)}\n  m({difference[1]}) differs by "
                           f"{difference[0]:.3g} (tolerance {self.tol:g})")

    # -- the laws ------------------------------------------------------------------------------------------------
    def conservation(self, sources: tuple) -> None:
        # The sources as one-row batches first: the raw values of a batch show every mass, where a
        # MassFunction keeps only the positive ones.
        batch = self.outcome(*(m.batch() for m in sources), what=_call(len(sources), "b"))
        result = self.outcome(*sources, what=_call(len(sources)))
        if isinstance(result, _Refusal) and isinstance(batch, _Refusal):
            self.skip(result)
        if isinstance(result, _Refusal) or isinstance(batch, _Refusal):
            self.fail("batch = row by row", f"{_call(len(sources))} is {_show(result)} but the same sources as "
                                            f"one-row batches give {_show(batch)}")

    def commutativity(self, case: tuple) -> None:
        sources, shuffled = case
        # By identity: two sources may be equal mass functions.
        order = [next(k for k, m in enumerate(sources, 1) if m is s) for s in shuffled]
        text = "combine(" + ", ".join(f"m{k}" for k in order) + ")"
        self.same("commutativity", self.outcome(*sources, what=_call(len(sources))),
                  self.outcome(*shuffled, what=text), _call(len(sources)), text)

    def associativity(self, sources: tuple) -> None:
        m1, m2, m3 = sources
        joint = self.outcome(m1, m2, m3, what="combine(m1, m2, m3)")
        left = self.outcome(m1, m2, what="combine(m1, m2)")
        if not isinstance(left, _Refusal):
            left = self.outcome(left, m3, what="combine(combine(m1, m2), m3)")
        self.same("associativity", joint, left, "combine(m1, m2, m3)", "combine(combine(m1, m2), m3)")
        right = self.outcome(m2, m3, what="combine(m2, m3)")
        if not isinstance(right, _Refusal):
            right = self.outcome(m1, right, what="combine(m1, combine(m2, m3))")
        self.same("associativity", joint, right, "combine(m1, m2, m3)", "combine(m1, combine(m2, m3))")

    def vacuous_neutrality(self, sources: tuple) -> None:
        vacuous = MassFunction.vacuous(model=sources[0].model)
        if len(sources) == 1:
            (m1,) = sources
            for pair, text in (((m1, vacuous), "combine(m1, vacuous)"), ((vacuous, m1), "combine(vacuous, m1)")):
                result = self.outcome(*pair, what=text)
                if isinstance(result, _Refusal):
                    self.skip(result)
                self.same("vacuous neutrality", result, m1, text, "m1")
            return
        plain = _call(len(sources))
        without = self.outcome(*sources, what=plain)
        names = plain[len("combine("):-1]
        self.same("vacuous neutrality", self.outcome(*sources, vacuous, what=f"combine({names}, vacuous)"),
                  without, f"combine({names}, vacuous)", plain)
        self.same("vacuous neutrality", self.outcome(vacuous, *sources, what=f"combine(vacuous, {names})"),
                  without, f"combine(vacuous, {names})", plain)

    def idempotence(self, sources: tuple) -> None:
        (m,) = sources
        result = self.outcome(m, m, what="combine(m, m)")
        if isinstance(result, _Refusal):
            self.skip(result)
        self.same("idempotence", result, m, "combine(m, m)", "m")
        if self.max_sources >= 3:
            self.same("idempotence", self.outcome(m, m, m, what="combine(m, m, m)"), m, "combine(m, m, m)", "m")

    def batch_rows(self, sources: tuple) -> None:
        n_rows = max(len(s) if isinstance(s, MassBatch) else 1 for s in sources)
        fused = self.combine(*sources)
        closed_form: dict[str, np.ndarray] = {}
        if not isinstance(fused, _Refusal) and type(fused) is not MassBatch:
            # A closed-form batch (belief.bayesian): its measures of the hypotheses come from the closed forms,
            # for every hypothesis (a table) or one per row (select=), whatever the general combination gives.
            hypotheses = list(fused.frame.singletons)
            select = np.arange(n_rows) % len(hypotheses)
            for measure in ("bel", "pls", "betp", "mass"):
                table = _attempt(lambda: getattr(fused, measure)(hypotheses))
                if not isinstance(table, _Refusal):
                    closed_form[measure] = table
                    closed_form[f"{measure} (select=)"] = getattr(fused, measure)(hypotheses, select=select)
            closed_form["m(∅)"] = fused.empty_mass
        if not isinstance(fused, _Refusal):
            self.valid(fused, _call(len(sources), "b"))
        per_row = []
        for k in range(n_rows):
            row_sources = [s[k if len(s) > 1 else 0] if isinstance(s, MassBatch) else s for s in sources]
            per_row.append(self.outcome(*row_sources, what=f"{_call(len(sources))} of row {k}"))
        refused = [r for r in per_row if isinstance(r, _Refusal)]
        if isinstance(fused, _Refusal):
            if refused:
                self.skip(fused)
            self.fail("batch = row by row", f"combining the batches is {fused}, but every row combines")
        if refused:
            k = next(k for k, r in enumerate(per_row) if isinstance(r, _Refusal))
            self.fail("batch = row by row", f"combining the batches gives a result, but row {k} is {refused[0]}")
        if len(fused) != n_rows:
            self.fail("batch = row by row", f"combining batches of {n_rows} rows gives {len(fused)} rows")
        for k, expected in enumerate(per_row):
            self.same("batch = row by row", fused[k], expected, f"row {k} of the combined batches",
                      f"the combination of row {k}'s mass functions")
            for measure, values in closed_form.items():
                wanted = _attempt(lambda: _measure(expected, measure))
                if isinstance(wanted, _Refusal):
                    continue
                if measure.endswith("(select=)"):
                    wanted = wanted[k % len(wanted)]
                got = np.asarray(values[k], dtype=float)
                if not np.all(np.abs(got - wanted) <= self.tol):
                    self.fail("batch = row by row", f"row {k} of the closed-form batch has {measure} "
                                                    f"{got.tolist()} of the hypotheses, the combination of the "
                                                    f"row's mass functions {np.asarray(wanted).tolist()}")


def _measure(m: MassFunction, measure: str) -> np.ndarray:
    """A measure of a mass function as :meth:`_Checker.batch_rows` names it: of every hypothesis, or m(∅)."""
    if measure == "m(∅)":
        return np.asarray(m.empty_mass)
    name = measure.split()[0]
    return np.asarray(getattr(m.batch(), name)(list(m.frame.singletons))[0], dtype=float)


def _attempt(compute: Callable):
    try:
        return compute()
    except BeliefError as error:
        return _Refusal(error)


def _call(count: int, prefix: str = "m") -> str:
    return "combine(" + ", ".join(f"{prefix}{k}" for k in range(1, count + 1)) + ")"


def _show(result) -> str:
    if isinstance(result, _Refusal):
        return str(result)
    return "{" + ", ".join(f"{str(e)!r}: {v:.12g}" for e, v in result.items()) + "}"


def _difference(first: MassFunction, second: MassFunction) -> tuple[float, Any] | None:
    """The largest difference of mass between two mass functions, and where (inf if their models differ)."""
    if first.model != second.model:
        return math.inf, f"any element: the models differ, {first.model!r} and {second.model!r}"
    mine = dict(first.items())
    theirs = dict(second.items())
    worst = None
    for element in set(mine) | set(theirs):
        gap = abs(mine.get(element, 0.0) - theirs.get(element, 0.0))
        if math.isnan(gap):
            gap = math.inf
        if worst is None or gap > worst[0]:
            worst = (gap, element)
    return worst


# -- argument checks --------------------------------------------------------------------------------------------
def _model_strategy(model: ModelLike) -> SearchStrategy:
    if model is None:
        return models()
    if isinstance(model, Model):
        if not model.total.terms:
            raise ValueError(f"every element is empty under {model!r}")
        return st.just(model)
    if isinstance(model, SearchStrategy):
        return model
    raise TypeError(f"model must be a Model or a strategy of models, got {type(model).__name__}")


def _check_kinds(kinds: Sequence[str]) -> tuple[str, ...]:
    if isinstance(kinds, str):
        kinds = (kinds,)
    kinds = tuple(kinds)
    unknown = [k for k in kinds if k not in KINDS]
    if unknown or not kinds:
        raise ValueError(f"kinds must be some of {', '.join(KINDS)}, got {list(kinds)!r}")
    return kinds


def _check_positive(name: str, value: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"{name} must be a positive integer, got {value!r}")


def _check_range(low_name: str, high_name: str, low: int, high: int, lowest: int) -> None:
    for name, value in ((low_name, low), (high_name, high)):
        if isinstance(value, bool) or not isinstance(value, int) or value < lowest:
            raise ValueError(f"{name} must be an integer of at least {lowest}, got {value!r}")
    if low > high:
        raise ValueError(f"{low_name} = {low} is more than {high_name} = {high}")


def _bounds(name: str, value: Union[int, tuple[int, int]]) -> tuple[int, int]:
    if isinstance(value, tuple) and len(value) == 2:
        low, high = value
    else:
        low = high = value
    _check_range(f"{name}[0]", f"{name}[1]", low, high, lowest=1)
    return low, high
