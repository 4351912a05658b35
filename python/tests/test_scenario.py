"""vibrobar.Scenario: presets, files, keyword overrides, TOML round trips, and every bad input
as a Python exception naming the field (and its allowed range, or the nearest valid name)."""

import math

import pytest

import vibrobar
from vibrobar import Scenario


def test_paper_is_the_shipped_scenario_file(root):
    assert Scenario.from_toml(root / "scenarios" / "paper.toml") == Scenario.paper()
    assert Scenario.from_toml(str(root / "scenarios" / "paper.toml")) == Scenario.paper()


def test_overrides_reach_their_section():
    s = Scenario.paper(gap_m=3e-4, friction="coulomb", solver="rk4", dt_s=2e-6)
    d = s.to_dict()
    assert d["damper"]["gap_m"] == 3e-4
    assert d["damper"]["friction"] == "coulomb"
    assert d["run"]["solver"] == "rk4" and s.solver == "rk4"
    assert d["run"]["dt_s"] == 2e-6
    # As in a file: a gap given without the sweep's gaps is the gap swept.
    assert d["sweep"]["gaps_m"] == [3e-4]
    assert Scenario.paper(gap_m=3e-4, gaps_m=[1e-3]).to_dict()["sweep"]["gaps_m"] == [1e-3]
    # One forcing frequency: ω replaces the ratio and the other way round.
    w = Scenario.paper(omega_rad_s=3000.0)
    assert w.to_dict()["forcing"] == {"amplitude_n": 15.0, "omega_rad_s": 3000.0, "static_force_n": 0.0}
    assert w.replace(frequency_ratio=1.0) == Scenario.paper()
    # Sections as dicts merge field by field; the paper's values stay elsewhere.
    b = Scenario.paper(bar=dict(mass_kg=0.7))
    assert b.to_dict()["bar"]["mass_kg"] == 0.7
    assert b.to_dict()["bar"]["stiffness_n_per_m"] == Scenario.paper().to_dict()["bar"]["stiffness_n_per_m"]
    # replace() leaves the original alone (scenarios are values).
    p = Scenario.paper()
    p.replace(gap_m=1e-3)
    assert p == Scenario.paper() and p.gap_m == 1e-4


def test_to_toml_reads_back_as_the_same_scenario():
    for s in [
        Scenario.paper(),
        Scenario.paper(friction="coulomb", friction_force_n=0.02, frequency_ratio=0.97, w_m=1e-5),
        Scenario.paper_beam(modes=3, cavity_position_m=0.1),
        Scenario.paper(omega_rad_s=3000.0),
    ]:
        assert Scenario.from_toml_str(s.to_toml()) == s
        assert eval(repr(s), {"Scenario": Scenario}) == s


def test_unknown_keywords_suggest_the_nearest_name():
    with pytest.raises(TypeError, match=r"unknown scenario keyword `gap`; did you mean `gap_m`"):
        Scenario.paper(gap=1e-4)
    with pytest.raises(TypeError, match=r"did you mean `restitution`"):
        Scenario.paper(restitutoin=0.4)
    with pytest.raises(ValueError, match=r"damper: unknown field `gap_mm`.*did you mean `gap_m`"):
        Scenario.paper(damper=dict(gap_mm=1.0))
    with pytest.raises(ValueError, match=r"beam: unknown field `lenght_m`.*did you mean `length_m`"):
        Scenario.paper_beam(beam=dict(lenght_m=0.2))
    # Unknown keywords of the functions go the same way (they are scenario overrides).
    with pytest.raises(TypeError, match=r"did you mean `duration_s`"):
        vibrobar.run(durration_s=0.01)
    with pytest.raises(TypeError, match=r"`mass_kg` is a field of several sections \(\[bar\], \[solid_bar\]\)"):
        Scenario.paper(mass_kg=1.0)


@pytest.mark.parametrize(
    "kw, field, allowed",
    [
        (dict(gap_m=-1e-4), "damper.gap_m", "(0, ∞)"),
        (dict(gap_m=math.nan), "damper.gap_m", "finite"),
        (dict(dt_s=0.0), "dt_s", "allowed range"),
        (dict(restitution=1.5), "restitution", "[0, 1]"),
        (dict(duration_s=math.inf), "duration_s", ""),
        (dict(rms_fraction=0.0), "rms_fraction", "allowed range"),
        (dict(solver="euler"), "run.solver", "rk4, exact"),
        (dict(friction="sticky"), "friction", "`coulomb`"),
        (dict(gravity_m_s2=-9.8), "gravity_m_s2", "(0, ∞)"),
    ],
)
def test_bad_values_raise_value_error_naming_field_and_range(kw, field, allowed):
    with pytest.raises(ValueError) as e:
        Scenario.paper(**kw)
    assert field in str(e.value) and allowed in str(e.value), str(e.value)


def test_wrong_types_raise_type_error_naming_the_keyword():
    with pytest.raises(TypeError, match=r"gap_m: invalid type: string"):
        Scenario.paper(gap_m="0.1 mm")
    with pytest.raises(TypeError, match=r"gap_m: expected a number, string, bool, list or dict"):
        Scenario.paper(gap_m=object())
    with pytest.raises(TypeError, match=r"bar: a section takes a dict"):
        Scenario.paper(bar=0.644)
    with pytest.raises(TypeError, match="scenario must be a vibrobar.Scenario"):
        vibrobar.run({"gap_m": 1e-4})
    with pytest.raises(OSError, match="cannot read scenario file"):
        Scenario.from_toml("/nonexistent/scenario.toml")


def test_numpy_values_are_numbers():
    import numpy as np

    s = Scenario.paper(gap_m=np.float64(2e-4), gaps_m=np.array([1e-4, 2e-4]))
    assert s.gap_m == 2e-4 and s.to_dict()["sweep"]["gaps_m"] == [1e-4, 2e-4]


def test_the_beam_is_reachable_the_same_way():
    b = Scenario.paper_beam(modes=3)
    assert b.is_beam and b.to_dict()["beam"]["modes"] == 3
    assert "bar" not in b.to_dict()
    assert Scenario.paper(beam=dict(modes=3)) == b
    assert b.replace(beam=None) == Scenario.paper()
    assert not Scenario.paper().is_beam
    with pytest.raises(ValueError, match=r"\[beam\] and \[bar\] both describe the bar"):
        b.replace(bar=dict(mass_kg=0.7))
    with pytest.raises(ValueError, match="modes"):
        Scenario.paper_beam(modes=-1)


def test_a_field_of_a_section_the_scenario_lacks_says_how_to_give_it():
    with pytest.raises(TypeError, match=r"`modes` is a field of \[beam\], which this scenario does not have \(the lumped bar\): give it as beam=dict\(modes=...\), or start from Scenario.paper_beam\(\)"):
        Scenario.paper(modes=3)
    with pytest.raises(TypeError, match=r"`stiffness_n_per_m` is a field of \[bar\], \[solid_bar\], which this scenario does not have \(a \[beam\]\)"):
        Scenario.paper_beam(stiffness_n_per_m=1e7)
