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

import json
from collections.abc import Iterator, Sequence
from typing import Any, Union, overload

import numpy as np

from belief.errors import LatticeTooLargeError
from belief.frame import Element, Frame, reduce_terms, term_key
from belief.model import Model

__all__ = ["HyperPowerSet", "hyper_power_set", "allowed_regions", "check_lattice_size", "MAX_REGIONS",
           "MAX_ELEMENTS"]

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
        raise LatticeTooLargeError(_too_large_message(n, model.kind, limit)) from None
    return sorted(found)


def check_lattice_size(n: int, model_data: Any = None) -> None:
    """Refuse at once D^Θ of ``n`` hypotheses that cannot have at most :data:`MAX_REGIONS` regions.

    This needs neither the frame nor the model, which for a huge ``n`` would not fit in
    memory: ``model_data`` is the model as read from JSON (None for the free model).  Every
    hypothesis that the model does not declare empty is a region of its own, and a proposition
    of the model's ``"empty"`` list can declare at most one hypothesis empty per union operand.

    >>> check_lattice_size(6)
    >>> check_lattice_size(100, {"type": "shafer", "empty": ["t1|t2"]})  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    belief.errors.LatticeTooLargeError: D^Θ of 100 hypotheses under the shafer model has more than 64 Venn regions, ...
    """
    kind = "free"
    removable = 0
    if model_data is not None:
        kind = "hybrid"
        if isinstance(model_data, dict):
            if isinstance(model_data.get("type"), str):
                kind = model_data["type"]
            empty = model_data.get("empty", [])
            if isinstance(empty, list):
                removable = sum(e.count("|") + e.count("∪") + 1 for e in empty if isinstance(e, str))
    if model_data is None:
        # Free model: 2^n - 1 regions.
        regions_at_least = (1 << n) - 1 if n <= MAX_REGIONS else MAX_REGIONS + 1
    else:
        regions_at_least = n - removable
    if regions_at_least > MAX_REGIONS:
        raise LatticeTooLargeError(_too_large_message(n, kind, MAX_REGIONS))


class _TooMany(Exception):
    pass


def _too_large_message(n: int, kind: str, limit: int) -> str:
    size = _FREE_SIZES.get(n)
    hint = (
        f" (on the free model |D^Θ| = {size:,} for n = {n})" if size and n >= 7 else ""
    )
    return (
        f"D^Θ of {n:,} hypotheses under the {kind} model has more than {limit} Venn regions, so it "
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
        if model_or_frame >= 1:
            check_lattice_size(model_or_frame)
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


def _bit_positions(mask: int) -> Iterator[int]:
    while mask:
        low = mask & -mask
        yield low.bit_length() - 1
        mask ^= low


def _byte_tables(images: Sequence[int]) -> list[np.ndarray]:
    """Tables of a map f, OR-linear over the bits of a mask (f(m) = OR of images[k] for the bits k of m), by byte."""
    tables = []
    for low in range(0, len(images), 8):
        table = np.zeros(256, dtype=np.uint64)
        for value in range(1, 256):
            bit = value & -value
            i = low + bit.bit_length() - 1
            table[value] = (table[value ^ bit] | np.uint64(images[i])) if i < len(images) else table[value ^ bit]
        tables.append(table)
    return tables


def _lookup(tables: list[np.ndarray], masks: np.ndarray) -> np.ndarray:
    """The OR-linear map of :func:`_byte_tables` applied to every mask."""
    out = np.zeros_like(masks)
    byte = np.uint64(0xFF)
    for j, table in enumerate(tables):
        out |= table[(masks >> np.uint64(8 * j)) & byte]
    return out


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

    def strings(self, style: str = "ascii", chunk: int = 65536, *, json_escaped: bool = False) -> Iterator[str]:
        """The canonical text of every element, in order; much faster than formatting elements one by one.

        With ``json_escaped`` the hypothesis names are written as inside a JSON string (quotes
        and backslashes escaped).
        """
        for block in self.string_blocks(style, chunk, json_escaped=json_escaped):
            yield from block

    def string_blocks(self, style: str = "ascii", chunk: int = 65536, *,
                      json_escaped: bool = False) -> Iterator[list[str]]:
        """:meth:`strings` in lists of ``chunk`` texts (the last may be shorter), for writing out in bulk.

        Each element's minimal regions are found, and renumbered in printing order, with
        lookup tables on each byte of the region masks (numpy, a chunk at a time); its text
        is then put together from four tables, each holding the text of every combination of
        sixteen consecutive regions in printing order.
        """
        for texts, parts, cut, empty, _ in self._printed_parts(style, chunk, json_escaped):
            yield self._joined_list(texts, parts, cut, empty)

    def text_blocks(self, separator: str = "\n", style: str = "ascii", chunk: int = 65536, *,
                    json_escaped: bool = False) -> Iterator[str]:
        """:meth:`string_blocks` with each block's texts joined by ``separator``, as one string.

        Faster than joining the lists, for listing millions of elements: the pieces of all
        the texts are gathered from the tables by numpy and joined once, so that no string
        is made per element.
        """
        tables = None
        for texts, parts, cut, empty, has_empty in self._printed_parts(style, chunk, json_escaped, lists=False):
            if has_empty:
                yield separator.join(self._joined_list(texts, [p.tolist() for p in parts], cut, empty))
                continue
            if tables is None:
                # Each table twice: as it is, and with the union sign before its first term
                # removed, for the first non-empty piece of a text.
                tables = [np.array(table + [text[cut:] for text in table], dtype=object) for table in texts]
            first = np.argmax(np.column_stack(parts) != 0, axis=1)
            # The pieces of every text and a separator after each, gathered by numpy and
            # joined once: no string is made per element.
            pieces = np.empty((len(parts[0]), len(parts) + 1), dtype=object)
            for j, (table, indices) in enumerate(zip(tables, parts)):
                pieces[:, j] = table[indices + (first == j) * (len(table) // 2)]
            pieces[:, -1] = separator
            block = "".join(pieces.ravel().tolist())
            yield block[:len(block) - len(separator)]

    @staticmethod
    def _joined_list(texts: list, parts: list, cut: int, empty: str) -> list[str]:
        if len(parts) == 1:
            (t0,), (p0,) = texts, parts
            return [t0[a][cut:] or empty for a in p0]
        if len(parts) == 2:
            t0, t1 = texts
            return [(t0[a] + t1[b])[cut:] or empty for a, b in zip(*parts)]
        if len(parts) == 3:
            t0, t1, t2 = texts
            return [(t0[a] + t1[b] + t2[c])[cut:] or empty for a, b, c in zip(*parts)]
        t0, t1, t2, t3 = texts
        return [(t0[a] + t1[b] + t2[c] + t3[d])[cut:] or empty for a, b, c, d in zip(*parts)]

    def _printed_parts(self, style: str, chunk: int, json_escaped: bool, lists: bool = True):
        """Per chunk: the text tables, each element's index into each, the union sign's length, ∅'s text, ∅ in it.

        Every non-empty text in the tables begins with the union sign (``cut`` characters);
        there are at most four tables, as there are at most 64 regions.
        """
        if style not in ("ascii", "unicode"):
            raise ValueError(f"style must be 'ascii' or 'unicode', got {style!r}")
        regions = self.regions
        names = [self.frame.term_name(r, style) for r in regions]
        if json_escaped:
            names = [json.dumps(name, ensure_ascii=False)[1:-1] for name in names]
        joiner = "|" if style == "ascii" else " ∪ "
        empty = "empty" if style == "ascii" else "∅"
        order = sorted(range(len(regions)), key=lambda k: term_key(regions[k]))
        rank = [0] * len(regions)
        for position, k in enumerate(order):
            rank[k] = position
        above = [0] * len(regions)          # for each region, its allowed one-larger regions
        for k, below in enumerate(self._below):
            for j in _bit_positions(below):
                above[j] |= 1 << k
        cover_tables = _byte_tables(above)
        rank_tables = _byte_tables([1 << r for r in rank])
        texts = []
        for low in range(0, max(len(regions), 1), 16):
            size = 1 << min(16, len(regions) - low)
            table = [""] * size
            for value in range(1, size):
                bit = value & -value
                table[value] = joiner + names[order[low + bit.bit_length() - 1]] + table[value ^ bit]
            texts.append(table)
        cut = len(joiner)
        mask16 = np.uint64(0xFFFF)
        for start in range(0, len(self), chunk):
            masks = self.masks[start:start + chunk]
            minimal = masks & ~_lookup(cover_tables, masks)
            printed = _lookup(rank_tables, minimal)
            parts = [((printed >> np.uint64(16 * j)) & mask16).astype(np.intp) for j in range(len(texts))]
            yield texts, [p.tolist() for p in parts] if lists else parts, cut, empty, bool((printed == 0).any())

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
