//! Measured FRFs in and out: UFF 58/58b/164 and plain columns. Round trips (58b bit for bit,
//! ASCII 58 to its 12 significant digits, 6 for the abscissa start and step), units, signs,
//! several records, and every kind of bad input with its file, record and line.

use num_complex::Complex64;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use vibrobar_core::structure::frf_data::{FrfKind, MeasuredFrf};
use vibrobar_io::frf::{read_frf, write_frf_uff, ColumnLayout, FrfReadOptions, Uff58Header};
use vibrobar_io::uff::{fmt_e, read_uff, round_e13_5, write_uff};

/// A 3-mode receptance (modal masses, frequencies, damping) with a deterministic ripple so
/// that every bit of the mantissa matters.
fn three_modes(freqs: &[f64]) -> Vec<Complex64> {
    let modes = [
        (0.3, 700.0, 0.02),
        (0.5, 2300.0, 0.015),
        (0.8, 6100.0, 0.01),
    ];
    freqs
        .iter()
        .enumerate()
        .map(|(i, &f)| {
            let w = 2.0 * PI * f;
            let g: Complex64 = modes
                .iter()
                .map(|&(m, fnh, z): &(f64, f64, f64)| {
                    let wn = 2.0 * PI * fnh;
                    1.0 / (m * Complex64::new(wn * wn - w * w, 2.0 * z * wn * w))
                })
                .sum();
            g * (1.0 + 1e-3 * ((i as f64) * 0.7).sin())
        })
        .collect()
}

fn frf(freqs: Vec<f64>, coherence: bool) -> MeasuredFrf {
    let v = three_modes(&freqs);
    let c = coherence.then(|| {
        (0..freqs.len())
            .map(|i| 0.5 + 0.5 * ((i as f64) * 0.3).cos().abs())
            .collect()
    });
    MeasuredFrf::new(freqs, v, FrfKind::Receptance, c, true, String::new()).unwrap()
}

fn tmp() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

fn even_lines() -> Vec<f64> {
    (1..=6000).map(|i| 2.0 * i as f64).collect()
}

fn opts() -> FrfReadOptions {
    FrfReadOptions::default()
}

#[test]
fn binary_58b_round_trip_is_bit_identical() {
    let d = tmp();
    for freqs in [
        even_lines(),
        // Uneven lines of full precision: the binary abscissa keeps every bit.
        (1..3000)
            .map(|i| 3.0 + (i as f64).powf(1.13) * 0.917_31)
            .collect(),
    ] {
        let a = frf(freqs, true);
        let p = d.path().join("a.uff");
        write_frf_uff(&p, &a, &Uff58Header::default(), true).unwrap();
        let r = read_frf(&p, &opts()).unwrap();
        assert_eq!(r.format, "uff58b");
        let b = &r.frf;
        assert_eq!(b.kind, FrfKind::Receptance);
        assert!(b.driving_point);
        assert_eq!(a.freqs_hz.len(), b.freqs_hz.len());
        for i in 0..a.len() {
            assert_eq!(a.freqs_hz[i].to_bits(), b.freqs_hz[i].to_bits(), "line {i}");
            assert_eq!(a.values[i].re.to_bits(), b.values[i].re.to_bits());
            assert_eq!(a.values[i].im.to_bits(), b.values[i].im.to_bits());
        }
        assert_eq!(a.coherence, b.coherence);
        // The file itself: read and written again, byte for byte.
        let file = read_uff(&p).unwrap();
        let q = d.path().join("b.uff");
        write_uff(&q, file.units.first(), &file.functions, true).unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), std::fs::read(&q).unwrap());
    }
}

#[test]
fn ascii_58_round_trip_keeps_12_digits_of_values_and_6_of_the_abscissa() {
    let d = tmp();
    // Even lines: start and step of 6 significant digits come back exactly.
    let a = frf(even_lines(), true);
    let p = d.path().join("a.unv");
    write_frf_uff(&p, &a, &Uff58Header::default(), false).unwrap();
    let b = read_frf(&p, &opts()).unwrap().frf;
    let twelve = |x: f64| -> f64 { format!("{x:.11e}").parse().unwrap() };
    for i in 0..a.len() {
        assert_eq!(a.freqs_hz[i].to_bits(), b.freqs_hz[i].to_bits());
        assert_eq!(b.values[i].re, twelve(a.values[i].re), "line {i}");
        assert_eq!(b.values[i].im, twelve(a.values[i].im));
        assert!((b.values[i] - a.values[i]).norm() <= 1e-11 * a.values[i].norm());
    }
    // Uneven lines: E13.5, 6 significant digits.
    let uneven: Vec<f64> = (1..500)
        .map(|i| 3.0 + (i as f64).powf(1.13) * 0.917_31)
        .collect();
    let a = frf(uneven, false);
    write_frf_uff(&p, &a, &Uff58Header::default(), false).unwrap();
    let b = read_frf(&p, &opts()).unwrap().frf;
    for i in 0..a.len() {
        assert_eq!(b.freqs_hz[i], round_e13_5(a.freqs_hz[i]));
        assert!((b.freqs_hz[i] - a.freqs_hz[i]).abs() <= 5e-6 * a.freqs_hz[i]);
    }
    // Read and written again: the same bytes.
    let file = read_uff(&p).unwrap();
    let q = d.path().join("b.unv");
    write_uff(&q, file.units.first(), &file.functions, false).unwrap();
    assert_eq!(std::fs::read(&p).unwrap(), std::fs::read(&q).unwrap());
}

#[test]
fn fortran_e_format_matches_c() {
    assert_eq!(fmt_e(1234.5, 13, 5), "  1.23450E+03");
    assert_eq!(fmt_e(-1.0e-100, 13, 5), "-1.00000E-100");
    assert_eq!(fmt_e(0.0, 20, 11), "   0.00000000000E+00");
    assert_eq!(fmt_e(-2.5e-7, 20, 11), "  -2.50000000000E-07");
}

/// Header records 1–11 of an ASCII dataset 58 with the given records 6–11.
fn header58(rec6: &str, rec7: &str, axes: [&str; 4]) -> String {
    let mut s = String::from("    -1\n    58\nid1\nid2\nNONE\nNONE\nNONE\n");
    s += rec6;
    s += "\n";
    s += rec7;
    s += "\n";
    for a in axes {
        s += a;
        s += "\n";
    }
    s
}

const REC6: &str =
    "    4         0    0         0       NONE         1   3       NONE         1   3";
/// A cross FRF (response node 2): no passivity check.
const REC6X: &str =
    "    4         0    0         0       NONE         2   3       NONE         1   3";
const AX_F: &str = "        18    0    0    0 Frequency            Hz                  ";
const AX_0: &str = "         0    0    0    0 NONE                 NONE                ";

/// An ASCII record with complex double data, even abscissa 10, 20, 30 Hz.
fn record(rec6: &str, ord: &str, den: &str, vals: &[(f64, f64)]) -> String {
    let mut s = header58(
        rec6,
        &format!(
            "{:>10}{:>10}{:>10}{}{}{}",
            6,
            vals.len(),
            1,
            fmt_e(10.0, 13, 5),
            fmt_e(10.0, 13, 5),
            fmt_e(0.0, 13, 5)
        ),
        [AX_F, ord, den, AX_0],
    );
    for (k, (re, im)) in vals.iter().enumerate() {
        s += &fmt_e(*re, 20, 11);
        s += &fmt_e(*im, 20, 11);
        if k % 2 == 1 || k == vals.len() - 1 {
            s += "\n";
        }
    }
    s + "    -1\n"
}

const VALS: [(f64, f64); 3] = [(1e-6, -1e-8), (2e-6, -5e-7), (-1e-6, -3e-6)];

fn write(d: &Path, name: &str, text: &str) -> PathBuf {
    let p = d.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn units_from_labels_dataset_164_and_flags() {
    let d = tmp();
    // Labels g over N: accelerance, ×9.80665.
    let ord = "        12    0    0    0 Acceleration         g                   ";
    let den = "        13    0    0    0 Force                N                   ";
    let p = write(d.path(), "g.uff", &record(REC6X, ord, den, &VALS));
    let r = read_frf(&p, &opts()).unwrap();
    assert_eq!(r.frf.kind, FrfKind::Accelerance);
    assert_eq!(r.frf.values[0].re, 1e-6 * 9.80665);
    // mm/N alone in record 9, no denominator label: receptance ×1e-3.
    let ord = "         0    0    0    0 Receptance           mm/N                ";
    let p = write(d.path(), "mm.uff", &record(REC6, ord, AX_0, &VALS));
    let r = read_frf(&p, &opts()).unwrap();
    assert_eq!(r.frf.kind, FrfKind::Receptance);
    assert_eq!(r.frf.values[1].im, -5e-7 * 1e-3);
    // Dataset 164 (mm, N: length factor 1000) with exponents length 1 over force 1.
    let u164 = "    -1\n   164\n         5  mm (milli newton)        2\n  1.00000000000000000D+03  1.00000000000000000D+03  1.00000000000000000D+00\n  2.73150000000000000D+02\n    -1\n";
    let ord = "         8    1    0    0 Displacement         NONE                ";
    let den = "        13    0    1    0 Force                NONE                ";
    let p = write(
        d.path(),
        "u164.uff",
        &(u164.to_string() + &record(REC6, ord, den, &VALS)),
    );
    let r = read_frf(&p, &opts()).unwrap();
    // SI = file / (1000^1 · 1000^−1) = file.
    assert_eq!(r.frf.values[0].re, 1e-6);
    assert!(
        r.notes.iter().any(|n| n.contains("dataset 164")),
        "{:?}",
        r.notes
    );
    // The IN system (length 39.37 in/m, force 0.2248 lbf/N), exponents inferred from the types.
    let uin = "    -1\n   164\n         7   IN (pound f)          2\n  3.93700787401574814D+01  2.24808943099710480D-01  1.00000000000000000D+00\n  0.00000000000000000D+00\n    -1\n";
    let ord = "         8    0    0    0 Displacement         NONE                ";
    let den = "        13    0    0    0 Force                NONE                ";
    let p = write(
        d.path(),
        "in.uff",
        &(uin.to_string() + &record(REC6, ord, den, &VALS)),
    );
    let r = read_frf(&p, &opts()).unwrap();
    let expect = 1e-6 / (39.370_078_740_157_48 / 0.224_808_943_099_710_48);
    assert!((r.frf.values[0].re - expect).abs() < 1e-14 * expect);
    assert!((expect - 1e-6 * 0.0254 / 4.448_221_615_260_5).abs() < 1e-9 * expect);
    // No units at all: SI assumed, and said.
    let p = write(d.path(), "si.uff", &record(REC6X, AX_0, AX_0, &VALS));
    let r = read_frf(&p, &opts()).unwrap();
    assert!(
        r.notes.iter().any(|n| n.contains("SI assumed")),
        "{:?}",
        r.notes
    );
    assert!(
        r.notes.iter().any(|n| n.contains("receptance assumed")),
        "{:?}",
        r.notes
    );
    // --frf-type fills in the kind; a contradiction is refused.
    let o = FrfReadOptions {
        kind: Some(FrfKind::Mobility),
        ..opts()
    };
    assert_eq!(read_frf(&p, &o).unwrap().frf.kind, FrfKind::Mobility);
    let ord = "        12    0    0    0 Acceleration         g                   ";
    let p = write(d.path(), "g2.uff", &record(REC6, ord, den, &VALS));
    let e = read_frf(
        &p,
        &FrfReadOptions {
            kind: Some(FrfKind::Receptance),
            ..opts()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("g2.uff") && e.contains("accelerance") && e.contains("--frf-type"),
        "{e}"
    );
}

#[test]
fn negative_direction_flips_the_sign_and_cross_frfs_are_not_driving_points() {
    let d = tmp();
    let rec6 = "    4         0    0         0       NONE         1   3       NONE         1  -3";
    // Stored as the file's sign convention: −G; read back as G.
    let stored: Vec<(f64, f64)> = VALS.iter().map(|&(a, b)| (-a, -b)).collect();
    let p = write(d.path(), "neg.uff", &record(rec6, AX_0, AX_0, &stored));
    let r = read_frf(&p, &opts()).unwrap();
    assert_eq!(r.frf.values[2], Complex64::new(-1e-6, -3e-6));
    assert!(r.notes.iter().any(|n| n.contains("sign flipped")));
    // Conjugated data at a driving point: refused with the diagnosis, file named.
    let conj: Vec<(f64, f64)> = VALS.iter().map(|&(a, b)| (a, -b)).collect();
    let p = write(d.path(), "conj.uff", &record(REC6, AX_0, AX_0, &conj));
    let e = read_frf(&p, &opts()).unwrap_err().to_string();
    assert!(
        e.contains("conj.uff") && e.contains("passivity") && e.contains("conjugate"),
        "{e}"
    );
    assert!(read_frf(
        &p,
        &FrfReadOptions {
            conjugate: true,
            ..opts()
        }
    )
    .is_ok());
    // The same values as a cross FRF (response node 2) pass unchecked.
    let rec6x = REC6X;
    let p = write(d.path(), "cross.uff", &record(rec6x, AX_0, AX_0, &conj));
    let r = read_frf(&p, &opts()).unwrap();
    assert!(!r.frf.driving_point);
}

#[test]
fn several_records_average_by_coherence_or_need_a_choice() {
    let d = tmp();
    let coh = |g: [f64; 3]| {
        let rec6 =
            "    6         0    0         0       NONE         1   3       NONE         1   3";
        let mut s = header58(
            rec6,
            &format!(
                "{:>10}{:>10}{:>10}{}{}{}",
                4,
                3,
                1,
                fmt_e(10.0, 13, 5),
                fmt_e(10.0, 13, 5),
                fmt_e(0.0, 13, 5)
            ),
            [AX_F, AX_0, AX_0, AX_0],
        );
        for v in g {
            s += &fmt_e(v, 20, 11);
        }
        s + "\n    -1\n"
    };
    let v2: Vec<(f64, f64)> = VALS.iter().map(|&(a, b)| (3.0 * a, 3.0 * b)).collect();
    let other = "    -1\n   151\nmodel\n    -1\n";
    let text = record(REC6, AX_0, AX_0, &VALS)
        + &coh([0.9, 0.5, 0.0])
        + other
        + &record(REC6, AX_0, AX_0, &v2)
        + &coh([0.3, 0.5, 0.0]);
    let p = write(d.path(), "taps.uff", &text);
    let r = read_frf(&p, &opts()).unwrap();
    // (0.9·1 + 0.3·3)/1.2 = 1.5 ; equal weights: 2 ; all zero: the plain mean 2.
    assert!((r.frf.values[0].re - 1.5e-6).abs() < 1e-20);
    assert!((r.frf.values[1].re - 4e-6).abs() < 1e-20);
    assert!((r.frf.values[2].re + 2e-6).abs() < 1e-20);
    assert!(
        r.notes
            .iter()
            .any(|n| n.contains("type 151") && n.contains("skipped")),
        "{:?}",
        r.notes
    );
    assert!(
        r.notes.iter().any(|n| n.contains("weighted")),
        "{:?}",
        r.notes
    );
    // Records of two pairs: a choice is needed, and --frf-record makes it.
    let rec6x = REC6X;
    let p = write(
        d.path(),
        "two.uff",
        &(record(REC6, AX_0, AX_0, &VALS) + &record(rec6x, AX_0, AX_0, &v2)),
    );
    let e = read_frf(&p, &opts()).unwrap_err().to_string();
    assert!(
        e.contains("--frf-record") && e.contains("response node 2"),
        "{e}"
    );
    let r = read_frf(
        &p,
        &FrfReadOptions {
            record: Some(2),
            ..opts()
        },
    )
    .unwrap();
    assert_eq!(r.frf.values[0].re, 3e-6);
    let e = read_frf(
        &p,
        &FrfReadOptions {
            record: Some(3),
            ..opts()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("[1, 2]"), "{e}");
}

#[test]
fn big_endian_and_single_precision_binary() {
    let d = tmp();
    let a = frf((1..=64).map(|i| 4.0 * i as f64).collect(), false);
    let p = d.path().join("le.uff");
    write_frf_uff(&p, &a, &Uff58Header::default(), true).unwrap();
    // Big endian: the same file with byte order 2 and every 8-byte value reversed.
    let mut file = read_uff(&p).unwrap();
    let bytes = std::fs::read(&p).unwrap();
    let text = String::from_utf8_lossy(&bytes);
    let id = text.find("    58b").unwrap();
    let line_end = id + bytes[id..].iter().position(|&b| b == b'\n').unwrap();
    let mut header_end = line_end;
    for _ in 0..11 {
        header_end += 1 + bytes[header_end + 1..]
            .iter()
            .position(|&b| b == b'\n')
            .unwrap();
    }
    let data_start = header_end + 1;
    let n = 64 * 2 * 8;
    let mut be = bytes.clone();
    be[id + 7..id + 13].copy_from_slice(b"     2");
    for k in 0..n / 8 {
        be[data_start + 8 * k..data_start + 8 * k + 8].reverse();
    }
    let q = d.path().join("be.uff");
    std::fs::write(&q, &be).unwrap();
    let b = read_frf(&q, &opts()).unwrap().frf;
    assert_eq!(a.values, b.values);
    // Single precision (data type 5), written and read: the values as f32.
    for f in &mut file.functions {
        f.ord_data_type = if f.is_complex() { 5 } else { 2 };
    }
    let s = d.path().join("single.uff");
    write_uff(&s, file.units.first(), &file.functions, true).unwrap();
    let b = read_frf(&s, &opts()).unwrap().frf;
    for i in 0..a.len() {
        assert_eq!(b.values[i].re, a.values[i].re as f32 as f64);
        assert_eq!(b.values[i].im, a.values[i].im as f32 as f64);
    }
    write_uff(&s, file.units.first(), &file.functions, false).unwrap();
    let b = read_frf(&s, &opts()).unwrap().frf;
    assert!((b.values[5] - a.values[5]).norm() <= 6e-6 * a.values[5].norm());
}

#[test]
fn plain_columns_with_units_and_layouts() {
    let d = tmp();
    let g = Complex64::new(2.0, -3.0);
    let cases: [(&str, FrfKind, f64); 8] = [
        ("m/N", FrfKind::Receptance, 1.0),
        ("mm/N", FrfKind::Receptance, 1e-3),
        ("µm/N", FrfKind::Receptance, 1e-6),
        ("in/lbf", FrfKind::Receptance, 0.0254 / 4.448_221_615_260_5),
        ("(m/s)/N", FrfKind::Mobility, 1.0),
        ("(m/s²)/N", FrfKind::Accelerance, 1.0),
        ("m/s^2/N", FrfKind::Accelerance, 1.0),
        ("g/N", FrfKind::Accelerance, 9.80665),
    ];
    // Mobility and accelerance of the same sign pattern are not passive: cross FRFs here.
    let p = write(d.path(), "a.csv", "# tap\nfreq,re,im\n10,2,-3\n20,2,-3\n");
    for (u, kind, fac) in cases {
        let o = FrfReadOptions {
            units: Some(u.into()),
            cross: true,
            ..opts()
        };
        let r = read_frf(&p, &o).unwrap();
        assert_eq!(r.frf.kind, kind, "{u}");
        assert!(
            (r.frf.values[0] - g * fac).norm() <= 1e-15 * fac * g.norm(),
            "{u}"
        );
    }
    let e = read_frf(
        &p,
        &FrfReadOptions {
            units: Some("furlong/N".into()),
            ..opts()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("furlong") && e.contains("in/lbf"), "{e}");
    // Magnitude and phase in degrees, whitespace separated, no header, with coherence.
    let p = write(d.path(), "b.txt", "10 2 -90 0.9\n20 1 -45 1\n");
    let r = read_frf(
        &p,
        &FrfReadOptions {
            columns: ColumnLayout::MagDeg,
            ..opts()
        },
    )
    .unwrap();
    assert!((r.frf.values[0] - Complex64::new(0.0, -2.0)).norm() < 1e-15);
    assert_eq!(r.frf.coherence.as_deref(), Some(&[0.9, 1.0][..]));
    assert!(r.notes.iter().any(|n| n.contains("SI")));
    // A header with phase in radians.
    let p = write(
        d.path(),
        "c.csv",
        "frequency_hz;phase_rad;mag\n10;-1.5707963267948966;2\n20;-1;1\n",
    );
    let r = read_frf(&p, &opts()).unwrap();
    assert!((r.frf.values[0] - Complex64::new(0.0, -2.0)).norm() < 1e-15);
}

/// `e` names `file` and every piece of `parts`.
fn names(e: &str, file: &str, parts: &[&str]) {
    assert!(e.contains(file), "{e}");
    for p in parts {
        assert!(e.contains(p), "{p:?} missing in: {e}");
    }
}

#[test]
fn bad_input_names_file_record_and_line() {
    let d = tmp();
    let good = record(REC6, AX_0, AX_0, &VALS);
    // Not UFF: a .uff file of text.
    let p = write(d.path(), "x.uff", "hello\n");
    names(
        &read_frf(&p, &opts()).unwrap_err().to_string(),
        "x.uff",
        &["line 1", "not a universal file"],
    );
    // Not UFF and not columns.
    let p = write(d.path(), "x.txt", "hello world\n1 2\n");
    names(
        &read_frf(&p, &opts()).unwrap_err().to_string(),
        "x.txt",
        &["line 1", "neither a universal file"],
    );
    let p = write(d.path(), "empty.uff", "");
    assert!(read_frf(&p, &opts()).is_err());
    // Truncated: the file ends inside record 12, or inside the header.
    let cut = &good[..good.len() - 48];
    let p = write(d.path(), "cut.uff", cut);
    names(
        &read_frf(&p, &opts()).unwrap_err().to_string(),
        "cut.uff",
        &["line 15", "truncated"],
    );
    let cut: String = good.lines().take(9).map(|l| format!("{l}\n")).collect();
    let p = write(d.path(), "cut2.uff", &cut);
    names(
        &read_frf(&p, &opts()).unwrap_err().to_string(),
        "cut2.uff",
        &["line 10", "record 8", "truncated"],
    );
    // The dataset closes before its values are all there.
    let short = good.replacen(
        &format!("{}{}\n", fmt_e(-1e-6, 20, 11), fmt_e(-3e-6, 20, 11)),
        "",
        1,
    );
    let p = write(d.path(), "short.uff", &short);
    names(
        &read_frf(&p, &opts()).unwrap_err().to_string(),
        "short.uff",
        &[
            "line 15",
            "dataset 1, record 12",
            "4 of the 6 values",
            "truncated",
        ],
    );
    // Non-finite values.
    let nan = good.replacen(&fmt_e(2e-6, 20, 11), "                 NaN", 1);
    let p = write(d.path(), "nan.uff", &nan);
    names(
        &read_frf(&p, &opts()).unwrap_err().to_string(),
        "nan.uff",
        &["line 14", "record 12", "point 2", "not finite"],
    );
    // Uneven abscissa that does not increase.
    let mut s = header58(
        REC6,
        &format!(
            "{:>10}{:>10}{:>10}{}{}{}",
            6,
            3,
            0,
            fmt_e(0.0, 13, 5),
            fmt_e(0.0, 13, 5),
            fmt_e(0.0, 13, 5)
        ),
        [AX_F, AX_0, AX_0, AX_0],
    );
    for (x, (a, b)) in [10.0, 20.0, 20.0].iter().zip(VALS) {
        s += &format!(
            "{}{}{}\n",
            fmt_e(*x, 13, 5),
            fmt_e(a, 20, 11),
            fmt_e(b, 20, 11)
        );
    }
    s += "    -1\n";
    let p = write(d.path(), "dec.uff", &s);
    names(
        &read_frf(&p, &opts()).unwrap_err().to_string(),
        "dec.uff",
        &["line 16", "point 3", "not above"],
    );
    // A header claiming 10^12 points: refused before anything is allocated.
    let huge = good.replacen(
        &format!("{:>10}{:>10}", 6, 3),
        &format!("{:>10}{:>10}", 6, 9_999_999_999u64),
        1,
    );
    let p = write(d.path(), "huge.uff", &huge);
    names(
        &read_frf(&p, &opts()).unwrap_err().to_string(),
        "huge.uff",
        &["line 9", "record 7", "9999999999"],
    );
    // A record field that is not a number, and an unknown data type.
    let bad6 = good.replacen(REC6, &REC6.replacen("    4", "    x", 1), 1);
    let p = write(d.path(), "f6.uff", &bad6);
    names(
        &read_frf(&p, &opts()).unwrap_err().to_string(),
        "f6.uff",
        &["line 8", "record 6", "function type"],
    );
    let bad7 = good.replacen(
        &format!("{:>10}{:>10}", 6, 3),
        &format!("{:>10}{:>10}", 7, 3),
        1,
    );
    let p = write(d.path(), "t7.uff", &bad7);
    names(
        &read_frf(&p, &opts()).unwrap_err().to_string(),
        "t7.uff",
        &["line 9", "record 7", "data type is 7"],
    );
    // Real data as an FRF.
    let real = good.replacen(
        &format!("{:>10}{:>10}", 6, 3),
        &format!("{:>10}{:>10}", 4, 6),
        1,
    );
    let p = write(d.path(), "real.uff", &real);
    names(
        &read_frf(&p, &opts()).unwrap_err().to_string(),
        "real.uff",
        &["record 7", "real-valued"],
    );
    // Passivity failure (a reversed hammer).
    let neg: Vec<(f64, f64)> = VALS.iter().map(|&(a, b)| (-a, -b)).collect();
    let p = write(d.path(), "neg.uff", &record(REC6, AX_0, AX_0, &neg));
    names(
        &read_frf(&p, &opts()).unwrap_err().to_string(),
        "neg.uff",
        &["passivity", "Im G ≤ 0", "negate"],
    );

    // Binary: a byte count that does not match, and a truncated data block.
    let a = frf((1..=16).map(|i| 4.0 * i as f64).collect(), false);
    let b = d.path().join("b.uff");
    write_frf_uff(&b, &a, &Uff58Header::default(), true).unwrap();
    let bytes = std::fs::read(&b).unwrap();
    let text = String::from_utf8_lossy(&bytes).to_string();
    let id_at = text.find("    58b").unwrap();
    let mut wrong = bytes.clone();
    // 16 points × 2 × 8 = 256 bytes; announce 264.
    let field = id_at + 7 + 12 + 12;
    assert_eq!(&wrong[field..field + 12], b"         256");
    wrong[field..field + 12].copy_from_slice(b"         264");
    // Data that end where record 7 says are read (some writers, pyuff among them, give the
    // byte count of real data for complex data), with a note.
    let p = d.path().join("count_ok.uff");
    std::fs::write(&p, &wrong).unwrap();
    let r = read_frf(&p, &opts()).unwrap();
    assert!(
        r.notes.iter().any(|n| n.contains("announces 264")),
        "{:?}",
        r.notes
    );
    // Data that do not: refused.
    let end = wrong.len() - 7;
    wrong.splice(end..end, [0u8; 8]);
    let p = d.path().join("count.uff");
    std::fs::write(&p, &wrong).unwrap();
    names(
        &read_frf(&p, &opts()).unwrap_err().to_string(),
        "count.uff",
        &["line 8", "264", "needs 256"],
    );
    let p = d.path().join("tb.uff");
    std::fs::write(&p, &bytes[..bytes.len() - 100]).unwrap();
    names(
        &read_frf(&p, &opts()).unwrap_err().to_string(),
        "tb.uff",
        &["record 12", "truncated", "byte"],
    );
    // A NaN inside the binary data: named by its byte offset.
    let mut nanb = bytes.clone();
    let data_at = bytes.len() - 7 - 256;
    nanb[data_at + 16..data_at + 24].copy_from_slice(&f64::NAN.to_le_bytes());
    let p = d.path().join("nanb.uff");
    std::fs::write(&p, &nanb).unwrap();
    names(
        &read_frf(&p, &opts()).unwrap_err().to_string(),
        "nanb.uff",
        &[&format!("byte {}", data_at + 16), "point 2", "not finite"],
    );
    // Columns: non-increasing, non-numeric and non-finite lines.
    let p = write(d.path(), "c.csv", "freq,re,im\n10,1,-1\n9,1,-1\n");
    names(
        &read_frf(&p, &opts()).unwrap_err().to_string(),
        "c.csv",
        &["line 3", "not above"],
    );
    let p = write(d.path(), "c2.csv", "freq,re,im\n10,1,-1\n11,x,-1\n");
    names(
        &read_frf(&p, &opts()).unwrap_err().to_string(),
        "c2.csv",
        &["line 3, column 2", "not a number"],
    );
    let p = write(d.path(), "c3.csv", "freq,re,im\n10,1,-1\n11,inf,-1\n");
    names(
        &read_frf(&p, &opts()).unwrap_err().to_string(),
        "c3.csv",
        &["line 3, column 2", "not finite"],
    );
}
