"""Closed forms for fusing Bayesian sources: probability vectors over the hypotheses.

A batch is *Bayesian* when its focal elements are singletons θ_i of the frame (a source of
the conjunctive rules may also carry ∅).  Classifier outputs, sensor likelihoods turned
into masses and the cue mass functions of the tracker (SPEC Part D) are of this kind.
Fusing them with the general plan of :mod:`belief.rules` builds every focal element of the
result, and these multiply: two or three sources over τ targets give O(τ²) or O(τ³)
intersections per row.  The measures that one reads afterwards (Bel, Pls, BetP or the
mass of a singleton, and m(∅)) only need a few sums over the hypotheses, so
:func:`~belief.rules.combine` computes those directly when it can, and builds the focal
elements only if someone asks for them.

Models
------
The closed forms hold on the models whose frame splits into

* a set O of hypotheses that are free among themselves (every intersection of members of
  O is non-empty), and
* a set E of *exclusive* hypotheses, each disjoint from every other hypothesis.

The free model (E = ∅), Shafer's model (E = Θ) and the tracking model of SPEC Part D
(O = the targets, E = {FA}, W (15)) belong to this class (:func:`exclusive_split`).  Its
Venn regions are the non-empty subsets of O plus one region per member of E, so with
N_k = 2^(|O| − k) the DSm cardinality of θ_S = ∩_{i∈S} θ_i (S ⊆ O, |S| = k) is N_k, and
C(θ_S ∩ θ_j) / C(θ_S) is 1 for j ∈ S and ½ otherwise.

Rules
-----
With s Bayesian sources m_1, …, m_s, O_i = Σ_{j∈O} m_i(θ_j) and P_O = Π_i O_i:

* ``conjunctive``, ``dsmc`` (W (2), SPEC A.3), ``dempster``, ``yager``: a tuple of singletons
  reaches θ_S when all lie in O (S = the distinct ones), θ_e when all equal e ∈ E, and ∅
  otherwise.  Hence Pls(θ_j) = P_O and m(θ_j) = Π_i m_i(θ_j) for j ∈ O, and Bel(θ_j) sums,
  over the first source k that picks θ_j, Π_{i<k} (O_i − m_i(θ_j)) · m_k(θ_j) · Π_{i>k} O_i
  (SPEC Part D's Bel(θ_J) written as a sum of products); BetP(θ_j) = ½ (P_O + Bel(θ_j)).
* ``pcr5``, ``pcr6`` (SPEC A.3): the consensus above, plus the conflicting tuples, which
  always hold an exclusive hypothesis.  With two sources the conflicting pairs are
  (e, y), (x, e) and (e, e′), O(|E|·n) per row; with more sources and |E| ≤ 1 the tuples
  are enumerated by the set A of sources that pick the exclusive hypothesis, O(n^(s−1))
  per row instead of n^s.
* ``r_rule`` (SPEC A.4) for |E| ≤ 1: folded in source order over element classes, see
  :class:`RRuleFusion`.

Every mass is a sum of products of the sources' masses, never ``1 − something``: near
total conflict (m(∅) = 1 − 10⁻¹⁶) the non-empty masses are tiny, and a difference with
one would lose them.  The few differences taken (O_i − m_i(θ_j), or Σ_{i≠l} s_i p_l as
S·T − Σ_i s_i p_i) are between sums of products that all reach non-empty elements; where
such a difference would cancel (one target holding nearly all of both masses), the R-weighted
rule's folds sum the terms one by one instead (:func:`~belief.bayesian_fold.cross_sum`), as its
error would reach masses far smaller than the difference.  BetP divides by the sum of the
non-empty masses, exactly as :meth:`~belief.batch.MassBatch.betp` does, so that both paths
find the same rows totally conflicting.

The fusions keep their arrays as (hypotheses, rows) and work in blocks of rows: a
per-row quantity of shape (N,) then broadcasts along the long axis, numpy's inner loops
run over rows rather than over the few hypotheses, and every temporary stays small.

Modules
-------
This module plans a closed form (:func:`closed_form`) and holds the lazy :class:`ClosedFormBatch`.  The
models and layouts are :mod:`belief.bayesian_split`; the blocks of rows and the base of the fusions
:mod:`belief.bayesian_blocks`; the fusions :mod:`belief.bayesian_conjunctive`, :mod:`belief.bayesian_pcr`
and :mod:`belief.bayesian_r` (on the folds of :mod:`belief.bayesian_fold`); the inconsistency R of W (10)
:mod:`belief.r_inconsistency`.  The fusions, the block sizes and the inconsistencies can be imported from
here as well.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import lru_cache

import numpy as np

from belief.batch import MassBatch, check_select, trusted_batch
from belief.bayesian_blocks import Fusion, NoClosedForm
from belief.bayesian_conjunctive import ConjunctiveFusion, Underflow
from belief.bayesian_pcr import PCRFusion
from belief.bayesian_r import RRuleFusion
from belief.bayesian_split import ExclusiveSplit, bayesian_layout, exclusive_split
from belief.errors import InvalidMassError, ModelError, TotalConflictError
from belief.frame import Element
from belief.model import Model
from belief.plan import check_joint
# Importable from here as before the closed forms had modules of their own.
from belief.bayesian_blocks import PAIR_BLOCK_ENTRIES, ROW_BLOCK_ENTRIES
from belief.bayesian_conjunctive import COLUMN_BLOCK_ROWS
from belief.bayesian_pcr import BLOCK_ENTRIES
from belief.r_inconsistency import aligned_inconsistency, bayesian_inconsistency, paper_inconsistency

__all__ = ["ENGINES", "ClosedFormBatch", "ExclusiveSplit", "exclusive_split", "closed_form_rules",
           "ConjunctiveFusion", "PCRFusion", "RRuleFusion"]


#: The values of ``combine(..., engine=...)``.
ENGINES = ("auto", "general", "bayesian")

_CONJUNCTIVE = ("conjunctive", "dsmc", "dempster", "yager")
_PCR = ("pcr5", "pcr6")


def closed_form_rules() -> dict[str, str]:
    """The rules with closed forms for Bayesian sources, and where they apply.

    >>> sorted(closed_form_rules())
    ['conjunctive', 'dempster', 'dsmc', 'pcr5', 'pcr6', 'r_rule', 'yager']
    """
    every = "every model of the class, any number of sources"
    return {"conjunctive": every, "dsmc": every, "dempster": every, "yager": every,
            "pcr5": "two sources on every model of the class; more when at most one hypothesis is exclusive",
            "pcr6": "two sources on every model of the class; more when at most one hypothesis is exclusive",
            "r_rule": "at most one exclusive hypothesis (free and tracking models); r_mode 'euclid' and "
                      "'jousselme' up to three sources"}


# -- planning ---------------------------------------------------------------------------------------
def _build_plan(rule: str, batches: Sequence[MassBatch], model: Model, options: dict) -> tuple[Callable | None, str]:
    """How to fuse ``batches`` in closed form, or why that is not possible.

    Returns ``(build, "")`` where ``build()`` gives the fusion object, or ``(None, reason)``.
    The checks are cached per model and per focal list, so they cost a few dictionary
    look-ups per call.
    """
    if rule not in _CONJUNCTIVE and rule not in _PCR and rule != "r_rule":
        return None, f"rule {rule!r} has no closed form for Bayesian sources (closed forms: " \
                     f"{', '.join(closed_form_rules())})"
    source_model = batches[0].model
    if model != source_model:
        return None, "the fusion model differs from the sources' model (dynamic fusion)"
    split = exclusive_split(model)
    if split is None:
        return None, (f"the {model.kind} model is outside the class of the closed forms (exclusive hypotheses, "
                      "each disjoint from every other, plus hypotheses that are free among themselves)")
    layouts = []
    for k, b in enumerate(batches, start=1):
        layout = bayesian_layout(b.focal_key)
        if layout is None:
            bad = next(x for x in b.focal if x.terms and (len(x.terms) > 1 or x.terms[0].bit_count() > 1))
            return None, f"source {k} is not Bayesian: it has the focal element {bad}"
        if layout.empty is not None and rule not in ("conjunctive", "dsmc", "dempster"):
            return None, f"source {k} has a column for ∅, which {rule} does not take"
        layouts.append(layout)
    s = len(batches)
    rows = max(len(b) for b in batches)
    if rule in _PCR and s > 2 and len(split.exclusive) > 1:
        return None, (f"{rule} of {s} sources has a closed form only with at most one exclusive hypothesis; "
                      f"this model has {len(split.exclusive)}")
    if rule in _PCR and s > 2:
        # The grids of the closed form hold up to n^s tuples per row, as the general path does.
        check_joint(rule, [split.size] * s, rows, "pcr", True, rule == "pcr5")
    if rule == "r_rule":
        if len(split.exclusive) > 1:
            return None, (f"r_rule has a closed form only with at most one exclusive hypothesis; this model has "
                          f"{len(split.exclusive)}")
        if options.get("r_mode", "paper") != "paper" and s > 3:
            return None, f"r_rule with r_mode={options['r_mode']!r} has a closed form up to three sources, not {s}"

    def build():
        # The sources' own columns, one-row sources broadcast; a focal list in another order (or
        # with singletons missing) is mapped to frame order block by block, without a copy of it all.
        values = [b.values for b in batches]
        maps = [None if layout.identity else (np.array(layout.columns, dtype=np.int64),
                                              np.array(layout.kept, dtype=np.int64)) for layout in layouts]
        empties = [None if layout.empty is None else np.broadcast_to(v[:, layout.empty], (rows,))
                   for v, layout in zip(values, layouts)]
        if rule in _CONJUNCTIVE:
            return ConjunctiveFusion(values, empties, split, rule, maps)
        if rule in _PCR:
            return PCRFusion(values, split, rule, maps)
        return RRuleFusion(values, split, options.get("r_mode", "paper"), options.get("empty_mode", "union") == "union",
                           maps)

    return build, ""


# -- the lazy batch ------------------------------------------------------------------------------------
@lru_cache(maxsize=4096)
def _query_columns(model: Model, queries: tuple) -> tuple[int, ...] | None:
    """Frame position of each query (−1 for ∅, or empty under the model); None if one is not a singleton."""
    out = []
    for q in queries:
        x = model.reduce(model.frame.element(q))
        if not x.terms:
            out.append(-1)
        elif len(x.terms) == 1 and x.terms[0].bit_count() == 1:
            out.append(x.terms[0].bit_length() - 1)
        else:
            return None
    return tuple(out)


def _columns(model: Model, queries) -> tuple[tuple[int, ...] | None, bool]:
    single = isinstance(queries, (str, Element))
    key = (queries,) if single else tuple(queries)
    try:
        return _query_columns(model, key), single
    except TypeError:                      # an unhashable query: resolve it without the cache
        return _query_columns.__wrapped__(model, key), single


@lru_cache(maxsize=1024)
def _select_table(split: ExclusiveSplit, columns: tuple[int, ...]) -> tuple[np.ndarray, bool]:
    """Each query's place in [O, E, ∅] (∅ last), read-only, and whether every query is a free hypothesis."""
    o = len(split.free)
    position = np.append(split.position, o + len(split.exclusive))
    table = position[list(columns)]
    table.flags.writeable = False
    return table, bool((table < o).all())


class ClosedFormBatch(MassBatch):
    """A fused batch of Bayesian sources whose measures come from closed forms (:mod:`belief.bayesian`).

    :func:`~belief.rules.combine` returns one when the closed forms apply.  It is a
    :class:`~belief.batch.MassBatch` in every respect: ``values``, ``focal``, indexing,
    iteration and the other measures are those of the general combination, which runs on
    first access (once).  Bel, Pls, BetP and the mass of singletons (any list, in any order,
    with or without ``select=``) and :attr:`empty_mass` come from the closed forms without
    it, and what they compute is cached, so reading several measures of one fused batch
    folds the rule once.

    Examples
    --------
    >>> from belief import MassBatch, Model, combine
    >>> model = Model.for_targets(2)
    >>> location = MassBatch.bayesian([[0.6, 0.3, 0.1], [0.2, 0.1, 0.7]], model=model)
    >>> colour = MassBatch.bayesian([[0.2, 0.7, 0.1], [0.3, 0.3, 0.4]], model=model)
    >>> fused = combine(location, colour, rule="r_rule")
    >>> type(fused).__name__, len(fused)
    ('ClosedFormBatch', 2)
    >>> fused.bel(["t1", "t2"], select=[0, 1]).round(4)      # Bel of each row's own target
    array([0.5149, 0.1038])
    >>> fused.values.shape                                    # the general combination, on request
    (2, 6)
    """

    __slots__ = ("_fusion", "_materialise", "_result", "_rows")

    def __init__(self, model: Model, fusion: Fusion, materialise: Callable[[], MassBatch]) -> None:
        self.model = model
        self._key = None
        self._fusion = fusion
        self._materialise = materialise
        self._result: MassBatch | None = None
        self._rows = fusion.rows

    # -- the general combination, on demand -------------------------------------------------------
    def materialised(self) -> MassBatch:
        """The general combination of the sources (computed on first call, then kept)."""
        if self._result is None:
            self._result = self._materialise()
        return self._result

    @property
    def focal(self) -> tuple[Element, ...]:  # type: ignore[override]
        return self.materialised().focal

    @property
    def values(self) -> np.ndarray:  # type: ignore[override]
        return self.materialised().values

    @property
    def _canonical(self) -> bool:  # type: ignore[override]
        return self.materialised()._canonical

    def __len__(self) -> int:
        return self._rows

    def __reduce__(self):
        result = self.materialised()
        return (trusted_batch, (result.model, result.focal, result.values, result._canonical))

    # -- measures ---------------------------------------------------------------------------------
    @property
    def empty_mass(self) -> np.ndarray:
        """m(∅) of every row, shape (N,)."""
        return np.array(self._fusion.empty(), dtype=np.float64, copy=True)

    def _closed(self, kind: str, queries, select) -> np.ndarray | None:
        columns, single = _columns(self.model, queries)
        if columns is None:
            return None
        try:
            if select is None:
                out = self._table(kind, columns)
                return out[:, 0] if single else out
            chosen = check_select(select, self._rows, len(columns))
            table, every_free = _select_table(self._fusion.split, columns)
            return self._selected(kind, table.take(chosen), every_free)
        except NoClosedForm:
            return None

    def _table(self, kind: str, columns: tuple[int, ...]) -> np.ndarray:
        fusion, split = self._fusion, self._fusion.split
        o = len(split.free)
        free = fusion.o_measure(kind)
        if free.ndim == 1:
            free = np.broadcast_to(free[:, None], (self._rows, o))
        extra = self.empty_mass[:, None] if kind == "mass" else np.zeros((self._rows, 1))
        table = np.concatenate([free, fusion.e_measure(kind), extra], axis=1)
        position = np.append(split.position, o + len(split.exclusive))
        out = table[:, position[list(columns)]]
        return self._normalise(out) if kind == "betp" else out

    def _selected(self, kind: str, position: np.ndarray, every_free: bool) -> np.ndarray:
        """The measure of one query per row; ``position`` in [O, E, ∅] coordinates (:func:`_select_table`)."""
        fusion = self._fusion
        o = len(fusion.split.free)
        if every_free:
            out = fusion.o_measure(kind, position)
        else:
            free = position < o
            out = np.zeros(self._rows)
            if free.any():
                out[free] = fusion.o_measure(kind, np.where(free, position, 0))[free]
            exclusive = ~free & (position < o + len(fusion.split.exclusive))
            if exclusive.any():
                rows = np.flatnonzero(exclusive)
                out[rows] = fusion.e_measure(kind)[rows, position[rows] - o]
            nothing = ~(free | exclusive)
            if kind == "mass" and nothing.any():
                rows = np.flatnonzero(nothing)
                out[rows] = fusion.empty()[rows]
        if kind == "betp":
            return self._normalise(out)                  # a new array: the cached numerator stays
        return np.array(out, dtype=np.float64, copy=True)

    def _normalise(self, numerator: np.ndarray) -> np.ndarray:
        """Remove ∅ and rescale by the non-empty mass, where MassBatch.betp does (some row has m(∅) > 0)."""
        fusion = self._fusion
        scale = fusion._betp_scale
        if scale is None:
            if not fusion.empty().any():
                scale = False
            else:
                scale = fusion.kept()
                dead = scale <= 0
                if dead.any():
                    where = f" (row {int(np.flatnonzero(dead)[0])})" if self._rows > 1 else ""
                    raise TotalConflictError(f"BetP is undefined: total conflict, m(∅) = 1{where}")
            fusion._betp_scale = scale
        if scale is False:
            return np.array(numerator, dtype=np.float64, copy=True)
        return numerator / (scale if numerator.ndim == 1 else scale[:, None])

    def bel(self, queries, *, select=None) -> np.ndarray:
        out = self._closed("bel", queries, select)
        return out if out is not None else super().bel(queries, select=select)

    def pls(self, queries, *, select=None) -> np.ndarray:
        out = self._closed("pls", queries, select)
        return out if out is not None else super().pls(queries, select=select)

    def betp(self, queries, *, select=None) -> np.ndarray:
        out = self._closed("betp", queries, select)
        return out if out is not None else super().betp(queries, select=select)

    def mass(self, queries, *, select=None) -> np.ndarray:
        out = self._closed("mass", queries, select)
        return out if out is not None else super().mass(queries, select=select)

    bel.__doc__ = MassBatch.bel.__doc__
    pls.__doc__ = MassBatch.pls.__doc__
    betp.__doc__ = MassBatch.betp.__doc__
    mass.__doc__ = MassBatch.mass.__doc__


def closed_form(rule: str, batches: Sequence[MassBatch], model: Model, options: dict,
                function: Callable[..., MassBatch]) -> tuple[ClosedFormBatch | None, str]:
    """The lazy fused batch of :func:`~belief.rules.combine`, or None and the reason the closed forms do not apply.

    ``function`` is the rule of the registry; it materialises the batch on request, and the
    rows that the R-weighted rule leaves to the general path.
    """
    build, reason = _build_plan(rule, batches, model, options)
    if build is None:
        return None, reason
    try:
        fusion = build()
    except Underflow:
        function(list(batches), model, **options)          # raises TotalConflictError where K = 1 exactly
        return None, ("Dempster's normalisation divides by a non-empty mass below 2^-600, which the closed forms "
                      "cannot keep from underflowing")

    def materialise() -> MassBatch:
        return function(list(batches), model, **options)

    def general(rows: np.ndarray) -> MassBatch:
        subset = [b if len(b) == 1 else trusted_batch(b.model, b.focal, b.values[rows], canonical=b._canonical)
                  for b in batches]
        return function(subset, model, **options)

    fusion.general = general
    return ClosedFormBatch(model, fusion, materialise), ""


def check_engine(engine: str) -> str:
    """Refuse an unknown ``engine=``, listing the known ones.

    >>> check_engine("fast")
    Traceback (most recent call last):
    ...
    belief.errors.InvalidMassError: unknown engine 'fast'; known engines: auto, general, bayesian
    """
    if engine not in ENGINES:
        raise InvalidMassError(f"unknown engine {engine!r}; known engines: {', '.join(ENGINES)}")
    return engine


def not_applicable(reason: str) -> Exception:
    """The error of ``engine="bayesian"`` when the closed forms do not apply."""
    kind = InvalidMassError if reason.startswith("source") else ModelError
    return kind(f"engine='bayesian' cannot fuse these sources: {reason}; use engine='auto' or 'general'")
