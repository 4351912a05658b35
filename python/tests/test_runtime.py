"""The GIL is released during computation (measured as overlap of two threads), Ctrl-C stops a
long sweep or map within a second with KeyboardInterrupt, and a panic comes out as an exception."""

import os
import signal
import subprocess
import sys
import textwrap
import threading
import time

import pytest

import vibrobar


def _overlap(call):
    """Run `call` on a thread; count how often this thread ran Python meanwhile."""
    started, done = threading.Event(), threading.Event()
    span = {}

    def worker():
        started.set()
        span["t0"] = time.perf_counter()
        call()
        span["t1"] = time.perf_counter()
        done.set()

    th = threading.Thread(target=worker)
    th.start()
    started.wait()
    stamps = []
    while not done.is_set():
        stamps.append(time.perf_counter())
    th.join()
    inside = [t for t in stamps if span["t0"] < t < span["t1"]]
    return span["t1"] - span["t0"], inside


def test_gil_is_released_during_native_work():
    seconds, inside = _overlap(lambda: vibrobar._vibrobar._busy(0.5))
    assert seconds >= 0.5
    # With the GIL held, this thread could only run at the switch interval's edges (a handful of
    # times); released, it runs all the time: thousands of iterations spread over the call.
    assert len(inside) > 10_000
    assert max(inside) - min(inside) > 0.8 * seconds


def test_gil_is_released_during_a_sweep():
    sc = vibrobar.Scenario.paper(solver="rk4", duration_s=0.2)
    seconds, inside = _overlap(lambda: vibrobar.sweep(sc, ratios=[0.98, 1.0, 1.02], gaps_m=[1e-4], threads=1))
    assert seconds > 0.05
    assert len(inside) > 1000 and max(inside) - min(inside) > 0.5 * seconds


CHILD = textwrap.dedent(
    """
    import sys, time, vibrobar
    what = sys.argv[1]
    sc = vibrobar.Scenario.paper(solver="rk4", duration_s=0.5)
    many = [0.9 + 0.002 * i for i in range(100)]
    print("ready", flush=True)
    try:
        if what == "sweep":
            vibrobar.sweep(sc, ratios=many, gaps_m=[1e-4, 1e-3])
        elif what == "map":
            vibrobar.map(sc, many, [1e-4, 1e-3])
        elif what == "ensemble":
            vibrobar.ensemble(sc, many, [1e-4], members=4)
        else:
            vibrobar._vibrobar._busy(60.0)
    except KeyboardInterrupt:
        print("interrupted", time.monotonic(), flush=True)
        sys.exit(0)
    print("finished", flush=True)
    """
)


@pytest.mark.parametrize("what", ["busy", "sweep", "map", "ensemble"])
def test_ctrl_c_raises_keyboard_interrupt_within_a_second(what):
    p = subprocess.Popen([sys.executable, "-c", CHILD, what], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "ready"
    time.sleep(1.0)
    assert p.poll() is None, "the batch must still be running when interrupted"
    sent = time.monotonic()
    os.kill(p.pid, signal.SIGINT)
    out, _ = p.communicate(timeout=30)
    words = out.split()
    assert words[0] == "interrupted", out
    assert float(words[1]) - sent < 1.0, f"{what}: KeyboardInterrupt {float(words[1]) - sent:.2f} s after SIGINT"


def test_a_panic_comes_out_as_an_exception():
    with pytest.raises(RuntimeError, match="internal error .*test panic"):
        vibrobar._vibrobar._busy(0.0, panic=True)
    # And the module still works afterwards.
    assert vibrobar.run(duration_s=0.01).history.rows > 0
