"""Property-based testing for users of :mod:`belief`: Hypothesis strategies and a law checker for rules.

Hypothesis is an optional dependency (``pip install 'belief-dsmt[testing]'``); this module
imports it at once and raises :class:`ImportError` without it.

Strategies
----------
:func:`frames`, :func:`models`, :func:`elements`, :func:`mass_functions`,
:func:`mass_batches` and :func:`bayesian_sources` draw the library's own objects.  Every
mass is a small integer weight (1 to :data:`MAX_WEIGHT`) divided by the sum of the
weights, so no mass is tiny, no sum cancels and laws can be compared with a tolerance of
1e-9.  The choices are made so that Hypothesis shrinks a counterexample towards something
a person reads at a glance:

* frames shrink towards the fewest hypotheses (``t1``, ``t2``, …);
* models towards the first kind asked for (the free model by default), hybrid models
  towards one exclusivity constraint between two hypotheses, tracking models towards
  ``t1`` as the false alarm;
* elements towards a single hypothesis, then towards few conjunctions of few hypotheses;
* mass functions towards one focal element (a categorical mass function), and weights
  towards 1, that is towards equal masses.

:func:`simplest` shows where a strategy shrinks to.

The law checker
---------------
:func:`check_rule` runs Hypothesis over the laws that a combination rule of the registry
claims (mass conservation, no negative mass, commutativity, associativity, neutrality of the
vacuous mass function, idempotence, and batch = row by row).  A failing law raises
:class:`AssertionError` naming the law, with the shrunk counterexample.

>>> from belief.testing import check_rule
>>> check_rule("conjunctive", vacuous_neutral=True, max_examples=5)
RuleReport(rule='conjunctive', laws=('mass conservation', 'no negative mass', 'commutativity', 'associativity', \
'vacuous neutrality', 'batch = row by row'))
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from contextlib import nullcontext
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any, Union

try:
    import hypothesis
    from hypothesis import strategies as st
    from hypothesis.errors import FailedHealthCheck, Unsatisfiable
    from hypothesis.strategies import SearchStrategy
except ImportError as exc:  # pragma: no cover - exercised in a subprocess by the tests
    from belief.install import install_command

    raise ImportError("belief.testing needs Hypothesis, an optional dependency: "
                      f"{install_command('testing')}") from exc

import numpy as np

from belief.batch import MassBatch
from belief.errors import BeliefError
from belief.mass import MassFunction
from belief.model import Model
from belief.rules import RuleInfo, combine, get_rule
from belief.strategies import (KINDS, MAX_WEIGHT, ModelLike, bayesian_sources, bayesian_sources_under, cached_integers,
                               check_kinds, check_positive, elements, frames, mass_batches, mass_batches_under,
                               mass_functions, mass_functions_under, models, simplest)

try:  # Hypothesis prints some reports (how to reproduce a failure); they go into the error instead.
    from hypothesis.reporting import with_reporter
except ImportError:  # pragma: no cover - an older or newer Hypothesis without it
    with_reporter = None

__all__ = ["KINDS", "LAWS", "MAX_WEIGHT", "RuleReport", "bayesian_sources", "check_rule", "elements", "frames",
           "mass_batches", "mass_functions", "models", "simplest"]


#: The laws :func:`check_rule` knows, in the order it checks them.
LAWS = ("mass conservation", "no negative mass", "commutativity", "associativity", "vacuous neutrality",
        "idempotence", "batch = row by row")


# -- the law checker ----------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RuleReport:
    """What :func:`check_rule` verified: the laws that held, and on how many inputs.

    Attributes
    ----------
    rule : str
        The rule's name in the registry.
    laws : tuple of str
        The laws checked (every one held), in the order of :data:`LAWS`.
    examples : dict
        For each law, the number of inputs the rule accepted and the law was checked on.
    refused : dict
        For each law, the number of inputs the rule refused (skipped, not failures).
    """

    rule: str
    laws: tuple[str, ...]
    examples: Mapping[str, int] = field(default_factory=dict, repr=False, compare=False)
    refused: Mapping[str, int] = field(default_factory=dict, repr=False, compare=False)

    def __str__(self) -> str:
        width = max(len(law) for law in self.laws)
        count = len(self.laws)
        lines = [f"rule {self.rule!r}: {count} law{'s hold' if count != 1 else ' holds'}"]
        for law in self.laws:
            lines.append(f"  {law:<{width}}  {self.examples.get(law, 0)} inputs, "
                         f"{self.refused.get(law, 0)} refused")
        return "\n".join(lines)


def check_rule(rule: Union[str, RuleInfo], *, associative: bool | None = None, commutative: bool = True,
               vacuous_neutral: bool | None = None, idempotent: bool = False, kinds: Sequence[str] = KINDS,
               max_hypotheses: int = 3, max_sources: int = 3, max_focal: int = 3, subnormal: bool | None = False,
               nondogmatic: bool = False, options: Mapping[str, Any] | None = None,
               may_raise: Union[type[BaseException], tuple[type[BaseException], ...]] = BeliefError,
               max_examples: int = 100, tol: float = 1e-9, settings: hypothesis.settings | None = None) -> RuleReport:
    """Check with Hypothesis the laws that a combination rule claims; raise AssertionError on the first that fails.

    The sources are mass functions of :func:`mass_functions` under one model of
    :func:`models` (frames of 1 to ``max_hypotheses`` hypotheses), 2 to ``max_sources`` of
    them.  The laws, each run on ``max_examples`` inputs:

    * **mass conservation**: every result's masses sum to one within ``tol``, m(∅)
      included if the rule keeps conflict (``RuleInfo.keeps_conflict``), else m(∅) = 0;
    * **no negative mass**: no mass below -``tol`` (read from the values of a batch result,
      which keep what a MassFunction drops);
    * **commutativity**: the order of the sources does not change the result;
    * **associativity**: ``combine(m1, m2, m3)`` equals both pairwise folds
      ``combine(combine(m1, m2), m3)`` and ``combine(m1, combine(m2, m3))``;
    * **vacuous neutrality**: adding the vacuous mass function (first or last) to one or
      more sources changes nothing;
    * **idempotence**: ``combine(m, m)`` (and ``combine(m, m, m)``) is m;
    * **batch = row by row**: combining batches (of N rows, or one row broadcast, including
      Bayesian batches that take the closed forms) gives, row by row, what combining the
      rows' mass functions gives, masses and Bel, Pls, BetP of the hypotheses alike.

    Mass conservation and no negative mass are checked on every result of every law.  An
    input that the rule refuses with an exception of ``may_raise`` (Dempster's rule at total
    conflict, a dogmatic source for the cautious rule) is skipped, not a failure; but a law
    whose every input is refused fails, for then nothing was checked, and so does a rule
    that accepts an input in one form and refuses it in another (one order of the sources
    but not the other, a batch but not its rows).  Any other exception propagates.

    Parameters
    ----------
    rule : str or RuleInfo
        A name of the registry (:func:`belief.rules.register_rule`) or a RuleInfo.
    associative : bool, optional
        Claim associativity; by default what the registry says (``RuleInfo.associative``).
    commutative : bool
        Claim commutativity (every rule of the library is, for two sources).
    vacuous_neutral : bool, optional
        Claim that the vacuous mass function is neutral; None (the registry records no
        neutral element) or False: not checked.
    idempotent : bool
        Claim idempotence.
    kinds : sequence of str
        The kinds of model the sources are drawn under (see :func:`models`).
    max_hypotheses : int
        Frames of 1 to this many hypotheses.
    max_sources : int
        2 to this many sources (associativity needs 3).
    max_focal : int
        Focal elements per source, see :func:`mass_functions`.
    subnormal : bool or None
        Mass on ∅ in the sources: never (False), always (True, as the bold rule needs) or
        either (None).
    nondogmatic : bool
        Every source has m(Θ) > 0 (as the cautious rule needs).
    options : mapping, optional
        Keyword options of the rule, passed to every :func:`~belief.rules.combine`.
    may_raise : exception class or tuple of them
        How the rule may refuse an input; by default any
        :class:`~belief.errors.BeliefError`.  Name the ones it should raise (e.g.
        ``TotalConflictError`` for Dempster's rule) to see any other as a failure: a rule
        that checks its own result with ``MassBatch(..., validate=True)`` turns lost mass
        into an :class:`~belief.errors.InvalidMassError`, a refusal by default.
    max_examples : int
        Inputs per law.
    tol : float
        Absolute tolerance on every mass and measure compared.
    settings : hypothesis.settings, optional
        Further Hypothesis settings (``derandomize``, ``phases``, ``database``, …); check_rule
        sets ``max_examples``, no deadline and one reported failure on top of them, and leaves
        out the explain phase (it would only point at lines of the checker).

    Returns
    -------
    RuleReport
        The rule and the laws that held; ``str()`` of it tells on how many inputs.

    Raises
    ------
    AssertionError
        A law fails (the message names it and shows the counterexample), or the rule
        refused every input of a law.
    UnknownRuleError
        ``rule`` is not in the registry.
    ValueError
        Claims or bounds that cannot be checked (associativity with ``max_sources`` < 3).

    Examples
    --------
    The cautious rule on Shafer's model, with the non-dogmatic sources it accepts:

    >>> report = check_rule("cautious", idempotent=True, kinds=("shafer",), nondogmatic=True, max_examples=10)
    >>> report.laws
    ('mass conservation', 'no negative mass', 'commutativity', 'associativity', 'idempotence', 'batch = row by row')

    Claiming a law that does not hold: PCR6 is not associative.

    >>> try:
    ...     check_rule("pcr6", associative=True, max_examples=100)
    ... except AssertionError as error:
    ...     print(str(error).splitlines()[0])
    associativity fails for rule 'pcr6': combine(m1, m2, m3) differs from combine(combine(m1, m2), m3)
    """
    info = get_rule(rule)
    if associative is None:
        associative = info.associative
    kinds = check_kinds(kinds)
    if isinstance(max_sources, bool) or not isinstance(max_sources, int) or max_sources < 2:
        raise ValueError(f"max_sources must be an integer of at least 2, got {max_sources!r}")
    check_positive("max_hypotheses", max_hypotheses)
    check_positive("max_focal", max_focal)
    check_positive("max_examples", max_examples)
    if associative and max_sources < 3:
        raise ValueError("associativity needs three sources: max_sources must be at least 3")
    if not tol >= 0:
        raise ValueError(f"tol must be a non-negative number, got {tol!r}")
    if isinstance(may_raise, type):
        may_raise = (may_raise,)
    may_raise = tuple(may_raise)
    if not all(isinstance(error, type) and issubclass(error, BaseException) for error in may_raise):
        raise TypeError(f"may_raise must be an exception class or a tuple of them, got {may_raise!r}")
    checker = _Checker(info, dict(options or {}), tol, max_sources, may_raise)
    model_strategy = models(frames(1, max_hypotheses), kinds)

    def sources(low: int, high: int) -> SearchStrategy:
        return model_strategy.flatmap(lambda model: _source_tuples(model, low, high, max_focal, subnormal,
                                                                   nondogmatic))

    # The laws claimed first: mass conservation and no negative mass are checked on their results too, and a
    # claim that does not hold shows at once.
    runs: list[tuple[str, SearchStrategy, Callable]] = []
    if commutative:
        runs.append(("commutativity", _permuted(sources(2, max_sources)), checker.commutativity))
    if associative:
        runs.append(("associativity", sources(3, 3), checker.associativity))
    if vacuous_neutral:
        runs.append(("vacuous neutrality", sources(1, max_sources - 1), checker.vacuous_neutrality))
    if idempotent:
        runs.append(("idempotence", sources(1, 1), checker.idempotence))
    runs.append(("mass conservation", sources(2, max_sources), checker.conservation))
    bayesian_too = not nondogmatic and subnormal is not True
    runs.append(("batch = row by row",
                 model_strategy.flatmap(lambda model: _batch_sources(model, max_sources, max_focal, subnormal,
                                                                     nondogmatic, bayesian_too)),
                 checker.batch_rows))
    base = settings if settings is not None else hypothesis.settings()
    run_settings = hypothesis.settings(
        base, max_examples=max_examples, deadline=None, report_multiple_bugs=False,
        # The explain phase would only point at lines of the checker, and it takes time.
        phases=[phase for phase in base.phases if phase != hypothesis.Phase.explain],
        # Not filter_too_much: a rule that refuses nearly every input fails early, for nothing would be checked.
        suppress_health_check=sorted(set(base.suppress_health_check) | {
            hypothesis.HealthCheck.too_slow, hypothesis.HealthCheck.data_too_large}, key=lambda h: h.name))
    for law, strategy, check in runs:
        checker.run(law, strategy, check, run_settings)
    laws = tuple(law for law in LAWS if law in checker.examples or law == "no negative mass")
    total = sum(checker.examples.values())
    examples = {**checker.examples, "no negative mass": total}
    refused = {**checker.refused, "no negative mass": sum(checker.refused.values())}
    return RuleReport(info.name, laws, examples, refused)


@lru_cache(maxsize=1024)
def _source_tuples(model: Model, low: int, high: int, max_focal: int, subnormal: bool | None,
                   nondogmatic: bool) -> SearchStrategy:
    return st.lists(mass_functions_under(model, max_focal, subnormal, nondogmatic, MAX_WEIGHT),
                    min_size=low, max_size=high).map(tuple)


@lru_cache(maxsize=64)
def _orders(count: int, moved: bool) -> SearchStrategy:
    """Permutations of range(count); ``moved``: not the identity.  They shrink towards swapping the first two."""
    orders = st.permutations(range(count))
    return orders.filter(lambda order: list(order) != sorted(order)) if moved else orders


@st.composite
def _permuted(draw, sources: SearchStrategy) -> tuple[tuple, tuple]:
    """(sources, the same in another order)."""
    ms = draw(sources)
    order = draw(_orders(len(ms), True))
    return ms, tuple(ms[k] for k in order)


@lru_cache(maxsize=1024)
def _broadcast_sources(model: Model, n_rows: int, max_focal: int, subnormal: bool | None,
                       nondogmatic: bool) -> tuple[SearchStrategy, SearchStrategy]:
    """An N-row batch, and one of: an N-row batch, a one-row batch, a mass function (the last two broadcast)."""
    batch = mass_batches_under(model, n_rows, n_rows, max_focal, subnormal, nondogmatic, MAX_WEIGHT)
    one_row = mass_batches_under(model, 1, 1, max_focal, subnormal, nondogmatic, MAX_WEIGHT)
    single = mass_functions_under(model, max_focal, subnormal, nondogmatic, MAX_WEIGHT)
    return batch, st.one_of(batch, one_row, single)


@lru_cache(maxsize=1024)
@st.composite
def _batch_sources(draw, model: Model, max_sources: int, max_focal: int, subnormal: bool | None,
                   nondogmatic: bool, bayesian_too: bool) -> tuple:
    """2 to max_sources sources for the batch law: N-row batches, one-row batches and mass functions (broadcast)."""
    n_rows = draw(cached_integers(1, 3))
    if bayesian_too and draw(cached_integers(0, 1)):
        return _Shown(draw(bayesian_sources_under(model, 2, max_sources, n_rows, n_rows, MAX_WEIGHT)))
    count = draw(cached_integers(2, max_sources))
    batch, any_source = _broadcast_sources(model, n_rows, max_focal, subnormal, nondogmatic)
    out = [draw(batch)]                        # one N-row batch at least, so that the result is a batch
    out += [draw(any_source) for _ in range(count - 1)]
    order = draw(_orders(count, False))
    return _Shown(out[k] for k in order)


class _Shown(tuple):
    """Sources that print as the calls that build them: a MassBatch's own repr gives only its shape."""

    def __repr__(self) -> str:
        return "(" + ", ".join(_source_repr(source) for source in self) + ")"


def _source_repr(source) -> str:
    if not isinstance(source, MassBatch):
        return repr(source)
    subnormal = ", subnormal=True" if any(not e.terms for e in source.focal) else ""
    return (f"MassBatch({[str(e) for e in source.focal]!r}, {source.values.tolist()!r}, "
            f"model={source.model!r}{subnormal})")


@dataclass(frozen=True)
class _Refusal:
    """A combination the rule refused (with an exception of ``may_raise``), or a measure that is undefined."""

    error: BaseException

    def __str__(self) -> str:
        return f"refused ({type(self.error).__name__}: {self.error})"


class _Checker:
    """The law checks of one rule: each takes one drawn input, rejects it if refused, and raises AssertionError."""

    def __init__(self, info: RuleInfo, options: dict, tol: float, max_sources: int,
                 may_raise: tuple[type[BaseException], ...]) -> None:
        self.info = info
        self.may_raise = may_raise
        self.max_sources = max_sources
        self.options = options
        self.tol = tol
        self.law = ""
        self.examples: dict[str, int] = {}
        self.refused: dict[str, int] = {}
        self.last_refusal: _Refusal | None = None

    # -- running one law ------------------------------------------------------------------------------------
    def run(self, law: str, strategy: SearchStrategy, check: Callable, run_settings: hypothesis.settings) -> None:
        self.law = law
        self.examples[law] = 0
        self.refused[law] = 0
        self.last_refusal = None

        def law_holds(case):
            check(case)
            self.examples[law] += 1

        # Failures print as a call of this name; the digest keeps the rules and laws apart in the example database.
        law_holds.__name__ = law_holds.__qualname__ = "check_" + "_".join(law.replace("=", "equals").split())
        law_holds._hypothesis_internal_add_digest = f"{self.info.name}|{law}".encode()
        law_holds = run_settings(hypothesis.given(strategy)(law_holds))
        reports: list[str] = []
        capture = with_reporter(reports.append) if with_reporter is not None else nullcontext()
        try:
            with capture:
                law_holds()
        except (Unsatisfiable, FailedHealthCheck) as error:
            if isinstance(error, FailedHealthCheck) and "filter_too_much" not in str(error):
                raise
            how = "every" if isinstance(error, Unsatisfiable) or not self.examples[law] else "nearly every"
            refusal = f" ({type(self.last_refusal.error).__name__}: {self.last_refusal.error})" \
                if self.last_refusal else ""
            raise AssertionError(
                f"{law}: rule {self.info.name!r} refused {how} input generated to check it{refusal}; draw inputs "
                "it accepts (kinds=, subnormal=, nondogmatic=, options=) or do not claim the law") from None
        except AssertionError as error:
            for line in reports:
                if hasattr(error, "add_note"):
                    error.add_note(line)
            raise

    def combine(self, *sources):
        """The result, or a _Refusal; materialised (a lazy closed-form batch may refuse only when read)."""
        try:
            result = combine(*sources, rule=self.info, **self.options)
            if isinstance(result, MassBatch):
                result.values
            return result
        except self.may_raise as error:
            return _Refusal(error)

    def skip(self, refusal: _Refusal) -> None:
        self.last_refusal = refusal
        self.refused[self.law] += 1
        hypothesis.reject()

    def fail(self, law: str, message: str) -> None:
        raise AssertionError(f"{law} fails for rule {self.info.name!r}: {message}")

    # -- what every result must satisfy ------------------------------------------------------------------------
    def valid(self, result, what: str, sources: tuple = ()) -> None:
        """Mass conservation and no negative mass, for a MassFunction or every row of a MassBatch.

        A MassFunction result keeps only the positive masses, so when its masses do not sum to one,
        the same ``sources`` are combined as batches to see whether negative masses were dropped.
        """
        if isinstance(result, MassFunction) and sources and not abs(math.fsum(result.values) - 1.0) <= self.tol:
            raw = self.combine(*(s.batch() if isinstance(s, MassFunction) else s for s in sources))
            if not isinstance(raw, _Refusal):
                for k, value in enumerate(raw.values[0].tolist()):
                    if not value >= -self.tol:
                        self.fail("no negative mass", f"{what} gives m({raw.focal[k]}) = {value:.12g}")
        rows = result.values.reshape(1, -1) if isinstance(result, MassFunction) else result.values
        empty = [k for k, e in enumerate(result.focal) if not e.terms]
        for k, row in enumerate(rows.tolist()):
            where = f"{what}, row {k}" if isinstance(result, MassBatch) else what
            negative = [(result.focal[j], v) for j, v in enumerate(row) if not v >= -self.tol]
            if negative:
                element, value = negative[0]
                self.fail("no negative mass", f"{where} gives m({element}) = {value:.12g}")
            total = math.fsum(row)
            if not abs(total - 1.0) <= self.tol:
                self.fail("mass conservation", f"the masses of {where} sum to {total:.12g}, not 1"
                          + (" (m(∅) included)" if self.info.keeps_conflict else ""))
            if empty and not self.info.keeps_conflict and not row[empty[0]] <= self.tol:
                self.fail("mass conservation", f"{where} puts {row[empty[0]]:.12g} on ∅, but the rule is registered "
                          "with keeps_conflict=False (its masses must sum to 1 without m(∅))")

    def outcome(self, *sources, what: str):
        result = self.combine(*sources)
        if not isinstance(result, _Refusal):
            self.valid(result, what, sources)
        return result

    def same(self, law: str, first, second, first_text: str, second_text: str) -> None:
        """Fail unless two outcomes agree: both refused, or mass functions equal within tol."""
        if isinstance(first, _Refusal) and isinstance(second, _Refusal):
            self.skip(first)
        if isinstance(first, _Refusal) or isinstance(second, _Refusal):
            self.fail(law, f"{first_text} is {_show(first)} but {second_text} is {_show(second)}")
        difference = _difference(first, second)
        if difference is not None and not difference[0] <= self.tol:
            self.fail(law, f"{first_text} differs from {second_text}\n  {first_text} = {_show(first)}\n"
                           f"  {second_text} = {_show(second)}\n  m({difference[1]}) differs by "
                           f"{difference[0]:.3g} (tolerance {self.tol:g})")

    # -- the laws ------------------------------------------------------------------------------------------------
    def conservation(self, sources: tuple) -> None:
        # The sources as one-row batches first: the raw values of a batch show every mass, where a
        # MassFunction keeps only the positive ones.
        batch = self.outcome(*(m.batch() for m in sources), what=_call(len(sources), "b"))
        result = self.outcome(*sources, what=_call(len(sources)))
        if isinstance(result, _Refusal) and isinstance(batch, _Refusal):
            self.skip(result)
        if isinstance(result, _Refusal) or isinstance(batch, _Refusal):
            self.fail("batch = row by row", f"{_call(len(sources))} is {_show(result)} but the same sources as "
                                            f"one-row batches give {_show(batch)}")

    def commutativity(self, case: tuple) -> None:
        sources, shuffled = case
        # By identity: two sources may be equal mass functions.
        order = [next(k for k, m in enumerate(sources, 1) if m is s) for s in shuffled]
        text = "combine(" + ", ".join(f"m{k}" for k in order) + ")"
        self.same("commutativity", self.outcome(*sources, what=_call(len(sources))),
                  self.outcome(*shuffled, what=text), _call(len(sources)), text)

    def associativity(self, sources: tuple) -> None:
        m1, m2, m3 = sources
        joint = self.outcome(m1, m2, m3, what="combine(m1, m2, m3)")
        left = self.outcome(m1, m2, what="combine(m1, m2)")
        if not isinstance(left, _Refusal):
            left = self.outcome(left, m3, what="combine(combine(m1, m2), m3)")
        self.same("associativity", joint, left, "combine(m1, m2, m3)", "combine(combine(m1, m2), m3)")
        right = self.outcome(m2, m3, what="combine(m2, m3)")
        if not isinstance(right, _Refusal):
            right = self.outcome(m1, right, what="combine(m1, combine(m2, m3))")
        self.same("associativity", joint, right, "combine(m1, m2, m3)", "combine(m1, combine(m2, m3))")

    def vacuous_neutrality(self, sources: tuple) -> None:
        vacuous = MassFunction.vacuous(model=sources[0].model)
        if len(sources) == 1:
            (m1,) = sources
            for pair, text in (((m1, vacuous), "combine(m1, vacuous)"), ((vacuous, m1), "combine(vacuous, m1)")):
                result = self.outcome(*pair, what=text)
                if isinstance(result, _Refusal):
                    self.skip(result)
                self.same("vacuous neutrality", result, m1, text, "m1")
            return
        plain = _call(len(sources))
        without = self.outcome(*sources, what=plain)
        names = plain[len("combine("):-1]
        self.same("vacuous neutrality", self.outcome(*sources, vacuous, what=f"combine({names}, vacuous)"),
                  without, f"combine({names}, vacuous)", plain)
        self.same("vacuous neutrality", self.outcome(vacuous, *sources, what=f"combine(vacuous, {names})"),
                  without, f"combine(vacuous, {names})", plain)

    def idempotence(self, sources: tuple) -> None:
        (m,) = sources
        result = self.outcome(m, m, what="combine(m, m)")
        if isinstance(result, _Refusal):
            self.skip(result)
        self.same("idempotence", result, m, "combine(m, m)", "m")
        if self.max_sources >= 3:
            self.same("idempotence", self.outcome(m, m, m, what="combine(m, m, m)"), m, "combine(m, m, m)", "m")

    def batch_rows(self, sources: tuple) -> None:
        n_rows = max(len(s) if isinstance(s, MassBatch) else 1 for s in sources)
        fused = self.combine(*sources)
        closed_form: dict[str, np.ndarray] = {}
        if not isinstance(fused, _Refusal) and type(fused) is not MassBatch:
            # A closed-form batch (belief.bayesian): its measures of the hypotheses come from the closed forms,
            # for every hypothesis (a table) or one per row (select=), whatever the general combination gives.
            hypotheses = list(fused.frame.singletons)
            select = np.arange(n_rows) % len(hypotheses)
            for measure in ("bel", "pls", "betp", "mass"):
                table = _attempt(lambda: getattr(fused, measure)(hypotheses))
                if not isinstance(table, _Refusal):
                    closed_form[measure] = table
                    closed_form[f"{measure} (select=)"] = getattr(fused, measure)(hypotheses, select=select)
            closed_form["m(∅)"] = fused.empty_mass
        if not isinstance(fused, _Refusal):
            self.valid(fused, _call(len(sources), "b"))
        per_row = []
        for k in range(n_rows):
            row_sources = [s[k if len(s) > 1 else 0] if isinstance(s, MassBatch) else s for s in sources]
            per_row.append(self.outcome(*row_sources, what=f"{_call(len(sources))} of row {k}"))
        refused = [r for r in per_row if isinstance(r, _Refusal)]
        if isinstance(fused, _Refusal):
            if refused:
                self.skip(fused)
            self.fail("batch = row by row", f"combining the batches is {fused}, but every row combines")
        if refused:
            k = next(k for k, r in enumerate(per_row) if isinstance(r, _Refusal))
            self.fail("batch = row by row", f"combining the batches gives a result, but row {k} is {refused[0]}")
        if len(fused) != n_rows:
            self.fail("batch = row by row", f"combining batches of {n_rows} rows gives {len(fused)} rows")
        for k, expected in enumerate(per_row):
            self.same("batch = row by row", fused[k], expected, f"row {k} of the combined batches",
                      f"the combination of row {k}'s mass functions")
            for measure, values in closed_form.items():
                wanted = _attempt(lambda: _measure(expected, measure))
                if isinstance(wanted, _Refusal):
                    continue
                if measure.endswith("(select=)"):
                    wanted = wanted[k % len(wanted)]
                got = np.asarray(values[k], dtype=float)
                if not np.all(np.abs(got - wanted) <= self.tol):
                    self.fail("batch = row by row", f"row {k} of the closed-form batch has {measure} "
                                                    f"{got.tolist()} of the hypotheses, the combination of the "
                                                    f"row's mass functions {np.asarray(wanted).tolist()}")


def _measure(m: MassFunction, measure: str) -> np.ndarray:
    """A measure of a mass function as :meth:`_Checker.batch_rows` names it: of every hypothesis, or m(∅)."""
    if measure == "m(∅)":
        return np.asarray(m.empty_mass)
    name = measure.split()[0]
    return np.asarray(getattr(m.batch(), name)(list(m.frame.singletons))[0], dtype=float)


def _attempt(compute: Callable):
    try:
        return compute()
    except BeliefError as error:
        return _Refusal(error)


def _call(count: int, prefix: str = "m") -> str:
    return "combine(" + ", ".join(f"{prefix}{k}" for k in range(1, count + 1)) + ")"


def _show(result) -> str:
    if isinstance(result, _Refusal):
        return str(result)
    return "{" + ", ".join(f"{str(e)!r}: {v:.12g}" for e, v in result.items()) + "}"


def _difference(first: MassFunction, second: MassFunction) -> tuple[float, Any] | None:
    """The largest difference of mass between two mass functions, and where (inf if their models differ)."""
    if first.model != second.model:
        return math.inf, f"any element: the models differ, {first.model!r} and {second.model!r}"
    mine = dict(first.items())
    theirs = dict(second.items())
    worst = None
    for element in set(mine) | set(theirs):
        gap = abs(mine.get(element, 0.0) - theirs.get(element, 0.0))
        if math.isnan(gap):
            gap = math.inf
        if worst is None or gap > worst[0]:
            worst = (gap, element)
    return worst
