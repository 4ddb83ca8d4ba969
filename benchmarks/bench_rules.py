"""Benchmark: combination rules (Dempster, PCR5/PCR6, batches, tracking), against peer libraries.

Run from the repository root::

    python benchmarks/bench_rules.py                # tables and PASS/FAIL per target
    python benchmarks/bench_rules.py --check        # exit 1 if a target fails
    python benchmarks/bench_rules.py --json         # machine-readable output
    python benchmarks/bench_rules.py --quick        # smaller sizes, a smoke run (targets skipped)
    python benchmarks/bench_rules.py --cases a,c    # some of the cases only

Cases:

(a) Dempster's rule of two sources with k = 8, 32, 128 random focal elements each (random
    non-empty subsets, random masses) on a frame of 10 hypotheses under Shafer's model.
(b) Joint PCR5 and PCR6 of s = 2..10 near-Bayesian sources on 3 hypotheses, 3 focal
    elements each (3^s tuples of focal elements).
(c) Throughput of two-source Dempster on 3 hypotheses: two MassBatch of 10^5 rows over
    the 7 non-empty subsets, combined in one call.
(d) A tracking-shaped batch: 10 targets and a false alarm (Model.for_targets(10)), 3
    Bayesian cues (Dirichlet masses over the 11 singletons), 10^4 rows, with the rules
    dsmc, pcr6 and r_rule: the full combination, every focal element (engine="general").
(e) What a tracker reads of the same fusion: ``combine`` (engine "auto", which takes the
    closed forms for Bayesian sources) and then Bel, Pls and BetP of each row's own target
    (``select=``), m(θ_J) and m(∅), for dsmc, r_rule and pcr6; beside it the same reading
    on engine="general" in the same run, the ratio, and (for information) the reading of
    Bel, Pls and BetP of all ten targets instead of ``select``.

Peers come from the ``bench`` extra (``pip install ".[bench]"``): evidencelib (DST and
DSmT, pure Python), py-dempster-shafer (module ``pyds``) and pybelief (both DST only).
Each is used only where it implements the case; a missing peer is reported and its
columns are skipped.  Every library gets the same inputs (fixed seeds), and the results
are compared with belief's: "agree" means every mass is within 1e-9.

Cases (a) and (b) time one combination at a time, the way a researcher calls the library
on a few mass functions.  Each (case, size, rule) runs in a fresh (spawned) process in
which belief and every peer that implements the case take turns call by call (the first of
the turn rotates), so that a load that comes and goes on the machine weighs on all of them
alike.  Each library first makes one untimed call on other inputs (loading lazily
initialised code), then:

* cold: after a garbage collection (which leaves the processor's caches cold, as a first
  call finds them), the median of 21 calls (5 with --quick), each on focal elements new to the
  process: the call builds the sources from their dicts ({"h1|h3": mass}) and combines
  them, and both are timed (the two parts are printed too).  belief compiles no plan
  for focal elements it meets for the first time (its direct path); its mass functions
  of unions of hypotheses make their elements and arrays when first read, which the
  "focal" column times apart (after the cold call, for information);
* warm: combining the sources of the last cold call again, 21 (5) turns of one untimed call
  and 5 timed ones in a row, the garbage collected before each turn (not before each call);
  the median of those calls (belief compiles or looks up what it keeps for focal elements
  that come back).

A peer stops once its calls took about 4 s (1 s with --quick), after at least one cold
call; a peer keeps nothing from call to call, and where it ran out of time before the
warm calls its cold combination times stand for them.

The batch cases (c), (d) and (e) run each library in its own fresh process, with one
untimed call first:

* cold: the median of 5 calls (3 with --quick), each on batches whose columns come in a
  fresh order, which gives belief focal lists it has not seen (with the same contents);
* warm: the median of 5 (3) more calls on the inputs of the last cold call.

Their peers loop over the first rows only (1 000 pairs, 100 rows) and the rate is
extrapolated; only the combination call is timed, not building the inputs.

Two references, no peers (never the "fastest peer"), show the computation written plainly:
"plain loop" in (b), joint PCR as a Python loop over the tuples on dicts of bit mask -> mass
built from the same mappings (:func:`plain_pcr`), taking turns with the others; "numpy" in
(c), two-source Dempster in a few lines of numpy (:func:`numpy_dempster`: an index table of
intersections, the products summed into the 7 targets by a matrix product, ``np.bincount``
or column sums, normalised; tables made anew on each cold call), in a fresh process, timed
as belief is, the fastest of its three ways shown.

Ratios are the fastest peer's time divided by belief's (above 1, belief is faster).
Targets: (a) and (b), every cold and warm case at least as fast as the fastest peer (1x),
and (c), (d) likewise on their warm calls; (a) k = 128 warm at least 10 times faster than
the fastest peer; (b) PCR6 of 10 sources warm at least 100 times faster than evidencelib,
and every warm call at least as fast as the plain loop; (c) at least 5 million pairs per
second, and at least as fast as the numpy reference; (d) at least 100 000 rows per second
for each rule; (e) at least 2 million rows per second for dsmc, 1 million for r_rule and
300 000 for pcr6.  Every peer that implements a case, and each reference, must agree with
belief.  ``--check`` exits with status 1 and names every target that failed.

Case (e) has no peer.  Its cold figure is the median of 5 (3) calls, each on fresh rows
in a fresh column order (a focal list the process has not seen, as in (c) and (d)); warm
repeats the last one 25 (3) times.  The general engine is slower, so it gets 3 cold and 5
warm calls (1 and 2 with --quick).  All three are measured in fresh processes of one run.
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import importlib.util
import io
import itertools
import json
import multiprocessing
import platform
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from itertools import combinations
from pathlib import Path

import numpy as np

# Measure the checkout this script belongs to, installed or not (spawned children inherit sys.path).
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

PEERS = ("evidencelib", "pyds", "pybelief")
DISTRIBUTIONS = {"evidencelib": "evidencelib", "pyds": "py-dempster-shafer", "pybelief": "pybelief"}
TOLERANCE = 1e-9
SEED = 20_240_611

FULL = {"a_sizes": (8, 32, 128), "b_sizes": tuple(range(2, 11)), "c_rows": 100_000, "c_peer_rows": 1_000,
        "d_rows": 10_000, "d_peer_rows": 100, "e_rows": 10_000, "cold": 5, "warm": 5, "e_warm": 25,
        "general_cold": 3, "general_warm": 5, "peer_budget": 4.0, "single_cold": 21, "single_warm": 21}
QUICK = {"a_sizes": (8, 32), "b_sizes": tuple(range(2, 7)), "c_rows": 10_000, "c_peer_rows": 200,
         "d_rows": 1_000, "d_peer_rows": 10, "e_rows": 1_000, "cold": 3, "warm": 3, "e_warm": 3,
         "general_cold": 1, "general_warm": 2, "peer_budget": 1.0, "single_cold": 5, "single_warm": 5}

# Targets (on warm times: plan compiled and cached).
A_K, A_RATIO = 128, 10.0
B_S, B_RATIO = 10, 100.0
C_ROWS, C_RATE = 100_000, 5e6
D_ROWS, D_RATE = 10_000, 1e5
D_RULES = ("dsmc", "pcr6", "r_rule")
E_ROWS = 10_000
E_RATES = {"dsmc": 2e6, "r_rule": 1e6, "pcr6": 3e5}
E_RULES = tuple(E_RATES)
#: evidencelib's method for each belief rule (its dsmc() is defined on the free model only;
#: on a hybrid frame its conjunctive rule is the same computation, conflict kept on ∅).
EVIDENCELIB_METHOD = {"dempster": "dempster", "pcr5": "pcr5", "pcr6": "pcr6", "dsmc": "conjunctive"}
SUPPORTS = {  # (case, rule) -> peers that implement it
    ("a", "dempster"): PEERS, ("b", "pcr5"): ("evidencelib",), ("b", "pcr6"): ("evidencelib",),
    ("c", "dempster"): PEERS, ("d", "dsmc"): ("evidencelib",), ("d", "pcr6"): ("evidencelib",), ("d", "r_rule"): (),
    ("e", "dsmc"): (), ("e", "r_rule"): (), ("e", "pcr6"): (),
}

A_NAMES = tuple(f"h{i}" for i in range(1, 11))
ABC = ("a", "b", "c")
TRACK_NAMES = tuple(f"t{i}" for i in range(1, 11)) + ("FA",)
# Near-Bayesian sources of case (b): the three singletons, or two singletons and a union.
B_STRUCTURES = [("a", "b", "c")] + [(x, y, z) for x, y in combinations(ABC, 2) for z in ("a|b", "a|c", "b|c", "a|b|c")]
C_FOCAL = tuple("|".join(h for i, h in enumerate(ABC) if mask >> i & 1) for mask in range(1, 8))


# -- inputs (library-neutral: a source is {"h1|h3": mass}; a batch is focal names and an (N, K) array) ------
def seed_of(case: str, size: int) -> int:
    return SEED + 1000 * (ord(case) - ord("a")) + size


def subset_name(mask: int, names=A_NAMES) -> str:
    return "|".join(h for i, h in enumerate(names) if mask >> i & 1)


def inputs_a(k: int, count: int) -> list[list[dict[str, float]]]:
    rng = np.random.default_rng(seed_of("a", k))
    samples, seen = [], set()
    while len(samples) < count:
        sample = []
        for _ in range(2):
            masks = rng.choice(np.arange(1, 1 << len(A_NAMES)), size=k, replace=False)
            weights = rng.uniform(0.1, 1.0, size=k)
            weights /= weights.sum()
            sample.append({subset_name(int(m)): float(w) for m, w in zip(masks, weights)})
        key = tuple(frozenset(source) for source in sample)
        if key not in seen:
            seen.add(key)
            samples.append(sample)
    return samples


def inputs_b(s: int, count: int) -> list[list[dict[str, float]]]:
    rng = np.random.default_rng(seed_of("b", s))
    samples, seen = [], set()
    while len(samples) < count:
        kinds = tuple(0 if rng.random() < 0.5 else int(rng.integers(1, len(B_STRUCTURES))) for _ in range(s))
        if kinds in seen:
            continue
        seen.add(kinds)
        sample = []
        for kind in kinds:
            weights = rng.uniform(0.1, 1.0, size=3)
            weights /= weights.sum()
            sample.append(dict(zip(B_STRUCTURES[kind], map(float, weights))))
        samples.append(sample)
    return samples


def inputs_batch(case: str, rows: int, count: int) -> tuple[tuple[str, ...], list[np.ndarray], list[list[np.ndarray]]]:
    """Focal names, the sources' (rows, K) masses in that order, and per sample a column order per source."""
    focal, sources = (C_FOCAL, 2) if case == "c" else (TRACK_NAMES, 3)
    rng = np.random.default_rng(seed_of(case, rows))
    values = [rng.dirichlet(np.ones(len(focal)), size=rows) for _ in range(sources)]
    orders, seen = [], set()
    while len(orders) < count:
        sample = [rng.permutation(len(focal)) for _ in range(sources)]
        key = tuple(tuple(p.tolist()) for p in sample)
        if key not in seen:
            seen.add(key)
            orders.append(sample)
    return focal, values, orders


# -- references: the same computations written plainly -----------------------------------------------------
def plain_pcr(sources: list[dict[int, float]], rule: str) -> dict[int, float]:
    """The "plain loop" of (b): joint PCR5 / PCR6 as a Python loop over the tuples of focal elements (bit mask -> mass).

    A conflicting tuple's product goes back to its elements, by mass (PCR6) or by the product of each one's masses.
    """
    out: dict[int, float] = {}
    for combo in itertools.product(*[s.items() for s in sources]):
        meet, product, total = -1, 1.0, 0.0
        for x, m in combo:
            meet, product, total = meet & x, product * m, total + m
        if meet:
            out[meet] = out.get(meet, 0.0) + product
            continue
        pairs = combo
        if rule == "pcr5":
            weights: dict[int, float] = {}
            for x, m in combo:
                weights[x] = weights.get(x, 1.0) * m
            total, pairs = sum(weights.values()), weights.items()
        factor = product / total
        for x, m in pairs:
            out[x] = out.get(x, 0.0) + factor * m
    return out


def numpy_dempster(focal1, v1: np.ndarray, focal2, v2: np.ndarray, how: str) -> tuple[list[int], np.ndarray]:
    """The "numpy reference" of (c): two-source Dempster on three exclusive hypotheses in plain numpy.

    The (N, K1·K2) products summed into the 7 non-empty targets by ``how`` ("matmul", "bincount", "columns").
    """
    bit = {h: 1 << i for i, h in enumerate(ABC)}
    m1 = np.array([sum(bit[h] for h in f.split("|")) for f in focal1])
    m2 = np.array([sum(bit[h] for h in f.split("|")) for f in focal2])
    target = (m1[:, None] & m2[None, :]).ravel()                  # 0 = the empty set
    products = (v1[:, :, None] * v2[:, None, :]).reshape(len(v1), -1)
    if how == "matmul":
        sums = (products @ (target[:, None] == np.arange(8)[None, :]).astype(float))[:, 1:]
    elif how == "bincount":
        index = (np.arange(len(v1))[:, None] * 8 + target[None, :]).ravel()
        sums = np.bincount(index, weights=products.ravel(), minlength=len(v1) * 8).reshape(-1, 8)[:, 1:]
    else:
        sums = np.stack([products[:, target == t].sum(axis=1) for t in range(1, 8)], axis=1)
    return list(range(1, 8)), sums / sums.sum(axis=1, keepdims=True)


NUMPY_WAYS = ("matmul", "bincount", "columns")

# -- libraries: model, conversion, call, canonical result -------------------------------------------------
def canonical(terms) -> str:
    """Minimal conjunctions (iterables of names) -> one string, the same for every library."""
    parts = sorted("&".join(sorted(term)) for term in terms)
    return "|".join(parts) if parts else "∅"


class Library:
    """One library's view of a case: builds its sources, combines them, reads the result."""

    def __init__(self, name: str, space: str) -> None:
        self.name = name
        names = {"shafer10": A_NAMES, "shafer3": ABC, "tracking10": TRACK_NAMES}[space]
        self.names = names
        self.bit = {h: 1 << i for i, h in enumerate(names)}
        if name == "belief":
            import belief

            self.lib = belief
            self.model = (belief.Model.for_targets(10) if space == "tracking10"
                          else belief.Model.shafer(belief.Frame(list(names))))
        elif name == "evidencelib":
            import evidencelib

            self.frame = (evidencelib.Frame.hybrid(list(names), empty=[f"{t}&FA" for t in names[:-1]])
                          if space == "tracking10" else evidencelib.Frame.dst(list(names)))
        elif name == "pyds":
            with contextlib.redirect_stderr(io.StringIO()):  # it warns that SciPy is absent (not needed here)
                import pyds
            self.lib = pyds
        elif name == "pybelief":
            import pybelief

            self.lib = pybelief

    def source(self, masses: dict[str, float]):
        if self.name == "belief":
            return self.lib.MassFunction(masses, model=self.model)
        if self.name == "evidencelib":
            return self.frame.mass(masses)
        if self.name == "pyds":
            return self.lib.MassFunction({frozenset(key.split("|")): v for key, v in masses.items()})
        if self.name == "plain":
            return {sum(self.bit[h] for h in key.split("|")): v for key, v in masses.items()}
        return self.lib.MassFunction(self.names, {sum(self.bit[h] for h in key.split("|")): v
                                                  for key, v in masses.items()})

    def batch(self, focal, values):
        return self.lib.MassBatch(list(focal), values, model=self.model)

    def combiner(self, rule: str):
        if self.name == "belief":
            combine = self.lib.combine
            # The full combination, every focal element: the closed forms for Bayesian sources
            # would return a batch combined only when read (case (e) measures those).
            return lambda sources: combine(*sources, rule=rule, engine="general")
        if self.name == "evidencelib":
            method = EVIDENCELIB_METHOD[rule]
            return lambda sources: getattr(sources[0], method)(*sources[1:])
        if self.name == "pyds":  # normalization=True (the default) is Dempster's rule
            return lambda sources: sources[0].combine_conjunctive(sources[1])
        if self.name == "plain":
            return lambda sources: plain_pcr(sources, rule)
        return lambda sources: sources[0].combine_dempster(sources[1])

    def read(self, result) -> dict[str, float]:
        """A combined mass function as {canonical element: mass}."""
        if self.name == "belief":
            return {self.key(e): float(v) for e, v in zip(result.focal, result.values.tolist())}
        if self.name == "evidencelib":
            out = {}
            for prop, value in result.items():
                text = str(prop)
                out[canonical([] if text == "empty" else [term.split("&") for term in text.split("|")])] = value
            return out
        if self.name == "pyds":
            return {canonical([[h] for h in hyp]): v for hyp, v in result.items()}
        masses = result if self.name == "plain" else result.focal_elements()
        return {canonical([[h] for h in self.names if mask & self.bit[h]]): v for mask, v in masses.items()}

    def key(self, element) -> str:
        hyps = element.frame.hypotheses
        return canonical([[h for i, h in enumerate(hyps) if term >> i & 1] for term in element.terms])

    def read_rows(self, result, rows: int) -> list[dict[str, float]]:
        keys = [self.key(e) for e in result.focal]
        return [{k: v for k, v in zip(keys, row) if v != 0.0} for row in result.values[:rows].tolist()]


#: Warm calls timed one after another in each turn of (a) and (b), after one untimed repeat.
WARM_BURST = 5


def timed(function, argument) -> tuple[float, object]:
    gc.collect()
    start = time.perf_counter()
    result = function(argument)
    return time.perf_counter() - start, result


# -- measurements (each runs in a fresh process) -----------------------------------------------------
def measure_single(case: str, rule: str, size: int, libraries: list[str], cold: int, warm: int,
                   budget: float) -> dict:
    """Cases (a) and (b): one combination per call, every library in this process, taking turns.

    A cold call builds the sources from their dicts (focal elements that the process has
    not seen) and combines them; the build and the combination are timed apart and
    together.  A warm call combines the sources of the library's last cold call again.
    The libraries take turns call by call (the first in the turn rotates), so that a load
    that comes and goes on the machine weighs on all of them alike.  A peer stops once
    its calls took ``budget`` seconds (after at least one cold call).
    """
    samples = inputs_a(size, cold + 1) if case == "a" else inputs_b(size, cold + 1)
    libs = {name: Library(name, "shafer10" if case == "a" else "shafer3") for name in libraries}
    calls = {name: lib.combiner(rule) for name, lib in libs.items()}
    data = {name: {"build": [], "combine": [], "total": [], "warm": [], "focal": [], "results": {}, "spent": 0.0,
                   "last": None} for name in libraries}
    for name, lib in libs.items():                     # untimed: lazy initialisation, on other inputs
        start = time.perf_counter()
        calls[name]([lib.source(masses) for masses in samples[0]])
        data[name]["first_s"] = time.perf_counter() - start

    def active(name):
        d = data[name]
        return name == "belief" or not d["total"] or d["spent"] <= budget

    for turn, sample in enumerate(samples[1:]):
        shift = turn % len(libraries)
        for name in libraries[shift:] + libraries[:shift]:
            if not active(name):
                continue
            lib, d = libs[name], data[name]
            gc.collect()
            t0 = time.perf_counter()
            sources = [lib.source(masses) for masses in sample]
            t1 = time.perf_counter()
            result = calls[name](sources)
            t2 = time.perf_counter()
            d["build"].append(t1 - t0)
            d["combine"].append(t2 - t1)
            d["total"].append(t2 - t0)
            d["spent"] += t2 - t0
            d["last"] = sources
            if name == "belief":                       # the focal elements are made when first read
                t3 = time.perf_counter()
                result.focal
                d["focal"].append(time.perf_counter() - t3)
            d["results"][turn] = lib.read(result)
    for turn in range(warm):
        shift = turn % len(libraries)
        for name in libraries[shift:] + libraries[:shift]:
            d = data[name]
            if name != "belief" and d["spent"] > budget:
                continue
            # Warm: the same call again and again, as a loop over the same sources makes it. The garbage is
            # collected before the burst, not before each call (a collection walks the whole heap and leaves
            # the processor's caches cold: that is the cold calls' regime).
            gc.collect()
            gc.disable()
            try:
                calls[name](d["last"])
                for _ in range(WARM_BURST):
                    t0 = time.perf_counter()
                    calls[name](d["last"])
                    seconds = time.perf_counter() - t0
                    d["warm"].append(seconds)
                    d["spent"] += seconds
            finally:
                gc.enable()
    out = {}
    for name, d in data.items():
        warm_times = d["warm"] or d["combine"]         # a peer keeps nothing from call to call
        out[name] = {"first_s": d["first_s"], "cold_s": statistics.median(d["total"]),
                     "build_s": statistics.median(d["build"]), "combine_s": statistics.median(d["combine"]),
                     "cold_runs": len(d["total"]), "warm_s": statistics.median(warm_times),
                     "warm_runs": len(d["warm"]), "results": d["results"]}
        if d["focal"]:
            out[name]["focal_s"] = statistics.median(d["focal"])
    return out


def measure_batch_belief(case: str, rule: str, rows: int, check_rows: int, cold: int, warm: int) -> dict:
    """Cases (c) and (d) for belief: all rows in one call, columns in a fresh order for every cold call."""
    focal, values, orders = inputs_batch(case, rows, cold + 1)
    lib = Library("belief", "shafer3" if case == "c" else "tracking10")
    call = lib.combiner(rule)

    def sources(i):
        return [lib.batch([focal[j] for j in order], v[:, order]) for v, order in zip(values, orders[i])]

    first, _ = timed(call, sources(0))
    cold_times, results = [], None
    for i in range(1, cold + 1):
        batch = sources(i)
        seconds, result = timed(call, batch)
        cold_times.append(seconds)
        if results is None:
            results = lib.read_rows(result, check_rows)
        del result
    warm_times = [timed(call, batch)[0] for _ in range(warm)]
    return {"rows": rows, "first_s": first, "cold_s": statistics.median(cold_times), "cold_runs": cold,
            "warm_s": statistics.median(warm_times), "warm_runs": warm, "results": [results]}


def measure_batch_numpy(rows: int, check_rows: int, cold: int, warm: int) -> dict:
    """Case (c) for the numpy reference (:func:`numpy_dempster`), timed as belief is; the fastest of its ways."""
    focal, values, orders = inputs_batch("c", rows, cold + 1)

    def call(i, how):
        (o1, o2) = orders[i]
        return numpy_dempster([focal[j] for j in o1], values[0][:, o1], [focal[j] for j in o2], values[1][:, o2], how)

    best = None
    for how in NUMPY_WAYS:
        times = [timed(lambda _: call(i, how), None)[0] for i in [0] + list(range(1, cold + 1)) + [cold] * warm]
        if best is None or statistics.median(times[cold + 1:]) < best["warm_s"]:
            best = {"rows": rows, "how": how, "cold_s": statistics.median(times[1:cold + 1]), "cold_runs": cold,
                    "warm_s": statistics.median(times[cold + 1:]), "warm_runs": warm}
    targets, masses = call(1, best["how"])
    names = [canonical([[h] for i, h in enumerate(ABC) if t >> i & 1]) for t in targets]
    best["results"] = [[{k: v for k, v in zip(names, row) if v != 0.0} for row in masses[:check_rows].tolist()]]
    return best


def inputs_tracker(rows: int, count: int) -> tuple[list[list[np.ndarray]], list[list[np.ndarray]], np.ndarray]:
    """Case (e): per sample, 3 cues of Dirichlet rows over t1..t10, FA and a fresh column order per cue; the owners."""
    rng = np.random.default_rng(seed_of("e", rows))
    n = len(TRACK_NAMES)
    owner = rng.integers(0, n - 1, size=rows)          # drawn first: the same whatever ``count``
    samples, orders = [], []
    for _ in range(count):
        samples.append([rng.dirichlet(np.ones(n), size=rows) for _ in range(3)])
        orders.append([rng.permutation(n) for _ in range(3)])
    return samples, orders, owner


def measure_tracker_reads(rule: str, rows: int, engine: str, select: bool, cold: int, warm: int) -> dict:
    """Case (e): combine, then the measures a tracker reads; one timed call is the whole reading."""
    import belief

    model = belief.Model.for_targets(10)
    samples, orders, owner = inputs_tracker(rows, cold + 1)
    targets = list(TRACK_NAMES[:-1])

    def sources(i):
        return [belief.MassBatch([TRACK_NAMES[j] for j in order], values[:, order], model=model)
                for values, order in zip(samples[i], orders[i])]

    def read(cues):
        fused = belief.combine(*cues, rule=rule, engine=engine)
        if select:
            out = [fused.bel(targets, select=owner), fused.pls(targets, select=owner),
                   fused.betp(targets, select=owner)]
        else:
            out = [fused.bel(targets), fused.pls(targets), fused.betp(targets)]
        out += [fused.mass(targets, select=owner), fused.empty_mass]
        return out

    first, _ = timed(read, sources(0))
    cold_times, reading = [], None
    for i in range(1, cold + 1):
        cues = sources(i)
        seconds, out = timed(read, cues)
        cold_times.append(seconds)
        if reading is None:                # the first cold sample, the same for both engines
            reading = out
    warm_times = [timed(read, cues)[0] for _ in range(warm)]
    return {"rows": rows, "first_s": first, "cold_s": statistics.median(cold_times), "cold_runs": cold,
            "warm_s": statistics.median(warm_times), "warm_runs": warm,
            "reading": [r[:64].tolist() for r in reading]}


def measure_batch_peer(library: str, case: str, rule: str, rows: int, peer_rows: int, budget: float) -> dict:
    """Cases (c) and (d) for a peer: a loop over the first ``peer_rows`` rows, timed and extrapolated."""
    focal, values, _ = inputs_batch(case, rows, 1)
    lib = Library(library, "shafer3" if case == "c" else "tracking10")
    call = lib.combiner(rule)
    pairs = [[lib.source(dict(zip(focal, map(float, v[r])))) for v in values] for r in range(peer_rows)]

    def loop(items):
        return [call(sources) for sources in items]

    timed(loop, pairs[:max(1, peer_rows // 10)])
    times, results = [], None
    while not times or (len(times) < 3 and sum(times) < budget):
        seconds, out = timed(loop, pairs)
        times.append(seconds)
        if results is None:
            results = [lib.read(r) for r in out]
    return {"rows": peer_rows, "cold_s": statistics.median(times), "cold_runs": len(times),
            "warm_s": None, "results": [results]}


def in_fresh_process(function, *args) -> dict:
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        return pool.submit(function, *args).result()


# -- agreement ----------------------------------------------------------------------------------------
def deviation(ours: list, theirs: list) -> float:
    """Largest |Δ| over the inputs both computed; results are {element: mass} or lists of them (rows)."""
    worst = 0.0
    for a, b in zip(ours, theirs):
        pairs = zip(a, b) if isinstance(a, list) else [(a, b)]
        for x, y in pairs:
            if not x or not y:           # a combination is never empty: something went wrong
                return float("inf")
            for key in set(x) | set(y):
                worst = max(worst, abs(x.get(key, 0.0) - y.get(key, 0.0)))
    return worst


def compare(row: dict, belief: dict) -> None:
    row["agreement"] = {}
    reference = row.get("numpy")
    if reference is not None:
        worst = deviation(belief["results"], reference.pop("results"))
        row["agreement_reference"] = {"max_abs_diff": worst, "compared": len(belief["results"][0]),
                                      "agree": worst <= TOLERANCE}
    for peer, data in row["peers"].items():
        if data is None:
            continue
        worst = deviation(belief["results"], data["results"])
        compared = min(len(belief["results"]), len(data["results"]))
        if isinstance(belief["results"][0], list):
            compared = min(len(belief["results"][0]), len(data["results"][0]))
        row["agreement"][peer] = {"max_abs_diff": worst, "compared": compared, "agree": worst <= TOLERANCE}
        del data["results"]
    del belief["results"]


def compare_single(row: dict) -> None:
    """Agreement of cases (a) and (b): belief against each peer (and the plain loop) on every sample both combined."""
    row["agreement"] = {}
    ours = row["belief"].pop("results")

    def agreement_with(theirs):
        common = sorted(set(ours) & set(theirs))
        worst = deviation([ours[k] for k in common], [theirs[k] for k in common]) if common else float("inf")
        return {"max_abs_diff": worst, "compared": len(common), "agree": worst <= TOLERANCE}

    if row.get("plain") is not None:
        row["agreement_reference"] = agreement_with(row["plain"].pop("results"))
    for peer, data in row["peers"].items():
        if data is not None:
            row["agreement"][peer] = agreement_with(data.pop("results"))


def add_single_ratios(row: dict) -> None:
    """Cold: the fastest peer's build and combination over belief's; warm: the combination alone."""
    timed_peers = {p: d for p, d in row["peers"].items() if d is not None}
    b = row["belief"]
    plain = row.get("plain")
    if plain is not None:
        row["ratio_plain_cold"], row["ratio_plain_warm"] = plain["cold_s"] / b["cold_s"], plain["warm_s"] / b["warm_s"]
    if not timed_peers:
        row["fastest_peer"] = row["ratio_cold"] = row["ratio_warm"] = None
        return
    cold_peer = min(timed_peers, key=lambda p: timed_peers[p]["cold_s"])
    warm_peer = min(timed_peers, key=lambda p: timed_peers[p]["warm_s"])
    row["fastest_peer"] = cold_peer
    row["fastest_warm_peer"] = warm_peer
    row["ratio_cold"] = timed_peers[cold_peer]["cold_s"] / b["cold_s"]
    row["ratio_warm"] = timed_peers[warm_peer]["warm_s"] / b["warm_s"]
    row["ratio_cold_combine"] = min(d["combine_s"] for d in timed_peers.values()) / b["combine_s"]


def fastest(row: dict) -> tuple[str | None, float | None]:
    """The fastest peer and its time per unit (per call, or per row for the batch cases)."""
    best = None
    for peer, data in row["peers"].items():
        if data is not None:
            per = data["cold_s"] / data.get("rows", 1)
            if best is None or per < best[1]:
                best = (peer, per)
    return best if best else (None, None)


def add_ratios(row: dict) -> None:
    peer, per = fastest(row)
    b = row["belief"]
    rows = b.get("rows", 1)
    reference = row.get("numpy")
    if reference is not None:
        row["ratio_reference_cold"], row["ratio_reference_warm"] = (reference["cold_s"] / b["cold_s"],
                                                                    reference["warm_s"] / b["warm_s"])
    row["fastest_peer"] = peer
    row["ratio_cold"] = per / (b["cold_s"] / rows) if peer else None
    row["ratio_warm"] = per / (b["warm_s"] / rows) if peer and b["warm_s"] else None


# -- the cases ----------------------------------------------------------------------------------------
def run_case(case: str, sizes: dict, have: dict, log) -> list[dict]:
    out = []
    plan = {"a": [("dempster", k) for k in sizes["a_sizes"]],
            "b": [(rule, s) for s in sizes["b_sizes"] for rule in ("pcr5", "pcr6")],
            "c": [("dempster", sizes["c_rows"])],
            "d": [(rule, sizes["d_rows"]) for rule in D_RULES],
            "e": [(rule, sizes["e_rows"]) for rule in E_RULES]}[case]
    if case == "e":
        for rule, size in plan:
            log(f"  (e) {rule} {size}")
            closed = in_fresh_process(measure_tracker_reads, rule, size, "auto", True, sizes["cold"], sizes["e_warm"])
            general = in_fresh_process(measure_tracker_reads, rule, size, "general", True, sizes["general_cold"],
                                       sizes["general_warm"])
            every = in_fresh_process(measure_tracker_reads, rule, size, "auto", False, sizes["cold"], sizes["e_warm"])
            worst = max(abs(a - b) for x, y in zip(closed.pop("reading"), general.pop("reading"))
                        for a, b in zip(x, y))
            every.pop("reading")
            out.append({"case": "e", "rule": rule, "size": size, "peers": {}, "agreement": {}, "belief": closed,
                        "general": general, "all_targets": every, "max_abs_diff": worst,
                        "ratio_warm": general["warm_s"] / closed["warm_s"],
                        "ratio_cold": general["cold_s"] / closed["cold_s"]})
        return out
    for rule, size in plan:
        log(f"  ({case}) {rule} {size}")
        row = {"case": case, "rule": rule, "size": size, "peers": {}}
        supported = [p for p in SUPPORTS[(case, rule)] if have[p]]
        if case in "ab":
            row["tuples"] = size * size if case == "a" else 3 ** size
            plain = ["plain"] if case == "b" else []
            measured = in_fresh_process(measure_single, case, rule, size, ["belief"] + supported + plain,
                                        sizes["single_cold"], sizes["single_warm"], sizes["peer_budget"])
            row["belief"] = measured["belief"]
            for peer in PEERS:
                row["peers"][peer] = measured.get(peer)
            row["plain"] = measured.get("plain")
            compare_single(row)
            add_single_ratios(row)
            out.append(row)
            continue
        else:
            peer_rows = sizes[f"{case}_peer_rows"]
            check = peer_rows if supported or case == "c" else 1
            belief = in_fresh_process(measure_batch_belief, case, rule, size, check, sizes["cold"], sizes["warm"])
            if case == "c":
                row["numpy"] = in_fresh_process(measure_batch_numpy, size, peer_rows, sizes["cold"], sizes["warm"])
            for peer in PEERS:
                row["peers"][peer] = (in_fresh_process(measure_batch_peer, peer, case, rule, size, peer_rows,
                                                       sizes["peer_budget"]) if peer in supported else None)
        row["belief"] = belief
        compare(row, belief)
        add_ratios(row)
        out.append(row)
    return out


# -- targets ------------------------------------------------------------------------------------------
def find(rows, case, rule, size):
    return next((r for r in rows if r["case"] == case and r["rule"] == rule and r["size"] == size), None)


def targets(rows: list[dict], cases: str, have: dict) -> list[dict]:
    found = []

    def target(name, value, ok, cold=None, skip=None, unit="x"):
        status = "SKIP" if skip else ("PASS" if ok else "FAIL")
        found.append({"target": name, "value": value, "cold_value": cold, "unit": unit, "status": status,
                      "note": skip})

    def why_skipped(case, row, needs_peer):
        if case not in cases:
            return f"case ({case}) not run"
        if row is None:
            return "size not run (--quick)"
        if needs_peer and row["fastest_peer"] is None:
            return "no peer installed"
        return None

    r = find(rows, "a", "dempster", A_K)
    skip = why_skipped("a", r, True)
    target(f"(a) Dempster, k = {A_K}: warm call >= {A_RATIO:g}x faster than the fastest peer",
           r and r["ratio_warm"], r and not skip and r["ratio_warm"] >= A_RATIO, r and r["ratio_cold"], skip)
    r = find(rows, "b", "pcr6", B_S)
    skip = why_skipped("b", r, True)
    target(f"(b) PCR6 of {B_S} sources: warm call >= {B_RATIO:g}x faster than evidencelib",
           r and r["ratio_warm"], r and not skip and r["ratio_warm"] >= B_RATIO, r and r["ratio_cold"], skip)
    r = find(rows, "c", "dempster", C_ROWS)
    skip = why_skipped("c", r, False)
    speed = r and C_ROWS / r["belief"]["warm_s"]
    target(f"(c) Dempster on {C_ROWS:,} pairs (3 hypotheses): warm call >= {C_RATE / 1e6:g} M pairs/s",
           speed, speed is not None and speed >= C_RATE, r and C_ROWS / r["belief"]["cold_s"], skip, "pairs/s")
    reference = r and r.get("numpy")
    target(f"(c) Dempster on {C_ROWS:,} pairs: warm call at least as fast as the numpy reference",
           reference and r["ratio_reference_warm"], bool(reference) and not skip and r["ratio_reference_warm"] >= 1.0,
           reference and r["ratio_reference_cold"], skip)
    for rule in D_RULES:
        r = find(rows, "d", rule, D_ROWS)
        skip = why_skipped("d", r, False)
        speed = r and D_ROWS / r["belief"]["warm_s"]
        target(f"(d) {rule}, tracking model, 3 cues, {D_ROWS:,} rows: warm call >= {D_RATE:,.0f} rows/s",
               speed, speed is not None and speed >= D_RATE, r and D_ROWS / r["belief"]["cold_s"], skip, "rows/s")
    for rule in E_RULES:
        r = find(rows, "e", rule, E_ROWS)
        skip = why_skipped("e", r, False)
        speed = r and E_ROWS / r["belief"]["warm_s"]
        target(f"(e) {rule}, tracker reading of {E_ROWS:,} rows, closed forms: warm >= {E_RATES[rule]:,.0f} rows/s",
               speed, speed is not None and speed >= E_RATES[rule], r and E_ROWS / r["belief"]["cold_s"], skip,
               "rows/s")
    for r in rows:
        if r["case"] not in "ab" or r.get("fastest_peer") is None:
            continue
        name = f"({r['case']}) {r['rule']}, {'k' if r['case'] == 'a' else 's'} = {r['size']}"
        target(f"{name}: cold call (build from dicts + combine) >= 1x the fastest peer ({r['fastest_peer']})",
               r["ratio_cold"], r["ratio_cold"] >= 1.0)
    for r in rows:
        if r["case"] == "e" or r.get("fastest_peer") is None or r.get("ratio_warm") is None:
            continue
        size = {"a": "k", "b": "s"}.get(r["case"], "rows")
        peer = r.get("fastest_warm_peer", r["fastest_peer"])
        target(f"({r['case']}) {r['rule']}, {size} = {r['size']:,}: warm call >= 1x the fastest peer ({peer})",
               r["ratio_warm"], r["ratio_warm"] >= 1.0)
    for r in rows:
        if r["case"] == "b" and r.get("plain") is not None:
            target(f"(b) {r['rule']}, s = {r['size']}: warm call at least as fast as the plain loop",
                   r["ratio_plain_warm"], r["ratio_plain_warm"] >= 1.0, r["ratio_plain_cold"])
    checks = [r["agreement_reference"] for r in rows if "agreement_reference" in r]
    target(f"the plain loop and the numpy reference agree with belief (|Δ| <= {TOLERANCE:g})",
           sum(a["agree"] for a in checks), all(a["agree"] for a in checks), None,
           None if checks else "no reference run", f"of {len(checks)} comparisons")
    e_rows = [r for r in rows if r["case"] == "e"]
    if e_rows:
        worst = max(r["max_abs_diff"] for r in e_rows)
        target("(e) the closed forms read what the general engine reads (|Δ| <= 1e-12)", worst, worst <= 1e-12,
               None, None, "max |Δ|")
    checks = [a for r in rows for a in r["agreement"].values()]
    differ = [f"({r['case']}) {r['rule']} {r['size']:,} vs {p}" for r in rows for p, a in r["agreement"].items()
              if not a["agree"]]
    target(f"results agree with every peer that implements the case (|Δ| <= {TOLERANCE:g})"
           + (f"; they differ in {', '.join(differ)}" if differ else ""),
           sum(a["agree"] for a in checks), all(a["agree"] for a in checks), None,
           None if checks else "no peer installed", f"of {len(checks)} comparisons")
    return found


# -- printing -----------------------------------------------------------------------------------------
def ms(seconds: float | None) -> str:
    return "-" if seconds is None else f"{seconds * 1e3:.3f}" if seconds < 0.1 else f"{seconds * 1e3:.1f}"


def ratio(value: float | None) -> str:
    return "-" if value is None else f"{value:.3g}x" if value < 10 else f"{value:.0f}x"


def rate(value: float) -> str:
    return f"{value / 1e6:.2f} M" if value >= 1e6 else f"{value:,.0f}"


def agreement(row: dict, peers: list[str]) -> str:
    parts = []
    for peer in peers:
        a = row["agreement"].get(peer)
        if a is not None:
            parts.append(f"{peer} {'agree' if a['agree'] else 'DIFFER'} ({a['max_abs_diff']:.1e})")
    if parts:
        return ", ".join(parts)
    return "no peer installed" if SUPPORTS[(row["case"], row["rule"])] else "no peer implements it"


def print_table(header: list[tuple[str, int]], lines: list[list[str]]) -> None:
    print("  ".join(f"{h:>{w}}" for h, w in header))
    print("-" * (sum(w for _, w in header) + 2 * (len(header) - 1)))
    for line in lines:
        print("  ".join(f"{c:>{w}}" for c, (_, w) in zip(line, header)))


def plain_cells(row: dict) -> list[str]:
    d = row.get("plain")
    return ["-", "-"] if d is None else [f"{ms(d['cold_s'])} / {ms(d['warm_s'])}", ratio(row["ratio_plain_warm"])]


def print_report(rows: list[dict], found: list[dict], peers: list[str], sizes: dict) -> None:
    def peer_cell(row, peer):
        d = row["peers"].get(peer)
        if d is None:
            return "-"
        cell = f"{ms(d['cold_s'])} / {ms(d['warm_s'])}"
        return cell + ("" if d["cold_runs"] >= sizes["single_cold"] else f" ({d['cold_runs']})")

    def belief_cells(r):
        b = r["belief"]
        return [ms(b["cold_s"]), ratio(r["ratio_cold"]), ms(b["build_s"]), ms(b["combine_s"]),
                ms(b.get("focal_s")), ms(b["warm_s"]), ratio(r["ratio_warm"])]

    by_case = {c: [r for r in rows if r["case"] == c] for c in "abcde"}
    belief_header = [("cold ms", 9), ("x", 7), ("build", 7), ("comb.", 7), ("focal", 7), ("warm ms", 9), ("x", 7)]
    if by_case["a"]:
        print("(a) Dempster's rule, two sources of k random focal elements, 10 hypotheses, Shafer's model")
        header = [("k", 4), ("tuples", 7)] + belief_header + [(f"{p} cold / warm ms", 24) for p in peers]
        print_table(header, [[str(r["size"]), str(r["tuples"])] + belief_cells(r) + [peer_cell(r, p) for p in peers]
                             for r in by_case["a"]])
        for r in by_case["a"]:
            print(f"  k = {r['size']}: {agreement(r, peers)}")
        print()
    if by_case["b"]:
        print("(b) joint PCR5 / PCR6 of s near-Bayesian sources on 3 hypotheses, 3 focal elements each "
              "(only evidencelib implements them)")
        header = [("s", 3), ("tuples", 7), ("rule", 5)] + belief_header
        shown = [p for p in peers if p == "evidencelib"]
        header += [(f"{p} cold / warm ms", 26) for p in shown]
        header += [("plain loop cold / warm", 22), ("x", 7), ("agreement", 28)]
        print_table(header, [[str(r["size"]), str(r["tuples"]), r["rule"]] + belief_cells(r)
                             + [peer_cell(r, p) for p in shown] + plain_cells(r) + [agreement(r, shown)]
                             for r in by_case["b"]])
        print("    plain loop = joint PCR as a plain Python loop over the tuples (dicts of bit mask -> mass, built "
              "from the same mappings; plain_pcr); x = its warm time / belief's")
        print()
    if by_case["a"] or by_case["b"]:
        print("    cold = build the sources from dicts of new focal elements + combine (median of "
              f"{sizes['single_cold']}); build, comb. = its two parts;")
        print("    focal = belief's first read of the result's focal elements (made then; not in cold); warm = "
              f"combine the last sources again (median of {sizes['single_warm']} x {WARM_BURST} calls in a row);")
        print("    x = the fastest peer's time / belief's; a peer's count in brackets = fewer cold calls "
              f"(capped at about {sizes['peer_budget']:g} s)")
        print()
    if by_case["c"]:
        r = by_case["c"][0]
        n = r["size"]
        print(f"(c) throughput of two-source Dempster, 3 hypotheses, 7 focal elements per source: "
              f"{n:,} pairs in one MassBatch call for belief;")
        if peers:
            print(f"    peers loop over the first {sizes['c_peer_rows']:,} pairs (extrapolated to pairs/s)")
        header = [("", 12), ("pairs", 8), ("ms", 9), ("pairs/s", 10), ("x", 7)]
        b = r["belief"]
        lines = [["belief cold", f"{n:,}", ms(b["cold_s"]), rate(n / b["cold_s"]), ratio(r["ratio_cold"])],
                 ["belief warm", f"{n:,}", ms(b["warm_s"]), rate(n / b["warm_s"]), ratio(r["ratio_warm"])]]
        reference = r.get("numpy")
        lines += [[f"numpy {when}", f"{n:,}", ms(reference[f"{when}_s"]), rate(n / reference[f"{when}_s"]),
                   ratio(r[f"ratio_reference_{when}"])] for when in ("cold", "warm") if reference is not None]
        for p in peers:
            d = r["peers"].get(p)
            if d is not None:
                lines.append([p, f"{d['rows']:,}", ms(d["cold_s"]), rate(d["rows"] / d["cold_s"]), ""])
        print_table(header, lines)
        if reference is not None:
            a = r["agreement_reference"]
            print(f"    numpy = the numpy reference (numpy_dempster, fastest way: {reference['how']}; x = its time / "
                  f"belief's), which {'agrees' if a['agree'] else 'DIFFERS'} ({a['max_abs_diff']:.1e})")
        print(f"  {agreement(r, peers)} (on {sizes['c_peer_rows']:,} pairs)")
        print()
    if by_case["d"]:
        n = by_case["d"][0]["size"]
        print(f"(d) tracking batch: 10 targets + FA (Model.for_targets(10)), 3 Bayesian cues, {n:,} rows;")
        if "evidencelib" in peers:
            print(f"    evidencelib (hybrid frame, θj∩FA = ∅) loops over the first {sizes['d_peer_rows']:,} rows "
                  "(extrapolated); its conjunctive rule stands for dsmc")
        header = [("rule", 7), ("cold ms", 9), ("rows/s", 10), ("x", 7), ("warm ms", 9), ("rows/s", 10), ("x", 7)]
        shown = [p for p in peers if p == "evidencelib"]
        header += [(f"{p} rows/s", 18) for p in shown] + [("agreement", 28)]
        lines = []
        for r in by_case["d"]:
            b = r["belief"]
            line = [r["rule"], ms(b["cold_s"]), rate(n / b["cold_s"]), ratio(r["ratio_cold"]),
                    ms(b["warm_s"]), rate(n / b["warm_s"]), ratio(r["ratio_warm"])]
            for p in shown:
                d = r["peers"].get(p)
                line.append("-" if d is None else rate(d["rows"] / d["cold_s"]))
            lines.append(line + [agreement(r, shown)])
        print_table(header, lines)
        print()
    if by_case["e"]:
        n = by_case["e"][0]["size"]
        print(f"(e) tracker reading: combine 3 Bayesian cues of {n:,} rows on Model.for_targets(10), then Bel, Pls, "
              "BetP of each row's own target (select=), m(θ_J), m(∅)")
        header = [("rule", 7), ("cold ms", 9), ("rows/s", 10), ("warm ms", 9), ("rows/s", 10),
                  ("general cold", 13), ("general warm", 13), ("rows/s", 10), ("x warm", 7), ("all τ warm", 11),
                  ("rows/s", 10), ("max |Δ|", 9)]
        lines = []
        for r in by_case["e"]:
            b, g, a = r["belief"], r["general"], r["all_targets"]
            lines.append([r["rule"], ms(b["cold_s"]), rate(n / b["cold_s"]), ms(b["warm_s"]), rate(n / b["warm_s"]),
                          ms(g["cold_s"]), ms(g["warm_s"]), rate(n / g["warm_s"]), ratio(r["ratio_warm"]),
                          ms(a["warm_s"]), rate(n / a["warm_s"]), f"{r['max_abs_diff']:.1e}"])
        print_table(header, lines)
        print("    x warm = general engine's warm time / closed forms' warm time; \"all τ\": Bel, Pls, BetP of every "
              "target instead of select= (for information)")
        print()
    print("Targets (cold: fresh focal elements, building the sources included; warm: the combination again):")
    for t in found:
        value, unit = t["value"], t["unit"]
        if t["status"] == "SKIP":
            print(f"{t['status']:<5} {t['target']} ({t['note']})")
            continue
        if unit == "x":
            shown = ratio(value) + ("" if t["cold_value"] is None else f" (cold {ratio(t['cold_value'])})")
        elif unit in ("pairs/s", "rows/s"):
            shown = f"{rate(value)} {unit} (cold {rate(t['cold_value'])} {unit})"
        elif unit == "max |Δ|":
            shown = f"{unit} {value:.1e}"
        else:
            shown = f"{value} {unit}"
        print(f"{t['status']:<5} {t['target']}: {shown}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller sizes for a smoke run (targets skipped)")
    parser.add_argument("--cases", default="a,b,c,d,e", help="comma-separated cases to run, of a,b,c,d,e (default all)")
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    parser.add_argument("--check", action="store_true", help="exit 1 if a target fails")
    args = parser.parse_args(argv)
    cases = [c.strip() for c in args.cases.split(",") if c.strip()]
    if not cases or any(c not in "abcde" or len(c) != 1 for c in cases):
        parser.error("--cases takes a comma-separated list of a, b, c, d, e")
    sizes = QUICK if args.quick else FULL

    from importlib.metadata import PackageNotFoundError, version

    have = {p: importlib.util.find_spec(p) is not None for p in PEERS}
    versions = {}
    for p in PEERS:
        try:
            versions[p] = version(DISTRIBUTIONS[p]) if have[p] else None
        except PackageNotFoundError:
            versions[p] = "unknown"
    peers = [p for p in PEERS if have[p]]

    def log(message):
        if not args.json:
            print(message, file=sys.stderr, flush=True)

    if not args.json:
        print(f"belief vs peers; Python {platform.python_version()}, numpy {np.__version__}")
        print("peers: " + ", ".join(f"{p} {versions[p]}" + (f" ({DISTRIBUTIONS[p]})" if DISTRIBUTIONS[p] != p else "")
                                    for p in peers) if peers else "peers: none")
        for p in PEERS:
            if not have[p]:
                print(f"{p} is not installed (pip install \".[bench]\"): its columns are skipped")
        print("(a), (b): one fresh process per case, the libraries taking turns call by call; cold = build the "
              "sources from dicts")
        print(f"of new focal elements + combine (median of {sizes['single_cold']}), warm = combine them again "
              f"({sizes['single_warm']} x {WARM_BURST} calls in a row, median).")
        print(f"(c)-(e): a fresh process per library and case; cold = median of {sizes['cold']} calls on focal "
              f"lists new to the process, warm = {sizes['warm']} repeats.")
        print("Peers: median over the same inputs (a count in brackets = fewer calls, capped at about "
              f"{sizes['peer_budget']:g} s).")
        print("x = fastest peer's time / belief's time (above 1: belief faster).  Times in ms.")
        print()
    start = time.perf_counter()
    rows = []
    for case in cases:
        rows.extend(run_case(case, sizes, have, log))
    found = targets(rows, "".join(cases), have)
    if args.json:
        print(json.dumps({"python": platform.python_version(), "numpy": np.__version__, "peers": versions,
                          "quick": args.quick, "sizes": sizes, "rows": rows, "targets": found}, indent=2))
    else:
        print_report(rows, found, peers, sizes)
        print(f"\n(total {time.perf_counter() - start:.0f} s)")
    failed = [t["target"] for t in found if t["status"] == "FAIL"]
    if failed and args.check:
        print("check failed: " + "; ".join(failed), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
