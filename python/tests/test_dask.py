"""Batch functions on Dask (issue #15): shards as Dask tasks on a two-worker LocalCluster of
processes, merged into the single-process result bit for bit; progress; cancellation."""

import os
import time

import numpy as np
import pytest

import vibrobar

try:
    from distributed import Client, LocalCluster, get_task_stream
    from distributed.client import FutureCancelledError
except ImportError:  # pragma: no cover - the test venv installs it
    if os.environ.get("VIBROBAR_REQUIRE_EXTRAS"):
        raise
    pytest.skip("dask.distributed not installed", allow_module_level=True)

RATIOS = np.round(np.arange(0.90, 1.1001, 0.02), 10)
GAPS_M = np.array([2e-4, 5e-4, 1e-3])


@pytest.fixture(scope="module")
def client():
    cluster = LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    )
    c = Client(cluster)
    yield c
    c.close()
    cluster.close()


def same(a, b):
    assert type(a) is type(b)
    assert list(a) == list(b)
    for k in a:
        assert a[k].dtype == b[k].dtype, k
        # Bit for bit: the bytes of every column, NaN or not.
        assert a[k].tobytes() == b[k].tobytes(), k
    assert a.to_csv() == b.to_csv()


def test_map_on_two_dask_workers_equals_the_single_process_map_bit_for_bit(client):
    sc = vibrobar.Scenario.paper(friction="none")
    ref = vibrobar.map(sc, RATIOS, GAPS_M, restitutions=[0.6, 0.8])
    assert ref.rows == len(RATIOS) * len(GAPS_M) * 2
    for shards in (1, 3, 4, 100):
        got = vibrobar.map(sc, RATIOS, GAPS_M, restitutions=[0.6, 0.8], client=client, shards=shards)
        same(ref, got)
    # Both worker processes took part (the shards really ran elsewhere).
    ran = client.run(lambda: os.getpid())
    assert len(set(ran.values())) == 2 and os.getpid() not in ran.values()


def test_map_with_rk4_and_overrides_on_dask_is_bit_identical(client):
    sc = vibrobar.Scenario.paper(friction="none", solver="rk4", duration_s=0.1)
    ref = vibrobar.map(sc, RATIOS[:4], GAPS_M[:2])
    same(ref, vibrobar.map(sc, RATIOS[:4], GAPS_M[:2], client=client, shards=3))


def test_ensemble_on_dask_is_bit_identical(client):
    kw = dict(members=5, seed=3, friction="none")
    ref = vibrobar.ensemble(None, RATIOS[:5], GAPS_M, **kw)
    same(ref, vibrobar.ensemble(None, RATIOS[:5], GAPS_M, client=client, shards=2, **kw))


def test_progress_reaches_the_caller(client):
    seen = []
    vibrobar.map(None, RATIOS, GAPS_M, friction="none", client=client, shards=4,
                 progress=lambda d, t: seen.append((d, t)))
    assert seen[0] == (0, len(RATIOS)) and seen[-1] == (len(RATIOS), len(RATIOS))
    assert len(seen) == 5 and all(a[0] < b[0] for a, b in zip(seen, seen[1:]))


def test_cancelling_the_future_cancels_the_work(client):
    # 16 shards of about 0.3 s each on 2 single-thread workers: about 2.5 s if not cancelled.
    sc = vibrobar.Scenario.paper(friction="none", solver="rk4", duration_s=1.0)
    ratios = np.round(np.linspace(0.9, 1.1, 16), 10)
    with get_task_stream(client) as ts:
        fut = vibrobar.submit(client, "map", sc, ratios, gaps_m=[5e-4], threads=1, shards=16)
        shards = fut.shard_futures
        while not any(f.done() for f in shards):
            time.sleep(0.01)
        fut.cancel()
        time.sleep(3.0)
    assert fut.cancelled()
    assert sum(f.cancelled() for f in shards) >= 8
    with pytest.raises((FutureCancelledError, Exception)):
        fut.result(timeout=1)
    ran = {t["key"] for t in ts.data if "shard" in str(t["key"])}
    assert 1 <= len(ran) < 16, f"{len(ran)} of 16 shards ran after the cancel"


def test_bad_arguments_are_refused(client):
    with pytest.raises(ValueError, match="shards"):
        vibrobar.map(None, RATIOS, GAPS_M, client=client, shards=0)
    with pytest.raises(ValueError, match="only 'map' and 'ensemble'"):
        vibrobar.submit(client, "sweep", None, RATIOS)
    # An error in a shard reaches the caller as the function's own error.
    with pytest.raises(ValueError, match="gaps_m"):
        vibrobar.map(None, RATIOS, [-1.0], client=client)


def test_map_in_hz_on_dask_is_bit_identical(client):
    sc = vibrobar.Scenario.paper(solver="rk4", duration_s=0.05)
    freqs = 580.0 + np.arange(5) * 5.0
    ref = vibrobar.map(sc, freqs_hz=freqs, gaps_m=GAPS_M[:2])
    same(ref, vibrobar.map(sc, freqs_hz=freqs, gaps_m=GAPS_M[:2], client=client, shards=2))
    with pytest.raises(ValueError, match="ratios and freqs_hz"):
        vibrobar.map(sc, RATIOS, GAPS_M, freqs_hz=freqs, client=client)
