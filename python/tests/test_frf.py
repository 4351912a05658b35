"""FRFs of every model from Python (``vibrobar.frf``): the command line's rows character for
character, the linear receptance's closed form at resonance, the stepped sine and the tap test
of a bar whose ball never reaches a wall against the ball-free receptance, and the errors."""

import numpy as np
import pytest

import vibrobar

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


@pytest.mark.parametrize("text", ["", MODES, "[beam]\nmodes = 3\n"])
def test_frf_rows_are_the_cli_rows(cli, tmp_path, text):
    sc_path = tmp_path / "s.toml"
    sc_path.write_text(text)
    out = tmp_path / "f.csv"
    cli("frf", "--scenario", sc_path, "--band-hz", "100:4000:7.5", "--to", "cavity",
        "--no-figure", "--out", out)
    py = vibrobar.frf(vibrobar.Scenario.from_toml(sc_path), (100, 4000, 7.5), to_point="cavity")
    assert py.to_csv() == out.read_text()
    assert list(py.keys()) == out.read_text().splitlines()[0].split(",")
    assert py.rows == 521
    # The same lines given as an array give the same numbers.
    again = vibrobar.frf(vibrobar.Scenario.from_toml(sc_path),
                         frequencies_hz=py["frequency_hz"], to_point="cavity")
    assert again.to_csv() == py.to_csv()


def test_one_mode_receptance_at_resonance_is_minus_i_over_2_zeta_k():
    sc = vibrobar.Scenario.paper()
    m, k, zeta = 0.668, 9.26e6, 0.01  # the paper's solid bar
    f = np.sqrt(k / m) / (2 * np.pi)
    t = vibrobar.frf(sc, frequencies_hz=[f], curves=["solid"])
    g = complex(t["solid_re_m_per_n"][0], t["solid_im_m_per_n"][0])
    assert abs(g - (-1j / (2 * zeta * k))) < 1e-12 * abs(g)
    assert t["solid_phase_deg"][0] == pytest.approx(-90.0, abs=1e-9)


def test_soft_stepped_sine_and_tap_are_the_ball_free_receptance():
    sc = vibrobar.Scenario.paper(gap_m=1e-4)
    calls = []
    t = vibrobar.frf(sc, (560, 640, 20), curves=["ball_free", "stepped_sine", "tap"],
                     force_n=0.5, tap_force_n=1.0, taps=2, progress=lambda d, n: calls.append(d))
    g = t["ball_free_re_m_per_n"] + 1j * t["ball_free_im_m_per_n"]
    h = t["stepped_sine_re_m_per_n"] + 1j * t["stepped_sine_im_m_per_n"]
    h1 = t["tap_re_m_per_n"] + 1j * t["tap_im_m_per_n"]
    assert np.all(np.abs(h - g) < 1e-9 * np.abs(g))
    assert np.all(np.abs(h1 - g) < 1e-6 * np.abs(g))
    assert np.all(t["stepped_sine_impacts_per_cycle"] == 0)
    assert np.all(np.abs(t["tap_coherence"] - 1) < 1e-9)
    np.testing.assert_allclose(t["stepped_sine_rms_m"], np.abs(g) * 0.5 / np.sqrt(2), rtol=1e-9)
    assert calls


def test_a_hard_tap_on_a_bar_with_a_ball_differs_from_a_soft_one():
    sc = vibrobar.Scenario.paper(gap_m=1e-4)
    f1 = np.sqrt(9.22e6 / 0.644) / (2 * np.pi)
    soft = vibrobar.frf(sc, frequencies_hz=[f1], curves=["ball_free", "tap"], tap_force_n=1.0, taps=3)
    hard = vibrobar.frf(sc, frequencies_hz=[f1], curves=["tap"], tap_force_n=2000.0, taps=3)
    assert hard["tap_mag_m_per_n"][0] < 0.9 * soft["tap_mag_m_per_n"][0]
    assert soft["tap_mag_m_per_n"][0] == pytest.approx(soft["ball_free_mag_m_per_n"][0], rel=1e-6)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(band_hz=(500, 400, 1)), "band_hz.*STOP"),
        (dict(band_hz=(0, 400, 1)), "band_hz.*START"),
        (dict(band_hz=(100, 400, 0)), "band_hz.*STEP"),
        (dict(band_hz=(100, 400)), "band_hz must be"),
        (dict(band_hz=(1, 1e6, 1e-3)), "band_hz.*100000"),
        (dict(frequencies_hz=[500.0, -1.0]), "frequencies_hz"),
        (dict(frequencies_hz=[float("nan")]), "frequencies_hz"),
        (dict(frequencies_hz=[]), "frequencies_hz"),
        (dict(), "band_hz"),
        (dict(band_hz=(500, 600, 50), frequencies_hz=[500.0]), "one of the two"),
        (dict(band_hz=(500, 600, 50), curves=["wobble"]), "wobble"),
        (dict(band_hz=(500, 600, 50), curves=[]), "curves is empty"),
        (dict(band_hz=(500, 600, 50), to_point="tip"), "to_point"),
        (dict(band_hz=(500, 600, 50), curves=["tap"], from_point="cavity"), "from_point"),
        (dict(band_hz=(500, 600, 50), curves=["tap"], to_point="force"), "to_point"),
        (dict(band_hz=(500, 600, 50), curves=["tap"], taps=0), "taps"),
        (dict(band_hz=(500, 600, 50), curves=["tap"], sample_rate_hz=100.0), "sample rate"),
        (dict(band_hz=(500, 600, 50), curves=["tap"], tap_duration_s=float("nan")), "pulse duration"),
        (dict(band_hz=(500, 600, 50), curves=["stepped_sine"], force_n=0.0), "force amplitude"),
        (dict(band_hz=(500, 600, 50), curves=["stepped_sine"], measure_periods=0), "measure periods"),
        (dict(band_hz=(500, 600, 50), curves=["stepped_sine"], settle_s=-1.0), "settle time"),
    ],
)
def test_frf_bad_input_is_refused_naming_the_argument(kwargs, match):
    with pytest.raises(ValueError, match=match):
        vibrobar.frf(vibrobar.Scenario.paper(), **kwargs)


def test_frf_argument_types_are_checked():
    with pytest.raises(TypeError, match="taps must be an int"):
        vibrobar.frf(vibrobar.Scenario.paper(), (500, 600, 50), curves=["tap"], taps=2.5)
    with pytest.raises(TypeError, match="band_hz must be a number"):
        vibrobar.frf(vibrobar.Scenario.paper(), (500, "x", 50))
