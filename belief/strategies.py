"""Hypothesis strategies that draw the library's own objects: the strategies of :mod:`belief.testing`.

:func:`frames`, :func:`models`, :func:`elements`, :func:`mass_functions`, :func:`mass_batches` and
:func:`bayesian_sources` draw frames, models, elements, mass functions and batches whose masses are small integer
weights over their sum (1 to :data:`MAX_WEIGHT`), chosen so that Hypothesis shrinks a counterexample towards
something a person reads at a glance (see :mod:`belief.testing`); :func:`simplest` shows where a strategy
shrinks to.  Hypothesis is an optional dependency (``pip install 'belief-dsmt[testing]'``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import lru_cache
from typing import Any, Union

import hypothesis
import numpy as np
from hypothesis import strategies as st
from hypothesis.strategies import SearchStrategy

from belief.batch import MassBatch
from belief.frame import Element, Frame
from belief.mass import MassFunction
from belief.model import Model

__all__ = ["KINDS", "MAX_WEIGHT", "bayesian_sources", "elements", "frames", "mass_batches", "mass_functions", "models",
           "simplest"]


#: The kinds of model that :func:`models` draws.
KINDS = ("free", "shafer", "hybrid", "tracking")

#: Masses are integer weights from 1 (0 for the rows of a batch) to this, divided by their sum.
MAX_WEIGHT = 10

#: Above this many hypotheses the conjunctions allowed by a model are drawn at random instead of listed.
_LISTED_HYPOTHESES = 12

#: What the strategies take as ``model``: a model, a strategy of models, or None for :func:`models`.
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
    MassFunction({'b': 1.0}, frame=['a', 'b'])
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
    kinds = check_kinds(kinds)
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
    check_positive("max_terms", size)
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
    MassFunction({'a': 1.0}, frame=['a', 'b', 'c'])
    >>> simplest(mass_functions(shafer), lambda m: m.bel("a") < 1)
    MassFunction({'b': 1.0}, frame=['a', 'b', 'c'])
    >>> simplest(mass_functions(shafer, subnormal=True, nondogmatic=True))
    MassFunction({'empty': 0.3333333333333333, 'a': 0.3333333333333333, 'a|b|c': 0.3333333333333333}, \
frame=['a', 'b', 'c'])
    """
    check_positive("max_focal", max_focal)
    check_positive("max_weight", max_weight)
    return _model_strategy(model).flatmap(
        lambda m: mass_functions_under(m, max_focal, subnormal, nondogmatic, max_weight))


@lru_cache(maxsize=1024)
def _element_lists(model: Model, max_focal: int) -> SearchStrategy:
    return st.lists(elements(model), min_size=1, max_size=max_focal, unique=True)


@lru_cache(maxsize=256)
def cached_integers(low: int, high: int) -> SearchStrategy:
    """``st.integers(low, high)``, built once for each pair of bounds."""
    return st.integers(low, high)


@lru_cache(maxsize=1024)
@st.composite
def _focal_list(draw, model: Model, max_focal: int, subnormal: bool | None, nondogmatic: bool) -> list[Element]:
    focal = draw(_element_lists(model, max_focal))
    if nondogmatic and model.total not in focal:
        focal.append(model.total)
    if draw(cached_integers(0, 1)) if subnormal is None else subnormal:
        focal.insert(0, model.frame.empty)
    return focal


@lru_cache(maxsize=1024)
@st.composite
def mass_functions_under(draw, model: Model, max_focal: int, subnormal: bool | None, nondogmatic: bool,
                         max_weight: int) -> MassFunction:
    """:func:`mass_functions` under one model, ``max_weight`` as given (the strategy is built once per arguments)."""
    focal = draw(_focal_list(model, max_focal, subnormal, nondogmatic))
    weight = cached_integers(1, max_weight)
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
    check_positive("max_focal", max_focal)
    check_positive("max_weight", max_weight)
    return _model_strategy(model).flatmap(
        lambda m: mass_batches_under(m, low, high, max_focal, subnormal, nondogmatic, max_weight))


@lru_cache(maxsize=1024)
@st.composite
def mass_batches_under(draw, model: Model, low: int, high: int, max_focal: int, subnormal: bool | None,
                       nondogmatic: bool, max_weight: int) -> MassBatch:
    """:func:`mass_batches` under one model, of ``low`` to ``high`` rows."""
    focal = draw(_focal_list(model, max_focal, None if subnormal is None else subnormal, nondogmatic))
    # Columns that must hold mass in every row: ∅ (subnormal=True) and Θ (nondogmatic).
    required = [(subnormal is True and not e.terms) or (nondogmatic and e == model.total) for e in focal]
    count = draw(cached_integers(low, high))
    values = []
    for _ in range(count):
        weights = [draw(cached_integers(1 if need else 0, max_weight)) for need in required]
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
    check_positive("max_weight", max_weight)
    return _model_strategy(model).flatmap(
        lambda m: bayesian_sources_under(m, low, high, row_low, row_high, max_weight))


@lru_cache(maxsize=1024)
@st.composite
def bayesian_sources_under(draw, model: Model, low: int, high: int, row_low: int, row_high: int,
                           max_weight: int) -> list[MassBatch]:
    """:func:`bayesian_sources` under one model: ``low`` to ``high`` sources of ``row_low`` to ``row_high`` rows."""
    allowed = [not model.is_empty(x) for x in model.frame.singletons]
    first = allowed.index(True)
    count = draw(cached_integers(low, high))
    n_rows = draw(cached_integers(row_low, row_high))
    weight = cached_integers(0, max_weight)
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


def check_kinds(kinds: Sequence[str]) -> tuple[str, ...]:
    """``kinds`` as a tuple of names of :data:`KINDS` (a single name is allowed); ValueError otherwise."""
    if isinstance(kinds, str):
        kinds = (kinds,)
    kinds = tuple(kinds)
    unknown = [k for k in kinds if k not in KINDS]
    if unknown or not kinds:
        raise ValueError(f"kinds must be some of {', '.join(KINDS)}, got {list(kinds)!r}")
    return kinds


def check_positive(name: str, value: int) -> None:
    """Refuse ``value`` of the argument ``name`` unless it is a positive integer (ValueError)."""
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
