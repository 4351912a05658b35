"""Design by time-domain lobes (issue #14 §3) from Python: the same rows as `vibrobar
lobe-design`, character for character, the optimum the row of the largest worst case, and bad
input named."""

import numpy as np
import pytest

import vibrobar


def test_lobe_design_is_the_cli_study(cli, tmp_path, time_domain_toml):
    path = tmp_path / "s.toml"
    path.write_text(time_domain_toml)
    out = tmp_path / "d.csv"
    cli("lobe-design", "--scenario", path, "--rpm", "5000:7000:2000", "--gaps-mm",
        "0.05:0.2:0.15", "--ball-masses-g", "10:30:20", "--no-figure", "--out", out)
    t = vibrobar.lobe_design(vibrobar.Scenario.from_toml_str(time_domain_toml), [5000.0, 7000.0],
                             [5e-5, 2e-4], ball_masses_kg=[0.01, 0.03])
    assert t.to_csv() == out.read_text()
    # The regime at each worst case, and the chaotic spread columns (issue #14).
    lines = t.to_csv().splitlines()
    assert lines[0].endswith(
        ",worst_regime,spread_min_width_m,spread_mean_width_m,spread_max_width_m")
    for line in lines[1:]:
        f = line.split(",")
        assert f[14] != "" and (f[15] != "") == (f[14] == "chaotic")
    best = int(np.argmax(t["worst_width_m"]))
    optimum = (tmp_path / "d.optimum.csv").read_text().splitlines()[1]
    assert t.to_csv().splitlines()[1 + best] == optimum


def test_bad_input_is_named(time_domain_toml):
    sc = vibrobar.Scenario.from_toml_str(time_domain_toml)
    with pytest.raises(ValueError, match="gaps_m"):
        vibrobar.lobe_design(sc, [5000.0], [-1e-4], ball_masses_kg=[0.01])
    with pytest.raises(ValueError, match="ball_masses_kg"):
        vibrobar.lobe_design(sc, [5000.0], [1e-4], ball_masses_kg=[0.0])
    with pytest.raises(ValueError, match="spindle_rpm"):
        vibrobar.lobe_design(sc, [0.5], [1e-4], ball_masses_kg=[0.01])
    with pytest.raises(ValueError, match="exactly one"):
        vibrobar.lobe_design(sc, [5000.0], [1e-4])
    with pytest.raises(ValueError, match=r"\[beam\]"):
        vibrobar.lobe_design(sc, [5000.0], [1e-4], positions_m=[0.1])
