//! Issue #9 from the command line: `vibrobar contact-test`, the `[contact]` section and the
//! `--contact` flag; bad input names the field or flag.

mod common;

use common::{assert_fails_with, assert_ok, vibrobar_in};
use std::fs;

/// The CSV has the contract's header, one row per speed, and the hertz law's numbers: the
/// target restitution at every speed, contact time and peak force growing/shrinking as Hertz's
/// law says (t_c ∝ v^{-1/5}, F ∝ v^{6/5}).
#[test]
fn contact_test_writes_the_schema_and_the_target_restitution() {
    let dir = tempfile::tempdir().unwrap();
    let o = vibrobar_in(
        dir.path(),
        &[
            "contact-test",
            "--speeds-m-s",
            "0.01,0.1,1",
            "--out",
            "c.csv",
        ],
    );
    assert_ok(&o);
    let text = fs::read_to_string(dir.path().join("c.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "speed_m_s,contact_time_s,restitution,max_force_n,max_penetration_m"
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 3);
    for r in &rows {
        assert!((r[2] - 0.5).abs() < 1e-6, "{r:?}");
    }
    // Ten times the speed: t_c × 10^{-1/5} (damped: the same self-similar law), F × 10^{6/5}.
    for w in rows.windows(2) {
        assert!((w[1][1] / w[0][1] - 10f64.powf(-0.2)).abs() < 1e-6, "{w:?}");
        assert!((w[1][3] / w[0][3] - 10f64.powf(1.2)).abs() < 1e-4, "{w:?}");
    }
    assert!(dir.path().join("c.csv.meta.json").exists());
}

/// `[contact]` in a scenario and `--contact` on run: a hertz run differs from the restitution
/// run of the same scenario, and bad constants name their field.
#[test]
fn contact_section_and_flag_reach_the_run_and_bad_values_name_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let base = "[run]\nduration_s = 0.05\n";
    fs::write(dir.path().join("r.toml"), base).unwrap();
    fs::write(
        dir.path().join("h.toml"),
        format!("{base}[contact]\nlaw = \"hertz\"\nwall_radius_m = 0.02\n"),
    )
    .unwrap();
    assert_ok(&vibrobar_in(
        dir.path(),
        &["run", "--scenario", "r.toml", "--out", "r.csv"],
    ));
    assert_ok(&vibrobar_in(
        dir.path(),
        &["run", "--scenario", "h.toml", "--out", "h.csv"],
    ));
    assert_ok(&vibrobar_in(
        dir.path(),
        &[
            "run",
            "--scenario",
            "r.toml",
            "--contact",
            "hertz",
            "--out",
            "f.csv",
        ],
    ));
    let r = fs::read_to_string(dir.path().join("r.csv")).unwrap();
    let h = fs::read_to_string(dir.path().join("h.csv")).unwrap();
    let f = fs::read_to_string(dir.path().join("f.csv")).unwrap();
    assert!(r != h, "hertz run equals the restitution run");
    assert!(r != f, "--contact hertz run equals the restitution run");
    for (section, field) in [
        (
            "law = \"hertz\"\nball_poisson = 0.7\n",
            "contact.ball_poisson",
        ),
        (
            "law = \"hertz\"\nwall_modulus_pa = 0\n",
            "contact.wall_modulus_pa",
        ),
        (
            "law = \"hertz\"\nwall_radius_m = 0.001\n",
            "contact.wall_radius_m",
        ),
        ("law = \"elastic\"\n", "law"),
        ("ball_modulus = 1\n", "ball_modulus"),
    ] {
        fs::write(
            dir.path().join("bad.toml"),
            format!("{base}[contact]\n{section}"),
        )
        .unwrap();
        assert_fails_with(
            &vibrobar_in(
                dir.path(),
                &["run", "--scenario", "bad.toml", "--out", "x.csv"],
            ),
            &[field],
        );
    }
    fs::write(
        dir.path().join("bad.toml"),
        format!("{base}[damper]\nrestitution = 0.0\n[contact]\nlaw = \"hertz\"\n"),
    )
    .unwrap();
    assert_fails_with(
        &vibrobar_in(
            dir.path(),
            &["run", "--scenario", "bad.toml", "--out", "x.csv"],
        ),
        &["damper.restitution", "hertz"],
    );
    assert_fails_with(
        &vibrobar_in(
            dir.path(),
            &["contact-test", "--speeds-m-s", "0.1,-1", "--out", "c.csv"],
        ),
        &["--speeds-m-s"],
    );
    assert_fails_with(
        &vibrobar_in(
            dir.path(),
            &[
                "run",
                "--contact",
                "hertz",
                "--solver",
                "rk4",
                "--duration",
                "0.01",
                "--out",
                "y.csv",
            ],
        ),
        &["hertz", "rk4"],
    );
}

/// `contact-laws --quick` writes the comparison document with every section and a verdict
/// computed from its own numbers.
#[test]
fn contact_laws_document_has_every_section_and_a_verdict() {
    let dir = tempfile::tempdir().unwrap();
    assert_ok(&vibrobar_in(
        dir.path(),
        &["contact-laws", "--quick", "--out", "c.md"],
    ));
    let doc = fs::read_to_string(dir.path().join("c.md")).unwrap();
    for want in [
        "## Figs. 3 and 5 sweep set, side by side",
        "## Best gap at resonance",
        "## Chaotic points: initial-condition ensembles",
        "## Verdict",
        "an adequate model",
        "--quick (SHORT RUNS",
    ] {
        assert!(doc.contains(want), "missing {want:?}");
    }
}

/// `contact-convergence --quick` writes the document, the CSV (its header, one row per law and
/// N for point A) and the figure; the hertz rows dissipate through contacts, the restitution
/// rows through impacts, and each law gets a verdict computed from the table.
#[test]
fn contact_convergence_writes_table_figure_and_verdicts() {
    let dir = tempfile::tempdir().unwrap();
    assert_ok(&vibrobar_in(
        dir.path(),
        &["contact-convergence", "--quick", "--out", "cc.md"],
    ));
    let text = fs::read_to_string(dir.path().join("cc.csv")).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    assert_eq!(
        header,
        "point,gap_mm,ratio,law,modes,inverse_effective_mass_per_kg,residual_compliance_m_per_n,rms_solid_m,rms_damped_m,reduction_pct,dissipation_w,impacts_per_cycle,regime"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 2 * 4, "{text}");
    for law in ["restitution", "hertz"] {
        let of: Vec<&Vec<&str>> = rows.iter().filter(|r| r[3] == law).collect();
        assert_eq!(of.len(), 4);
        for (k, r) in of.iter().enumerate() {
            assert_eq!(r[0], "A");
            assert_eq!(r[4], (k + 1).to_string());
            let loss: f64 = r[10].parse().unwrap();
            assert!(loss > 0.0 && loss.is_finite(), "{r:?}");
        }
    }
    // The residual compliance falls as modes are added.
    let res: Vec<f64> = rows[..4].iter().map(|r| r[6].parse().unwrap()).collect();
    assert!(
        res.windows(2).all(|w| w[1] <= w[0]) && res[3] < res[0],
        "{res:?}"
    );
    for f in ["cc.png", "cc.svg"] {
        assert!(
            fs::metadata(dir.path().join(f)).unwrap().len() > 1000,
            "{f}"
        );
    }
    let doc = fs::read_to_string(dir.path().join("cc.md")).unwrap();
    for want in [
        "## Point A",
        "**Criterion.**",
        "## Verdict",
        "`restitution` converges at",
        "`hertz` converges at",
        "## Residual flexibility of the truncated modes",
        "--quick",
    ] {
        assert!(doc.contains(want), "missing {want:?}");
    }
}
