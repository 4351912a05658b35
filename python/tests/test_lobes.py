"""Issue #13: the stability lobes and measured modes ([[modes]]) from Python give the command
line's rows, character for character, and its errors."""

import numpy as np
import pytest

import vibrobar

CUT = """
[cutting]
coefficient_n_m2 = 2e9
width_m = 1e-3
feed_m = 1e-4
spindle_rpm = 5000
chip_direction_factor = 0.95
"""
MODES = """
[[modes]]
frequency_hz = 600
damping_ratio = 0.01
modal_mass_kg = 0.155
shape_cavity = 0.9
[[modes]]
frequency_hz = 3760
damping_ratio = 0.015
modal_mass_kg = 0.155
shape_cavity = -0.4
"""


@pytest.mark.parametrize("text", [CUT, MODES + CUT, "[beam]\nmodes = 3\n" + CUT])
def test_lobes_rows_are_the_cli_rows(cli, tmp_path, text):
    sc_path = tmp_path / "s.toml"
    sc_path.write_text(text)
    out = tmp_path / "l.csv"
    cli("lobes", "--scenario", sc_path, "--rpm", "1500:45000:250", "--no-figure", "--out", out)
    py = vibrobar.lobes(vibrobar.Scenario.from_toml(sc_path), 1500, 45000, 250)
    assert py.to_csv() == out.read_text()
    lines = out.read_text().splitlines()
    header = lines[0].split(",")
    assert list(py.keys()) == header
    assert header[:6] == ["spindle_rpm", "b_lim_m", "chatter_frequency_hz", "b_lim_ball_stuck_m",
                          "chatter_frequency_ball_stuck_hz", "b_lim_solid_m"]
    j = header.index("b_lim_m")
    assert [float(l.split(",")[j]).hex() for l in lines[1:]] == [x.hex() for x in py["b_lim_m"].tolist()]
    assert py.rows == 175
    assert np.all(py["b_lim_m"] > 0) and np.all(np.isfinite(py["b_lim_ball_stuck_m"]))


def test_measured_modes_run_from_python_and_keep_their_reference():
    sc = vibrobar.Scenario.from_toml_str(MODES, duration_s=0.05)
    assert "no_ball" in sc.to_toml()
    assert "[bar]" not in sc.to_toml()
    r = vibrobar.run(sc)
    assert r.rms_m > 0
    with pytest.raises(ValueError, match=r"modes\[0\]\.damping_ratio = 1 is outside the allowed range \[0, 1\)"):
        vibrobar.Scenario.from_toml_str(MODES.replace("0.01", "1.0", 1))
    with pytest.raises(ValueError, match=r"\[\[modes\]\] and \[bar\] both describe the bar"):
        vibrobar.Scenario.from_toml_str(MODES + "[bar]\nmass_kg = 1\n")


def test_lobes_bad_input_says_what_and_the_range():
    with pytest.raises(ValueError, match=r"\[cutting\]"):
        vibrobar.lobes(vibrobar.Scenario.paper(), 1000, 2000, 100)
    sc = vibrobar.Scenario.from_toml_str(CUT)
    with pytest.raises(ValueError, match=r"rpm STOP = 300000 rpm is outside the allowed range \[1, 200000\]"):
        vibrobar.lobes(sc, 1000, 300000, 1000)
    with pytest.raises(ValueError, match="range is empty"):
        vibrobar.lobes(sc, 2000, 1000, 100)
    with pytest.raises(ValueError, match="finite"):
        vibrobar.lobes(sc, 1000, float("nan"), 100)
