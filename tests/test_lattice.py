"""The hyper-power set D^Θ under a model, and its Hasse diagram."""

import json
import re

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings

from belief import Frame, HyperPowerSet, LatticeTooLargeError, Model, hyper_power_set
from tests.strategies import (
    ModelCase,
    frames,
    free_allowed,
    hybrid_cases,
    hypothesis_regions,
    regions_of,
    shafer_allowed,
)

# |D^Θ| on the free model, ∅ included, for n = 1..7: the Dedekind numbers minus one
# (OEIS A014466: 1, 2, 5, 19, 167, 7580, 7828353, 2414682040997, ...; the same values up to
# n = 5 in Table 2 of Dezert & Smarandache, "An introduction to DSmT", arXiv:0903.0279).
FREE_SIZES = {1: 2, 2: 5, 3: 19, 4: 167, 5: 7580, 6: 7828353}
FREE_SIZE_7 = 2414682040997


@pytest.mark.parametrize(("n", "size"), sorted(FREE_SIZES.items()))
def test_free_lattice_sizes_are_the_dedekind_numbers_minus_one(n, size):
    lattice = hyper_power_set(n)
    assert len(lattice) == size
    ordered = np.sort(lattice.masks)
    assert (ordered[1:] != ordered[:-1]).all()  # no element listed twice


def test_frames_and_models_give_the_same_lattice_as_a_number():
    frame = Frame.numbered(3)
    a, b, c = hyper_power_set(3), hyper_power_set(frame), hyper_power_set(Model.free(frame))
    assert list(a) == list(b) == list(c)
    with pytest.raises(TypeError):
        hyper_power_set(True)
    with pytest.raises(TypeError):
        hyper_power_set("t1,t2")


@pytest.mark.parametrize("n", [7, 8])
def test_seven_or_more_free_hypotheses_are_refused_with_an_explanation(n):
    with pytest.raises(LatticeTooLargeError) as info:
        hyper_power_set(n)
    message = str(info.value)
    assert f"{n} hypotheses" in message
    assert "cannot be enumerated" in message
    assert "focal elements" in message
    if n == 7:
        digits = re.sub(r"[,\s\u202f\u2009_]", "", message)
        assert str(FREE_SIZE_7) in digits


@pytest.mark.parametrize("n", range(1, 11))
def test_shafer_model_gives_the_power_set(n):
    frame = Frame.numbered(n)
    lattice = hyper_power_set(Model.shafer(frame))
    assert len(lattice) == 2**n
    # every element is a union of singletons
    assert all(all(t.bit_count() == 1 for t in e.terms) for e in lattice)


@pytest.mark.parametrize(("targets", "size"), [(1, 4), (2, 10), (3, 38), (4, 2 * 167), (5, 2 * 7580)])
def test_tracking_model_sizes(targets, size):
    # SPEC A.2: |D^Θ| under M_τ is 2·|D^{Θ_τ}| (target up-set × FA region in or out),
    # which gives 4, 10, 38 for τ = 1, 2, 3; |D^{Θ_τ}| from the free sizes above.
    assert len(hyper_power_set(Model.for_targets(targets))) == size


# -- brute-force closure on hybrid models ----------------------------------------------------------


def closure(case: ModelCase) -> set[frozenset]:
    """Close {∅, θ_1..θ_n} under ∩ and ∪ of region sets, by a plain fixed-point loop."""
    n = case.n
    found = {frozenset()} | {hypothesis_regions(n, i) & case.allowed for i in range(n)}
    while True:
        items = list(found)
        new = {x & y for x in items for y in items} | {x | y for x in items for y in items}
        if new <= found:
            return found
        found |= new


def lattice_regions(lattice: HyperPowerSet, case: ModelCase) -> set[frozenset]:
    return {case.regions(e) for e in lattice}


@settings(max_examples=25)
@given(frames(1, 4).flatmap(hybrid_cases))
def test_hybrid_lattice_equals_brute_force_closure(case):
    lattice = hyper_power_set(case.model)
    expected = closure(case)
    assert len(lattice) == len(expected)
    assert lattice_regions(lattice, case) == expected
    # every listed element is in canonical form under the model, and no two coincide
    assert all(case.model.reduce(e) == e for e in lattice)
    assert len(set(lattice)) == len(lattice)


def test_free_lattice_n4_equals_brute_force_closure():
    frame = Frame.numbered(4)
    case = ModelCase(Model.free(frame), free_allowed(4), "free")
    assert lattice_regions(hyper_power_set(4), case) == closure(case)


# -- literature element lists ----------------------------------------------------------------------


def test_elements_for_two_hypotheses():
    # D^Θ for Θ = {θ1, θ2}: α0 = ∅, α1 = θ1∩θ2, α2 = θ1, α3 = θ2, α4 = θ1∪θ2.
    # Source: Dezert & Smarandache, "An introduction to DSmT" (2009, arXiv:0903.0279),
    # §2.1 "Example of the first hyper-power sets".
    frame = Frame(["θ1", "θ2"])
    listed = ["∅", "θ1 ∩ θ2", "θ1", "θ2", "θ1 ∪ θ2"]
    assert set(hyper_power_set(frame)) == {frame.element(s) for s in listed}


def test_elements_for_three_hypotheses():
    # D^Θ for Θ = {θ1, θ2, θ3}, the 19 elements α0..α18.
    # Source: Dezert & Smarandache, "An introduction to DSmT" (2009, arXiv:0903.0279),
    # §2.1 "Example of the first hyper-power sets"; that paper is Chapter 1 of Smarandache &
    # Dezert (eds.), "Advances and Applications of DSmT for Information Fusion", Vol. 3 (2009).
    frame = Frame(["θ1", "θ2", "θ3"])
    listed = [
        "∅",  # α0
        "θ1 ∩ θ2 ∩ θ3",  # α1
        "θ1 ∩ θ2",  # α2
        "θ1 ∩ θ3",  # α3
        "θ2 ∩ θ3",  # α4
        "(θ1 ∪ θ2) ∩ θ3",  # α5
        "(θ1 ∪ θ3) ∩ θ2",  # α6
        "(θ2 ∪ θ3) ∩ θ1",  # α7
        "(θ1 ∩ θ2) ∪ (θ1 ∩ θ3) ∪ (θ2 ∩ θ3)",  # α8
        "θ1",  # α9
        "θ2",  # α10
        "θ3",  # α11
        "(θ1 ∩ θ2) ∪ θ3",  # α12
        "(θ1 ∩ θ3) ∪ θ2",  # α13
        "(θ2 ∩ θ3) ∪ θ1",  # α14
        "θ1 ∪ θ2",  # α15
        "θ1 ∪ θ3",  # α16
        "θ2 ∪ θ3",  # α17
        "θ1 ∪ θ2 ∪ θ3",  # α18
    ]
    elements = [frame.element(s) for s in listed]
    assert len(set(elements)) == 19
    assert set(hyper_power_set(frame)) == set(elements)


def test_paper_hybrid_model_lattice():
    # Hybrid model of Dezert & Smarandache, "An introduction to DSmT" (arXiv:0903.0279), §2.2
    # Fig. 3: every conjunction is empty except θ1∩θ2.  The paper lists 9 elements with their
    # DSm cardinals (α0..α8).  The brute-force closure (and an independent DSmT library) finds a
    # tenth, (θ1∩θ2) ∪ θ3, which is non-empty and different from all nine: the list in the paper
    # omits it.  We check the nine are there, and the size against brute force.
    frame = Frame(["θ1", "θ2", "θ3"])
    model = Model.hybrid(frame, ["θ1∩θ3", "θ2∩θ3"])
    lattice = hyper_power_set(model)
    listed = ["∅", "θ1∩θ2", "θ3", "θ1", "θ2", "θ1∪θ2", "θ1∪θ3", "θ2∪θ3", "θ1∪θ2∪θ3"]
    assert {frame.element(s) for s in listed} <= set(lattice)
    allowed = frozenset(r for r in range(1, 8) if r not in (0b101, 0b110, 0b111))
    case = ModelCase(model, allowed, "paper hybrid")
    assert len(lattice) == len(closure(case)) == 10
    assert frame.element("(θ1∩θ2) ∪ θ3") in lattice


# -- the sequence protocol ------------------------------------------------------------------------------


LATTICE_CASES = [
    ModelCase(Model.free(Frame.numbered(3)), free_allowed(3), "free 3"),
    ModelCase(Model.shafer(Frame.numbered(3)), shafer_allowed(3), "shafer 3"),
    ModelCase(Model.hybrid(Frame.numbered(4), ["t1&t2", "t3&t4&t1"]),
              frozenset(r for r in range(1, 16) if r & 0b0011 != 0b0011 and r & 0b1101 != 0b1101),
              "hybrid 4"),
    ModelCase(Model.for_targets(2), frozenset({1, 2, 3, 4}), "tracking 2"),
]


@pytest.mark.parametrize("case", LATTICE_CASES, ids=lambda c: c.label)
def test_regions_masks_and_round_trips(case):
    lattice = hyper_power_set(case.model)
    assert lattice.model == case.model and lattice.frame == case.frame
    assert set(lattice.regions) == case.allowed
    for i, element in enumerate(lattice):
        assert lattice[i] == element
        assert lattice.index(element) == i
        assert element in lattice
        mask = lattice.mask_of(element)
        assert mask == int(lattice.masks[i])
        assert lattice.element_of(mask) == element
        # bit k of the mask is set iff the element contains region k
        assert {r for k, r in enumerate(lattice.regions) if mask >> k & 1} == case.regions(element)
        assert lattice.cardinalities[i] == len(case.regions(element)) == case.model.cardinality(element)
    assert list(lattice.cardinalities) == sorted(lattice.cardinalities)
    assert lattice[-1] == case.model.total and lattice[0].is_empty
    assert lattice[1:3] == [lattice[1], lattice[2]]


def test_membership_needs_a_canonical_element_of_the_same_frame():
    frame = Frame.numbered(3)
    shafer = hyper_power_set(Model.shafer(frame))
    assert frame.element("t1&t2") not in shafer  # not canonical: it is ∅ under Shafer's model
    assert frame.element("t1|t2") in shafer
    assert Frame.numbered(4).element("t1") not in shafer
    assert "t1" not in shafer
    free = hyper_power_set(frame)
    with pytest.raises(ValueError):
        free.index(free[5], start=6)
    assert free.index(str(free[5])) == 5


def test_repr():
    assert "19 elements" in repr(hyper_power_set(3))


# -- Hasse diagram -----------------------------------------------------------------------------------


def covering_pairs(lattice: HyperPowerSet, case: ModelCase) -> set:
    """Pairs (x, y) with x ⊂ y and nothing strictly between, from region-set inclusion."""
    regions = {e: case.regions(e) for e in lattice}
    pairs = set()
    for x, rx in regions.items():
        for y, ry in regions.items():
            if rx < ry and not any(rx < rz < ry for rz in regions.values()):
                pairs.add((x, y))
    return pairs


def check_hasse(case: ModelCase):
    lattice = hyper_power_set(case.model)
    graph = lattice.hasse_diagram()
    assert isinstance(graph, nx.DiGraph)
    assert set(graph.nodes) == set(lattice)
    assert set(graph.edges) == covering_pairs(lattice, case)
    assert nx.is_directed_acyclic_graph(graph)
    bottoms = [v for v in graph if graph.in_degree(v) == 0]
    tops = [v for v in graph if graph.out_degree(v) == 0]
    assert bottoms == [case.frame.empty]
    assert tops == [case.model.total]
    for node, data in graph.nodes(data=True):
        assert data["cardinality"] == len(case.regions(node))
        assert case.frame.element(data["label"]) == node
    return graph


def test_hasse_diagram_two_hypotheses():
    graph = check_hasse(ModelCase(Model.free(Frame.numbered(2)), free_allowed(2), "free 2"))
    assert graph.number_of_nodes() == 5


@pytest.mark.parametrize("case", LATTICE_CASES, ids=lambda c: c.label)
def test_hasse_diagram_edges_are_the_covering_pairs(case):
    check_hasse(case)


def test_hasse_diagram_free_three_hypotheses_top_is_total():
    graph = check_hasse(ModelCase(Model.free(Frame.numbered(3)), free_allowed(3), "free 3"))
    frame = Frame.numbered(3)
    assert frame.element("t1|t2|t3") in graph and graph.out_degree(frame.element("t1|t2|t3")) == 0


@settings(max_examples=15)
@given(frames(1, 3).flatmap(hybrid_cases))
def test_hasse_diagram_of_random_hybrid_models(case):
    check_hasse(case)


def test_hasse_diagram_four_hypotheses_is_a_graded_dag():
    frame = Frame.numbered(4)
    lattice = hyper_power_set(frame)
    graph = lattice.hasse_diagram()
    assert graph.number_of_nodes() == 167
    assert nx.is_directed_acyclic_graph(graph)
    # in a distributive lattice every covering step adds exactly one region
    for x, y in graph.edges:
        rx, ry = regions_of(x), regions_of(y)
        assert rx < ry and len(ry - rx) == 1
    assert [v for v in graph if graph.in_degree(v) == 0] == [frame.empty]
    assert [v for v in graph if graph.out_degree(v) == 0] == [frame.total]


def test_hasse_diagram_of_six_hypotheses_is_refused():
    lattice = hyper_power_set(6)
    with pytest.raises(LatticeTooLargeError, match="too large"):
        lattice.hasse_diagram()


def test_lattices_and_graphs_beyond_the_limits_are_refused(monkeypatch):
    import belief.lattice as lattice_module

    monkeypatch.setattr(lattice_module, "MAX_ELEMENTS", 100)
    with pytest.raises(LatticeTooLargeError, match="more than 100 elements"):
        lattice_module.hyper_power_set(Model.hybrid(Frame.numbered(4), ["t1&t2&t3&t4"]))
    monkeypatch.setattr(lattice_module, "MAX_GRAPH_NODES", 10)
    with pytest.raises(LatticeTooLargeError, match="limit 10"):
        lattice_module.hyper_power_set(3).hasse_diagram()


@given(frames(1, 4).flatmap(hybrid_cases))
@settings(max_examples=10, deadline=None)
def test_text_blocks_join_the_texts_of_the_elements(case):
    lattice = hyper_power_set(case.model)
    for style in ("ascii", "unicode"):
        texts = list(lattice.strings(style))
        assert texts == [e.format(style) for e in lattice]
        # ∅ in the first block (another path) or not; separators with and without a union sign
        for separator in ("\n", '",\n    "', " | ", " ∪ "):
            for chunk in (1, 2, 7, 65536):
                assert separator.join(lattice.text_blocks(separator, style, chunk)) == separator.join(texts)


def test_text_blocks_escape_names_for_json():
    lattice = hyper_power_set(Model.free(Frame(['a"b', "c\\d", "e"])))
    text = "[" + ", ".join('"' + block + '"' for block in lattice.text_blocks('", "', json_escaped=True)) + "]"
    assert json.loads(text) == list(lattice.strings())
