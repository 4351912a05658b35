"""Python and the command line give the same numbers, bit for bit: the same sweep rows (the CSV
text, and every RMS as the same double), the same map rows, the same run history."""

import numpy as np
import pytest

import vibrobar

SWEEP_CASES = [
    # (CLI flags, the same as scenario overrides)
    (["--duration", "0.3"], dict(duration_s=0.3)),
    (
        ["--solver", "rk4", "--friction", "coulomb", "--duration", "0.05", "--gap-mm", "0.1"],
        dict(solver="rk4", friction="coulomb", duration_s=0.05),
    ),
]


@pytest.mark.parametrize("flags, overrides", SWEEP_CASES)
def test_sweep_rows_are_the_cli_rows_bit_for_bit(cli, tmp_path, flags, overrides):
    out = tmp_path / "sweep.csv"
    cli("sweep", *flags, "--out", out)
    cli_text = out.read_text()
    gaps = [0.1 * 1e-3] if "--gap-mm" in flags else None  # the CLI's own mm → m conversion
    py = vibrobar.sweep(vibrobar.Scenario.paper(**overrides), gaps_m=gaps)
    assert py.to_csv() == cli_text
    lines = cli_text.splitlines()
    header = lines[0].split(",")
    assert list(py.keys()) == header
    rows = [l.split(",") for l in lines[1:]]
    assert py.rows == len(rows) > 0
    for col in ["rms_solid_m", "rms_damped_m"]:
        j = header.index(col)
        # Shortest round-trip text: parsing it gives back the very double.
        assert [float(r[j]).hex() for r in rows] == [x.hex() for x in py[col].tolist()]
    j = header.index("impacts")
    assert [int(r[j]) for r in rows] == py["impacts"].tolist()
    assert any(py["impacts"] > 0), "the comparison must include impacting points"


def test_map_rows_are_the_cli_rows(cli, tmp_path):
    out = tmp_path / "map.csv"
    cli("map", "--ratios", "0.98:1.02:0.02", "--gaps-mm", "0.1:0.5:0.4", "--restitutions", "0.5:0.7:0.2",
        "--friction", "none", "--duration", "0.2", "--out", out)
    # The CLI's grid: start + i·step, and mm · 1e-3.
    ratios = 0.98 + np.arange(3) * 0.02
    gaps_m = (0.1 + np.arange(2) * 0.4) * 1e-3
    rest = 0.5 + np.arange(2) * 0.2
    py = vibrobar.map(vibrobar.Scenario.paper(duration_s=0.2), ratios, gaps_m, restitutions=rest)
    cli_lines = out.read_text().splitlines()
    py_lines = py.to_csv().splitlines()
    assert py_lines[0] == cli_lines[0]
    assert sorted(py_lines[1:]) == sorted(cli_lines[1:])
    assert py.rows == 12
    assert any(py["impacts_per_cycle"] > 0), "the comparison must include impacting points"


def test_run_history_is_the_cli_history(cli, tmp_path):
    out = tmp_path / "run.npy"
    cli("run", "--duration", "0.2", "--out", out)
    h = np.load(out)
    r = vibrobar.run(duration_s=0.2)
    cols = ["t_s", "u_m", "du_m_s", "v_m", "dv_m_s", "w_m", "dw_m_s"]
    assert list(r.history.keys()) == cols
    assert h.shape == (r.history.rows, 7)
    for j, c in enumerate(cols):
        assert np.array_equal(h[:, j], r.history[c]), c
        assert np.array_equal(getattr(r, c), r.history[c])
    assert r.impacts > 0
