"""Joint PCR6 of two Bayesian batches on Dask arrays, from ``.npy`` memory maps to a ``.npy`` result.

Two sources of ``--rows`` rows over three hypotheses (the tracking model of one target and
FA, plus a second target: t1, t2, FA) are written to ``.npy`` files, opened as memory maps,
wrapped by ``dask.array.from_array`` and fused with ``combine(..., rule="pcr6")`` on a
``LocalCluster`` of ``--workers`` workers, threads of this process unless ``--processes``
(:func:`belief.dask_batches.from_npy`); the
result is stored chunk by chunk into a ``.npy`` file made by ``np.lib.format.open_memmap``
(:func:`belief.dask_batches.to_npy`).  Printed: the rows, the time of the fusion, the
throughput in rows per second, that of the in-memory kernel on a batch that fits
(``--memory-rows``, the same rule and engine, best of three), their ratio, and the peak
memory of the whole process tree (this process and the workers, sampled by psutil).

The files take 3 x rows x 3 x 8 bytes (two inputs and the result of four focal elements
take 2 x 24 + 32 = 80 bytes a row); the script refuses to start, naming the space needed,
when the folder has less free space, and removes its files at the end.

Usage::

    python benchmarks/bench_dask.py --rows 10000000
    python benchmarks/bench_dask.py --rows 100000000 --dir /some/big/disk --memory-limit 700MB
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

#: Bytes of disk per row: two inputs of three floats and the result of four focal elements.
BYTES_PER_ROW = (3 + 3 + 4) * 8


def tree_rss(process) -> int:
    """Resident memory of a process and all its descendants, in bytes."""
    import psutil

    total = 0
    for p in [process, *process.children(recursive=True)]:
        try:
            total += p.memory_info().rss
        except psutil.Error:
            pass
    return total


class PeakSampler(threading.Thread):
    """Samples the resident memory of the process tree every ``interval`` seconds and keeps the peak."""

    def __init__(self, interval: float = 0.05) -> None:
        import psutil

        super().__init__(daemon=True)
        self.process = psutil.Process(os.getpid())
        self.interval = interval
        self.peak = 0
        self._stop_event = threading.Event()

    def run(self) -> None:
        while not self._stop_event.is_set():
            self.peak = max(self.peak, tree_rss(self.process))
            time.sleep(self.interval)

    def stop(self) -> int:
        self._stop_event.set()
        self.join()
        self.peak = max(self.peak, tree_rss(self.process))
        return self.peak


def write_source(path: Path, rows: int, seed: int, block: int = 1 << 22) -> None:
    """A .npy file of ``rows`` random probability vectors over three hypotheses, written block by block."""
    out = np.lib.format.open_memmap(path, mode="w+", dtype=np.float64, shape=(rows, 3))
    rng = np.random.default_rng(seed)
    for start in range(0, rows, block):
        stop = min(rows, start + block)
        x = rng.random((stop - start, 3)) + 0.01
        out[start:stop] = x / x.sum(axis=1, keepdims=True)
    out.flush()
    del out


def in_memory_rate(rows: int, model) -> float:
    """Rows per second of the in-memory PCR6 kernel (combine(...).values), best of three."""
    from belief import MassBatch, combine

    rng = np.random.default_rng(3)
    x, y = rng.random((rows, 3)) + 0.01, rng.random((rows, 3)) + 0.01
    a = MassBatch.bayesian(x / x.sum(1, keepdims=True), model=model)
    b = MassBatch.bayesian(y / y.sum(1, keepdims=True), model=model)
    best = float("inf")
    for _ in range(3):
        start = time.perf_counter()
        combine(a, b, rule="pcr6").values
        best = min(best, time.perf_counter() - start)
    return rows / best


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=10_000_000, help="rows of each source (default 10^7)")
    parser.add_argument("--dir", default=None, help="folder for the .npy files (default: a temporary folder)")
    parser.add_argument("--chunk", type=int, default=1 << 19, help="rows per chunk (default 2^19)")
    parser.add_argument("--workers", type=int, default=2, help="workers of the LocalCluster (default 2)")
    parser.add_argument("--memory-limit", default="700MB", help="memory limit of each worker (default 700MB)")
    parser.add_argument("--memory-rows", type=int, default=4_000_000,
                        help="rows of the in-memory reference batch (default 4 x 10^6)")
    parser.add_argument("--processes", action="store_true",
                        help="workers as processes of their own; by default they are threads of this process "
                             "(LocalCluster(processes=False)), which pickle no chunk between processes while "
                             "numpy's kernels release the GIL")
    parser.add_argument("--keep", action="store_true", help="keep the .npy files")
    args = parser.parse_args(argv)

    from dask.distributed import Client, LocalCluster

    from belief import MassBatch, Model, combine
    from belief.dask_batches import from_npy, to_npy

    base = Path(args.dir) if args.dir else Path(tempfile.gettempdir())
    base.mkdir(parents=True, exist_ok=True)
    needed = args.rows * BYTES_PER_ROW
    free = shutil.disk_usage(base).free
    if free < needed * 1.05:
        print(f"not enough disk in {base}: {args.rows:,} rows need {needed / 2**30:.1f} GiB, "
              f"{free / 2**30:.1f} GiB are free; use --dir or fewer --rows", file=sys.stderr)
        return 2
    folder = Path(tempfile.mkdtemp(prefix="bench_dask_", dir=base))
    model = Model.for_targets(2)                          # t1, t2 and FA
    try:
        memory_rate = in_memory_rate(args.memory_rows, model)
        start = time.perf_counter()
        write_source(folder / "a.npy", args.rows, 1)
        write_source(folder / "b.npy", args.rows, 2)
        written = time.perf_counter() - start

        with LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=args.processes,
                          memory_limit=args.memory_limit, dashboard_address=None) as cluster, \
                Client(cluster) as client:
            client.run(lambda: __import__("belief"))          # the workers import belief once, before the clock
            sampler = PeakSampler()
            sampler.start()
            start = time.perf_counter()
            # Memory maps opened in the workers (NpyRows pickles as its path), the result written there (to_npy).
            a = from_npy(folder / "a.npy", rows_per_chunk=args.chunk, model=model)
            b = from_npy(folder / "b.npy", rows_per_chunk=args.chunk, model=model)
            fused = combine(a, b, rule="pcr6")
            to_npy(fused, folder / "fused.npy")
            elapsed = time.perf_counter() - start
            peak = sampler.stop()
            focal = [str(x) for x in fused.focal]
        check = np.load(folder / "fused.npy", mmap_mode="r")
        head = combine(MassBatch.bayesian(np.load(folder / "a.npy", mmap_mode="r")[:1000], model=model),
                       MassBatch.bayesian(np.load(folder / "b.npy", mmap_mode="r")[:1000], model=model),
                       rule="pcr6").values
        equal = bool(np.array_equal(check[:1000], head))
        del check
        rate = args.rows / elapsed
        kind = "processes" if args.processes else "threads"
        print(f"rows: {args.rows:,} (chunks of {args.chunk:,}, {args.workers} workers as {kind}, "
              f"{args.memory_limit} each)")
        print(f"result focal elements: {focal}; first 1,000 rows equal to the in-memory path: {equal}")
        print(f"inputs written in {written:.1f} s")
        print(f"dask, memory maps -> .npy: {elapsed:.1f} s, {rate / 1e6:.2f} M rows/s")
        print(f"in memory ({args.memory_rows:,} rows): {memory_rate / 1e6:.2f} M rows/s")
        print(f"ratio dask / in memory: {rate / memory_rate:.2f}")
        print(f"peak memory of the process tree: {peak / 2**30:.2f} GiB")
    finally:
        if not args.keep:
            shutil.rmtree(folder, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
