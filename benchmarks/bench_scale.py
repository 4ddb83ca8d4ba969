"""Benchmark: how the cost of a first call grows with the size of the frame and the number of focal elements.

Run from the repository root::

    python benchmarks/bench_scale.py            # the table, and PASS/FAIL per target
    python benchmarks/bench_scale.py --check    # exit 1 if a target fails
    python benchmarks/bench_scale.py --json     # machine-readable output
    python benchmarks/bench_scale.py --quick    # smaller sizes, one repetition (targets skipped)

Every figure is a first call on fresh inputs, the call a researcher waits for: each
measurement runs on a frame of hypothesis names never seen before in the process (so no
cache of an earlier measurement helps), and on mass functions just built from string
mappings (``{"h3": 0.2, ...}``), the way a user writes them.  Building the sources is timed
apart ("build").  Each figure is the median of ``--repeat`` such first calls.

Cases and targets:

* two Bayesian sources (every focal element a single hypothesis) over n hypotheses under
  Shafer's model, n = 500, 1 000, 2 000: Dempster's rule, the conjunctive rule and PCR6,
  ≤ 10 ms each at n = 2 000, and the first-call cost of Dempster's rule growing no faster
  than n^1.2 from n = 500 to 2 000 (the exponent is printed for every rule);
* what is read of a Bayesian mass function over n = 2 000 and 20 000 hypotheses:
  ``decide(m, "betp" / "pls" / "bel")`` and BetP, Bel and Pls of every hypothesis,
  ≤ 5 ms at 2 000 and ≤ 100 ms at 20 000;
* Dempster's rule of two sources with 1 000 random focal elements each (random non-empty
  unions of hypotheses) on 64 hypotheses under Shafer's model: ≤ 1 s;
* the same through the command line, ``belief combine`` and ``belief decide`` on BBA files
  over 2 000 hypotheses, minus the start of the process: a fresh interpreter imports the
  command line, then times the command from its arguments to its last line of output, and
  the same on files over three hypotheses is subtracted (the parser, the plugins' commands and
  the lazy imports of a first command cost the same whatever the size).

Peers from the ``bench`` extra run the cases they implement, in the same run, on the same
mappings, with a budget: py-dempster-shafer (``pyds``: Dempster's rule, BetP) and pybelief
(Dempster's rule over bit masks, which it takes as Python integers of any size).  A peer that
takes longer than ``--peer-budget`` seconds on a size is not run on the larger sizes.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import itertools
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import belief  # noqa: E402
from belief import Frame, MassFunction, Model, combine  # noqa: E402
from belief.decisions import decide  # noqa: E402

_FRESH = itertools.count()


def fresh_names(n: int) -> list[str]:
    """n hypothesis names no frame of this process has used yet."""
    tag = next(_FRESH)
    return [f"x{tag}_{i}" for i in range(n)]


def bayesian_mapping(rng: np.random.Generator, names: list[str]) -> dict[str, float]:
    p = rng.random(len(names))
    p /= p.sum()
    return dict(zip(names, p.tolist()))


def general_mapping(rng: np.random.Generator, names: list[str], k: int) -> dict[str, float]:
    """k distinct random non-empty unions of the hypotheses, with random masses."""
    n = len(names)
    seen: set[int] = set()
    while len(seen) < k:
        mask = int(rng.integers(1, 1 << 62)) | (int(rng.integers(0, 4)) << 62)
        seen.add(mask & ((1 << n) - 1) or 1)
    masses = rng.random(k)
    masses /= masses.sum()
    return {"|".join(names[i] for i in range(n) if mask >> i & 1): float(v) for mask, v in zip(sorted(seen), masses)}


def timed(function) -> tuple[float, object]:
    start = time.perf_counter()
    result = function()
    return time.perf_counter() - start, result


def median_ms(values: list[float]) -> float:
    return 1e3 * statistics.median(values)


# -- belief ------------------------------------------------------------------------------------------
def belief_rule(n: int, rule: str, repeat: int, rng: np.random.Generator) -> dict:
    """The first call on fresh sources (``ms``), their build, and the same call again (``warm_ms``)."""
    build, call, again = [], [], []
    for _ in range(repeat):
        names = fresh_names(n)
        maps = [bayesian_mapping(rng, names), bayesian_mapping(rng, names)]
        t_build, sources = timed(lambda: (lambda model: [MassFunction(m, model=model) for m in maps])(
            Model.shafer(Frame(names))))
        t_call, _ = timed(lambda: combine(*sources, rule=rule))
        t_again, _ = timed(lambda: combine(*sources, rule=rule))
        build.append(t_build)
        call.append(t_call)
        again.append(t_again)
    return {"build_ms": median_ms(build), "ms": median_ms(call), "warm_ms": median_ms(again)}


def belief_reading(n: int, what: str, repeat: int, rng: np.random.Generator) -> dict:
    call = []
    for _ in range(repeat):
        names = fresh_names(n)
        m = MassFunction(bayesian_mapping(rng, names), model=Model.shafer(Frame(names)))
        if what.startswith("decide"):
            criterion = what.split()[1]
            t, _ = timed(lambda: decide(m, criterion))
        else:
            measure = what.lower()
            t, _ = timed(lambda: getattr(m.batch(), measure)(m.frame.singletons))
        call.append(t)
    return {"ms": median_ms(call)}


def belief_general(n: int, k: int, repeat: int, rng: np.random.Generator) -> dict:
    """As :func:`belief_rule`, for two sources of ``k`` random unions of hypotheses each."""
    build, call, again = [], [], []
    for _ in range(repeat):
        names = fresh_names(n)
        maps = [general_mapping(rng, names, k), general_mapping(rng, names, k)]
        model = Model.shafer(Frame(names))
        t_build, sources = timed(lambda: [MassFunction(m, model=model) for m in maps])
        t_call, _ = timed(lambda: combine(*sources, rule="dempster"))
        t_again, _ = timed(lambda: combine(*sources, rule="dempster"))
        build.append(t_build)
        call.append(t_call)
        again.append(t_again)
    return {"build_ms": median_ms(build), "ms": median_ms(call), "warm_ms": median_ms(again)}


# -- peers ---------------------------------------------------------------------------------------------
def quiet_import(name: str):
    try:
        with contextlib.redirect_stderr(io.StringIO()):
            return __import__(name)
    except ImportError:
        return None


def peer_dempster(library: str, maps: list[dict[str, float]], names: list[str]) -> float:
    """Seconds for the peer to build its two sources from the mappings and combine them by Dempster's rule."""
    if library == "pyds":
        pyds = quiet_import("pyds")
        start = time.perf_counter()
        a, b = (pyds.MassFunction({frozenset(key.split("|")): v for key, v in m.items()}) for m in maps)
        a.combine_conjunctive(b)
        return time.perf_counter() - start
    pybelief = quiet_import("pybelief")
    bit = {h: 1 << i for i, h in enumerate(names)}
    start = time.perf_counter()
    a, b = (pybelief.MassFunction(names, {sum(bit[h] for h in key.split("|")): v for key, v in m.items()})
            for m in maps)
    a.combine_dempster(b)
    return time.perf_counter() - start


def peer_betp(maps: dict[str, float]) -> float:
    pyds = quiet_import("pyds")
    start = time.perf_counter()
    m = pyds.MassFunction({frozenset(key.split("|")): v for key, v in maps.items()})
    pignistic = m.pignistic()
    max(pignistic.items(), key=lambda item: item[1])
    return time.perf_counter() - start


# -- the command line ------------------------------------------------------------------------------------
#: Run in a fresh interpreter: import the command line, then time one command, from parsing its arguments to its
#: last line of output (sent to /dev/null), and print the seconds.
_TIME_COMMAND = """
import contextlib, os, sys, time
import belief.cli
arguments = sys.argv[1:]
with open(os.devnull, "w") as sink, contextlib.redirect_stdout(sink):
    start = time.perf_counter()
    status = belief.cli.main(arguments)
    seconds = time.perf_counter() - start
assert status == 0, status
print(seconds)
"""


def cli_seconds(arguments: list[str], repeat: int) -> float:
    """Median seconds of a ``belief`` command in a fresh process, without the start of the process."""
    times = []
    for _ in range(repeat):
        done = subprocess.run([sys.executable, "-c", _TIME_COMMAND, *arguments], check=True, capture_output=True,
                              text=True, cwd=ROOT)
        times.append(float(done.stdout.split()[-1]))
    return statistics.median(times)


def write_bba(folder: str, name: str, names: list[str], rng: np.random.Generator) -> str:
    path = os.path.join(folder, name)
    with open(path, "w", encoding="utf-8") as f:
        json.dump({"frame": names, "model": {"type": "shafer"}, "mass": bayesian_mapping(rng, names)}, f)
    return path


def cli_cases(n: int, repeat: int, rng: np.random.Generator) -> list[dict]:
    """The commands on files over n hypotheses, and (for comparison) over three, in fresh processes."""
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        names = [f"h{i}" for i in range(n)]
        paths = [write_bba(folder, f"source{i}.json", names, rng) for i in range(2)]
        small = [write_bba(folder, f"small{i}.json", ["a", "b", "c"], rng) for i in range(2)]
        for label, command in ((f"belief combine --rule dempster, n = {n}", ["combine", "--rule", "dempster"]),
                               (f"belief combine --rule pcr6, n = {n}", ["combine", "--rule", "pcr6"]),
                               (f"belief decide, n = {n}", ["decide"])):
            count = 1 if command == ["decide"] else 2
            small_run = cli_seconds(command + small[:count], repeat)
            total = cli_seconds(command + paths[:count], repeat)
            rows.append({"case": label, "ms": 1e3 * (total - small_run), "command_ms": 1e3 * total,
                         "small_ms": 1e3 * small_run})
    return rows


# -- the run ------------------------------------------------------------------------------------------
def growth(small: float, large: float, n_small: int, n_large: int) -> float:
    return math.log(large / small) / math.log(n_large / n_small)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if a target fails")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    parser.add_argument("--quick", action="store_true", help="small sizes, one repetition; targets skipped")
    parser.add_argument("--repeat", type=int, default=5, help="first calls per figure (median; default 5)")
    parser.add_argument("--peer-budget", type=float, default=5.0, help="seconds a peer may take on one size")
    args = parser.parse_args(argv)
    repeat = 1 if args.quick else max(1, args.repeat)
    rng = np.random.default_rng(2026)
    sizes = (100, 200, 400) if args.quick else (500, 1000, 2000)
    reading_sizes = (200, 2000) if args.quick else (2000, 20000)
    have = {name: quiet_import(name) is not None for name in ("pyds", "pybelief")}
    rows: list[dict] = []
    log = (lambda *a: None) if args.json else (lambda *a: print(*a, flush=True))
    log(f"belief {belief.__version__}, numpy {np.__version__}, {os.cpu_count()} CPUs; "
        f"median of {repeat} first calls on fresh frames")

    log("\nTwo Bayesian sources over n hypotheses (Shafer's model), first call")
    log(f"{'rule':<12}" + "".join(f"{f'n = {n}':>14}" for n in sizes) + f"{'growth':>9}{'build (n max)':>15}"
        f"{'again (n max)':>15}")
    for rule in ("dempster", "conjunctive", "pcr6"):
        figures = [belief_rule(n, rule, repeat, rng) for n in sizes]
        exponent = growth(figures[0]["ms"], figures[-1]["ms"], sizes[0], sizes[-1])
        for n, f in zip(sizes, figures):
            rows.append({"case": f"{rule}, Bayesian, n = {n}", "rule": rule, "n": n, **f})
        rows.append({"case": f"{rule}, growth exponent", "rule": rule, "exponent": exponent})
        log(f"{rule:<12}" + "".join(f"{f['ms']:>11.2f} ms" for f in figures) + f"{exponent:>9.2f}"
            f"{figures[-1]['build_ms']:>12.2f} ms{figures[-1]['warm_ms']:>12.2f} ms")
    for peer in ("pyds", "pybelief"):
        if not have[peer]:
            log(f"{peer}: not installed (pip install '.[bench]')")
            continue
        line = []
        for n in sizes:
            names = [f"p{i}" for i in range(n)]
            maps = [bayesian_mapping(rng, names), bayesian_mapping(rng, names)]
            seconds = peer_dempster(peer, maps, names)
            ours = next(r["ms"] for r in rows if r.get("rule") == "dempster" and r.get("n") == n)
            rows.append({"case": f"dempster, Bayesian, n = {n}, {peer}", "peer": peer, "n": n, "ms": 1e3 * seconds,
                         "ratio": 1e3 * seconds / ours})
            line.append(f"{1e3 * seconds:>11.1f} ms")
            if seconds > args.peer_budget:
                break
        log(f"{peer + ' (dempster, build + call)':<12}  " + "".join(line))

    log("\nReading a Bayesian mass function over n hypotheses, first call")
    log(f"{'reading':<14}" + "".join(f"{f'n = {n}':>14}" for n in reading_sizes))
    for what in ("decide betp", "decide pls", "decide bel", "BetP", "Bel", "Pls"):
        figures = [belief_reading(n, what, repeat, rng) for n in reading_sizes]
        for n, f in zip(reading_sizes, figures):
            rows.append({"case": f"{what}, n = {n}", "reading": what, "n": n, **f})
        log(f"{what:<14}" + "".join(f"{f['ms']:>11.2f} ms" for f in figures))
    if have["pyds"]:
        for n in reading_sizes:
            names = [f"q{i}" for i in range(n)]
            seconds = peer_betp(bayesian_mapping(rng, names))
            ours = next(r["ms"] for r in rows if r.get("reading") == "decide betp" and r.get("n") == n)
            rows.append({"case": f"decide betp, n = {n}, pyds", "peer": "pyds", "n": n, "ms": 1e3 * seconds,
                         "ratio": 1e3 * seconds / ours})
            log(f"{'pyds betp + argmax (build + call)':<14} n = {n}: {1e3 * seconds:.1f} ms")

    general_n, general_k = (32, 200) if args.quick else (64, 1000)
    log(f"\nDempster's rule, two sources of {general_k} random focal elements on {general_n} hypotheses (Shafer)")
    figure = belief_general(general_n, general_k, repeat, rng)
    rows.append({"case": f"dempster, {general_k} focal elements, n = {general_n}", **figure})
    log(f"belief: {figure['ms']:.1f} ms (build {figure['build_ms']:.1f} ms; the same call again "
        f"{figure['warm_ms']:.1f} ms)")
    for peer in ("pybelief", "pyds"):
        if have[peer]:
            names = [f"g{i}" for i in range(general_n)]
            maps = [general_mapping(rng, names, general_k), general_mapping(rng, names, general_k)]
            seconds = peer_dempster(peer, maps, names)
            rows.append({"case": f"dempster, {general_k} focal elements, n = {general_n}, {peer}", "peer": peer,
                         "ms": 1e3 * seconds, "ratio": 1e3 * seconds / figure["ms"]})
            log(f"{peer} (build + call): {1e3 * seconds:.1f} ms")

    log("\nThe command line, first command of a fresh process, after its imports")
    for row in cli_cases(sizes[-1], 1 if args.quick else 3, rng):
        rows.append(row)
        log(f"{row['case']:<40} {row['ms']:>8.1f} ms beyond the same command on three hypotheses "
            f"({row['command_ms']:.1f} ms against {row['small_ms']:.1f} ms)")

    failed = [] if args.quick else check_targets(rows, log)
    if args.json:
        print(json.dumps({"rows": rows, "failed": failed}, indent=2))
    return 1 if args.check and failed else 0


def check_targets(rows: list[dict], log) -> list[str]:
    def ms(case: str) -> float:
        return next(r["ms"] for r in rows if r["case"] == case)

    targets = []
    for rule in ("dempster", "conjunctive", "pcr6"):
        targets.append((f"{rule} of two Bayesian sources, n = 2000, ≤ 10 ms", ms(f"{rule}, Bayesian, n = 2000") <= 10))
    exponent = next(r["exponent"] for r in rows if r["case"] == "dempster, growth exponent")
    targets.append((f"Dempster's first call grows as n^{exponent:.2f} from 500 to 2000, ≤ n^1.2", exponent <= 1.2))
    for what in ("decide betp", "decide pls", "decide bel", "BetP", "Bel", "Pls"):
        targets.append((f"{what} over 2000 hypotheses ≤ 5 ms", ms(f"{what}, n = 2000") <= 5))
        targets.append((f"{what} over 20000 hypotheses ≤ 100 ms", ms(f"{what}, n = 20000") <= 100))
    targets.append(("Dempster of two 1000-focal-element sources on 64 hypotheses ≤ 1 s",
                    ms("dempster, 1000 focal elements, n = 64") <= 1000))
    for label in ("belief combine --rule dempster, n = 2000", "belief combine --rule pcr6, n = 2000"):
        targets.append((f"{label} ≤ 10 ms beyond the process start", ms(label) <= 10))
    targets.append(("belief decide, n = 2000 ≤ 5 ms beyond the process start", ms("belief decide, n = 2000") <= 5))
    log("\nTargets")
    failed = []
    for label, ok in targets:
        log(f"  {'PASS' if ok else 'FAIL'}  {label}")
        if not ok:
            failed.append(label)
    return failed


if __name__ == "__main__":
    sys.exit(main())
