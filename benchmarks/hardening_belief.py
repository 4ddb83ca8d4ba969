"""Hostile but fair input to the evidence commands: each reproducer run as a process of its own.

For every case it prints the exit status, the number of lines on standard error, the wall time
and the peak memory of the process (its own ``ru_maxrss``, read with ``os.wait4``), and PASS or
FAIL against (issue 26's acceptance): at most 30 s, at most 2 GB, exactly one line on standard error for a refusal and
none for a success, no traceback, the expected kind of exit status, and, for a success, a valid
result (a BBA that ``belief`` reads back, probabilities that sum to one, no NaN or inf, the
exact values where they are known).

Cases that may either succeed or refuse (a joint combination that the engine may fold pairwise,
a frame that may be too large) accept both, but a success must print a valid result.  A case of
several steps (a result fed to the next command) stops at the first refusal.

A step may also name files that must keep their bytes (an outside file a symlink points to):
they are compared before and after the step, whatever its exit status.

A process still running after 35 s is killed (FAIL); each process is also limited to 4 GB of
address space so that a runaway job cannot take the machine down (it then fails with > 2 GB or
a traceback).

    python benchmarks/hardening_belief.py            # in a temporary folder, removed afterwards
    python benchmarks/hardening_belief.py --keep DIR # keep the inputs and outputs in DIR
    python benchmarks/hardening_belief.py -k 6       # only the cases whose name contains '6'
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import os
import re
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Callable, NamedTuple, Optional

from process_usage import Usage, run_cli

#: What a hostile input may cost, result or refusal (issue 26's acceptance; process_usage's
#: shared defaults are 10 s and 1 GB, stricter than the issue).
LIMIT_SECONDS = 30.0
LIMIT_BYTES = 2 << 30
KILL_SECONDS = 35.0
ADDRESS_SPACE = 4 << 30
NOT_FINITE = re.compile(r"(?<![\w.])-?(nan|inf|infinity)(?![\w.])", re.IGNORECASE)

Check = Callable[[Path], Optional[str]]


class Step(NamedTuple):
    argv: list
    out: str                      # standard output goes to this file of the folder
    expected: str                 # 'ok', 'error' or 'either'
    check: Optional[Check] = None  # a success's output, checked: None or the problem
    unchanged: tuple = ()          # files of the folder whose bytes the step must not change


# -- checks of a success's output --------------------------------------------------------------------
def _text(path: Path) -> str:
    return path.read_bytes().decode("utf-8")   # a success must print valid UTF-8


def _not_finite(text: str) -> Optional[str]:
    found = NOT_FINITE.search(text)
    return f"prints {found.group(0)!r}" if found else None


def check_table(path: Path) -> Optional[str]:
    try:
        text = _text(path)
    except UnicodeDecodeError:
        return "output is not UTF-8"
    if not text.strip():
        return "empty output"
    return _not_finite(text)


def check_bba(path: Path, expected: Optional[dict] = None) -> Optional[str]:
    """A BBA file that the library reads back, finite, summing to one; optionally with the given masses."""
    from belief import MassFunction

    try:
        text = _text(path)
        data = json.loads(text, parse_constant=lambda c: float("nan"))
    except (UnicodeDecodeError, ValueError) as exc:
        return f"output is not a JSON document ({type(exc).__name__})"
    if not isinstance(data, dict) or not isinstance(data.get("mass"), dict):
        return "output has no \"mass\" object"
    values = list(data["mass"].values())
    if not all(isinstance(v, (int, float)) and math.isfinite(v) and v >= 0 for v in values):
        return "a mass is negative, NaN or inf"
    try:
        MassFunction.from_dict(data)
    except Exception as exc:   # noqa: BLE001 - any refusal of the result is the finding
        return f"not read back: {str(exc)[:120]}"
    if expected is not None:
        for key, value in expected.items():
            if not math.isclose(data["mass"].get(key, 0.0), value, rel_tol=1e-9, abs_tol=1e-12):
                return f"m({key}) = {data['mass'].get(key, 0.0)!r}, expected {value!r}"
        extra = set(data["mass"]) - set(expected)
        if extra:
            return f"unexpected focal elements {sorted(extra)[:3]}"
    return None


def check_probability(path: Path, expected: Optional[dict] = None) -> Optional[str]:
    """``{"probability": ...}`` over exclusive hypotheses: finite, in [0, 1], summing to one."""
    try:
        data = json.loads(_text(path), parse_constant=lambda c: float("nan"))
        values = list(data["probability"].values())
    except (UnicodeDecodeError, ValueError, KeyError, TypeError, AttributeError):
        return "output is not {\"probability\": {...}}"
    if not all(isinstance(v, (int, float)) and math.isfinite(v) and 0 <= v <= 1 + 1e-12 for v in values):
        return "a probability is not finite or not in [0, 1]"
    if abs(math.fsum(values) - 1) > 1e-9:
        return f"probabilities sum to {math.fsum(values)!r}"
    for key, value in (expected or {}).items():
        if not math.isclose(data["probability"].get(key, -1.0), value, rel_tol=1e-6):
            return f"P({key}) = {data['probability'].get(key)!r}, expected {value!r}"
    return None


def check_lattice_json(count: int) -> Check:
    """``lattice --json`` read as a stream: the count, and that many element strings, without loading it whole."""
    separator = re.compile(r"[ \t\n\r]*(,?)[ \t\n\r]*")

    def check(path: Path) -> Optional[str]:
        decoder = json.JSONDecoder()
        with open(path, encoding="utf-8") as f:
            head = f.read(1 << 16)
            start = head.find('"elements"')
            if start < 0:
                return "no \"elements\" in the output"
            buffer, pos = head, head.index("[", start) + 1
            seen = 0
            while True:
                if len(buffer) - pos < 1 << 15:
                    buffer, pos = buffer[pos:] + f.read(1 << 20), 0
                gap = separator.match(buffer, pos)
                pos = gap.end()
                if pos >= len(buffer):
                    return f"the output ends after {seen} elements"
                if buffer[pos] == "]":
                    break
                if bool(gap.group(1)) != bool(seen):
                    return f"malformed list after {seen} elements"
                try:
                    value, pos = decoder.raw_decode(buffer, pos)
                except ValueError:
                    return f"malformed element after {seen} elements"
                if not isinstance(value, str) or not value:
                    return f"element {seen} is not a proposition string"
                seen += 1
            rest = buffer[pos + 1:] + f.read()
        try:
            json.loads('{"x": []' + rest)
        except ValueError:
            return "the document does not end as JSON"
        found = re.search(r'"count"\s*:\s*(\d+)', head[:start] + rest)
        if not found or int(found.group(1)) != count:
            return f"count is not {count}"
        return None if seen == count else f"{seen} elements listed, count is {count}"

    return check


# -- inputs -----------------------------------------------------------------------------------------------
def _bba(frame, mass, model=None) -> str:
    data = {"frame": frame, "mass": mass}
    if model is not None:
        data["model"] = model
    return json.dumps(data)


def prepare(folder: Path) -> None:
    """The input files of the cases."""
    def write(name: str, text: str) -> None:
        (folder / name).write_text(text, encoding="utf-8")

    shafer = {"type": "shafer"}
    for i in range(1, 65):   # point 1: 64 identical Shafer sources
        write(f"s{i}.json", _bba(["a", "b"], {"a": 0.5, "b": 0.5}, shafer))
    for k in range(24):      # point 2: 24 sources of two focal elements, all different
        a = 0.2 + 0.6 * ((k * 37) % 64) / 64
        write(f"p{k}.json", _bba(["a", "b"], {"a": a, "b": 1 - a}, shafer))
    h = [f"h{i}" for i in range(10)]
    for k in range(25):      # point 2: 25 sources of five focal elements on the free frame of 10 hypotheses
        mass = {h[k % 10]: 0.3, f"{h[(k + 1) % 10]}|{h[(k + 3) % 10]}": 0.25,
                f"{h[(k + 2) % 10]}&{h[(k + 5) % 10]}": 0.15,
                f"{h[(k + 4) % 10]}|{h[(k + 6) % 10]}|{h[(k + 7) % 10]}": 0.2, "|".join(h): 0.1}
        write(f"f{k}.json", _bba(h, mass))
    # point 3
    write("type_list.json", _bba(["a", "b"], {"a": 1}, {"type": ["x"]}))
    write("type_list_model.json", json.dumps({"type": ["x"]}))
    write("ab.json", _bba(["a", "b"], {"a": 0.5, "b": 0.5}))
    write("int400.json", '{"frame": ["a", "b"], "mass": {"a": 1' + "0" * 399 + "}}")
    write("int5000.json", '{"frame": ["a", "b"], "mass": {"a": 1' + "0" * 4999 + "}}")
    write("deep_json.json", "[" * 50000 + "]" * 50000)
    write("deep_mass.json", '{"frame": ["a", "b"], "mass": ' + '{"a": ' * 50000 + "1" + "}" * 50001)
    write("parens400.json", _bba(["a", "b"], {"(" * 400 + "a" + ")" * 400: 0.5, "b": 0.5}))
    write("surrogate.json", '{"frame": ["\\ud800", "b"], "mass": {"\\ud800": 0.5, "b": 0.5}}')
    write("free1030.json", _bba([f"h{i}" for i in range(1030)], {"h0": 0.5, "h1|h2": 0.5}))
    write("shafer1000.json", _bba([f"h{i}" for i in range(1000)], {"h0": 0.5, "h1|h2": 0.5}, shafer))
    write("shafer10000.json", _bba([f"h{i}" for i in range(10000)], {"h0": 0.5, "h1|h2": 0.5}, shafer))
    # point 4: a union of n hypotheses through the general parser (parentheses)
    for n in (1000, 2000, 4000, 8000):
        names = [f"h{i}" for i in range(n)]
        write(f"union{n}.json", _bba(names, {"(" + "|".join(names[:-1]) + ")": 1.0}))
    # point 5: masses summing to 1 + 9e-10
    write("drift.json", _bba(["a", "b", "c"], {"a": 0.3, "b": 0.3, "a|b|c": 0.4000000009}))
    # point 6
    write("dsmp.json", _bba(["a", "b", "c"], {"a": 0.5, "b|c": 0.5}, shafer))
    hh = [f"h{i}" for i in range(5)]
    write("tiny1.json", _bba(hh, {"h4": 1, "h0|h1": 5e-324, "h2|h3": 1e-300}, shafer))
    write("tiny2.json", _bba(hh, {"h0": 2 / 3, "h1": 1 / 3}, shafer))
    write("tiny3.json", _bba(hh, {"h4": 1, "h0|h1": 5e-324}, shafer))
    write("tiny4.json", _bba(hh, {"h0": 0.4, "h1": 0.4, "h2": 0.2}, shafer))
    write("abc1.json", _bba(["A", "B", "C"], {"A": 0.5, "B|C": 0.5}))
    write("abc2.json", _bba(["A", "B", "C"], {"B": 0.5, "A|C": 0.5}))
    write("all_empty.json", json.dumps({"type": "hybrid", "empty": ["A|B|C"]}))
    # point 7
    write("duplicate.json", '{"frame": ["a", "b"], "mass": {"a": 0.5, "b": 0.2, "b": 0.5}}')
    write("invisible.json", '{"frame": ["a", "a\\u200b"], "mass": {"a": 0.5, "a\\u200b": 0.5}}')
    write("nul.json", '{"frame": ["a\\u0000b", "c"], "mass": {"a\\u0000b": 0.5, "c": 0.5}}')
    # point 9: plot outputs
    (folder / "plotdir").mkdir()
    (folder / "outside_plot.png").write_bytes(b"the user's own picture, not a plot\n")
    os.symlink("outside_plot.png", folder / "plot_link.png")
    # point 10: special files as a BBA file
    os.mkfifo(folder / "fifo.json")
    # point 11: 10^6 focal elements on a Shafer frame of 20 hypotheses (the subsets 1 .. 10^6 by their bits)
    names = [f"h{i}" for i in range(20)]
    count = 1_000_000
    with open(folder / "million.json", "w", encoding="utf-8") as f:
        f.write('{"model": {"type": "shafer"}, "frame": ' + json.dumps(names) + ', "mass": {')
        share = 1.0 / count
        f.write(", ".join('"' + "|".join(names[b] for b in range(20) if k >> b & 1) + '": ' + repr(share)
                          for k in range(1, count)))
        f.write(f', "{"|".join(names[b] for b in range(20) if count >> b & 1)}": {1.0 - share * (count - 1)!r}}}}}')
    write("vacuous20.json", _bba(names, {"h0": 0.5, "|".join(names): 0.5}, shafer))
    thousand = {"|".join(names[b] for b in range(20) if k >> b & 1): 1 / 1000 for k in range(1, 1001)}
    write("thousand.json", _bba(names, thousand, shafer))   # sums to 1 within 1e-15
    ten_thousand = {"|".join(names[b] for b in range(20) if k >> b & 1): 1 / 10_000 for k in range(1, 10_001)}
    write("tenk.json", _bba(names, ten_thousand, shafer))


def cases() -> list[tuple[str, list[Step]]]:
    """(name, steps); the steps run in order and stop at the first non-zero exit status."""
    def one(name, argv, expected, check=None):
        return name, [Step(argv, _slug(name) + ".out", expected, check)]

    sixty_four = [f"s{i}.json" for i in range(1, 65)]
    twenty_four = [f"p{k}.json" for k in range(24)]
    twenty_five = [f"f{k}.json" for k in range(25)]
    listed = []
    for rule in ("dsmh", "pcr5", "pcr6", "dubois_prade"):
        listed.append(one(f"1 {rule}, 64 sources", ["combine", "--rule", rule, *sixty_four, "--json"],
                          "either", check_bba))
    for rule in ("pcr6", "dsmh"):
        listed.append(one(f"2 {rule}, 24 x 2", ["combine", "--rule", rule, *twenty_four, "--json"],
                          "either", check_bba))
    for rule in ("dempster", "conjunctive", "disjunctive"):
        listed.append(one(f"2 {rule}, 25 x 5 free 10", ["combine", "--rule", rule, *twenty_five, "--json"],
                          "either", check_bba))
    listed += [
        one("3 model type list (measures)", ["measures", "type_list.json"], "error"),
        one("3 model type list (combine)", ["combine", "--rule", "dempster", "ab.json", "ab.json",
                                            "--model", "type_list_model.json"], "error"),
        one("3 mass of 400 digits (measures)", ["measures", "int400.json"], "error"),
        one("3 mass of 400 digits (transform)", ["transform", "int400.json", "--pignistic"], "error"),
        one("3 mass of 5000 digits (measures)", ["measures", "int5000.json"], "error"),
        one("3 mass of 5000 digits (combine)", ["combine", "--rule", "pcr6", "int5000.json", "ab.json"],
            "error"),
        one("3 JSON nested 50000 deep", ["measures", "deep_json.json"], "error"),
        one("3 mass nested 50000 deep", ["transform", "deep_mass.json", "--pignistic"], "error"),
        one("3 400 nested parentheses", ["measures", "parens400.json"], "either", check_table),
        one("3 hypothesis '\\ud800' (measures)", ["measures", "surrogate.json"], "either", check_table),
        one("3 hypothesis '\\ud800' (combine)", ["combine", "--rule", "dempster", "surrogate.json",
                                                 "surrogate.json", "--json"], "either", check_bba),
        one("3 free frame of 1030 (measures)", ["measures", "free1030.json"], "either", check_table),
        one("3 Shafer 1000 hypotheses", ["measures", "shafer1000.json"], "either", check_table),
        one("3 Shafer 10000 hypotheses", ["measures", "shafer10000.json"], "either", check_table),
    ]
    for n in (1000, 2000, 4000, 8000):
        listed.append(one(f"4 union of {n // 1000}k hypotheses",
                          ["transform", f"union{n}.json", "--discount", "0.9", "--json"], "ok", check_bba))
    listed += [
        ("5 pcr6 x3 of 1 + 9e-10, read back", [
            Step(["combine", "--rule", "pcr6", "drift.json", "drift.json", "drift.json", "--json"],
                 "drift_pcr6.json", "ok", check_bba),
            Step(["measures", "drift_pcr6.json"], "drift_measures.out", "ok", check_table)]),
        ("5 pcr6 chain of 1 + 9e-10, read back", [
            Step(["combine", "--rule", "pcr6", "drift.json", "drift.json", "--json"], "chain1.json", "ok", check_bba),
            Step(["combine", "--rule", "pcr6", "chain1.json", "drift.json", "--json"], "chain2.json", "ok",
                 check_bba),
            Step(["combine", "--rule", "pcr6", "chain2.json", "drift.json", "--json"], "chain3.json", "ok",
                 check_bba),
            Step(["measures", "chain3.json"], "chain_measures.out", "ok", check_table)]),
        one("6 DSmP eps 1e308", ["transform", "dsmp.json", "--dsmp", "1e308", "--json"], "either",
            lambda p: check_probability(p, {"a": 0.5, "b": 0.25, "c": 0.25})),
        one("6 dempster, K = 1 - 5e-324", ["combine", "--rule", "dempster", "tiny1.json", "tiny2.json", "--json"],
            "either", lambda p: check_bba(p, {"h0": 2 / 3, "h1": 1 / 3})),
        one("6 dempster, K < 1 called total", ["combine", "--rule", "dempster", "tiny3.json", "tiny4.json",
                                              "--json"], "either", lambda p: check_bba(p, {"h0": 0.5, "h1": 0.5})),
        one("6 yager, model makes all empty", ["combine", "--rule", "yager", "abc1.json", "abc2.json",
                                               "--model", "all_empty.json", "--json"], "error"),
        one("6 dsmh, model makes all empty", ["combine", "--rule", "dsmh", "abc1.json", "abc2.json",
                                              "--model", "all_empty.json", "--json"], "error"),
        one("7 duplicate JSON keys", ["measures", "duplicate.json"], "error"),
        one("7 names 'a' and 'a\\u200b'", ["measures", "invisible.json"], "error"),
        one("7 NUL in a name", ["measures", "nul.json"], "error"),
        one("8 lattice 100000000", ["lattice", "100000000"], "error"),
        one("8 lattice 6 --json", ["lattice", "6", "--json"], "ok", check_lattice_json(7828353)),
    ]
    if importlib.util.find_spec("matplotlib") is not None:
        listed += [
            one("9 plot --out X (no suffix)", ["plot", "ab.json", "--out", "X"], "ok", check_exactly("X")),
            one("9 plot --out missing/x.png", ["plot", "ab.json", "--out", "missing/x.png"], "error"),
            one("9 plot --out name of 300 chars", ["plot", "ab.json", "--out", "p" * 300 + ".png"], "error"),
            one("9 plot --out a folder", ["plot", "ab.json", "--out", "plotdir"], "error"),
            ("9 plot --out symlink to outside", [
                Step(["plot", "ab.json", "--out", "plot_link.png"], "plot_link.out", "either",
                     check_exactly("plot_link.png"), unchanged=("outside_plot.png",))]),
        ]
    else:
        print("matplotlib is not installed: the plot cases (9) are skipped", flush=True)
    listed += [
        one("10 combine: /dev/zero as a BBA", ["combine", "--rule", "dempster", "/dev/zero", "ab.json"], "error"),
        one("10 combine: FIFO as a BBA", ["combine", "--rule", "dempster", "fifo.json", "ab.json"], "error"),
        one("10 measures: FIFO as a BBA", ["measures", "fifo.json"], "error"),
        one("11 10^6 focal elements (measures)", ["measures", "million.json"], "either", check_table),
        one("11 10^3 focal elements (measures)", ["measures", "thousand.json"], "either", check_table),
        one("11 10^6 focal elements (combine)", ["combine", "--rule", "dempster", "million.json", "vacuous20.json",
                                                 "--json"], "either", check_bba),
        one("11 10^6 focal elements (transform)", ["transform", "million.json", "--pignistic", "--json"],
            "either", check_probability),
        one("11 10^3 focal elements (jousselme)", ["distance", "thousand.json", "vacuous20.json"], "either"),
        one("11 10^4 focal elements (jousselme)", ["distance", "tenk.json", "vacuous20.json"], "either"),
        one("11 10^6 focal elements (jousselme)", ["distance", "million.json", "vacuous20.json"], "either"),
        one("11 10^4 focal elements (uncertainty)", ["uncertainty", "tenk.json"], "either"),
        one("11 10^4 focal elements (decide)", ["decide", "tenk.json"], "either"),
        one("11 10^4 focal elements (plot)", ["plot", "tenk.json", "--out", "tenk.png"], "either"),
        one("11 10^6 focal elements (plot)", ["plot", "million.json", "--out", "million.png"], "either"),
    ]
    return listed


def check_exactly(name: str) -> Check:
    """``plot --out NAME`` wrote a picture at NAME itself (a regular file, not through a symlink), nothing at
    NAME.png, and printed the path it wrote."""
    def check(path: Path) -> Optional[str]:
        folder, target = path.parent, path.parent / name
        if not target.is_file() or target.is_symlink():
            return f"{name} is not a regular file"
        if not name.endswith(".png") and (folder / (name + ".png")).exists():
            return f"wrote {name}.png as well"
        if target.read_bytes()[:8] != b"\x89PNG\r\n\x1a\n":
            return f"{name} is not a PNG"
        text = path.read_text(encoding="utf-8", errors="replace")
        if name not in text or (not name.endswith(".png") and name + ".png" in text):
            return f"prints {text.strip()[:60]!r}, not the path written"
        return None

    return check


def _slug(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "_", name).strip("_")


def verdict(step: Step, result: Usage, folder: Path) -> list[str]:
    """The problems of one step's run (an empty list: PASS)."""
    problems = []
    lines = result.stderr.splitlines()
    if result.killed:
        problems.append(f"killed after {KILL_SECONDS:g} s")
    elif result.seconds > LIMIT_SECONDS:
        problems.append(f"> {LIMIT_SECONDS:g} s")
    if result.peak > LIMIT_BYTES:
        problems.append(f"> {LIMIT_BYTES / 2**30:g} GB")
    if "Traceback" in result.stderr:
        problems.append("traceback")
    if result.killed:
        return problems
    if result.status == 0:
        if step.expected == "error":
            problems.append("exit 0")
        if lines:
            problems.append(f"{len(lines)} stderr lines")
        if step.expected != "error":
            problem = (step.check or check_table)(folder / step.out)
            if problem is None and step.check is not None and (folder / step.out).stat().st_size < 1 << 26:
                problem = _not_finite(_text(folder / step.out))
            if problem:
                problems.append(problem)
    else:
        if step.expected == "ok":
            problems.append(f"exit {result.status}")
        elif result.status < 0 or result.status > 125:
            problems.append(f"exit {result.status} (signal)")
        if len(lines) != 1:
            problems.append(f"{len(lines)} stderr lines")
    return problems


def _bytes(path: Path) -> Optional[bytes]:
    try:
        return path.read_bytes()
    except OSError:
        return None


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--keep", metavar="DIR", help="work in DIR and keep it")
    parser.add_argument("-k", metavar="TEXT", help="only the cases whose name contains TEXT")
    args = parser.parse_args()
    folder = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="hardening-"))
    folder.mkdir(parents=True, exist_ok=True)
    try:
        prepare(folder)
        selected = [(name, steps) for name, steps in cases() if not args.k or args.k in name]
        print(f"{'case':38} {'exit':>4} {'stderr':>6} {'seconds':>8} {'peak MB':>8}  verdict", flush=True)
        failed = 0
        for name, steps in selected:
            seconds, peak, problems, status, first_line, count = 0.0, 0, [], 0, "", 0
            for step in steps:
                kept = {name: _bytes(folder / name) for name in step.unchanged}
                result = run_cli(step.argv, folder, stdout=folder / step.out, kill_after=KILL_SECONDS,
                                 address_space=ADDRESS_SPACE)
                seconds += result.seconds
                peak = max(peak, result.peak)
                status, lines = result.status, result.stderr.splitlines()
                count = len(lines)
                first_line = lines[-1] if "Traceback" in result.stderr and lines else (lines[0] if lines else "")
                problems += [f"{' '.join(map(str, step.argv[:1]))}: {p}" if len(steps) > 1 else p
                             for p in verdict(step, result, folder)]
                problems += [f"changed {name}" for name, data in kept.items() if _bytes(folder / name) != data]
                if result.status != 0:
                    break
            shown = "PASS" if not problems else "FAIL (" + "; ".join(problems) + ")"
            failed += bool(problems)
            print(f"{name:38} {status:>4} {count:>6} {seconds:>8.2f} {peak / 2**20:>8.0f}  {shown}", flush=True)
            if first_line:
                print(f"    {first_line[:150]}", flush=True)
        print(f"{failed} of {len(selected)} cases failed")
        return 1 if failed else 0
    finally:
        if not args.keep:
            shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
