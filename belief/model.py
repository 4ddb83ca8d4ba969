"""Constraint models: free DSm, Shafer, hybrid and the tracking model (SPEC A.2, Part D).

A model says which Venn regions may be non-empty.  Here a model is given by the
antichain of its *forbidden conjunctions*: a region (a set S of hypotheses, "inside
exactly the θ_i with i in S") is empty under the model iff S contains one of them.
Declaring any element empty forbids its minimal conjunctions, so every hybrid model has
this form.  Under a model an element keeps only its non-forbidden conjunctions; the
result is again canonical (the minimal conjunctions of the surviving regions), so
equality, ∩, ∪ and ⊆ stay cheap bit operations.
"""

from __future__ import annotations

import reprlib
from collections.abc import Iterable, Mapping
from functools import lru_cache
from typing import Any, Union

from belief.errors import FormatError, LatticeTooLargeError, ModelError
from belief.frame import Element, Frame, _listing, reduce_terms

__all__ = ["Model", "MAX_LISTED_CONSTRAINTS"]

_KINDS = ("free", "shafer", "hybrid", "tracking")

#: Shafer's model forbids every pair of hypotheses without listing them; a model that must list
#: them (Shafer's model with extra empty propositions, or :attr:`Model.forbidden` read on a large
#: frame) is refused beyond this many pairs, which would take gigabytes and minutes.
MAX_LISTED_CONSTRAINTS = 500_000

# Messages quote user data cut short (and shallow), so that they stay one line.
_show = reprlib.Repr()
_show.maxlevel = 2
_show.maxstring = 60
_show.maxother = 60


class Model:
    """A constraint model over a frame.

    Use the constructors :meth:`free`, :meth:`shafer`, :meth:`hybrid` and :meth:`tracking`.
    Two models are equal when they forbid the same regions, whatever constructor built them.

    Attributes
    ----------
    frame : Frame
    kind : str
        ``"free"``, ``"shafer"``, ``"hybrid"`` or ``"tracking"``.
    forbidden : tuple of int
        The minimal forbidden conjunctions (hypothesis bit masks).

    Examples
    --------
    >>> from belief import Frame
    >>> f = Frame(["a", "b", "c"])
    >>> m = Model.hybrid(f, empty=["a&b"])
    >>> m.reduce(f.element("a&b | c"))
    Element('c')
    >>> m.is_empty(f.element("a&b&c")), Model.free(f).is_empty(f.element("a&b&c"))
    (True, False)
    >>> Model.shafer(f).cardinality(f.total), Model.free(f).cardinality(f.total)
    (3, 7)
    """

    __slots__ = ("frame", "kind", "_forbidden", "false_alarm", "_hash", "_unions")

    def __init__(self, frame: Frame, forbidden: Iterable[int] = (), *, kind: str = "hybrid",
                 false_alarm: str | None = None) -> None:
        if not isinstance(frame, Frame):
            raise TypeError("Model needs a Frame")
        if kind not in _KINDS:
            raise ModelError(f"unknown model type {kind!r}; known types: {', '.join(_KINDS)}")
        self.frame = frame
        self.kind = kind
        self.false_alarm = false_alarm
        self._unions = None             # what MassFunction needs to read unions of hypotheses (filled there)
        if kind == "shafer":
            # Every pair of hypotheses is forbidden: n(n-1)/2 conjunctions, listed only when asked for.
            self._forbidden = None
            self._hash = _SHAFER_HASH ^ frame._hash
            return
        full = (1 << len(frame)) - 1
        terms = list(forbidden)
        for term in terms:
            if isinstance(term, bool) or not isinstance(term, int) or term <= 0 or term & ~full:
                raise ModelError(f"{_show.repr(term)} is not a conjunction mask of this frame")
        self._forbidden = reduce_terms(terms)
        if _all_pairs(self._forbidden, len(frame)):
            self._hash = _SHAFER_HASH ^ frame._hash     # equal to Shafer's model, so hashed alike
        else:
            self._hash = hash(("belief.Model", frame, self._forbidden))

    @property
    def forbidden(self) -> tuple[int, ...]:
        """The minimal forbidden conjunctions (hypothesis bit masks), in canonical order.

        Shafer's model lists its n(n-1)/2 pairs on first use; more than
        :data:`MAX_LISTED_CONSTRAINTS` raise :class:`~belief.errors.LatticeTooLargeError`.
        """
        listed = self._forbidden
        if listed is None:
            n = len(self.frame)
            _check_listing(n * (n - 1) // 2, n, "Shafer's model")
            listed = tuple((1 << i) | (1 << j) for i in range(n) for j in range(i + 1, n))
            self._forbidden = listed
        return listed

    @property
    def constrained(self) -> bool:
        """True if the model forbids some region (it is not the free model)."""
        if self._forbidden is None:
            return len(self.frame) > 1
        return bool(self._forbidden)

    # -- constructors ------------------------------------------------------------------
    @classmethod
    def free(cls, frame: Frame) -> "Model":
        """The free DSm model: no intersection is empty."""
        return cls(frame, (), kind="free")

    @classmethod
    def shafer(cls, frame: Frame) -> "Model":
        """Shafer's model: the hypotheses are exclusive, so D^Θ becomes the power set 2^Θ."""
        return cls(frame, kind="shafer")

    @classmethod
    def hybrid(cls, frame: Frame, empty: Iterable[Union[str, Element]] = ()) -> "Model":
        """A hybrid model in which each listed proposition is constrained to be empty.

        ``empty=["a&b"]`` is an exclusivity constraint; ``empty=["c"]`` says that θ_c
        does not exist; ``empty=["a&b|c"]`` says both.
        """
        return cls(frame, _empty_terms(frame, empty), kind="hybrid")

    def _checked(self, empty: Iterable[Union[str, Element]]) -> "Model":
        """The model itself, unless it declares every hypothesis empty (then every element is ∅).

        Only models read from a file are refused so: :meth:`hybrid` keeps building the
        degenerate model, which property-based tests generate on purpose.
        """
        singles = 0
        for term in self._forbidden or ():
            if not term & (term - 1):
                singles |= term
        if singles == (1 << len(self.frame)) - 1:
            listed = [str(e) for e in empty] if not isinstance(empty, (str, Element)) else [str(empty)]
            raise ModelError(
                f"the model declares every hypothesis empty ({_listing(self.frame.hypotheses)}) through "
                f"{_show.repr(listed)}, so every element is empty under it and no mass can be placed; "
                "leave at least one hypothesis possible"
            )
        return self

    @classmethod
    def tracking(cls, frame: Frame, false_alarm: str = "FA") -> "Model":
        """The tracking model M_τ of SPEC Part D (W (15)).

        Targets may overlap (occlusion), and the false-alarm hypothesis excludes every
        target: θ_j ∩ θ_FA ≡ ∅.  With τ targets there are 2^τ regions and
        2·|D^{Θ_τ}| elements.

        >>> from belief import Frame
        >>> m = Model.tracking(Frame(["t1", "t2", "FA"]))
        >>> m.is_empty(m.frame.element("t1&t2")), m.is_empty(m.frame.element("t1&FA"))
        (False, True)
        """
        fa = frame.index(false_alarm)
        if len(frame) < 2:
            raise ModelError("the tracking model needs at least one target besides the false alarm")
        terms = [(1 << fa) | (1 << j) for j in range(len(frame)) if j != fa]
        return cls(frame, terms, kind="tracking", false_alarm=false_alarm)

    @classmethod
    def for_targets(cls, n_targets: int, false_alarm: str = "FA", prefix: str = "t") -> "Model":
        """Tracking model on the frame ``t1 .. tτ, FA``.

        >>> Model.for_targets(2).frame.hypotheses
        ('t1', 't2', 'FA')
        """
        if isinstance(n_targets, bool) or not isinstance(n_targets, int) or n_targets < 1:
            raise ModelError(f"the number of targets must be a positive integer, got {n_targets!r}")
        frame = Frame([f"{prefix}{i}" for i in range(1, n_targets + 1)] + [false_alarm])
        return cls.tracking(frame, false_alarm)

    # -- identity ---------------------------------------------------------------------------
    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Model):
            return NotImplemented
        if self is other:
            return True
        if self.frame != other.frame:
            return False
        mine, theirs = self._forbidden, other._forbidden
        if mine is None or theirs is None:
            # Shafer's model against another: compared without listing its pairs.
            if mine is None and theirs is None:
                return True
            return _all_pairs(theirs if mine is None else mine, len(self.frame))
        return mine == theirs

    def __hash__(self) -> int:
        return self._hash

    def __reduce__(self):
        # Rebuild on unpickling: the cached hash depends on the interpreter run.
        return (_restore_model, (self.frame, self._forbidden or (), self.kind, self.false_alarm))

    def __repr__(self) -> str:
        if self.kind in ("free", "shafer"):
            return f"Model.{self.kind}({self.frame!r})"
        if self.kind == "tracking":
            return f"Model.tracking({self.frame!r}, false_alarm={self.false_alarm!r})"
        empty = [self.frame.term_name(t) for t in self.forbidden]
        return f"Model.hybrid({self.frame!r}, empty={empty!r})"

    # -- regions and elements ---------------------------------------------------------------
    def is_forbidden(self, term: int) -> bool:
        """True if the conjunction (equivalently the region) ``term`` is empty under the model."""
        if self.kind == "shafer":
            return term.bit_count() > 1
        return any(f & ~term == 0 for f in self._forbidden)

    def kept_terms(self, terms: tuple[int, ...]) -> tuple[int, ...]:
        """The conjunctions of a canonical antichain that the model allows (its form under the model).

        >>> from belief import Frame
        >>> Model.hybrid(Frame(["a", "b", "c"]), empty=["a&b"]).kept_terms((3, 4))
        (4,)
        """
        if self.kind == "shafer":
            return tuple(t for t in terms if not t & (t - 1))
        forbidden = self._forbidden
        if not forbidden:
            return terms
        return tuple(t for t in terms if not any(f & ~t == 0 for f in forbidden))

    def reduce(self, element: Union[Element, str]) -> Element:
        """The canonical form of an element under this model (forbidden conjunctions dropped)."""
        if not (isinstance(element, Element) and element.frame is self.frame):
            element = self.frame.element(element)
        if self.kind == "shafer":
            kept = tuple(t for t in element.terms if not t & (t - 1))
        elif not self._forbidden:
            return element
        else:
            kept = tuple(t for t in element.terms if not self.is_forbidden(t))
        if len(kept) == len(element.terms):
            return element
        return Element._make(self.frame, kept)

    def element(self, value: Union[Element, str]) -> Element:
        """Parse (if needed) and reduce a proposition under the model."""
        return self.reduce(value)

    def is_empty(self, element: Union[Element, str]) -> bool:
        """True if the element is ∅ under the model."""
        element = self.frame.element(element)
        return all(self.is_forbidden(t) for t in element.terms)

    def intersection(self, x: Union[Element, str], y: Union[Element, str]) -> Element:
        """x ∩ y under the model."""
        return self.reduce(self.frame.element(x) & self.frame.element(y))

    def union(self, x: Union[Element, str], y: Union[Element, str]) -> Element:
        """x ∪ y under the model."""
        return self.reduce(self.frame.element(x) | self.frame.element(y))

    def includes(self, x: Union[Element, str], y: Union[Element, str]) -> bool:
        """True if x ⊆ y under the model."""
        return self.reduce(x) <= self.reduce(y)

    @property
    def total(self) -> Element:
        """Total ignorance under the model (the union of the non-empty hypotheses)."""
        return self.reduce(self.frame.total)

    @property
    def empty(self) -> Element:
        return self.frame.empty

    def cardinality(self, element: Union[Element, str]) -> int:
        """DSm cardinality C_M(X): the number of Venn regions of X allowed by the model.

        Counted exactly (a Python integer) without listing regions, so it works on
        frames of any size.  Equals |X| on Shafer's model.

        >>> from belief import Frame
        >>> f = Frame(["a", "b", "c"])
        >>> Model.free(f).cardinality("a"), Model.free(f).cardinality("a&b|c")
        (4, 5)
        """
        element = self.reduce(element)
        if not element.terms:
            return 0
        if self.kind == "shafer":
            # The allowed regions are the single hypotheses, and a reduced element keeps only those.
            return len(element.terms)
        universe = (1 << len(self.frame)) - 1
        try:
            return _count_regions(element.terms, self._forbidden, universe)
        except RecursionError:
            raise LatticeTooLargeError(
                f"the DSm cardinality of {_show.repr(str(element))} under the {self.kind} model of "
                f"{len(self.frame):,} hypotheses is too intricate to count (too many nested case splits over "
                "hypotheses); use fewer hypotheses or more constraints"
            ) from None

    def is_refined_by(self, other: "Model") -> bool:
        """True if ``other`` is at least as strict (forbids every region this model forbids)."""
        if other.frame != self.frame:
            return False
        if other.kind == "shafer":
            # Every region of two or more hypotheses is forbidden: only single hypotheses matter.
            return all(other.is_forbidden(f) for f in self._forbidden or () if not f & (f - 1))
        return all(other.is_forbidden(f) for f in self.forbidden)

    # -- serialisation ----------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The JSON model object: ``{"type": ..., "empty": [...]}``.

        >>> from belief import Frame
        >>> Model.hybrid(Frame(["a", "b", "c"]), ["b&a"]).to_dict()
        {'type': 'hybrid', 'empty': ['a&b']}
        """
        if self.kind in ("free", "shafer"):
            return {"type": self.kind}
        if self.kind == "tracking":
            return {"type": "tracking", "false_alarm": self.false_alarm}
        return {"type": "hybrid", "empty": [self.frame.term_name(t) for t in self.forbidden]}

    @classmethod
    def from_dict(cls, frame: Frame, data: Any) -> "Model":
        """Inverse of :meth:`to_dict`; ``None`` (no model given) gives Shafer's model.

        An object without ``"type"`` is Shafer's model too, or a hybrid model when it lists
        ``"empty"`` propositions; the free DSm model is asked for by name, ``{"type": "free"}``.

        Every type accepts ``"empty"``: the listed propositions are constrained to be empty
        on top of the type's own constraints.  ``free`` with ``empty`` is a hybrid model,
        ``shafer`` with ``empty`` is Shafer's model in which those propositions are also
        empty (a hypothesis that turned out impossible, as in dynamic fusion), and
        ``"empty": []`` changes nothing.

        >>> from belief import Frame
        >>> frame = Frame(["a", "b", "c"])
        >>> Model.from_dict(frame, {"type": "shafer", "empty": []}) == Model.shafer(frame)
        True
        >>> model = Model.from_dict(frame, {"type": "shafer", "empty": ["c"]})
        >>> model.is_empty("c"), model.is_empty("a&b"), model.is_empty("a")
        (True, True, False)
        """
        if data is None:
            return cls.shafer(frame)
        if not isinstance(data, Mapping):
            raise FormatError(f"a model must be a JSON object with a \"type\", got {_show.repr(data)}")
        kind = data.get("type", "shafer" if "empty" not in data else "hybrid")
        if not isinstance(kind, str):
            raise FormatError(f"a model's \"type\" must be a string, one of {', '.join(_KINDS)}; "
                              f"got {_show.repr(kind)}")
        accepted = {"type", "empty"} | ({"false_alarm"} if kind == "tracking" else set())
        unknown = set(data) - accepted
        if unknown and kind in _KINDS:
            raise FormatError(
                f"key(s) {', '.join(sorted(k if k.isprintable() else repr(k) for k in map(str, unknown)))} "
                f"do not belong to a {kind} model"
            )
        empty = data.get("empty", [])
        if isinstance(empty, str) or not isinstance(empty, list) or not all(isinstance(e, str) for e in empty):
            raise FormatError("the \"empty\" of a model must be a list of proposition strings")
        if kind == "free":
            base = cls.free(frame)
        elif kind == "shafer":
            base = cls.shafer(frame)
        elif kind == "hybrid":
            return cls.hybrid(frame, empty)._checked(empty)
        elif kind == "tracking":
            fa = data.get("false_alarm", "FA")
            if not isinstance(fa, str):
                raise FormatError("\"false_alarm\" must be a hypothesis name")
            base = cls.tracking(frame, fa)
        else:
            raise FormatError(f"unknown model type {_show.repr(kind)}; known types: {', '.join(_KINDS)}")
        extra = reduce_terms(_empty_terms(frame, empty))
        if all(base.is_forbidden(term) for term in extra):
            return base
        if base.kind == "shafer":
            # Only the hypotheses declared empty add to Shafer's pairs; the pairs that hold one
            # of them are absorbed by it, and the others are listed in canonical order directly.
            gone = 0
            for term in extra:
                if not term & (term - 1):
                    gone |= term
            kept = [i for i in range(len(frame)) if not gone >> i & 1]
            _check_listing(len(kept) * (len(kept) - 1) // 2, len(frame), "Shafer's model with empty propositions")
            # Listed reduced and in canonical order at once: (i,) or the pairs (i, j), i ascending.
            listed: list[int] = []
            k = 0
            for i in range(len(frame)):
                if gone >> i & 1:
                    listed.append(1 << i)
                else:
                    k += 1
                    listed.extend((1 << i) | (1 << j) for j in kept[k:])
            model = cls(frame, kind="hybrid")
            model._forbidden = tuple(listed)
            model._hash = hash(("belief.Model", frame, model._forbidden))
            return model._checked(empty)
        return cls(frame, list(base.forbidden) + list(extra), kind="hybrid")._checked(empty)


def _restore_model(frame: Frame, forbidden: tuple[int, ...], kind: str, false_alarm: str | None) -> Model:
    return Model(frame, forbidden, kind=kind, false_alarm=false_alarm)


_SHAFER_HASH = hash("belief.Model.shafer")


def _all_pairs(forbidden: tuple[int, ...], n: int) -> bool:
    """Whether a reduced antichain is every pair of n hypotheses (Shafer's model)."""
    return len(forbidden) == n * (n - 1) // 2 and all(t.bit_count() == 2 for t in forbidden)


def _check_listing(count: int, n: int, what: str) -> None:
    if count > MAX_LISTED_CONSTRAINTS:
        raise LatticeTooLargeError(
            f"{what} on {n:,} hypotheses needs {count:,} forbidden conjunctions listed, more than "
            f"MAX_LISTED_CONSTRAINTS = {MAX_LISTED_CONSTRAINTS:,}; use fewer hypotheses"
        )


def _empty_terms(frame: Frame, empty: Iterable[Union[str, Element]]) -> list[int]:
    """The conjunctions of the propositions a model declares empty."""
    if isinstance(empty, (str, Element)):
        empty = [empty]
    terms: list[int] = []
    for proposition in empty:
        terms.extend(frame.element(proposition).terms)
    return terms


@lru_cache(maxsize=65536)
def _count_regions(terms: tuple[int, ...], forbidden: tuple[int, ...], universe: int) -> int:
    """Number of sets S ⊆ universe with some term ⊆ S and no forbidden conjunction ⊆ S.

    Shannon expansion on one hypothesis at a time, memoised; hypotheses that no term
    or constraint mentions contribute a factor of two each.
    """
    if not terms:
        return 0
    if any(f == 0 for f in forbidden):
        return 0
    if any(t == 0 for t in terms):
        # Every S qualifies on the term side: count the sets that avoid the constraints.
        if not forbidden:
            return 1 << universe.bit_count()
        return (1 << universe.bit_count()) - _count_regions(forbidden, (), universe)
    used = 0
    for t in terms:
        used |= t
    for f in forbidden:
        used |= f
    factor = (universe & ~used).bit_count()
    universe &= used
    if not forbidden and len(terms) == 1:
        return 1 << (universe.bit_count() - terms[0].bit_count() + factor)
    if not forbidden and len(terms) >= 8:
        # Every set meets a union of hypotheses, but the empty one.
        if all(not t & (t - 1) for t in terms):
            return ((1 << universe.bit_count()) - 1) << factor
        # The sets that hold no term are counted apart on each group of terms linked by
        # shared hypotheses, and multiplied: this keeps the case splits few and shallow.
        groups = _linked_groups(terms)
        if len(groups) > 1:
            avoiding = 1
            for mask, group in groups:
                avoiding *= (1 << mask.bit_count()) - _count_regions(reduce_terms(group), (), mask)
            return ((1 << universe.bit_count()) - avoiding) << factor
    # A single-hypothesis constraint excludes that hypothesis outright.
    for f in forbidden:
        if f.bit_count() == 1:
            rest = tuple(t for t in terms if not t & f)
            forb = tuple(g for g in forbidden if not g & f)
            return _count_regions(rest, forb, universe & ~f) << factor
    # Split on the hypothesis used most often.
    counts: dict[int, int] = {}
    for t in terms + forbidden:
        m = t
        while m:
            low = m & -m
            counts[low] = counts.get(low, 0) + 1
            m ^= low
    v = max(counts, key=lambda b: (counts[b], -b))
    rest_universe = universe & ~v
    with_v = _count_regions(
        _reduce_or_zero(t & ~v for t in terms),
        _reduce_or_zero(f & ~v for f in forbidden),
        rest_universe,
    )
    without_v = _count_regions(
        tuple(t for t in terms if not t & v),
        tuple(f for f in forbidden if not f & v),
        rest_universe,
    )
    return (with_v + without_v) << factor


def _linked_groups(terms: tuple[int, ...]) -> list[tuple[int, list[int]]]:
    """The terms in groups linked by shared hypotheses (union-find on hypothesis bits), with each group's hypotheses."""
    parent: dict[int, int] = {}

    def find(b: int) -> int:
        root = parent.setdefault(b, b)
        while root != b:
            parent[b] = parent[root]
            b, root = root, parent[root]
        return root

    for t in terms:
        low = t & -t
        root = find(low)
        m = t ^ low
        while m:
            b = m & -m
            m ^= b
            other = find(b)
            if other != root:
                parent[other] = root
    groups: dict[int, tuple[int, list[int]]] = {}
    for t in terms:
        root = find(t & -t)
        mask, group = groups.get(root, (0, []))
        group.append(t)
        groups[root] = (mask | t, group)
    return list(groups.values())


def _reduce_or_zero(terms: Iterable[int]) -> tuple[int, ...]:
    terms = list(terms)
    if any(t == 0 for t in terms):
        return (0,)
    return reduce_terms(terms)
