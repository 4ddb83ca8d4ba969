"""Benchmark: generating the hyper-power set D^Θ, against evidencelib.

Run from the repository root::

    python benchmarks/bench_lattice.py            # table
    python benchmarks/bench_lattice.py --check    # exit 1 if a target fails
    python benchmarks/bench_lattice.py --json     # machine-readable output

For n = 1..6 hypotheses it times ``belief.hyper_power_set`` on the free DSm model (and,
for information, on Shafer's model and the tracking model ``t1..t(n-1), FA``), and for
n ≤ 5 the same lattices built by evidencelib (``Frame.dsmt(names).elements(max_count=None)``,
pure Python) in the same run.  The peer comes from the ``bench`` extra
(``pip install ".[bench]"``); without it only belief's figures are printed.

Every measurement runs in a fresh (spawned) process:

* time: best of ``--repeat`` runs (default 5, 3 for n = 6 and for evidencelib at n = 5);
* RSS: increase of the peak resident set size (``ru_maxrss``) over its value after the
  imports, taken on the first run;
* tracemalloc: peak of the allocations traced in one extra run (numpy reports its
  buffers to tracemalloc, so the arrays are counted).

Targets: n = 6 (free) in under 1 s (first run and best run) and under 300 MB of peak RSS
increase; n = 5 (free) at least 100 times faster than evidencelib; both libraries give the
same element counts, and those are the known sizes.
"""

from __future__ import annotations

import argparse
import gc
import importlib.util
import json
import multiprocessing
import platform
import resource
import sys
import time
import tracemalloc
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

# Measure the checkout this script belongs to, installed or not (spawned children inherit sys.path).
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

MODELS = ("free", "shafer", "tracking")
PEER_MAX_N = 5  # evidencelib's tracking lattice alone takes minutes at n = 6
FREE_SIZES = {1: 2, 2: 5, 3: 19, 4: 167, 5: 7580, 6: 7828353}  # Dedekind numbers - 1
TIME_LIMIT_S, RSS_LIMIT_MB, MIN_RATIO = 1.0, 300.0, 100.0


def expected_size(model: str, n: int) -> int:
    return {"free": FREE_SIZES[n], "shafer": 2 ** n, "tracking": 2 * FREE_SIZES.get(n - 1, 0)}[model]


def hypotheses(model: str, n: int) -> list[str]:
    if model == "tracking":
        return [f"t{i}" for i in range(1, n)] + ["FA"]
    return [f"t{i}" for i in range(1, n + 1)]


def builder(library: str, model: str, n: int):
    """Import ``library`` and return a function that builds D^Θ with it."""
    names = hypotheses(model, n)
    if library == "belief":
        import belief

        make_model = {"free": belief.Model.free, "shafer": belief.Model.shafer,
                      "tracking": belief.Model.tracking}[model]
        return lambda: belief.hyper_power_set(make_model(belief.Frame(names)))
    import evidencelib

    if model == "free":
        return lambda: evidencelib.Frame.dsmt(names).elements(max_count=None)
    if model == "shafer":
        return lambda: evidencelib.Frame.dst(names).elements(max_count=None)
    empty = [f"{t}&FA" for t in names[:-1]]
    return lambda: evidencelib.Frame.hybrid(names, empty=empty).elements(max_count=None)


def peak_rss_mb() -> float:
    """Peak resident set size so far, in MB (10^6 bytes)."""
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / 1e6 if sys.platform == "darwin" else peak * 1024 / 1e6  # bytes on macOS, KiB elsewhere


def measure(library: str, model: str, n: int, repeat: int) -> dict:
    """Runs in a fresh process: time, peak RSS increase and tracemalloc peak of one build."""
    build = builder(library, model, n)
    gc.collect()
    baseline = peak_rss_mb()
    times = []
    for run in range(repeat):
        start = time.perf_counter()
        result = build()
        times.append(time.perf_counter() - start)
        if run == 0:
            rss = peak_rss_mb() - baseline
            count = len(result)
        del result
        gc.collect()
    tracemalloc.start()
    build()
    traced = tracemalloc.get_traced_memory()[1] / 1e6
    tracemalloc.stop()
    return {"elements": count, "time_s": min(times), "first_s": times[0], "repeat": repeat,
            "rss_mb": rss, "tracemalloc_mb": traced}


def in_fresh_process(*args) -> dict:
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        return pool.submit(measure, *args).result()


def run(max_n: int, repeat: int | None, have_peer: bool) -> list[dict]:
    rows = []
    for model in MODELS:
        for n in range(2 if model == "tracking" else 1, max_n + 1):
            row = {"model": model, "n": n, "expected": expected_size(model, n)}
            row["belief"] = in_fresh_process("belief", model, n, repeat or (3 if n >= 6 else 5))
            peer = None
            if have_peer and n <= PEER_MAX_N:
                peer = in_fresh_process("evidencelib", model, n, repeat or (3 if n >= 5 else 5))
            row["evidencelib"] = peer
            row["ratio"] = peer["time_s"] / row["belief"]["time_s"] if peer else None
            row["same_count"] = peer["elements"] == row["belief"]["elements"] if peer else None
            rows.append(row)
    return rows


def targets(rows: list[dict], have_peer: bool) -> list[dict]:
    free = {r["n"]: r for r in rows if r["model"] == "free"}

    def target(name, value, ok, skip_reason=None):
        status = "SKIP" if skip_reason else ("PASS" if ok else "FAIL")
        return {"target": name, "value": value, "status": status, "note": skip_reason}

    six, five = free.get(6), free.get(5)
    found = [
        target(f"n=6 free: first (cold) run < {TIME_LIMIT_S:g} s", six and six["belief"]["first_s"],
               six and six["belief"]["first_s"] < TIME_LIMIT_S, None if six else "--max-n < 6"),
        target(f"n=6 free: best run < {TIME_LIMIT_S:g} s", six and six["belief"]["time_s"],
               six and six["belief"]["time_s"] < TIME_LIMIT_S, None if six else "--max-n < 6"),
        target(f"n=6 free: peak RSS increase < {RSS_LIMIT_MB:g} MB", six and six["belief"]["rss_mb"],
               six and six["belief"]["rss_mb"] < RSS_LIMIT_MB, None if six else "--max-n < 6"),
        target(f"n=5 free: >= {MIN_RATIO:g}x faster than evidencelib", five and five["ratio"],
               five and five["ratio"] is not None and five["ratio"] >= MIN_RATIO,
               None if five and have_peer else ("evidencelib not installed" if five else "--max-n < 5")),
    ]
    checked = [r for r in rows if r["same_count"] is not None]
    found.append(target("same element counts as evidencelib", len(checked),
                        all(r["same_count"] for r in checked),
                        None if checked else "evidencelib not installed"))
    found.append(target("element counts as expected", len(rows),
                        all(r["belief"]["elements"] == r["expected"] for r in rows)))
    return found


def print_table(rows: list[dict], found: list[dict], have_peer: bool) -> None:
    print("Generating D^Θ (∅ included), each measurement in a fresh process: ms = best of the runs,")
    print("cold = first run, RSS = peak RSS increase, trace = tracemalloc peak (MB = 10^6 bytes);")
    print("tracking = frame t1..t(n-1), FA")
    header = f"{'model':<9}{'n':>2}{'elements':>10} | {'belief ms':>10}{'cold ms':>9}{'RSS MB':>8}{'trace MB':>9}"
    if have_peer:
        header += f" | {'evidencelib ms':>14}{'RSS MB':>8}{'trace MB':>9}{'ratio':>8}{'same':>6}"
    print(header)
    print("-" * len(header))
    for r in rows:
        b = r["belief"]
        line = (f"{r['model']:<9}{r['n']:>2}{b['elements']:>10} | "
                f"{b['time_s'] * 1e3:>10.3f}{b['first_s'] * 1e3:>9.3f}{b['rss_mb']:>8.1f}{b['tracemalloc_mb']:>9.1f}")
        if have_peer:
            e = r["evidencelib"]
            line += (f" | {e['time_s'] * 1e3:>14.3f}{e['rss_mb']:>8.1f}{e['tracemalloc_mb']:>9.1f}"
                     f"{r['ratio']:>7.1f}x{'yes' if r['same_count'] else 'NO':>6}" if e else f" | {'-':>14}")
        print(line)
    print()
    for t in found:
        value = t["value"]
        shown = f"{value:.3f}" if isinstance(value, float) else str(value)
        print(f"{t['status']:<5} {t['target']}" + (f" ({t['note']})" if t["note"] else f": {shown}"))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=None, help="timed runs per measurement (best is kept)")
    parser.add_argument("--max-n", type=int, default=6, choices=range(1, 7), metavar="N",
                        help="largest number of hypotheses, 1..6 (default 6)")
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    parser.add_argument("--check", action="store_true", help="exit 1 if a target fails")
    args = parser.parse_args(argv)
    if args.repeat is not None and args.repeat < 1:
        parser.error("--repeat must be at least 1")

    have_peer = importlib.util.find_spec("evidencelib") is not None
    if not have_peer and not args.json:
        print("evidencelib is not installed (pip install \".[bench]\"): no comparison, belief figures only\n")
    rows = run(args.max_n, args.repeat, have_peer)
    found = targets(rows, have_peer)
    if args.json:
        import numpy

        peer_version = None
        if have_peer:
            from importlib.metadata import version

            peer_version = version("evidencelib")
        print(json.dumps({"python": platform.python_version(), "numpy": numpy.__version__,
                          "evidencelib": peer_version, "rows": rows, "targets": found}, indent=2))
    else:
        print_table(rows, found, have_peer)
    failed = any(t["status"] == "FAIL" for t in found)
    return 1 if failed and args.check else 0


if __name__ == "__main__":
    sys.exit(main())
