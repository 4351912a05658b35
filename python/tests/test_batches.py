"""Sweeps, maps, regimes, Poincaré sections, bifurcation diagrams, Lyapunov exponents and
ensembles from Python: tables, progress, threads, xarray/pandas, and bad arrays."""

import math

import numpy as np
import pytest

import vibrobar
from vibrobar import Scenario

QUICK = Scenario.paper(duration_s=0.3)


def test_sweep_is_a_mapping_of_cli_columns():
    s = vibrobar.sweep(QUICK)
    assert list(s) == ["ratio", "gap_mm", "friction", "solver", "rms_solid_m", "rms_damped_m", "reduction_pct", "impacts"]
    assert s.rows == 22
    assert s["rms_damped_m"].dtype == np.float64 and s["impacts"].dtype == np.int64
    # Gap-major rows.
    assert s["gap_mm"].tolist() == [0.1] * 11 + [1.0] * 11
    # reduction = 100·(1 − damped/solid).
    assert np.allclose(s["reduction_pct"], 100 * (1 - s["rms_damped_m"] / s["rms_solid_m"]), rtol=1e-12)
    pandas = pytest.importorskip("pandas")
    df = pandas.DataFrame(s)
    assert df.shape == (22, 8) and df["solver"].iloc[0] == "exact"


def test_sweep_to_xarray_has_ratio_and_gap_dimensions_with_units():
    pytest.importorskip("xarray")
    s = vibrobar.sweep(QUICK, ratios=[0.98, 1.0], gaps_m=[1e-4, 2e-4, 1e-3])
    ds = s.to_xarray()
    assert dict(ds.sizes) == {"gap_mm": 3, "ratio": 2}
    assert ds["rms_damped_m"].attrs["units"] == "m" and ds["gap_mm"].attrs["units"] == "mm"
    k = (s["gap_mm"] == 0.2) & (s["ratio"] == 1.0)
    assert ds["rms_damped_m"].sel(gap_mm=0.2, ratio=1.0).item() == s["rms_damped_m"][k][0]


def test_progress_callback_and_threads():
    calls = []
    a = vibrobar.sweep(QUICK, ratios=[0.97, 0.99, 1.01], progress=lambda d, t: calls.append((d, t)))
    assert calls and calls[-1] == (calls[-1][1], calls[-1][1])
    assert all(b[0] >= a_[0] for a_, b in zip(calls, calls[1:]))
    # Rows do not depend on the thread count.
    b = vibrobar.sweep(QUICK, ratios=[0.97, 0.99, 1.01], threads=1)
    assert a.to_csv() == b.to_csv()
    # A raising callback stops the batch with its exception.
    def boom(d, t):
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        vibrobar.sweep(Scenario.paper(solver="rk4", duration_s=0.2), progress=boom)
    assert vibrobar.sweep(QUICK, ratios=[1.0], progress=True).rows == 2


@pytest.mark.parametrize(
    "kw, exc, msg",
    [
        (dict(ratios=[[0.9, 1.0], [1.1, 1.2]]), ValueError, r"ratios must be 1-d, got an array of shape \(2, 2\)"),
        (dict(ratios=[1.0, math.nan]), ValueError, r"ratios\[1\] = NaN is outside the allowed range \(0, ∞\)"),
        (dict(ratios=[1.0, -1.0]), ValueError, r"ratios\[1\] = -1 is outside"),
        (dict(ratios="0.9:1.1:0.1"), TypeError, "ratios must be a number or a 1-d array"),
        (dict(ratios=["a"]), TypeError, "ratios must be"),
        (dict(ratios=[]), ValueError, "ratios is empty"),
        (dict(gaps_m=[0.0]), ValueError, r"gaps_m\[0\] = 0 is outside the allowed range \(0, ∞\) m"),
        (dict(threads=0), ValueError, r"threads = 0 is outside the allowed range \[1, ∞\)"),
        (dict(threads="2"), TypeError, "threads must be an int"),
        (dict(progress=3), TypeError, "progress must be"),
        (dict(solver="euler"), ValueError, "run.solver"),
    ],
)
def test_bad_sweep_input(kw, exc, msg):
    with pytest.raises(exc, match=msg):
        vibrobar.sweep(QUICK, **kw)


def test_map_with_an_optional_axis():
    m = vibrobar.map(QUICK, [0.98, 1.0], [1e-4, 1e-3], restitutions=[0.3, 0.6])
    assert list(m) == ["ratio", "gap_mm", "restitution", "rms_solid_m", "rms_damped_m", "reduction_pct", "impacts_per_cycle", "regime"]
    assert m.rows == 8
    assert set(m["regime"].tolist()) >= {"none"}
    if pytest.importorskip("xarray"):
        ds = m.to_xarray()
        assert dict(ds.sizes) == {"ratio": 2, "gap_mm": 2, "restitution": 2}
    with pytest.raises(ValueError, match=r"restitutions\[0\] = 2 is outside the allowed range \[0, 1\]"):
        vibrobar.map(QUICK, [1.0], [1e-4], restitutions=[2.0])
    with pytest.raises(TypeError, match="ratios is required"):
        vibrobar.map(QUICK, gaps_m=[1e-4])


def test_regime_matches_the_map_row():
    r = vibrobar.regime(QUICK, ratio=1.0, gap_m=1e-4)
    m = vibrobar.map(QUICK, [1.0], [1e-4])
    assert r["regime"] == m["regime"][0] and r["rms_damped_m"] == m["rms_damped_m"][0]
    assert vibrobar.regime(QUICK, ratio=0.98, gap_m=1e-3)["regime"] == "none"
    with pytest.raises(ValueError, match=r"gap_m = -1 is outside the allowed range \(0, ∞\) m"):
        vibrobar.regime(QUICK, ratio=1.0, gap_m=-1.0)
    with pytest.raises(TypeError, match="ratio must be a number"):
        vibrobar.regime(QUICK, ratio="1")


def test_poincare_of_a_period_one_orbit_is_one_point():
    # No impacts (1 mm gap at 0.98): the linear steady state, one point per period.
    p = vibrobar.poincare(Scenario.paper(), ratio=0.98, gap_m=1e-3, transient_s=1.5)
    assert list(p) == ["t_s", "u_m", "du_m_s", "w_m", "dw_m_s"]
    period = 2 * math.pi / (0.98 * math.sqrt(9.22e6 / 0.644))
    assert np.allclose(np.diff(p["t_s"]), period, rtol=1e-9)
    assert p.rows == pytest.approx(0.5 / period, abs=1.5)
    assert np.ptp(p["u_m"]) < 1e-4 * np.abs(p["u_m"]).max()
    with pytest.raises(ValueError, match=r"transient_s = 3 is outside the allowed range \[0, duration_s"):
        vibrobar.poincare(ratio=1.0, transient_s=3.0)


def test_bifurcation_diagram():
    values = [0.98, 1.0]
    pts, imp = vibrobar.bifurcation(QUICK, "ratio", values, gap_m=1e-4, progress=lambda d, t: None)
    assert list(pts) == ["ratio", "t_s", "u_m", "du_m_s"] and list(imp) == ["ratio", "t_s", "wall", "dw_m_s"]
    assert set(pts["ratio"].tolist()) == set(values)
    assert imp.rows > 0 and set(imp["ratio"].tolist()) <= set(values)
    # Points per value: the forcing periods after the transient (the default: before the RMS window).
    for r in values:
        period = 2 * math.pi / (r * math.sqrt(9.22e6 / 0.644))
        n = (pts["ratio"] == r).sum()
        assert abs(n - 0.8 * 0.3 / period) <= 1.5
    pts2, _ = vibrobar.bifurcation(QUICK, "gap_m", [1e-4, 1e-3], ratio=1.0)
    assert list(pts2)[0] == "gap_m"
    with pytest.raises(ValueError, match='param must be "ratio" or "gap_m"'):
        vibrobar.bifurcation(QUICK, "gap_mm", [0.1])


def test_lyapunov_exponent():
    chaotic = vibrobar.lyapunov(Scenario.paper(), ratio=1.0, gap_m=1e-4)
    assert vibrobar.regime(Scenario.paper(), ratio=1.0, gap_m=1e-4)["regime"] == "chaotic"
    # An independent classification says chaotic; the exponent is positive beyond its error.
    assert chaotic["exponent_per_s"] > 3 * chaotic["std_error_per_s"] > 0
    assert chaotic["intervals"] >= 2 and chaotic["d0"] == 1e-9
    with pytest.raises(ValueError, match=r"periods = 0 is outside the allowed range \(0, ∞\)"):
        vibrobar.lyapunov(periods=0.0)
    with pytest.raises(ValueError, match="at least 2 are needed"):
        vibrobar.lyapunov(periods=1000.0)


def test_lyapunov_spectrum():
    # The symmetric two-impact orbit (0.08 mm, frictionless): four finite, negative exponents whose
    # sum is the phase-volume identity −C/M + 2 ln(e) × impacts per second (the Rust tests check
    # the identity; here the sum is the sum and the orbit is stable).
    sc = Scenario.paper(friction="none")
    r = vibrobar.lyapunov_spectrum(sc, ratio=1.0, gap_m=0.08e-3)
    lam = r["exponents_per_s"]
    assert len(lam) == 4 and r["collapsed"] == 0 and lam[0] < 0
    assert abs(sum(lam) - r["sum_per_s"]) < 1e-9 * abs(r["sum_per_s"])
    assert r["impacts_per_s"] > 1000 and r["grazing"] == 0
    # The paper's chaotic 0.1 mm point: a positive largest exponent that agrees with the
    # two-trajectory estimate, and two directions removed by wall contact (None = −∞).
    chaotic = vibrobar.lyapunov_spectrum(sc, ratio=1.0, gap_m=1e-4)
    two = vibrobar.lyapunov(sc, ratio=1.0, gap_m=1e-4)
    l1 = chaotic["exponents_per_s"][0]
    tol = 3 * (chaotic["std_error_per_s"][0] ** 2 + two["std_error_per_s"] ** 2) ** 0.5
    assert l1 > 0 and abs(l1 - two["exponent_per_s"]) < tol, (l1, two)
    assert chaotic["collapsed"] == 2 and chaotic["exponents_per_s"][3] is None
    with pytest.raises(ValueError, match="blocks = 1 is outside"):
        vibrobar.lyapunov_spectrum(blocks=1)
    with pytest.raises(ValueError, match='needs solver = "exact"'):
        vibrobar.lyapunov_spectrum(sc, ratio=1.0, gap_m=1e-4, solver="rk4")


def test_ensemble():
    e = vibrobar.ensemble(QUICK, [1.0], [1e-4, 1e-3], members=4, seed=7)
    assert list(e) == ["ratio", "gap_mm", "members", "mean_rms_m", "std_rms_m", "min_rms_m", "max_rms_m", "regimes"]
    assert e["members"].tolist() == [4, 4]
    assert (e["min_rms_m"] <= e["mean_rms_m"]).all() and (e["mean_rms_m"] <= e["max_rms_m"]).all()
    assert all(sum(int(c.split(":")[1]) for c in r.split(";")) == 4 for r in e["regimes"])
    again = vibrobar.ensemble(QUICK, [1.0], [1e-4, 1e-3], members=4, seed=7)
    assert e.to_csv() == again.to_csv()
    with pytest.raises(ValueError, match=r"members = 0 is outside the allowed range \[1, ∞\)"):
        vibrobar.ensemble(QUICK, [1.0], [1e-4], members=0)
    with pytest.raises(ValueError, match=r"u_m = -1 is outside the allowed range \[0, ∞\) m"):
        vibrobar.ensemble(QUICK, [1.0], [1e-4], u_m=-1.0)
