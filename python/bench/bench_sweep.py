"""Python call overhead: a 110-point paper sweep (55 ratios 0.95…1.058 step 0.002 × the paper's
gaps 0.1 and 1 mm, the paper scenario) from Python and with the CLI binary, in one process run,
alternating, medians of repeats. The two must give the same CSV text (checked).

    python python/bench/bench_sweep.py [--bin target/release/vibrobar] [--repeats 9] [--rk4-repeats 3]

"CLI wall" is the subprocess's wall time as a user sees it (process start, files written); "CLI
self" is the time the CLI reports for its own sweep (it starts after argument parsing and ends
when the files are written). The Python time is the call of vibrobar.sweep, table included.
"""

import argparse
import pathlib
import re
import statistics
import subprocess
import tempfile
import time

import numpy as np

import vibrobar

ROOT = pathlib.Path(__file__).resolve().parents[2]


def cli_self_seconds(stderr: str) -> float:
    m = re.search(r" in ([0-9.]+) (ms|s)\s*$", stderr.strip())
    if not m:
        raise RuntimeError(f"no time in the CLI's output: {stderr!r}")
    return float(m.group(1)) * (1e-3 if m.group(2) == "ms" else 1.0)


def bench(exe: str, solver: str, repeats: int) -> dict:
    ratios = 0.95 + np.arange(55) * 0.002  # the CLI's START + i·STEP
    sc = vibrobar.Scenario.paper(solver=solver)
    cli_wall, cli_self, py = [], [], []
    with tempfile.TemporaryDirectory() as d:
        out = pathlib.Path(d) / "sweep.csv"
        for k in range(repeats + 1):  # the first pair warms up (page cache, CPU clock)
            out.unlink(missing_ok=True)
            t = time.perf_counter()
            p = subprocess.run([exe, "sweep", "--solver", solver, "--ratios", "0.95:1.058:0.002", "--out", str(out)],
                               capture_output=True, text=True, check=True)
            w = time.perf_counter() - t
            t = time.perf_counter()
            s = vibrobar.sweep(sc, ratios=ratios)
            dt = time.perf_counter() - t
            if k == 0:
                assert s.rows == 110
                assert s.to_csv() == out.read_text(), "Python and CLI rows differ"
                continue
            cli_wall.append(w)
            cli_self.append(cli_self_seconds(p.stderr))
            py.append(dt)
    med = statistics.median
    return dict(solver=solver, repeats=repeats, cli_wall=med(cli_wall), cli_self=med(cli_self), py=med(py))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", default=str(ROOT / "target" / "release" / "vibrobar"))
    ap.add_argument("--repeats", type=int, default=9)
    ap.add_argument("--rk4-repeats", type=int, default=3)
    a = ap.parse_args()
    print(f"vibrobar {vibrobar.__version__}: 110-point paper sweep (55 ratios × 2 gaps), medians")
    print(f"{'solver':<7}{'repeats':>8}{'CLI wall':>11}{'CLI self':>11}{'Python':>10}{'Py/CLI wall':>13}{'Py/CLI self':>13}")
    for solver, n in [("exact", a.repeats), ("rk4", a.rk4_repeats)]:
        if n <= 0:
            continue
        r = bench(a.bin, solver, n)
        print(f"{solver:<7}{n:>8}{r['cli_wall']:>10.3f}s{r['cli_self']:>10.3f}s{r['py']:>9.3f}s"
              f"{r['py'] / r['cli_wall']:>13.3f}{r['py'] / r['cli_self']:>13.3f}")


if __name__ == "__main__":
    main()
