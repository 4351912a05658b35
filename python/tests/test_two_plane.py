"""The bar that bends in two planes from Python: the same numbers as the core, the one-plane
counterpart with the force along the hole, and keywords named in errors."""
import numpy as np
import pytest

import vibrobar


def test_force_along_the_hole_on_frictionless_walls_is_the_one_plane_model():
    t = vibrobar.two_plane(
        hole_axial_gap_m=0.1e-3, forcing_angle_deg=0.0, gravity_m_s2=0.0,
        members=3, duration_s=0.1,
    )
    c = t
    assert len(c["rms_along_force_m"]) == 3
    # Member 0 starts at rest: nothing moves across the hole. The others start with a small
    # speed across it, which frictionless walls keep apart from the motion along it: along it
    # the two models agree.
    assert c["rms_tangential_m"][0] < 1e-15
    assert np.all(c["rms_tangential_m"][1:] > 0)
    assert np.allclose(c["rms_along_force_m"], c["one_plane_rms_m"], rtol=1e-9)
    assert np.all(c["impacts_axial_plus"] + c["impacts_axial_minus"] > 0)
    assert np.all(c["solid_rms_m"] > 0)


def test_members_are_reproducible_and_start_along_the_hole():
    a = vibrobar.two_plane(members=4, duration_s=0.02, seed=7)
    b = vibrobar.two_plane(members=4, duration_s=0.02, seed=7, threads=1)
    for k in a:
        assert np.array_equal(a[k], b[k]), k
    assert a["w_along_start_m"][0] == 0.0
    assert np.all(np.abs(a["w_along_start_m"]) <= 0.5e-3)
    assert np.all(np.abs(a["dw_along_start_m_s"]) <= 0.01)
    # Across the hole too, away from the floor gravity presses the ball onto.
    assert a["dw_across_start_m_s"][0] == 0.0
    assert np.all(a["dw_across_start_m_s"][1:] != 0.0)
    assert np.all(np.abs(a["dw_across_start_m_s"]) <= 0.01)


@pytest.mark.parametrize(
    "kw, name",
    [
        ({"hole_diameter_m": 0.012}, "hole_diameter_m"),
        ({"hole_angle_deg": float("nan")}, "hole_angle_deg"),
        ({"gravity_m_s2": float("inf")}, "gravity_m_s2"),
        ({"ball_friction_static": 1.0}, "ball_friction_static"),
        ({"ball_friction_static": 0.2, "ball_friction_kinetic": 0.3}, "ball_friction_kinetic"),
        ({"hole_axial_gap_m": -1e-4}, "hole_axial_gap_m"),
        ({"bar_stiffness_n_per_m": (9e6, -1.0)}, "bar_stiffness_n_per_m[1]"),
        ({"members": 0}, "members"),
    ],
)
def test_bad_input_names_the_keyword(kw, name):
    with pytest.raises(ValueError, match=name.replace("[", r"\[").replace("]", r"\]")):
        vibrobar.two_plane(duration_s=0.01, **kw)


def test_wrong_types_are_type_errors():
    with pytest.raises(TypeError, match="bar_stiffness_n_per_m"):
        vibrobar.two_plane(bar_stiffness_n_per_m="stiff")
    with pytest.raises(TypeError, match="members"):
        vibrobar.two_plane(members=2.5)


def test_the_exact_solver_runs_where_the_planes_decouple_and_matches_the_reference():
    # Frictionless walls, a round bar: "auto" runs the exact solver; over a short run where
    # the motion has not yet spread, the reference solver gives the same RMS.
    kw = dict(hole_axial_gap_m=0.1e-3, hole_diameter_m=0.01504, forcing_angle_deg=70.0,
              hole_angle_deg=40.0, gravity_m_s2=0.0, members=1, duration_s=0.06)
    auto = vibrobar.two_plane(**kw)
    ref = vibrobar.two_plane(solver="reference", **kw)
    assert list(auto["solver"]) == ["exact"] and list(ref["solver"]) == ["reference"]
    for k in ("rms_along_force_m", "rms_radial_m", "rms_tangential_m", "rms_total_m"):
        assert np.allclose(auto[k], ref[k], rtol=1e-6), k
    # With friction "auto" takes the reference solver, and "exact" refuses and says why.
    rough = dict(kw, ball_friction_static=0.3, ball_friction_kinetic=0.2, duration_s=0.01)
    assert list(vibrobar.two_plane(**rough)["solver"]) == ["reference"]
    # ... at the step it is given.
    coarse = vibrobar.two_plane(dt_s=2e-6, **rough)
    assert not np.array_equal(coarse["rms_along_force_m"],
                              vibrobar.two_plane(**rough)["rms_along_force_m"])
    with pytest.raises(Exception, match="frictionless walls"):
        vibrobar.two_plane(solver="exact", **rough)
    with pytest.raises(ValueError, match="solver"):
        vibrobar.two_plane(solver="rk4", **kw)


TWO_PLANE_TOML = """[damper]
gap_m = 1.0e-4

[run]
duration_s = 0.05

[two_plane]
hole_diameter_m = 0.0151
force_ratio = 2.0
members = 4
"""


def _vibrobar_cli():
    import os
    import shutil

    here = os.path.dirname(os.path.abspath(__file__))
    root = os.path.dirname(os.path.dirname(here))
    for p in (os.path.join(root, "target", "release", "vibrobar"), shutil.which("vibrobar")):
        if p and os.path.exists(p):
            return p
    pytest.skip("no vibrobar binary built")


def test_a_two_plane_run_is_the_command_line_run(tmp_path):
    import subprocess

    sc_path = tmp_path / "tp.toml"
    sc_path.write_text(TWO_PLANE_TOML)
    sc = vibrobar.Scenario.from_toml(str(sc_path))
    r = vibrobar.two_plane_run(sc, member=2, sample_every=5)
    assert r.solver == "exact" and r.member == 2
    h = r.history
    assert h.rows == 10_001
    assert np.all(np.abs(h["w_along_m"]) <= 0.05e-3 + 1e-12)
    assert abs(r.reduction_pct - 100 * (1 - r.rms_along_force_m / r.solid_rms_m)) < 1e-9
    assert abs(r.energy["residual_j"]) < 1e-9 * abs(r.energy["forcing_work_j"])
    assert sum(w["impacts"] for w in r.walls.values()) > 0
    out = tmp_path / "run.csv"
    subprocess.run(
        [_vibrobar_cli(), "run", "--scenario", str(sc_path), "--member", "2",
         "--sample-every", "5", "--out", str(out)],
        check=True, capture_output=True,
    )
    assert h.to_csv() == out.read_text()


def test_two_plane_run_refuses_bad_members_and_one_plane_functions_refuse_two_planes(tmp_path):
    sc_path = tmp_path / "tp.toml"
    sc_path.write_text(TWO_PLANE_TOML)
    sc = vibrobar.Scenario.from_toml(str(sc_path))
    with pytest.raises(ValueError, match=r"member = 4 is outside the allowed range \[0, 3\]"):
        vibrobar.two_plane_run(sc, member=4)
    with pytest.raises(ValueError, match="member"):
        vibrobar.two_plane_run(sc, member=-1)
    with pytest.raises(TypeError, match="sample_every"):
        vibrobar.two_plane_run(sc, sample_every=1.5)
    with pytest.raises(ValueError, match=r"needs a scenario with \[two_plane\]"):
        vibrobar.two_plane_run(vibrobar.Scenario.paper())
    # The one-plane functions do not run the one-plane model in its place.
    for f in (lambda: vibrobar.run(sc), lambda: vibrobar.regime(sc),
              lambda: vibrobar.continuation2(sc)):
        with pytest.raises(ValueError, match=r"does not run a scenario with \[two_plane\]"):
            f()


def _cli_file(tmp_path, name, *args):
    import subprocess

    out = tmp_path / name
    subprocess.run([_vibrobar_cli(), *args, "--out", str(out)], check=True, capture_output=True)
    return out.read_text()


def test_sweep_ensemble_and_map_of_a_two_plane_scenario_are_the_command_line_files(tmp_path):
    sc_path = tmp_path / "tp.toml"
    sc_path.write_text(TWO_PLANE_TOML)
    sc = vibrobar.Scenario.from_toml(str(sc_path))
    assert sc.is_two_plane and not vibrobar.Scenario.paper().is_two_plane
    scen = ("--scenario", str(sc_path))

    s = vibrobar.sweep(sc, ratios=[0.98, 1.0], gaps_m=[1e-4, 1e-3], threads=1)
    assert isinstance(s, vibrobar.TwoPlaneTable) and s.rows == 4
    assert list(s["axial_gap_m"]) == [1e-4, 1e-4, 1e-3, 1e-3]
    assert list(s["members"]) == [4] * 4
    red = 100 * (1 - s["rms_along_force_mean_m"] / s["solid_rms_m"])
    assert np.allclose(red, s["reduction_mean_pct"], atol=1e-9 + 1e-6 * np.abs(red).max())
    assert s.to_csv() == _cli_file(tmp_path, "sweep.csv", "sweep", *scen, "--ratios",
                                   "0.98:1.0:0.02", "--gap-mm", "0.1", "--gap-mm", "1.0")

    e = vibrobar.ensemble(sc, ratios=[0.98, 1.0], gaps_m=1e-3, members=3, seed=7)
    assert e.rows == 6 and list(e["member"]) == [0, 1, 2, 0, 1, 2]
    assert e.to_csv() == _cli_file(tmp_path, "ens.csv", "ensemble", *scen, "--ratios",
                                   "0.98:1.0:0.02", "--gap-mm", "1.0", "--members", "3",
                                   "--seed", "7")
    # The sweep's point is the mean of the same members (the scenario's 4, seed 1).
    e4 = vibrobar.ensemble(sc, ratios=1.0, gaps_m=1e-3)
    assert e4.rows == 4
    assert abs(e4["rms_along_force_m"].mean() - s["rms_along_force_mean_m"][3]) < 1e-18

    m = vibrobar.map(sc, ratios=1.0, gaps_m=[1e-4, 1e-3], hole_angles_deg=[0.0, 45.0],
                     hole_diameters_m=0.0151)
    assert m.rows == 4 and list(m["hole_angle_deg"]) == [0.0, 0.0, 45.0, 45.0]
    assert np.allclose(m["radial_clearance_m"], 0.05e-3)
    assert m.to_csv() == _cli_file(tmp_path, "map.csv", "map", *scen, "--ratios", "1:1:1",
                                   "--gaps-mm", "0.1:1.0:0.9", "--hole-angles-deg", "0:45:45",
                                   "--hole-diameters-mm", "15.1:15.1:1")
    # The map's radial-hole cells are the sweep's points.
    assert np.allclose(m["reduction_mean_pct"][:2], s["reduction_mean_pct"][[1, 3]], atol=1e-4)


def test_poincare_and_lyapunov_of_a_two_plane_scenario_are_the_command_line_ones(tmp_path):
    import json
    import subprocess

    sc_path = tmp_path / "tp.toml"
    sc_path.write_text(TWO_PLANE_TOML)
    sc = vibrobar.Scenario.from_toml(str(sc_path))
    p = vibrobar.poincare(sc, ratio=1.0, gap_m=1e-4, phase_deg=30.0, transient_s=0.01, member=1)
    period = 2 * np.pi / (np.sqrt(9.22e6 / 0.644))
    t = p["t_s"]
    assert len(t) > 10 and t[0] >= 0.01 and np.allclose(np.diff(t), period, rtol=1e-12)
    assert np.allclose(np.mod(t / period, 1.0), 30.0 / 360.0, atol=1e-9)
    out = tmp_path / "p.csv"
    subprocess.run(
        [_vibrobar_cli(), "poincare", "--scenario", str(sc_path), "--ratio", "1", "--gap-mm",
         "0.1", "--phase-deg", "30", "--transient", "0.01", "--member", "1", "--out", str(out)],
        check=True, capture_output=True,
    )
    cli_rows = np.loadtxt(out, delimiter=",", skiprows=1, ndmin=2)
    assert cli_rows.shape[0] == len(t)
    assert np.array_equal(cli_rows[:, 0], t) and np.array_equal(cli_rows[:, 5], p["u_force_m"])

    ly = vibrobar.lyapunov(sc, ratio=1.0, gap_m=1e-4, transient_s=0.01, periods=5.0, member=1)
    assert ly["member"] == 1 and ly["solver"] == "exact" and ly["intervals"] >= 2
    o = subprocess.run(
        [_vibrobar_cli(), "lyapunov", "--scenario", str(sc_path), "--ratio", "1", "--gap-mm",
         "0.1", "--transient", "0.01", "--periods", "5", "--member", "1", "--json"],
        check=True, capture_output=True, text=True,
    )
    j = json.loads(o.stdout)
    assert j["exponent_per_s"] == ly["exponent_per_s"]
    assert j["std_error_per_s"] == ly["std_error_per_s"]


def test_two_plane_tables_refuse_what_does_not_apply_and_name_it(tmp_path):
    sc_path = tmp_path / "tp.toml"
    sc_path.write_text(TWO_PLANE_TOML)
    sc = vibrobar.Scenario.from_toml(str(sc_path))
    paper = vibrobar.Scenario.paper(duration_s=0.01)
    cases = [
        (lambda: vibrobar.sweep(sc, freqs_hz=[600.0]), "freqs_hz"),
        (lambda: vibrobar.map(sc, ratios=1.0, gaps_m=1e-3, restitutions=[0.5]), "restitutions"),
        (lambda: vibrobar.map(sc, ratios=1.0, gaps_m=1e-3, hole_diameters_m=0.014),
         "hole_diameters_m"),
        (lambda: vibrobar.map(sc, ratios=1.0, gaps_m=1e-3, hole_angles_deg=400.0),
         "hole_angles_deg"),
        (lambda: vibrobar.map(paper, ratios=1.0, gaps_m=1e-3, hole_angles_deg=0.0),
         "hole_angles_deg"),
        (lambda: vibrobar.ensemble(sc, ratios=1.0, gaps_m=1e-3, u_m=1e-5), "u_m"),
        (lambda: vibrobar.ensemble(sc, ratios=1.0, gaps_m=1e-3, members=0), "members"),
        (lambda: vibrobar.ensemble(sc, ratios=1.0, gaps_m=-1e-3), "gaps_m"),
        (lambda: vibrobar.ensemble(sc, ratios=[np.nan], gaps_m=1e-3), "ratios"),
        (lambda: vibrobar.poincare(sc, member=4), "member"),
        (lambda: vibrobar.poincare(paper, member=0), "member"),
        (lambda: vibrobar.lyapunov(sc, gap_m=0.0), "gap_m"),
        (lambda: vibrobar.lyapunov(sc, periods=-1.0), "periods"),
        (lambda: vibrobar.lyapunov(sc, periods=1e6), "intervals"),
    ]
    for f, name in cases:
        with pytest.raises(ValueError, match=name):
            f()
    with pytest.raises(TypeError, match="member"):
        vibrobar.lyapunov(sc, member=1.5)


TIGHT_TOML = """[damper]
gap_m = 0.04e-3

[run]
duration_s = 0.3

[two_plane]
hole_diameter_m = 0.01508
force_ratio = 2.0
members = 4
"""


def test_orbit_and_spectrum_of_a_two_plane_scenario_are_the_command_line_ones(tmp_path):
    import json
    import subprocess

    sc_path = tmp_path / "tight.toml"
    sc_path.write_text(TIGHT_TOML)
    sc = vibrobar.Scenario.from_toml(str(sc_path))
    o = vibrobar.orbit(sc, ratio=1.0, gap_m=0.04e-3, member=1)
    assert o["stable"] and o["member"] == 1 and len(o["multipliers"]) == 8
    assert o["return_gap"] < 1e-9
    assert o["planes"]["along_hole"]["impacts_per_period"] == 2
    assert o["planes"]["across_hole"]["impacts_per_period"] == 2
    out = tmp_path / "o.json"
    subprocess.run(
        [_vibrobar_cli(), "orbit", "--scenario", str(sc_path), "--ratio", "1", "--gap-mm",
         "0.04", "--member", "1", "--out", str(out)],
        check=True, capture_output=True,
    )
    j = json.loads(out.read_text())
    assert j["rms_along_force_m"] == o["rms_along_force_m"]
    assert j["max_abs_multiplier"] == o["max_abs_multiplier"]
    assert [tuple(m) for m in j["multipliers"]] == [tuple(m) for m in o["multipliers"]]

    sp = vibrobar.lyapunov_spectrum(sc, ratio=1.0, gap_m=0.04e-3, member=1)
    p = subprocess.run(
        [_vibrobar_cli(), "lyapunov", "--scenario", str(sc_path), "--ratio", "1", "--gap-mm",
         "0.04", "--member", "1", "--spectrum", "--json"],
        check=True, capture_output=True, text=True,
    )
    js = json.loads(p.stdout)
    for plane in ("along_hole", "across_hole"):
        assert sp[plane]["exponents_per_s"] == js[plane]["exponents_per_s"]
        assert len(sp[plane]["exponents_per_s"]) == 4
    assert sp["spin_exponent_per_s"] == 0.0

    with pytest.raises(ValueError, match="start"):
        vibrobar.orbit(sc, start="symmetric")
    with pytest.raises(ValueError, match="member"):
        vibrobar.orbit(vibrobar.Scenario.paper(), member=0)
    rough = tmp_path / "rough.toml"
    rough.write_text(TIGHT_TOML + "friction_static = 0.3\n")
    with pytest.raises(ValueError, match="decouple"):
        vibrobar.orbit(vibrobar.Scenario.from_toml(str(rough)))
    with pytest.raises(ValueError, match="decouple"):
        vibrobar.lyapunov_spectrum(vibrobar.Scenario.from_toml(str(rough)))


def test_continuation_of_a_two_plane_scenario_is_the_command_line_one(tmp_path):
    import subprocess

    sc_path = tmp_path / "tight.toml"
    sc_path.write_text(TIGHT_TOML)
    sc = vibrobar.Scenario.from_toml(str(sc_path))
    c = vibrobar.continuation(sc, param="ratio", from_=1.0, to=1.05, gap_m=0.04e-3)
    planes = set(c["plane"])
    assert planes == {"along_hole", "across_hole"}
    along = c["plane"] == "along_hole"
    assert c["param"][along][0] == 1.0 and abs(c["param"][along][-1] - 1.05) < 1e-9
    out = tmp_path / "c.csv"
    subprocess.run(
        [_vibrobar_cli(), "continue", "--scenario", str(sc_path), "--param", "ratio", "--from",
         "1", "--to", "1.05", "--gap-mm", "0.04", "--out", str(out)],
        check=True, capture_output=True,
    )
    # The ratio is dimensionless: the same rows, character for character.
    assert c.to_csv() == out.read_text()
    g = vibrobar.continuation(sc, param="gap_m", from_=0.04e-3, to=0.05e-3, ratio=1.0)
    assert set(g["plane"]) == {"along_hole"}
    with pytest.raises(ValueError, match="param"):
        vibrobar.continuation(sc, param="friction_force_n", from_=1.0, to=2.0, ratio=1.0,
                              gap_m=0.04e-3)
    with pytest.raises(ValueError, match="member"):
        vibrobar.continuation(vibrobar.Scenario.paper(), member=1)
