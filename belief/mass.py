"""Mass functions (basic belief assignments): the friendly face of :class:`MassBatch`.

A :class:`MassFunction` is an immutable value: a model, a canonical tuple of focal
elements and their masses.  Equality is exact; :meth:`MassFunction.isclose` compares
with a tolerance.  Every measure is computed by the batch engine on a single row.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator, Mapping, Sequence
from typing import Any, Union

import numpy as np

from belief.batch import (SUM_TOLERANCE, MassBatch, check_cardinality_range, check_masses, exact_sum, resolve_model,
                          trusted_batch)
from belief.errors import FormatError, InvalidMassError
from belief.frame import Element, Frame, make_elements
from belief.incidence import held_measure
from belief.model import Model, _show
from belief.masks import canonical_order, to_words, union_key, word_count
from belief.plan import RANK_TABLE_WIDTH, union_elements, union_ranks
from belief.textfiles import load_json

__all__ = ["MassFunction"]

Query = Union[Element, str]


class _MassSlots(Mapping):
    """The storage of :class:`MassFunction`, shared with :class:`_FreshMass`.

    ``_focal`` (elements) or ``_masks`` (hypothesis bit masks of unions of hypotheses)
    holds the focal elements, ``_values`` (array) or ``_floats`` (tuple) their masses; the
    missing one of each pair is made from the other when first read.  With ``_loose``,
    ``_masks`` and ``_floats`` are not yet in canonical order (they are sorted then too).
    ``_memo`` keeps what :func:`belief.rules.combine` learnt of the last partner of this mass
    function, for the next combination of the same two.
    """

    __slots__ = ("model", "_focal", "_values", "_batch", "_hash", "_masks", "_floats", "_loose", "_memo")


class MassFunction(_MassSlots):
    """A mass function m: D^Θ → [0, 1] with Σ m = 1 (W (1)).

    Parameters
    ----------
    masses : mapping of proposition (str or Element) to float
        Zero masses are dropped; propositions that denote the same element (``"a|b"``
        and ``"b|a"``) have their masses added.
    frame : Frame or sequence of str, optional
        The frame; may be omitted when ``model`` is a :class:`~belief.model.Model`.
    model : Model or {"shafer", "free"}, optional
        The model the evidence was elicited under: Shafer's model (exclusive, exhaustive
        hypotheses, as in Dempster–Shafer theory) by default; ``"free"`` for the free DSm
        model, where hypotheses may overlap, or a :class:`~belief.model.Model` (hybrid, tracking).
    subnormal : bool
        Allow mass on ∅ or on elements that are empty under the model (open world, as
        in the transferable belief model); such mass is kept on ∅.

    Raises
    ------
    InvalidMassError
        Non-finite or negative masses, a sum other than one (within 1e-9), or mass on
        an empty element without ``subnormal=True``.

    Examples
    --------
    >>> m = MassFunction({"a": 0.6, "a|b": 0.4}, frame=["a", "b"])
    >>> m
    MassFunction({'a': 0.6, 'a|b': 0.4}, frame=['a', 'b'])
    >>> m.bel("a"), m.pls("b"), m.betp("a")  # Shafer's model: a and b exclude each other
    (0.6, 0.4, 0.8)
    >>> free = MassFunction({"a": 0.6, "a|b": 0.4}, frame=["a", "b"], model="free")
    >>> free.pls("b")  # on the free model a∩b ≠ ∅, so a's mass is plausible for b too
    1.0
    >>> free.betp("a")  # a|b has 3 regions on the free model, a&b counts for a and for b
    0.8666666666666667
    """

    __slots__ = ()

    model: Model

    def __init__(self, masses: Mapping[Query, float], frame=None, model=None, *,
                 subnormal: bool = False) -> None:
        if type(masses) is not dict and not isinstance(masses, Mapping):
            raise InvalidMassError(f"masses must be a mapping of propositions to numbers, got {type(masses).__name__}")
        if frame is not None or type(model) is not Model:
            model = resolve_model(frame, model)
        context = model._unions
        if context is None:
            context = _union_context(model)
        if context:
            # Unions of hypotheses ("a|c"), kept as bit masks and floats (see _MassSlots): a
            # combination works on them alone, and one of a few focal elements costs less
            # than making the elements or the array.  One pass over the items checks what
            # can be checked item by item: a call on new inputs pays for every object it
            # touches and every builtin it runs, more than for the arithmetic.  Anything
            # else (intersections, element keys, "empty", a name twice, a zero or a bad
            # mass) goes to the slower constructors below, which raise the errors.  The masks
            # of propositions read before are remembered by their text (a bounded dict).
            get, bits, _, parsed = context
            if len(masses) > _NAMES_AT_ONCE and _all_hypotheses(self, masses, model, bits):
                return
            bit_of = bits.get
            known = parsed.get
            masks = []
            try:
                for key, value in masses.items():
                    if type(value) is not float or not value > 0.0:
                        break
                    # A hypothesis's name is its frame's own bit (found by identity when read); a union's
                    # mask is remembered by its text.
                    mask = bit_of(key)
                    if mask is None:
                        mask = known(key)
                        if mask is None:
                            parts = key.split("|")
                            if len(parts) == 1:
                                break
                            mask = sum(map(get, parts))
                            # Without carries (each name once) the mask has a bit per name.
                            if mask.bit_count() != len(parts):
                                break
                            if len(parsed) >= PARSE_CACHE_SIZE:
                                parsed.clear()
                            parsed[key] = mask
                    masks.append(mask)
                else:
                    if masks and len(set(masks)) == len(masks):
                        values = list(masses.values())
                        off = abs(sum(values) - 1.0)
                        if (off <= _SURELY_ONE and len(values) <= _PLAIN_SUM_COUNT
                                or off <= _MAYBE_ONE and abs(exact_sum(values) - 1.0) <= SUM_TOLERANCE):
                            if type(self) is MassFunction:
                                _set(self, "__class__", _FreshMass)
                                _fill(self, model, masks, values, True)
                            else:
                                self._set_unions(model, masks, values)
                            return
            except (KeyError, AttributeError, TypeError):
                pass
            if _spaced_unions(self, masses, model, context[1]):
                return
        if not self._plain_init(masses, model):
            self._checked_init(masses, model, subnormal)

    def _set_unions(self, model: Model, masks: list[int], values: list[float]) -> None:
        """Hold unions of hypotheses in the order given (sorted, as tuples, when first read)."""
        if type(self) is MassFunction:
            # Plain stores on the twin class (see mass_from_masks), then back to MassFunction.
            _set(self, "__class__", _FreshMass)
            self.model = model
            self._focal = self._values = self._batch = self._hash = None
            self._masks = masks
            self._floats = values
            self._loose = True
            self._memo = None
            self.__class__ = MassFunction
        else:
            for name, value in (("model", model), ("_focal", None), ("_values", None), ("_batch", None),
                                ("_hash", None), ("_masks", masks), ("_floats", values), ("_loose", True),
                                ("_memo", None)):
                _set(self, name, value)

    def _plain_init(self, masses: Mapping[Query, float], model: Model) -> bool:
        """Build from a mapping that needs no merging, no ∅ and no error, in one pass; False otherwise.

        Propositions without parentheses are read by :meth:`Frame.plain_terms`, elements are
        made once, in canonical order, and the masses are checked in Python (a handful of
        numbers costs less than numpy's calls).  Anything unusual (two keys for one element,
        an element empty under the model, a mass that is not a finite non-negative number, a
        sum other than one) returns False before anything is set, and
        :meth:`_checked_init` then builds the mass function or raises the error.
        """
        frame = model.frame
        plain = frame._plain
        shafer = model.kind == "shafer"
        forbidden = not shafer and bool(model.forbidden)
        seen: set[tuple[int, ...]] = set()
        items = []
        single = True                   # every conjunction a single hypothesis
        for key, value in masses.items():
            if type(key) is str:
                parsed = plain(key)
                if parsed is None:
                    return False
                terms, simple = parsed
            elif isinstance(key, Element) and key.frame == frame:
                terms = key.terms
                simple = all(not t & (t - 1) for t in terms)
            else:
                return False
            if type(value) is not float:
                if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
                    return False
                if type(value) is int and value.bit_length() > 1000:
                    return False
                value = float(value)
            if not 0.0 <= value < math.inf:
                return False
            if not simple:
                if shafer:
                    terms = tuple(t for t in terms if not t & (t - 1))
                else:
                    single = False
            if forbidden:
                terms = model.kept_terms(terms)
            if not terms or terms in seen:
                return False
            seen.add(terms)
            if value > 0.0:
                items.append((terms, value))
        if not items or abs(exact_sum([v for _, v in items]) - 1.0) > SUM_TOLERANCE:
            return False
        if single:
            # Unions of hypotheses: the canonical order is by the number of hypotheses, then their positions.
            items.sort(key=_plain_key)
            focal = tuple(make_elements(frame, [t for t, _ in items]))
        else:
            pairs = sorted(zip(make_elements(frame, [t for t, _ in items]), [v for _, v in items]),
                           key=_sort_key)
            focal = tuple(e for e, _ in pairs)
            items = pairs
        values = np.array([v for _, v in items], dtype=np.float64)
        values.flags.writeable = False
        object.__setattr__(self, "model", model)
        object.__setattr__(self, "_focal", focal)
        object.__setattr__(self, "_values", values)
        object.__setattr__(self, "_batch", None)
        object.__setattr__(self, "_hash", None)
        object.__setattr__(self, "_masks", None)
        object.__setattr__(self, "_floats", None)
        object.__setattr__(self, "_loose", False)
        object.__setattr__(self, "_memo", None)
        return True

    def _checked_init(self, masses: Mapping[Query, float], model: Model, subnormal: bool) -> None:
        merged: dict[Element, list[float]] = {}
        for key, value in masses.items():
            element = model.frame.element(key)
            mass = _as_mass(value, key)
            if model.is_empty(element):
                if element.terms and mass > 0 and not subnormal:
                    raise InvalidMassError(
                        f"mass {mass!r} on {element}, which is empty under the {model.kind} model; "
                        "pass subnormal=True to allow an unnormalised (open-world) mass function"
                    )
                element = model.frame.empty
            else:
                element = model.reduce(element)
            merged.setdefault(element, []).append(mass)
        items = sorted(((e, exact_sum(v)) for e, v in merged.items()), key=lambda ev: ev[0].sort_key)
        if not items:
            raise InvalidMassError("a mass function needs at least one focal element")
        focal = tuple(e for e, _ in items)
        values = np.array([v for _, v in items], dtype=np.float64)
        check_masses(values.reshape(1, -1), focal, model, subnormal)
        keep = values > 0
        self._init(model, tuple(e for e, k in zip(focal, keep.tolist()) if k), values[keep])

    def _init(self, model: Model, focal: tuple[Element, ...], values: np.ndarray) -> None:
        values = np.array(values, dtype=np.float64)
        values.flags.writeable = False
        object.__setattr__(self, "model", model)
        object.__setattr__(self, "_focal", focal)
        object.__setattr__(self, "_values", values)
        object.__setattr__(self, "_batch", None)
        object.__setattr__(self, "_hash", None)
        object.__setattr__(self, "_masks", None)
        object.__setattr__(self, "_floats", None)
        object.__setattr__(self, "_loose", False)
        object.__setattr__(self, "_memo", None)

    @classmethod
    def _trusted(cls, model: Model, focal: tuple[Element, ...], values) -> "MassFunction":
        obj = object.__new__(cls)
        obj._init(model, focal, values)
        return obj

    def _settle(self) -> None:
        """Put loose masks and floats in canonical order (:func:`~belief.plan.union_ranks`, or its key if wider)."""
        n = len(self.model.frame)
        masks, floats = self._masks, self._floats
        if n > RANK_TABLE_WIDTH and len(masks) > _SORTED_BY_WORDS:
            elements = list(map(self.model.frame.singleton_of_bit, masks))
            if None not in elements:
                # The frame's own bits: their canonical order is that of the hypotheses, their elements the frame's.
                order = sorted(range(len(masks)), key=lambda i: masks[i].bit_length())
                object.__setattr__(self, "_focal", tuple([elements[i] for i in order]))
            else:
                # Many masks of a wide frame: numpy sorts their words (the key of one mask is a few microseconds).
                order = canonical_order(to_words(masks, word_count(n))).tolist()
            object.__setattr__(self, "_masks", tuple([masks[i] for i in order]))
            object.__setattr__(self, "_floats", tuple([floats[i] for i in order]))
        else:
            rank = union_ranks(n)[2] if n <= RANK_TABLE_WIDTH else list(map(union_key(n), masks))
            items = sorted(zip([rank[m] for m in masks] if n <= RANK_TABLE_WIDTH else rank, masks, floats))
            object.__setattr__(self, "_masks", tuple([m for _, m, _ in items]))
            object.__setattr__(self, "_floats", tuple([v for _, _, v in items]))
        object.__setattr__(self, "_loose", False)

    @property
    def focal(self) -> tuple[Element, ...]:
        """The focal elements, in canonical order (:attr:`Element.sort_key`)."""
        focal = self._focal
        if focal is None:
            if self._loose:
                self._settle()                  # which may find the elements
            focal = self._focal
            if focal is None:
                focal = tuple(union_elements(self.model.frame, self._masks))
                object.__setattr__(self, "_focal", focal)
        return focal

    @property
    def values(self) -> np.ndarray:
        """The masses of the focal elements, in their order (a read-only array)."""
        values = self._values
        if values is None:
            if self._loose:
                self._settle()
            values = np.array(self._floats, dtype=np.float64)
            values.flags.writeable = False
            object.__setattr__(self, "_values", values)
        return values

    def _union_masks(self) -> tuple[int, ...] | None:
        """The focal elements as hypothesis bit masks in canonical order, if every one is a union of hypotheses."""
        if self._loose:
            self._settle()
        masks = self._masks
        if masks is None:
            out = []
            for x in self._focal:
                terms = x.terms
                mask = 0
                for t in terms:
                    if t & (t - 1):
                        return None
                    mask |= t
                out.append(mask)
            masks = tuple(out)
            object.__setattr__(self, "_masks", masks)
        return masks

    def _unions_as_held(self) -> tuple[Sequence[int], Sequence[float]] | None:
        """The focal elements as hypothesis bit masks and their masses, in the order held (maybe not canonical).

        None if they are not held as masks.  Nothing is sorted or made: a reader that does not
        need the canonical order (a sum, a scatter by position) takes them as they are.
        """
        masks = self._masks
        if masks is None:
            return None
        floats = self._floats
        return masks, (floats if floats is not None else self._union_floats())

    def _union_floats(self) -> tuple[float, ...]:
        """The masses as a tuple of floats, in the order of :meth:`_union_masks`."""
        if self._loose:
            self._settle()
        floats = self._floats
        if floats is None:
            floats = tuple(self._values.tolist())
            object.__setattr__(self, "_floats", floats)
        return floats

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError("MassFunction is immutable")

    def __reduce__(self):
        return (MassFunction._trusted, (self.model, self.focal, self.values.copy()))

    # -- constructors ---------------------------------------------------------------------
    @classmethod
    def vacuous(cls, frame=None, model=None) -> "MassFunction":
        """Total ignorance: m(θ_1 ∪ … ∪ θ_n) = 1.

        >>> MassFunction.vacuous(frame=["a", "b"])
        MassFunction({'a|b': 1.0}, frame=['a', 'b'])
        """
        model = resolve_model(frame, model)
        return cls._trusted(model, (model.total,), [1.0])

    @classmethod
    def categorical(cls, element: Query, frame=None, model=None) -> "MassFunction":
        """All the mass on one element.

        >>> MassFunction.categorical("a", frame=["a", "b"])
        MassFunction({'a': 1.0}, frame=['a', 'b'])
        >>> MassFunction.categorical("a&b", frame=["a", "b"], model="free")
        MassFunction({'a&b': 1.0}, frame=['a', 'b'], model='free')
        """
        model = resolve_model(frame, model)
        target = model.frame.element(element)
        if model.is_empty(target):
            raise InvalidMassError(f"{target} is empty under the {model.kind} model and cannot hold all the mass")
        return cls._trusted(model, (model.reduce(target),), [1.0])

    # -- mapping protocol ----------------------------------------------------------------
    @property
    def frame(self) -> Frame:
        return self.model.frame

    def __getitem__(self, key: Query) -> float:
        element = self.model.frame.element(key)
        element = self.model.frame.empty if self.model.is_empty(element) else self.model.reduce(element)
        for e, v in zip(self.focal, self.values.tolist()):
            if e == element:
                return v
        return 0.0

    mass = __getitem__

    def __iter__(self) -> Iterator[Element]:
        return iter(self.focal)

    def __len__(self) -> int:
        return len(self._masks if self._focal is None else self._focal)

    def __contains__(self, key: object) -> bool:
        if not isinstance(key, (str, Element)):
            return False
        return self[key] > 0

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, MassFunction):
            return NotImplemented
        return (self.model == other.model and self.focal == other.focal
                and bool(np.array_equal(self.values, other.values)))

    def __ne__(self, other: object) -> bool:
        result = self.__eq__(other)
        return result if result is NotImplemented else not result

    def __hash__(self) -> int:
        if self._hash is None:
            object.__setattr__(self, "_hash", hash((self.model, self.focal, self.values.tobytes())))
        return self._hash  # type: ignore[return-value]

    def isclose(self, other: "MassFunction", *, rel_tol: float = 1e-9, abs_tol: float = 1e-12) -> bool:
        """Equal up to floating-point tolerance (a focal element missing on one side counts as 0).

        >>> a = MassFunction({"a": 0.1 + 0.2, "b": 0.7}, frame=["a", "b"])
        >>> b = MassFunction({"a": 0.3, "b": 0.7}, frame=["a", "b"])
        >>> a == b, a.isclose(b)
        (False, True)
        """
        if not isinstance(other, MassFunction):
            raise TypeError("isclose compares two mass functions")
        if self.model != other.model:
            return False
        mine = dict(zip(self.focal, self.values.tolist()))
        theirs = dict(zip(other.focal, other.values.tolist()))
        return all(
            math.isclose(mine.get(e, 0.0), theirs.get(e, 0.0), rel_tol=rel_tol, abs_tol=abs_tol)
            for e in set(mine) | set(theirs)
        )

    def items(self):  # type: ignore[override]
        """(element, mass) pairs in canonical order."""
        return list(zip(self.focal, self.values.tolist()))

    def to_mapping(self) -> dict[str, float]:
        """``{proposition string: mass}`` in canonical order."""
        if self._focal is None and self._masks is not None:
            # Unions of hypotheses print from their masks: no element need be made.
            masks, floats = self._union_masks(), self._union_floats()
            if self._focal is None:
                return dict(zip(self.model.frame.union_names(masks), floats))
        return {str(e): v for e, v in zip(self.focal, self.values.tolist())}

    def __repr__(self) -> str:
        body = ", ".join(f"{str(e)!r}: {v!r}" for e, v in zip(self.focal, self.values.tolist()))
        frame = f"frame={list(self.frame.hypotheses)!r}"
        if self.model == Model.shafer(self.frame):
            where = frame
        elif self.model.kind == "free" and not self.model.forbidden:
            where = f"{frame}, model='free'"
        else:
            where = f"model={self.model!r}"
        return f"MassFunction({{{body}}}, {where})"

    @property
    def empty_mass(self) -> float:
        """m(∅): the conflict an unnormalised result keeps."""
        return self[self.frame.empty]

    @property
    def is_subnormal(self) -> bool:
        return self.empty_mass > 0

    # -- the engine --------------------------------------------------------------------------
    def batch(self) -> MassBatch:
        """This mass function as a one-row :class:`MassBatch`."""
        if self._batch is None:
            object.__setattr__(self, "_batch", trusted_batch(self.model, self.focal, self.values.reshape(1, -1),
                                                                   canonical=True))
        return self._batch  # type: ignore[return-value]

    def _one(self, method: str, query, **kwargs):
        # Unions of hypotheses still held as masks are measured from them where that applies (no element made).
        result = None if kwargs else held_measure(self, method, query)
        if result is None:
            result = getattr(self.batch(), method)(query, **kwargs)
        result = result[0]
        if isinstance(query, (str, Element)):
            return float(result)
        return result

    def bel(self, query: Query) -> float:
        """Belief Bel(A) = Σ_{∅≠B⊆A} m(B) (W (8)).  A list of queries gives an array."""
        return self._one("bel", query)

    def pls(self, query: Query) -> float:
        """Plausibility Pls(A) = Σ_{B∩A≠∅} m(B) (W (9)).  A list of queries gives an array."""
        return self._one("pls", query)

    def q(self, query: Query) -> float:
        """Commonality q(A) = Σ_{B⊇A} m(B).  A list of queries gives an array."""
        return self._one("q", query)

    commonality = q
    belief = bel
    plausibility = pls

    def cardinality(self, element: Query) -> int:
        """DSm cardinality C_M(A) under this mass function's model."""
        return self.model.cardinality(element)

    def betp(self, query: Query | None = None):
        """Generalised pignistic probability BetP(A) = Σ_X m(X) C_M(X∩A)/C_M(X); without a query, of every hypothesis.

        m(∅) is removed and the rest rescaled by 1 - m(∅).  ``m.betp()`` is :meth:`pignistic`,
        ``{name: probability}``.

        >>> m = MassFunction({"a": 0.5, "a|b": 0.5}, model=Model.shafer(Frame(["a", "b"])))
        >>> m.betp("a"), m.betp()
        (0.75, {'a': 0.75, 'b': 0.25})
        """
        if query is None:
            return self.pignistic()
        check_cardinality_range(self, "BetP")
        return self._one("betp", query)

    def dsmp(self, query: Query, epsilon: float = 0.001) -> float:
        """DSmP_ε(A), the proportional transformation of DSmT (see :meth:`MassBatch.dsmp`).

        >>> m = MassFunction({"a": 0.4, "b": 0.2, "a|b": 0.4}, model=Model.shafer(Frame(["a", "b"])))
        >>> round(m.dsmp("a", epsilon=0), 12)
        0.666666666667
        """
        check_cardinality_range(self, "DSmP", epsilon)
        return self._one("dsmp", query, epsilon=epsilon)

    def pignistic(self) -> dict[str, float]:
        """BetP of every hypothesis, ``{name: probability}``."""
        check_cardinality_range(self, "BetP")
        values = self.batch().pignistic()[0]
        return dict(zip(self.frame.hypotheses, values.tolist()))

    def dsmp_probabilities(self, epsilon: float = 0.001) -> dict[str, float]:
        """DSmP_ε of every hypothesis, ``{name: probability}``."""
        check_cardinality_range(self, "DSmP", epsilon)
        values = self.batch().dsmp(list(self.frame.singletons), epsilon=epsilon)[0]
        return dict(zip(self.frame.hypotheses, values.tolist()))

    # -- operations ------------------------------------------------------------------------------
    @staticmethod
    def _from_row(batch: MassBatch) -> "MassFunction":
        return batch[0]

    def discount(self, alpha: float) -> "MassFunction":
        """Shafer discounting with reliability α ∈ [0, 1].

        m_α(X) = α m(X) for X ≠ Θ and m_α(Θ) = α m(Θ) + 1 - α.  α = 1 keeps the source,
        α = 0 makes it vacuous.

        >>> MassFunction({"a": 0.6, "b": 0.4}, frame=["a", "b"]).discount(0.5)
        MassFunction({'a': 0.3, 'b': 0.2, 'a|b': 0.5}, frame=['a', 'b'])
        """
        return self._from_row(self.batch().discount(alpha))

    def condition(self, given: Query, normalized: bool = True) -> "MassFunction":
        """Dempster conditioning on ``given`` (combination with the categorical m(B) = 1).

        >>> m = MassFunction({"a": 0.5, "b": 0.3, "a|b": 0.2}, model="shafer", frame=["a", "b"])
        >>> m.condition("a")
        MassFunction({'a': 1.0}, frame=['a', 'b'])
        >>> m.condition("a", normalized=False)
        MassFunction({'empty': 0.3, 'a': 0.7}, frame=['a', 'b'])
        """
        return self._from_row(self.batch().condition(given, normalized=normalized))

    def normalized(self) -> "MassFunction":
        """Remove m(∅) and rescale by 1 - m(∅); raises TotalConflictError if m(∅) = 1."""
        return self._from_row(self.batch().normalized())

    def under(self, model: Model) -> "MassFunction":
        """Read the same evidence under a stricter model (dynamic fusion).

        Focal elements are reduced under ``model``; the mass of those that become empty
        moves to ∅, so the result may be subnormal.

        >>> m = MassFunction({"a&b": 0.3, "a": 0.7}, frame=["a", "b"], model="free")
        >>> m.under(Model.shafer(m.frame))
        MassFunction({'empty': 0.3, 'a': 0.7}, frame=['a', 'b'])
        """
        return self._from_row(self.batch().under(model))

    # -- serialisation ------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The BBA file object: ``{"frame", "model", "mass"[, "subnormal"]}``."""
        data: dict[str, Any] = {
            "frame": list(self.frame.hypotheses),
            "model": self.model.to_dict(),
            "mass": self.to_mapping(),
        }
        if self.is_subnormal:
            data["subnormal"] = True
        return data

    def to_json(self, indent: int | None = 2) -> str:
        """JSON text of :meth:`to_dict`; floats are written exactly (round trip is exact)."""
        return json.dumps(self.to_dict(), indent=indent, ensure_ascii=False)

    @classmethod
    def from_dict(cls, data: Any) -> "MassFunction":
        """Inverse of :meth:`to_dict`; raises :class:`FormatError` naming what is wrong."""
        if not isinstance(data, Mapping):
            raise FormatError("a BBA must be a JSON object with \"frame\" and \"mass\"")
        unknown = set(data) - {"frame", "model", "mass", "subnormal"}
        if unknown:
            raise FormatError(f"unknown key(s) in BBA: {', '.join(sorted(map(_key_text, unknown)))}")
        for key in ("frame", "mass"):
            if key not in data:
                raise FormatError(f"the BBA has no \"{key}\"")
        names = data["frame"]
        if not isinstance(names, list) or set(map(type, names)) - {str} and not all(isinstance(n, str) for n in names):
            raise FormatError("\"frame\" must be a list of hypothesis names")
        frame = Frame(names)
        model = Model.from_dict(frame, data.get("model"))
        masses = data["mass"]
        if not isinstance(masses, Mapping):
            raise FormatError("\"mass\" must be an object mapping propositions to numbers")
        subnormal = data.get("subnormal", False)
        if not isinstance(subnormal, bool):
            raise FormatError("\"subnormal\" must be true or false")
        return cls(masses, model=model, subnormal=subnormal)

    @classmethod
    def from_json(cls, text: Union[str, bytes]) -> "MassFunction":
        """Parse a BBA file's text."""
        return cls.from_dict(load_json(text))


MassBatch.row_type = MassFunction       # a row of a batch is a mass function (the engine does not import this module)

_NUMBERS = (int, float, np.integer, np.floating)
#: The plain float sum of at most _PLAIN_SUM_COUNT positive masses is off their exact sum by less
#: than 2**16 units in the last place (1.5e-11) of it: within _SURELY_ONE of one, the exact sum is
#: within SUM_TOLERANCE, and beyond _MAYBE_ONE it is not (math.fsum decides in between, and for more masses).
_PLAIN_SUM_COUNT = 1 << 16
_SURELY_ONE = SUM_TOLERANCE / 2
_MAYBE_ONE = 2 * SUM_TOLERANCE


class _FreshMass(_MassSlots):
    """A mass function under construction (see :func:`mass_from_masks`)."""

    __slots__ = ()
    # Not abstract, so that object.__new__ makes one; it is a MassFunction before anyone sees it.
    __getitem__ = __iter__ = __len__ = None


_new = object.__new__
_set = object.__setattr__


def _fill(obj: _FreshMass, model: Model, masks, values, loose: bool) -> None:
    """Make ``obj`` the mass function of unions ``masks`` with ``values`` (see :func:`mass_from_masks`)."""
    # A twin class without MassFunction.__setattr__ takes plain stores (cheaper than
    # object.__setattr__), then the object becomes a MassFunction: both share one layout.
    obj.model = model
    obj._focal = obj._batch = obj._hash = obj._memo = None
    obj._masks = masks
    obj._loose = loose
    if type(values) is not np.ndarray:
        obj._values = None
        obj._floats = values
    else:
        values.flags.writeable = False
        obj._values = values
        obj._floats = None
    obj.__class__ = MassFunction


def _spaced_unions(mass: MassFunction, masses: Mapping, model: Model, bit: dict[str, int]) -> bool:
    """Unions of hypotheses for ``MassFunction.__init__`` with spaces around the names, or masses of other number
    types (ints, numpy scalars); False, with nothing set, for anything else."""
    masks = []
    values = []
    for key, value in masses.items():
        if type(key) is not str:
            return False
        parts = key.split("|")
        mask = 0
        for part in parts:
            b = bit.get(part.strip())
            if b is None:
                return False
            mask += b
        if mask.bit_count() != len(parts):
            return False
        if type(value) is not float:
            if type(value) is bool or not isinstance(value, _NUMBERS):
                return False
            if type(value) is int and value.bit_length() > 1000:
                return False
            value = float(value)
        masks.append(mask)
        values.append(value)
    if not masks or len(set(masks)) != len(masks) or not min(values) >= 0.0 \
            or not abs(exact_sum(values) - 1.0) <= SUM_TOLERANCE:
        return False
    if 0.0 in values:
        masks = [m for m, v in zip(masks, values) if v > 0.0]
        values = [v for v in values if v > 0.0]
    mass._set_unions(model, masks, values)
    return True


#: Above this many propositions, a mapping whose every key is a hypothesis's name is read at once (builtins over all
#: the keys and values, no Python step per item).
_NAMES_AT_ONCE = 64


def _all_hypotheses(m: MassFunction, masses: Mapping, model: Model, bits: dict) -> bool:
    """Set ``m`` from masses on single hypotheses (every key a name of the frame), or return False untouched.

    The keys are names, so their masks are distinct bits; the values must all be positive floats
    summing to one (NaN and infinity fail the sum), else the item-by-item reading decides.
    """
    try:
        masks = list(map(bits.__getitem__, masses))
    except (KeyError, TypeError):
        return False
    values = list(masses.values())
    # Written so that a NaN, for which every comparison is False, fails each test.
    if (set(map(type, values)) != {float} or not min(values) > 0.0
            or not abs(exact_sum(values) - 1.0) <= SUM_TOLERANCE):
        return False
    if type(m) is MassFunction:
        _set(m, "__class__", _FreshMass)
        _fill(m, model, masks, values, True)
    else:
        m._set_unions(model, masks, values)
    return True


def _union_context(model: Model) -> tuple | bool:
    """What :class:`MassFunction` needs to read unions of hypotheses under a model (kept on it), or False.

    It applies to frames whose model declares no hypothesis empty on its own (a union of
    hypotheses is then its own form under the model).
    """
    frame = model.frame
    n = len(frame)
    # Shafer's model forbids no hypothesis on its own (and its conjunctions are not listed on wide frames).
    if model.kind != "shafer" and any(f & (f - 1) == 0 for f in model.forbidden):
        context = False
    else:
        # The bit of each name, the rank table (none on wide frames: masks are sorted by their key), and the
        # propositions read so far, by their text.
        context = (frame._bit.__getitem__, frame._bit, union_ranks(n)[2] if n <= RANK_TABLE_WIDTH else None, {})
    model._unions = context
    return context


#: Above this many loose masks of a frame wider than the rank tables, they are put in order by numpy.
_SORTED_BY_WORDS = 64

#: How many propositions a model remembers the hypothesis masks of (``MassFunction(...)`` reads the others); then it
#: starts over.
PARSE_CACHE_SIZE = 4096


def _plain_key(item: tuple[tuple[int, ...], float]) -> tuple:
    """Canonical order of an element whose conjunctions are single hypotheses (see ``Element.sort_key``)."""
    terms = item[0]
    return len(terms), terms


def _sort_key(item: tuple[Element, float]) -> tuple:
    return item[0].sort_key


def _as_mass(value: Any, key: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InvalidMassError(f"the mass of {_key_text(key)} must be a number, "
                               f"got {_show.repr(value)}")
    try:
        return float(value)
    except OverflowError:
        digits = int(int(value).bit_length() * math.log10(2)) + 1
        raise InvalidMassError(f"the mass of {_key_text(key)} is an integer of "
                               f"about {digits:,} digits, too large for a float; masses lie in [0, 1]") from None


def _key_text(key: Any) -> str:
    text = str(key)
    return text if len(text) <= 60 and text.isprintable() else _show.repr(text)


def mass_from_masks(model: Model, masks, values, loose: bool = False) -> MassFunction:
    """Wrap unions of hypotheses (bit masks, 0 for ∅) and their masses, without copying or checks.

    The package's kernels make their results so.  ``values`` is a tuple of floats, or a
    fresh array that nothing else holds.  Without ``loose`` the masks are in canonical
    order; with it they (lists or tuples, floats only) are sorted when first read.
    """
    obj = _new(_FreshMass)
    _fill(obj, model, masks, values, loose)
    return obj
