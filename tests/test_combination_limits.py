"""The limits of a combination (belief.plan), pairwise folds of associative rules, and valid outputs.

Joint rules (PCR5, PCR6, DSmH, Dubois–Prade) visit every tuple of focal elements: their
cost is estimated before they start, with Python ints, and a job over the limits is refused
with a :class:`CombinationTooLargeError` that names the limit.  Associative rules fold
pairwise, each step checked first.  These tests do not time anything: a refusal or a result
is what they check.
"""

from __future__ import annotations

import itertools
import json
import math
import random

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import belief.plan as plan_module
from belief import (
    CombinationTooLargeError,
    Frame,
    InvalidMassError,
    MassBatch,
    MassFunction,
    Model,
    ResourceLimitError,
    TotalConflictError,
    combine,
)
from belief.batch import SUM_TOLERANCE
from belief.cli import main
from belief.rules import RULES

AB = Model.shafer(Frame(["a", "b"]))
JOINT = ("pcr5", "pcr6", "dsmh", "dubois_prade")
ASSOCIATIVE = tuple(name for name, info in RULES.items() if info.associative)


def halves(count: int) -> list[MassFunction]:
    return [MassFunction({"a": 0.5, "b": 0.5}, model=AB) for _ in range(count)]


def test_the_rules_of_the_conjunctive_and_disjunctive_kind_are_associative():
    assert {"conjunctive", "dsmc", "dempster", "disjunctive"} <= set(ASSOCIATIVE)
    assert not set(JOINT) & set(ASSOCIATIVE)


# -- the reproducers: 64 sources (2^64 tuples wrap an int64), 24 × 2, 25 × 5 ------------------------------
@pytest.mark.parametrize("rule", JOINT)
def test_64_sources_of_two_focal_elements_are_refused_by_the_joint_rules(rule):
    with pytest.raises(CombinationTooLargeError, match=r"18,446,744,073,709,551,616 tuples.*MAX_TUPLES"):
        combine(*halves(64), rule=rule)
    with pytest.raises(CombinationTooLargeError, match="MAX_TUPLES"):
        combine(*[m.batch() for m in halves(64)], rule=rule, engine="general")


@pytest.mark.parametrize("rule", ["dempster", "conjunctive", "disjunctive", "dsmc", "yager"])
def test_64_sources_fold_pairwise(rule):
    fused = combine(*halves(64), rule=rule)
    assert math.isclose(math.fsum(fused.values), 1.0, abs_tol=1e-12)
    if rule == "dempster":
        assert fused.to_mapping() == pytest.approx({"a": 0.5, "b": 0.5}, abs=1e-12)


def test_the_64_source_reproducer_ends_with_one_line_on_the_command_line(tmp_path, capsys):
    paths = []
    for k in range(64):
        path = tmp_path / f"s{k}.json"
        path.write_text(json.dumps({"frame": ["a", "b"], "model": {"type": "shafer"}, "mass": {"a": 0.5, "b": 0.5}}))
        paths.append(str(path))
    assert main(["combine", "--rule", "dsmh", *paths]) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "belief.plan.MAX_TUPLES" in err


@pytest.mark.parametrize("rule", JOINT)
def test_24_sources_of_two_focal_elements_are_refused(rule):
    with pytest.raises(CombinationTooLargeError, match="16,777,216 tuples"):
        combine(*halves(24), rule=rule)


def free_sources(count: int = 25, seed: int = 1) -> list[MassFunction]:
    """Sources of five focal elements (unions of up to three hypotheses) on a free ten-hypothesis frame."""
    names = [f"h{k}" for k in range(10)]
    model = Model.free(Frame(names))
    rng = random.Random(seed)
    sources = []
    for _ in range(count):
        elements: set[str] = set()
        while len(elements) < 5:
            elements.add("|".join(sorted(rng.sample(names, rng.randint(1, 3)))))
        weights = [rng.random() for _ in elements]
        total = sum(weights)
        sources.append(MassFunction({e: w / total for e, w in zip(sorted(elements), weights)}, model=model))
    return sources


@pytest.mark.parametrize("rule", ["dempster", "conjunctive", "disjunctive"])
def test_25_sources_of_five_focal_elements_on_a_free_frame_end_quickly(rule):
    # Intersections on the free model grow at every step of the fold; unions soon reach Θ.
    try:
        fused = combine(*free_sources(), rule=rule)
    except CombinationTooLargeError as exc:
        assert "belief.plan.MAX_ELEMENT_TUPLES" in str(exc) and "\n" not in str(exc)
    else:
        assert math.isclose(math.fsum(fused.values), 1.0, abs_tol=1e-12)


# -- the limits -----------------------------------------------------------------------------------------
def test_the_refusal_is_a_resource_limit_and_an_invalid_mass_error():
    assert issubclass(CombinationTooLargeError, ResourceLimitError)
    assert issubclass(CombinationTooLargeError, InvalidMassError)      # as such refusals used to be


def test_tuple_counts_never_wrap():
    assert plan_module.joint_cost([2] * 64).tuples == 2 ** 64
    assert plan_module.joint_cost([5] * 25, rows=3).work == 5 ** 25 * 25 * 11


@pytest.mark.parametrize("limit, value", [("MAX_TUPLES", 242), ("MAX_WORK", 1000), ("MAX_BYTES", 1000)])
def test_each_limit_is_read_when_a_combination_starts_and_named(monkeypatch, limit, value):
    shafer = Model.shafer(Frame(["a", "b", "c"]))
    m = MassFunction({"a": 0.5, "b": 0.3, "c": 0.2}, model=shafer)
    monkeypatch.setattr(plan_module, limit, value)
    for engine in ("auto", "general"):
        with pytest.raises(CombinationTooLargeError, match=f"belief.plan.{limit} = "):
            combine(m, m, m, m, m, rule="pcr6", engine=engine)         # 243 tuples
    monkeypatch.undo()
    assert combine(m, m, m, m, m, rule="pcr6").isclose(combine(m, m, m, m, m, rule="pcr6", engine="general"))


def test_a_fold_is_checked_before_each_step(monkeypatch):
    free = free_sources(6)
    monkeypatch.setattr(plan_module, "MAX_ELEMENT_TUPLES", 100)
    with pytest.raises(CombinationTooLargeError, match=r"folded pairwise.*by source \d.*MAX_ELEMENT_TUPLES = 100"):
        combine(*free, rule="conjunctive")
    monkeypatch.setattr(plan_module, "MAX_WORK", 10)
    shafer = halves(3)
    with pytest.raises(CombinationTooLargeError, match="MAX_WORK"):
        combine(*[m.batch() for m in shafer], rule="dempster", engine="general")


def test_a_batch_counts_its_rows(monkeypatch):
    rng = np.random.default_rng(0)
    values = rng.random((2000, 2))
    batch = MassBatch(["a", "b"], values / values.sum(axis=1, keepdims=True), model=AB)
    cost = plan_module.joint_cost([2] * 12, rows=2000)
    monkeypatch.setattr(plan_module, "MAX_WORK", cost.work - 1)
    with pytest.raises(CombinationTooLargeError, match="2,000 rows"):
        combine(*[batch] * 12, rule="pcr6", engine="general")


# -- associative rules: the pairwise fold is the joint enumeration ---------------------------------------
def joint(sources: list[MassFunction], rule: str, model: Model) -> dict:
    """Every tuple of focal elements visited at once (the definition), in floats."""
    out: dict = {}
    items = [list(zip(m.focal, m.values.tolist())) for m in sources]
    for combo in itertools.product(*items):
        element, product = combo[0]
        for x, v in combo[1:]:
            element = element | x if rule == "disjunctive" else element & x
            product *= v
        element = model.reduce(element)
        out[element] = out.get(element, 0.0) + product
    if rule == "dempster":
        out.pop(model.frame.empty, None)
        total = math.fsum(out.values())
        out = {x: v / total for x, v in out.items()}
    return out


MODELS = [Model.shafer(Frame(["a", "b", "c"])), Model.free(Frame(["a", "b", "c"])),
          Model.hybrid(Frame(["a", "b", "c"]), ["a&b"])]
POOL = ["a", "b", "c", "a|b", "b|c", "a&b", "a&c", "a|b|c", "a&b&c", "c|a&b"]
# Strategies are built once and reused: building one costs more than drawing from it.
FREE_NAMES = st.lists(st.sampled_from(POOL), min_size=1, max_size=4, unique=True)
SHAFER_NAMES = st.lists(st.sampled_from(POOL[:4] + ["a|b|c"]), min_size=1, max_size=4, unique=True)
WEIGHT_LISTS = {size: st.lists(st.floats(0.05, 1.0), min_size=size, max_size=size) for size in range(1, 5)}


@pytest.mark.parametrize("rule", ["dempster", "conjunctive", "disjunctive", "dsmc"])
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_the_pairwise_fold_equals_the_joint_enumeration(rule, data):
    model = data.draw(st.sampled_from(MODELS), label="model")
    sources = []
    for _ in range(data.draw(st.integers(2, 5), label="sources")):
        names = data.draw(FREE_NAMES if model.kind != "shafer" else SHAFER_NAMES)
        weights = data.draw(WEIGHT_LISTS[len(names)])
        total = math.fsum(weights)
        masses = {n: w / total for n, w in zip(names, weights)}
        sources.append(MassFunction(masses, model=Model.free(model.frame)).under(model))
    want = joint(sources, rule, model)
    if rule == "dempster" and not want:
        return
    fused = combine(*sources, rule=rule)
    got = dict(zip(fused.focal, fused.values.tolist()))
    for x in set(got) | set(want):
        assert math.isclose(got.get(x, 0.0), want.get(x, 0.0), rel_tol=1e-12, abs_tol=1e-15), str(x)


# -- outputs are valid inputs ------------------------------------------------------------------------------
SHAFER = Model.shafer(Frame(["a", "b", "c"]))
OUTPUT_RULES = ("conjunctive", "dempster", "disjunctive", "yager", "dubois_prade", "dsmh", "pcr5", "pcr6", "r_rule",
                "average", "murphy", "pcr6_plus")


OUTPUT_NAMES = st.lists(st.sampled_from(["a", "b", "c", "a|b", "b|c", "a|b|c"]), min_size=1, max_size=4, unique=True)
OFFSETS = st.sampled_from([1.0 + 0.9 * SUM_TOLERANCE, 1.0 - 0.9 * SUM_TOLERANCE, 1.0])


@st.composite
def off_by_the_tolerance(draw):
    """A mass function whose masses sum to one within the accepted tolerance, not closer."""
    names = draw(OUTPUT_NAMES)
    weights = draw(WEIGHT_LISTS[len(names)])
    total = math.fsum(weights)
    off = draw(OFFSETS)
    return MassFunction({n: w / total * off for n, w in zip(names, weights)}, model=SHAFER)


OFF_BY_THE_TOLERANCE = off_by_the_tolerance()
SOURCE_COUNTS = st.integers(2, 3)


@pytest.mark.parametrize("rule", OUTPUT_RULES)
@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_combined_results_are_valid_inputs_again(rule, data):
    result = None
    for _ in range(3):
        sources = [data.draw(OFF_BY_THE_TOLERANCE) for _ in range(data.draw(SOURCE_COUNTS))]
        if result is not None:
            sources[0] = result
        try:
            result = combine(*sources, rule=rule)
        except TotalConflictError:
            return
        assert abs(math.fsum(result.values) - 1.0) <= 1e-12
        again = MassFunction(result.to_mapping(), model=SHAFER, subnormal=True)
        assert again.isclose(result)
    batches = [MassBatch.from_mass_functions([data.draw(OFF_BY_THE_TOLERANCE) for _ in range(3)])
               for _ in range(3)]
    try:
        fused = combine(*batches, rule=rule)
    except TotalConflictError:
        return
    assert np.all(np.abs(fused.values.sum(axis=1) - 1.0) <= 1e-12)


@pytest.mark.parametrize(("flag", "limit"), [("max-tuples", "MAX_TUPLES"), ("max-work", "MAX_WORK"),
                                             ("max-bytes", "MAX_BYTES")])
def test_the_command_line_sets_a_limit_for_one_combination(tmp_path, capsys, flag, limit):
    paths = []
    for k in range(14):            # 16,384 tuples: large enough for every limit to be checked
        path = tmp_path / f"s{k}.json"
        path.write_text(json.dumps({"frame": ["a", "b"], "model": {"type": "shafer"}, "mass": {"a": .5, "b": .5}}))
        paths.append(str(path))
    before = getattr(plan_module, limit)
    # Lowered below the job: refused, and the message names the option.
    assert main(["combine", "--rule", "pcr6", *paths, f"--{flag}", "2"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"belief.plan.{limit} = 2" in err and f"--{flag} N" in err
    assert getattr(plan_module, limit) == before                  # restored after the command
    assert main(["combine", "--rule", "pcr6", *paths, f"--{flag}", "1e9", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["mass"] == pytest.approx({"a": 0.5, "b": 0.5}, abs=1e-12)
    assert getattr(plan_module, limit) == before


@pytest.mark.parametrize("value", ["0", "-5", "1.5", "nan", "inf", "x", "1e30"])
def test_a_bad_limit_on_the_command_line_is_one_line(tmp_path, capsys, value):
    path = tmp_path / "s.json"
    path.write_text(json.dumps({"frame": ["a", "b"], "mass": {"a": 1.0}}))
    assert main(["combine", "--rule", "pcr6", str(path), str(path), "--max-tuples", value]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--max-tuples" in err and "Traceback" not in err


@pytest.mark.parametrize(("flag", "module", "limit", "rule", "frame"), [
    ("max-element-tuples", "belief.plan", "MAX_ELEMENT_TUPLES", "pcr6",
     {"frame": [f"t{k}" for k in range(7)], "model": {"type": "free"}}),
    ("max-plus-tuples", "belief.extra_rules", "MAX_PLUS_TUPLES", "pcr6_plus",
     {"frame": ["a", "b"], "model": {"type": "shafer"}}),
])
def test_the_other_limits_have_their_options_too(tmp_path, capsys, flag, module, limit, rule, frame):
    # The free model of seven hypotheses combines element by element; PCR6+ has a limit of its own.
    first, second = frame["frame"][:2]
    paths = []
    for k in range(3):
        path = tmp_path / f"s{k}.json"
        path.write_text(json.dumps({**frame, "mass": {first: 0.5, f"{first}|{second}": 0.5}}))
        paths.append(str(path))
    assert main(["combine", "--rule", rule, *paths, f"--{flag}", "2"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{module}.{limit} = 2" in err and f"--{flag} N" in err
    assert main(["combine", "--rule", rule, *paths, f"--{flag}", "1000"]) == 0
