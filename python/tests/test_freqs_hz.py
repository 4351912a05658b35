"""Sweeps and maps in absolute frequencies (``freqs_hz=``): both bars at the same Ω, the same rows
as the CLI's ``--freqs-hz``, bit for bit, on the paper preset (damped and solid bars of different
ω₁); ``ratios`` and ``freqs_hz`` are exclusive."""

import numpy as np
import pytest

import vibrobar

# The CLI's START:STOP:STEP lines are start + i·step.
FREQS = "590:600:5"
FREQS_HZ = 590.0 + np.arange(3) * 5.0
SC = dict(solver="rk4", friction="none", duration_s=0.05)
FLAGS = ["--preset", "paper", "--solver", "rk4", "--friction", "none", "--duration", "0.05"]


def bits(text_column, floats):
    return [float(x).hex() for x in text_column] == [x.hex() for x in floats]


def test_sweep_in_hz_is_the_cli_sweep_bit_for_bit(cli, tmp_path):
    out = tmp_path / "s.csv"
    cli("sweep", *FLAGS, "--freqs-hz", FREQS, "--gap-mm", "0.1", "--out", out)
    text = out.read_text()
    py = vibrobar.sweep(vibrobar.Scenario.paper(**SC), freqs_hz=FREQS_HZ, gaps_m=[0.1 * 1e-3])
    assert py.to_csv() == text
    lines = text.splitlines()
    header = lines[0].split(",")
    rows = [l.split(",") for l in lines[1:]]
    assert py.rows == len(rows) == 3
    for col in ["rms_solid_m", "rms_damped_m"]:
        j = header.index(col)
        assert bits([r[j] for r in rows], py[col].tolist()), col
    # Not the sweep in ratios of the same damped ratios: the solid bar ran at its own Ω/ω₁.
    by_ratio = vibrobar.sweep(vibrobar.Scenario.paper(**SC), ratios=py["ratio"], gaps_m=[1e-4])
    assert not np.array_equal(by_ratio["rms_solid_m"], py["rms_solid_m"])


def test_map_in_hz_is_the_cli_map(cli, tmp_path):
    out = tmp_path / "m.csv"
    cli("map", *FLAGS, "--freqs-hz", FREQS, "--gaps-mm", "0.1:0.2:0.1", "--out", out)
    gaps_m = (0.1 + np.arange(2) * 0.1) * 1e-3
    py = vibrobar.map(vibrobar.Scenario.paper(**SC), freqs_hz=FREQS_HZ, gaps_m=gaps_m)
    assert py.to_csv() == out.read_text()
    lines = out.read_text().splitlines()
    header = lines[0].split(",")
    rows = [l.split(",") for l in lines[1:]]
    for col in ["rms_solid_m", "rms_damped_m"]:
        j = header.index(col)
        assert bits([r[j] for r in rows], py[col].tolist()), col
    # The solid RMS of each frequency is the sweep's at that frequency.
    s = vibrobar.sweep(vibrobar.Scenario.paper(**SC), freqs_hz=FREQS_HZ, gaps_m=[1e-4])
    assert np.array_equal(py["rms_solid_m"][::2], s["rms_solid_m"])


def test_ratios_and_freqs_hz_are_exclusive():
    sc = vibrobar.Scenario.paper(**SC)
    for fn in (vibrobar.sweep, vibrobar.map):
        with pytest.raises(ValueError, match="ratios and freqs_hz"):
            fn(sc, ratios=[1.0], gaps_m=[1e-4], freqs_hz=[600.0])
    with pytest.raises(TypeError, match="ratios is required, or freqs_hz"):
        vibrobar.map(sc, gaps_m=[1e-4])
    for bad in ([-600.0], [0.0], [2e7], [np.nan]):
        for fn in (vibrobar.sweep, vibrobar.map):
            with pytest.raises(ValueError, match=r"freqs_hz\[0\] = .* \(0, 1e7\] Hz"):
                fn(sc, freqs_hz=bad, gaps_m=[1e-4])
    with pytest.raises(ValueError, match="freqs_hz is empty"):
        vibrobar.map(sc, freqs_hz=[], gaps_m=[1e-4])
    with pytest.raises(ValueError, match="freqs_hz.*distinct"):
        vibrobar.map(sc, freqs_hz=[600.0, 600.0], gaps_m=[1e-4])
