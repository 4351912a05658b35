"""vibrobar.run: the history, the impact table against the impact law's closed forms, the energy
books, and the beam."""

import warnings

import numpy as np
import pytest

import vibrobar
from vibrobar import Scenario


def test_history_columns_and_sampling():
    r = vibrobar.run(duration_s=0.1, sample_every=5)
    dt = Scenario.paper().to_dict()["run"]["dt_s"]
    assert list(r.history) == ["t_s", "u_m", "du_m_s", "v_m", "dv_m_s", "w_m", "dw_m_s"]
    assert r.history.rows == round(0.1 / (5 * dt)) + 1
    assert np.allclose(np.diff(r.t_s), 5 * dt, rtol=1e-9, atol=0)
    # w is the ball relative to the cavity: v − u, never beyond the half gap by more than the
    # solver's rounding.
    assert np.allclose(r.w_m, r.v_m - r.u_m, atol=1e-18)
    assert np.abs(r.w_m).max() <= 0.5e-4 * (1 + 1e-9)
    assert np.isfinite(r.history.to_pandas().to_numpy()).all()


def test_impact_table_obeys_the_impact_law():
    sc = Scenario.paper(duration_s=0.5)
    d = sc.to_dict()
    e = d["damper"]["restitution"]
    m, M = d["damper"]["ball_mass_kg"], d["bar"]["mass_kg"]
    r = vibrobar.run(sc)
    it = r.impact_table
    assert r.impacts == it.rows > 100 and not r.impact_table_truncated
    # Newton's law on the relative velocity: ẇ+ = −e·ẇ− (Eqs. 4–5).
    assert np.allclose(it["dw_after_m_s"], -e * it["dw_before_m_s"], rtol=1e-12, atol=1e-15)
    # The kinetic energy lost, ½·mM/(m+M)·(1 − e²)·ẇ−², a closed form independent of the solver.
    loss = 0.5 * m * M / (m + M) * (1 - e * e) * it["dw_before_m_s"] ** 2
    assert np.allclose(it["energy_loss_j"], loss, rtol=1e-12)
    # The ball hits the + wall moving outwards (ẇ− > 0), the − wall moving inwards.
    assert set(np.unique(it["wall"])) == {-1, 1}
    assert (np.sign(it["dw_before_m_s"]) == it["wall"]).all()
    assert (np.diff(it["t_s"]) > 0).all()
    # The books: the impacts' losses are the table's, and the balance closes (exact solver).
    assert r.energy["impact_loss_j"] == pytest.approx(it["energy_loss_j"].sum(), rel=1e-12)
    assert abs(r.energy["residual_j"]) < 1e-9 * r.energy["work_input_j"]
    assert r.max_penetration_m < 1e-15
    assert 0 < r.rms_m < 1e-3 and r.solver == "exact"


def test_no_ball_contact_means_no_impacts():
    # A 1 mm gap at 0.98: the paper's no-impact regime.
    r = vibrobar.run(duration_s=0.3, gap_m=1e-3, frequency_ratio=0.98)
    assert r.impacts == 0 and r.impact_table.rows == 0
    assert r.energy["impact_loss_j"] == 0.0


def test_beam_runs_with_rk4():
    b = Scenario.paper_beam(modes=2, solver="rk4", duration_s=0.05)
    r = vibrobar.run(b)
    assert r.solver == "rk4" and r.history.rows > 0 and r.rms_m > 0
    assert np.isfinite(r.u_m).all()


def test_beam_with_the_exact_solver():
    b = Scenario.paper_beam(modes=2, duration_s=0.05)
    r = vibrobar.run(b)
    assert r.solver == "exact" and r.impacts > 0 and r.rms_m > 0
    # The modal books close to rounding (forcing − viscous − impacts + friction = ΔE).
    assert abs(r.energy["residual_j"]) < 1e-9 * r.energy["work_input_j"]
    assert r.max_penetration_m <= 1e-12


def test_beam_with_the_hertz_contact_law():
    # Issue #9 on the beam: the compliant contact runs in the N-mode exact solver; its releases
    # are the impacts (the loss is the contact's damping work), the books close to the contact
    # phase's integrator tolerance, and the ball sinks micrometres into the wall.
    b = Scenario.paper_beam(modes=3, duration_s=0.05, contact=dict(law="hertz"))
    with warnings.catch_warnings():
        # The penetration is the contact's compression, not an rk4-style overshoot: no warning.
        warnings.simplefilter("error")
        r = vibrobar.run(b)
    assert r.solver == "exact" and r.impacts > 10
    assert (r.impact_table["energy_loss_j"] > 0).all()
    assert abs(r.energy["residual_j"]) < 1e-7 * r.energy["work_input_j"]
    assert 1e-7 < r.max_penetration_m < 1e-5
    rest = vibrobar.run(Scenario.paper_beam(modes=3, duration_s=0.05))
    assert r.rms_m != rest.rms_m


def test_bad_run_arguments():
    with pytest.raises(ValueError, match=r"sample_every = 0 is outside the allowed range \[1, ∞\)"):
        vibrobar.run(sample_every=0)
    with pytest.raises(TypeError, match="sample_every must be an int"):
        vibrobar.run(sample_every=2.5)
    with pytest.raises(ValueError, match="rows"):
        vibrobar.run(duration_s=100.0, sample_every=1)
