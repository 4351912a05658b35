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
    for f in (lambda: vibrobar.run(sc), lambda: vibrobar.sweep(sc, ratios=[1.0], gaps_m=[1e-4])):
        with pytest.raises(ValueError, match=r"does not run a scenario with \[two_plane\]"):
            f()
