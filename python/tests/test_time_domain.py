"""Width diagrams and time-domain lobes (issue #14) from Python: the same rows as the CLI's,
bit for bit, and bad input named."""

import pytest

import vibrobar

SC = """
[bar]
mass_kg = 0.1548
stiffness_n_per_m = 2.2e6
damping_ratio = 0.01

[solid_bar]
mass_kg = 0.1548
stiffness_n_per_m = 2.2e6
damping_ratio = 0.01

[damper]
gap_m = 1e-4
ball_mass_kg = 0.026

[cutting]
coefficient_n_m2 = 2e9
width_m = 1e-5
feed_m = 1e-4
spindle_rpm = 5000

[time_domain]
settle_revs = 10
judge_revs = 20
monotonic_checks = 2
"""


def test_width_diagram_is_the_cli_diagram(cli, tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(SC)
    out = tmp_path / "d.csv"
    cli("width-diagram", "--scenario", path, "--rpm", 5000, "--widths-mm", "0.02:0.06:0.04",
        "--no-figure", "--out", out)
    t = vibrobar.width_diagram(vibrobar.Scenario.from_toml_str(SC), 5000.0, [2e-5, 6e-5])
    assert t.to_csv() == out.read_text()


def test_time_domain_lobes_are_the_cli_lobes(cli, tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(SC)
    out = tmp_path / "t.csv"
    cli("lobes", "--time-domain", "--scenario", path, "--rpm", "5000:6000:1000", "--no-figure",
        "--out", out)
    t = vibrobar.time_domain_lobes(vibrobar.Scenario.from_toml_str(SC), [5000.0, 6000.0])
    assert t.to_csv() == out.read_text()


def test_bad_input_is_named():
    sc = vibrobar.Scenario.from_toml_str(SC)
    with pytest.raises(ValueError, match="widths_m"):
        vibrobar.width_diagram(sc, 5000.0, [-1e-5])
    with pytest.raises(ValueError, match="spindle_rpm"):
        vibrobar.time_domain_lobes(sc, [0.5])
    bad = vibrobar.Scenario.from_toml_str(SC.replace("judge_revs = 20", "judge_revs = 2"))
    with pytest.raises(ValueError, match="time_domain.judge_revs"):
        vibrobar.time_domain_lobes(bad, [5000.0])
