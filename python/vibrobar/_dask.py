"""Batch functions on a Dask cluster: ``vibrobar.map(..., client=client)``.

The grid is cut by frequency ratio, round-robin: shard ``k`` of ``n`` gets ``ratios[k::n]`` with
every gap (and every optional axis). A row depends only on its own grid point (a map's solid run
only on its ratio, an ensemble member only on the seed and its member number), so each shard
computes exactly the rows the whole call would, and the merge puts them back in grid order
(ratio outer): the result is the single-process result, bit for bit, columns and CSV text alike.

Each shard is one Dask task (named ``vibrobar-<fn>-shard-<k>``) that calls the same function
without a client; the merge is one more task depending on them. :func:`submit` returns the merge's
future: cancelling it (``future.cancel()``) cancels the shard tasks too, so those not yet
started never run (a running shard finishes its few points; Dask cannot stop a thread). The blocking form
(``client=`` on the function) reports ``progress(done, total)`` in ratios as shards finish, and
cancels everything on ``KeyboardInterrupt``.
"""

from __future__ import annotations

from typing import Any, Callable, Optional

import numpy as _np


def _run_shard(fn: str, scenario_toml: Optional[str], axis: str, values, kwargs: dict):
    """One shard, on a worker: the function itself, without a client; ``axis`` is the keyword
    of its frequency values (``ratios``, or ``freqs_hz`` for a map in Hz)."""
    import vibrobar

    sc = None if scenario_toml is None else vibrobar.Scenario.from_toml_str(scenario_toml)
    return getattr(vibrobar, fn)(sc, **{axis: values}, **kwargs)


def _merge(n_ratios: int, *parts):
    """The rows of the shards back in grid order: ratio ``i`` is block ``i // n`` of shard
    ``i % n``; every ratio has the same number of rows (gaps × optional axes)."""
    n = len(parts)
    first = parts[0]
    per = [p.rows // len(range(k, n_ratios, n)) for k, p in enumerate(parts)]
    if len(set(per)) != 1:
        raise RuntimeError(f"shards disagree on rows per ratio: {per}")
    per = per[0]
    order = [(i % n, (i // n) * per) for i in range(n_ratios)]
    cols = {
        name: _np.concatenate([parts[k][name][j : j + per] for k, j in order])
        for name in first
    }
    csv = None
    if first._csv is not None:
        lines = [p._csv.splitlines() for p in parts]
        body = [row for k, j in order for row in lines[k][1 + j : 1 + j + per]]
        csv = "\n".join([lines[0][0], *body]) + "\n"
    return type(first)(cols, csv)


def submit(client, fn: str, scenario, ratios, shards: Optional[int] = None, **kwargs):
    """Submit ``vibrobar.<fn>(scenario, ratios, **kwargs)`` as shard tasks and a merge task;
    returns the merge's future (its result: what the function returns without a client). A map
    in absolute frequencies (``freqs_hz=`` in ``kwargs``, no ratios) is cut by frequency the
    same way: a row depends only on its own frequency."""
    axis = "ratios"
    if kwargs.get("freqs_hz") is not None:
        axis, ratios = "freqs_hz", kwargs.pop("freqs_hz")
    kwargs.pop("freqs_hz", None)
    ratios = _np.atleast_1d(_np.asarray(ratios, dtype=float))
    if ratios.ndim != 1 or len(ratios) == 0:
        raise ValueError(f"{axis} must be a non-empty 1-d array")
    if shards is None:
        workers = max(1, len(client.scheduler_info().get("workers", {})))
        shards = 4 * workers
    if isinstance(shards, bool) or not isinstance(shards, (int, _np.integer)) or shards < 1:
        raise ValueError(f"shards = {shards!r} is outside the allowed range [1, ∞)")
    n = min(int(shards), len(ratios))
    toml = None if scenario is None else scenario.to_toml()
    import uuid

    job = uuid.uuid4().hex[:12]
    futs = [
        client.submit(
            _run_shard,
            fn,
            toml,
            axis,
            ratios[k::n],
            kwargs,
            key=f"vibrobar-{fn}-shard-{k + 1}-of-{n}-{job}",
            pure=False,
        )
        for k in range(n)
    ]
    merged = client.submit(_merge, len(ratios), *futs, key=f"vibrobar-{fn}-merge-{job}")
    merged.shard_futures = futs

    # Cancelling the result cancels the shards too (Dask cancels a key and its dependents only).
    def cancel(**kw):
        return client.cancel([*futs, merged], **kw)

    merged.cancel = cancel
    merged.shard_points = [len(ratios[k::n]) for k in range(n)]
    return merged


def run(
    client,
    fn: str,
    scenario,
    ratios,
    shards: Optional[int],
    progress: Optional[Callable[[int, int], Any]],
    **kwargs,
):
    """The blocking form: submit, report progress (in ratios, as shards finish), gather; on
    ``KeyboardInterrupt`` (or any error) cancel every task of the call."""
    from distributed import as_completed

    merged = submit(client, fn, scenario, ratios, shards, **kwargs)
    futs = merged.shard_futures
    total = sum(merged.shard_points)
    points = dict(zip((f.key for f in futs), merged.shard_points))
    done = 0
    try:
        if progress is not None:
            progress(0, total)
        for f in as_completed(futs):
            if f.status == "error":
                f.result()  # raises the shard's exception
            done += points[f.key]
            if progress is not None:
                progress(done, total)
        return merged.result()
    except BaseException:
        client.cancel([merged, *futs])
        raise
