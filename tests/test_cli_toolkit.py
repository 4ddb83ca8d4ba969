"""The command line of the everyday toolkit: decide, distance, uncertainty, plot, and the new transforms."""

import json
import subprocess
import sys

import pytest

from belief import MassFunction
from belief.cli import main
from belief.decisions import decide
from belief.distances import distance
from belief.representations import contextual_discount, plausibility_transform
from belief.uncertainty import uncertainty


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


SHAFER = {"frame": ["a", "b", "c"], "model": {"type": "shafer"}}
FIRST = {**SHAFER, "mass": {"a": 0.4, "b": 0.4, "a|b|c": 0.2}}
SECOND = {**SHAFER, "mass": {"a": 0.6, "c": 0.1, "a|b": 0.3}}


@pytest.fixture
def files(tmp_path):
    paths = {}
    for name, data in {"first": FIRST, "second": SECOND}.items():
        paths[name] = tmp_path / f"{name}.json"
        paths[name].write_text(json.dumps(data), encoding="utf-8")
    return paths


def mass(data) -> MassFunction:
    return MassFunction.from_dict(data)


# -- decide ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("criterion", ["betp", "bel", "pls", "dsmp"])
def test_decide_prints_every_tied_hypothesis_and_the_value_of_the_library(capsys, files, criterion):
    code, out, err = run(capsys, "decide", files["first"], "--criterion", criterion, "--json")
    assert code == 0, err
    expected = decide(mass(FIRST), criterion)
    assert json.loads(out) == {"decision": expected.elements, "value": expected.value}
    assert json.loads(out)["decision"] == ["a", "b"]                      # a and b are symmetric in FIRST


def test_decide_among_candidates_and_in_words(capsys, files):
    code, out, _ = run(capsys, "decide", files["second"], "--candidates", "a|b", "c", "--criterion", "bel")
    assert code == 0 and out.strip() == "a|b: bel = 0.900000"


def test_decide_epsilon_only_with_dsmp(capsys, files):
    code, _, err = run(capsys, "decide", files["first"], "--epsilon", "0.1")
    assert code == 2 and "--epsilon goes with --criterion dsmp" in err


# -- distance -------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["jousselme", "euclidean", "tessem"])
def test_distance_is_the_library_value(capsys, files, kind):
    code, out, _ = run(capsys, "distance", files["first"], files["second"], "--kind", kind, "--json")
    assert code == 0
    assert json.loads(out) == {"distance": pytest.approx(float(distance(mass(FIRST), mass(SECOND), kind=kind)),
                                                         abs=1e-15)}


def test_distance_of_a_file_to_itself_is_zero(capsys, files):
    code, out, _ = run(capsys, "distance", files["first"], files["first"], "--json")
    assert code == 0 and json.loads(out)["distance"] == 0.0


def test_distance_between_different_frames_is_one_line(capsys, files, tmp_path):
    other = tmp_path / "other.json"
    other.write_text(json.dumps({"frame": ["x", "y"], "mass": {"x": 1.0}}), encoding="utf-8")
    code, out, err = run(capsys, "distance", files["first"], other)
    assert code == 1 and out == "" and len(err.strip().splitlines()) == 1


# -- uncertainty ----------------------------------------------------------------------------------------
def test_uncertainty_prints_every_measure_in_bits(capsys, files):
    code, out, _ = run(capsys, "uncertainty", files["first"], "--json")
    assert code == 0
    printed = json.loads(out)
    assert {"nonspecificity", "deng"} <= set(printed) and len(printed) >= 4
    assert printed == pytest.approx({k: float(v) for k, v in uncertainty(mass(FIRST)).items()})


def test_uncertainty_of_named_measures_only(capsys, files):
    code, out, _ = run(capsys, "uncertainty", files["first"], "--measure", "deng", "--measure", "nonspecificity",
                       "--json")
    assert code == 0 and set(json.loads(out)) == {"deng", "nonspecificity"}


# -- transform ------------------------------------------------------------------------------------------
def test_transform_plausibility(capsys, files):
    code, out, _ = run(capsys, "transform", files["first"], "--plausibility", "--json")
    assert code == 0
    probability = json.loads(out)["probability"]
    assert list(probability) == ["a", "b", "c"]
    assert list(probability.values()) == pytest.approx(plausibility_transform(mass(FIRST)).tolist(), abs=1e-15)
    assert probability["a"] == pytest.approx(0.6 / 1.4)                     # Pls = .6, .6, .2


def test_transform_contextual_discount_prints_a_bba_that_reads_back(capsys, files, tmp_path):
    rates = tmp_path / "rates.json"
    rates.write_text(json.dumps({"a": 0.1, "b": 0.2, "c": 0.5}), encoding="utf-8")
    code, out, _ = run(capsys, "transform", files["first"], "--contextual-discount", rates, "--json")
    assert code == 0
    result = MassFunction.from_dict(json.loads(out))
    assert result.isclose(contextual_discount(mass(FIRST), {"a": 0.1, "b": 0.2, "c": 0.5}))
    written = tmp_path / "discounted.json"
    written.write_text(out, encoding="utf-8")
    assert run(capsys, "measures", written)[0] == 0


@pytest.mark.parametrize("rates, fragment", [("[0.1, 0.2]", "JSON object"), ('{"a": 2}', "")])
def test_transform_bad_discount_rates_are_one_line(capsys, files, tmp_path, rates, fragment):
    path = tmp_path / "rates.json"
    path.write_text(rates, encoding="utf-8")
    code, out, err = run(capsys, "transform", files["first"], "--contextual-discount", path)
    assert code == 1 and out == "" and len(err.strip().splitlines()) == 1 and fragment in err


# -- --query, both ways -----------------------------------------------------------------------------------
def test_measures_query_repeated_or_listed_answers_every_query(capsys, files):
    _, repeated, _ = run(capsys, "measures", files["first"], "--query", "a", "--query", "b", "--query", "c", "--json")
    _, listed, _ = run(capsys, "measures", files["first"], "--query", "a", "b", "c", "--json")
    assert list(json.loads(repeated)) == ["a", "b", "c"]
    assert json.loads(repeated) == json.loads(listed)


# -- a model with "empty" in a BBA file -----------------------------------------------------------------------
def test_a_shafer_model_with_an_impossible_hypothesis_is_read_and_used(capsys, tmp_path):
    path = tmp_path / "m.json"
    path.write_text(json.dumps({"frame": ["a", "b", "c"], "model": {"type": "shafer", "empty": ["c"]},
                                "mass": {"a": 0.5, "a|c": 0.3, "b": 0.2}}), encoding="utf-8")
    code, out, err = run(capsys, "measures", path, "--query", "a", "--json")
    assert code == 0, err
    assert json.loads(out)["a"]["bel"] == pytest.approx(0.8)               # a|c is a once c is impossible


# -- plot -------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("suffix, magic", [(".png", b"\x89PNG"), (".svg", b"<?xml"), (".pdf", b"%PDF")])
def test_plot_writes_the_picture(capsys, files, tmp_path, suffix, magic):
    out = tmp_path / f"figure{suffix}"
    code, printed, err = run(capsys, "plot", files["first"], "--out", out)
    assert code == 0, err
    assert out.read_bytes().startswith(magic)


def test_plot_to_an_unknown_format_is_one_line(capsys, files, tmp_path):
    code, _, err = run(capsys, "plot", files["first"], "--out", tmp_path / "figure.xyz")
    assert code == 1 and len(err.strip().splitlines()) == 1 and "xyz" in err


def test_plot_without_matplotlib_names_the_extra(files, tmp_path):
    code = ("import sys\nsys.modules['matplotlib'] = None\nfrom belief.cli import main\n"
            f"sys.exit(main(['plot', {str(files['first'])!r}, '--out', {str(tmp_path / 'f.png')!r}]))")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 1
    assert result.stderr.strip().splitlines() == [
        "belief: error: drawing needs matplotlib, which is not installed: pip install 'belief-dsmt[plot]'"]
    assert not (tmp_path / "f.png").exists()


def test_the_rules_of_the_toolkit_are_combined_by_name(capsys, files, tmp_path):
    for rule in ("murphy", "average", "pcr5_plus", "pcr6_plus"):
        code, out, err = run(capsys, "combine", files["first"], files["second"], "--rule", rule, "--json")
        assert code == 0, (rule, err)
        assert sum(json.loads(out)["mass"].values()) == pytest.approx(1.0)


@pytest.mark.parametrize("option", [["--plausibility"], ["--contextual-discount", "rates.json"]])
@pytest.mark.parametrize("extra", [["--normalized"], ["--query", "a"]])
def test_transform_refuses_options_of_other_transforms(capsys, files, option, extra):
    code, out, err = run(capsys, "transform", files["first"], *option, *extra)
    assert code == 2 and out == ""
    assert f"{extra[0]} does not go with {option[0]}" in err and len(err.strip().splitlines()) == 1


def test_a_plot_of_many_focal_elements_and_hypotheses_draws_the_largest_and_says_so():
    pytest.importorskip("matplotlib")
    from belief import Frame, MassFunction, Model
    from belief.plot import MAX_PLOTTED_FOCAL, MAX_PLOTTED_HYPOTHESES, plot_mass

    names = [f"h{i}" for i in range(60)]
    masses = {name: (i + 1) / 1830 for i, name in enumerate(names)}        # 1 + 2 + ... + 60 = 1830
    m = MassFunction(masses, model=Model.shafer(Frame(names)))
    figure = plot_mass(m)
    bars, intervals = figure.axes[0], figure.axes[1]
    assert bars.get_title().startswith(f"Mass of each focal element (the {MAX_PLOTTED_FOCAL} largest of 60)")
    ticks = [t.get_text() for t in bars.get_xticklabels()]
    assert ticks[:-1] == names[-MAX_PLOTTED_FOCAL:] and ticks[-1] == "the other 30"
    heights = [p.get_height() for p in bars.patches]
    assert heights[-1] == pytest.approx(sum(range(1, 31)) / 1830) and sum(heights) == pytest.approx(1.0)
    assert f"(the {MAX_PLOTTED_HYPOTHESES} of largest BetP of 60)" in intervals.get_title()
    assert [t.get_text() for t in intervals.get_yticklabels()] == names[-MAX_PLOTTED_HYPOTHESES:]


def test_hasse_edges_stop_at_the_labels_instead_of_crossing_them():
    pytest.importorskip("matplotlib")
    from matplotlib.text import Annotation

    from belief import MassFunction
    from belief.plot import focal_hasse_edges, plot_mass

    m = MassFunction({"a": 0.4, "a|b": 0.25, "c": 0.15, "a&b": 0.1, "a|b|c": 0.1}, frame=["a", "b", "c"],
                     model="free")
    hasse = plot_mass(m).axes[2]
    labels = {text.get_text().split("\n")[0]: text for text in hasse.texts if not isinstance(text, Annotation)}
    assert set(labels) == {str(e) for e in m.focal}
    assert all(text.get_bbox_patch() is not None and text.get_bbox_patch().get_facecolor()[3] > 0.5
               for text in labels.values())
    edges = [text.arrow_patch for text in hasse.texts if isinstance(text, Annotation)]
    assert not hasse.lines and len(edges) == len(focal_hasse_edges(m))
    label_boxes = {id(text.get_bbox_patch()) for text in labels.values()}
    assert all(id(edge.patchA) in label_boxes and id(edge.patchB) in label_boxes for edge in edges)
