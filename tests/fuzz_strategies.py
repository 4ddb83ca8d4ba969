"""Strategies and checks of the command-line fuzz suite (tests/test_fuzz_cli.py).

:func:`call` runs ``belief.cli.main`` in-process with standard output and error encoded as a
terminal would encode them (UTF-8, strict for the output), so that a result that cannot be
printed is seen as it would be by a user.  :func:`assert_contract` is the contract every
command must keep: exit status 0 with a valid result, or a non-zero exit status with exactly one
line on standard error; never a traceback, never NaN or inf.
"""

from __future__ import annotations

import io
import json
import math
import re
import string
import traceback
import warnings
from contextlib import redirect_stderr, redirect_stdout
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any, Callable, Optional

from hypothesis import strategies as st

from belief.cli import main

NOT_FINITE = re.compile(r"(?<![\w.])-?(nan|inf|infinity)(?![\w.])", re.IGNORECASE)
RULES = ["conjunctive", "dsmc", "dempster", "disjunctive", "yager", "dubois_prade", "dsmh", "pcr5", "pcr6",
         "r_rule", "cautious", "bold", "average", "murphy", "pcr5_plus", "pcr6_plus"]
TOL = 1e-9


@dataclass
class Outcome:
    argv: list
    code: Optional[int]
    out: str
    err: str
    crash: Optional[str] = None          # the traceback of an exception that left main
    warned: list = field(default_factory=list)

    def describe(self) -> str:
        text = f"belief {' '.join(map(repr, self.argv))} -> exit {self.code}\nstderr: {self.err[-2000:]!r}"
        if self.crash:
            text += f"\n{self.crash[-3000:]}"
        if self.warned:
            text += f"\nwarnings: {self.warned}"
        return text


def call(*argv: Any) -> Outcome:
    """``belief.cli.main(argv)`` with captured, encoded streams; an exception that escapes is recorded."""
    argv = [str(a) for a in argv]
    out_bytes, err_bytes = io.BytesIO(), io.BytesIO()
    out = io.TextIOWrapper(out_bytes, encoding="utf-8", errors="strict", newline="\n")
    err = io.TextIOWrapper(err_bytes, encoding="utf-8", errors="backslashreplace", newline="\n")
    crash = None
    code: Optional[int] = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            with redirect_stdout(out), redirect_stderr(err):
                try:
                    code = main(argv)
                finally:
                    out.flush()
                    err.flush()
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 1
        except BaseException as exc:  # noqa: BLE001 - a traceback is what the contract forbids
            crash = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))
    warned = [f"{w.category.__name__}: {w.message}" for w in caught
              if issubclass(w.category, RuntimeWarning)]
    return Outcome(argv, code, out_bytes.getvalue().decode("utf-8", "replace"),
                   err_bytes.getvalue().decode("utf-8", "replace"), crash, warned)


def assert_contract(result: Outcome, expected: str = "either",
                    check: Optional[Callable[[str], None]] = None) -> None:
    """Exit 0 with a valid result (``check`` on the output), or non-zero with one line on stderr.

    ``expected`` is ``"ok"``, ``"error"`` or ``"either"``.
    """
    assert result.crash is None, "traceback:\n" + result.describe()
    assert "Traceback" not in result.err, result.describe()
    assert not result.warned, "numerical warnings: " + result.describe()
    if result.code == 0:
        assert expected != "error", f"accepted, should be refused: {result.describe()}\nstdout: {result.out[:500]!r}"
        found = NOT_FINITE.search(result.out)
        assert found is None, f"prints {found.group(0)!r}: " + result.describe()
        if check is not None:
            check(result.out)
    else:
        assert expected != "ok", "refused: " + result.describe()
        assert result.code is not None and result.code > 0, result.describe()
        lines = result.err.splitlines()
        assert len(lines) == 1 and lines[0].strip(), f"{len(lines)} lines on stderr: " + result.describe()


# -- checks of outputs --------------------------------------------------------------------------------------
def load_json(text: str) -> Any:
    def refuse(constant: str) -> None:
        raise AssertionError(f"output has {constant}")

    return json.loads(text, parse_constant=refuse)


def check_bba(text: str) -> dict:
    data = load_json(text)
    assert isinstance(data, dict) and isinstance(data.get("mass"), dict), text[:300]
    values = list(data["mass"].values())
    assert all(isinstance(v, (int, float)) and math.isfinite(v) and -TOL <= v <= 1 + TOL for v in values), values
    assert abs(math.fsum(values) - 1) <= TOL, f"masses sum to {math.fsum(values)!r}"
    return data


def check_probability(text: str, exclusive: bool, hypotheses: Optional[list] = None) -> dict:
    data = load_json(text)
    probability = data["probability"]
    values = list(probability.values())
    assert all(isinstance(v, (int, float)) and math.isfinite(v) and -TOL <= v <= 1 + TOL for v in values), values
    if exclusive:
        total = math.fsum(probability[h] for h in (hypotheses or probability))
        assert abs(total - 1) <= 1e-6, f"probabilities of the hypotheses sum to {total!r}"
    return probability


def check_measures(text: str) -> None:
    data = load_json(text)
    for query, row in data.items():
        assert set(row) == {"bel", "pls", "q", "betp"}, row
        assert all(math.isfinite(v) and -TOL <= v <= 1 + TOL for v in row.values()), (query, row)
        assert row["bel"] <= row["pls"] + TOL, (query, row)


def check_number(key: str) -> Callable[[str], None]:
    def check(text: str) -> None:
        value = load_json(text)[key]
        assert isinstance(value, (int, float)) and math.isfinite(value), value

    return check


def check_finite_values(text: str) -> None:
    data = load_json(text)
    assert all(isinstance(v, (int, float)) and math.isfinite(v) for v in data.values()), data


def check_lattice(text: str) -> None:
    data = load_json(text)
    if "elements" in data:
        assert data["count"] == len(data["elements"]) == len(set(data["elements"]))


# -- strategies ---------------------------------------------------------------------------------------------
# Building a strategy costs more than drawing from it, so the ones that depend on drawn names are built once for
# each tuple of names (and the other arguments) and reused.
_memo = lru_cache(maxsize=None)


def _plain_name(name: str) -> bool:
    return not NOT_FINITE.fullmatch(name)


SIMPLE_NAMES = st.sampled_from(["a", "b", "c", "d", "θ1", "θ2", "x_y", "A", "FA", "h0", "h10"])
ODD_NAMES = st.one_of(
    st.sampled_from(["", " ", "a b", "a&b", "a|b", "(a)", "empty", "∅", "a\u200b", "\u200b", "a\x00",
                     "é", "e\u0301", "\ud800", "a,b", "\n", "∩", "-", "0"]),
    st.text(alphabet=st.characters(codec="utf-8"), max_size=4),
    st.text(alphabet=string.printable, min_size=1, max_size=4),
).filter(_plain_name)
NAMES = st.one_of(SIMPLE_NAMES, SIMPLE_NAMES, ODD_NAMES)


@_memo
def frames(names=SIMPLE_NAMES, min_size: int = 1, max_size: int = 4, unique: bool = True):
    return st.lists(names, min_size=min_size, max_size=max_size, unique=unique)


def propositions(names: list[str], max_leaves: int = 6, clean: bool = False):
    """Proposition strings over ``names``: unions and intersections with parentheses, and (unless clean) noise."""
    return _propositions(tuple(names), max_leaves, clean)


@_memo
def _propositions(names: tuple, max_leaves: int, clean: bool):
    if clean and names:
        atoms = st.sampled_from(list(names))
    else:
        atoms = st.sampled_from(list(names) + ["empty", "∅"]) if names else st.just("empty")
    tree = st.recursive(
        atoms,
        lambda inner: st.one_of(
            st.tuples(inner, st.sampled_from(["|", "&", " | ", " & ", "∪", "∩"]), inner).map("".join),
            inner.map(lambda s: f"({s})"),
        ),
        max_leaves=max_leaves,
    )
    if clean:
        return tree
    noise = st.one_of(st.sampled_from(["", "(", ")", "a|", "|a", "&&", "((a)", "a)", "unknown", "a b"]),
                      st.text(alphabet="ab()&|∩∪∅ empty", max_size=8))
    return st.one_of(tree, tree, tree, noise)


def model_objects(names: list[str]):
    return _model_objects(tuple(names))


@_memo
def _model_objects(names: tuple):
    empties = st.lists(propositions(names, max_leaves=3), max_size=2)
    typed = st.fixed_dictionaries({"type": st.sampled_from(["free", "shafer", "hybrid", "tracking"])},
                                  optional={"empty": empties})
    return st.one_of(st.none(), typed, typed, typed, json_values(max_leaves=4))


@_memo
def json_values(max_leaves: int = 10):
    scalars = st.one_of(st.none(), st.booleans(), st.integers(), st.floats(allow_nan=True, allow_infinity=True),
                        st.text(max_size=6), st.sampled_from([10 ** 400, -1, 0, 1, 0.5, 1e-320, 1e308]))
    return st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                         st.dictionaries(st.text(max_size=5), inner, max_size=4)),
                        max_leaves=max_leaves)


@_memo
def mass_values():
    return st.one_of(st.floats(min_value=0, max_value=1), st.floats(allow_nan=True, allow_infinity=True),
                     st.integers(min_value=-2, max_value=2), st.sampled_from([5e-324, 1e-300, 1 + 9e-10, 10 ** 30]),
                     st.text(max_size=3), st.none(), st.booleans())


@_memo
def _proposition_lists(names: tuple, clean: bool):
    return st.lists(propositions(names, clean=clean), min_size=1, max_size=4)


@_memo
def _broken_masses(props: tuple):
    return st.dictionaries(st.one_of(st.sampled_from(props), st.text(max_size=3)), mass_values(), max_size=4)


@_memo
def _weights(size: int):
    return st.lists(st.floats(min_value=0.0, max_value=1.0), min_size=size, max_size=size)


@_memo
def _well_formed_models(names: tuple):
    # the model dictionaries are drawn anew each time: a drawn value must not be shared between examples
    return st.one_of(st.none(), st.sampled_from(["shafer", "free"]).map(lambda kind: {"type": kind}),
                     st.sampled_from(["shafer", "free"]).map(lambda kind: {"type": kind}),
                     st.fixed_dictionaries({"type": st.sampled_from(["hybrid", "shafer", "free"]),
                                            "empty": st.lists(propositions(names, 3), max_size=2)}))


@_memo
@st.composite
def bba_documents(draw, valid_bias: bool = True) -> dict:
    """A BBA object: mostly well formed (masses normalised), sometimes broken in one or several ways."""
    broken = draw(st.integers(0, 3)) == 0 if valid_bias else True
    names = draw(frames(NAMES if broken else SIMPLE_NAMES, min_size=0 if broken else 1, unique=not broken))
    props = draw(_proposition_lists(tuple(names), not broken))
    if broken:
        mass = draw(_broken_masses(tuple(props)))
        model = draw(model_objects(names))
    else:
        weights = draw(_weights(len(props)))
        total = math.fsum(weights)
        if total == 0:
            weights, total = [1.0] * len(props), float(len(props))
        mass = {}
        for p, w in zip(props, weights):
            mass[p] = mass.get(p, 0.0) + w / total
        model = draw(_well_formed_models(tuple(names)))
    data: dict = {"frame": names, "mass": mass}
    if model is not None:
        data["model"] = model
    if draw(st.integers(0, 9)) == 0:
        data["subnormal"] = draw(st.one_of(st.booleans(), json_values(2)))
    if broken and draw(st.booleans()):
        for key in draw(st.lists(st.sampled_from(["frame", "mass", "model", "extra"]), max_size=2)):
            data[key] = draw(json_values(4))
    return data


def encoded(values) -> st.SearchStrategy[str]:
    """JSON text of the drawn values, escaped to ASCII or not (NaN and Infinity as Python writes them)."""
    return st.tuples(values, st.booleans()).map(lambda pair: json.dumps(pair[0], ensure_ascii=pair[1]))


def write(path: Path, text: str) -> str:
    """Write ``text`` as UTF-8 (a lone surrogate as the bytes it would have, which is not UTF-8)."""
    path.write_bytes(text.encode("utf-8", "surrogatepass"))
    return str(path)


def documents():
    """The text of a file given where a BBA is expected: a BBA object, any JSON, or not JSON at all."""
    return st.one_of(encoded(bba_documents()), encoded(bba_documents()), encoded(bba_documents()),
                     encoded(json_values()),
                     st.text(max_size=40),
                     st.sampled_from(["", "{", "[" * 100, '{"frame": ["a"], "mass": {"a": 1, "a": 0}}',
                                      '{"frame": ["a"], "mass": {"a": NaN}}',
                                      '{"frame": ["a"], "mass": {"a": 1e999}}',
                                      '\ufeff{"frame": ["a"], "mass": {"a": 1}}']))
