"""Measured FRFs in and out: pyuff reads our universal files and we read pyuff's, bit for bit in
binary (58b) and to the 12 significant digits of ASCII 58; bad files raise with their name."""

import os

import numpy as np
import pytest

import vibrobar

if os.environ.get("VIBROBAR_REQUIRE_EXTRAS"):
    import pyuff  # scripts/test-python.sh installs it from PyPI: a skip would hide the check
else:
    pyuff = pytest.importorskip("pyuff", reason="the cross-checks read and write with pyuff")


def three_modes(freqs):
    w = 2 * np.pi * freqs
    g = np.zeros_like(w, dtype=complex)
    for m, fn, z in [(0.25, 620.0, 0.02), (0.4, 1830.0, 0.02), (0.9, 4100.0, 0.03)]:
        wn = 2 * np.pi * fn
        g += 1 / (m * (wn**2 - w**2 + 2j * z * wn * w))
    # A ripple, so that every bit of the mantissa matters.
    return g * (1 + 1e-3 * np.sin(0.7 * np.arange(len(w))))


FREQS = 2.0 * np.arange(1, 6001)


def sets_58(path):
    sets = pyuff.UFF(str(path)).read_sets()
    sets = sets if isinstance(sets, list) else [sets]
    return [s for s in sets if s["type"] == 58]


@pytest.mark.parametrize("binary", [True, False])
def test_pyuff_reads_our_files(tmp_path, binary):
    g = three_modes(FREQS)
    coh = 0.5 + 0.5 * np.abs(np.cos(0.3 * np.arange(len(FREQS))))
    p = tmp_path / "ours.uff"
    vibrobar.write_uff58(p, FREQS, g, coherence=coh, binary=binary)
    frf, c = sets_58(p)
    assert frf["func_type"] == 4 and c["func_type"] == 6
    assert np.array_equal(frf["x"], FREQS)
    if binary:
        assert np.array_equal(frf["data"].view(np.float64), g.view(np.float64))
        assert np.array_equal(c["data"], coh)
    else:
        twelve = np.array([float("%.11e" % v) for v in g.view(np.float64)])
        assert np.array_equal(frf["data"].view(np.float64), twelve)
        assert np.allclose(frf["data"], g, rtol=1e-11, atol=0)


@pytest.mark.parametrize("binary", [1, 0])
def test_we_read_pyuffs_files(tmp_path, binary):
    g = three_modes(FREQS)
    p = tmp_path / "pyuff.uff"
    d = pyuff.prepare_58(
        binary=binary,
        func_type=4,
        rsp_node=1,
        rsp_dir=3,
        ref_node=1,
        ref_dir=3,
        rsp_ent_name="bar",
        ref_ent_name="bar",
        abscissa_spacing=1,
        abscissa_spec_data_type=18,
        ordinate_spec_data_type=8,
        orddenom_spec_data_type=13,
        data=g,
        x=FREQS,
        id1="tap test",
    )
    # mode="overwrite" with binary=1 leaves a 7-byte file: add to a new file instead.
    pyuff.UFF(str(p)).write_sets(d, mode="add")
    r = vibrobar.read_frf(p)
    assert r["format"] == ("uff58b" if binary else "uff58")
    assert r["kind"] == "receptance" and r["driving_point"]
    assert np.array_equal(r["freqs_hz"], FREQS)
    if binary:
        assert np.array_equal(r["values"].view(np.float64), g.view(np.float64))
    else:
        twelve = np.array([float("%.11e" % v) for v in g.view(np.float64)])
        assert np.array_equal(r["values"].view(np.float64), twelve)
    assert any("SI assumed" in n for n in r["notes"])


def test_bad_files_name_file_and_line(tmp_path):
    p = tmp_path / "bad.uff"
    p.write_text("not a universal file\n")
    with pytest.raises(ValueError, match=r"bad\.uff.*line 1.*not a universal file"):
        vibrobar.read_frf(p)
    g = np.conj(three_modes(FREQS))
    q = tmp_path / "conj.uff"
    vibrobar.write_uff58(q, FREQS, g)
    with pytest.raises(ValueError, match="passivity"):
        vibrobar.read_frf(q)
    assert vibrobar.read_frf(q, conjugate=True)["kind"] == "receptance"

