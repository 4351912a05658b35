//! `[damper] gravity_along_gap_m_s2` from a scenario file: an explicit 0 gives the same files
//! as leaving it out, a non-zero value reaches the run, bad values name the field, and the
//! `hertz` law refuses it.

mod common;

use common::{assert_fails_with, assert_ok, names, vibrobar_in};
use std::fs;

#[test]
fn gravity_along_the_gap_from_a_scenario_file() {
    let dir = tempfile::tempdir().unwrap();
    let base = "[run]\nduration_s = 0.05\n";
    let damper = |v: &str| format!("{base}[damper]\ngap_m = 1e-3\n{v}");
    fs::write(dir.path().join("r.toml"), damper("")).unwrap();
    fs::write(
        dir.path().join("z.toml"),
        damper("gravity_along_gap_m_s2 = 0.0\n"),
    )
    .unwrap();
    fs::write(
        dir.path().join("g.toml"),
        damper("gravity_along_gap_m_s2 = -9.80665\n"),
    )
    .unwrap();
    for (toml, out) in [("r.toml", "r"), ("z.toml", "z"), ("g.toml", "g")] {
        let sub = dir.path().join(out);
        fs::create_dir(&sub).unwrap();
        fs::copy(dir.path().join(toml), sub.join("s.toml")).unwrap();
        assert_ok(&vibrobar_in(
            &sub,
            &["run", "--scenario", "s.toml", "--out", "out.csv"],
        ));
    }
    // Every file written, byte for byte, with the 0 written out as without it.
    let files = names(&dir.path().join("r"));
    assert!(files.iter().any(|f| f == "out.csv"), "{files:?}");
    assert_eq!(files, names(&dir.path().join("z")));
    for f in &files {
        if f == "s.toml" {
            continue;
        }
        let r = fs::read(dir.path().join("r").join(f)).unwrap();
        let z = fs::read(dir.path().join("z").join(f)).unwrap();
        assert!(
            r == z,
            "{f} differs with gravity_along_gap_m_s2 = 0.0 written out"
        );
    }
    let r = fs::read(dir.path().join("r/out.csv")).unwrap();
    let g = fs::read(dir.path().join("g/out.csv")).unwrap();
    assert!(r != g, "gravity along the gap did not reach the run");
    for bad in ["1e4", "-1001.0", "nan", "inf"] {
        fs::write(
            dir.path().join("bad.toml"),
            damper(&format!("gravity_along_gap_m_s2 = {bad}\n")),
        )
        .unwrap();
        assert_fails_with(
            &vibrobar_in(
                dir.path(),
                &["run", "--scenario", "bad.toml", "--out", "x.csv"],
            ),
            &["damper.gravity_along_gap_m_s2"],
        );
    }
    fs::write(
        dir.path().join("h.toml"),
        format!(
            "{}[contact]\nlaw = \"hertz\"\n",
            damper("gravity_along_gap_m_s2 = -9.80665\n")
        ),
    )
    .unwrap();
    assert_fails_with(
        &vibrobar_in(
            dir.path(),
            &["run", "--scenario", "h.toml", "--out", "x.csv"],
        ),
        &["damper.gravity_along_gap_m_s2", "hertz"],
    );
}
