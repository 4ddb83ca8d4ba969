"""Batches on dask arrays (belief.dask_batches): lazy, chunk by chunk, equal to the in-memory path row for row."""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

da = pytest.importorskip("dask.array")
dask = pytest.importorskip("dask")

import belief.plan as plan  # noqa: E402
from belief import Frame, MassBatch, Model, combine, decide  # noqa: E402
from belief.dask_batches import DaskMassBatch, from_npy, to_npy  # noqa: E402
from belief.errors import CombinationTooLargeError, InvalidMassError  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
QUERIES = ["t1", "t2", "FA", "t1|t2", "t1&t2"]


def rows(n, k, seed):
    x = np.random.default_rng(seed).random((n, k)) + 0.01
    return x / x.sum(axis=1, keepdims=True)


@pytest.fixture(scope="module")
def sources():
    model = Model.for_targets(3)
    first, second = rows(700, 4, 1), rows(700, 4, 2)
    lazy = [MassBatch.bayesian(da.from_array(x, chunks=(200, -1)), model=model) for x in (first, second)]
    memory = [MassBatch.bayesian(x, model=model) for x in (first, second)]
    return lazy, memory


@pytest.fixture(autouse=True)
def synchronous():
    with dask.config.set(scheduler="synchronous"):
        yield


@pytest.mark.parametrize("rule", ["dempster", "conjunctive", "pcr6", "pcr5", "r_rule", "dsmh"])
def test_combine_equals_the_in_memory_path(sources, rule):
    lazy, memory = sources
    fused, expected = combine(*lazy, rule=rule), combine(*memory, rule=rule)
    assert isinstance(fused, DaskMassBatch) and fused.focal == expected.focal
    assert fused.values.chunks[0] == (200, 200, 200, 100)
    assert np.array_equal(fused.compute().values, expected.values)
    for measure in ("bel", "pls", "betp", "mass"):
        got = getattr(fused, measure)(QUERIES)
        assert isinstance(got, da.Array)
        assert np.array_equal(got.compute(), getattr(expected, measure)(QUERIES)), measure
    select = np.arange(700) % len(QUERIES)
    assert np.array_equal(fused.bel(QUERIES, select=select).compute(), expected.bel(QUERIES, select=select))
    decided, reference = decide(fused), decide(expected)
    assert decided.candidates == reference.candidates
    for field in ("scores", "value", "tied", "index"):
        assert np.array_equal(getattr(decided, field).compute(), getattr(reference, field)), field
    discounted = fused.discount(0.8)
    assert discounted.focal == expected.discount(0.8).focal
    assert np.array_equal(discounted.compute().values, expected.discount(0.8).values)


def test_general_focal_elements_and_three_sources():
    shafer = Model.shafer(Frame(["a", "b", "c"]))
    focal = ["a", "b", "a|b", "a|b|c"]
    values = rows(300, 4, 3)
    lazy = MassBatch(focal, da.from_array(values, chunks=(70, 4)), model=shafer)
    memory = MassBatch(focal, values, model=shafer)
    for rule in ("dempster", "conjunctive", "pcr6", "yager"):
        fused, expected = combine(lazy, lazy, lazy, rule=rule), combine(memory, memory, memory, rule=rule)
        assert fused.focal == expected.focal
        assert np.array_equal(fused.compute().values, expected.values)
        assert np.array_equal(fused.betp(["a", "b", "c"]).compute(), expected.betp(["a", "b", "c"]))
    assert np.array_equal(lazy.discount(0.3).compute().values, memory.discount(0.3).values)
    assert np.array_equal(decide(lazy, "pls").index.compute(), decide(memory, "pls").index)


def test_columns_chunked_or_duplicated_are_whole_rows():
    shafer = Model.shafer(Frame(["a", "b"]))
    values = rows(10, 3, 4)
    lazy = MassBatch(["a", "b", "a"], da.from_array(values, chunks=(4, 1)), model=shafer)
    memory = MassBatch(["a", "b", "a"], values, model=shafer)
    assert lazy.focal == memory.focal and lazy.values.chunks[1] == (2,)
    assert np.array_equal(lazy.compute().values, memory.values)


def test_nothing_is_computed_before_compute(sources):
    calls = []

    def counted(block):
        if len(block):                  # dask calls it on an empty block to learn the output's type
            calls.append(len(block))
        return block

    model = Model.for_targets(3)
    values = da.from_array(rows(50, 4, 5), chunks=(10, -1)).map_blocks(counted, dtype=float)
    batch = MassBatch.bayesian(values, model=model)
    fused = combine(batch, sources[1][0][0], rule="pcr6")
    measures = [fused.bel("t1"), fused.betp(QUERIES), decide(fused).index, fused.discount(0.5).values]
    assert calls == [] and all(isinstance(m, da.Array) for m in measures)
    fused.compute()
    assert sum(calls) == 50


def test_bad_rows_are_refused_when_computed_naming_the_row():
    model = Model.for_targets(2)
    values = rows(30, 3, 6)
    values[17, 1] = -0.1
    batch = MassBatch.bayesian(da.from_array(values, chunks=(10, -1)), model=model)
    with pytest.raises(InvalidMassError, match=r"negative mass -0.1 row 17"):
        batch.compute()
    with pytest.raises(InvalidMassError, match=r"values must have shape \(N, 3\)"):
        MassBatch.bayesian(da.zeros((4, 5), chunks=2), model=model)


def test_limits_apply_per_chunk(monkeypatch, sources):
    lazy, memory = sources
    # 700 rows exceed the limit in memory; chunks of 200 rows do not.
    cost = plan.joint_cost([4, 4], 200, "targets").work
    monkeypatch.setattr(plan, "MAX_WORK", cost)
    with pytest.raises(CombinationTooLargeError, match="MAX_WORK"):
        combine(*memory, rule="dsmh").values
    fused = combine(*lazy, rule="dsmh")
    monkeypatch.setattr(plan, "MAX_WORK", 10 * cost)
    expected = combine(*memory, rule="dsmh").values
    monkeypatch.setattr(plan, "MAX_WORK", cost)
    assert np.array_equal(fused.compute().values, expected)
    # One chunk of 700 rows is refused, with the limit's message.
    whole = combine(*[DaskMassBatch.wrap(m, 700) for m in memory], rule="dsmh")
    with pytest.raises(CombinationTooLargeError, match=r"belief\.plan\.MAX_WORK"):
        whole.compute()


def test_mixed_inputs_and_row_counts(sources):
    lazy, memory = sources
    expected = combine(*memory, rule="pcr6").values
    assert np.array_equal(combine(lazy[0], memory[1], rule="pcr6").compute().values, expected)
    assert np.array_equal(combine(memory[0], lazy[1], rule="pcr6").compute().values, expected)
    one = memory[1][3]
    assert np.array_equal(combine(lazy[0], one, rule="pcr6").compute().values,
                          combine(memory[0], one, rule="pcr6").values)
    rechunked = lazy[1].rechunk(150)
    fused = combine(lazy[0], rechunked, rule="pcr6")
    assert fused.values.chunks[0] == (200, 200, 200, 100)
    assert np.array_equal(fused.compute().values, expected)
    short = MassBatch.bayesian(da.from_array(rows(600, 4, 7), chunks=(200, -1)), model=memory[0].model)
    with pytest.raises(InvalidMassError, match="different numbers of rows"):
        combine(lazy[0], short)


def test_memory_maps_and_npy_results(tmp_path, sources):
    lazy, memory = sources
    for name, batch in zip("ab", memory):
        np.save(tmp_path / f"{name}.npy", batch.values)
    mapped = np.load(tmp_path / "a.npy", mmap_mode="r")
    first = MassBatch.bayesian(da.from_array(mapped, chunks=(256, -1)), model=memory[0].model)
    second = from_npy(tmp_path / "b.npy", rows_per_chunk=256, model=memory[0].model)
    fused = combine(first, second, rule="pcr6")
    to_npy(fused, tmp_path / "fused.npy")
    assert np.array_equal(np.load(tmp_path / "fused.npy"), combine(*memory, rule="pcr6").values)


def test_zarr(tmp_path, sources):
    zarr = pytest.importorskip("zarr")
    lazy, memory = sources
    store = zarr.open(str(tmp_path / "a.zarr"), mode="w", shape=memory[0].shape, chunks=(300, 4), dtype="f8")
    store[:] = memory[0].values
    batch = MassBatch.bayesian(da.from_zarr(str(tmp_path / "a.zarr")), model=memory[0].model)
    assert np.array_equal(combine(batch, lazy[1], rule="pcr6").compute().values,
                          combine(*memory, rule="pcr6").values)


def test_local_cluster(tmp_path, sources):
    distributed = pytest.importorskip("dask.distributed")
    lazy, memory = sources
    np.save(tmp_path / "a.npy", memory[0].values)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0") as cluster, \
            distributed.Client(cluster) as client:
        fused = combine(from_npy(tmp_path / "a.npy", rows_per_chunk=300, model=memory[0].model), lazy[1],
                        rule="pcr6")
        values, bel = client.compute([fused.values, fused.bel("t1")], sync=True)
    expected = combine(*memory, rule="pcr6")
    assert np.array_equal(values, expected.values) and np.array_equal(bel, expected.bel("t1"))


def test_import_belief_does_not_import_dask():
    code = "import sys, numpy, belief; from belief import combine, MassBatch; print('dask' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_the_docs_page_runs():
    # docs/dask.md keeps its examples in plain ```python blocks (no prompts), run here only where dask is.
    page = (ROOT / "docs" / "dask.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", page, flags=re.S)
    assert blocks
    namespace = {}
    for block in blocks:
        exec(compile(block, "docs/dask.md", "exec"), namespace)
