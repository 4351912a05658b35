"""The cutting process (issue #13) from Python: a scenario with [cutting] runs, with the same
numbers as `vibrobar run` (bit for bit), the cutting columns and the cutting work in the books;
commands that cannot use the cut refuse it by name."""

import numpy as np
import pytest

import vibrobar

CUT = """
[bar]
mass_kg = 0.1548
stiffness_n_per_m = 2.2e6
damping_ratio = 0.01

[damper]
gap_m = 2e-5
ball_mass_kg = 0.01

[cutting]
coefficient_n_m2 = 2e9
width_m = 5e-4
feed_m = 1e-4
spindle_rpm = 30000

[initial]
u_m = 5e-6

[run]
duration_s = 0.1
dt_s = 1e-5
"""

COLS = ["t_s", "u_m", "du_m_s", "v_m", "dv_m_s", "w_m", "dw_m_s", "chip_thickness_m", "in_cut", "cutting_force_n"]


def test_cutting_run_is_the_cli_run(cli, tmp_path):
    path = tmp_path / "cut.toml"
    path.write_text(CUT)
    out = tmp_path / "run.npy"
    cli("run", "--scenario", path, "--sample-every", "1", "--out", out)
    h = np.load(out)
    r = vibrobar.run(vibrobar.Scenario.from_toml_str(CUT), sample_every=1)
    assert list(r.history.keys()) == COLS
    assert h.shape == (r.history.rows, len(COLS))
    for j, c in enumerate(COLS):
        assert np.array_equal(h[:, j], np.asarray(r.history[c], dtype=float)), c
    # The chatter grew until the tool left the cut, and the ball hit the walls.
    assert r.impacts > 0
    assert set(np.unique(r.in_cut)) == {0, 1}
    assert np.all(r.cutting_force_n[r.in_cut == 0] == 0.0)
    assert np.all(r.chip_thickness_m[r.in_cut == 1] > 0.0)
    e = r.energy
    assert e["cutting_work_j"] > 0.0
    scale = sum(abs(e[k]) for k in ["viscous_loss_j", "impact_loss_j", "cutting_work_j"])
    assert abs(e["residual_j"]) < 1e-9 * scale
    # The CSV names the same columns.
    out_csv = tmp_path / "run.csv"
    cli("run", "--scenario", path, "--out", out_csv)
    assert out_csv.read_text().splitlines()[0] == ",".join(COLS)


def test_cutting_overrides_and_refusals():
    sc = vibrobar.Scenario.from_toml_str(CUT)
    wider = sc.replace(width_m=6e-4, spindle_rpm=31000)
    assert "width_m = 0.0006" in wider.to_toml() and "spindle_rpm = 31000" in wider.to_toml()
    with pytest.raises(ValueError, match=r"cutting\.width_m"):
        sc.replace(width_m=-1.0)
    with pytest.raises(ValueError, match=r"cutting\.spindle_rpm"):
        sc.replace(spindle_rpm=0.5)
    with pytest.raises(ValueError, match=r"\[cutting\]"):
        sc.replace(solver="rk4")
    with pytest.raises(ValueError, match=r"sweep does not support the \[cutting\] section"):
        vibrobar.sweep(sc, ratios=[1.0], gaps_m=[2e-5])


MODES_CUT = """
[[modes]]
frequency_hz = 597.51
damping_ratio = 0.01
modal_mass_kg = 0.15637
shape_cavity = 0.70066

[[modes]]
frequency_hz = 1900.0
damping_ratio = 0.015
modal_mass_kg = 0.4
shape_cavity = -0.3

[damper]
gap_m = 2e-5
ball_mass_kg = 0.01

[cutting]
coefficient_n_m2 = 2e9
width_m = 3e-4
feed_m = 1e-4
spindle_rpm = 20000

[initial]
u_m = 1.5e-4

[run]
duration_s = 0.05
dt_s = 1e-5
"""

BEAM_CUT = """
[beam]
modes = 3

[damper]
gap_m = 2e-5

[cutting]
coefficient_n_m2 = 2e9
width_m = 5e-4
feed_m = 1e-4
spindle_rpm = 20000

[initial]
u_m = 1.5e-4

[run]
duration_s = 0.02
dt_s = 1e-5
"""


def three_quarter(text):
    """The scenario with the three-quarter force law."""
    return text.replace("spindle_rpm = 20000", 'spindle_rpm = 20000\nforce_law = "three-quarter"')


@pytest.mark.parametrize(
    "text",
    [MODES_CUT, BEAM_CUT, three_quarter(MODES_CUT), three_quarter(BEAM_CUT)],
    ids=["modes", "beam", "modes-three-quarter", "beam-three-quarter"],
)
def test_modal_cutting_run_is_the_cli_run(cli, tmp_path, text):
    """A cutting run on a modal bar ([[modes]], [beam]; issue #13), with both force laws: the
    same numbers as `vibrobar run`, bit for bit, with the cutting columns; the tool leaves the
    cut, the ball hits the walls and the books close with the cutting work."""
    path = tmp_path / "cut.toml"
    path.write_text(text)
    out = tmp_path / "run.npy"
    cli("run", "--scenario", path, "--sample-every", "1", "--out", out)
    h = np.load(out)
    r = vibrobar.run(vibrobar.Scenario.from_toml_str(text), sample_every=1)
    assert list(r.history.keys()) == COLS
    assert h.shape == (r.history.rows, len(COLS))
    for j, c in enumerate(COLS):
        assert np.array_equal(h[:, j], np.asarray(r.history[c], dtype=float)), c
    assert r.impacts > 0
    assert set(np.unique(r.in_cut)) == {0, 1}
    assert np.all(r.cutting_force_n[r.in_cut == 0] == 0.0)
    e = r.energy
    scale = sum(abs(e[k]) for k in ["viscous_loss_j", "impact_loss_j", "cutting_work_j"])
    assert abs(e["residual_j"]) < 1e-9 * scale
