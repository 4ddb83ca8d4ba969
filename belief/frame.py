"""Frames of discernment and the elements of their hyper-power set.

An element of the hyper-power set D^Θ (SPEC A.1) is stored in *reduced disjunctive
normal form*: the antichain of its minimal conjunctions.  A conjunction is an integer
bit mask over the hypotheses (bit ``i`` set means θ_i takes part in the intersection),
so an element built from a few conjunctions costs a few integers whatever the size of
the frame, and

* ∩ is the pairwise OR of conjunction masks, then reduction to the minimal ones;
* ∪ is the union of the two antichains, then reduction;
* X ⊆ Y holds iff every conjunction of X contains (as a bit set) some conjunction of Y.

The minimal conjunctions of an element are exactly its minimal Venn regions, so the form
is canonical: two elements are equal iff their antichains are equal.  Elements here are
read on the *free* DSm model; a :class:`~belief.model.Model` maps them to their
canonical form under constraints.
"""

from __future__ import annotations

import operator
import re
import unicodedata
import weakref
from collections.abc import Iterable, Iterator, Sequence
from functools import lru_cache
from typing import Union

from belief.errors import FrameError, ParseError, UnknownHypothesisError

__all__ = ["Frame", "Element", "reduce_terms", "term_key", "MAX_PROPOSITION_TERMS"]

#: A proposition whose normal form would have more conjunctions than this is refused by the parser:
#: the normal form of an intersection of unions grows as the product of their sizes.
MAX_PROPOSITION_TERMS = 100_000

_OPERATOR_CHARS = set("()&|∩∪∅,")
# str.isspace's characters and the operators (re's \s matches the same Unicode whitespace).
_RESERVED_CHARACTER = re.compile(r"[\s" + re.escape("".join(sorted(_OPERATOR_CHARS))) + "]")
#: The live frames by their names (see Frame.__new__).
_FRAMES: "weakref.WeakValueDictionary[tuple[str, ...], Frame]" = weakref.WeakValueDictionary()
_RESERVED_NAMES = {"empty", "∅"}


def term_key(term: int) -> tuple[int, ...]:
    """Sort key of a conjunction mask: the positions of its hypotheses, compared as words.

    This is the order in which an element prints its conjunctions (``a&b|c``).

    >>> sorted([0b110, 0b100, 0b011], key=term_key)
    [3, 6, 4]
    """
    return tuple(_bits(term))


@lru_cache(maxsize=1 << 16)
def _term_order(term: int) -> tuple[int, tuple[int, ...]]:
    """A conjunction's part of :attr:`Element.sort_key`: its size, then :func:`term_key`."""
    return term.bit_count(), tuple(_bits(term))


def reduce_terms(terms: Iterable[int]) -> tuple[int, ...]:
    """Reduce conjunction masks to their canonical antichain.

    A conjunction that contains another one (as a bit set) is absorbed by it,
    because θ_a ∩ θ_b ⊆ θ_a.  The survivors are returned in :func:`term_key` order.

    Parameters
    ----------
    terms : iterable of int
        Conjunction masks (bit ``i`` = hypothesis ``i``); each must be non-zero.

    Returns
    -------
    tuple of int
        The minimal masks, sorted.

    Examples
    --------
    >>> reduce_terms([0b011, 0b001, 0b110])
    (1, 6)
    >>> reduce_terms([0b100, 0b011, 0b111])
    (3, 4)
    """
    unique = sorted(set(terms), key=int.bit_count)
    if not unique:
        return ()
    smallest = unique[0].bit_count()
    if len(unique) > 64 and unique[-1].bit_count() != smallest:
        kept = _reduce_many(unique, smallest)
    else:
        kept = []
        for term in unique:
            # Terms of the smallest size cannot absorb one another.
            if term.bit_count() == smallest or not any(k & ~term == 0 for k in kept):
                kept.append(term)
    if len(kept) > 1:
        kept.sort(key=term_key)
    return tuple(kept)


def _reduce_many(unique: list[int], smallest: int) -> list[int]:
    """The absorption of :func:`reduce_terms` for many terms, sorted by size.

    A kept term can only absorb a term that holds its lowest hypothesis, so the kept terms
    are filed under that hypothesis and a term is compared with those filed under its own
    hypotheses only: a union of n hypotheses and their pairs costs about n, not n².
    """
    kept: list[int] = []
    filed: dict[int, list[int]] = {}
    for term in unique:
        if term.bit_count() != smallest:
            absorbed = False
            if term.bit_count() < len(filed):
                m = term
                while m and not absorbed:
                    low = m & -m
                    m ^= low
                    for k in filed.get(low, ()):
                        if k & ~term == 0:
                            absorbed = True
                            break
            else:
                for low, group in filed.items():
                    if low & term and any(k & ~term == 0 for k in group):
                        absorbed = True
                        break
            if absorbed:
                continue
        kept.append(term)
        low = term & -term
        group = filed.get(low)
        if group is None:
            filed[low] = [term]
        else:
            group.append(term)
    return kept


class Frame:
    """A frame of discernment: an ordered tuple of named hypotheses.

    Parameters
    ----------
    hypotheses : sequence of str
        Distinct names.  A name may not be empty, contain white space or any of
        ``( ) & | ∩ ∪ ∅ ,``, nor be the reserved word ``empty``.

    Examples
    --------
    >>> frame = Frame(["a", "b", "c"])
    >>> frame.element("c | b & a")
    Element('a&b|c')
    >>> frame["a"] & frame["b"]
    Element('a&b')
    >>> len(frame)
    3
    """

    __slots__ = ("_names", "_index", "_hash", "_bit", "_singletons", "_by_identity", "__weakref__")

    def __new__(cls, hypotheses: Sequence[str]) -> "Frame":
        # Frames of the same names are one object while any is alive: elements, mass functions and the
        # caches keyed by them then compare frames by identity instead of name by name (a comparison of
        # n names per element made a look-up of n elements cost n²).
        if cls is Frame and not isinstance(hypotheses, str):
            try:
                names = tuple(hypotheses)
                known = _FRAMES.get(names)
            except TypeError:                   # unhashable names: __init__ says what is wrong with them
                known = None
            if known is not None:
                return known
        return super().__new__(cls)

    def __init__(self, hypotheses: Sequence[str]) -> None:
        if getattr(self, "_names", None) is not None:
            return                              # the frame of these names, made before (see __new__)
        if isinstance(hypotheses, str):
            raise FrameError(
                f"a frame takes a sequence of hypothesis names, not the single string {hypotheses!r}; "
                "use Frame.parse('a,b,c') for a comma-separated list"
            )
        names = tuple(hypotheses)
        if not names:
            raise FrameError("a frame needs at least one hypothesis")
        if not _plain_names(names):
            _check_names(names)
        self._names = names
        positions = range(len(names))
        self._index = dict(zip(names, positions))
        self._bit = dict(zip(names, map((1).__lshift__, positions)))
        self._hash = hash(("belief.Frame", names))
        self._singletons = None
        self._by_identity = None
        if type(self) is Frame:
            _FRAMES[names] = self

    @classmethod
    def parse(cls, text: str) -> "Frame":
        """Build a frame from a comma-separated list of names.

        >>> Frame.parse("t1, t2, FA").hypotheses
        ('t1', 't2', 'FA')
        """
        return cls([part.strip() for part in text.split(",")])

    @classmethod
    def numbered(cls, n: int, prefix: str = "t") -> "Frame":
        """The frame ``t1 .. tn``.

        >>> Frame.numbered(3).hypotheses
        ('t1', 't2', 't3')
        """
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise FrameError(f"the number of hypotheses must be a positive integer, got {n!r}")
        return cls([f"{prefix}{i}" for i in range(1, n + 1)])

    # -- basic protocol -------------------------------------------------------------
    @property
    def hypotheses(self) -> tuple[str, ...]:
        """The hypothesis names, in frame order."""
        return self._names

    def __len__(self) -> int:
        return len(self._names)

    def __iter__(self) -> Iterator[str]:
        return iter(self._names)

    def __contains__(self, name: object) -> bool:
        return name in self._index

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Frame):
            return NotImplemented
        return self is other or self._names == other._names

    def __hash__(self) -> int:
        return self._hash

    def __reduce__(self):
        # Rebuild on unpickling: string hashes differ between interpreter runs.
        return (Frame, (list(self._names),))

    def __repr__(self) -> str:
        return f"Frame({list(self._names)!r})"

    def index(self, name: str) -> int:
        """Position of a hypothesis; raises :class:`UnknownHypothesisError`."""
        try:
            return self._index[name]
        except KeyError:
            raise UnknownHypothesisError(
                f"unknown hypothesis {name!r}; the frame has {_listing(self._names)}"
            ) from None

    def __getitem__(self, name: str) -> "Element":
        return _make(self, (1 << self.index(name),))

    # -- distinguished elements ----------------------------------------------------
    @property
    def empty(self) -> "Element":
        """The empty element ∅."""
        return _make(self, ())

    @property
    def total(self) -> "Element":
        """Total ignorance θ_1 ∪ … ∪ θ_n."""
        return _make(self, tuple(1 << i for i in range(len(self._names))))

    @property
    def singletons(self) -> tuple["Element", ...]:
        """The elements θ_1, …, θ_n."""
        singletons = self._singletons
        if singletons is None:
            # Made once per frame: over thousands of hypotheses, each mask is an integer of thousands of bits.
            singletons = self._singletons = tuple([_make(self, (bit,)) for bit in self._bit.values()])
        return singletons

    def singleton_of_bit(self, mask: int) -> "Element | None":
        """The singleton whose hypothesis bit is this very ``int`` object (``frame.bits[name]``), else None.

        A look-up by identity costs the same on every frame; one by value hashes an integer
        of n bits.  A mask equal to a hypothesis bit but made otherwise gives None.
        """
        table = self._by_identity
        if table is None:
            table = self._by_identity = {id(e.terms[0]): e for e in self.singletons}
        element = table.get(id(mask))
        return element if element is not None and element.terms[0] is mask else None

    @property
    def bits(self) -> tuple[int, ...]:
        """The bit mask of each hypothesis, in frame order (the objects a parsed name maps to)."""
        return tuple(self._bit.values())

    def conjunction(self, names: Iterable[str]) -> "Element":
        """The intersection of the named hypotheses.

        >>> Frame(["a", "b", "c"]).conjunction(["c", "a"])
        Element('a&c')
        """
        mask = 0
        for name in names:
            mask |= 1 << self.index(name)
        if mask == 0:
            raise FrameError("a conjunction needs at least one hypothesis")
        return _make(self, (mask,))

    def element(self, value: Union[str, "Element"]) -> "Element":
        """Coerce a proposition string (or an element of this frame) to an element.

        The grammar: hypothesis names, ``&`` or ``∩`` (intersection, binds tighter),
        ``|`` or ``∪`` (union), parentheses, and ``empty`` or ``∅``.
        """
        if isinstance(value, Element):
            if value.frame != self:
                raise FrameError(
                    f"element {value} belongs to the frame {list(value.frame.hypotheses)}, "
                    f"not {list(self._names)}"
                )
            return value
        if isinstance(value, str):
            terms = self.plain_terms(value)
            if terms is not None:
                return _make(self, terms)
            return _Parser(self, value).parse()
        raise TypeError(f"expected a proposition string or an Element, got {type(value).__name__}")

    def plain_terms(self, text: str) -> tuple[int, ...] | None:
        """The canonical conjunctions of a proposition written without parentheses, or None.

        A union of intersections of hypothesis names (``a|b&c``) is read by splitting
        the text, which costs far less than the general parser; anything else (parentheses,
        ``∩``, ``∪``, ``∅``, ``empty``, an unknown name or a malformed text) gives None, and
        :meth:`element` leaves it to the parser, which also names what is wrong.

        >>> Frame(["a", "b", "c"]).plain_terms("c | b&a")
        (3, 4)
        >>> Frame(["a", "b", "c"]).plain_terms("(a|b)&c") is None
        True
        """
        parsed = self._plain(text)
        return None if parsed is None else parsed[0]

    def _plain(self, text: str) -> tuple[tuple[int, ...], bool] | None:
        """:meth:`plain_terms`, and whether every conjunction is a single hypothesis."""
        if "(" in text or "∩" in text or "∪" in text or "∅" in text:
            return None
        bit = self._bit
        terms = []
        single = True
        for part in text.split("|"):
            if "&" in part:
                single = False
                mask = 0
                for name in part.split("&"):
                    b = bit.get(name)
                    if b is None:
                        b = bit.get(name.strip())
                        if b is None:
                            return None
                    mask |= b
                terms.append(mask)
            else:
                b = bit.get(part)
                if b is None:
                    b = bit.get(part.strip())
                    if b is None:
                        return None
                terms.append(b)
        if single:
            # Single hypotheses cannot absorb one another, and their masks sort in frame order.
            if len(terms) > 1:
                terms = sorted(set(terms))
            return tuple(terms), True
        return reduce_terms(terms), False

    def term_name(self, term: int, style: str = "ascii") -> str:
        """Name of one conjunction mask, e.g. ``a&b``."""
        if term.bit_count() == 1:               # one hypothesis: no walk over the bits of a wide mask
            return self._names[term.bit_length() - 1]
        sep = "&" if style == "ascii" else "∩"
        return sep.join(self._names[i] for i in _bits(term))

    def union_name(self, mask: int) -> str:
        """The text of the union of the hypotheses of a bit mask, as ``str`` of its element gives it.

        >>> Frame(["a", "b", "c"]).union_name(0b101)
        'a|c'
        """
        if not mask:
            return "empty"
        if mask.bit_count() == 1:
            return self._names[mask.bit_length() - 1]
        return "|".join([self._names[i] for i in _bits(mask)])

    def union_names(self, masks: Sequence[int]) -> list[str]:
        """:meth:`union_name` of each mask; masks that are the frame's own hypothesis bits are named at once.

        >>> frame = Frame(["a", "b", "c"])
        >>> frame.union_names([frame.bits[2], 0b011, 0])
        ['c', 'a|b', 'empty']
        """
        lengths = list(map(int.bit_length, masks))
        # By identity, as Frame.singleton_of_bit: a hypothesis's own bit needs no reading of its bits.
        own = (None, *self._bit.values())
        try:
            if all(map(operator.is_, map(own.__getitem__, lengths), masks)):
                return list(map(self._names.__getitem__, [length - 1 for length in lengths]))
        except IndexError:              # a mask beyond the frame: union_name says what it is
            pass
        return list(map(self.union_name, masks))

    def term(self, text: str) -> int:
        """Parse a single conjunction (``a&b``) into its mask."""
        element = self.element(text)
        if len(element.terms) != 1:
            raise ParseError(f"{text!r} is not a single conjunction of hypotheses")
        return element.terms[0]


def _plain_names(names: tuple) -> bool:
    """Whether every name is a non-empty, printable ASCII string without reserved characters, none twice.

    Checked on all the names at once: a frame of thousands of hypotheses is then built in
    a fraction of a millisecond.  Where it is False, :func:`_check_names` finds what is wrong
    (or that a non-ASCII name is fine).
    """
    try:
        joined = "".join(names)
    except TypeError:
        return False
    return (joined.isascii() and joined.isprintable() and _RESERVED_CHARACTER.search(joined) is None
            and all(names) and _RESERVED_NAMES.isdisjoint(names) and len(set(names)) == len(names))


def _check_names(names: tuple) -> None:
    """Raise FrameError for the first name that cannot name a hypothesis of a frame, or a name given twice."""
    seen: set[str] = set()
    composed: dict[str, str] | None = None
    for name in names:
        _check_name(name)
        if name in seen:
            raise FrameError(f"hypothesis {name!r} appears twice in the frame")
        seen.add(name)
        if not name.isascii():
            # Two spellings of one text (composed é and e + combining accent) print alike.
            if composed is None:
                composed = {}
            key = unicodedata.normalize("NFC", name)
            other = composed.setdefault(key, name)
            if other != name:
                raise FrameError(
                    f"hypotheses {other!r} and {name!r} differ only in their Unicode normalisation "
                    f"({_escaped(other)} and {_escaped(name)}) and would print alike"
                )


def _check_name(name: object) -> None:
    if not isinstance(name, str):
        raise FrameError(f"hypothesis names must be strings, got {name!r}")
    if not name:
        raise FrameError("hypothesis names must not be empty")
    if name in _RESERVED_NAMES:
        raise FrameError(f"{name!r} is reserved for the empty element and cannot name a hypothesis")
    if _RESERVED_CHARACTER.search(name) is not None:
        bad = sorted({ch for ch in name if ch.isspace() or ch in _OPERATOR_CHARS})
        raise FrameError(f"hypothesis name {name!r} contains the reserved character(s) {''.join(bad)!r}")
    if not name.isprintable():
        # Control, format (zero-width), private-use and unassigned characters and lone
        # surrogates make names that look alike, or that cannot be printed at all.
        ch = next(ch for ch in name if not ch.isprintable())
        raise FrameError(
            f"hypothesis name {name!r} contains the invisible or unprintable character "
            f"{_codepoint(ch)} ({_category_name(ch)}); hypothesis names must be printable"
        )


def _codepoint(ch: str) -> str:
    code = ord(ch)
    return f"\\u{code:04x}" if code <= 0xFFFF else f"\\U{code:08x}"


def _escaped(name: str) -> str:
    """A name quoted with every non-printable or non-ASCII character as an escape."""
    return "'" + "".join(ch if ch.isascii() and ch.isprintable() else _codepoint(ch) for ch in name) + "'"


_CATEGORIES = {"Cc": "control character", "Cf": "format character", "Cs": "lone surrogate",
               "Co": "private-use character", "Cn": "unassigned code point"}


def _category_name(ch: str) -> str:
    category = unicodedata.category(ch)
    return _CATEGORIES.get(category, f"Unicode category {category}")


def _bits(mask: int) -> Iterator[int]:
    while mask:
        low = mask & -mask
        yield low.bit_length() - 1
        mask ^= low


class _ElementSlots:
    """The storage of :class:`Element`, shared with :class:`_Fresh` (see :func:`_make`)."""

    __slots__ = ("frame", "terms", "_hash", "_key")


class _Fresh(_ElementSlots):
    """An element under construction: its slots take plain stores, then it becomes an :class:`Element`."""

    __slots__ = ()


class Element(_ElementSlots):
    """An element of the hyper-power set D^Θ, in canonical reduced form (SPEC A.1).

    Build elements through a :class:`Frame` (``frame["a"]``, ``frame.element("a&b|c")``)
    and combine them with ``&`` (∩) and ``|`` (∪).  ``x <= y`` tests inclusion on the free
    model.  Elements are immutable and hashable; equal elements print equally.

    Attributes
    ----------
    frame : Frame
        The frame the element belongs to.
    terms : tuple of int
        The minimal conjunctions, as hypothesis bit masks, in canonical order.

    Examples
    --------
    >>> f = Frame(["a", "b", "c"])
    >>> x = f.element("(a | b) & c")
    >>> x
    Element('a&c|b&c')
    >>> x <= f["c"], f["c"] <= x
    (True, False)
    >>> print(x.format("unicode"))
    a∩c ∪ b∩c
    """

    __slots__ = ()

    frame: Frame
    terms: tuple[int, ...]

    def __init__(self, frame: Frame, terms: Iterable[int]) -> None:
        if not isinstance(frame, Frame):
            raise TypeError("Element needs a Frame")
        full = (1 << len(frame)) - 1
        checked = []
        for term in terms:
            if isinstance(term, bool) or not isinstance(term, int) or term <= 0 or term & ~full:
                raise FrameError(f"{term!r} is not a conjunction mask of a {len(frame)}-hypothesis frame")
            checked.append(term)
        object.__setattr__(self, "frame", frame)
        object.__setattr__(self, "terms", reduce_terms(checked))
        object.__setattr__(self, "_hash", None)
        object.__setattr__(self, "_key", None)

    @classmethod
    def _make(cls, frame: Frame, terms: tuple[int, ...]) -> "Element":
        """Build from an already reduced, sorted antichain (no checks)."""
        return _make(frame, terms)

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError("Element is immutable")

    def __reduce__(self):
        return (Element, (self.frame, self.terms))

    # -- lattice operations -------------------------------------------------------------
    def _other(self, other: object) -> "Element":
        if isinstance(other, str):
            return self.frame.element(other)
        if not isinstance(other, Element):
            raise TypeError(f"cannot combine an Element with {type(other).__name__}")
        if other.frame != self.frame:
            raise FrameError("elements of different frames cannot be combined")
        return other

    def __and__(self, other: Union["Element", str]) -> "Element":
        other = self._other(other)
        if self.terms == other.terms:
            # X ∩ X = X, without the |X|² products (measures meet each focal element with itself).
            return self
        return _make(self.frame, reduce_terms(a | b for a in self.terms for b in other.terms))

    def __or__(self, other: Union["Element", str]) -> "Element":
        other = self._other(other)
        return _make(self.frame, reduce_terms(self.terms + other.terms))

    __rand__ = __and__
    __ror__ = __or__

    def __le__(self, other: Union["Element", str]) -> bool:
        other = self._other(other)
        return all(any(d & ~c == 0 for d in other.terms) for c in self.terms)

    def __ge__(self, other: Union["Element", str]) -> bool:
        return self._other(other) <= self

    def __lt__(self, other: Union["Element", str]) -> bool:
        other = self._other(other)
        return self != other and self <= other

    def __gt__(self, other: Union["Element", str]) -> bool:
        return self._other(other) < self

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Element):
            return NotImplemented
        return self.terms == other.terms and self.frame == other.frame

    def __hash__(self) -> int:
        h = self._hash
        if h is None:
            h = hash((self.frame._hash, self.terms))
            object.__setattr__(self, "_hash", h)
        return h

    def __bool__(self) -> bool:
        return bool(self.terms)

    @property
    def is_empty(self) -> bool:
        """True for ∅ (on the free model; see :meth:`Model.is_empty` under constraints)."""
        return not self.terms

    @property
    def hypotheses(self) -> int:
        """Bit mask of the hypotheses that appear in the element."""
        mask = 0
        for term in self.terms:
            mask |= term
        return mask

    @property
    def sort_key(self) -> tuple:
        """Canonical total order of elements (used to order focal elements).

        Fewer conjunctions first; then, term by term, smaller conjunctions first and
        frame order among equals: ∅, a, b, a&b, a|b, a|b&c, …
        """
        key = self._key
        if key is None:
            key = (len(self.terms), tuple(map(_term_order, self.terms)))
            object.__setattr__(self, "_key", key)
        return key

    # -- printing ------------------------------------------------------------------------
    def format(self, style: str = "ascii") -> str:
        """Canonical text: a union of intersections.

        Parameters
        ----------
        style : {"ascii", "unicode"}
            ``ascii`` gives ``a&b|c`` and ``empty``; ``unicode`` gives ``a∩b ∪ c`` and ``∅``.
        """
        if style not in ("ascii", "unicode"):
            raise ValueError(f"style must be 'ascii' or 'unicode', got {style!r}")
        if not self.terms:
            return "empty" if style == "ascii" else "∅"
        joiner = "|" if style == "ascii" else " ∪ "
        return joiner.join(self.frame.term_name(t, style) for t in self.terms)

    def __str__(self) -> str:
        terms = self.terms
        if len(terms) == 1:                     # one conjunction (most often one hypothesis): no join
            return self.frame.term_name(terms[0])
        return self.format("ascii")

    def __repr__(self) -> str:
        return f"Element({self.format('ascii')!r})"


def _make(frame: Frame, terms: tuple[int, ...]) -> Element:
    """An :class:`Element` from an already reduced, sorted antichain, without checks.

    The slots are filled by plain stores on a :class:`_Fresh` object, which then takes the
    class :class:`Element` (the two share one layout): three times cheaper than storing
    through ``object.__setattr__`` past :meth:`Element.__setattr__`, and combinations build
    one element per focal element of their result.  The hash is computed on first use.
    """
    obj = _new(_Fresh)
    obj.frame = frame
    obj.terms = terms
    obj._hash = None
    obj._key = None
    obj.__class__ = Element
    return obj


def make_elements(frame: Frame, terms: Iterable[tuple[int, ...]]) -> list[Element]:
    """Elements from canonical antichains, in order (:func:`_make` for each)."""
    out = []
    append = out.append
    for t in terms:
        obj = _new(_Fresh)
        obj.frame = frame
        obj.terms = t
        obj._hash = None
        obj._key = None
        obj.__class__ = Element
        append(obj)
    return out


_new = object.__new__


# -- parsing -----------------------------------------------------------------------------
_TOKEN = re.compile(r"\s*(?:(?P<op>[()&|∩∪∅])|(?P<name>[^\s()&|∩∪∅]+))")


class _Parser:
    """Parser of union := inter ('|' inter)*; inter := atom ('&' atom)*; atom := name | empty | '(' union ')'.

    It reads the tokens in one pass with an explicit stack of open parentheses, so that
    deep nesting costs no recursion, and it collects the conjunctions of a union in a list
    reduced once when the union closes, so that a union of n hypotheses costs n log n
    rather than n reductions of a growing antichain.
    """

    def __init__(self, frame: Frame, text: str) -> None:
        self.frame = frame
        self.text = text

    def _fail(self, message: str, where: int) -> None:
        raise ParseError(f"malformed proposition {_shorten(self.text)!r}: {message} at position {where}")

    def _tokens(self) -> Iterator[tuple[str, str, int]]:
        text = self.text
        pos = 0
        stripped_end = len(text.rstrip())
        kinds = {"∩": "&", "∪": "|", "∅": "empty"}
        while pos < stripped_end:
            match = _TOKEN.match(text, pos)
            if match is None:  # pragma: no cover - the pattern matches any non-space
                self._fail("unexpected character", pos)
            op = match.group("op")
            if op:
                yield kinds.get(op, op), op, match.start("op")
            else:
                name = match.group("name")
                yield ("empty" if name == "empty" else "name"), name, match.start("name")
            pos = match.end()
        yield "end", "", len(text)

    def parse(self) -> Element:
        if not self.text.strip():
            raise ParseError("empty proposition string; write 'empty' for the empty element")
        bit = self.frame._bit
        # One entry per open parenthesis (the first for the whole text): the conjunctions of
        # the union's finished operands, and the value of the intersection being read.
        union: list[int] = []
        inter: tuple[int, ...] | None = None
        stack: list[tuple[list[int], tuple[int, ...] | None]] = []
        expect_atom = True
        for kind, value, where in self._tokens():
            if expect_atom:
                if kind == "(":
                    stack.append((union, inter))
                    union, inter = [], None
                    continue
                if kind == "name":
                    b = bit.get(value)
                    if b is None:
                        raise UnknownHypothesisError(
                            f"unknown hypothesis {value!r} in {_shorten(self.text)!r}; "
                            f"the frame has {_listing(self.frame.hypotheses)}"
                        )
                    atom: tuple[int, ...] = (b,)
                elif kind == "empty":
                    atom = ()
                elif kind == "end":
                    self._fail("unexpected end, expected a hypothesis or '('", where)
                else:
                    self._fail(f"unexpected {value!r}, expected a hypothesis or '('", where)
                inter = atom if inter is None else self._meet(inter, atom)
                expect_atom = False
            elif kind == "&":
                expect_atom = True
            elif kind == "|":
                union.extend(inter)
                inter = None
                expect_atom = True
            elif kind == ")" and stack:
                union.extend(inter)
                atom = reduce_terms(union)
                union, inter = stack.pop()
                inter = atom if inter is None else self._meet(inter, atom)
            elif stack:
                self._fail("missing ')'", where)
            elif kind == "end":
                union.extend(inter)
                return _make(self.frame, reduce_terms(union))
            else:
                self._fail(f"unexpected {value!r}", where)
        raise AssertionError  # pragma: no cover - the last token is "end"

    def _meet(self, x: tuple[int, ...], y: tuple[int, ...]) -> tuple[int, ...]:
        """x ∩ y of two reduced antichains."""
        if len(y) == 1:
            b = y[0]
            if len(x) == 1:
                return (x[0] | b,)
            return reduce_terms([a | b for a in x])
        if len(x) * len(y) > MAX_PROPOSITION_TERMS:
            raise ParseError(
                f"proposition {_shorten(self.text)!r} is too large: an intersection of a union of {len(x):,} "
                f"conjunctions and one of {len(y):,} has up to {len(x) * len(y):,} conjunctions in normal form "
                f"(limit {MAX_PROPOSITION_TERMS:,})"
            )
        return reduce_terms([a | b for a in x for b in y])


def _shorten(text: str, limit: int = 200) -> str:
    """A long proposition cut for an error message, which must stay one readable line."""
    return text if len(text) <= limit else text[:limit] + "…"


def _listing(names: Sequence[str], limit: int = 20) -> str:
    """The hypotheses of a frame for an error message; a large frame is cut short."""
    if len(names) <= limit:
        return ", ".join(names)
    return ", ".join(names[:limit]) + f", … ({len(names):,} hypotheses)"
