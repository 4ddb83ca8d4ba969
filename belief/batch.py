"""Batches of mass functions over one fixed list of focal elements: the numeric engine.

A batch holds N mass functions (one per particle, say) as an ``(N, K)`` float array over
K focal elements shared by all rows.  Every measure is a product of that array with a
``(K, Q)`` table that depends only on the model, the focal elements and the queries; the
tables are compiled once and cached (:func:`measure_plan`), so evaluating thousands of
rows costs one matrix product and no Python loop per row.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import cached_property, lru_cache
from typing import ClassVar, Union

import numpy as np

from belief.errors import FrameError, InvalidMassError, ResourceLimitError, UndefinedTransformError
from belief.frame import Element, Frame
from belief.model import Model, _show
from belief.incidence import SPARSE_TABLE_ENTRIES, Incidence, incidence, without_empty
from belief.plan import weighted_sum
from belief.relation_tables import CodedRelations, coded_relations

__all__ = ["MassBatch", "measure_plan", "MeasurePlan", "SUM_TOLERANCE", "resolve_model", "check_select"]

#: Masses must sum to one within this absolute tolerance.
SUM_TOLERANCE = 1e-9
#: Entries of a dense table relating focal elements to queries (8 bytes each, up to five tables a plan).
MAX_TABLE_ENTRIES = 10_000_000
#: Entries of such a table computed element by element, where the model has too many Venn regions to code them.
MAX_ELEMENT_ENTRIES = 200_000

_module = sys.modules[__name__]

Query = Union[Element, str]


def resolve_model(frame=None, model=None) -> Model:
    """The model from the ``frame=`` / ``model=`` arguments of the constructors."""
    if isinstance(model, Model):
        if frame is not None and _as_frame(frame) != model.frame:
            raise FrameError("frame= and model= name different frames")
        return model
    if frame is None:
        raise FrameError("give the frame (frame=Frame([...]) or a list of names) or a model")
    frame = _as_frame(frame)
    if model is None or model == "shafer":
        return Model.shafer(frame)
    if model == "free":
        return Model.free(frame)
    if isinstance(model, str):
        raise FrameError(f"model must be a Model, 'free' or 'shafer', got {model!r}")
    raise TypeError(f"model must be a Model, got {type(model).__name__}")


def _as_frame(frame) -> Frame:
    if isinstance(frame, Frame):
        return frame
    if isinstance(frame, str):
        return Frame.parse(frame)
    return Frame(list(frame))


# -- compiled tables ---------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class MeasurePlan:
    """Index tables relating K focal elements to Q queries under a model.

    Each table has shape ``(K, Q)``; they are computed on first use and kept.
    """

    model: Model
    focal: tuple[Element, ...]
    queries: tuple[Element, ...]

    @cached_property
    def sparse(self) -> Incidence | None:
        """The tables as one entry per hypothesis of each focal element (:mod:`belief.incidence`), where that applies
        and the dense tables would hold more than :data:`~belief.incidence.SPARSE_TABLE_ENTRIES` entries."""
        if len(self.focal) * len(self.queries) <= SPARSE_TABLE_ENTRIES:
            return None
        return incidence(self.focal, self.queries, self.model)

    def weigh(self, values: np.ndarray, relation: str) -> np.ndarray:
        """Σ_X values[:, X] · table[X, q] for the table of ``relation`` (an attribute name), shape (N, Q).

        The same bits as :func:`~belief.plan.weighted_sum` of the dense table, which it is for small tables.
        """
        sparse = self.sparse
        if sparse is not None:
            return sparse.weigh(values, relation)
        return weighted_sum(values, getattr(self, relation))

    @cached_property
    def _coded(self) -> CodedRelations | None:
        return coded_relations(self.model, self.focal, self.queries)

    def _table(self, name: str, relation) -> np.ndarray:
        """The (K, Q) table of ``name``: from the elements' codes where they have them, else ``relation`` pair by pair."""
        k, q = len(self.focal), len(self.queries)
        check_table_entries(k * q, f"a table of {k:,} focal elements by {q:,} queries")
        coded = self._coded if k * q else None
        if coded is not None and (name != "meet_cardinality" or coded.weights is not None):
            table = coded.table(name)
        else:
            check_table_entries(k * q, f"a table of {k:,} focal elements by {q:,} queries compared element by element "
                           "(the model has too many Venn regions to code them)", one_by_one=True)
            table = np.array(
                [[relation(x, a) for a in self.queries] for x in self.focal], dtype=np.float64
            ).reshape(k, q)
        table.flags.writeable = False
        return table

    @cached_property
    def subset(self) -> np.ndarray:
        """1 where ∅ ≠ X ⊆ A (belief, W (8))."""
        return self._table("subset", lambda x, a: bool(x.terms) and x <= a)

    @cached_property
    def meets(self) -> np.ndarray:
        """1 where X ∩ A ≠ ∅ under the model (plausibility, W (9))."""
        model = self.model
        return self._table("meets", lambda x, a: not model.is_empty(x & a))

    @cached_property
    def superset(self) -> np.ndarray:
        """1 where A ⊆ X (commonality)."""
        return self._table("superset", lambda x, a: a <= x)

    @cached_property
    def equal(self) -> np.ndarray:
        """1 where X = A under the model (the mass of A); an empty query matches the ∅ column."""
        return self._table("equal", lambda x, a: x == a)

    @cached_property
    def focal_cardinality(self) -> np.ndarray:
        """DSm cardinality C_M(X) of each focal element, shape (K,)."""
        return np.array([float(self.model.cardinality(x)) for x in self.focal], dtype=np.float64)

    @cached_property
    def meet_cardinality(self) -> np.ndarray:
        """C_M(X ∩ A), shape (K, Q)."""
        model = self.model
        return self._table("meet_cardinality", lambda x, a: float(model.cardinality(x & a)))

    @cached_property
    def ratio(self) -> np.ndarray:
        """C_M(X ∩ A) / C_M(X) (0 for X = ∅): the pignistic share of X that falls in A."""
        card = self.focal_cardinality[:, None]
        with np.errstate(invalid="ignore", divide="ignore"):
            table = np.where(card > 0, self.meet_cardinality / np.where(card > 0, card, 1.0), 0.0)
        table.flags.writeable = False
        return table

    @cached_property
    def unit(self) -> np.ndarray:
        """1 for focal elements of DSm cardinality one (the DSmP anchors), shape (K,)."""
        return (self.focal_cardinality == 1.0).astype(np.float64)

    @cached_property
    def unit_in_meet(self) -> np.ndarray:
        """[C(Z) = 1 and Z ⊆ X ∩ A], shape (K_Z, K_X, Q)."""
        model = self.model
        focal, queries = self.focal, self.queries
        units = int(self.unit.sum())
        what = f"the DSmP table of {len(focal):,} focal elements by {len(queries):,} queries"
        check_table_entries(len(focal) ** 2 * len(queries), what)
        check_table_entries(units * len(focal) * len(queries), what + " compared element by element", one_by_one=True)
        table = np.zeros((len(focal), len(focal), len(queries)))
        for z, zel in enumerate(focal):
            if not self.unit[z]:
                continue
            for x, xel in enumerate(focal):
                for a, ael in enumerate(queries):
                    table[z, x, a] = float(zel <= model.reduce(xel & ael))
        return table

    @cached_property
    def unit_in_focal(self) -> np.ndarray:
        """[C(Z) = 1 and Z ⊆ X], shape (K_Z, K_X)."""
        focal = self.focal
        check_table_entries(len(focal) ** 2, f"the DSmP table of {len(focal):,} focal elements by themselves")
        return np.array(
            [[float(self.unit[z] and zel <= xel) for xel in focal] for z, zel in enumerate(focal)]
        ).reshape(len(focal), len(focal))


def check_table_entries(entries: int, what: str, one_by_one: bool = False, advice: str = "ask for fewer queries") -> None:
    """Refuse a table of more entries than :data:`MAX_TABLE_ENTRIES` (:data:`MAX_ELEMENT_ENTRIES` ``one_by_one``)."""
    name = "MAX_ELEMENT_ENTRIES" if one_by_one else "MAX_TABLE_ENTRIES"
    limit = getattr(_module, name)
    if entries > limit:
        raise ResourceLimitError(
            f"{what} holds {entries:,} entries, more than belief.batch.{name} = {limit:,}; {advice} "
            f"or raise belief.batch.{name}", f"belief.batch.{name}")


@lru_cache(maxsize=256)
def _resolved(model: Model, queries: tuple) -> tuple[Element, ...]:
    """Queries (propositions or elements) in canonical form under the model; the same list of queries comes back."""
    frame = model.frame
    if model.kind == "shafer" and queries is frame.singletons:
        return queries                          # the hypotheses are their own form under Shafer's model
    return tuple(model.reduce(frame.element(q)) for q in queries)


@lru_cache(maxsize=1024)
def measure_plan(model: Model, focal: tuple[Element, ...], queries: tuple[Element, ...]) -> MeasurePlan:
    """The cached :class:`MeasurePlan` for these focal elements and queries."""
    return MeasurePlan(model, focal, queries)


# -- validation ----------------------------------------------------------------------------------
def check_masses(values: np.ndarray, focal: Sequence[Element], model: Model, subnormal: bool,
                 row_names: Sequence[str] | None = None) -> None:
    """Raise :class:`InvalidMassError` unless every row is a valid mass function.

    ``values`` has shape (N, K).  Masses must be finite and non-negative and sum to one
    within :data:`SUM_TOLERANCE`; mass on ∅ (or on an element empty under the model)
    needs ``subnormal=True``.
    """

    def where(row: int, col: int | None = None) -> str:
        parts = []
        if row_names is not None:
            parts.append(row_names[row])
        elif values.shape[0] > 1:
            parts.append(f"row {row}")
        if col is not None:
            parts.append(f"on {focal[col]!s}")
        return " ".join(parts)

    bad = ~np.isfinite(values)
    if bad.any():
        r, c = map(int, np.argwhere(bad)[0])
        raise InvalidMassError(f"mass {float(values[r, c])!r} {where(r, c)} is not a finite number".replace("  ", " "))
    negative = values < 0
    if negative.any():
        r, c = map(int, np.argwhere(negative)[0])
        raise InvalidMassError(f"negative mass {float(values[r, c])!r} {where(r, c)}")
    totals = _row_sums(values)
    off = np.abs(totals - 1.0) > SUM_TOLERANCE
    if off.any():
        r = int(np.flatnonzero(off)[0])
        label = where(r)
        raise InvalidMassError(
            f"masses {label + ' ' if label else ''}sum to {float(totals[r])!r}, not 1 (tolerance {SUM_TOLERANCE:g})"
        )
    if not subnormal:
        for col, element in enumerate(focal):
            if model.is_empty(element):
                rows = np.flatnonzero(values[:, col] > 0)
                if rows.size:
                    what = ("the empty set" if element.is_empty
                            else f"{element}, which is empty under the {model.kind} model")
                    label = where(int(rows[0]))
                    raise InvalidMassError(
                        f"mass {float(values[rows[0], col])!r} {label + ' ' if label else ''}on {what}; "
                        "pass subnormal=True to allow an unnormalised (open-world) mass function"
                    )


def exact_sum(values) -> float:
    """The correctly rounded sum of finite floats (``math.fsum``); ``inf`` where it exceeds the float range.

    ``math.fsum`` raises ``OverflowError`` when the partial sums of finite values overflow
    (two masses of 1e308); such masses are invalid, and the sum check reports them.

    Examples
    --------
    >>> exact_sum([0.1] * 10), exact_sum([1e308, 1e308])
    (1.0, inf)
    """
    try:
        return math.fsum(values)
    except OverflowError:
        return math.inf


#: Below this many focal elements a row's sum is added column by column: numpy adds fewer than eight numbers in
#: order, so the bits are those of ``values.sum(axis=1)``, which spends ten times longer on rows this short.
COLUMN_SUM_WIDTH = 8


def _row_sums(values: np.ndarray) -> np.ndarray:
    """The sum of each row of ``values`` (N, K), shape (N,): exact for a few rows, numpy's sum otherwise.

    >>> _row_sums(np.full((100, 3), 0.1))[:2]
    array([0.3, 0.3])
    """
    if values.shape[1] <= 64 and values.shape[0] <= 64:
        return np.array([exact_sum(row) for row in values.tolist()], dtype=np.float64)
    with np.errstate(over="ignore", invalid="ignore"):  # a sum past the float range is inf, and refused
        if values.shape[1] < COLUMN_SUM_WIDTH:
            totals = values[:, 0].copy()
            for column in range(1, values.shape[1]):
                totals += values[:, column]
            return totals
        return values.sum(axis=1)


def check_select(select, n_rows: int, n_queries: int) -> np.ndarray:
    """The ``select=`` argument of the batch measures as an int64 array of shape (N,).

    Parameters
    ----------
    select : array_like of int, shape (N,)
        For row n, the position in the query list of the one query to evaluate.
    n_rows, n_queries : int
        N and the number of queries Q.

    Returns
    -------
    ndarray of int64, shape (N,)

    Raises
    ------
    InvalidMassError
        If ``select`` is not integer, has the wrong shape, or names a query that does not exist.

    Examples
    --------
    >>> check_select([1, 0], 2, 2)
    array([1, 0])
    >>> check_select([2, 0], 2, 2)
    Traceback (most recent call last):
    ...
    belief.errors.InvalidMassError: select=[2, 0] picks query 2 in row 0, but there are 2 queries (0 to 1)
    """
    array = np.asarray(select)
    if array.dtype == bool or not np.issubdtype(array.dtype, np.integer):
        raise InvalidMassError(f"select must be an array of integer query positions, got dtype {array.dtype}")
    if array.shape != (n_rows,):
        raise InvalidMassError(f"select must have shape ({n_rows},), one query position per row, got {array.shape}")
    array = array.astype(np.int64, copy=False)
    if n_rows:
        bad = (array < 0) | (array >= n_queries)
        if bad.any():
            row = int(np.flatnonzero(bad)[0])
            shown = array.tolist() if n_rows <= 8 else f"[{array[row]}, ...]"
            raise InvalidMassError(f"select={shown} picks query {int(array[row])} in row {row}, but there are "
                                   f"{n_queries} queries (0 to {n_queries - 1})")
    return array


@lru_cache(maxsize=256)
def _singleton_focal(model: Model):
    """θ_1, …, θ_n under ``model`` in frame order, their hashed focal key, and whether none is empty.

    Cached per model, so that :meth:`MassBatch.bayesian` costs no Python loop over the frame.
    """
    from belief.plan import FocalKey

    focal = tuple(model.reduce(x) for x in model.frame.singletons)
    return focal, FocalKey(focal), all(bool(x.terms) for x in focal)


# -- the batch -----------------------------------------------------------------------------------
class MassBatch:
    """N mass functions over one ordered list of K focal elements.

    Parameters
    ----------
    focal : sequence of Element or str
        The focal elements, shared by every row.  Elements are reduced under the model;
        two columns that become equal are merged.
    values : array_like, shape (N, K)
        Row n is the n-th mass function.
    frame, model :
        As for :class:`~belief.mass.MassFunction`.
    subnormal : bool
        Allow mass on ∅ (open world).
    validate : bool
        Check every row (finite, non-negative, sums to one); turn off only for arrays
        that the library itself produced.

    Examples
    --------
    >>> import numpy as np
    >>> from belief import Frame
    >>> rows = [[0.5, 0.2, 0.3], [0.1, 0.6, 0.3]]
    >>> batch = MassBatch(["a", "b", "a|b"], rows, frame=["a", "b"], model="shafer")
    >>> batch.bel("a")
    array([0.5, 0.1])
    >>> batch.pls(["a", "b"])
    array([[0.8, 0.5],
           [0.4, 0.9]])
    >>> batch.betp("a")
    array([0.65, 0.25])
    >>> MassBatch(["a", "b", "a|b"], rows, frame=["a", "b"], model="free").pls("a")  # a∩b ≠ ∅
    array([1., 1.])
    """

    __slots__ = ("model", "focal", "values", "_canonical", "_key", "__weakref__")

    #: The class of a batch on a dask array, :class:`~belief.dask_batches.DaskMassBatch`: that module sets it when
    #: it defines the class (``belief.rules`` imports it; the engine never imports it, nor dask).
    lazy_type: ClassVar[type]

    #: The class of one row (:meth:`__getitem__`), :class:`~belief.mass.MassFunction`: :mod:`belief.mass`, which
    #: builds the mass functions on this engine, sets it when it defines them (the engine never imports them).
    row_type: ClassVar[type]

    def __new__(cls, *args, **kwargs):
        # A dask array of values gives the lazy batch of belief.dask_batches (dask is imported only then).
        if cls is MassBatch and "dask.array" in sys.modules:
            values = args[1] if len(args) > 1 else kwargs.get("values")
            if isinstance(values, sys.modules["dask.array"].Array):
                return object.__new__(_lazy_type())
        return object.__new__(cls)

    def __init__(self, focal: Iterable[Query], values, frame=None, model=None, *,
                 subnormal: bool = False, validate: bool = True) -> None:
        model = resolve_model(frame, model)
        elements = [model.reduce(model.frame.element(x)) for x in focal]
        array = np.array(values, dtype=np.float64, copy=True)
        if array.ndim == 1 and len(elements) == array.size:
            array = array.reshape(1, -1)
        if array.ndim != 2 or array.shape[1] != len(elements):
            raise InvalidMassError(
                f"values must have shape (N, {len(elements)}) for {len(elements)} focal elements, "
                f"got {array.shape}"
            )
        if len(set(elements)) != len(elements):
            merged: dict[Element, int] = {}
            for e in elements:
                merged.setdefault(e, len(merged))
            combined = np.zeros((array.shape[0], len(merged)))
            for col, e in enumerate(elements):
                combined[:, merged[e]] += array[:, col]
            elements, array = list(merged), combined
        if validate:
            check_masses(array, elements, model, subnormal)
        array.flags.writeable = False
        self.model = model
        self.focal = tuple(elements)
        self.values = array
        keys = [e.sort_key for e in self.focal]
        self._canonical = all(a < b for a, b in zip(keys, keys[1:]))
        self._key = None

    @classmethod
    def _trusted(cls, model: Model, focal: tuple[Element, ...], values: np.ndarray,
                 canonical: bool = False) -> "MassBatch":
        """Wrap arrays the library computed; ``canonical`` says the focal elements are in canonical order."""
        obj = object.__new__(cls)
        values = np.asarray(values, dtype=np.float64)
        values.flags.writeable = False
        obj.model, obj.focal, obj.values, obj._canonical, obj._key = model, focal, values, canonical, None
        return obj

    @classmethod
    def bayesian(cls, values, *, frame=None, model=None, validate: bool = True) -> "MassBatch":
        """A batch of Bayesian mass functions: probability vectors over the hypotheses.

        The focal elements are the singletons θ_1, …, θ_n in frame order (cached per model,
        so a call costs no loop over the frame); :func:`~belief.rules.combine` recognises
        such batches and fuses them with closed forms (see :mod:`belief.bayesian`).

        Parameters
        ----------
        values : array_like, shape (N, n) or (n,)
            Row k gives m(θ_1), …, m(θ_n) of the k-th mass function; one row may be given
            as a vector.
        frame, model :
            As for :class:`~belief.mass.MassFunction` (a model alone is enough).
        validate : bool
            Check every row (finite, non-negative, sums to one within
            :data:`SUM_TOLERANCE`) and copy the array.  With ``validate=False`` the array is
            used as it is, without a copy: the caller vouches for it and must not modify it.

        Returns
        -------
        MassBatch
            N rows over the n singletons.

        Raises
        ------
        InvalidMassError
            For a wrong shape, or (with ``validate``) a row that is not a mass function.

        Examples
        --------
        >>> from belief import Model
        >>> cues = MassBatch.bayesian([[0.6, 0.3, 0.1], [0.2, 0.7, 0.1]], model=Model.for_targets(2))
        >>> [str(x) for x in cues.focal], cues.bel("t1")
        (['t1', 't2', 'FA'], array([0.6, 0.2]))
        """
        if "dask.array" in sys.modules and isinstance(values, sys.modules["dask.array"].Array):
            return _lazy_type().from_bayesian(values, frame=frame, model=model, validate=validate)
        model = resolve_model(frame, model)
        focal, key, none_empty = _singleton_focal(model)
        if not none_empty:
            # A hypothesis that the model declares empty: let the general constructor move its mass.
            return cls(focal, values, model=model, subnormal=not validate, validate=validate)
        array = np.asarray(values, dtype=np.float64)
        if array.ndim == 1 and array.size == len(focal):
            array = array.reshape(1, -1)
        if array.ndim != 2 or array.shape[1] != len(focal):
            raise InvalidMassError(f"values must have shape (N, {len(focal)}) for the {len(focal)} hypotheses "
                                   f"of the frame, got {array.shape}")
        if validate:
            array = array.copy()
            # No singleton is empty under the model, so the per-element check can be skipped.
            check_masses(array, focal, model, subnormal=True)
        else:
            array = array.view()          # read-only view: the caller's own array keeps its flags
        obj = cls._trusted(model, focal, array, canonical=True)
        obj._key = key
        return obj

    @property
    def focal_key(self):
        """The focal elements as a hashable key hashed once (combination plans are cached by it)."""
        if self._key is None:
            from belief.plan import FocalKey

            self._key = FocalKey(self.focal)
        return self._key

    @classmethod
    def from_mass_functions(cls, masses: Iterable) -> "MassBatch":
        """Stack mass functions of one model; the focal list is the union of theirs.

        >>> from belief import MassFunction
        >>> m1 = MassFunction({"a": 1.0}, frame=["a", "b"])
        >>> m2 = MassFunction({"b": 0.5, "a|b": 0.5}, frame=["a", "b"])
        >>> MassBatch.from_mass_functions([m1, m2]).values
        array([[1. , 0. , 0. ],
               [0. , 0.5, 0.5]])
        """
        masses = list(masses)
        if not masses:
            raise InvalidMassError("need at least one mass function")
        model = masses[0].model
        for m in masses[1:]:
            if m.model != model:
                raise FrameError("all mass functions of a batch must share one frame and model")
        focal = sorted({e for m in masses for e in m.focal}, key=lambda e: e.sort_key)
        column = {e: i for i, e in enumerate(focal)}
        values = np.zeros((len(masses), len(focal)))
        for row, m in enumerate(masses):
            for e, v in zip(m.focal, m.values.tolist()):
                values[row, column[e]] = v
        return cls._trusted(model, tuple(focal), values, canonical=True)

    # -- protocol ----------------------------------------------------------------------------
    @property
    def frame(self) -> Frame:
        return self.model.frame

    @property
    def shape(self) -> tuple[int, int]:
        return self.values.shape  # type: ignore[return-value]

    def __len__(self) -> int:
        return self.values.shape[0]

    def __getitem__(self, index: int):
        """Row ``index`` as a :class:`~belief.mass.MassFunction` (without the focal elements it gives no mass)."""
        row = self.values[index]
        if row.ndim != 1:
            raise TypeError("index a batch with one integer; use .values for slices")
        # canonical order of focal elements, as MassFunction equality and hashing expect
        positive = row > 0
        if self._canonical and positive.all():
            return self.row_type._trusted(self.model, self.focal, row)
        kept = np.flatnonzero(positive).tolist()
        if not self._canonical:
            kept.sort(key=lambda i: self.focal[i].sort_key)
        focal = self.focal
        return self.row_type._trusted(self.model, tuple([focal[i] for i in kept]), row[kept])

    def __iter__(self):
        for i in range(len(self)):
            yield self[i]

    def __repr__(self) -> str:
        return f"<MassBatch of {len(self)} mass functions over {len(self.focal)} focal elements>"

    # -- helpers -------------------------------------------------------------------------------
    def _plan(self, queries) -> tuple[MeasurePlan, bool]:
        single = isinstance(queries, (str, Element))
        if single:
            queries = [queries]
        try:
            resolved = _resolved(self.model, queries if type(queries) is tuple else tuple(queries))
        except TypeError:                       # an unhashable query: frame.element says what is wrong with it
            resolved = tuple(self.model.reduce(self.model.frame.element(q)) for q in queries)
        return measure_plan(self.model, self.focal, resolved), single

    @staticmethod
    def _shape(result: np.ndarray, single: bool) -> np.ndarray:
        return result[:, 0] if single else result

    @property
    def empty_mass(self) -> np.ndarray:
        """m(∅) of every row, shape (N,)."""
        cols = [i for i, e in enumerate(self.focal) if not e.terms]
        if not cols:
            return np.zeros(len(self))
        return self.values[:, cols[0]].copy()

    def _normal_values(self, what: str) -> np.ndarray:
        """Rows with ∅ removed and rescaled by 1 - m(∅) (Dempster normalisation)."""
        empty = self.empty_mass
        if not empty.any():
            return self.values
        return without_empty(self.values, np.array([bool(e.terms) for e in self.focal], dtype=np.float64), what)

    # -- measures -----------------------------------------------------------------------------------
    def _finish(self, result: np.ndarray, single: bool, select) -> np.ndarray:
        """(N, Q) -> (N,) for one query, (N, Q) for a list, or (N,) of the selected query per row."""
        if select is None:
            return self._shape(result, single)
        chosen = check_select(select, result.shape[0], result.shape[1])
        return result[np.arange(result.shape[0]), chosen]

    def bel(self, queries, *, select=None) -> np.ndarray:
        """Belief Bel(A) = Σ_{∅≠B⊆A} m(B) (W (8)).

        Parameters
        ----------
        queries : Element, str or sequence of them
        select : array_like of int, shape (N,), optional
            Evaluate only ``queries[select[n]]`` in row n.

        Returns
        -------
        ndarray
            Shape (N,) for one query or with ``select``, (N, Q) for a list of Q queries.
        """
        plan, single = self._plan(queries)
        return self._finish(plan.weigh(self.values, "subset"), single, select)

    def pls(self, queries, *, select=None) -> np.ndarray:
        """Plausibility Pls(A) = Σ_{B∩A≠∅} m(B) (W (9)); shapes and ``select`` as :meth:`bel`."""
        plan, single = self._plan(queries)
        return self._finish(plan.weigh(self.values, "meets"), single, select)

    def mass(self, queries, *, select=None) -> np.ndarray:
        """The mass m(A) of each query (0 for an element that is not focal); shapes and ``select`` as :meth:`bel`.

        A query that is empty under the model (∅ itself, or e.g. ``t1&FA`` under the tracking
        model) reads m(∅).

        >>> batch = MassBatch(["a", "a|b"], [[0.6, 0.4], [0.1, 0.9]], frame=["a", "b"])
        >>> batch.mass(["a", "b", "a|b"])
        array([[0.6, 0. , 0.4],
               [0.1, 0. , 0.9]])
        >>> batch.mass(["a", "a|b"], select=[1, 0])
        array([0.4, 0.1])
        """
        plan, single = self._plan(queries)
        return self._finish(plan.weigh(self.values, "equal"), single, select)

    def q(self, queries) -> np.ndarray:
        """Commonality q(A) = Σ_{B⊇A} m(B); shape (N,) or (N, Q)."""
        plan, single = self._plan(queries)
        return self._shape(plan.weigh(self.values, "superset"), single)

    commonality = q

    def betp(self, queries, *, select=None) -> np.ndarray:
        """Generalised pignistic probability BetP(A) = Σ_X m(X) C_M(X∩A)/C_M(X).

        Mass on ∅ is removed first and the rest rescaled by 1 - m(∅) (computed as the sum
        of the non-empty masses); shapes and ``select`` as :meth:`bel`.

        Raises
        ------
        TotalConflictError
            If a row has m(∅) = 1.
        """
        check_cardinality_range(self, "BetP")
        plan, single = self._plan(queries)
        return self._finish(plan.weigh(self._normal_values("BetP"), "ratio"), single, select)

    def dsmp(self, queries, epsilon: float = 0.001) -> np.ndarray:
        """DSmP_ε(A), the proportional probabilistic transformation of DSmT.

        DSmP_ε(A) = Σ_X m(X) [Σ_{Z⊆X∩A, C(Z)=1} m(Z) + ε C(X∩A)] / [Σ_{Z⊆X, C(Z)=1} m(Z) + ε C(X)],
        the sums over focal elements Z of DSm cardinality one (Dezert & Smarandache,
        "A new probabilistic transformation of belief mass assignment", Fusion 2008).
        ε = 0 gives DSmP_0 when every focal element holds such a Z.
        """
        epsilon = float(epsilon)
        if not math.isfinite(epsilon) or epsilon < 0:
            raise UndefinedTransformError(f"DSmP needs a finite ε ≥ 0, got {epsilon!r}")
        check_cardinality_range(self, "DSmP", epsilon)
        plan, single = self._plan(queries)
        m = self._normal_values("DSmP")
        sparse = plan.sparse
        if sparse is not None and sparse.complete:
            result, undefined = sparse.dsmp(m, epsilon)
            if undefined is None:
                return self._shape(result, single)
            raise _dsmp_undefined(epsilon, self.focal[undefined[1]])
        numerator = np.einsum("nz,zxa->nxa", m, plan.unit_in_meet) + epsilon * plan.meet_cardinality[None]
        denominator = weighted_sum(m, plan.unit_in_focal) + epsilon * plan.focal_cardinality[None]
        live = m > 0
        if (live & (denominator <= 0)).any():
            n, x = map(int, np.argwhere(live & (denominator <= 0))[0])
            raise _dsmp_undefined(epsilon, self.focal[x])
        safe = np.where(live, denominator, 1.0)
        shares = np.where(live[:, :, None], numerator / safe[:, :, None], 0.0)
        return self._shape(np.einsum("nx,nxa->na", m, shares), single)

    def pignistic(self) -> np.ndarray:
        """BetP of every hypothesis θ_1..θ_n, shape (N, n)."""
        return self.betp(self.frame.singletons)

    # -- operations ----------------------------------------------------------------------------------
    def _regroup(self, targets: Sequence[Element], scale: np.ndarray | None = None) -> "MassBatch":
        order = sorted(set(targets), key=lambda e: e.sort_key)
        column = {e: i for i, e in enumerate(order)}
        mapping = np.zeros((len(targets), len(order)))
        for i, t in enumerate(targets):
            mapping[i, column[t]] = 1.0
        values = weighted_sum(self.values, mapping)
        return trusted_batch(self.model, tuple(order), values, canonical=True)

    def discount(self, alpha: float) -> "MassBatch":
        """Shafer discounting with reliability α: m_α(X) = α m(X), m_α(Θ) += 1 - α.

        α = 1 keeps every row, α = 0 makes every row vacuous.
        """
        alpha = _check_alpha(alpha)
        total = self.model.total
        focal = list(self.focal)
        values = alpha * self.values
        if total in focal:
            col = focal.index(total)
            values[:, col] += 1.0 - alpha
        else:
            focal.append(total)
            values = np.hstack([values, np.full((len(self), 1), 1.0 - alpha)])
        order = sorted(range(len(focal)), key=lambda i: focal[i].sort_key)
        return trusted_batch(self.model, tuple(focal[i] for i in order), values[:, order], canonical=True)

    def condition(self, given: Query, normalized: bool = True) -> "MassBatch":
        """Dempster conditioning on ``given``: m(C | B) = Σ_{X∩B=C} m(X).

        Unnormalised, the mass of X with X ∩ B = ∅ stays on ∅; normalised, it is removed and
        the rest rescaled by 1 - m(∅).
        """
        named = self.model.frame.element(given)
        given = self.model.reduce(named)
        targets = [self.model.reduce(x & given) for x in self.focal]
        result = self._regroup(targets)
        if not normalized:
            return result
        return trusted_batch(result.model, result.focal, result._normal_values(f"conditioning on {named}"),
                                  canonical=result._canonical)._drop_empty()

    def _drop_empty(self) -> "MassBatch":
        keep = [i for i, e in enumerate(self.focal) if e.terms]
        return trusted_batch(self.model, tuple(self.focal[i] for i in keep), self.values[:, keep],
                                  canonical=self._canonical)

    def normalized(self) -> "MassBatch":
        """Remove the mass of ∅ and rescale each row by 1 - m(∅)."""
        return trusted_batch(self.model, self.focal, self._normal_values("normalisation"),
                                  canonical=self._canonical)._drop_empty()

    def under(self, model: Model) -> "MassBatch":
        """The same evidence read under a stricter model (dynamic fusion).

        Every focal element is reduced under ``model``; mass of elements that become
        empty goes to ∅, so the result may be subnormal (see :meth:`normalized`).
        """
        check_refines(self.model, model)
        return trusted_batch(model, self.focal, self.values)._regroup(
            [model.reduce(x) for x in self.focal])


def _lazy_type() -> type:
    lazy = getattr(MassBatch, "lazy_type", None)
    if lazy is None:                       # belief.rules defines it on import, which ``import belief`` does
        import importlib

        lazy = importlib.import_module("belief.dask_batches").DaskMassBatch
    return lazy


def _dsmp_undefined(epsilon: float, element: Element) -> UndefinedTransformError:
    return UndefinedTransformError(f"DSmP with ε = {epsilon:g} is undefined: focal element {element} holds no mass "
                                   "of DSm cardinality one; use ε > 0")


def _check_alpha(alpha: float) -> float:
    try:
        value = float(alpha)
    except (TypeError, ValueError):
        raise InvalidMassError(f"the reliability α must be a number in [0, 1], got {alpha!r}") from None
    if not (0.0 <= value <= 1.0):
        raise InvalidMassError(f"the reliability α must be in [0, 1], got {alpha!r}")
    return value


def check_refines(old: Model, new: Model) -> None:
    if not isinstance(new, Model):
        raise TypeError(f"expected a Model, got {type(new).__name__}")
    if new.frame != old.frame:
        raise FrameError("the new model must be over the same frame")
    if not old.is_refined_by(new):
        allowed = [old.frame.term_name(f) for f in old.forbidden if not new.is_forbidden(f)]
        from belief.errors import ModelError

        raise ModelError(
            f"the {new.kind} model is not stricter than the {old.kind} model: it allows "
            f"{', '.join(allowed)}, which the source model declares empty"
        )


def check_cardinality_range(mass, what: str, epsilon: float | None = None) -> None:
    """Refuse a transformation whose DSm cardinalities, or ε times them, do not fit a float.

    ``mass`` is a :class:`MassBatch` or a :class:`~belief.mass.MassFunction`.  BetP and DSmP
    divide by C_M(X) (DSmP by m(X's singletons) + ε C_M(X)) in floating point; past the
    largest float (about 1.8e308) the quotient would come out as 0 or NaN instead of the
    right value.  C_M(X) ≤ 2^n - 1, so frames of fewer than 1 023 hypotheses with ε ≤ 1
    pass without computing anything.

    Raises
    ------
    UndefinedTransformError
        Naming the focal element, its cardinality and, for DSmP, the largest usable ε.
    """
    if epsilon is not None:
        try:
            epsilon = float(epsilon)
        except (TypeError, ValueError, OverflowError):
            return                      # MassBatch.dsmp names the bad ε
        if not math.isfinite(epsilon) or epsilon < 0:
            return
    model = mass.model
    # C_M(X) ≤ 2^n - 1, and under Shafer's model C_M(X) ≤ n.
    if (len(model.frame) < 1023 or model.kind == "shafer") and (epsilon is None or epsilon <= 1.0):
        return
    biggest, focal = max((model.cardinality(x), i) for i, x in enumerate(mass.focal))
    x = mass.focal[focal]
    if biggest.bit_length() > 1023:
        raise UndefinedTransformError(
            f"{what} is out of floating-point range: the DSm cardinality of {_show.repr(str(x))} under the "
            f"{model.kind} model of {len(model.frame):,} hypotheses is about 2^{biggest.bit_length() - 1}, more "
            "than the largest float (about 2^1024); use Shafer's model or constraints that leave fewer Venn regions"
        )
    if epsilon is not None and not math.isfinite(epsilon * float(biggest)):
        raise UndefinedTransformError(
            f"DSmP with ε = {epsilon:g} is out of floating-point range: ε·C({_show.repr(str(x))}) = "
            f"{epsilon:g}·{biggest} exceeds the largest float, and the shares of that element would be lost; "
            f"use ε ≤ {_largest_epsilon(biggest):.6g} (as ε grows DSmP tends to BetP)"
        )


def _largest_epsilon(cardinality: int) -> float:
    """The largest ε whose product with ``cardinality`` is a finite float."""
    epsilon = sys.float_info.max / cardinality
    while not math.isfinite(epsilon * float(cardinality)):
        epsilon = math.nextafter(epsilon, 0.0)
    return epsilon


def trusted_batch(model: Model, focal: tuple[Element, ...], values: np.ndarray, canonical: bool = False) -> "MassBatch":
    """A batch of arrays the library computed, wrapped without checks (the package's kernels make their results so).

    ``canonical`` says the focal elements are in canonical order.
    """
    obj = object.__new__(MassBatch)
    values = np.asarray(values, dtype=np.float64)
    values.flags.writeable = False
    obj.model, obj.focal, obj.values, obj._canonical, obj._key = model, focal, values, canonical, None
    return obj
