"""Width diagrams and time-domain lobes (issue #14) from Python: the same rows as the CLI's,
bit for bit, and bad input named."""

import pytest

import vibrobar


def test_width_diagram_is_the_cli_diagram(cli, tmp_path, time_domain_toml):
    path = tmp_path / "s.toml"
    path.write_text(time_domain_toml)
    out = tmp_path / "d.csv"
    cli("width-diagram", "--scenario", path, "--rpm", 5000, "--widths-mm", "0.02:0.06:0.04",
        "--no-figure", "--out", out)
    sc = vibrobar.Scenario.from_toml_str(time_domain_toml)
    t = vibrobar.width_diagram(sc, 5000.0, [2e-5, 6e-5])
    assert t.to_csv() == out.read_text()


def test_time_domain_lobes_are_the_cli_lobes(cli, tmp_path, time_domain_toml):
    path = tmp_path / "s.toml"
    path.write_text(time_domain_toml)
    out = tmp_path / "t.csv"
    cli("lobes", "--time-domain", "--scenario", path, "--rpm", "5000:6000:1000", "--no-figure",
        "--out", out)
    t = vibrobar.time_domain_lobes(vibrobar.Scenario.from_toml_str(time_domain_toml),
                                   [5000.0, 6000.0])
    assert t.to_csv() == out.read_text()


def test_bad_input_is_named(time_domain_toml):
    sc = vibrobar.Scenario.from_toml_str(time_domain_toml)
    with pytest.raises(ValueError, match="widths_m"):
        vibrobar.width_diagram(sc, 5000.0, [-1e-5])
    with pytest.raises(ValueError, match="spindle_rpm"):
        vibrobar.time_domain_lobes(sc, [0.5])
    bad = vibrobar.Scenario.from_toml_str(
        time_domain_toml.replace("judge_revs = 20", "judge_revs = 2"))
    with pytest.raises(ValueError, match="time_domain.judge_revs"):
        vibrobar.time_domain_lobes(bad, [5000.0])
