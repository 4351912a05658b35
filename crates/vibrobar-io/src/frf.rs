//! Measured FRFs in and out: [`read_frf`] turns a universal file (datasets 58/58b with 164,
//! [`crate::uff`]) or plain columns into a checked [`MeasuredFrf`] in SI units, and
//! [`write_frf_uff`] writes one as dataset 58 or 58b.
//!
//! **Plain columns** (CSV, semicolon, tab or blank separated; `#`, `%` and `//` lines are
//! comments): frequency in Hz, then the real and imaginary parts or the magnitude and phase,
//! optionally a coherence. A header line names the columns (`freq`/`frequency_hz`, `re`/`real`,
//! `im`/`imag`, `mag`/`abs`, `phase_deg` or `phase_rad`, `coherence`); without one the layout
//! is [`FrfReadOptions::columns`]. The units are [`FrfReadOptions::units`] (`--units`): m/N,
//! mm/N, µm/N, in/lbf, (m/s)/N, (m/s²)/N or g/N, which also give the kind.
//!
//! **Units of a universal file**, in this order: the units labels of records 9 and 10 (e.g.
//! `m/s^2` over `N`, `g` over `N`, or `mm/N` alone), then dataset 164 with the unit exponents
//! of records 9 and 10 (`SI = file / (length^a · force^b)`, `a`, `b` the exponents of the
//! ordinate over its denominator; where both exponents are 0 but the specific data types say
//! displacement, velocity or acceleration over force, those types' exponents), else SI, and the
//! note says which ([`MeasuredFrf::units_note`]). The kind comes from the ordinate's specific
//! data type (8, 11, 12) or its units, else from [`FrfReadOptions::kind`], else receptance is
//! assumed and said. A response or reference direction of negative sign (`−3` is `−Z`) flips the
//! sign of the FRF.
//!
//! **Several records.** FRF records (function type 4) of one response/reference pair are
//! repeated taps: they are averaged, weighted by coherence where each has a coherence record
//! (function type 6) of the same pair, matched in file order. Records of different pairs need
//! [`FrfReadOptions::record`] (`--frf-record`).

use crate::error::{IoError, Result};
use crate::uff::{self, bad, AxisSpec, UffFile, UffFunction, Units164, FUNC_COHERENCE, FUNC_FRF};
use num_complex::Complex64;
use std::f64::consts::PI;
use std::path::Path;
use vibrobar_core::structure::frf_data::{FrfDataError, FrfKind, MeasuredFrf, MAX_FRF_LINES};

/// Standard gravity, m/s² (the `g` of `g/N`).
pub const STANDARD_GRAVITY: f64 = 9.80665;
/// One inch, m.
pub const INCH_M: f64 = 0.0254;
/// One pound-force, N.
pub const LBF_N: f64 = 4.448_221_615_260_5;

/// The units `--units` accepts, as users type them.
pub const PLAIN_UNITS: &str = "m/N, mm/N, µm/N (um/N), in/lbf, (m/s)/N, (m/s²)/N (m/s^2/N), g/N";

/// How plain columns hold the complex values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ColumnLayout {
    /// Frequency, real part, imaginary part.
    #[default]
    ReIm,
    /// Frequency, magnitude, phase in degrees.
    MagDeg,
    /// Frequency, magnitude, phase in radians.
    MagRad,
}

impl ColumnLayout {
    /// Parse `re-im`, `mag-deg`, `mag-rad`.
    pub fn parse(s: &str) -> Option<ColumnLayout> {
        match s.trim().to_ascii_lowercase().as_str() {
            "re-im" | "reim" => Some(ColumnLayout::ReIm),
            "mag-deg" | "mag-phase" => Some(ColumnLayout::MagDeg),
            "mag-rad" => Some(ColumnLayout::MagRad),
            _ => None,
        }
    }
}

/// How to read a measured FRF.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FrfReadOptions {
    /// Units of plain columns (`--units`, [`PLAIN_UNITS`]); for a universal file, units that
    /// replace the file's.
    pub units: Option<String>,
    /// The kind, where the file does not say (an error where it says otherwise).
    pub kind: Option<FrfKind>,
    /// Layout of plain columns without a header.
    pub columns: ColumnLayout,
    /// The FRF record to take from a universal file (1-based among its FRF records).
    pub record: Option<usize>,
    /// Conjugate the values (an FRF written under `e^{−iωt}`).
    pub conjugate: bool,
    /// Negate the values (a reversed hammer or sensor).
    pub negate: bool,
    /// Mass of the accelerometer to cancel, kg.
    pub accelerometer_mass_kg: Option<f64>,
    /// Treat plain columns as a cross FRF (no passivity check).
    pub cross: bool,
}

/// A measured FRF read from a file, with what the reader did.
#[derive(Debug, Clone, PartialEq)]
pub struct FrfRead {
    /// The FRF, SI units.
    pub frf: MeasuredFrf,
    /// Notes for the user (units assumed, records skipped or averaged, signs flipped).
    pub notes: Vec<String>,
    /// `uff58`, `uff58b` or `columns`.
    pub format: &'static str,
}

/// Parse an FRF unit (`--units`, or a units label of a universal file): its kind and the
/// factor to SI.
pub fn parse_frf_units(text: &str) -> Option<(FrfKind, f64)> {
    let (num, den) = split_units(text)?;
    let (kind, a) = parse_response_unit(num)?;
    let f = parse_force_unit(den)?;
    Some((kind, a / f))
}

/// Normalise a unit text: lower case, no blanks, `²`/`^2`/`**2` → `2`, `µ`/`μ` → `u`.
fn norm_unit(s: &str) -> String {
    s.trim()
        .to_lowercase()
        .replace(['µ', 'μ'], "u")
        .replace('²', "2")
        .replace("^2", "2")
        .replace("**2", "2")
        .replace("sec", "s")
        .chars()
        .filter(|c| !c.is_whitespace())
        .collect()
}

/// `num/den` of an FRF unit: `(m/s)/N`, `m/s/N`, `m/s2/N`, `mm/N`.
fn split_units(text: &str) -> Option<(String, String)> {
    let t = norm_unit(text);
    let (num, den) = t.rsplit_once('/')?;
    let num = num
        .trim_start_matches('(')
        .trim_end_matches(')')
        .to_string();
    Some((num, den.to_string()))
}

/// A response unit: its kind and factor to m, m/s or m/s².
fn parse_response_unit(u: impl AsRef<str>) -> Option<(FrfKind, f64)> {
    let u = norm_unit(u.as_ref());
    let u = u.trim_start_matches('(').trim_end_matches(')');
    Some(match u {
        "m" => (FrfKind::Receptance, 1.0),
        "mm" => (FrfKind::Receptance, 1e-3),
        "um" | "micron" => (FrfKind::Receptance, 1e-6),
        "in" | "inch" => (FrfKind::Receptance, INCH_M),
        "m/s" => (FrfKind::Mobility, 1.0),
        "mm/s" => (FrfKind::Mobility, 1e-3),
        "in/s" => (FrfKind::Mobility, INCH_M),
        "m/s2" => (FrfKind::Accelerance, 1.0),
        "mm/s2" => (FrfKind::Accelerance, 1e-3),
        "in/s2" => (FrfKind::Accelerance, INCH_M),
        "g" => (FrfKind::Accelerance, STANDARD_GRAVITY),
        _ => return None,
    })
}

/// A force unit: its factor to N.
fn parse_force_unit(u: impl AsRef<str>) -> Option<f64> {
    Some(match norm_unit(u.as_ref()).as_str() {
        "n" => 1.0,
        "kn" => 1e3,
        "lbf" | "lb" => LBF_N,
        _ => return None,
    })
}

/// Kind from a specific data type of record 9.
fn kind_of_data_type(t: i64) -> Option<FrfKind> {
    match t {
        8 => Some(FrfKind::Receptance),
        11 => Some(FrfKind::Mobility),
        12 => Some(FrfKind::Accelerance),
        _ => None,
    }
}

/// Whether a label says nothing.
fn empty_label(s: &str) -> bool {
    let t = s.trim();
    t.is_empty() || t.eq_ignore_ascii_case("none")
}

/// Read a measured FRF: a universal file (first line `-1`) or plain columns; then the
/// options' corrections, and the passivity check of a driving point.
pub fn read_frf(path: &Path, opts: &FrfReadOptions) -> Result<FrfRead> {
    let bytes = uff::read_bytes(path)?;
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let mut read = if uff::looks_like_uff(&bytes) {
        let file = uff::parse_uff(path, &bytes)?;
        frf_from_uff(path, &file, opts)?
    } else if matches!(ext.as_deref(), Some("uff" | "unv" | "uf")) {
        let first = bytes
            .split(|&b| b == b'\n')
            .map(|l| String::from_utf8_lossy(l).trim().to_string())
            .find(|l| !l.is_empty())
            .unwrap_or_default();
        return Err(bad(
            path,
            "line 1",
            format!(
                "not a universal file (UFF): the first line should be \"    -1\", found {:?}",
                first.chars().take(60).collect::<String>()
            ),
        ));
    } else {
        read_columns(path, &bytes, opts)?
    };
    let data_err = |e: FrfDataError| bad(path, "", e.to_string());
    if opts.conjugate {
        read.frf = read.frf.conjugated();
        read.notes
            .push("values conjugated (--frf-conjugate)".into());
    }
    if opts.negate {
        read.frf = read.frf.negated();
        read.notes.push("values negated (--frf-negate)".into());
    }
    if let Some(m) = opts.accelerometer_mass_kg {
        read.frf = read.frf.cancel_accelerometer_mass(m).map_err(data_err)?;
        read.notes.push(format!(
            "accelerometer mass {m} kg cancelled: H = H_m/(1 + m_a ω² H_m) in receptance terms"
        ));
    }
    let p = read.frf.check_passivity().map_err(data_err)?;
    if read.frf.driving_point && p.wrong_lines > 0 {
        read.notes.push(format!(
            "passivity: {} line(s) with {} broken, {:.2} % of the dissipative part (noise)",
            p.wrong_lines,
            read.frf.kind.passivity_condition(),
            100.0 * p.wrong_share
        ));
    }
    Ok(read)
}

/// The response/reference pair of a record, for grouping.
fn pair(f: &UffFunction) -> (String, i64, i64, String, i64, i64) {
    (
        f.rsp_entity.trim().to_ascii_lowercase(),
        f.rsp_node,
        f.rsp_dir.abs(),
        f.ref_entity.trim().to_ascii_lowercase(),
        f.ref_node,
        f.ref_dir.abs(),
    )
}

/// The FRF of a universal file (module docs).
pub fn frf_from_uff(path: &Path, file: &UffFile, opts: &FrfReadOptions) -> Result<FrfRead> {
    let mut notes = file.notes.clone();
    let frfs: Vec<&UffFunction> = file
        .functions
        .iter()
        .filter(|f| f.func_type == FUNC_FRF)
        .collect();
    let cohs: Vec<&UffFunction> = file
        .functions
        .iter()
        .filter(|f| f.func_type == FUNC_COHERENCE)
        .collect();
    for f in &file.functions {
        if f.func_type != FUNC_FRF && f.func_type != FUNC_COHERENCE {
            notes.push(format!(
                "{} skipped: function type {} is neither an FRF (4) nor a coherence (6)",
                f.describe(),
                f.func_type
            ));
        }
    }
    if frfs.is_empty() {
        return Err(bad(
            path,
            "",
            format!(
                "no FRF record (dataset 58 with function type 4) in the file; it holds {} dataset-58 record(s) of function types {:?}",
                file.functions.len(),
                file.functions.iter().map(|f| f.func_type).collect::<Vec<_>>()
            ),
        ));
    }
    let chosen: Vec<&UffFunction> = match opts.record {
        Some(k) => {
            if k == 0 || k > frfs.len() {
                return Err(bad(
                    path,
                    "",
                    format!(
                        "--frf-record {k} is outside [1, {}]: the file holds {} FRF record(s)",
                        frfs.len(),
                        frfs.len()
                    ),
                ));
            }
            vec![frfs[k - 1]]
        }
        None => {
            let p0 = pair(frfs[0]);
            if frfs.iter().any(|f| pair(f) != p0) {
                let list: Vec<String> = frfs
                    .iter()
                    .enumerate()
                    .map(|(i, f)| format!("  {}: {}", i + 1, f.describe()))
                    .collect();
                return Err(bad(
                    path,
                    "",
                    format!(
                        "the file holds FRF records of different response/reference pairs; choose one with --frf-record N:\n{}",
                        list.join("\n")
                    ),
                ));
            }
            frfs.clone()
        }
    };
    // Coherences of the chosen pair, matched in order.
    let p0 = pair(chosen[0]);
    let same_pair_frfs: Vec<&&UffFunction> = frfs.iter().filter(|f| pair(f) == p0).collect();
    let pair_cohs: Vec<&&UffFunction> = cohs.iter().filter(|f| pair(f) == p0).collect();
    let coh_for = |f: &UffFunction| -> Option<&UffFunction> {
        if pair_cohs.len() == same_pair_frfs.len() {
            let k = same_pair_frfs.iter().position(|g| std::ptr::eq(**g, f))?;
            Some(*pair_cohs[k])
        } else if pair_cohs.len() == 1 {
            Some(*pair_cohs[0])
        } else {
            None
        }
    };
    if !pair_cohs.is_empty() && pair_cohs.len() != same_pair_frfs.len() && pair_cohs.len() != 1 {
        notes.push(format!(
            "{} coherence record(s) for {} FRF record(s) of the pair: coherences not used",
            pair_cohs.len(),
            same_pair_frfs.len()
        ));
    }
    let mut records = Vec::with_capacity(chosen.len());
    let mut unit_note = String::new();
    let mut sign_note = None;
    for f in &chosen {
        let (frf, note, sign) = convert_function(path, file, f, coh_for(f), opts)?;
        unit_note = note;
        if sign.is_some() {
            sign_note = sign;
        }
        records.push(frf);
    }
    notes.push(format!("units: {unit_note}"));
    if let Some(s) = sign_note {
        notes.push(s);
    }
    let frf = if records.len() == 1 {
        records.pop().expect("one record")
    } else {
        notes.push(format!(
            "{} FRF records of one response/reference pair averaged{}",
            records.len(),
            if records.iter().all(|r| r.coherence.is_some()) {
                ", weighted by their coherence"
            } else {
                " (not all have a coherence: unweighted)"
            }
        ));
        MeasuredFrf::average(&records).map_err(|e| bad(path, "", e.to_string()))?
    };
    let format = if chosen[0].binary.is_some() {
        "uff58b"
    } else {
        "uff58"
    };
    Ok(FrfRead { frf, notes, format })
}

/// One dataset-58 FRF record in SI, with its units note and sign note.
fn convert_function(
    path: &Path,
    file: &UffFile,
    f: &UffFunction,
    coh: Option<&UffFunction>,
    opts: &FrfReadOptions,
) -> Result<(MeasuredFrf, String, Option<String>)> {
    let at = |what: &str| format!("{} ({what})", f.describe());
    if !f.is_complex() {
        return Err(bad(
            path,
            at("record 7"),
            format!(
                "the FRF is real-valued (ordinate data type {}); an FRF needs complex data (type 5 or 6)",
                f.ord_data_type
            ),
        ));
    }
    // Abscissa: frequency in Hz (or rad/s by its label).
    let ab = &f.axes[0];
    if ab.data_type == 17 {
        return Err(bad(
            path,
            at("record 8"),
            "the abscissa is time (specific data type 17): this is not a frequency-domain function",
        ));
    }
    let x_scale = match norm_unit(&ab.units_label).as_str() {
        "rad/s" => 1.0 / (2.0 * PI),
        "" | "none" | "hz" | "1/s" => 1.0,
        other => {
            return Err(bad(
                path,
                at("record 8"),
                format!("the abscissa units label is {other:?}; allowed Hz (or NONE) or rad/s"),
            ))
        }
    };
    let (kind, factor, note) = units_of(path, file, f, opts)?;
    let sign = if f.rsp_dir < 0 { -1.0 } else { 1.0 } * if f.ref_dir < 0 { -1.0 } else { 1.0 };
    let sign_note = (sign < 0.0).then(|| {
        format!(
            "sign flipped: response direction {:+}, reference direction {:+} (a negative direction code points the other way)",
            f.rsp_dir, f.ref_dir
        )
    });
    let freqs: Vec<f64> = f.x.iter().map(|x| x * x_scale).collect();
    let values: Vec<Complex64> = f.y.iter().map(|y| y * (sign * factor)).collect();
    let coherence = match coh {
        None => None,
        Some(c) => {
            let close = c.x.len() == f.x.len()
                && c.x
                    .iter()
                    .zip(&f.x)
                    .all(|(a, b)| (a - b).abs() <= 1e-9 * a.abs().max(b.abs()));
            if !close {
                return Err(bad(
                    path,
                    c.describe(),
                    format!(
                        "the coherence has other frequency lines ({} points) than its FRF, {} ({} points)",
                        c.x.len(),
                        f.describe(),
                        f.x.len()
                    ),
                ));
            }
            let g: Vec<f64> = c.y.iter().map(|v| v.re).collect();
            if let Some(k) = g.iter().position(|v| !(0.0..=1.0).contains(v)) {
                return Err(bad(
                    path,
                    format!(
                        "{} (dataset {}, record 12, point {})",
                        c.sources[k],
                        c.dataset,
                        k + 1
                    ),
                    format!("the coherence is {}; allowed [0, 1]", g[k]),
                ));
            }
            Some(g)
        }
    };
    let driving = pair_is_driving(f);
    let frf =
        MeasuredFrf::new(freqs, values, kind, coherence, driving, note.clone()).map_err(|e| {
            let loc = e
                .index()
                .and_then(|i| f.sources.get(i))
                .map(|s| format!("{s} ({}, record 12)", at("data")))
                .unwrap_or_else(|| at("record 12"));
            bad(path, loc, e.to_string())
        })?;
    Ok((frf, note, sign_note))
}

/// Force and response at one node and direction.
fn pair_is_driving(f: &UffFunction) -> bool {
    f.rsp_node == f.ref_node
        && f.rsp_dir.abs() == f.ref_dir.abs()
        && f.rsp_entity
            .trim()
            .eq_ignore_ascii_case(f.ref_entity.trim())
}

/// Kind, factor to SI and note for a record (module docs).
fn units_of(
    path: &Path,
    file: &UffFile,
    f: &UffFunction,
    opts: &FrfReadOptions,
) -> Result<(FrfKind, f64, String)> {
    let at = |r: &str| format!("{} ({r})", f.describe());
    let (num, den) = (&f.axes[1], &f.axes[2]);
    let type_kind = kind_of_data_type(num.data_type);
    // Units: an override, then labels, then dataset 164, then SI.
    let (label_kind, factor, note): (Option<FrfKind>, f64, String) = if let Some(u) = &opts.units {
        let (k, fac) = parse_frf_units(u).ok_or_else(|| {
            bad(
                path,
                "--units",
                format!("{u:?} is not an FRF unit; allowed {PLAIN_UNITS}"),
            )
        })?;
        (Some(k), fac, format!("{u} (--units, replacing the file's)"))
    } else if let Some((k, fac, how)) = label_units(num, den) {
        (
            Some(k),
            fac,
            format!("{how} (units labels of records 9–10)"),
        )
    } else if let Some(u) = file.units_for(f) {
        let (a, b, inferred) = exponents(num, den);
        let fac = 1.0 / (u.length.powi(a as i32) * u.force.powi(b as i32));
        if !(fac.is_finite() && fac > 0.0) {
            return Err(bad(
                path,
                at("records 9–10"),
                format!("the unit exponents {a} (length) and {b} (force) overflow with the factors of dataset {}", u.dataset),
            ));
        }
        (
            None,
            fac,
            format!(
                "dataset 164 (dataset {}, code {} {:?}: length factor {}, force factor {}) with length exponent {a} and force exponent {b}{}",
                u.dataset,
                u.code,
                u.description,
                u.length,
                u.force,
                if inferred { " (from the specific data types: the records give none)" } else { " (records 9–10)" }
            ),
        )
    } else {
        (
            None,
            1.0,
            "none in the file (no units labels, no dataset 164): SI assumed (m, N, s)".to_string(),
        )
    };
    if let (Some(a), Some(b)) = (type_kind, label_kind) {
        if a != b {
            return Err(bad(
                path,
                at("record 9"),
                format!(
                    "the specific data type {} says {}, the units say {}",
                    num.data_type,
                    a.name(),
                    b.name()
                ),
            ));
        }
    }
    let file_kind = type_kind.or(label_kind);
    let (kind, kind_note) = match (file_kind, opts.kind) {
        (Some(a), Some(b)) if a != b => {
            return Err(bad(
                path,
                at("record 9"),
                format!("the file says {}, --frf-type says {}", a.name(), b.name()),
            ))
        }
        (Some(a), _) => (a, format!("{} (from the file)", a.name())),
        (None, Some(b)) => (b, format!("{} (--frf-type)", b.name())),
        (None, None) => (
            FrfKind::Receptance,
            "receptance assumed (the file does not say; give --frf-type)".to_string(),
        ),
    };
    Ok((
        kind,
        factor,
        format!("{note}; {kind_note}, {}", kind.si_unit()),
    ))
}

/// From the units labels of records 9 and 10: kind, factor and how it was read.
fn label_units(num: &AxisSpec, den: &AxisSpec) -> Option<(FrfKind, f64, String)> {
    if empty_label(&num.units_label) {
        return None;
    }
    if empty_label(&den.units_label) {
        let (k, f) = parse_frf_units(&num.units_label)?;
        return Some((k, f, num.units_label.trim().to_string()));
    }
    let (k, a) = parse_response_unit(&num.units_label)?;
    let f = parse_force_unit(&den.units_label)?;
    Some((
        k,
        a / f,
        format!("{} / {}", num.units_label.trim(), den.units_label.trim()),
    ))
}

/// Length and force exponents of ordinate over denominator; inferred from the data types
/// where the records give none.
fn exponents(num: &AxisSpec, den: &AxisSpec) -> (i64, i64, bool) {
    let (a, b) = (
        num.length_exp - den.length_exp,
        num.force_exp - den.force_exp,
    );
    let none_given =
        num.length_exp == 0 && num.force_exp == 0 && den.length_exp == 0 && den.force_exp == 0;
    if none_given && kind_of_data_type(num.data_type).is_some() && matches!(den.data_type, 9 | 13) {
        (1, -1, true)
    } else {
        (a, b, false)
    }
}

// ---------------------------------------------------------------------------------------------
// plain columns

/// Which quantity a column holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Col {
    Freq,
    Re,
    Im,
    Mag,
    PhaseDeg,
    PhaseRad,
    Coherence,
}

fn column_of(name: &str) -> Option<Col> {
    let n = name.trim().trim_matches('"').to_ascii_lowercase();
    let n = n.as_str();
    let starts = |p: &str| {
        n == p
            || n.starts_with(&format!("{p}_"))
            || n.starts_with(&format!("{p} "))
            || n.starts_with(&format!("{p}("))
    };
    if starts("freq") || starts("frequency") || n == "f" || n == "hz" || n == "f_hz" {
        Some(Col::Freq)
    } else if starts("re") || starts("real") {
        Some(Col::Re)
    } else if starts("im") || starts("imag") {
        Some(Col::Im)
    } else if starts("mag") || starts("magnitude") || starts("abs") || starts("amplitude") {
        Some(Col::Mag)
    } else if starts("phase") || starts("arg") {
        Some(if n.contains("rad") {
            Col::PhaseRad
        } else {
            Col::PhaseDeg
        })
    } else if starts("coh") || starts("coherence") || starts("gamma2") {
        Some(Col::Coherence)
    } else {
        None
    }
}

/// Split a data line on commas, semicolons, tabs or blanks.
fn split_line(t: &str) -> Vec<&str> {
    if t.contains(',') {
        t.split(',').map(str::trim).collect()
    } else if t.contains(';') {
        t.split(';').map(str::trim).collect()
    } else {
        t.split_whitespace().collect()
    }
}

/// Plain columns (module docs).
fn read_columns(path: &Path, bytes: &[u8], opts: &FrfReadOptions) -> Result<FrfRead> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        bad(
            path,
            format!("byte {}", e.valid_up_to()),
            "neither a universal file (UFF, first line \"    -1\") nor text columns (not UTF-8 text)",
        )
    })?;
    let mut cols: Option<Vec<Option<Col>>> = None;
    let mut freqs = Vec::new();
    let mut values = Vec::new();
    let mut coh: Vec<f64> = Vec::new();
    let mut lines: Vec<usize> = Vec::new();
    let mut notes = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let ln = i + 1;
        let t = raw.trim();
        if t.is_empty() || t.starts_with('#') || t.starts_with('%') || t.starts_with("//") {
            continue;
        }
        let toks = split_line(t);
        if cols.is_none() {
            if toks.iter().any(|s| s.parse::<f64>().is_err()) {
                let named: Vec<Option<Col>> = toks.iter().map(|s| column_of(s)).collect();
                let has = |c: Col| named.contains(&Some(c));
                let ok = has(Col::Freq)
                    && ((has(Col::Re) && has(Col::Im))
                        || (has(Col::Mag) && (has(Col::PhaseDeg) || has(Col::PhaseRad))));
                if !ok {
                    return Err(bad(
                        path,
                        format!("line {ln}"),
                        format!(
                            "neither a universal file (UFF, first line \"    -1\") nor FRF columns: the header {:?} must name a frequency column (freq, frequency_hz) and re/im or mag/phase_deg/phase_rad columns (optionally coherence)",
                            t.chars().take(80).collect::<String>()
                        ),
                    ));
                }
                // Re/Im win over Mag/Phase when both are present.
                let reim = has(Col::Re) && has(Col::Im);
                let named = named
                    .into_iter()
                    .map(|c| match c {
                        Some(Col::Mag | Col::PhaseDeg | Col::PhaseRad) if reim => None,
                        c => c,
                    })
                    .collect();
                cols = Some(named);
                continue;
            }
            let layout: Vec<Option<Col>> = match opts.columns {
                ColumnLayout::ReIm => vec![Some(Col::Freq), Some(Col::Re), Some(Col::Im)],
                ColumnLayout::MagDeg => vec![Some(Col::Freq), Some(Col::Mag), Some(Col::PhaseDeg)],
                ColumnLayout::MagRad => vec![Some(Col::Freq), Some(Col::Mag), Some(Col::PhaseRad)],
            };
            let mut layout = layout;
            if toks.len() == 4 {
                layout.push(Some(Col::Coherence));
            }
            if toks.len() != 3 && toks.len() != 4 {
                return Err(bad(
                    path,
                    format!("line {ln}"),
                    format!(
                        "a line of FRF columns without a header has 3 or 4 fields (frequency, two parts of the value, optional coherence); this one has {}",
                        toks.len()
                    ),
                ));
            }
            cols = Some(layout);
        }
        let layout = cols.as_ref().expect("set above");
        if toks.len() != layout.len() {
            return Err(bad(
                path,
                format!("line {ln}"),
                format!("{} fields, the first line has {}", toks.len(), layout.len()),
            ));
        }
        if freqs.len() >= MAX_FRF_LINES {
            return Err(bad(
                path,
                format!("line {ln}"),
                format!("more than {MAX_FRF_LINES} lines of data"),
            ));
        }
        let (mut f, mut a, mut b, mut g) = (f64::NAN, f64::NAN, f64::NAN, None);
        let mut polar = false;
        for (k, (tok, c)) in toks.iter().zip(layout).enumerate() {
            let Some(c) = c else { continue };
            let v: f64 = tok.parse().map_err(|_| {
                bad(
                    path,
                    format!("line {ln}, column {}", k + 1),
                    format!("{tok:?} is not a number"),
                )
            })?;
            if !v.is_finite() {
                return Err(bad(
                    path,
                    format!("line {ln}, column {}", k + 1),
                    format!("{tok:?} is not finite"),
                ));
            }
            match c {
                Col::Freq => f = v,
                Col::Re => a = v,
                Col::Im => b = v,
                Col::Mag => {
                    a = v;
                    polar = true;
                }
                Col::PhaseDeg => {
                    b = v.to_radians();
                    polar = true;
                }
                Col::PhaseRad => {
                    b = v;
                    polar = true;
                }
                Col::Coherence => g = Some(v),
            }
        }
        let z = if polar {
            Complex64::from_polar(a, b)
        } else {
            Complex64::new(a, b)
        };
        freqs.push(f);
        values.push(z);
        if let Some(g) = g {
            coh.push(g);
        }
        lines.push(ln);
    }
    if freqs.is_empty() {
        return Err(bad(
            path,
            "",
            "no data lines (an empty file, or comments only)",
        ));
    }
    let (kind, factor, note) = match &opts.units {
        Some(u) => {
            let (k, fac) = parse_frf_units(u).ok_or_else(|| {
                bad(
                    path,
                    "--units",
                    format!("{u:?} is not an FRF unit; allowed {PLAIN_UNITS}"),
                )
            })?;
            if let Some(k2) = opts.kind {
                if k2 != k {
                    return Err(bad(
                        path,
                        "--frf-type",
                        format!(
                            "--units {u} is a {}, --frf-type says {}",
                            k.name(),
                            k2.name()
                        ),
                    ));
                }
            }
            (k, fac, format!("{u} (--units); {}", k.name()))
        }
        None => {
            let k = opts.kind.unwrap_or(FrfKind::Receptance);
            notes.push(format!(
                "no --units: values taken as SI, {} in {}{}",
                k.name(),
                k.si_unit(),
                if opts.kind.is_none() {
                    " (receptance assumed; give --frf-type)"
                } else {
                    ""
                }
            ));
            (k, 1.0, format!("SI assumed; {}", k.name()))
        }
    };
    notes.push(format!("units: {note}"));
    let values: Vec<Complex64> = values.iter().map(|v| v * factor).collect();
    let coherence = (!coh.is_empty()).then_some(coh);
    let frf = MeasuredFrf::new(freqs, values, kind, coherence, !opts.cross, note).map_err(|e| {
        let loc = e
            .index()
            .and_then(|i| lines.get(i))
            .map(|l| format!("line {l}"))
            .unwrap_or_default();
        bad(path, loc, e.to_string())
    })?;
    Ok(FrfRead {
        frf,
        notes,
        format: "columns",
    })
}

// ---------------------------------------------------------------------------------------------
// writing

/// What [`write_frf_uff`] puts in the header.
#[derive(Debug, Clone, PartialEq)]
pub struct Uff58Header {
    /// ID line 1 (the description).
    pub description: String,
    /// Response node.
    pub rsp_node: i64,
    /// Response direction (signed).
    pub rsp_dir: i64,
    /// Reference node.
    pub ref_node: i64,
    /// Reference direction (signed).
    pub ref_dir: i64,
}

impl Default for Uff58Header {
    fn default() -> Self {
        Uff58Header {
            description: "vibrobar FRF".into(),
            rsp_node: 1,
            rsp_dir: 3,
            ref_node: 1,
            ref_dir: 3,
        }
    }
}

/// The dataset-58 records of `frf` (its FRF, and its coherence if any), in SI with the units
/// labels and exponents of its kind.
pub fn uff_functions(frf: &MeasuredFrf, h: &Uff58Header) -> Vec<UffFunction> {
    let f = &frf.freqs_hz;
    // Even when every line is start + i·step with a start and step of 6 significant digits
    // (record 7 keeps E13.5): then the lines read back bit for bit.
    let s6 = uff::round_e13_5(f[0]);
    let d6 = uff::round_e13_5(f[1] - f[0]);
    let even = f
        .iter()
        .enumerate()
        .all(|(i, &x)| x.to_bits() == (s6 + i as f64 * d6).to_bits())
        .then_some((s6, d6));
    let (type_code, unit) = match frf.kind {
        FrfKind::Receptance => (8, "m"),
        FrfKind::Mobility => (11, "m/s"),
        FrfKind::Accelerance => (12, "m/s^2"),
    };
    let axis = |t: i64, l: i64, fo: i64, lab: &str, u: &str| AxisSpec {
        data_type: t,
        length_exp: l,
        force_exp: fo,
        temp_exp: 0,
        label: lab.into(),
        units_label: u.into(),
    };
    let base = |func_type: i64, ord: i64, ord_axis: AxisSpec, den: AxisSpec, y: Vec<Complex64>| {
        UffFunction {
            dataset: 0,
            start_line: 0,
            binary: None,
            ids: [
                h.description.clone(),
                frf.kind.name().to_string(),
                "NONE".into(),
                "NONE".into(),
                "NONE".into(),
            ],
            func_type,
            func_id: 0,
            version: 0,
            load_case: 0,
            rsp_entity: "NONE".into(),
            rsp_node: h.rsp_node,
            rsp_dir: h.rsp_dir,
            ref_entity: "NONE".into(),
            ref_node: h.ref_node,
            ref_dir: h.ref_dir,
            ord_data_type: ord,
            even,
            z_axis_value: 0.0,
            axes: [
                axis(18, 0, 0, "Frequency", "Hz"),
                ord_axis,
                den,
                AxisSpec::default(),
            ],
            x: f.clone(),
            y,
            sources: Vec::new(),
        }
    };
    // The file's signs: a negative direction product flips the stored values back.
    let sign = if h.rsp_dir < 0 { -1.0 } else { 1.0 } * if h.ref_dir < 0 { -1.0 } else { 1.0 };
    let mut out = vec![base(
        FUNC_FRF,
        6,
        axis(type_code, 1, 0, frf.kind.name(), unit),
        axis(13, 0, 1, "Force", "N"),
        frf.values.iter().map(|v| v * sign).collect(),
    )];
    if let Some(c) = &frf.coherence {
        out.push(base(
            FUNC_COHERENCE,
            4,
            axis(0, 0, 0, "Coherence", "NONE"),
            axis(0, 0, 0, "NONE", "NONE"),
            c.iter().map(|&g| Complex64::new(g, 0.0)).collect(),
        ));
    }
    out
}

/// Write `frf` as a universal file: dataset 164 (SI), its FRF (function type 4, complex
/// double) and its coherence (function type 6) if any, as 58b when `binary`, else ASCII 58
/// (values to 12 significant digits; see [`crate::uff`]).
pub fn write_frf_uff(
    path: &Path,
    frf: &MeasuredFrf,
    header: &Uff58Header,
    binary: bool,
) -> Result<()> {
    uff::write_uff(
        path,
        Some(&Units164::si()),
        &uff_functions(frf, header),
        binary,
    )
}

/// A file-level message for an FRF data error (for callers holding a [`MeasuredFrf`]).
pub fn data_error(path: &Path, e: FrfDataError) -> IoError {
    bad(path, "", e.to_string())
}
