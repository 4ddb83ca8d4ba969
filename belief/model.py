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

from collections.abc import Iterable, Mapping
from functools import lru_cache
from typing import Any, Union

from belief.errors import FormatError, ModelError
from belief.frame import Element, Frame, reduce_terms

__all__ = ["Model"]

_KINDS = ("free", "shafer", "hybrid", "tracking")


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

    __slots__ = ("frame", "kind", "forbidden", "false_alarm", "_hash", "_unions")

    def __init__(self, frame: Frame, forbidden: Iterable[int] = (), *, kind: str = "hybrid",
                 false_alarm: str | None = None) -> None:
        if not isinstance(frame, Frame):
            raise TypeError("Model needs a Frame")
        if kind not in _KINDS:
            raise ModelError(f"unknown model type {kind!r}; known types: {', '.join(_KINDS)}")
        full = (1 << len(frame)) - 1
        terms = list(forbidden)
        for term in terms:
            if isinstance(term, bool) or not isinstance(term, int) or term <= 0 or term & ~full:
                raise ModelError(f"{term!r} is not a conjunction mask of this frame")
        self.frame = frame
        self.kind = kind
        self.forbidden = reduce_terms(terms)
        self.false_alarm = false_alarm
        self._hash = hash(("belief.Model", frame, self.forbidden))
        self._unions = None             # what MassFunction needs to read unions of hypotheses (filled there)

    # -- constructors ------------------------------------------------------------------
    @classmethod
    def free(cls, frame: Frame) -> "Model":
        """The free DSm model: no intersection is empty."""
        return cls(frame, (), kind="free")

    @classmethod
    def shafer(cls, frame: Frame) -> "Model":
        """Shafer's model: the hypotheses are exclusive, so D^Θ becomes the power set 2^Θ."""
        n = len(frame)
        pairs = [(1 << i) | (1 << j) for i in range(n) for j in range(i + 1, n)]
        return cls(frame, pairs, kind="shafer")

    @classmethod
    def hybrid(cls, frame: Frame, empty: Iterable[Union[str, Element]] = ()) -> "Model":
        """A hybrid model in which each listed proposition is constrained to be empty.

        ``empty=["a&b"]`` is an exclusivity constraint; ``empty=["c"]`` says that θ_c
        does not exist; ``empty=["a&b|c"]`` says both.
        """
        if isinstance(empty, (str, Element)):
            empty = [empty]
        terms: list[int] = []
        for proposition in empty:
            element = frame.element(proposition)
            if element.is_empty:
                continue
            terms.extend(element.terms)
        return cls(frame, terms, kind="hybrid")

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
        return self.forbidden == other.forbidden and self.frame == other.frame

    def __hash__(self) -> int:
        return self._hash

    def __reduce__(self):
        # Rebuild on unpickling: the cached hash depends on the interpreter run.
        return (_restore_model, (self.frame, self.forbidden, self.kind, self.false_alarm))

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
        return any(f & ~term == 0 for f in self.forbidden)

    def kept_terms(self, terms: tuple[int, ...]) -> tuple[int, ...]:
        """The conjunctions of a canonical antichain that the model allows (its form under the model).

        >>> from belief import Frame
        >>> Model.hybrid(Frame(["a", "b", "c"]), empty=["a&b"]).kept_terms((3, 4))
        (4,)
        """
        forbidden = self.forbidden
        if not forbidden:
            return terms
        if self.kind == "shafer":
            return tuple(t for t in terms if not t & (t - 1))
        return tuple(t for t in terms if not any(f & ~t == 0 for f in forbidden))

    def reduce(self, element: Union[Element, str]) -> Element:
        """The canonical form of an element under this model (forbidden conjunctions dropped)."""
        if not (isinstance(element, Element) and element.frame is self.frame):
            element = self.frame.element(element)
        if not self.forbidden:
            return element
        if self.kind == "shafer":
            kept = tuple(t for t in element.terms if not t & (t - 1))
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
        universe = (1 << len(self.frame)) - 1
        return _count_regions(element.terms, self.forbidden, universe)

    def is_refined_by(self, other: "Model") -> bool:
        """True if ``other`` is at least as strict (forbids every region this model forbids)."""
        if other.frame != self.frame:
            return False
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
        """Inverse of :meth:`to_dict`; ``None`` gives the free model.

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
            return cls.free(frame)
        if not isinstance(data, Mapping):
            raise FormatError(f"a model must be a JSON object with a \"type\", got {data!r}")
        kind = data.get("type", "free" if "empty" not in data else "hybrid")
        if not isinstance(kind, str):
            raise FormatError(f"a model's \"type\" must be a string, one of {', '.join(_KINDS)}; got {kind!r}")
        accepted = {"type", "empty"} | ({"false_alarm"} if kind == "tracking" else set())
        unknown = set(data) - accepted
        if unknown and kind in _KINDS:
            raise FormatError(
                f"key(s) {', '.join(sorted(map(str, unknown)))} do not belong to a {kind} model"
            )
        empty = data.get("empty", [])
        if isinstance(empty, str) or not isinstance(empty, list) or not all(isinstance(e, str) for e in empty):
            raise FormatError("the \"empty\" of a model must be a list of proposition strings")
        if kind == "free":
            base = cls.free(frame)
        elif kind == "shafer":
            base = cls.shafer(frame)
        elif kind == "hybrid":
            return cls.hybrid(frame, empty)
        elif kind == "tracking":
            fa = data.get("false_alarm", "FA")
            if not isinstance(fa, str):
                raise FormatError("\"false_alarm\" must be a hypothesis name")
            base = cls.tracking(frame, fa)
        else:
            raise FormatError(f"unknown model type {kind!r}; known types: {', '.join(_KINDS)}")
        extra = cls.hybrid(frame, empty)
        if all(base.is_forbidden(term) for term in extra.forbidden):
            return base
        return cls(frame, base.forbidden + extra.forbidden, kind="hybrid")


def _restore_model(frame: Frame, forbidden: tuple[int, ...], kind: str, false_alarm: str | None) -> Model:
    return Model(frame, forbidden, kind=kind, false_alarm=false_alarm)


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


def _reduce_or_zero(terms: Iterable[int]) -> tuple[int, ...]:
    terms = list(terms)
    if any(t == 0 for t in terms):
        return (0,)
    return reduce_terms(terms)
