"""The hyper-power set D^Θ (Dedekind lattice) of a frame under a model (SPEC A.1, A.2).

Under a model, the allowed Venn regions form a family closed under taking non-empty
subsets, and the elements of D^Θ are exactly the up-sets (upward-closed families) of
allowed regions.  They are enumerated here as 64-bit masks over the allowed regions,
with a vectorised sweep: regions are visited from the largest to the smallest, and each
partial up-set either leaves a region out or takes it in, which it may do only if it
already holds every allowed region one hypothesis larger.

Sizes with ∅ on the free model: 2, 5, 19, 167, 7580 and 7 828 353 for n = 1..6; n = 7
has 2 414 682 040 997 elements and is refused.  Nothing else in the library needs the
full lattice: every operation works on focal elements only.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Union, overload

import numpy as np

from belief.errors import LatticeTooLargeError
from belief.frame import Element, Frame, reduce_terms, term_key
from belief.model import Model

__all__ = ["HyperPowerSet", "hyper_power_set", "allowed_regions", "MAX_REGIONS", "MAX_ELEMENTS"]

#: Regions are bits of one unsigned 64-bit word.
MAX_REGIONS = 64
#: Enumeration stops with :class:`LatticeTooLargeError` beyond this many elements.
MAX_ELEMENTS = 20_000_000
#: :meth:`HyperPowerSet.hasse_diagram` refuses lattices larger than this.
MAX_GRAPH_NODES = 100_000

_FREE_SIZES = {1: 2, 2: 5, 3: 19, 4: 167, 5: 7580, 6: 7828353, 7: 2414682040997, 8: 56130437228687557907787}


def allowed_regions(model: Model, limit: int = MAX_REGIONS) -> list[int]:
    """The regions (hypothesis sets, as bit masks) that the model allows.

    Raises :class:`LatticeTooLargeError` when there are more than ``limit``.

    >>> from belief import Frame, Model
    >>> allowed_regions(Model.tracking(Frame(["t1", "t2", "FA"])))
    [1, 2, 3, 4]
    >>> allowed_regions(Model.free(Frame(["a", "b"])))
    [1, 2, 3]
    """
    n = len(model.frame)
    found: list[int] = []

    def visit(region: int, start: int) -> None:
        # Depth-first over sets in increasing bit order; a forbidden set prunes its supersets.
        for i in range(start, n):
            bigger = region | (1 << i)
            if model.is_forbidden(bigger):
                continue
            found.append(bigger)
            if len(found) > limit:
                raise _TooMany
            visit(bigger, i + 1)

    try:
        visit(0, 0)
    except _TooMany:
        raise LatticeTooLargeError(_too_large_message(model, limit)) from None
    return sorted(found)


class _TooMany(Exception):
    pass


def _too_large_message(model: Model, limit: int) -> str:
    n = len(model.frame)
    size = _FREE_SIZES.get(n)
    hint = (
        f" (on the free model |D^Θ| = {size:,} for n = {n})" if size and n >= 7 else ""
    )
    return (
        f"D^Θ of {n} hypotheses under the {model.kind} model has more than {limit} Venn regions, so it "
        f"cannot be enumerated{hint}: the number of elements grows like the Dedekind numbers. "
        "Work with focal elements instead (every rule and measure needs only those), "
        "or add constraints to the model"
    )


def hyper_power_set(model_or_frame: Union[Model, Frame, int]) -> "HyperPowerSet":
    """Enumerate D^Θ under a model, ∅ included.

    Parameters
    ----------
    model_or_frame : Model, Frame or int
        A frame (or a number n, for the frame ``t1..tn``) means the free model.

    Returns
    -------
    HyperPowerSet
        A lazy sequence of :class:`~belief.frame.Element` backed by an ``(K,)`` uint64
        array of region masks, ordered by DSm cardinality.

    Raises
    ------
    LatticeTooLargeError
        If the model allows more than 64 regions (for instance the free model with
        n ≥ 7), or the lattice has more than ``MAX_ELEMENTS`` elements.

    Examples
    --------
    >>> [len(hyper_power_set(n)) for n in range(1, 6)]
    [2, 5, 19, 167, 7580]
    >>> [str(e) for e in hyper_power_set(2)]
    ['empty', 't1&t2', 't1', 't2', 't1|t2']
    >>> from belief import Frame, Model
    >>> len(hyper_power_set(Model.shafer(Frame.numbered(4))))
    16
    """
    if isinstance(model_or_frame, bool):
        raise TypeError("expected a Model, a Frame or a number of hypotheses")
    if isinstance(model_or_frame, int):
        model = Model.free(Frame.numbered(model_or_frame))
    elif isinstance(model_or_frame, Frame):
        model = Model.free(model_or_frame)
    elif isinstance(model_or_frame, Model):
        model = model_or_frame
    else:
        raise TypeError("expected a Model, a Frame or a number of hypotheses")
    regions = allowed_regions(model)
    if not model.forbidden and len(model.frame) >= 3:
        masks = _free_upsets(len(model.frame))
    else:
        masks = _enumerate_upsets(regions, model)
    counts = np.bitwise_count(masks)
    order = np.argsort(counts, kind="stable")
    return HyperPowerSet(model, regions, masks[order])


def _monotone_functions(k: int) -> np.ndarray:
    """Truth tables (bit S = value on the set S) of all monotone Boolean functions of k variables.

    A function of k variables is a pair (f0, f1) of functions of k - 1 variables, its
    values without and with the last variable, with f0 ≤ f1 for monotonicity.
    """
    tables = np.array([0, 1], dtype=np.uint64)  # constant false, constant true
    for j in range(k):
        low, high = _ordered_pairs(tables)
        tables = low | (high << np.uint64(1 << j))
    return tables


def _ordered_pairs(tables: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All pairs (a, b) of truth tables with a ≤ b pointwise."""
    b_index, a_index = np.nonzero((tables[None, :] & ~tables[:, None]) == 0)
    return tables[a_index], tables[b_index]


def _free_upsets(n: int) -> np.ndarray:
    """D^Θ of the free model of n ≥ 3 hypotheses as region masks (region S has bit S - 1).

    An up-set of non-empty regions splits into the regions without θ_n, an up-set A
    that does not hold the empty set, and those with θ_n, an up-set B of subsets of the
    other hypotheses, with A ⊆ B.  Splitting A and B once more on θ_{n-1} gives four
    monotone functions of n - 2 variables with a0 ≤ a1 ≤ b1 and a0 ≤ b0 ≤ b1: for each
    pair a0 ≤ b1, a1 and b0 range freely over the interval [a0, b1].  Each such pair
    fills one block of the output with a single outer OR, and the bits of the four parts
    do not overlap.
    """
    tables = _monotone_functions(n - 2)
    h = 1 << (n - 2)
    below = (tables[:, None] & ~tables[None, :]) == 0  # below[x, y]: x ≤ y
    a0_index, b1_index = np.nonzero(below & ((tables & np.uint64(1)) == 0)[:, None])
    inside = below[a0_index, :] & below[:, b1_index].T
    sizes = inside.sum(axis=1)
    total = int((sizes * sizes).sum())
    a1_part = tables << np.uint64(h - 1)
    b0_part = tables << np.uint64(2 * h - 1)
    fixed = (tables[a0_index] >> np.uint64(1)) | (tables[b1_index] << np.uint64(3 * h - 1))
    out = np.empty(total, dtype=np.uint64)
    position = 0
    for row, size, base in zip(inside, sizes.tolist(), fixed):
        members = np.flatnonzero(row)
        block = out[position:position + size * size].reshape(size, size)
        np.bitwise_or.outer(a1_part[members] | base, b0_part[members], out=block)
        position += size * size
    return out


def _covers(regions: Sequence[int]) -> list[int]:
    """For each region, the bit mask (over region indices) of its allowed one-larger supersets."""
    position = {r: i for i, r in enumerate(regions)}
    needs = []
    for r in regions:
        need = 0
        for i, s in enumerate(regions):
            if s & r == r and (s ^ r).bit_count() == 1:
                need |= 1 << i
        needs.append(need)
    del position
    return needs


def _enumerate_upsets(regions: Sequence[int], model: Model) -> np.ndarray:
    needs = _covers(regions)
    masks = np.zeros(1, dtype=np.uint64)
    # Largest regions first, so that every superset of a region is decided before it.
    for index in sorted(range(len(regions)), key=lambda i: -regions[i].bit_count()):
        need = np.uint64(needs[index])
        bit = np.uint64(1 << index)
        if needs[index]:
            chosen = masks[(masks & need) == need]
        else:
            chosen = masks
        total = masks.size + chosen.size
        if total > MAX_ELEMENTS:
            raise LatticeTooLargeError(
                f"D^Θ under the {model.kind} model of {len(model.frame)} hypotheses has more than "
                f"{MAX_ELEMENTS:,} elements, too many to enumerate; work with focal elements instead"
            )
        grown = np.empty(total, dtype=np.uint64)
        grown[: masks.size] = masks
        np.bitwise_or(chosen, bit, out=grown[masks.size:])
        del chosen
        masks = grown
    return masks


class HyperPowerSet(Sequence):
    """D^Θ under a model, as a sequence of elements backed by region masks.

    Attributes
    ----------
    model : Model
    regions : tuple of int
        The allowed regions (hypothesis sets as bit masks); bit ``k`` of a mask is
        ``regions[k]``.
    masks : numpy.ndarray, shape (K,), uint64
        One region mask per element, ordered by DSm cardinality (stable).

    Examples
    --------
    >>> h = hyper_power_set(3)
    >>> len(h), h[0], h[-1]
    (19, Element('empty'), Element('t1|t2|t3'))
    >>> h.index(h.frame.element("t1&t2&t3"))
    1
    """

    def __init__(self, model: Model, regions: Sequence[int], masks: np.ndarray) -> None:
        self.model = model
        self.regions = tuple(regions)
        self.masks = masks
        self._lookup: dict[int, int] | None = None
        self._region_index = {r: i for i, r in enumerate(self.regions)}

    @property
    def frame(self) -> Frame:
        return self.model.frame

    def __len__(self) -> int:
        return int(self.masks.size)

    @overload
    def __getitem__(self, index: int) -> Element: ...
    @overload
    def __getitem__(self, index: slice) -> list[Element]: ...

    def __getitem__(self, index):
        if isinstance(index, slice):
            return [self.element_of(int(m)) for m in self.masks[index]]
        return self.element_of(int(self.masks[index]))

    def __iter__(self) -> Iterator[Element]:
        frame, regions = self.frame, self.regions
        for start in range(0, len(self), 65536):
            for minimal in self._minimal_masks(self.masks[start:start + 65536]).tolist():
                yield Element._make(frame, reduce_terms(r for i, r in enumerate(regions) if minimal >> i & 1))

    def __contains__(self, element: object) -> bool:
        if not isinstance(element, Element) or element.frame != self.frame:
            return False
        return self.model.reduce(element) == element

    def element_of(self, mask: int) -> Element:
        """The element whose region mask is ``mask`` (its minimal regions are its terms)."""
        minimal = int(self._minimal_masks(np.array([mask], dtype=np.uint64))[0])
        return Element._make(self.frame, reduce_terms(r for i, r in enumerate(self.regions) if minimal >> i & 1))

    def _minimal_masks(self, masks: np.ndarray) -> np.ndarray:
        """For each up-set, the mask of its minimal regions (those with no allowed one-smaller region in it)."""
        minimal = masks.copy()
        for k, below in enumerate(self._below):
            if below:
                bit, below_u = np.uint64(1 << k), np.uint64(below)
                minimal[(masks & below_u) != 0] &= ~bit
        return minimal

    @property
    def _below(self) -> list[int]:
        """For each region, the mask of its allowed one-smaller regions."""
        cached = getattr(self, "_below_cache", None)
        if cached is None:
            index = self._region_index
            cached = []
            for r in self.regions:
                below = 0
                for i in range(len(self.frame)):
                    smaller = r & ~(1 << i)
                    if smaller != r and smaller in index:
                        below |= 1 << index[smaller]
                cached.append(below)
            self._below_cache = cached
        return cached

    def strings(self, style: str = "ascii", chunk: int = 65536) -> Iterator[str]:
        """The canonical text of every element, in order; much faster than formatting elements one by one."""
        names = [self.frame.term_name(r, style) for r in self.regions]
        keys = [term_key(r) for r in self.regions]
        joiner = "|" if style == "ascii" else " ∪ "
        empty = "empty" if style == "ascii" else "∅"
        for start in range(0, len(self), chunk):
            for minimal in self._minimal_masks(self.masks[start:start + chunk]).tolist():
                if not minimal:
                    yield empty
                    continue
                picked = []
                while minimal:
                    low = minimal & -minimal
                    picked.append(low.bit_length() - 1)
                    minimal ^= low
                if len(picked) > 1:
                    picked.sort(key=keys.__getitem__)
                yield joiner.join(names[k] for k in picked)

    def mask_of(self, element: Union[Element, str]) -> int:
        """The region mask of an element (reduced under the model first)."""
        element = self.model.reduce(element)
        mask = 0
        for r, i in self._region_index.items():
            if any(t & ~r == 0 for t in element.terms):
                mask |= 1 << i
        return mask

    def index(self, element: Union[Element, str], start: int = 0, stop: int | None = None) -> int:
        """Position of an element in this sequence."""
        if self._lookup is None:
            self._lookup = {m: i for i, m in enumerate(self.masks.tolist())}
        position = self._lookup[self.mask_of(element)]
        if position < start or (stop is not None and position >= stop):
            raise ValueError(f"{element} is not in the given range")
        return position

    @property
    def cardinalities(self) -> np.ndarray:
        """DSm cardinality of every element, shape (K,)."""
        return np.bitwise_count(self.masks).astype(np.int64)

    def hasse_diagram(self):
        """The Hasse diagram of the lattice as a :class:`networkx.DiGraph`.

        Nodes are the elements (with ``label`` and ``cardinality`` attributes); an edge
        x → y means y covers x.  In a lattice of up-sets, y covers x exactly when y adds
        one region to x.

        >>> g = hyper_power_set(2).hasse_diagram()
        >>> g.number_of_nodes(), g.number_of_edges()
        (5, 5)
        """
        import networkx as nx

        if len(self) > MAX_GRAPH_NODES:
            raise LatticeTooLargeError(
                f"the Hasse diagram of {len(self):,} elements is too large for a graph "
                f"(limit {MAX_GRAPH_NODES:,}); use the mask array instead"
            )
        masks = self.masks
        order = np.argsort(masks)
        sorted_masks = masks[order]
        needs = _covers(self.regions)
        graph = nx.DiGraph()
        elements = list(self)
        for element, mask, card in zip(elements, masks.tolist(), self.cardinalities.tolist()):
            graph.add_node(element, label=element.format("unicode"), cardinality=card, mask=mask)
        for k, need in enumerate(needs):
            bit = np.uint64(1 << k)
            need_u = np.uint64(need)
            ok = ((masks & bit) == 0) & ((masks & need_u) == need_u)
            sources = np.nonzero(ok)[0]
            targets = np.searchsorted(sorted_masks, masks[sources] | bit)
            for s, t in zip(sources.tolist(), order[targets].tolist()):
                graph.add_edge(elements[s], elements[t])
        return graph

    def __repr__(self) -> str:
        return f"<HyperPowerSet of {len(self)} elements, {self.model!r}>"
