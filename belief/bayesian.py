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
S·T − Σ_i s_i p_i) are between sums of products that all reach non-empty elements, so
their rounding stays below the non-empty mass itself.  BetP divides by the sum of the
non-empty masses, exactly as :meth:`~belief.batch.MassBatch.betp` does, so that both paths
find the same rows totally conflicting.

The fusions keep their arrays as (hypotheses, rows) and work in blocks of rows: a
per-row quantity of shape (N,) then broadcasts along the long axis, numpy's inner loops
run over rows rather than over the few hypotheses, and every temporary stays small.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property, lru_cache
from itertools import combinations

import numpy as np

from belief.batch import MassBatch, check_select, measure_plan
from belief.errors import InvalidMassError, ModelError, TotalConflictError
from belief.frame import Element
from belief.model import Model
from belief.plan import check_joint, weighted_sum

__all__ = ["ENGINES", "ClosedFormBatch", "ExclusiveSplit", "exclusive_split", "closed_form_rules",
           "ConjunctiveFusion", "PCRFusion", "RRuleFusion"]

#: The values of ``combine(..., engine=...)``.
ENGINES = ("auto", "general", "bayesian")

#: Rows × grid entries per block of the enumerations (a block's temporaries stay in cache).
BLOCK_ENTRIES = 1 << 18
#: Rows × |O| × |O| entries per block of the pairwise pass of the R-weighted rule.
PAIR_BLOCK_ENTRIES = 1 << 19
#: Rows per block of a fusion that reads the sources column by column (a column of a block stays
#: below the size where the allocator maps fresh pages for every temporary).
COLUMN_BLOCK_ROWS = 1 << 13
#: Rows × n entries per block of rows of the R-weighted rule's folds and of PCR: each array of a
#: block stays a few hundred kB at most, long enough to spread numpy's per-call overhead, short
#: enough that the fold's temporaries are recycled by the allocator rather than mapped afresh.
ROW_BLOCK_ENTRIES = 22_000

_CONJUNCTIVE = ("conjunctive", "dsmc", "dempster", "yager")
_PCR = ("pcr5", "pcr6")


class _NoClosedForm(Exception):
    """A measure that the closed forms of this fusion do not give (the general path answers)."""


# -- the class of models ----------------------------------------------------------------------------
@dataclass(frozen=True)
class ExclusiveSplit:
    """The hypotheses of a model split into free ones (O) and exclusive ones (E).

    Attributes
    ----------
    free : tuple of int
        Frame positions of O, in frame order; never empty (a lone hypothesis counts as free).
    exclusive : tuple of int
        Frame positions of E, in frame order.
    """

    free: tuple[int, ...]
    exclusive: tuple[int, ...]

    @property
    def size(self) -> int:
        return len(self.free) + len(self.exclusive)

    @cached_property
    def o_index(self):
        """Rows (or columns) of O in a frame-ordered array: a slice when they are contiguous (no copy)."""
        return _index(self.free)

    @cached_property
    def e_index(self):
        """Rows (or columns) of E in a frame-ordered array."""
        return _index(self.exclusive)

    @cached_property
    def position(self) -> np.ndarray:
        """For each frame position, its column in [O columns, E columns], shape (n,)."""
        out = np.empty(self.size, dtype=np.int64)
        out[list(self.free)] = np.arange(len(self.free))
        out[list(self.exclusive)] = len(self.free) + np.arange(len(self.exclusive))
        return out

    def inverse_cardinality(self, k: int) -> float:
        """1 / N_k = 2^(k − |O|), the inverse DSm cardinality of θ_S for |S| = k (no overflow for large |O|)."""
        return 2.0 ** (k - len(self.free))


def _index(positions: tuple[int, ...]):
    if positions and positions == tuple(range(positions[0], positions[-1] + 1)):
        return slice(positions[0], positions[-1] + 1)
    return np.array(positions, dtype=np.int64)


@lru_cache(maxsize=256)
def exclusive_split(model: Model) -> ExclusiveSplit | None:
    """Whether the closed forms apply to ``model``, and how its hypotheses split.

    The model must forbid exactly the pairs θ_e ∩ θ_j with e ∈ E and j ≠ e, for some set E
    of hypotheses: every other intersection is then non-empty.  When no hypothesis is
    free, one exclusive hypothesis is counted as free (alone in O, it is exclusive
    anyway), which keeps E as small as possible.

    Parameters
    ----------
    model : Model

    Returns
    -------
    ExclusiveSplit or None
        None for a frame of one hypothesis and for models outside the class.

    Examples
    --------
    >>> from belief import Frame, Model
    >>> exclusive_split(Model.for_targets(3))
    ExclusiveSplit(free=(0, 1, 2), exclusive=(3,))
    >>> exclusive_split(Model.shafer(Frame(["a", "b", "c"])))
    ExclusiveSplit(free=(0,), exclusive=(1, 2))
    >>> exclusive_split(Model.hybrid(Frame(["a", "b", "c"]), empty=["a&b"])) is None
    True
    """
    n = len(model.frame)
    if n < 2:
        return None
    forbidden = set(model.forbidden)
    if any(term.bit_count() != 2 for term in forbidden):
        return None
    exclusive = [i for i in range(n) if all((1 << i) | (1 << j) in forbidden for j in range(n) if j != i)]
    members = set(exclusive)
    expected = {(1 << i) | (1 << j) for i in exclusive for j in range(n) if j != i}
    if forbidden != expected:
        return None
    free = [i for i in range(n) if i not in members]
    if not free:
        free, exclusive = [exclusive[0]], exclusive[1:]
    return ExclusiveSplit(tuple(free), tuple(exclusive))


@dataclass(frozen=True)
class _Layout:
    """Where a batch's columns sit in the frame: a Bayesian focal list."""

    columns: tuple[int, ...]     # frame position of each non-empty column
    kept: tuple[int, ...]        # which columns those are
    empty: int | None            # the ∅ column, if any
    identity: bool               # the focal list is θ_1 … θ_n in frame order


@lru_cache(maxsize=1024)
def _layout(key) -> _Layout | None:
    """The layout of a focal list (a :class:`~belief.plan.FocalKey`), or None if it is not Bayesian."""
    columns, kept, empty = [], [], None
    for k, x in enumerate(key.focal):
        if not x.terms:
            empty = k
        elif len(x.terms) == 1 and x.terms[0].bit_count() == 1:
            columns.append(x.terms[0].bit_length() - 1)
            kept.append(k)
        else:
            return None
    if len(set(columns)) != len(columns):
        return None
    n = len(key.focal[0].frame) if key.focal else 0
    identity = empty is None and columns == list(range(n))
    return _Layout(tuple(columns), tuple(kept), empty, identity)


def _dense(batch: MassBatch, layout: _Layout, n: int) -> tuple[np.ndarray, np.ndarray | None]:
    """Masses of θ_1 … θ_n in frame order, shape (rows, n), and m(∅) if the batch has that column."""
    values = batch.values
    if layout.identity:
        return values, None
    out = np.zeros((values.shape[0], n))
    if layout.columns:
        out[:, list(layout.columns)] = values[:, list(layout.kept)]
    return out, (values[:, layout.empty] if layout.empty is not None else None)


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
        layout = _layout(b.focal_key)
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


# -- shared pieces ------------------------------------------------------------------------------------
_TINY = np.finfo(np.float64).smallest_subnormal
#: Dempster's rule below this non-empty mass goes the general way, which rescales its products
#: (belief.rules.WIDE_SCALE).  Above it, what underflowed is below 2^-474 of every result.
_WIDE_SCALE = 2.0 ** -600


class _Underflow(Exception):
    """The closed form of Dempster's rule would divide by a non-empty mass that may have underflowed."""

#: Pair weights above this (a normal number) have a finite, exact 1 / (x_i + x_l) whose products
#: with masses (≤ 1), and sums of fewer than 10¹⁷ of those, stay finite.
_RECIPROCAL_FLOOR = 2.0 ** -960


def _above(values: np.ndarray, floor: float) -> bool:
    """Whether every value exceeds ``floor`` (NaN does not): one pass, no mask."""
    return not values.size or bool(values.min() > floor)


def _below(values: np.ndarray, rows: np.ndarray) -> None:
    """Mark in ``rows`` the columns of (K, B) ``values`` with an entry at or below the floor (or NaN)."""
    if not _above(values, _RECIPROCAL_FLOOR):
        rows |= ~(values.min(axis=0) > _RECIPROCAL_FLOOR)


def _ratio(numerator: np.ndarray, denominator: np.ndarray) -> np.ndarray:
    """numerator / denominator where the denominator is positive, else 0 (never NaN)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        out = numerator / denominator
    return np.where(denominator > 0, out, 0.0)


def _share(numerator: np.ndarray, denominator: np.ndarray) -> np.ndarray:
    """numerator / denominator for 0 ≤ numerator ≤ denominator, and 0 where both are 0.

    Only a zero denominator is raised (to the smallest subnormal), so every positive one
    divides exactly as on the general path.
    """
    return numerator / np.maximum(denominator, _TINY)


def _product(arrays: Sequence[np.ndarray]) -> np.ndarray:
    out = arrays[0]
    for a in arrays[1:]:
        out = out * a
    return out if len(arrays) > 1 else out.copy()


class _Fusion:
    """Measures of a fused batch by element class.

    ``o_measure(kind)`` gives, for kind ``"bel"``, ``"pls"``, ``"mass"`` or ``"betp"`` (the
    pignistic numerator, before the division by the non-empty mass), the values for every
    free hypothesis, shape (N, |O|) (or (N,) when they are the same for all);
    ``o_measure(kind, positions)`` the value for one free hypothesis per row, shape (N,).
    ``e_measure(kind)`` gives shape (N, |E|).
    """

    rows: int
    split: ExclusiveSplit
    sources: "_Blocks"
    general: Callable[[np.ndarray], MassBatch] | None = None
    _picks: tuple[bytes, list[np.ndarray]] | None = None
    #: BetP's divisor, once checked for total conflict (False: no row has m(∅) > 0).
    _betp_scale: np.ndarray | bool | None = None

    def empty(self) -> np.ndarray:
        raise NotImplementedError

    def kept(self) -> np.ndarray:
        """Σ of the non-empty masses per row, shape (N,) (the BetP normalisation)."""
        raise NotImplementedError

    def o_measure(self, kind: str, positions: np.ndarray | None = None) -> np.ndarray:
        raise NotImplementedError

    def e_measure(self, kind: str) -> np.ndarray:
        raise NotImplementedError

    def picked(self, positions: np.ndarray) -> list[np.ndarray]:
        """Each source's mass of θ_j, j the free hypothesis ``positions[n]``, in row n; shape (N,) each.

        Bel, BetP and the mass of one reading select the same hypotheses, so the gathers of
        the last ``positions`` are kept.
        """
        key = positions.tobytes()
        if self._picks is None or self._picks[0] != key:
            sources, free = self.sources, self.split.o_index
            self._picks = (key, [sources.gather_source(k, lookup[free].take(positions))
                                 for k, lookup in enumerate(sources.lookup)])
        return self._picks[1]


def _sources(values: Sequence[np.ndarray], split: ExclusiveSplit):
    """Each source's free rows (|O|, B), exclusive rows (|E|, B) and free total O_i (B,), of one block."""
    free = [v[split.o_index] for v in values]
    excl = [v[split.e_index] for v in values]
    return free, excl, [f.sum(axis=0) for f in free]


@lru_cache(maxsize=4)
def _row_offsets(rows: int, stride: int) -> np.ndarray:
    """n · stride for n < rows: where each row starts in a flattened (rows, stride) array (read-only, shared)."""
    out = np.arange(0, rows * stride, stride, dtype=np.int64)
    out.flags.writeable = False
    return out


class _Blocks:
    """The sources read in blocks of rows, each block turned to (hypotheses, rows) in frame order.

    A fusion computes its per-row results block by block: every temporary then stays in
    cache (a temporary of the whole batch would be allocated, and the pages of its memory
    touched, at every call), while a block is long enough that numpy's per-call overhead
    is spread over thousands of rows.

    Parameters
    ----------
    values : sequence of ndarray, each shape (N, K_i)
        The sources' masses (a broadcast one-row source has stride 0 along the rows).
    width : int
        n, the hypotheses of the frame.
    pairs : int
        A pairwise pass over this many hypotheses runs per block: its (pairs, pairs) matrix
        per row must fit too.
    maps : sequence of (None or (ndarray, ndarray)), optional
        For a source whose columns are not θ_1 … θ_n in frame order: the frame position of
        each of its singleton columns, and those columns.
    step : int, optional
        Rows per block, for a fusion that reads the sources column by column
        (:meth:`total`, :meth:`part`) and never holds a whole block.
    """

    def __init__(self, values: Sequence[np.ndarray], width: int, pairs: int = 0, maps=None,
                 step: int | None = None) -> None:
        self.values = [np.asarray(v) for v in values]
        self.width = width
        self.rows = max(v.shape[0] for v in self.values)
        if step is None:
            step = max(64, min(ROW_BLOCK_ENTRIES // max(1, width), PAIR_BLOCK_ENTRIES // max(1, pairs * pairs)))
        self.step = step
        # For each source: the column of each frame position, −1 where it has none (mass 0).
        self.lookup = []
        for v, mapping in zip(self.values, maps if maps is not None else [None] * len(self.values)):
            lookup = np.arange(width, dtype=np.int64)
            if mapping is not None:
                lookup[:] = -1
                lookup[mapping[0]] = mapping[1]
            self.lookup.append(lookup)
        self.complete = [bool((lookup >= 0).all()) for lookup in self.lookup]
        in_order = np.arange(width)
        self.in_order = [np.array_equal(lookup, in_order) for lookup in self.lookup]

    def __iter__(self):
        for start in range(0, self.rows, self.step):
            yield slice(start, min(self.rows, start + self.step))

    def _columns(self, k: int) -> np.ndarray:
        """Source k as (K_k, N); rows of it are contiguous when the source is stored column-major."""
        v = self.values[k]
        if not (v.flags.c_contiguous or v.flags.f_contiguous):
            v = self.values[k] = np.ascontiguousarray(v)
        return v.T

    def block(self, rows: slice) -> list[np.ndarray]:
        """Each source's rows ``rows`` as (n, B), θ_1 … θ_n in frame order (views where the memory allows)."""
        out = []
        size = rows.stop - rows.start
        for k, v in enumerate(self.values):
            lookup = self.lookup[k]
            columns = self._columns(k)
            if v.shape[0] != self.rows:                          # one row, broadcast
                row = np.where(lookup >= 0, columns[:, 0].take(np.maximum(lookup, 0)), 0.0)
                out.append(np.repeat(row[:, None], size, axis=1))
            elif not self.complete[k]:
                block = np.zeros((self.width, size))
                present = lookup >= 0
                block[present] = columns[:, rows].take(lookup[present], axis=0)
                out.append(block)
            elif v.flags.f_contiguous and self.in_order[k]:
                out.append(columns[:, rows])                     # already (n, B), rows contiguous
            else:
                out.append(columns[lookup, rows])
        return out

    def column(self, k: int, j: int, rows: slice) -> np.ndarray | None:
        """Source k's masses of θ_j (frame position j) in ``rows``, a view: shape (B,), or (1,) if broadcast."""
        c = int(self.lookup[k][j])
        if c < 0:
            return None
        columns = self._columns(k)
        return columns[c, :1] if self.values[k].shape[0] != self.rows else columns[c, rows]

    def total(self, k: int, positions: Sequence[int], rows: slice, out: np.ndarray) -> np.ndarray:
        """Σ_j of source k's masses of θ_j, j in ``positions`` (frame order), in ``rows``, written to ``out``.

        Read where the masses lie: one reduction when the columns are adjacent, else one
        addition per column, so that no block of the source is copied.
        """
        columns = self._columns(k)
        cols = [int(self.lookup[k][j]) for j in positions]
        cols = [c for c in cols if c >= 0]
        part = columns[:, :1] if self.values[k].shape[0] != self.rows else columns[:, rows]
        if not cols:
            out[...] = 0.0
        elif len(cols) > 2 and cols == list(range(cols[0], cols[0] + len(cols))):
            adjacent = part[cols[0]:cols[-1] + 1]
            if adjacent.shape[1] == out.shape[0]:
                np.add.reduce(adjacent, axis=0, out=out)
            else:
                out[...] = np.add.reduce(adjacent, axis=0)
        elif len(cols) == 1:
            np.copyto(out, part[cols[0]])
        else:
            np.add(part[cols[0]], part[cols[1]], out=out)
            for c in cols[2:]:
                out += part[c]
        return out

    def part(self, k: int, positions: Sequence[int], rows: slice) -> np.ndarray:
        """Source k's masses of θ_j, j in ``positions``, in ``rows``: a (len(positions), B) copy."""
        out = np.zeros((len(positions), rows.stop - rows.start))
        for i, j in enumerate(positions):
            column = self.column(k, j, rows)
            if column is not None:
                out[i] = column
        return out

    def gather_source(self, k: int, columns: np.ndarray) -> np.ndarray:
        """The mass in column ``columns[n]`` of source k (−1: none, mass 0) in row n, shape (N,)."""
        v = self._columns(k).T
        absent = None if self.complete[k] else columns < 0
        if absent is not None:
            columns = np.where(absent, 0, columns)
        if v.shape[0] != self.rows:                              # a one-row source, broadcast
            out = v[0].take(columns)
        elif v.flags.c_contiguous:
            out = v.reshape(-1).take(np.add(columns, _row_offsets(self.rows, v.shape[1])))
        else:
            # Column-major: the masses of a hypothesis lie together.
            flat = np.multiply(columns, self.rows)
            flat += _row_offsets(self.rows, 1)
            out = v.T.reshape(-1).take(flat)
        if absent is not None:
            out[absent] = 0.0
        return out


def _first_pick(free: Sequence[np.ndarray], totals: Sequence[np.ndarray]) -> np.ndarray:
    """Σ m(θ_S) over the all-free tuples whose S holds j (SPEC Part D, Bel(θ_J)), for each row j of ``free``.

    Summed over the first source k that picks θ_j: Π_{i<k} (O_i − m_i(θ_j)) · m_k(θ_j) ·
    Π_{i>k} O_i, a sum of non-negative products.  The difference O_i − m_i(θ_j) is the
    mass of the other free hypotheses, never more than O_i, so its rounding stays below
    that of P_O = Π_i O_i.  Works on (|O|, N) arrays and on one (N,) value per row alike.
    """
    bel = np.array(free[0], dtype=np.float64, copy=True)
    if len(free) == 1:
        return bel
    without = np.subtract(totals[0], free[0])              # the tuples so far that avoid θ_j
    np.maximum(without, 0.0, out=without)
    term = np.empty_like(without)
    last = len(free) - 1
    for k in range(1, len(free)):
        m, total = free[k], totals[k]
        bel *= total
        bel += np.multiply(without, m, out=term)
        if k < last:
            np.subtract(total, m, out=term)
            np.maximum(term, 0.0, out=term)
            without *= term
    return bel


def _pick(values: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """values[positions[n], n] for every row n of a (K, N) array."""
    n = positions.size
    if values.flags.c_contiguous and values.shape[1] == n:
        flat = np.multiply(positions, n)
        flat += _row_offsets(n, 1)
        return values.reshape(-1).take(flat)
    return values[positions, np.arange(n)]


# -- conjunctive family ------------------------------------------------------------------------------
class ConjunctiveFusion(_Fusion):
    """The conjunctive rule, DSmC, Dempster's and Yager's rule of Bayesian sources (W (2), SPEC A.3, Part D).

    Parameters
    ----------
    values : sequence of ndarray, each shape (N, n)
        The sources' masses of θ_1 … θ_n, in frame order (see ``maps`` for other orders).
    empties : sequence of (ndarray of shape (N,) or None)
        m(∅) of each source, for the subnormal sources the conjunctive rules accept.
    split : ExclusiveSplit
    rule : {"conjunctive", "dsmc", "dempster", "yager"}
    maps : optional
        Where the columns of each source sit in the frame (:class:`_Blocks`).

    Examples
    --------
    SPEC Part D, two cues on three targets: Bel = (.52, .44, .23), Pls = .72 and m(∅) = .26.

    >>> from belief import Model
    >>> loc, col = np.array([[.5, .2, .2, .1]]), np.array([[.3, .4, .1, .2]])
    >>> fusion = ConjunctiveFusion([loc, col], [None, None], exclusive_split(Model.for_targets(3)), "dsmc")
    >>> fusion.o_measure("bel").round(12), fusion.o_measure("pls").round(12), fusion.empty().round(12)
    (array([[0.52, 0.44, 0.23]]), array([0.72]), array([0.26]))
    """

    def __init__(self, values, empties, split: ExclusiveSplit, rule: str, maps=None) -> None:
        self.split = split
        self.rule = rule
        self.sources = _Blocks(values, split.size, maps=maps, step=COLUMN_BLOCK_ROWS)
        n = self.rows = self.sources.rows
        s = len(values)
        self.totals = np.empty((s, n))                             # O_i per source
        self.exclusive = np.empty((len(split.exclusive), n))       # Π_i m_i(θ_e)
        self.conflict = np.empty(n)                                # m∩(∅), summed over conflicting tuples
        sources = self.sources
        for rows in sources:
            totals = [sources.total(k, split.free, rows, self.totals[k, rows]) for k in range(s)]
            excl = [sources.part(k, split.exclusive, rows) for k in range(s)]
            if s > 1:
                np.multiply(excl[0], excl[1], out=self.exclusive[:, rows])
                for e in excl[2:]:
                    self.exclusive[:, rows] *= e
            else:
                self.exclusive[:, rows] = excl[0]
            self.conflict[rows] = _conflict(excl, totals, [None if z is None else z[rows] for z in empties])
        self.all_free = _product(list(self.totals))                # P_O = Π_i O_i
        self.scale = np.add.reduce(self.exclusive, axis=0)         # Σ of the non-empty masses
        self.scale += self.all_free
        if rule == "dempster" and not (self.scale > _WIDE_SCALE).all():
            raise _Underflow       # total conflict, or products that underflowed: the general path tells which
        self._cache: dict = {}
        self._bel: tuple[bytes, np.ndarray] | None = None

    def empty(self) -> np.ndarray:
        return self.conflict if self.rule in ("conjunctive", "dsmc") else np.zeros(self.rows)

    def kept(self) -> np.ndarray:
        return self.scale

    def _norm(self, values: np.ndarray) -> np.ndarray:
        if self.rule != "dempster":
            return values
        return np.divide(values, self.scale, out=values if values.ndim == 1 else None)

    def _yager_shares(self) -> tuple[float, float]:
        """C(θ_j)/C(Θ) for j in O and in E: Θ holds the conflict under Yager's rule."""
        inverse = self.split.inverse_cardinality(1)                    # 1 / 2^(|O|-1)
        total = 2.0 - inverse + len(self.split.exclusive) * inverse    # C(Θ) / 2^(|O|-1)
        return 1.0 / total, inverse / total

    def _measure(self, kind: str, free: list[np.ndarray], totals, all_free, conflict, bel=None) -> np.ndarray:
        """The raw (before Dempster's normalisation) measure; fresh arrays, free to reuse."""
        if kind == "mass":
            return _product(free)
        if bel is None:
            bel = _first_pick(free, totals)
            if kind == "bel":
                return bel
        elif kind == "bel":
            return bel.copy()
        out = np.add(all_free, bel)
        out *= 0.5                                                     # θ_S with j ∉ S counts for ½
        if self.rule == "yager":
            out += conflict * self._yager_shares()[0]
        return out

    def o_measure(self, kind: str, positions: np.ndarray | None = None) -> np.ndarray:
        key = (kind, None if positions is None else positions.tobytes())
        if key in self._cache:
            return self._cache[key]
        if kind == "pls":
            out = self.all_free + self.conflict if self.rule == "yager" else self.all_free.copy()
            out = self._norm(out)
        elif positions is not None:
            free = self.picked(positions)
            bel = None
            if kind != "mass":
                # Bel and BetP of one selection share the sum over the first source that picks θ_j.
                if self._bel is None or self._bel[0] != key[1]:
                    self._bel = (key[1], _first_pick(free, list(self.totals)))
                bel = self._bel[1]
            out = self._norm(self._measure(kind, free, list(self.totals), self.all_free, self.conflict, bel))
        else:
            out = np.empty((len(self.split.free), self.rows))
            for rows in self.sources:
                free, _, _ = _sources(self.sources.block(rows), self.split)
                out[:, rows] = self._measure(kind, free, list(self.totals[:, rows]), self.all_free[rows],
                                             self.conflict[rows])
            out = self._norm(out).T
        self._cache[key] = out
        return out

    def e_measure(self, kind: str) -> np.ndarray:
        out = self.exclusive
        if kind == "pls" and self.rule == "yager":
            out = out + self.conflict
        elif kind == "betp" and self.rule == "yager":
            out = out + self.conflict * self._yager_shares()[1]
        return self._norm(out).T


def _conflict(excl, totals, empties) -> np.ndarray:
    """m∩(∅) of Bayesian sources by a pass over them, as a sum of products (never 1 − Σ).

    After source k a tuple is all-free (mass P_k), all on one exclusive θ_e (B_k(e)), or
    already conflicting (C_k); the next source keeps or breaks each state:
    C_{k+1} = C_k · T + P_k · (E + z) + Σ_e B_k(e) · (O + z + E − m(θ_e)), where T, O, E
    and z are the next source's total, free, exclusive and ∅ masses.
    """
    free_so_far = totals[0]
    same = excl[0]
    conflict = empties[0].copy() if empties[0] is not None else np.zeros(totals[0].shape)
    for e, total, z in zip(excl[1:], totals[1:], empties[1:]):
        e_total = e.sum(axis=0)
        outside = e_total if z is None else e_total + z          # what breaks an all-free tuple
        free_or_empty = total if z is None else total + z
        others = np.maximum(e_total - e, 0.0)                    # the other exclusive hypotheses
        conflict = (conflict * (free_or_empty + e_total) + free_so_far * outside
                    + (same * (free_or_empty + others)).sum(axis=0))
        free_so_far = free_so_far * total
        same = same * e
    return conflict


# -- PCR5 and PCR6 -----------------------------------------------------------------------------------
class PCRFusion(_Fusion):
    """PCR5 and PCR6 of Bayesian sources (SPEC A.3): consensus plus proportional redistribution.

    Only tuples that hold an exclusive hypothesis conflict.  Two sources: the pairs
    (θ_e, θ_y), (θ_x, θ_e) and (θ_e, θ_e′), O(|E|·n) per row.  More sources (|E| ≤ 1): for
    each set A of sources that pick the exclusive θ_F, the others pick free hypotheses, a
    grid of |O|^(s−|A|) tuples per row.

    Examples
    --------
    Zadeh's example on Shafer's model: PCR6 gives (.486, .486, .028).

    >>> from belief import Frame, Model
    >>> split = exclusive_split(Model.shafer(Frame(["a", "b", "c"])))
    >>> fusion = PCRFusion([np.array([[.9, 0, .1]]), np.array([[0, .9, .1]])], split, "pcr6")
    >>> np.hstack([fusion.o_measure("mass"), fusion.e_measure("mass")]).round(12)
    array([[0.486, 0.486, 0.028]])
    """

    def __init__(self, values, split: ExclusiveSplit, rule: str, maps=None) -> None:
        self.split = split
        self.rule = rule
        # With three sources or more a block holds one (|O|, |O|) grid per row.
        self.sources = _Blocks(values, split.size, len(split.free) if len(values) > 2 else 0, maps)
        self.rows = self.sources.rows
        self.s = len(values)
        self._parts: dict | None = None
        self._cache: dict = {}
        self._share: tuple[bytes, np.ndarray, np.ndarray | None] | None = None

    def parts(self) -> dict:
        """Per row: O_i, P_O, Π_i m_i(θ_e), and what the conflicting tuples give back to each hypothesis."""
        if self._parts is None:
            n, o, e = self.rows, len(self.split.free), len(self.split.exclusive)
            parts = {"totals": np.empty((self.s, n)), "exclusive": np.empty((e, n)),
                     "to_free": np.empty((o, n)), "to_excl": np.empty((e, n))}
            for rows in self.sources:
                free, excl, totals = _sources(self.sources.block(rows), self.split)
                parts["totals"][:, rows] = totals
                parts["exclusive"][:, rows] = _product(excl)
                if not e:
                    parts["to_free"][:, rows] = 0.0
                elif self.s == 2:
                    parts["to_free"][:, rows], parts["to_excl"][:, rows] = _two_sources(free, excl)
                else:
                    parts["to_free"][:, rows], parts["to_excl"][:, rows] = _enumerated(free, excl, self.rule)
            parts["all_free"] = _product(list(parts["totals"]))
            parts["spread"] = parts["all_free"] + parts["to_free"].sum(axis=0)      # every free-side mass
            self._parts = parts
        return self._parts

    def empty(self) -> np.ndarray:
        return np.zeros(self.rows)

    def kept(self) -> np.ndarray:
        return np.ones(self.rows)

    def o_measure(self, kind: str, positions: np.ndarray | None = None) -> np.ndarray:
        key = (kind, None if positions is None else positions.tobytes())
        if key in self._cache:
            return self._cache[key]
        parts = self.parts()
        if kind == "pls":
            out = parts["spread"]
        elif positions is not None:
            free = self.picked(positions)
            if self._share is None or self._share[0] != key[1]:
                self._share = (key[1], _pick(parts["to_free"], positions), None)
            share = self._share[1]
            if kind == "mass":
                out = _product(free) + share
            else:
                # Bel and BetP of one selection share the sum over the first source that picks θ_j.
                if self._share[2] is None:
                    bel = _first_pick(free, list(parts["totals"]))
                    bel += share
                    self._share = (key[1], share, bel)
                bel = self._share[2]
                out = bel.copy() if kind == "bel" else 0.5 * (parts["spread"] + bel)
        else:
            out = np.empty((len(self.split.free), self.rows))
            for rows in self.sources:
                free, _, _ = _sources(self.sources.block(rows), self.split)
                out[:, rows] = self._measure(kind, free, list(parts["totals"][:, rows]), parts["to_free"][:, rows],
                                             parts["spread"][rows])
            out = out.T
        self._cache[key] = out
        return out

    @staticmethod
    def _measure(kind, free, totals, share, spread) -> np.ndarray:
        if kind == "mass":
            return _product(free) + share
        bel = _first_pick(free, totals) + share
        return bel if kind == "bel" else 0.5 * (spread + bel)

    def e_measure(self, kind: str) -> np.ndarray:
        parts = self.parts()
        return (parts["exclusive"] + parts["to_excl"]).T


def _two_sources(free, excl) -> tuple[np.ndarray, np.ndarray]:
    """The redistribution of two sources' conflicting pairs (θ_e, θ_y), (θ_x, θ_e), (θ_e, θ_e′), one block."""
    (x1, x2), (e1, e2) = free, excl
    # For two sources the PCR5 and PCR6 weights are the same, m_1(X) and m_2(Y).
    g12 = _share(e1[:, None] * x2[None], e1[:, None] + x2[None])          # (E, O, B)
    g21 = _share(x1[:, None] * e2[None], x1[:, None] + e2[None])          # (O, E, B)
    to_free = x2 * g12.sum(axis=0) + x1 * g21.sum(axis=1)
    to_excl = e1 * g12.sum(axis=1) + e2 * g21.sum(axis=0)
    if e1.shape[0] > 1:
        gee = _share(e1[:, None] * e2[None], e1[:, None] + e2[None])       # (E, E, B)
        diagonal = np.arange(e1.shape[0])
        gee[diagonal, diagonal] = 0.0
        to_excl = to_excl + e1 * gee.sum(axis=1) + e2 * gee.sum(axis=0)
    return to_free, to_excl


def _enumerated(free, excl, rule) -> tuple[np.ndarray, np.ndarray]:
    """s ≥ 3 sources, one exclusive hypothesis F: every split of the sources into A (on F) and B, one block."""
    s = len(free)
    f = [e[0] for e in excl]
    to_free = np.zeros(free[0].shape)
    to_f = np.zeros(free[0].shape[1])
    pcr5 = rule == "pcr5"
    for size in range(1, s):
        for on_f in combinations(range(s), size):
            product = _product([f[k] for k in on_f])
            total = f[on_f[0]].copy()
            for k in on_f[1:]:
                total += f[k]
            weight_f = product if pcr5 else total      # PCR5: one group, Π m_i(F); PCR6: Σ m_i(F)
            xs = [free[k] for k in range(s) if k not in on_f]
            _grid_shares(xs, product, weight_f, pcr5, to_free, to_f)
    return to_free, to_f[None]


def _grid_shares(xs: list[np.ndarray], product: np.ndarray, weight_f: np.ndarray, pcr5: bool,
                 to_free: np.ndarray, to_f: np.ndarray) -> None:
    """Add the shares of the tuples where the sources of ``xs`` pick free hypotheses and the others F.

    The tuple (a_1, …, a_b) has the product P = product · Π_k x_k(a_k).  PCR6 sends
    P · x_k(a_k) / D to θ_{a_k} for each k and P · weight_f / D to F, with
    D = weight_f + Σ_k x_k(a_k); PCR5 weighs each distinct element once, by the product of
    the masses put on it.  One or two free positions: a matrix H_ab = 1/D per row and two
    products with it; more: the whole grid, in blocks of rows.
    """
    b = len(xs)
    if b == 1:
        (x,) = xs
        g = product * _share(x, weight_f + x)              # P / D per free hypothesis
        to_free += x * g
        to_f += weight_f * g.sum(axis=0)
        return
    o, rows = xs[0].shape
    block = max(64, BLOCK_ENTRIES // max(1, o ** b))
    if b == 2:
        _pair_grid_shares(xs[0], xs[1], product, weight_f, pcr5, block, to_free, to_f)
        return
    shape = [o] * b
    if pcr5:
        axes = np.indices(shape)
        equal = {(k, j): (axes[k] == axes[j])[..., None] for k in range(b) for j in range(b) if k != j}
        first = [np.logical_and.reduce([~equal[(j, k)] for j in range(k)]) if k else np.ones(shape + [1], bool)
                 for k in range(b)]
    for start in range(0, rows, block):
        r = slice(start, min(rows, start + block))
        n = r.stop - r.start
        grid = [x[:, r].reshape(tuple(o if j == k else 1 for j in range(b)) + (n,)) for k, x in enumerate(xs)]
        p = product[r] * _product(grid)
        wf = weight_f[r]
        if pcr5:
            weights = []
            for k in range(b):
                w = grid[k]
                for j in range(b):
                    if j != k:
                        w = w * np.where(equal[(k, j)], grid[j], 1.0)
                weights.append(w * first[k])
        else:
            weights = grid
        denominator = wf + weights[0]
        for w in weights[1:]:
            denominator = denominator + w
        g = p / np.maximum(denominator, 1e-300)            # D = 0 only where P = 0
        for k in range(b):
            others = tuple(j for j in range(b) if j != k)
            to_free[:, r] += (weights[k] * g).sum(axis=others).reshape(o, n)
        to_f[r] += wf * g.reshape(-1, n).sum(axis=0)


def _pair_grid_shares(x: np.ndarray, y: np.ndarray, product: np.ndarray, weight_f: np.ndarray, pcr5: bool,
                      block: int, to_free: np.ndarray, to_f: np.ndarray) -> None:
    """:func:`_grid_shares` of two free positions: H_ab = 1 / (w_F + x_a + y_b) per row, two contractions.

    θ_a gets c x_a² Σ_b H_ab y_b and θ_b gets c y_b² Σ_a H_ab x_a, F gets c w_F Σ_ab x_a H_ab y_b.
    The grid and the per-block results are allocated once and reused from block to block.
    """
    o, rows = x.shape
    diagonal = np.arange(o)
    # D = 0 only where x_a = y_b = w_F = 0, and then every share of the tuple vanishes; raising
    # w_F + x_a to 1e-300 changes no share by more than its tuple's product, below 1e-300.
    alpha = np.add(x, weight_f)
    np.maximum(alpha, 1e-300, out=alpha)
    step = min(block, rows)
    grid, hy, hx, term = np.empty((o, o, step)), np.empty((o, step)), np.empty((o, step)), np.empty((o, step))
    for start in range(0, rows, step):
        r = slice(start, min(rows, start + step))
        if r.stop - r.start != step:                     # the last, shorter block
            step = r.stop - r.start
            grid, hy, hx, term = np.empty((o, o, step)), np.empty((o, step)), np.empty((o, step)), np.empty((o, step))
        xr, yr, c, wf = x[:, r], y[:, r], product[r], weight_f[r]
        np.add(alpha[:, None, r], yr[None], out=grid)    # (a, b, rows): D = w_F + x_a + y_b
        np.divide(1.0, grid, out=grid)
        if pcr5:
            grid[diagonal, diagonal] = 0.0               # a = b is one group: below
        np.einsum("abn,bn->an", grid, yr, out=hy)
        np.einsum("abn,an->bn", grid, xr, out=hx)
        np.multiply(xr, hy, out=term)                    # x_a Σ_b H_ab y_b
        to_f[r] += wf * c * np.add.reduce(term, axis=0)
        term *= xr
        hx *= yr
        hx *= yr
        term += hx
        term *= c
        to_free[:, r] += term
        if pcr5:
            group = xr * yr                              # both sources on θ_a: weight m_1(θ_a) m_2(θ_a)
            g = c * _share(group, c + group)
            to_free[:, r] += group * g
            to_f[r] += c * g.sum(axis=0)


# -- the R-weighted rule -------------------------------------------------------------------------------
@dataclass
class _RState:
    """A running R-weighted result by element class: (N,) per class, (|O|, N) per free hypothesis."""

    s: np.ndarray                          # m(θ_i)
    u: np.ndarray                          # m(θ_i ∪ F)
    f: np.ndarray                          # m(F)
    e: np.ndarray                          # m(∅)
    q: np.ndarray                          # Σ m(θ_S), |S| ≥ 2
    qj: np.ndarray                         # Σ_{S∋j} m(θ_S), per j
    v: np.ndarray                          # Σ m(θ_S ∪ F), |S| ≥ 2
    vj: np.ndarray                         # Σ_{S∋j} m(θ_S ∪ F), per j
    q_squares: np.ndarray | None = None    # Σ_S m(θ_S)², known while every θ_S is a pair (after one fold)
    fresh: bool = False                    # a Bayesian source: every class but θ_i and F is empty
    no_v: bool = True                      # no θ_S ∪ F yet
    u_total: np.ndarray | None = None      # Σ_i m(θ_i ∪ F), when known

    @classmethod
    def bayesian(cls, s: np.ndarray, f: np.ndarray) -> "_RState":
        # Read-only zeros without memory: a fresh state's other classes are never read per element.
        zero = np.broadcast_to(0.0, (s.shape[1],))
        zeros = np.broadcast_to(0.0, s.shape)
        return cls(s, zeros, f, zero, zero, zeros, zero, zeros, zero, fresh=True)


class _Fold:
    """The quantities that one fold of the R-weighted rule with a Bayesian cue shares out (SPEC A.4).

    With the running result m (element classes of :class:`_RState`) and the cue p (p_i on
    the free hypotheses, p_F on the exclusive one F), m0 (Dempster's rule on the Shafer
    projections) only has singleton keys: m0(θ_i) ∝ w_i = (s_i + u_i) p_i and
    m0(F) ∝ w_F = (f + U + V) p_F.  The conflicting pairs (W (11)), where R·k goes (W (14))
    and how (1 − R)·k is split (W (12), (12′), (13)):

    ===================  ===================  ===================  ==================================
    pair                 k                    R·k                  (1 − R)·k
    ===================  ===================  ===================  ==================================
    θ_i, θ_l             s_i p_l + s_l p_i    θ_i ∩ θ_l            θ_i : θ_l as w_i : w_l
    θ_i, F               s_i p_F + f p_i      θ_i ∪ F, or ∅        θ_i : F as w_i : w_F
    θ_S, F               m(θ_S) p_F           θ_S ∪ F, or ∅        F and θ_S ∪ F, ½ each
    θ_i ∪ F, θ_l         u_i p_l              θ_i ∩ θ_l            all to θ_l
    θ_S ∪ F, θ_l         m(θ_S ∪ F) p_l       θ_{S∪{l}}            θ_S ∪ F : θ_l as w_F : w_l
    ===================  ===================  ===================  ==================================

    Every other product is consensus: θ_S with θ_l goes to θ_{S∪{l}}, θ_i ∪ F with θ_i to θ_i,
    every element holding F with F to F, and ∅ stays on ∅.  When m0 gives a pair no
    weight, SPEC A.4 weighs it by the sources' own support: exact sums for the first, second
    and fourth pair; the third and fifth depend on each m(θ_S), and their rows are
    ``flagged`` for the general path.  Terms of classes that are still empty (the first
    fold starts from a Bayesian source) are skipped.
    """

    def __init__(self, state: _RState, p: np.ndarray, p_f: np.ndarray, r_rho: tuple[np.ndarray, np.ndarray],
                 union: bool) -> None:
        s, f = state.s, state.f
        self.r, self.rho = r_rho                               # R and 1 − R (_state_inconsistency)
        self.state, self.p, self.p_f, self.union = state, p, p_f, union
        self._totals: dict | None = None
        self.t = np.add.reduce(p, 0)
        self.s_total = np.add.reduce(s, 0)
        fresh = state.fresh
        if fresh:
            self.w = s * p
            self.w_f = f * p_f
        else:
            self.u_total = state.u_total if state.u_total is not None else np.add.reduce(state.u, 0)
            self.w = s + state.u
            self.w *= p
            self.w_f = (f + self.u_total + state.v) * p_f
        self.k_f = s * p_f                                     # k of θ_i against F
        self.k_f += f * p
        both = self.w + self.w_f
        floor = _above(both, _RECIPROCAL_FLOOR)
        self.complete = complete = floor or bool(both.all())   # m0 weighs every pair θ_i, F
        if not complete:
            lost = ~(both > 0)
            both[lost] = 1.0                                # w = w_F = 0 there: their shares are 0
            floor = _above(both, _RECIPROCAL_FLOOR)
        self._both, self._inverse = both, floor
        if floor:
            inverse = np.divide(1.0, both, out=both)        # 1 / (w_i + w_F), one division for both shares
            self.to_target = self.w * inverse
        else:
            # Weights of 1e-300 and below (masses whose products underflow): the shares, at most
            # 1, are formed directly, where 1 / (w_i + w_F) would overflow.
            self.to_target = self.w / both
        if not state.no_v:
            # θ_S ∪ F against θ_l: θ_l gets p_l w_l/(w_F + w_l), θ_S ∪ F keeps Σ_l p_l w_F/(w_F + w_l).
            self.to_l = p * self.to_target
            self.stays = _dot(p, self.to_f)
        self.to_union = None
        self.fallback = None
        if not complete:
            fallback = lost & (self.k_f > 0)
            if fallback.any():
                # θ_i against F without m0 weight: split by support σ_i : f + p_F : u_i (SPEC A.4).
                hyp, rows = np.nonzero(fallback)
                sigma = s[hyp, rows] + p[hyp, rows]
                own_f = f[rows] + p_f[rows]
                u = np.zeros(rows.size) if fresh else state.u[hyp, rows]
                total = sigma + own_f + u
                self.to_target[hyp, rows] = sigma / total
                # What F gets there, the ratio first (≤ 1): k_iF · (f + p_F) underflows for masses
                # near 1e-150 while the share itself is representable, and F's m0 weight in the
                # next fold may be that share alone.
                self.fallback = (rows, self.k_f[hyp, rows] * (own_f / total))
                self.to_union = np.zeros(s.shape)
                self.to_union[hyp, rows] = u / total
        self.flagged = np.zeros(s.shape[1], dtype=bool)
        self.pair_rows = np.zeros(0, dtype=np.int64)
        self.w_floor = False                                    # every w_i above the reciprocal floor
        if not fresh:
            self.half = 0.5 * (self.w_f > 0)
            self.flagged = (state.q > 0) & (p_f > 0) & ~(self.w_f > 0)
            if not state.no_v and not complete:
                self.flagged |= (state.v > 0) & (lost & (p > 0)).any(axis=0)
            least = self.w.min() if self.w.size else 1.0
            self.w_floor = bool(least > _RECIPROCAL_FLOOR)
            if least > 0:
                self.zero_w = None                              # m0 weighs every target
                self.some_zero_w = np.zeros(s.shape[1], dtype=bool)
            else:
                self.zero_w = p > 0
                self.zero_w &= ~(self.w > 0)
                self.some_zero_w = self.zero_w.any(axis=0)
                self.pair_rows = np.flatnonzero(self.some_zero_w & (self.u_total > 0))

    @cached_property
    def to_f(self) -> np.ndarray:
        """w_F / (w_i + w_F): F's part of the pairs θ_i, F (formed only where a fold needs it whole)."""
        if self._inverse:
            return self.w_f * self._both
        return self.w_f / self._both

    @property
    def except_p(self) -> np.ndarray:
        """Σ_{l≠i} p_l: a float sum of non-negative terms is at least each of them, so t − p ≥ 0."""
        return self.t - self.p

    @property
    def except_u(self) -> np.ndarray:
        """Σ_{l≠i} u_l (≥ 0, as t − p)."""
        return self.u_total - self.state.u

    @property
    def sigma(self) -> np.ndarray:
        """Support m(θ_i) + p(θ_i), the weight of SPEC A.4's fallback."""
        return self.state.s + self.p

    def totals(self, names: tuple[str, ...] = ("s", "f", "u", "q", "v", "e")) -> dict[str, np.ndarray]:
        """The totals after the fold, O(|O|) per row, cached.

        Keys: ``s`` Σ_i m′(θ_i), ``f`` m′(F), ``u`` Σ_i m′(θ_i ∪ F), ``q`` Σ_S m′(θ_S),
        ``v`` Σ_S m′(θ_S ∪ F), ``e`` m′(∅).
        """
        if self._totals is None:
            self._totals = {}
        missing = tuple(k for k in names if k not in self._totals)
        if missing:
            self._totals.update(self._compute_totals(missing))
        return self._totals

    def _unions_to_targets(self) -> np.ndarray:
        """p_i Σ_{l≠i} u_l where m0 weighs θ_i: the pairs θ_l ∪ F / θ_i give θ_i all of (1 − R)·k."""
        out = self.p * self.except_u
        if self.zero_w is not None:
            out[self.zero_w] = 0.0
        return out

    def _f_share(self) -> np.ndarray:
        """Σ_i k_iF w_F / (w_i + w_F): F's part of the conflicts θ_i / F (with SPEC A.4's fallback)."""
        if self._inverse and "to_f" not in self.__dict__:
            out = _dot(self.k_f, self._both)                # Σ_i k_iF / (w_i + w_F), then times w_F
            out *= self.w_f
        else:
            out = _dot(self.k_f, self.to_f)
        if self.fallback is not None:
            np.add.at(out, *self.fallback)
        return out

    def _compute_totals(self, names: tuple[str, ...]) -> dict[str, np.ndarray]:
        st, rho, r, k_f = self.state, self.rho, self.r, self.k_f
        fresh = st.fresh
        out = {}
        # Σ_i s_i p_i and Σ_i u_i p_i: their sum is Σ_i w_i, the consensus on the singletons.
        sp = self.w.sum(axis=0) if fresh else _dot(st.s, self.p)
        up = None if fresh else _dot(st.u, self.p)
        if "s" in names or "q" in names:
            # Σ_{i<l} k_il = Σ_{i≠l} s_i p_l = S t − Σ_i s_i p_i: a difference of sums of target
            # products, which the fold gives to non-empty elements whatever R (never 1 − m(∅)).
            pairs = np.maximum(self.s_total * self.t - sp, 0.0)
            unions = None if fresh else np.maximum(self.u_total * self.t - up, 0.0)    # Σ_i u_i Σ_{l≠i} p_l
        if "s" in names:
            to_singles = pairs + _dot(k_f, self.to_target)
            if not fresh:
                # θ_l ∪ F against θ_i: θ_i gets p_i Σ_{l≠i} u_l = U t − Σ u p, where m0 weighs θ_i.
                to_singles += unions
                if self.zero_w is not None:
                    to_singles -= np.where(self.zero_w, self.p * self.except_u, 0.0).sum(axis=0)
                    if self.pair_rows.size:
                        to_singles[self.pair_rows] += self._target_fallback(self.pair_rows).sum(axis=0)
                if not st.no_v:
                    to_singles += st.v * self.to_l.sum(axis=0)
            out["s"] = (sp if fresh else sp + up) + rho * to_singles
        q_p_f = None if fresh else st.q * self.p_f
        if "f" in names:
            to_f = self._f_share()
            if not fresh:
                to_f += self.half * q_p_f
            out["f"] = self.w_f + rho * to_f
        if "u" in names:
            to_unions = np.zeros(r.shape) if self.to_union is None else _dot(k_f, self.to_union)
            if not fresh and self.pair_rows.size:
                to_unions[self.pair_rows] += self._union_fallback(self.pair_rows).sum(axis=0)
            out["u"] = (r * k_f.sum(axis=0) if self.union else 0.0) + rho * to_unions
        if "q" in names:
            q_new = r * pairs
            if not fresh:
                q_new += st.q * self.t + r * unions
                if not st.no_v:
                    q_new += r * st.v * self.t
            out["q"] = q_new
        if "v" in names:
            v_new = np.zeros(r.shape)
            if not fresh:
                v_new += ((r if self.union else 0.0) + rho * self.half) * q_p_f
                if not st.no_v:
                    v_new += rho * st.v * self.stays
            out["v"] = v_new
        if "e" in names:
            e_new = np.zeros(r.shape) if self.union else r * k_f.sum(axis=0)
            if not fresh:
                e_new += st.e * (self.t + self.p_f) + (0.0 if self.union else r * q_p_f)
            out["e"] = e_new
        return out

    def full(self, positions: np.ndarray | None = None) -> _RState:
        """The state after the fold, every free hypothesis: O(|O|²) per row.

        With ``positions`` (the fold before a last one that is read for one target per row)
        Σ_{S∋j} m′(θ_S) and Σ_{S∋j} m′(θ_S ∪ F) are kept for j = positions[n] only, shape (B,).
        """
        st, p, k_f, rho, r = self.state, self.p, self.k_f, self.rho, self.r
        s = st.s
        to_singles = _pair_shares(s, p, self.w)
        to_singles += k_f * self.to_target
        to_unions = None if self.to_union is None else k_f * self.to_union
        if positions is None:
            def pick(a):
                return a
            sj, pj, t, s_total = s, p, self.t, self.s_total
        else:
            flat = positions * s.shape[1] + np.arange(s.shape[1])

            def pick(a):
                return a.reshape(-1).take(flat)
            sj, pj = pick(s), pick(p)
            t, s_total = self.t, self.s_total
        qj = s_total - sj                                               # ≥ 0, as t − p
        qj *= pj
        qj += sj * (t - pj)
        qj *= r
        vj = np.zeros(qj.shape)
        if not st.fresh:
            to_singles += self._unions_to_targets()
            if self.pair_rows.size:
                rows = self.pair_rows
                to_singles[:, rows] += self._target_fallback(rows)
                if to_unions is None:
                    to_unions = np.zeros_like(s)
                to_unions[:, rows] += self._union_fallback(rows)
            qj_before, uj = pick(st.qj), pick(st.u)
            qj += (qj_before * t + np.maximum(st.q - qj_before, 0.0) * pj
                   + r * (uj * (t - pj) + pj * (self.u_total - uj)))
            vj += ((r if self.union else 0.0) + rho * self.half) * self.p_f * qj_before
            if not st.no_v:
                to_singles += st.v * self.to_l
                vj_before = pick(st.vj)
                qj += r * (vj_before * t + np.maximum(st.v - vj_before, 0.0) * pj)
                vj += rho * self.stays * vj_before
        if to_unions is not None:
            u = rho * to_unions
            if self.union:
                u += r * k_f
        else:
            u = r * k_f if self.union else np.zeros_like(s)
        totals = self.totals(("f", "e", "q", "v"))
        to_singles *= rho
        to_singles += self.w
        return _RState(to_singles, u, totals["f"], totals["e"], totals["q"], qj, totals["v"], vj,
                       fresh=False, no_v=st.fresh, u_total=np.add.reduce(u, 0))

    def selected(self, j: np.ndarray) -> dict[str, np.ndarray]:
        """m′(θ_J), m′(θ_J ∪ F), Σ_{S∋J} m′(θ_S), Σ_{S∋J} m′(θ_S ∪ F) for one J = j[n] per row.

        O(|O|) per row: the pairs of θ_J with the other targets only.
        """
        st, p, rho, r = self.state, self.p, self.rho, self.r
        s = st.s
        o, n = s.shape
        flat = j * n + np.arange(n)

        def pick(a):
            return a.reshape(-1).take(flat)

        s_j, p_j, w_j = pick(s), pick(p), pick(self.w)
        # θ_J against every other θ_l: k_Jl = s_J p_l + p_J s_l split by m0, w_J : w_l, that is
        # w_J (s_J Σ_l p_l h_l + p_J Σ_l s_l h_l) with h_l = 1 / (w_J + w_l), l ≠ J; by support
        # where m0 gives neither any weight.
        both = w_j + self.w
        if self.w_floor or _above(both, _RECIPROCAL_FLOOR):    # w_J + w_l ≥ w_l
            h = np.divide(1.0, both, out=both)
            h.reshape(-1)[flat] = 0.0
            to_single = w_j * (s_j * _dot(p, h) + p_j * _dot(s, h))
        else:
            k = s_j * p
            k += p_j * s
            lost = ~(both > 0) & (k > 0)
            share = _share(np.broadcast_to(w_j, both.shape), both)
            if lost.any():
                hyp, cols = np.nonzero(lost)
                g_b = s_j[cols] + p_j[cols]
                share[hyp, cols] = g_b / (g_b + s[hyp, cols] + p[hyp, cols])
            share.reshape(-1)[flat] = 0.0
            to_single = _dot(k, share)
        k_f = pick(self.k_f)
        to_single += k_f * pick(self.to_target)
        to_union = np.zeros(n) if self.to_union is None else k_f * pick(self.to_union)
        except_p = self.t - p_j
        qj = self.s_total - s_j
        qj *= p_j
        qj += s_j * except_p
        qj *= r
        vj = np.zeros(n)
        if not st.fresh:
            u = st.u
            u_j = pick(u)
            except_u = self.u_total - u_j
            plain = w_j > 0
            to_single += p_j * except_u * plain
            bare = ~plain & (p_j > 0) & (except_u > 0)
            if bare.any():
                # θ_l ∪ F against θ_J without m0 weight on θ_J: θ_J gets σ_J / (u_l + σ_J).
                b = np.flatnonzero(bare)
                g_b = s_j[b] + p_j[b]
                ratio = _share(np.broadcast_to(g_b, (o, b.size)), u[:, b] + g_b)
                ratio[j[b], np.arange(b.size)] = 0.0
                to_single[b] += p_j[b] * (u[:, b] * ratio).sum(axis=0)
            lonely = u_j > 0
            lonely &= self.some_zero_w
            if lonely.any():
                # θ_J ∪ F against θ_l without m0 weight on θ_l: θ_J ∪ F keeps u_J / (u_J + σ_l).
                b = np.flatnonzero(lonely)
                terms = np.where(self.zero_w[:, b], _share(p[:, b], u_j[b] + s[:, b] + p[:, b]), 0.0)
                terms[j[b], np.arange(b.size)] = 0.0
                to_union[b] += u_j[b] * u_j[b] * terms.sum(axis=0)
            qj_j = st.qj if st.qj.ndim == 1 else pick(st.qj)        # kept for J only by the fold before
            qj += qj_j * self.t + np.maximum(st.q - qj_j, 0.0) * p_j + r * (u_j * except_p + p_j * except_u)
            vj += ((r if self.union else 0.0) + rho * self.half) * self.p_f * qj_j
            if not st.no_v:
                vj_j = st.vj if st.vj.ndim == 1 else pick(st.vj)
                to_single += st.v * pick(self.to_l)
                qj += r * (vj_j * self.t + np.maximum(st.v - vj_j, 0.0) * p_j)
                vj += rho * self.stays * vj_j
        u_new = rho * to_union
        if self.union:
            u_new += r * k_f
        to_single *= rho
        to_single += w_j
        return {"s": to_single, "u": u_new, "qj": qj, "vj": vj}

    def _union_pairs(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """D_ij = σ_i + u_j and the mask of the pairs it counts (targets i without m0 weight, j ≠ i); (|O|, |O|, R)."""
        u, sigma, zero_w = self.state.u[:, rows], self.sigma[:, rows], self.zero_w[:, rows]
        denominator = sigma[:, None] + u[None]
        counted = np.broadcast_to(zero_w[:, None], denominator.shape).copy()
        diagonal = np.arange(u.shape[0])
        counted[diagonal, diagonal] = False
        return denominator, counted

    def _target_fallback(self, rows: np.ndarray) -> np.ndarray:
        """θ_i's share of the pairs θ_j ∪ F / θ_i without m0 weight: p_i Σ_j u_j σ_i / (u_j + σ_i).

        The ratio σ_i / (u_j + σ_i) ≤ 1 is formed first, so tiny supports cannot overflow it.
        """
        denominator, counted = self._union_pairs(rows)
        shares = _share(np.broadcast_to(self.sigma[:, rows][:, None], denominator.shape), denominator)
        shares *= counted
        return self.p[:, rows] * np.einsum("ijn,jn->in", shares, self.state.u[:, rows])

    def _union_fallback(self, rows: np.ndarray) -> np.ndarray:
        """θ_j ∪ F's share of the same pairs: u_j Σ_i p_i u_j / (u_j + σ_i), the ratio formed first."""
        denominator, counted = self._union_pairs(rows)
        u = self.state.u[:, rows]
        shares = _share(np.broadcast_to(u[None], denominator.shape), denominator)
        shares *= counted
        return u * np.einsum("ijn,in->jn", shares, self.p[:, rows])


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Σ_i a_i b_i over the hypotheses of (K, B) arrays (one pass, no BLAS)."""
    if a.ndim == 2 and a.shape == b.shape:
        return np.einsum("ij,ij->j", a, b)
    return np.add.reduce(a * b, 0)


def _pair_shares(s: np.ndarray, p: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Σ_{l≠i} k_il m0(θ_i) / (m0(θ_i) + m0(θ_l)) for every i, k_il = s_i p_l + s_l p_i (support fallback).

    The sum does not factorise: one (|O|, |O|) matrix per row, built by :func:`_pair_sums`
    and multiplied by w_i once; the pairs whose weights sum below the floor are then
    corrected by :func:`_low_pairs`, where a pair without m0 weight is split by support
    σ_i : σ_l, σ = s + p (SPEC A.4).  Shape (|O|, B).
    """
    out = _pair_sums(w, s, p, np.zeros(s.shape))
    out *= w
    return _low_pairs(w, s, p, out)


def _pair_sums(weights: np.ndarray, s: np.ndarray, p: np.ndarray, out: np.ndarray) -> np.ndarray:
    """``out`` plus Σ_{l≠i} k_il / max(x_i + x_l, floor) for every i, k_il = s_i p_l + s_l p_i, in place.

    Shape (|O|, B).  Both k and D = x_i + x_l are symmetric, so each unordered pair is formed
    once, the pairs (i, i + d) of one offset d together, and G_il = k_il / D_il goes to both
    ends; a caller multiplies by x_i last.  The floor (:data:`_RECIPROCAL_FLOOR`, a normal
    number) keeps every G finite and exact for the pairs above it (k ≤ 2, so G ≤ 2 / floor
    and a sum of fewer than 10¹⁷ of them stays finite); the pairs below it, both of whose
    weights lie below the floor, get x_i G ≤ k x_i / floor, which :func:`_low_pairs` tops up
    to their exact share.
    """
    o, n = s.shape
    clamp = not _above(weights, 0.5 * _RECIPROCAL_FLOOR)     # x_i + x_l ≥ 2 min x
    pair, share, term = np.empty((o - 1, n)), np.empty((o - 1, n)), np.empty((o - 1, n))
    for d in range(1, o):
        m = o - d
        d_il, k_il, t = pair[:m], share[:m], term[:m]
        np.add(weights[:m], weights[d:], out=d_il)
        if clamp:
            np.maximum(d_il, _RECIPROCAL_FLOOR, out=d_il)
        np.multiply(s[:m], p[d:], out=k_il)
        k_il += np.multiply(s[d:], p[:m], out=t)
        k_il /= d_il
        out[:m] += k_il
        out[d:] += k_il
    return out


def _low_pairs(weights: np.ndarray, s: np.ndarray, p: np.ndarray, out: np.ndarray) -> np.ndarray:
    """``out`` (x_i Σ_l G_il of :func:`_pair_sums`) topped up to the exact shares of the pairs below the floor.

    A pair with D = x_i + x_l below :data:`_RECIPROCAL_FLOOR` got k x_i / floor; its exact
    share is k x_i / D, formed ratio first (x_i / D ≤ 1, so weights of 1e-300 and below
    cannot overflow it), and with D = 0 (no m0 weight) k σ_i / (σ_i + σ_l), σ = s + p
    (SPEC A.4).  The missing part, k (x_i / D)(1 − D / floor) or the whole fallback share,
    is non-negative and is added.  Both weights of such a pair lie below the floor, and
    k_il = s_i p_l + s_l p_i is a sum of two products s_a p_b, so each row's low targets
    with running mass (a) and those with cue mass (b) are gathered into two compact lists
    first, and the product s_a p_b is shared out on their (a, b) grid; shape (|O|, B).
    """
    if _above(weights, _RECIPROCAL_FLOOR):
        return out
    low = weights < _RECIPROCAL_FLOOR
    with_s, with_p = low & (s > 0), low & (p > 0)
    if not (with_s.any() and with_p.any()):
        return out
    n = weights.shape[1]

    def compact(mask):
        # Each row's members, in order, down the first axis of a (size, B) table of flat
        # indices; the padding reads entry 0, which ``kept`` zeroes.
        column, hyp = np.nonzero(mask.T)
        counts = np.bincount(column, minlength=n)
        place = np.arange(column.size) - (np.cumsum(counts) - counts)[column]
        flat = np.zeros((int(counts.max()), n), dtype=np.intp)
        flat[place, column] = hyp * n + column
        kept = np.zeros(flat.shape, dtype=bool)
        kept[place, column] = True
        return flat, kept, (hyp, column, place)

    def gather(values, flat, kept):
        return np.ascontiguousarray(values).reshape(-1).take(flat) * kept

    flat_a, kept_a, where_a = compact(with_s)
    flat_b, kept_b, where_b = compact(with_p)
    x_a, x_b = gather(weights, flat_a, kept_a)[:, None], gather(weights, flat_b, kept_b)[None]
    s_a, p_b = gather(s, flat_a, kept_a), gather(p, flat_b, kept_b)
    term = s_a[:, None] * p_b[None]                                  # s_a p_b on the (a, b, row) grid
    term *= flat_a[:, None] != flat_b[None]                          # pairs of two targets
    total = x_a + x_b
    if (((x_a[:, 0] == 0) & kept_a).any(axis=0) & ((x_b[0] == 0) & kept_b).any(axis=0)).any():
        # Some pair may have no m0 weight (D = 0): the fallback share σ_a : σ_b there.
        sigma_a = (s_a + gather(p, flat_a, kept_a))[:, None]
        sigma_b = (p_b + gather(s, flat_b, kept_b))[None]
        weighed = total > 0
        term *= np.where(weighed, np.maximum(1.0 - total / _RECIPROCAL_FLOOR, 0.0), 1.0)
        np.maximum(np.where(weighed, total, sigma_a + sigma_b), _TINY, out=total)
        x_a, x_b = np.where(weighed, x_a, sigma_a), np.where(weighed, x_b, sigma_b)
    else:
        # 1 − D / floor: 0 for D ≥ floor, where _pair_sums was exact.
        missing = total * (-1.0 / _RECIPROCAL_FLOOR)
        missing += 1.0
        term *= np.maximum(missing, 0.0, out=missing)
        np.maximum(total, _TINY, out=total)                          # the padding's 0 / 0
    to_a = np.divide(x_a, total)
    to_a *= term
    to_b = np.divide(x_b, total, out=total)
    to_b *= term
    for (hyp, column, place), extra in ((where_a, to_a.sum(axis=1)), (where_b, to_b.sum(axis=0))):
        out[hyp, column] += extra[place, column]
    return out


def _state_inconsistency(state: _RState, p: np.ndarray, p_f: np.ndarray, r_mode: str,
                         split: ExclusiveSplit) -> tuple[np.ndarray, np.ndarray]:
    """R (W (10)) between a running result and a Bayesian cue, and 1 − R, from the element classes; shape (N,)."""
    if r_mode == "paper":
        # The cue has mass on singletons only, so they alone overlap the running result.
        overlap = np.add.reduce(np.minimum(state.s, p), 0)
        overlap += np.minimum(state.f, p_f)
    d = state.s - p
    d_f = state.f - p_f
    if r_mode == "paper":
        # Σ_A |Δ(A)|: the other elements count fully.
        value = np.add.reduce(np.abs(d, out=d), 0)
        value += np.abs(d_f, out=d_f)
        if not state.fresh:
            u_total = state.u_total if state.u_total is not None else np.add.reduce(state.u, 0)
            value += state.q
            value += u_total
            value += state.v
            value += state.e
        value *= 0.5
        return paper_inconsistency(value, overlap)
    if r_mode == "euclid":
        value = (d * d).sum(axis=0) + d_f * d_f
        if not state.fresh:
            value += state.q_squares + (state.u * state.u).sum(axis=0) + state.v * state.v + state.e * state.e
        value *= 0.5
    else:
        value = 0.5 * _jousselme_form(state, d, d_f, split)
    np.maximum(value, 0.0, out=value)
    np.minimum(value, 1.0, out=value)
    r = np.sqrt(value, out=value)
    return r, 1.0 - r


def _jousselme_form(state: _RState, d: np.ndarray, d_f: np.ndarray, split: ExclusiveSplit) -> np.ndarray:
    """ΔᵀDΔ over θ_i, F, the pairs θ_i ∩ θ_l, θ_i ∪ F and ∅, D(A, B) = C(A∩B)/C(A∪B) (SPEC A.4).

    With N_k = C(θ_S) for |S| = k (N_1 = 2 N_2 = 4 N_3): D(θ_i, θ_l) = 1/3; D(θ_i, θ_i∩θ_l) = ½
    and 1/5 off the pair; between pairs 1, 1/3 (one target shared), 1/7 (none);
    D(θ_i∪F, θ_i) = N_1/(N_1+1), D(θ_i∪F, θ_l) = N_2/(2N_1−N_2+1), D(θ_i∪F, F) = 1/(N_1+1),
    D(θ_i∪F, θ_S) = N_2/(N_1+1) if i ∈ S, else N_3/(N_1+N_2−N_3+1),
    D(θ_i∪F, θ_l∪F) = (N_2+1)/(2N_1−N_2+1); 0 with ∅ and between F and the targets.
    Valid while every θ_S is a pair and no θ_S ∪ F exists: for the R of the first two folds.
    """
    d_sum = d.sum(axis=0)
    d2 = (d * d).sum(axis=0)
    # The pair terms as (Σ d)² − Σ d², which is exactly 0 when one target differs: a degenerate R
    # of exactly 1 (sources on disjoint singletons) then stays exactly 1, as on the general path.
    value = d2 + (d_sum * d_sum - d2) / 3.0 + d_f * d_f
    if state.fresh:
        return value
    i1, i2, i3 = (split.inverse_cardinality(k) for k in (1, 2, 3))
    q_each, q, q2, u = state.qj, state.q, state.q_squares, state.u
    u_sum = u.sum(axis=0)
    value += 2.0 * (d * (0.5 * q_each + 0.2 * (q - q_each))).sum(axis=0)
    q_each2 = (q_each * q_each).sum(axis=0)
    value += q2 + (q_each2 - 2.0 * q2) / 3.0 + (q * q + q2 - q_each2) / 7.0
    value += 2.0 * (u * (d / (1.0 + i1) + (d_sum - d) / (3.0 + i2))).sum(axis=0)
    value += 2.0 * u_sum * d_f * i1 / (1.0 + i1)
    value += 2.0 * (u * (q_each * 0.5 / (1.0 + i1) + (q - q_each) / (5.0 + i3))).sum(axis=0)
    u2 = (u * u).sum(axis=0)
    value += u2 + (u_sum * u_sum - u2) * (1.0 + i2) / (3.0 + i2)
    return value


def bayesian_inconsistency(m1: np.ndarray, m2: np.ndarray, split: ExclusiveSplit, r_mode: str) -> np.ndarray:
    """R of W (10) between two Bayesian batches in frame order, shape (N,): O(n) per row.

    ``paper`` and ``euclid`` are computed as :func:`belief.rules.inconsistency` does on the
    same columns; ``jousselme`` uses D(θ_i, θ_l) = C(θ_i∩θ_l)/C(θ_i∪θ_l) = 1/3 for two free
    hypotheses and 0 otherwise off the diagonal, so ΔᵀDΔ = Σ Δ² + ((Σ_O Δ)² − Σ_O Δ²) / 3.

    Parameters
    ----------
    m1, m2 : ndarray, shape (N, n)
    split : ExclusiveSplit
    r_mode : {"paper", "euclid", "jousselme"}

    Examples
    --------
    SPEC A.4: paper R = .632 and euclid R = .400 for (.6, .3, .1) against (.2, .7, .1).

    >>> from belief import Model
    >>> split = exclusive_split(Model.for_targets(2))
    >>> a, b = np.array([[.6, .3, .1]]), np.array([[.2, .7, .1]])
    >>> [float(bayesian_inconsistency(a, b, split, mode)[0].round(4)) for mode in ("paper", "euclid")]
    [0.6325, 0.4]
    """
    def jousselme(delta: np.ndarray) -> np.ndarray:
        free = delta[:, split.o_index]
        squares = (free * free).sum(axis=1)
        free_sum = free.sum(axis=1)
        excl = delta[:, split.e_index]
        # (Σ Δ)² − Σ Δ² is exactly 0 when a single free hypothesis differs, so sources on two
        # disjoint singletons give exactly R = 1, as the general path does.
        return 0.5 * ((excl * excl).sum(axis=1) + squares + (free_sum * free_sum - squares) / 3.0)

    return aligned_inconsistency(m1, m2, r_mode, jousselme)[0]


def aligned_inconsistency(m1: np.ndarray, m2: np.ndarray, r_mode: str,
                          jousselme: Callable[[np.ndarray], np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """R of W (10) between rows of two arrays aligned on the same focal elements, and 1 − R; shapes (N,).

    ``jousselme(delta)`` returns ½ ΔᵀDΔ for the rows of ``delta = m1 − m2``; it is called only
    when ``r_mode == "jousselme"``, so each caller supplies the form its columns allow.  For
    ``paper``, 1 − R keeps its relative precision when R is near 1 (:func:`paper_inconsistency`).
    """
    delta = m1 - m2
    if r_mode == "paper":
        return paper_inconsistency(np.abs(delta).sum(axis=1) / 2.0, np.minimum(m1, m2).sum(axis=1))
    if r_mode == "euclid":
        value = 0.5 * (delta * delta).sum(axis=1)
    else:
        value = jousselme(delta)
    r = np.sqrt(np.clip(value, 0.0, 1.0))
    return r, 1.0 - r


def paper_inconsistency(half_distance: np.ndarray, overlap: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """R of W (10) as printed, and 1 − R, from Σ_A |Δ(A)| / 2 and the overlap Σ_A min(m1(A), m2(A)).

    For two mass functions that sum to 1, Σ |Δ| / 2 = 1 − Σ min(m1, m2).  Where the overlap is
    below ½ (R above 0.71), R = sqrt(1 − overlap) and 1 − R = overlap / (1 + R): a sum of
    non-negative terms, so 1 − R keeps its relative precision when the sources barely overlap.
    Taken as 1 − sqrt(Σ|Δ|/2), it would be rounding noise of 1e-16 where the exact value is,
    say, 1e-200, and the shares (1 − R)·k it sends to A, B and A ∪ B would be noise that the
    next fold's m0 weights magnify.  Sources with no common focal element have overlap 0, so
    R = 1 and 1 − R = 0 exactly (SPEC A.4).

    Parameters
    ----------
    half_distance, overlap : ndarray, shape (N,)

    Returns
    -------
    r, rho : ndarray, shape (N,)
        R and 1 − R.

    Examples
    --------
    >>> r, rho = paper_inconsistency(np.array([0.4, 1.0 - 1e-200]), np.array([0.6, 1e-200]))
    >>> r.round(4), rho[1]
    (array([0.6325, 1.    ]), np.float64(5e-201))
    """
    far = overlap < 0.5
    r = np.sqrt(np.where(far, 1.0 - overlap, np.clip(half_distance, 0.0, 1.0)))
    return r, np.where(far, overlap / (1.0 + r), 1.0 - r)


class RRuleFusion(_Fusion):
    """The R-weighted rule (SPEC A.4) of Bayesian sources, folded in source order, at most one exclusive F.

    Every fold but the last keeps each m(θ_i) and m(θ_i ∪ F), because the next fold's R and
    its m0 weights need them: one O(|O|²) pass per row (the pair shares do not factorise).
    The last fold gives Σ-type totals in O(|O|) per row, and the per-hypothesis values
    either for all free hypotheses (O(|O|²)) or for one selected per row (O(|O|)).  The rows
    are processed in blocks that fit in cache.  Rows whose SPEC A.4 fallback does not reduce
    to sums (:class:`_Fold`) are listed in :attr:`general_rows`; their measures are read off
    the general combination of those rows alone.

    Coverage: ``r_mode="paper"`` for any number of sources, ``"euclid"`` and
    ``"jousselme"`` (which need Σ_S m(θ_S)² and D between all the elements) up to three;
    BetP up to three sources (its weight of θ_S ∪ F depends on |S|, and from four
    sources on |S| varies).

    Examples
    --------
    SPEC A.4, worked example: Bel(θ1) = .5149, Bel(θ2) = .6609 and m(θ1 ∩ θ2) = .3036.

    >>> from belief import Model
    >>> fusion = RRuleFusion([np.array([[.6, .3, .1]]), np.array([[.2, .7, .1]])],
    ...                      exclusive_split(Model.for_targets(2)), "paper", union=True)
    >>> fusion.o_measure("bel").round(4), (fusion.o_measure("bel") - fusion.o_measure("mass")).round(4)
    (array([[0.5149, 0.6609]]), array([[0.3036, 0.3036]]))
    """

    def __init__(self, values, split: ExclusiveSplit, r_mode: str, union: bool, maps=None) -> None:
        self.split = split
        self.sources = _Blocks(values, split.size, len(split.free) if len(values) > 2 else 0, maps)
        self._maps = maps
        self._three = len(values) == 3 and r_mode == "paper"     # :meth:`_run_three` applies
        self.rows = self.sources.rows
        self.s = len(values)
        self.r_mode = r_mode
        self.union = union
        self._totals: dict | None = None
        self._full: dict | None = None
        self._selected: tuple[bytes, dict] | None = None
        self._flagged = np.zeros(self.rows, dtype=bool)
        self._sub: MassBatch | None = None
        self._cache: dict = {}

    # -- the folds, in blocks of rows -------------------------------------------------------------
    def _cues(self, rows: slice) -> list[tuple[np.ndarray, np.ndarray]]:
        """The sources of these rows: (|O|, B) masses of the free hypotheses, and (B,) of F (0 without F)."""
        split = self.split
        f_row = split.exclusive[0] if split.exclusive else None
        zero = np.zeros(rows.stop - rows.start)
        return [(b[split.o_index], b[f_row] if f_row is not None else zero) for b in self.sources.block(rows)]

    def _last_fold(self, rows: slice, positions: np.ndarray | None = None) -> _Fold:
        """Every fold but the last for these rows, then the last fold.

        ``positions``: the last fold is read for one free hypothesis per row only, so the fold
        before it keeps the per-hypothesis sums of intersections for that one (not with the
        Jousselme R, whose form needs them all).

        A second pass over the rows (another ``select``, say) folds the first sources again
        rather than keeping their (|O|, N) state: a pass serves all the measures of one reading.
        """
        cues = self._cues(rows)
        state = _RState.bayesian(*cues[0])
        r_rho = _state_inconsistency(state, *cues[1], self.r_mode, self.split)             # W (10)
        for index in range(1, len(cues) - 1):
            p, p_f = cues[index]
            fold = _Fold(state, p, p_f, r_rho, self.union)
            self._flagged[rows] |= fold.flagged
            only = positions if index == len(cues) - 2 and self.r_mode != "jousselme" else None
            before, state = state, fold.full(only)
            if index == 1 and self.r_mode != "paper":
                # After one fold every θ_S is a pair θ_i ∩ θ_l of mass R·k_il, and
                # Σ_{i<l} k_il² = Σs² Σp² − Σ(s p)² + (Σ s p)² − Σ(s p)².
                sp = before.s * p
                sp2 = (sp * sp).sum(axis=0)
                squares = ((before.s * before.s).sum(axis=0) * (p * p).sum(axis=0) - sp2 + sp.sum(axis=0) ** 2 - sp2)
                state.q_squares = r_rho[0] * r_rho[0] * np.maximum(squares, 0.0)
            r_rho = _state_inconsistency(state, *cues[index + 1], self.r_mode, self.split)
        fold = _Fold(state, *cues[-1], r_rho, self.union)
        self._flagged[rows] |= fold.flagged
        return fold

    def _run(self, positions: np.ndarray | None = None, full: bool = False) -> None:
        """One pass over the row blocks for the totals, and the selected or every free hypothesis."""
        if not full and self._three:
            self._run_three(positions)
            return
        n, o = self.rows, len(self.split.free)
        totals = None if self._totals is not None else {k: np.empty(n) for k in ("s", "f", "u", "q", "v", "e")}
        selected = None if positions is None else {k: np.empty(n) for k in ("s", "u", "qj", "vj")}
        every = {k: np.empty((o, n)) for k in ("s", "u", "qj", "vj")} if full else None
        for rows in self.sources:
            fold = self._last_fold(rows, None if positions is None or full else positions[rows])
            if totals is not None:
                for k, v in fold.totals().items():
                    totals[k][rows] = v
            if selected is not None:
                for k, v in fold.selected(positions[rows]).items():
                    selected[k][rows] = v
            if every is not None:
                state = fold.full()
                for k in every:
                    every[k][:, rows] = getattr(state, k)
        if totals is not None:
            self._totals = totals
        if selected is not None:
            self._selected = (positions.tobytes(), selected)
        if every is not None:
            self._full = every

    def _run_three(self, positions: np.ndarray | None) -> None:
        """:meth:`_run` for three cues and the R of W (10) as printed.

        The two folds of :class:`_Fold` in the case that nearly every row of a tracker meets:
        m0 weighs every pair of a target with F in both folds (w_i + w_F above
        :data:`_RECIPROCAL_FLOOR`), and the selected target with every other one, so no
        flagged class arises in the first fold, and the second one has no θ_S ∪ F to start
        from.  The pairs of targets in the first fold may be as small as they come (particles
        far from a target give it likelihoods of 1e-300, or 0): :func:`_low_pairs` gives them
        their exact shares.  Blocks of rows give only the sums over the targets that the
        second fold needs; its per-row formulas (R of W (10), the totals and the selected
        target) then run once on whole columns.  The other rows are folded again by the
        general fold on their own, so that every row gets the arithmetic of :class:`_Fold`.
        """
        n, union = self.rows, self.union
        sums = {k: np.empty(n) for k in ("r1", "s0", "t1", "w1", "f1", "k1", "a2", "o2", "s1", "w2", "f2", "g2",
                                         "t2", "f", "pf", "cf")}
        if positions is not None:
            sums.update({k: np.empty(n) for k in ("sj", "pj", "cj", "s1j", "w2j", "ch", "sh")})
        slow = np.zeros(n, dtype=bool)
        with np.errstate(all="ignore"):              # rows below the floor are redone by _Fold
            for rows in self.sources:
                self._three_block(rows, None if positions is None else positions[rows], sums, slow)
            totals, selected, flagged = self._three_rows(sums, positions)
        self._flagged |= flagged
        if slow.any():
            redo = np.flatnonzero(slow)
            sub = RRuleFusion([v if v.shape[0] != n else v[redo] for v in self.sources.values], self.split,
                              self.r_mode, union, self._maps)
            sub._three = False
            sub._run(None if positions is None else positions[redo])
            self._flagged[redo] = sub._flagged
            for k, v in sub._totals.items():
                totals[k][redo] = v
            if selected is not None:
                for k, v in sub._selected[1].items():
                    selected[k][redo] = v
        if self._totals is None:
            self._totals = totals
        if selected is not None:
            self._selected = (positions.tobytes(), selected)

    def _three_block(self, rows: slice, j: np.ndarray | None, sums: dict, slow: np.ndarray) -> None:
        """The sums over the targets of one block of rows (:meth:`_run_three`), written to ``sums[k][rows]``."""
        (s, f), (p, p_f), (c, c_f) = self._cues(rows)
        put = {k: v[rows] for k, v in sums.items()}
        reduce = np.add.reduce
        put["f"][...], put["pf"][...], put["cf"][...] = f, p_f, c_f
        # R of W (10) between the first two cues, and 1 − R.
        r1, rho1 = _state_inconsistency(_RState.bayesian(s, f), p, p_f, "paper", self.split)
        put["r1"][...] = r1
        near = np.zeros(r1.shape, dtype=bool)                # rows for the general fold
        # First fold (its state is fresh): k_il of every pair to θ_i and θ_l as w_i : w_l, k_iF to
        # θ_i and F as w_i : w_F, R·k_iF to θ_i ∪ F (or ∅).
        d = w1 = s * p
        w_f = f * p_f
        inverse = w1 + w_f
        _below(inverse, near)
        np.divide(1.0, inverse, out=inverse)                 # 1 / (w_i + w_F)
        k1 = s * p_f
        k1 += f * p
        ki = np.multiply(k1, inverse, out=inverse)          # k_iF / (w_i + w_F)
        f1 = reduce(ki, 0, out=put["f1"])
        to_singles = _pair_sums(w1, s, p, ki)                # + Σ_{l≠i} k_il / (w_i + w_l)
        f1 *= w_f
        f1 *= rho1
        f1 += w_f                                            # m′(F)
        to_singles *= w1
        _low_pairs(w1, s, p, to_singles)                     # the pairs whose weights sum below the floor
        to_singles *= rho1
        s1 = np.add(to_singles, w1, out=to_singles)          # m′(θ_i)
        s_total, t = reduce(s, 0, out=put["s0"]), reduce(p, 0, out=put["t1"])
        reduce(w1, 0, out=put["w1"])
        reduce(s1, 0, out=put["s1"])
        reduce(c, 0, out=put["t2"])
        k_total = np.multiply(s_total, p_f, out=put["k1"])  # Σ_i k_iF, a sum of non-negative terms
        k_total += f * t
        # Second fold: R needs Σ|m′(θ_i) − c_i|, m0 weighs w_i = (m′(θ_i) + m′(θ_i ∪ F)) c_i.
        reduce(np.minimum(s1, c, out=d), 0, out=put["o2"])
        np.subtract(s1, c, out=d)
        reduce(np.abs(d, out=d), 0, out=put["a2"])
        if self.union:
            k1 *= r1                                         # m′(θ_i ∪ F)
            w2 = np.add(k1, s1, out=k1)
            u_total = r1 * k_total
        else:
            w2 = s1.copy()
            u_total = 0.0
        w2 *= c
        if self.union and not w2.all():
            # θ_l ∪ F against a target θ_i that m0 does not weigh takes SPEC A.4's fallback: the general fold.
            near |= ((w2 == 0) & (c > 0)).any(axis=0) & (u_total > 0)
        reduce(w2, 0, out=put["w2"])
        w2_f = (f1 + u_total) * c_f
        k2 = s1 * c_f
        k2 += np.multiply(f1, c, out=d)
        inverse = np.add(w2, w2_f, out=d)
        _below(inverse, near)
        np.divide(1.0, inverse, out=inverse)
        np.einsum("ij,ij->j", k2, inverse, out=put["f2"])                 # Σ k_iF / (w_i + w_F)
        np.einsum("ij,ij,ij->j", k2, w2, inverse, out=put["g2"])          # Σ k_iF w_i / (w_i + w_F)
        if j is not None:
            # θ_J against every other θ_l: Σ_l c_l h_l and Σ_l m′(θ_l) h_l, h_l = 1 / (w_J + w_l).
            flat = j * j.size
            flat += _row_offsets(j.size, 1)
            for key, values in (("sj", s), ("pj", p), ("cj", c), ("s1j", s1), ("w2j", w2)):
                values.reshape(-1).take(flat, out=put[key], mode="clip")      # unbuffered: flat is valid
            h = np.add(w2, put["w2j"], out=inverse)
            _below(h, near)
            np.divide(1.0, h, out=h)
            h.reshape(-1)[flat] = 0.0
            np.einsum("ij,ij->j", c, h, out=put["ch"])
            np.einsum("ij,ij->j", s1, h, out=put["sh"])
        slow[rows] = near

    def _three_rows(self, sums: dict, positions: np.ndarray | None):
        """The per-row formulas of the second fold (:meth:`_Fold.totals`, :meth:`_Fold.selected`) on whole columns.

        Returns the totals, the selected parts (or None) and the flagged rows.
        """
        union = self.union
        f0, p_f, c_f = sums["f"], sums["pf"], sums["cf"]
        r1, k1, f1, t2 = sums["r1"], sums["k1"], sums["f1"], sums["t2"]
        q1 = np.maximum(sums["s0"] * sums["t1"] - sums["w1"], 0.0)
        q1 *= r1                                             # Σ m′(θ_S), every θ_S a pair
        u1 = r1 * k1 if union else np.zeros(self.rows)       # Σ m′(θ_i ∪ F)
        e1 = np.zeros(self.rows) if union else r1 * k1       # m′(∅)
        # R of W (10) between m′ and the third cue: the cue has mass on singletons only.
        value = sums["a2"] + np.abs(f1 - c_f)
        value += q1
        value += u1
        value += e1
        value *= 0.5
        r, rho = paper_inconsistency(value, sums["o2"] + np.minimum(f1, c_f))
        w_f = (f1 + u1) * c_f
        half = 0.5 * (w_f > 0)
        flagged = (q1 > 0) & (c_f > 0) & ~(w_f > 0)
        # Σ_{i≠l} (m′(θ_i) + m′(θ_i ∪ F)) c_l: the consensus of targets and of θ_i ∪ F with other targets.
        s1, w2 = sums["s1"], sums["w2"]
        spread = np.maximum((s1 + u1) * t2 - w2, 0.0)
        q_p_f = q1 * c_f
        r_k = s1 * c_f                                       # Σ_i k_iF of the second fold
        r_k += f1 * t2
        r_k *= r
        totals = {"s": w2 + rho * (spread + sums["g2"]),
                  "f": w_f + rho * (sums["f2"] * w_f + half * q_p_f),
                  "u": r_k if union else np.zeros(self.rows),
                  "q": r * spread + q1 * t2,
                  "v": ((r if union else 0.0) + rho * half) * q_p_f,
                  "e": e1 * (t2 + c_f) if union else r_k + e1 * (t2 + c_f) + r * q_p_f}
        if positions is None:
            return totals, None, flagged
        s_j, p_j, c_j = sums["sj"], sums["pj"], sums["cj"]
        s1j, w_j = sums["s1j"], sums["w2j"]
        q1j = sums["s0"] - s_j                              # Σ_{S∋J} m′(θ_S): the pairs θ_J ∩ θ_l
        q1j *= p_j
        q1j += s_j * (sums["t1"] - p_j)
        q1j *= r1
        if union:
            u1j = s_j * p_f
            u1j += f0 * p_j
            u1j *= r1                                        # m′(θ_J ∪ F)
        else:
            u1j = np.zeros(self.rows)
        k_f = s1j * c_f
        k_f += f1 * c_j
        except_p = t2 - c_j
        except_u = u1 - u1j
        to_single = s1j * sums["ch"]
        to_single += c_j * sums["sh"]
        to_single *= w_j
        to_single += k_f * (w_j * (1.0 / (w_j + w_f)))
        to_single += c_j * except_u                         # θ_l ∪ F against θ_J: all to θ_J
        qj = s1 - s1j
        qj *= c_j
        qj += s1j * except_p
        qj *= r
        qj += q1j * t2 + np.maximum(q1 - q1j, 0.0) * c_j + r * (u1j * except_p + c_j * except_u)
        to_single *= rho
        to_single += w_j
        selected = {"s": to_single, "u": r * k_f if union else np.zeros(self.rows), "qj": qj,
                    "vj": ((r if union else 0.0) + rho * half) * c_f * q1j}
        return totals, selected, flagged

    @property
    def general_rows(self) -> np.ndarray:
        self.totals()
        return np.flatnonzero(self._flagged)

    def totals(self) -> dict:
        if self._totals is None:
            self._run()
        return self._totals

    def _parts(self, positions: np.ndarray | None) -> dict:
        if positions is None:
            if self._full is None:
                self._run(full=True)
            return self._full
        if self._full is not None:
            return {k: _pick(v, positions) for k, v in self._full.items()}
        key = positions.tobytes()
        if self._selected is None or self._selected[0] != key:
            self._run(positions=positions)
        return self._selected[1]

    # -- measures ---------------------------------------------------------------------------------
    def _sub_batch(self) -> MassBatch | None:
        rows = self.general_rows
        if not rows.size:
            return None
        if self._sub is None:
            self._sub = self.general(rows)
        return self._sub

    def _patch(self, out: np.ndarray, kind: str, exclusive: bool, positions: np.ndarray | None) -> np.ndarray:
        """Rows left to the general path: their values come from the general combination of those rows."""
        sub = self._sub_batch()
        if sub is None:
            return out
        rows = self.general_rows
        frame = sub.model.frame
        members = self.split.exclusive if exclusive else self.split.free
        values = _raw(sub, kind, tuple(frame.singletons[i] for i in members))
        out = np.array(out, dtype=np.float64, copy=True)
        if positions is not None:
            values = values[np.arange(rows.size), positions[rows]]
        elif out.ndim == 1:
            values = values[:, 0]          # Pls(θ_j) is the same for every free j
        out[rows] = values
        return out

    def _betp_ready(self) -> None:
        if self.s > 3:
            raise _NoClosedForm("BetP of the R-weighted rule of more than three sources")

    def o_measure(self, kind: str, positions: np.ndarray | None = None) -> np.ndarray:
        key = (kind, None if positions is None else positions.tobytes())
        if key in self._cache:
            return self._cache[key]
        if kind == "pls":
            totals = self.totals()
            out = totals["s"] + totals["q"] + totals["u"] + totals["v"]          # every element but F and ∅
        else:
            if kind == "betp":
                self._betp_ready()
            parts = self._parts(positions)          # one pass over the rows gives the totals as well
            totals = self.totals()
            if kind == "mass":
                out = parts["s"]
            elif kind == "bel":
                out = parts["s"] + parts["qj"]                                  # W (8): θ_j and θ_S ∋ j
            else:
                i1, i2 = self.split.inverse_cardinality(1), self.split.inverse_cardinality(2)
                own1, other1 = 1.0 / (1.0 + i1), 0.5 / (1.0 + i1)               # θ_j∪F, θ_i∪F against θ_j
                own2, other2 = 1.0 / (1.0 + i2), 0.5 / (1.0 + i2)               # θ_S∪F with j ∈ S, j ∉ S
                out = (0.5 * (totals["s"] + totals["q"] + parts["s"] + parts["qj"])
                       + other1 * totals["u"] + other2 * totals["v"]
                       + (own1 - other1) * parts["u"] + (own2 - other2) * parts["vj"])
            if positions is None:
                out = out.T
        out = self._patch(out, kind, False, positions)
        self._cache[key] = out
        return out

    def e_measure(self, kind: str) -> np.ndarray:
        if not self.split.exclusive:
            return np.zeros((self.rows, 0))
        key = (kind, "exclusive")
        if key in self._cache:
            return self._cache[key]
        totals = self.totals()
        f = totals["f"]
        if kind == "pls":
            out = f + totals["u"] + totals["v"]
        elif kind == "betp":
            self._betp_ready()
            i1, i2 = self.split.inverse_cardinality(1), self.split.inverse_cardinality(2)
            out = f + totals["u"] * (i1 / (1.0 + i1)) + totals["v"] * (i2 / (1.0 + i2))   # C(F)/C(θ_S ∪ F)
        else:
            out = f
        out = self._patch(out[:, None], kind, True, None)
        self._cache[key] = out
        return out

    def empty(self) -> np.ndarray:
        out = self.totals()["e"]
        sub = self._sub_batch()
        if sub is not None:
            out = out.copy()
            out[self.general_rows] = sub.empty_mass
        return out

    def kept(self) -> np.ndarray:
        t = self.totals()
        out = t["s"] + t["f"] + t["q"] + t["u"] + t["v"]
        sub = self._sub_batch()
        if sub is not None:
            out = out.copy()
            keep = np.array([bool(x.terms) for x in sub.focal], dtype=np.float64)
            out[self.general_rows] = (sub.values * keep).sum(axis=1)
        return out


def _raw(batch: MassBatch, kind: str, queries: tuple[Element, ...]) -> np.ndarray:
    """A measure of a general batch before any normalisation, shape (N, Q) (BetP: its numerator)."""
    plan = measure_plan(batch.model, batch.focal, queries)
    table = {"bel": plan.subset, "pls": plan.meets, "mass": plan.equal, "betp": plan.ratio}[kind]
    return weighted_sum(batch.values, table)


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

    def __init__(self, model: Model, fusion: _Fusion, materialise: Callable[[], MassBatch]) -> None:
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
        return (MassBatch._trusted, (result.model, result.focal, result.values, result._canonical))

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
        except _NoClosedForm:
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
    except _Underflow:
        function(list(batches), model, **options)          # raises TotalConflictError where K = 1 exactly
        return None, ("Dempster's normalisation divides by a non-empty mass below 2^-600, which the closed forms "
                      "cannot keep from underflowing")

    def materialise() -> MassBatch:
        return function(list(batches), model, **options)

    def general(rows: np.ndarray) -> MassBatch:
        subset = [b if len(b) == 1 else MassBatch._trusted(b.model, b.focal, b.values[rows], canonical=b._canonical)
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
