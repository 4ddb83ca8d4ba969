"""Cost of the evidential k-NN classifier: ``EKNN(k=5, alpha=0.95).fit`` + ``predict_mass``, beside evtools-dst.

The data: three Gaussian classes in 4-D (centres 1.5 standard deviations apart), 10^5 training
rows and 10^4 query rows, drawn from ``numpy.random.default_rng(29)``.  Each run is a fresh
process, so that its peak resident memory (``resource.getrusage``, which includes the
interpreter and the data) is its own.  The target is at most 10 s and 2 GB for belief.learn.

evtools-dst's ``EkNN(k=5, alpha=0.95, optimize=False)`` (fit + its dense masses) runs on the same
data when it can be imported, by this interpreter or by the one of ``--evtools-python``; otherwise
the line says "not installed".  It computes the default γ from the full matrix of distances of
each class (``scipy.spatial.distance.pdist``), about 4.4 GB for a class of 33 000 rows, so it runs
under a cap: ``--evtools-seconds`` of wall time and ``--evtools-gb`` of address space.  When it
fails under the cap it is run again on ``--evtools-fallback-rows`` training rows (and the same
share of query rows), and the output says so.  Where it finishes, the largest difference between
its masses and belief.learn's on the same rows is printed.

Usage::

    python benchmarks/bench_learn.py [--train N] [--test N] [--repeat N]
        [--evtools-python PATH] [--evtools-seconds S] [--evtools-gb G] [--evtools-fallback-rows N]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import numpy as np

SEED = 29

#: Run in a fresh interpreter: load the rows, time fit + masses, print time, peak memory and masses' path.
OURS = textwrap.dedent("""
    import json, resource, sys, time
    import numpy as np
    from belief.learn import EKNN
    data = np.load(sys.argv[1])
    started, cpu = time.perf_counter(), time.process_time()
    masses = EKNN(k=5, alpha=0.95).fit(data["X_train"], data["y_train"]).predict_mass(data["X_test"])
    seconds, cpu = time.perf_counter() - started, time.process_time() - cpu
    np.save(sys.argv[2], masses.values)
    print(json.dumps({"seconds": seconds, "cpu": cpu, "peak_kb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss}))
""")

EVTOOLS = textwrap.dedent("""
    import json, resource, sys, time
    import numpy as np
    from evtools.classifiers import EkNN
    data = np.load(sys.argv[1])
    started, cpu = time.perf_counter(), time.process_time()
    clf = EkNN(k=5, alpha=0.95, optimize=False).fit(data["X_train"], data["y_train"])
    masses = clf._bbas_dense(data["X_test"]).T
    seconds, cpu = time.perf_counter() - started, time.process_time() - cpu
    np.save(sys.argv[2], masses)
    print(json.dumps({"seconds": seconds, "cpu": cpu, "peak_kb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss}))
""")


def data(n_train: int, n_test: int) -> dict[str, np.ndarray]:
    """Three classes in 4-D: training rows and labels, query rows."""
    rng = np.random.default_rng(SEED)
    centres = np.array([[0.0, 0.0, 0.0, 0.0], [1.5, 0.0, 1.5, 0.0], [0.0, 1.5, 0.0, 1.5]])
    labels = rng.integers(0, 3, size=n_train)
    X_train = centres[labels] + rng.normal(size=(n_train, 4))
    X_test = centres[rng.integers(0, 3, size=n_test)] + rng.normal(size=(n_test, 4))
    return {"X_train": X_train, "y_train": np.array(["red", "green", "blue"])[labels], "X_test": X_test}


def run(python: str, script: str, rows: dict[str, np.ndarray], folder: Path, name: str,
        seconds: float | None = None, gigabytes: float | None = None) -> tuple[dict | None, str]:
    """Run ``script`` on ``rows`` in a fresh ``python``: its figures and masses, or None and why it failed."""
    inputs, outputs = folder / f"{name}.npz", folder / f"{name}_masses.npy"
    np.savez(inputs, **rows)

    def cap():
        if gigabytes is not None:
            limit = int(gigabytes * 2**30)
            resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    try:
        done = subprocess.run([python, "-c", script, str(inputs), str(outputs)], capture_output=True, text=True,
                              timeout=seconds, preexec_fn=cap, env={**os.environ, "OMP_NUM_THREADS": "2"})
    except subprocess.TimeoutExpired:
        return None, f"stopped after {seconds:g} s"
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["no message"])[-1]
        if "MemoryError" in done.stderr or "Cannot allocate" in done.stderr:
            return None, f"out of memory under the cap of {gigabytes:g} GB ({last})"
        return None, f"failed: {last}"
    figures = json.loads(done.stdout.strip().splitlines()[-1])
    figures["masses"] = np.load(outputs)
    return figures, ""


def evtools_python(given: str | None) -> str | None:
    """An interpreter that imports evtools: ``given``, else this one; None when neither does."""
    for python in ([given] if given else []) + [sys.executable]:
        try:
            found = subprocess.run([python, "-c", "import evtools.classifiers"], capture_output=True, timeout=60)
        except (OSError, subprocess.TimeoutExpired):
            continue
        if found.returncode == 0:
            return python
    return None


def show(what: str, figures: dict) -> str:
    return (f"{what:<38} {figures['seconds']:6.2f} s ({figures['cpu']:6.2f} s of CPU)   "
            f"peak memory {figures['peak_kb'] / 2**20:5.2f} GB")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--train", type=int, default=100_000, help="training rows (default 10^5)")
    parser.add_argument("--test", type=int, default=10_000, help="query rows (default 10^4)")
    parser.add_argument("--repeat", type=int, default=1, help="runs of belief.learn; the fastest is printed")
    parser.add_argument("--evtools-python", help="an interpreter with evtools-dst installed (default: this one)")
    parser.add_argument("--evtools-seconds", type=float, default=120.0, help="wall-time cap of evtools-dst")
    parser.add_argument("--evtools-gb", type=float, default=4.0, help="address-space cap of evtools-dst, GB")
    parser.add_argument("--evtools-fallback-rows", type=int, default=30_000,
                        help="training rows for evtools-dst when the full size fails under the cap")
    args = parser.parse_args(argv)

    rows = data(args.train, args.test)
    print(f"data: {args.train:,} training rows, {args.test:,} query rows, 4 features, 3 classes (seed {SEED})")
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        ours = None
        for _ in range(args.repeat):
            figures, why = run(sys.executable, OURS, rows, folder, "ours")
            if figures is None:
                print(f"belief.learn EKNN {why}")
                return 1
            if ours is None or figures["seconds"] < ours["seconds"]:
                ours = figures
        print(show("belief.learn EKNN fit + predict_mass", ours) + "   (target 10 s, 2 GB)")

        python = evtools_python(args.evtools_python)
        if python is None:
            print(f"{'evtools-dst EkNN':<38} not installed")
            return 0
        theirs, why = run(python, EVTOOLS, rows, folder, "evtools", args.evtools_seconds, args.evtools_gb)
        if theirs is not None:
            print(show("evtools-dst EkNN fit + masses", theirs))
            print(f"{'largest difference of the masses':<38} {np.abs(theirs['masses'] - ours['masses']).max():.2g}")
            return 0
        print(f"evtools-dst EkNN at {args.train:,} training rows: {why}")
        n_train = min(args.evtools_fallback_rows, args.train)
        n_test = max(1, args.test * n_train // args.train)
        smaller = {"X_train": rows["X_train"][:n_train], "y_train": rows["y_train"][:n_train],
                   "X_test": rows["X_test"][:n_test]}
        theirs, why = run(python, EVTOOLS, smaller, folder, "evtools", args.evtools_seconds, args.evtools_gb)
        if theirs is None:
            print(f"evtools-dst EkNN at {n_train:,} training rows: {why}")
            return 0
        mine, _ = run(sys.executable, OURS, smaller, folder, "ours_smaller")
        print(f"smaller size, {n_train:,} training x {n_test:,} query rows:")
        print(show("  belief.learn EKNN", mine))
        print(show("  evtools-dst EkNN", theirs))
        print(f"{'  largest difference of the masses':<38} {np.abs(theirs['masses'] - mine['masses']).max():.2g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
