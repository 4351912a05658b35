"""The modal fit from Python: a known 3-mode FRF recovered, the stabilisation chart, bad input
refused naming the keyword, and the poles against sdypy-EMA's LSCF on the same clean data."""

import os

import numpy as np
import pytest

import vibrobar

# (frequency Hz, damping ratio, modal mass kg with the tip shape 1, cavity shape)
TRUE = [(597.51, 0.01, 0.15637, 0.70066), (3588.7, 0.012, 0.16333, -0.015423), (10057.0, 0.02, 0.17623, -0.55646)]
F = 2.0 * np.arange(1, 6001)


def receptance(cross=False):
    w = 2 * np.pi * F
    return sum(
        (s if cross else 1.0) / (m * (wn**2 - w**2 + 2j * z * wn * w))
        for (f, z, m, s) in TRUE
        for wn in [2 * np.pi * f]
    )


def test_clean_modes_are_recovered_with_the_cavity_shape():
    r = vibrobar.fit_modes(F, receptance(), cross=receptance(True))
    assert len(r.modes["frequency_hz"]) == 3
    for k, (f, z, m, s) in enumerate(TRUE):
        assert abs(r.modes["frequency_hz"][k] / f - 1) < 1e-6
        assert abs(r.modes["damping_ratio"][k] / z - 1) < 1e-6
        assert abs(r.modes["modal_mass_kg"][k] / m - 1) < 1e-6
        assert abs(r.modes["shape_cavity"][k] - s) < 1e-6
    assert r.fit_error < 1e-8
    assert r.chart["stable"].dtype == bool and r.chart["stable"].any()


def test_accelerance_is_fitted_in_its_own_form():
    w = 2 * np.pi * F
    r = vibrobar.fit_modes(F, -(w**2) * receptance(), form="accelerance")
    assert np.allclose(r.modes["modal_mass_kg"], [t[2] for t in TRUE], rtol=1e-6)
    assert np.isnan(r.modes["shape_cavity"]).all()


@pytest.mark.parametrize(
    "kwargs, needle",
    [
        (dict(form="velocity"), "form"),
        (dict(band_hz=(1.0, 5000.0)), "band_hz low end"),
        (dict(max_order=31), "max_order"),
        (dict(max_order=True), "max_order must be an int"),
        (dict(weights=np.full(F.size, 2.0)), "weights"),
        (dict(poles_hz=[2000.0]), "poles_hz"),
    ],
)
def test_bad_input_names_the_keyword(kwargs, needle):
    with pytest.raises((ValueError, TypeError), match=needle):
        vibrobar.fit_modes(F, receptance(), **kwargs)


def test_non_increasing_frequencies_are_refused():
    f = F.copy()
    f[5] = f[4]
    with pytest.raises(ValueError, match="strictly increasing"):
        vibrobar.fit_modes(f, receptance())


def test_poles_agree_with_sdypy_ema_on_clean_data():
    """sdypy-EMA's LSCF at its highest order, each true mode's nearest pole, against ours:
    within 1e-5 in frequency and 1e-4 in damping."""
    ema = _ema()
    a = ema.Model(frf=receptance()[None, :], freq=F, lower=2, upper=12000, pol_order_high=20, frf_form="receptance")
    a.get_poles(show_progress=False)
    fr, xi = ema.tools.complex_freq_to_freq_and_damp(a.all_poles[-1])
    ours = vibrobar.fit_modes(F, receptance())
    for k, (f, _z, _m, _s) in enumerate(TRUE):
        j = np.argmin(abs(fr - f))
        assert abs(fr[j] / ours.modes["frequency_hz"][k] - 1) < 1e-5
        assert abs(xi[j] / ours.modes["damping_ratio"][k] - 1) < 1e-4


def _ema():
    """sdypy-EMA: required where the test command installed it, else the test is skipped."""
    if os.environ.get("VIBROBAR_REQUIRE_EXTRAS") == "1":
        from sdypy import EMA

        return EMA
    return pytest.importorskip("sdypy.EMA")
