"""Periodic orbits and continuation from Python (issue #11): the same numbers as the command
line's core, checked against the analytic symmetric orbit's known stability interval."""
import pytest

import vibrobar
from vibrobar import Scenario


def test_orbit_is_the_stable_symmetric_orbit():
    o = vibrobar.orbit(Scenario.paper(friction="none"), ratio=1.0, gap_m=0.08e-3)
    assert o["impacts_per_period"] == 2 and o["period"] == 1
    assert o["stable"] and o["max_abs_multiplier"] < 1.0
    assert len(o["multipliers"]) == 4 and o["event_sequence"] in ("+-", "-+")
    assert o["confined"] and o["residual"] <= 1e-9
    # Past the torus point (0.0949 mm) the same orbit is unstable.
    u = vibrobar.orbit(Scenario.paper(friction="none"), ratio=1.0, gap_m=0.1e-3)
    assert not u["stable"] and u["max_abs_multiplier"] > 1.0
    with pytest.raises(ValueError, match=r"period = 0 is outside the allowed range \[1, 64\]"):
        vibrobar.orbit(period=0)


def test_continuation_finds_the_torus_point():
    t = vibrobar.continuation(
        Scenario.paper(friction="none"), "gap_m", 0.06e-3, 0.12e-3, ratio=1.0
    )
    assert list(t) == [
        "param", "rms_m", "max_abs_multiplier", "stable", "impacts_per_period", "period", "event",
    ]
    events = [(p, e) for p, e in zip(t["param"], t["event"]) if e]
    assert [e for _, e in events] == ["torus"]
    assert 0.094e-3 < events[0][0] < 0.096e-3
    assert t.to_csv().startswith("param,rms_m,max_abs_multiplier,stable,")
    assert t.to_csv().count("\n") == t.rows + 1
    with pytest.raises(ValueError, match="param must be one of"):
        vibrobar.continuation(Scenario.paper(), "gap_mm", 0.06, 0.12, ratio=1.0)
    with pytest.raises(ValueError, match="--to"):
        vibrobar.continuation(Scenario.paper(), "gap_m", 1e-4, 1e-4, ratio=1.0)


def test_continuation2_follows_the_torus_curve():
    t = vibrobar.continuation2(
        Scenario.paper(friction="none"), "torus", 1.0, 0.09489e-3, ratios=(0.98, 1.03)
    )
    assert list(t) == [
        "ratio", "gap_mm", "kind", "rms_m", "max_abs_multiplier", "on_boundary",
        "test_function", "residual", "impacts_per_period", "event",
    ]
    assert t.rows > 10
    assert abs(t["ratio"][0] - 0.98) < 1e-12 and abs(t["ratio"][-1] - 1.03) < 1e-12
    assert max(abs(v) for v in t["test_function"]) < 1e-9
    # At r = 1.03 the orbit-stability table's torus end, 0.08811 mm.
    assert abs(t["gap_mm"][-1] - 0.08811) < 1e-5
    assert t.to_csv().startswith("ratio,gap_mm,kind,")
    with pytest.raises(ValueError, match="--kind"):
        vibrobar.continuation2(Scenario.paper(), "hopf", 1.0, 0.09489e-3)
    with pytest.raises(ValueError, match="--ratios"):
        vibrobar.continuation2(Scenario.paper(), "torus", 1.0, 0.09489e-3, ratios=(1.0, 1.0))
def test_hertz_orbit_and_spectrum():
    # The compliant contact law (issue #11 through hertz contact phases): the symmetric orbit
    # softened (max |λ| 0.7288 against 0.8469 with the restitution law), and a spectrum whose
    # sum is the trace average plus the law's approach-speed memory (the Rust tests check it).
    sc = Scenario.paper(friction="none", contact=dict(law="hertz"))
    o = vibrobar.orbit(sc, ratio=1.0, gap_m=0.08e-3)
    assert o["impacts_per_period"] == 2 and o["stable"] and o["confined"]
    assert abs(o["max_abs_multiplier"] - 0.7288) < 1e-3
    r = vibrobar.lyapunov_spectrum(sc, ratio=1.0, gap_m=0.08e-3)
    assert r["collapsed"] == 0 and r["compliant_contacts"] > 100
    assert r["approach_memory_per_s"] > 100 and r["sum_per_s"] < 0
def test_orbit_and_continuation_of_a_beam():
    # The paper's beam with three modes at 0.1 mm: the two-impact orbit from a settled run
    # (unstable: a real multiplier ≈ 7), its 2N + 2 multipliers and modal state; followed in the
    # cavity position.
    b = Scenario.paper_beam(friction="none", modes=3)
    o = vibrobar.orbit(b, ratio=1.0, gap_m=0.1e-3)
    assert o["modes"] == 3 and len(o["multipliers"]) == 8 and len(o["state"]["q_m"]) == 3
    assert o["impacts_per_period"] == 2 and not o["stable"] and o["confined"]
    assert o["residual"] <= 1e-9
    t = vibrobar.continuation(
        b, "cavity_position_m", 0.137, 0.130, ratio=1.0, gap_m=0.1e-3, max_points=20
    )
    assert t.rows >= 5 and abs(t["param"][0] - 0.137) < 1e-12
    assert all(0.130 - 1e-12 <= p <= 0.137 + 1e-12 for p in t["param"])
    with pytest.raises(ValueError, match="settled"):
        vibrobar.orbit(b, ratio=1.0, gap_m=0.1e-3, start="symmetric")


def test_lyapunov_spectrum_of_a_beam_meets_the_modal_identity():
    import math

    b = Scenario.paper_beam(friction="none", modes=3, solver="exact", duration_s=0.4)
    r = vibrobar.lyapunov_spectrum(b, ratio=1.0, gap_m=0.08e-3)
    # 2N + 2 exponents whose sum is −Σcₙ/mₙ + 2 ln(e) × impacts/s.
    assert len(r["exponents_per_s"]) == 8 and r["collapsed"] == 0
    assert r["impacts_per_s"] > 100
    assert math.isclose(r["sum_per_s"], r["volume_identity_per_s"], rel_tol=1e-9)


ONE_UNIT_MODE = """[[modes]]
frequency_hz = 602.2026447166344
damping_ratio = 0.01
modal_mass_kg = 0.644
shape_cavity = 1.0
"""


def test_continuation_of_an_n_mode_bar_switches_at_the_period_doubling():
    # The lumped bar as one [[modes]] table: its asymmetric orbit's period doubling (0.050342
    # mm, the lumped bar's) is located and the period-2 branch followed unless switch_branches
    # is False.
    sc = Scenario.from_toml_str(ONE_UNIT_MODE, friction="none")
    args = (sc, "gap_m", 0.052e-3, 0.0495e-3)
    t = vibrobar.continuation(*args, ratio=1.0, start="settled")
    pd = [p for p, e in zip(t["param"], t["event"]) if e == "period-doubling"]
    assert len(pd) == 1 and abs(pd[0] - 0.0503415494e-3) < 1e-12
    assert sum(1 for k in t["period"] if k == 2) >= 3
    u = vibrobar.continuation(*args, ratio=1.0, start="settled", switch_branches=False)
    assert all(k == 1 for k in u["period"])
