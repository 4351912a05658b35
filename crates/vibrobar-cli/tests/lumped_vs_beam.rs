//! The generated lumped-vs-beam document (`vibrobar lumped-vs-beam --quick`): its structure, that
//! every number is finite, and that its beam numbers are those of a direct `placement` run.

mod common;

use common::{assert_ok, s, vibrobar_env, vibrobar_ok};
use std::fs;

/// The numbers of a Markdown table row (cells that parse as numbers).
fn numbers(row: &str) -> Vec<f64> {
    row.split('|')
        .filter_map(|c| c.trim().parse::<f64>().ok())
        .collect()
}

#[test]
fn quick_document_has_its_sections_finite_numbers_and_agrees_with_placement() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("docs/lumped-vs-beam.md");
    vibrobar_ok(&[
        "lumped-vs-beam",
        "--solver",
        "rk4",
        "--quick",
        "--out",
        s(&out),
    ]);
    let doc = fs::read_to_string(&out).unwrap();
    for h in [
        "# The paper's lumped bar against the beam model",
        "## 1. The two models",
        "## 2. At resonance, side by side",
        "## 3. What changes in the paper's conclusions",
        "## 4. Convergence in the number of modes N",
        "**Point A**",
        "**Point B**",
        "**Point C**",
        "**Why it cannot converge.**",
        "Szalai 2014",
    ] {
        assert!(doc.contains(h), "missing {h:?}");
    }
    for bad in ["NaN", "inf", "chatter"] {
        assert!(!doc.contains(bad), "{bad:?} in the document");
    }
    // The N tables: N = 1, 2, 3 at each point, every cell finite, Σφ²/m growing with N.
    let rows: Vec<Vec<f64>> = doc
        .lines()
        .filter(|l| l.starts_with("| 1 |") || l.starts_with("| 2 |") || l.starts_with("| 3 |"))
        .filter(|l| l.matches('|').count() == 12)
        .map(numbers)
        .collect();
    assert_eq!(rows.len(), 9, "{doc}");
    for r in &rows {
        assert!(r.iter().all(|x| x.is_finite()), "{r:?}");
    }
    assert!(rows[2][2] > rows[0][2]);
    // The side-by-side row at 0.1 mm: the beam's reduction is that of a direct placement run.
    let side = doc
        .lines()
        .find(|l| l.starts_with("| 0.1 |") && l.matches('|').count() == 8)
        .expect("0.1 mm row");
    let beam_reduction = numbers(side)[4];
    let csv = d.path().join("p.csv");
    vibrobar_ok(&[
        "placement",
        "--friction",
        "none",
        "--solver",
        "rk4",
        "--duration",
        "0.05",
        "--rms-fraction",
        "0.8",
        "--dt",
        "1e-6",
        "--positions-mm",
        "137:137:1",
        "--gaps-mm",
        "0.1:0.1:1",
        "--ratios",
        "1:1:1",
        "--out",
        s(&csv),
    ]);
    let text = fs::read_to_string(&csv).unwrap();
    let direct: f64 = text
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .nth(2)
        .unwrap()
        .parse()
        .unwrap();
    assert!(
        (direct - beam_reduction).abs() <= 0.051,
        "document {beam_reduction} %, placement {direct} %"
    );
    // The default solver, exact, runs the beams too.
    std::fs::remove_file(&out).unwrap();
    let o = vibrobar_env(&["lumped-vs-beam", "--quick", "--out", s(&out)], &[]);
    assert_ok(&o);
    assert!(std::fs::read_to_string(&out).unwrap().contains("exact"));
}
