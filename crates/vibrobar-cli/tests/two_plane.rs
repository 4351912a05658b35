//! The generated two-plane document (`vibrobar two-plane --quick`): its sections and tables,
//! that the table of every point is written beside it with finite numbers, that with the force
//! along the hole on frictionless walls the two models give the same answers, and that bad
//! flags are refused before anything is written.

mod common;

use common::{assert_fails_with, s, vibrobar, vibrobar_ok};
use std::fs;

#[test]
fn quick_document_has_its_tables_and_the_force_along_the_hole_agrees_with_one_plane() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("docs/two-plane.md");
    vibrobar_ok(&["two-plane", "--quick", "--out", s(&out)]);
    let doc = fs::read_to_string(&out).unwrap();
    for h in [
        "# One plane or two: the ball in a hole across a round bar",
        "## The model",
        "## The exact solver against the reference",
        "## The beam referred to the tip",
        "## One plane against two planes, frictionless walls",
        "## One plane against two planes, frictional walls",
        "## Where to drill the hole: hole angle × axial gap",
        "## How tight a hole: radial clearance × axial gap",
        "## Which of the paper's conclusions survive",
        "| hole | gap | r | one plane | 0° | 63.4° |",
    ] {
        assert!(doc.contains(h), "missing {h:?}");
    }
    assert!(!doc.contains("NaN") && !doc.contains("inf"));
    assert!(!doc.contains("-0 "), "a negative zero in a cell");
    let csv = fs::read_to_string(d.path().join("docs/two-plane/points.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    // 2 wall laws × 2 holes × 2 gaps × 1 ratio × 2 forces, the two 2 × 2 maps and the beam's
    // 2 holes × 2 gaps × 2 forces; two models each; and the reference solver's check at the four
    // frictionless points at 63.4°.
    assert_eq!(rows.len(), 2 * (16 + 4 + 4 + 8) + 4);
    assert_eq!(rows.iter().filter(|r| r[0] == "beam").count(), 16);
    for r in &rows {
        assert_eq!(r.len(), 17);
        let r = &r[1..];
        for v in &r[9..] {
            assert!(v.parse::<f64>().unwrap().is_finite(), "{r:?}");
        }
        // The exact solver where the planes decouple, the reference one with friction.
        let expected = match (r[0], r[7]) {
            (_, "one-plane") | ("frictionless", _) => &["exact", "reference"][..],
            _ => &["reference"][..],
        };
        assert!(expected.contains(&r[8]), "{r:?}");
    }
    let checks = rows
        .iter()
        .filter(|r| r[1] == "frictionless" && r[8] == "two-plane" && r[9] == "reference")
        .count();
    assert_eq!(checks, 4);
    // Frictionless walls with the force along the hole: two planes = one plane, member by
    // member, so the means and ranges agree.
    let along: Vec<Vec<&str>> = rows
        .iter()
        .filter(|r| r[0] == "lumped" && r[1] == "frictionless" && r[7] == "0")
        .map(|r| r[1..].to_vec())
        .collect();
    assert_eq!(along.len(), 8);
    for pair in along.chunks(2) {
        let (two, one) = (&pair[0], &pair[1]);
        assert_eq!((two[7], one[7]), ("two-plane", "one-plane"));
        for k in 9..13 {
            let (a, b): (f64, f64) = (two[k].parse().unwrap(), one[k].parse().unwrap());
            assert!((a - b).abs() < 0.01, "{two:?} against {one:?}");
        }
    }
}

#[test]
fn bad_flags_are_refused_and_nothing_is_written() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("two-plane.md");
    let o = vibrobar(&["two-plane", "--members", "0", "--out", s(&out)]);
    assert_fails_with(&o, &["--members"]);
    let o = vibrobar(&["two-plane", "--duration", "-1", "--out", s(&out)]);
    assert_fails_with(&o, &["--duration"]);
    let txt = d.path().join("two-plane.txt");
    let o = vibrobar(&["two-plane", "--quick", "--out", s(&txt)]);
    assert_fails_with(&o, &["--out", ".md"]);
    assert!(fs::read_dir(d.path()).unwrap().next().is_none());
}
