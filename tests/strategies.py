"""Hypothesis strategies and slow, literal reference helpers shared by the test modules.

The reference helpers work directly on the definitions of SPEC A.1/A.2: a Venn region is a
non-empty set S of hypotheses (an int bit mask), an element of D^Θ is the set of regions it
contains (region S is in the element iff one of its conjunctions is a subset of S), and a
model is the set of regions it allows.  Nothing here relies on the library's own ∩, ∪, ⊆,
reduction or cardinality code, so the tests can compare the library against it.

The strategies that only draw library objects come from :mod:`belief.testing`, the ones users
get (:func:`frames`); those here pair each drawn object with its literal reference (a model
with its allowed regions, a mass function with the regions of its focal elements).
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from functools import lru_cache

from hypothesis import assume
from hypothesis import strategies as st

from belief import Element, Frame, MassFunction, Model
from belief import testing

# Building a strategy costs far more than drawing from it (Hypothesis validates it and works out
# its properties on first use), so every strategy below is built once for its arguments and
# reused: the composites would otherwise build several new ones for every example they draw.
_memo = lru_cache(maxsize=None)

# -- literal Venn-region semantics ---------------------------------------------------------------


def all_regions(n: int) -> frozenset[int]:
    """Every Venn region of an n-hypothesis frame: the non-empty subsets of {0..n-1}."""
    return frozenset(range(1, 1 << n))


def regions_of_terms(terms, n: int) -> frozenset[int]:
    """Regions contained in the union of the given conjunctions (hypothesis bit masks)."""
    terms = list(terms)
    return frozenset(s for s in range(1, 1 << n) if any(t & s == t for t in terms))


def regions_of(element: Element) -> frozenset[int]:
    """The region set of a library element, read literally from its conjunctions."""
    return regions_of_terms(element.terms, len(element.frame))


def hypothesis_regions(n: int, i: int) -> frozenset[int]:
    """θ_i as a region set: every region that contains hypothesis i."""
    return frozenset(s for s in range(1, 1 << n) if s >> i & 1)


def minimal_regions(regions) -> list[int]:
    """The regions of a family that contain no other region of the family."""
    regions = list(regions)
    return [r for r in regions if not any(s != r and s & r == s for s in regions)]


def term_text(frame: Frame, mask: int) -> str:
    """A conjunction written out by hand: the names of its hypotheses joined by '&'."""
    return "&".join(name for i, name in enumerate(frame.hypotheses) if mask >> i & 1)


def free_allowed(n: int) -> frozenset[int]:
    return all_regions(n)


def shafer_allowed(n: int) -> frozenset[int]:
    """Shafer's model allows the singleton regions only."""
    return frozenset(1 << i for i in range(n))


def hybrid_allowed(n: int, empty_terms) -> frozenset[int]:
    """A region is allowed unless it contains a conjunction declared empty."""
    empty_terms = list(empty_terms)
    return frozenset(s for s in range(1, 1 << n) if not any(t & s == t for t in empty_terms))


def tracking_allowed(n: int, false_alarm: int) -> frozenset[int]:
    """Tracking model: any set of targets, plus the false-alarm region on its own."""
    fa = 1 << false_alarm
    return frozenset(s for s in range(1, 1 << n) if not (s & fa and s != fa))


@dataclass(frozen=True)
class ModelCase:
    """A model together with its allowed regions computed from the definition."""

    model: Model
    allowed: frozenset[int]
    label: str

    @property
    def frame(self) -> Frame:
        return self.model.frame

    @property
    def n(self) -> int:
        return len(self.model.frame)

    def regions(self, element: Element) -> frozenset[int]:
        """Regions of an element that survive under the model."""
        return regions_of(element) & self.allowed


# -- strategies ---------------------------------------------------------------------------------------


@_memo
def frames(min_n: int = 1, max_n: int = 5):
    """Frames t1 .. tn, min_n ≤ n ≤ max_n (:func:`belief.testing.frames`, up to five hypotheses by default)."""
    return testing.frames(min_n, max_n)


@_memo
def conjunctions(n: int):
    """A non-empty conjunction mask of an n-hypothesis frame."""
    return st.integers(1, (1 << n) - 1)


@_memo
def elements(frame: Frame, max_terms: int = 4):
    """Arbitrary elements of D^Θ (the empty one included), from random conjunctions."""
    n = len(frame)
    return st.lists(conjunctions(n), max_size=max_terms).map(lambda terms: Element(frame, terms))


@_memo
def expressions(n: int, max_leaves: int = 8):
    """Expression trees over θ_0..θ_{n-1}: ("h", i), ("empty",), ("&", x, y), ("|", x, y)."""
    leaves = st.integers(0, n).map(lambda i: ("empty",) if i == n else ("h", i))
    return st.recursive(
        leaves,
        lambda kids: st.tuples(st.sampled_from(["&", "|"]), kids, kids),
        max_leaves=max_leaves,
    )


def expression_regions(expr, n: int) -> frozenset[int]:
    """Evaluate an expression tree as a region set (∩ and ∪ are set operations)."""
    if expr[0] == "h":
        return hypothesis_regions(n, expr[1])
    if expr[0] == "empty":
        return frozenset()
    left, right = expression_regions(expr[1], n), expression_regions(expr[2], n)
    return left & right if expr[0] == "&" else left | right


def expression_element(expr, frame: Frame) -> Element:
    """Evaluate an expression tree with the library's ``&`` and ``|`` operators."""
    if expr[0] == "h":
        return frame[frame.hypotheses[expr[1]]]
    if expr[0] == "empty":
        return frame.empty
    left, right = expression_element(expr[1], frame), expression_element(expr[2], frame)
    return left & right if expr[0] == "&" else left | right


def expression_text(expr, frame: Frame, *, unicode: bool = False, minimal_parentheses: bool = True) -> str:
    """Write an expression tree as a proposition string.

    With ``minimal_parentheses`` a union is parenthesised only inside an intersection, so the
    string relies on ∩ binding tighter than ∪; otherwise every operation is parenthesised.
    """
    and_op, or_op, empty = (" ∩ ", " ∪ ", "∅") if unicode else (" & ", " | ", "empty")

    def write(e, inside_and: bool) -> str:
        if e[0] == "h":
            return frame.hypotheses[e[1]]
        if e[0] == "empty":
            return empty
        if e[0] == "&":
            text = write(e[1], True) + and_op + write(e[2], True)
            return text if minimal_parentheses else f"({text})"
        text = write(e[1], False) + or_op + write(e[2], False)
        return f"({text})" if (inside_and or not minimal_parentheses) else text

    return write(expr, False)


@_memo
def _propositions(n: int, max_constraints: int):
    return st.lists(st.lists(conjunctions(n), min_size=1, max_size=2), max_size=max_constraints)


@_memo
@st.composite
def hybrid_cases(draw, frame: Frame, max_constraints: int = 3) -> ModelCase:
    """A hybrid model declaring a few random propositions (unions of conjunctions) empty."""
    n = len(frame)
    props = draw(_propositions(n, max_constraints))
    texts = ["|".join(term_text(frame, t) for t in prop) for prop in props]
    empty_terms = [t for prop in props for t in prop]
    return ModelCase(Model.hybrid(frame, texts), hybrid_allowed(n, empty_terms), f"hybrid {texts}")


@_memo
def _sampled(values: tuple):
    return st.sampled_from(values)


@_memo
def weight_lists(low: int, high: int, size: int):
    """Exactly ``size`` integer weights in [low, high]."""
    return st.lists(st.integers(low, high), min_size=size, max_size=size)


@_memo
@st.composite
def model_cases(draw, frame: Frame, kinds=("free", "shafer", "hybrid", "tracking")) -> ModelCase:
    n = len(frame)
    choices = [k for k in kinds if k != "tracking" or n >= 2]
    kind = draw(_sampled(tuple(choices)))
    if kind == "free":
        return ModelCase(Model.free(frame), free_allowed(n), "free")
    if kind == "shafer":
        return ModelCase(Model.shafer(frame), shafer_allowed(n), "shafer")
    if kind == "hybrid":
        return draw(hybrid_cases(frame))
    fa = draw(st.integers(0, n - 1))
    return ModelCase(Model.tracking(frame, frame.hypotheses[fa]), tracking_allowed(n, fa), f"tracking FA={fa}")


@_memo
def any_model_cases(min_n: int = 1, max_n: int = 5, kinds=("free", "shafer", "hybrid", "tracking")):
    return frames(min_n, max_n).flatmap(lambda f: model_cases(f, kinds))


@dataclass(frozen=True)
class MassCase:
    """Raw input of a mass function: distinct propositions and masses, as handed to the library."""

    case: ModelCase
    entries: tuple[tuple[Element, float], ...]
    subnormal: bool

    def build(self) -> MassFunction:
        return MassFunction(dict(self.entries), model=self.case.model, subnormal=self.subnormal)

    def region_masses(self) -> list[tuple[frozenset[int], float]]:
        """(regions under the model, mass) for every entry; empty region sets are ∅."""
        return [(self.case.regions(e), v) for e, v in self.entries]


def _normalised(weights: list[int]) -> list[float]:
    total = sum(weights)
    return [w / total for w in weights]


@_memo
def _entry_focals(case: ModelCase, max_focal: int):
    frame = case.frame
    # half of the conjunctions are drawn among the allowed regions, so that few are rejected
    term = st.one_of(st.sampled_from(sorted(case.allowed)), conjunctions(case.n))
    candidates = (st.lists(term, min_size=1, max_size=3)
                  .map(lambda terms: Element(frame, terms))
                  .filter(lambda e: bool(case.regions(e))))
    return st.lists(candidates, min_size=1, max_size=max_focal, unique=True)


@_memo
def _empty_extras(extras: tuple):
    return st.lists(st.sampled_from(extras), min_size=1, max_size=2, unique=True)


@_memo
@st.composite
def _entries(draw, case: ModelCase, max_focal: int, subnormal: bool) -> tuple[tuple[Element, float], ...]:
    frame = case.frame
    focal = draw(_entry_focals(case, max_focal))
    if subnormal:
        # mass on ∅ itself and/or on an element that the model declares empty
        extras = [frame.empty]
        empty_terms = tuple(t for t in range(1, 1 << case.n) if t not in case.allowed)
        if empty_terms:
            extras.append(Element(frame, [draw(_sampled(empty_terms))]))
        focal += draw(_empty_extras(tuple(extras)))
    weights = draw(weight_lists(1, 20, len(focal)))
    return tuple(zip(focal, _normalised(weights)))


@_memo
@st.composite
def mass_cases(draw, min_n: int = 1, max_n: int = 4, kinds=("free", "shafer", "hybrid", "tracking"),
               subnormal=False, max_focal: int = 5) -> MassCase:
    """Random mass functions under random models.

    ``subnormal`` is False (normal mass functions only), True (always some mass on ∅) or
    None (either).
    """
    case = draw(any_model_cases(min_n, max_n, kinds))
    assume(case.allowed)
    sub = draw(st.booleans()) if subnormal is None else subnormal
    return MassCase(case, draw(_entries(case, max_focal, sub)), sub)



@_memo
def mass_cases_under(case: ModelCase, subnormal=None, max_focal: int = 4):
    """Random mass functions under the given model (``subnormal`` as for :func:`mass_cases`)."""
    flags = st.booleans() if subnormal is None else st.just(subnormal)
    return flags.flatmap(lambda sub: _entries(case, max_focal, sub).map(lambda entries: MassCase(case, entries, sub)))

@_memo
@st.composite
def mass_case_lists(draw, min_n: int = 1, max_n: int = 4, size: int = 4,
                    kinds=("free", "shafer", "hybrid", "tracking"), max_focal: int = 4) -> list[MassCase]:
    """Several normal mass functions under one shared model."""
    case = draw(any_model_cases(min_n, max_n, kinds))
    assume(case.allowed)
    count = draw(st.integers(1, size))
    return [MassCase(case, draw(_entries(case, max_focal, False)), False) for _ in range(count)]


# -- sources for the combination rules ------------------------------------------------------------------


@_memo
def _extra_conjunctions(n: int):
    return st.lists(conjunctions(n), min_size=1, max_size=2)


@_memo
@st.composite
def stricter_cases(draw, case: ModelCase) -> ModelCase:
    """A model at least as strict as ``case`` (it forbids every region that ``case`` forbids).

    Shafer's and the tracking models are offered when they are stricter; otherwise a hybrid
    model that keeps the constraints of ``case`` and declares one or two more conjunctions empty.
    """
    frame, n = case.frame, case.n
    options = ["hybrid"]
    if shafer_allowed(n) <= case.allowed:
        options.append("shafer")
    fas = [i for i in range(n) if n >= 2 and tracking_allowed(n, i) <= case.allowed]
    if fas:
        options.append("tracking")
    kind = draw(_sampled(tuple(options)))
    if kind == "shafer":
        return ModelCase(Model.shafer(frame), shafer_allowed(n), "shafer")
    if kind == "tracking":
        fa = draw(_sampled(tuple(fas)))
        return ModelCase(Model.tracking(frame, frame.hypotheses[fa]), tracking_allowed(n, fa), f"tracking FA={fa}")
    extra = draw(_extra_conjunctions(n))
    texts = [term_text(frame, t) for t in (*case.model.forbidden, *extra)]
    return ModelCase(Model.hybrid(frame, texts), case.allowed & hybrid_allowed(n, extra),
                     f"{case.label} then hybrid {texts}")


@_memo
def focal_lists(case: ModelCase, max_focal: int, prefer=frozenset()):
    """Distinct elements that are not empty under ``case`` (conjunctions drawn partly from ``prefer``)."""
    frame = case.frame
    pools = [st.sampled_from(sorted(case.allowed)), conjunctions(case.n)]
    if prefer:
        pools.append(st.sampled_from(sorted(prefer)))
    candidates = (st.lists(st.one_of(*pools), min_size=1, max_size=3)
                  .map(lambda terms: Element(frame, terms))
                  .filter(lambda e: bool(case.regions(e))))
    return st.lists(candidates, min_size=1, max_size=max_focal, unique=True)


@dataclass(frozen=True)
class FusionCase:
    """s ≥ 2 sources elicited under one model, and the (possibly stricter) fusion model.

    ``sources[k]`` lists (element as given, exact mass) pairs; masses are Fractions that sum
    to one, handed to the library as floats.
    """

    source: ModelCase
    fusion: ModelCase
    sources: tuple[tuple[tuple[Element, Fraction], ...], ...]

    @property
    def dynamic(self) -> bool:
        return self.fusion.allowed != self.source.allowed

    def build(self) -> list[MassFunction]:
        return [MassFunction({e: float(v) for e, v in s}, model=self.source.model) for s in self.sources]


def exact_weights(weights: list[int]) -> list[Fraction]:
    total = sum(weights)
    return [Fraction(w, total) for w in weights]


@_memo
@st.composite
def fusion_cases(draw, min_sources: int = 2, max_sources: int = 4, min_n: int = 1, max_n: int = 4,
                 kinds=("free", "shafer", "hybrid", "tracking"), dynamic=False, max_focal: int = 3) -> FusionCase:
    """Random sources under a random model; ``dynamic`` True (stricter fusion model), False or None."""
    case = draw(any_model_cases(min_n, max_n, kinds))
    assume(case.allowed)
    fusion = case
    if dynamic is None:
        dynamic = draw(st.booleans())
    if dynamic:
        fusion = draw(stricter_cases(case))
        assume(fusion.allowed)
    count = draw(st.integers(min_sources, max_sources))
    sources = []
    for _ in range(count):
        focal = draw(focal_lists(case, max_focal, prefer=fusion.allowed))
        weights = draw(weight_lists(1, 12, len(focal)))
        sources.append(tuple(zip(focal, exact_weights(weights))))
    return FusionCase(case, fusion, tuple(sources))



# -- mass functions on 2^Θ as exact masses of subsets (representations, cautious and bold rules) ------------


def subset_text(frame: Frame, mask: int) -> str:
    """A subset of Θ (bit i = the i-th hypothesis) written by hand: names joined by '|', or 'empty'."""
    names = [name for i, name in enumerate(frame.hypotheses) if mask >> i & 1]
    return "|".join(names) if names else "empty"


@dataclass(frozen=True)
class SubsetMass:
    """A mass function on Shafer's model as exact masses of subsets (bit masks over the hypotheses)."""

    frame: Frame
    masses: tuple[tuple[int, Fraction], ...]

    @property
    def n(self) -> int:
        return len(self.frame)

    @property
    def model(self) -> Model:
        return Model.shafer(self.frame)

    def exact(self) -> dict[int, Fraction]:
        return dict(self.masses)

    def build(self) -> MassFunction:
        return MassFunction({subset_text(self.frame, mask): float(v) for mask, v in self.masses},
                            model=self.model, subnormal=True)


@_memo
def _subset_lists(full: int, max_focal: int):
    return st.lists(st.integers(1, full), min_size=1, max_size=max_focal)


@_memo
@st.composite
def subset_masses(draw, frame: Frame | None = None, min_n: int = 1, max_n: int = 4, max_focal: int = 5,
                  total=None, empty=None) -> SubsetMass:
    """Random mass functions on Shafer's model with exact masses.

    ``total`` True forces m(Θ) > 0 (non-dogmatic), False forbids it, None leaves it to chance;
    ``empty`` does the same for m(∅) (True: subnormal, False: normal).
    """
    if frame is None:
        frame = draw(frames(min_n, max_n))
    n = len(frame)
    full = (1 << n) - 1
    chosen = set(draw(_subset_lists(full, max_focal)))
    if empty is None:
        empty = draw(st.booleans())
    if empty:
        chosen.add(0)
    else:
        chosen.discard(0)
    if total is True:
        chosen.add(full)
    elif total is False:
        chosen.discard(full)
        if not chosen - {0}:
            chosen.add(draw(st.integers(1, full - 1)) if full > 1 else 0)
    assume(chosen and (empty is not False or chosen - {0}))
    focal = sorted(chosen)
    weights = draw(weight_lists(1, 12, len(focal)))
    return SubsetMass(frame, tuple(zip(focal, exact_weights(weights))))


@_memo
@st.composite
def subset_mass_lists(draw, min_sources: int = 2, max_sources: int = 3, min_n: int = 1, max_n: int = 3,
                      max_focal: int = 4, total=None, empty=None) -> list[SubsetMass]:
    """Several exact mass functions on Shafer's model of one frame (options as :func:`subset_masses`)."""
    frame = draw(frames(min_n, max_n))
    count = draw(st.integers(min_sources, max_sources))
    return [draw(subset_masses(frame, max_focal=max_focal, total=total, empty=empty)) for _ in range(count)]
