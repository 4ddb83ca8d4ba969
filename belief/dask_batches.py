"""Batches on Dask arrays: the rows of a :class:`~belief.batch.MassBatch` chunked, and every kernel run per chunk.

``MassBatch(focal, values)`` and ``MassBatch.bayesian(values, ...)`` given a
``dask.array.Array`` of shape (N, K) give a :class:`DaskMassBatch`: a batch whose
``values`` is a dask array chunked by rows (one chunk along the focal elements; other
chunkings are rechunked).  Everything on it is lazy and built with
:func:`dask.array.blockwise` over the in-memory kernels:

* :func:`~belief.rules.combine` returns a :class:`DaskMassBatch` whose focal elements are
  those the in-memory path gives (found from a one-row probe of the same sources, before
  anything is computed); each chunk of rows is combined by ``combine`` itself, so with the
  kernel that ``combine`` picks for that rule and representation, and the work and memory
  limits of :mod:`belief.plan` apply to a chunk, not to the whole batch;
* the measures (:meth:`~DaskMassBatch.bel`, ``pls``, ``mass``, ``q``, ``betp``, ``dsmp``,
  :attr:`~DaskMassBatch.empty_mass`) return dask arrays, and
  :func:`~belief.decisions.decide` a :class:`~belief.decisions.DecisionBatch` of dask arrays;
* ``discount``, ``condition``, ``normalized`` and ``under`` return lazy batches;
* :meth:`DaskMassBatch.compute` gives the in-memory :class:`~belief.batch.MassBatch`.

The rows are checked (finite, non-negative, summing to one) chunk by chunk when they are
computed, and a bad row raises :class:`~belief.errors.InvalidMassError` naming its row in the
whole batch.  Each row of a result is computed by the same kernel as in memory, so results
are equal bit for bit, with one exception: BetP and DSmP remove the mass of ∅ and rescale
every row of a batch (chunk) when one of its rows has m(∅) > 0, so a row without mass on ∅
may differ by the rounding of that division by its total mass (a relative
:data:`~belief.rules_common.RESULT_TOLERANCE` at most).

Dask is optional (``pip install belief-dsmt[dask]``): this module imports it only when a
dask array is given, and ``import belief`` never imports it.

Examples
--------
>>> import numpy as np
>>> import pytest
>>> da = pytest.importorskip("dask.array")
>>> from belief import MassBatch, Model, combine
>>> model = Model.for_targets(2)
>>> rows = np.array([[0.6, 0.3, 0.1], [0.2, 0.7, 0.1], [0.5, 0.25, 0.25]])
>>> a = MassBatch.bayesian(da.from_array(rows, chunks=(2, -1)), model=model)
>>> b = MassBatch.bayesian(da.from_array(rows[::-1].copy(), chunks=(2, -1)), model=model)
>>> fused = combine(a, b, rule="pcr6")
>>> type(fused).__name__, [str(x) for x in fused.focal], fused.values.chunks
('DaskMassBatch', ['t1', 't2', 'FA', 't1&t2'], ((2, 1), (4,)))
>>> memory = combine(MassBatch.bayesian(rows, model=model), MassBatch.bayesian(rows[::-1], model=model), rule="pcr6")
>>> bool(np.array_equal(fused.compute().values, memory.values))
True
>>> bool(np.array_equal(fused.bel("t1").compute(), memory.bel("t1")))
True
"""

from __future__ import annotations

import math
import sys
from collections.abc import Iterable, Sequence

import numpy as np

from belief.batch import MassBatch, _singleton_focal, check_masses, check_select, resolve_model, trusted_batch
from belief.errors import InvalidMassError
from belief.frame import Element
from belief.model import Model

__all__ = ["DaskMassBatch", "is_dask_array", "from_npy", "to_npy", "NpyRows", "NpyTarget", "combine_lazy",
           "lazy_decisions"]

#: Set once a :class:`DaskMassBatch` exists: until then :func:`~belief.rules.combine` does not look for one.
made = False


def is_dask_array(values) -> bool:
    """Whether ``values`` is a ``dask.array.Array`` (False, without importing dask, when dask was never imported).

    >>> is_dask_array(np.zeros((2, 3)))
    False
    """
    module = sys.modules.get("dask.array")
    return module is not None and isinstance(values, module.Array)


def _dask_array():
    try:
        import dask.array as da
    except ImportError:                                   # pragma: no cover - dask is given when we get here
        raise ImportError("batches on dask arrays need dask: pip install 'belief-dsmt[dask]'") from None
    return da


def any_lazy(sources) -> bool:
    """Whether one of ``combine``'s sources (or of a list given as its only argument) is a :class:`DaskMassBatch`."""
    if len(sources) == 1 and isinstance(sources[0], (list, tuple)):
        sources = sources[0]
    return any(isinstance(s, DaskMassBatch) for s in sources)


def _prepared(values, columns: int, what: str):
    """``values`` as a float64 dask array of shape (N, columns), one chunk along axis 1, with known row chunks."""
    array = values if values.dtype == np.float64 else values.astype(np.float64)
    if array.ndim == 1 and array.shape[0] == columns:
        array = array.reshape(1, columns)
    if array.ndim != 2 or array.shape[1] != columns:
        raise InvalidMassError(f"values must have shape (N, {columns}) for {what}, got {array.shape}")
    if any(math.isnan(c) for c in array.chunks[0]):
        raise InvalidMassError("the row chunks of the dask array are unknown; call its compute_chunk_sizes() first")
    if array.numblocks[1] != 1:
        array = array.rechunk({1: -1})                   # whole rows of focal elements in every chunk
    return array


def probe_row(live: np.ndarray, n: int) -> np.ndarray:
    """A made-up mass function of shape (1, K): distinct positive masses on the ``live`` columns, others for input n.

    >>> probe_row(np.array([False, True, True]), 0).round(3)
    array([[0.   , 0.567, 0.433]])
    """
    weights = 1.0 + (np.arange(len(live)) * 0.6180339887498949 + n * 0.41421356237309515) % 1.0
    weights = np.where(live, weights, 0.0) if live.any() else weights
    return (weights / weights.sum()).reshape(1, -1)


class _RowNames:
    """Row labels ``row <n>`` of a chunk that starts at row ``start`` of the whole batch (for check_masses)."""

    __slots__ = ("start",)

    def __init__(self, start: int) -> None:
        self.start = start

    def __getitem__(self, row: int) -> str:
        return f"row {self.start + row}"


def _start(block_info) -> int:
    if not block_info or 0 not in block_info:
        return 0
    return int(block_info[0]["array-location"][0][0])


class _Checked:
    """A chunk of a user's array: its duplicate columns merged as the constructor does, then checked (``validate``)."""

    def __init__(self, raw: tuple[Element, ...], focal: tuple[Element, ...], model: Model, subnormal: bool,
                 validate: bool) -> None:
        self.raw, self.focal, self.model, self.subnormal, self.validate = raw, focal, model, subnormal, validate

    def __call__(self, block: np.ndarray, block_info=None) -> np.ndarray:
        block = np.asarray(block, dtype=np.float64)
        if len(self.raw) != len(self.focal):
            block = MassBatch(self.raw, block, model=self.model, validate=False).values
        if self.validate:
            check_masses(block, self.focal, self.model, self.subnormal, row_names=_RowNames(_start(block_info)))
        return block


class _Plain:
    """The in-memory batch of one chunk of a batch's values."""

    def __init__(self, model: Model, focal: tuple[Element, ...], canonical: bool) -> None:
        self.model, self.focal, self.canonical = model, focal, canonical

    def __call__(self, block: np.ndarray) -> MassBatch:
        return trusted_batch(self.model, self.focal, np.asarray(block), canonical=self.canonical)


class _Op:
    """A batch operation (``discount``, ``condition``, ...) applied to the in-memory batch of a chunk."""

    def __init__(self, chunk, name: str, args: tuple) -> None:
        self.chunk, self.name, self.args = chunk, name, args

    def __call__(self, *blocks) -> MassBatch:
        return getattr(self.chunk(*blocks), self.name)(*self.args)


class _Combined:
    """``combine`` of the in-memory batches of one chunk of each source (one-row sources as they are)."""

    def __init__(self, combine, parts: list, info, model, engine: str, options: dict) -> None:
        # parts: (chunk function, number of input arrays) for a lazy source, (None, source) for a broadcast one
        self.combine, self.parts, self.info, self.model, self.engine, self.options = (combine, parts, info, model,
                                                                                       engine, options)

    def __call__(self, *blocks) -> MassBatch:
        sources, at = [], 0
        for chunk, count in self.parts:
            if chunk is None:
                sources.append(count)
            else:
                sources.append(chunk(*blocks[at:at + count]))
                at += count
        return self.combine(*sources, rule=self.info, model=self.model, engine=self.engine, **self.options)


class _Values:
    """The values of a chunk's batch, in the columns of the planned focal elements."""

    def __init__(self, chunk, focal: tuple[Element, ...]) -> None:
        self.chunk, self.focal = chunk, focal

    def __call__(self, *blocks) -> np.ndarray:
        batch = self.chunk(*blocks)
        if batch.focal == self.focal:
            return np.asarray(batch.values)
        column = {e: i for i, e in enumerate(self.focal)}
        missing = [e for e in batch.focal if e not in column]
        if missing:
            from belief.errors import BeliefError

            raise BeliefError(f"a chunk's result has the focal element {missing[0]}, which the plan of the lazy batch "
                              f"does not hold ({', '.join(map(str, self.focal))})")
        out = np.zeros((len(batch), len(self.focal)))
        out[:, [column[e] for e in batch.focal]] = batch.values
        return out


class _Measure:
    """A measure of a chunk's batch (the last block is ``select`` where it is given)."""

    def __init__(self, chunk, name: str, queries, keywords: dict, selected: bool) -> None:
        self.chunk, self.name, self.queries, self.keywords, self.selected = chunk, name, queries, keywords, selected

    def __call__(self, *blocks) -> np.ndarray:
        if self.selected:
            batch = self.chunk(*blocks[:-1])
            return getattr(batch, self.name)(self.queries, select=blocks[-1], **self.keywords)
        batch = self.chunk(*blocks)
        if self.queries is None:
            return np.asarray(getattr(batch, self.name), dtype=np.float64)
        return getattr(batch, self.name)(self.queries, **self.keywords)


class _Decided:
    """One field of :func:`belief.decisions._decisions` of a chunk of scores."""

    def __init__(self, decisions, names: tuple[str, ...], tol: float, field: str) -> None:
        self.decisions, self.names, self.tol, self.field = decisions, names, tol, field

    def __call__(self, scores: np.ndarray) -> np.ndarray:
        return getattr(self.decisions(self.names, scores, self.tol), self.field)


class DaskMassBatch(MassBatch):
    """N mass functions over K focal elements whose ``(N, K)`` values are a dask array chunked by rows.

    Made by ``MassBatch(focal, values)`` or ``MassBatch.bayesian(values, ...)`` given a
    ``dask.array.Array`` (the parameters are those of :class:`~belief.batch.MassBatch`), by
    :func:`from_npy`, and by :func:`~belief.rules.combine` and the operations of such
    batches.  The rows are checked chunk by chunk when computed.

    Attributes
    ----------
    values : dask.array.Array, shape (N, K)
        Chunked by rows, one chunk along the focal elements.
    focal : tuple of Element
        The K focal elements, known before anything is computed.

    Examples
    --------
    >>> import pytest
>>> da = pytest.importorskip("dask.array")
    >>> from belief import MassBatch
    >>> values = da.from_array(np.array([[0.5, 0.2, 0.3], [0.1, 0.6, 0.3]]), chunks=(1, 3))
    >>> batch = MassBatch(["a", "b", "a|b"], values, frame=["a", "b"])
    >>> type(batch).__name__, batch.shape
    ('DaskMassBatch', (2, 3))
    >>> batch.pls(["a", "b"]).compute()
    array([[0.8, 0.5],
           [0.4, 0.9]])
    >>> batch.discount(0.5).compute().values
    array([[0.25, 0.1 , 0.65],
           [0.05, 0.3 , 0.65]])
    """

    __slots__ = ("_inputs", "_live", "_chunk", "_plain")

    def __init__(self, focal: Iterable, values, frame=None, model=None, *, subnormal: bool = False,
                 validate: bool = True) -> None:
        model = resolve_model(frame, model)
        raw = tuple(model.reduce(model.frame.element(x)) for x in focal)
        array = _prepared(values, len(raw), f"{len(raw)} focal elements")
        merged = MassBatch(raw, np.zeros((0, len(raw))), model=model, validate=False)
        focal = merged.focal
        if validate or len(focal) != len(raw):
            array = array.map_blocks(_Checked(raw, focal, model, subnormal, validate), dtype=np.float64,
                                     chunks=(array.chunks[0], (len(focal),)), meta=np.empty((0, 0)))
        self._setup(model, focal, merged._canonical, (array,), _Plain(model, focal, merged._canonical), True)

    def _setup(self, model: Model, focal: tuple[Element, ...], canonical: bool, inputs: tuple, chunk,
               plain: bool, live: tuple | None = None) -> None:
        global made
        made = True
        self.model, self.focal, self._canonical, self._key = model, focal, canonical, None
        self._inputs, self._chunk, self._plain = inputs, chunk, plain
        # Per input, the columns of elements that are not empty under the model (the probe's mass goes there).
        self._live = live if live is not None else (np.array([not model.is_empty(x) for x in focal]),)

    @classmethod
    def _make(cls, model: Model, focal: tuple[Element, ...], canonical: bool, inputs: tuple, chunk,
              live: tuple) -> "DaskMassBatch":
        obj = object.__new__(cls)
        obj._setup(model, focal, canonical, inputs, chunk, False, live)
        return obj

    @classmethod
    def from_bayesian(cls, values, *, frame=None, model=None, validate: bool = True) -> "DaskMassBatch":
        """:meth:`MassBatch.bayesian <belief.batch.MassBatch.bayesian>` of a dask array of shape (N, n)."""
        model = resolve_model(frame, model)
        focal, key, none_empty = _singleton_focal(model)
        if not none_empty:
            return cls(focal, values, model=model, subnormal=not validate, validate=validate)
        array = _prepared(values, len(focal), f"the {len(focal)} hypotheses of the frame")
        if validate:
            array = array.map_blocks(_Checked(focal, focal, model, True, True), dtype=np.float64,
                                     meta=np.empty((0, 0)))
        obj = object.__new__(cls)
        obj._setup(model, focal, True, (array,), _Plain(model, focal, True), True)
        obj._key = key
        return obj

    @classmethod
    def wrap(cls, batch: MassBatch, chunks) -> "DaskMassBatch":
        """An in-memory batch as a lazy one whose rows are chunked as ``chunks`` (a tuple of row counts or an int)."""
        if isinstance(batch, DaskMassBatch):
            return batch.rechunk(chunks)
        da = _dask_array()
        values = da.from_array(np.asarray(batch.values), chunks=(chunks, -1))
        return cls._from_values(batch.model, batch.focal, batch._canonical, values)

    @classmethod
    def _from_values(cls, model: Model, focal: tuple[Element, ...], canonical: bool, values) -> "DaskMassBatch":
        obj = object.__new__(cls)
        obj._setup(model, focal, canonical, (values,), _Plain(model, focal, canonical), True)
        return obj

    # -- the dask side --------------------------------------------------------------------------------
    @property
    def values(self):  # type: ignore[override]
        """The (N, K) values as a dask array (computed by the chunks' kernels)."""
        if self._plain:
            return self._inputs[0]
        return self._blockwise(_Values(self._chunk, self.focal), len(self.focal))

    @property
    def row_chunks(self) -> tuple[int, ...]:
        """The number of rows of each chunk."""
        return tuple(self._inputs[0].chunks[0])

    def _blockwise(self, function, columns: int | None, extra: Sequence = (), dtype=np.float64):
        """``function`` of the blocks of every input (and of ``extra`` arrays of shape (N,)), per chunk of rows.

        The result has shape (N,) (``columns=None``) or (N, columns).
        """
        da = _dask_array()
        args: list = []
        for n, array in enumerate(self._inputs):
            args += [array, ("i", f"k{n}")]
        for array in extra:
            args += [array, ("i",)]
        if columns is None:
            return da.blockwise(function, ("i",), *args, dtype=dtype, concatenate=True, meta=np.empty((0,), dtype))
        return da.blockwise(function, ("i", "j"), *args, new_axes={"j": columns}, dtype=dtype, concatenate=True,
                            meta=np.empty((0, 0), dtype))

    def probe(self) -> MassBatch:
        """The in-memory batch of one made-up row of each input: its focal elements and shapes are those of the
        chunks (nothing of the dask arrays is computed).

        The row of input n puts a different positive mass on every element that is not
        empty under the model (none equal, none shared with another input), so that a rule
        whose focal elements depend on the masses (the R-weighted rule keeps A ∩ B only
        where R > 0) reaches all the elements it can.
        """
        return self._chunk(*[probe_row(live, n) for n, live in enumerate(self._live)])

    def rechunk(self, chunks) -> "DaskMassBatch":
        """The same batch with its rows chunked as ``chunks`` (a tuple of row counts, or rows per chunk)."""
        inputs = tuple(a.rechunk({0: chunks, 1: -1}) for a in self._inputs)
        if self._plain:
            return DaskMassBatch._from_values(self.model, self.focal, self._canonical, inputs[0])
        return DaskMassBatch._make(self.model, self.focal, self._canonical, inputs, self._chunk, self._live)

    def compute(self, **kwargs) -> MassBatch:
        """The in-memory :class:`~belief.batch.MassBatch` (``kwargs`` go to ``dask.array.Array.compute``)."""
        values = self.values.compute(**kwargs)
        return trusted_batch(self.model, self.focal, np.asarray(values), canonical=self._canonical)

    def _derive(self, name: str, *args) -> "DaskMassBatch":
        probe = getattr(self.probe(), name)(*args)          # checks the arguments and plans the focal elements
        return DaskMassBatch._make(probe.model, probe.focal, probe._canonical, self._inputs,
                                   _Op(self._chunk, name, args), self._live)

    # -- protocol -------------------------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        return (len(self), len(self.focal))

    def __len__(self) -> int:
        return int(self._inputs[0].shape[0])

    def __getitem__(self, index: int):
        """Row ``index`` as a :class:`~belief.mass.MassFunction` (computes that row's chunk)."""
        if not isinstance(index, (int, np.integer)):
            raise TypeError("index a batch with one integer; use .values for slices")
        n = len(self)
        if not -n <= index < n:
            raise IndexError(f"row {index} of a batch of {n} rows")
        index = int(index) % n
        row = self.values[index:index + 1].compute()
        return trusted_batch(self.model, self.focal, row, canonical=self._canonical)[0]

    def __iter__(self):
        raise TypeError("a lazy batch is not iterated row by row; compute() it, or a slice of its values, first")

    def __repr__(self) -> str:
        chunks = self.row_chunks
        return (f"<DaskMassBatch of {len(self)} mass functions over {len(self.focal)} focal elements, "
                f"{len(chunks)} chunk{'s' if len(chunks) != 1 else ''} of rows>")

    # -- measures -------------------------------------------------------------------------------------
    def _measure(self, name: str, queries, select=None, **keywords):
        probe = getattr(self.probe(), name)
        if select is None:
            shape = probe(queries, **keywords).shape
            return self._blockwise(_Measure(self._chunk, name, queries, keywords, False),
                                   None if len(shape) == 1 else shape[1])
        queries_count = probe(queries, **keywords).reshape(1, -1).shape[1]
        chosen = self._select(select, queries_count)
        return self._blockwise(_Measure(self._chunk, name, queries, keywords, True), None, extra=(chosen,))

    def _select(self, select, queries: int):
        if is_dask_array(select):
            if select.dtype == bool or not np.issubdtype(select.dtype, np.integer):
                raise InvalidMassError(f"select must be an array of integer query positions, got dtype {select.dtype}")
            if select.shape != (len(self),):
                raise InvalidMassError(f"select must have shape ({len(self)},), one query position per row, "
                                       f"got {select.shape}")
            return select.rechunk((self.row_chunks,))
        chosen = check_select(select, len(self), queries)
        return _dask_array().from_array(chosen, chunks=(self.row_chunks,))

    def bel(self, queries, *, select=None):
        """Belief of each query, a dask array of shape (N,) or (N, Q) (:meth:`MassBatch.bel <belief.batch.MassBatch.bel>`)."""
        return self._measure("bel", queries, select)

    def pls(self, queries, *, select=None):
        """Plausibility of each query, a dask array (:meth:`MassBatch.pls <belief.batch.MassBatch.pls>`)."""
        return self._measure("pls", queries, select)

    def mass(self, queries, *, select=None):
        """The mass of each query, a dask array (:meth:`MassBatch.mass <belief.batch.MassBatch.mass>`)."""
        return self._measure("mass", queries, select)

    def betp(self, queries, *, select=None):
        """BetP of each query, a dask array (:meth:`MassBatch.betp <belief.batch.MassBatch.betp>`); ∅ is removed
        chunk by chunk (see the module's notes)."""
        return self._measure("betp", queries, select)

    def q(self, queries):
        """Commonality of each query, a dask array (:meth:`MassBatch.q <belief.batch.MassBatch.q>`)."""
        return self._measure("q", queries)

    commonality = q

    def dsmp(self, queries, epsilon: float = 0.001):
        """DSmP_ε of each query, a dask array (:meth:`MassBatch.dsmp <belief.batch.MassBatch.dsmp>`)."""
        return self._measure("dsmp", queries, epsilon=epsilon)

    def pignistic(self):
        """BetP of every hypothesis, a dask array of shape (N, n)."""
        return self.betp(self.frame.singletons)

    @property
    def empty_mass(self):
        """m(∅) of every row, a dask array of shape (N,)."""
        return self._blockwise(_Measure(self._chunk, "empty_mass", None, {}, False), None)

    # -- operations -----------------------------------------------------------------------------------
    def discount(self, alpha: float) -> "DaskMassBatch":
        """Shafer discounting, lazily (:meth:`MassBatch.discount <belief.batch.MassBatch.discount>`)."""
        return self._derive("discount", alpha)

    def condition(self, given, normalized: bool = True) -> "DaskMassBatch":
        """Dempster conditioning, lazily (:meth:`MassBatch.condition <belief.batch.MassBatch.condition>`)."""
        return self._derive("condition", given, normalized)

    def normalized(self) -> "DaskMassBatch":
        """∅ removed and rows rescaled, lazily (:meth:`MassBatch.normalized <belief.batch.MassBatch.normalized>`)."""
        return self._derive("normalized")

    def under(self, model: Model) -> "DaskMassBatch":
        """The batch read under a stricter model, lazily (:meth:`MassBatch.under <belief.batch.MassBatch.under>`)."""
        return self._derive("under", model)


class NpyRows:
    """The rows of a ``.npy`` file, read through a memory map opened where they are read.

    It pickles as its path only, so a task sent to a ``dask.distributed`` worker process
    opens the file there (a ``np.memmap`` itself pickles as a copy of all its data).
    """

    def __init__(self, path) -> None:
        self.path = str(path)
        mapped = np.load(self.path, mmap_mode="r")
        self.shape, self.dtype, self.ndim = mapped.shape, mapped.dtype, mapped.ndim
        del mapped

    def __reduce__(self):
        return (NpyRows, (self.path,))

    def __getitem__(self, index) -> np.ndarray:
        # A map per read, closed after the copy: pages of the file read earlier do not stay in the process's memory.
        mapped = np.load(self.path, mmap_mode="r")
        out = np.array(mapped[index], dtype=np.float64)
        del mapped
        return out


class NpyTarget:
    """A ``.npy`` file written in place, as the target of ``dask.array.store`` (pickles as its path, as :class:`NpyRows`)."""

    def __init__(self, path) -> None:
        self.path = str(path)

    def __setitem__(self, index, value) -> None:
        mapped = np.load(self.path, mmap_mode="r+")
        mapped[index] = value
        mapped.flush()
        del mapped


def to_npy(values, path) -> None:
    """Compute a lazy batch's values (or a dask array) chunk by chunk into a new ``.npy`` file at ``path``.

    Each chunk is written where it is computed (a ``dask.distributed`` worker writes its
    own chunks), so the result never has to fit in memory.
    """
    da = _dask_array()
    if isinstance(values, DaskMassBatch):
        values = values.values
    header = np.lib.format.open_memmap(str(path), mode="w+", dtype=values.dtype, shape=values.shape)
    del header
    da.store(values, NpyTarget(path), lock=False)


def from_npy(path, focal=None, *, rows_per_chunk: int = 1 << 20, frame=None, model=None,
             validate: bool = True) -> DaskMassBatch:
    """A lazy batch over a ``.npy`` file of shape (N, K), read as a memory map chunk by chunk.

    Parameters
    ----------
    path : str or path-like
        A ``.npy`` file of float64 (other dtypes are converted per chunk).
    focal : sequence of Element or str, optional
        The K focal elements; by default the batch is Bayesian (:meth:`MassBatch.bayesian`).
    rows_per_chunk : int
        Rows of each chunk.
    frame, model, validate :
        As for :class:`~belief.batch.MassBatch`.

    Returns
    -------
    DaskMassBatch
    """
    da = _dask_array()
    values = da.from_array(NpyRows(path), chunks=(rows_per_chunk, -1), asarray=True)
    if focal is None:
        return DaskMassBatch.from_bayesian(values, frame=frame, model=model, validate=validate)
    return DaskMassBatch(focal, values, frame=frame, model=model, validate=validate)


def combine_lazy(combine, sources: Sequence, info, model, engine: str, options: dict) -> DaskMassBatch:
    """:func:`~belief.rules.combine` where a source is a :class:`DaskMassBatch`: the same ``combine`` per chunk of rows.

    ``combine`` is :func:`belief.rules.combine` and ``info`` the rule's
    :class:`~belief.rules_registry.RuleInfo` (this module does not import the rules).
    Multi-row in-memory sources are wrapped with the row chunks of the first lazy source,
    other lazy sources are rechunked to them; one-row sources and mass functions are
    broadcast to every chunk.  The rule, options and focal elements are checked on a
    one-row probe before anything is computed.

    Raises
    ------
    InvalidMassError
        For sources with different numbers of rows (or fewer than two sources).
    """
    if len(sources) == 1 and isinstance(sources[0], (list, tuple)):
        sources = tuple(sources[0])
    if len(sources) < 2:
        raise InvalidMassError(f"combination needs at least two sources, got {len(sources)}")
    first = next(s for s in sources if isinstance(s, DaskMassBatch))
    rows, chunks = len(first), first.row_chunks
    parts, inputs, live, probes = [], [], [], []
    for k, source in enumerate(sources, start=1):
        if isinstance(source, MassBatch) and (isinstance(source, DaskMassBatch) or len(source) != 1):
            if len(source) != rows:
                raise InvalidMassError(f"batches have different numbers of rows: source {k} has {len(source):,}, "
                                       f"the first lazy source {rows:,}")
            source = DaskMassBatch.wrap(source, chunks) if not isinstance(source, DaskMassBatch) else source
            if source.row_chunks != chunks:
                source = source.rechunk(chunks)
            parts.append((source._chunk, len(source._inputs)))
            probes.append(source._chunk(*[probe_row(columns, len(live) + n)
                                          for n, columns in enumerate(source._live)]))
            inputs.extend(source._inputs)
            live.extend(source._live)
        else:
            parts.append((None, source))                  # a mass function or a one-row batch: broadcast
            probes.append(source)
    probe = combine(*probes, rule=info, model=model, engine=engine, **options)
    if not isinstance(probe, MassBatch):
        raise InvalidMassError("a lazy combination needs a batch among its sources")
    return DaskMassBatch._make(probe.model, probe.focal, probe._canonical, tuple(inputs),
                               _Combined(combine, parts, info, model, engine, options), tuple(live))


def lazy_decisions(decisions, batch: DaskMassBatch, key: str, queries: tuple, names: tuple[str, ...], tol: float,
                   epsilon: float):
    """The :class:`~belief.decisions.DecisionBatch` of a lazy batch: dask arrays, each chunk decided in memory.

    ``decisions`` is the function of :mod:`belief.decisions` that decides an in-memory array of
    scores (this module does not import that one).
    """
    scores = batch.dsmp(queries, epsilon=epsilon) if key == "dsmp" else getattr(batch, key)(queries)
    if scores.ndim == 1:
        scores = scores[:, None]
    value = scores.map_blocks(_Decided(decisions, names, tol, "value"), drop_axis=1, dtype=np.float64)
    tied = scores.map_blocks(_Decided(decisions, names, tol, "tied"), dtype=bool)
    index = scores.map_blocks(_Decided(decisions, names, tol, "index"), drop_axis=1, dtype=np.intp)
    return type(decisions(names, np.zeros((0, len(names))), tol))(names, scores, value, tied, index)


MassBatch.lazy_type = DaskMassBatch
