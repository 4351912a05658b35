//! Universal File Format (UFF, "universal file") datasets 58 (function at nodal DOF, ASCII),
//! 58b (its binary form) and 164 (units): read and write.
//!
//! **Layout.** A file is a sequence of datasets, each between two lines `    -1`; the line after
//! the opening one holds the dataset number in columns 1–6. Dataset 58 has 11 header records
//! (records 1–5 ID lines; 6 the DOFs: function type, response and reference node and signed
//! direction; 7 the data form: ordinate data type 2/4/5/6 = real single/real double/complex
//! single/complex double, number of points, even (1) or uneven (0) abscissa, abscissa start and
//! step; 8–11 the abscissa, ordinate, ordinate-denominator and z-axis characteristics: specific
//! data type, length/force/temperature unit exponents, axis label, units label) and record 12
//! the data: per point the abscissa (uneven only), then the real value or the real and imaginary
//! parts. ASCII writes values as `E20.12` (double, 12 significant digits) or `E13.5` (single;
//! the abscissa of uneven double data too: 6 significant digits), four or six to a line as the
//! format prescribes. In 58b the ID line is `    58b` followed by byte order (1 little, 2 big
//! endian), floating-point format (2 = IEEE 754), the number of ASCII header lines (11) and of
//! data bytes; the data follow record 11 directly in binary, every value (the abscissa
//! included) in the precision of the data type, as pyuff reads and writes them, and `    -1`
//! follows the last byte.
//!
//! Dataset 164 gives the unit system of the datasets after it: a code, and factors with
//! `SI value = file value / factor` for length and force (time is always seconds).
//!
//! Reading checks everything a file can get wrong (not UFF, truncated records, fields that are
//! not numbers, unknown data types, a byte count that does not match, non-finite values,
//! abscissae that do not increase) and names the file, the dataset, the record and the line
//! (or the byte offset in binary data) in [`IoError::FrfInput`]. A header cannot make the
//! reader allocate more than [`vibrobar_core::structure::frf_data::MAX_FRF_LINES`] points.
//! Datasets of other numbers are skipped; [`UffFile::notes`] says so.

use crate::error::{IoError, Result};
use num_complex::Complex64;
use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;
use vibrobar_core::structure::frf_data::MAX_FRF_LINES;

/// Largest file the readers load, bytes.
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// Function type of an FRF (record 6, field 1).
pub const FUNC_FRF: i64 = 4;
/// Function type of a coherence.
pub const FUNC_COHERENCE: i64 = 6;

/// One axis description (records 8–11).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct AxisSpec {
    /// Specific data type (0 unknown, 8 displacement, 11 velocity, 12 acceleration, 13
    /// excitation force, 18 frequency, …).
    pub data_type: i64,
    /// Length units exponent.
    pub length_exp: i64,
    /// Force units exponent.
    pub force_exp: i64,
    /// Temperature units exponent.
    pub temp_exp: i64,
    /// Axis label (`NONE` if unused).
    pub label: String,
    /// Axis units label (`NONE` if unused).
    pub units_label: String,
}

/// The binary form of a 58b record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BinaryForm {
    /// 1 little endian, 2 big endian.
    pub byte_order: i64,
}

/// Where a point of a record came from, for error messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PointSource {
    /// ASCII line (1-based).
    Line(usize),
    /// Byte offset in the file (0-based) of its first value.
    Byte(usize),
}

impl std::fmt::Display for PointSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PointSource::Line(l) => write!(f, "line {l}"),
            PointSource::Byte(b) => write!(f, "byte {b}"),
        }
    }
}

/// One dataset 58 as stored (file units, file signs).
#[derive(Debug, Clone, PartialEq)]
pub struct UffFunction {
    /// Position of the dataset in the file (1-based, all dataset numbers counted).
    pub dataset: usize,
    /// Line of its opening `-1`.
    pub start_line: usize,
    /// `Some` for 58b.
    pub binary: Option<BinaryForm>,
    /// Records 1–5.
    pub ids: [String; 5],
    /// Function type (4 FRF, 6 coherence, …).
    pub func_type: i64,
    /// Function identification number.
    pub func_id: i64,
    /// Version or sequence number.
    pub version: i64,
    /// Load case (0: single-point excitation).
    pub load_case: i64,
    /// Response entity name.
    pub rsp_entity: String,
    /// Response node.
    pub rsp_node: i64,
    /// Response direction (signed: −3 is −Z).
    pub rsp_dir: i64,
    /// Reference entity name.
    pub ref_entity: String,
    /// Reference node.
    pub ref_node: i64,
    /// Reference direction (signed).
    pub ref_dir: i64,
    /// Ordinate data type: 2, 4, 5 or 6.
    pub ord_data_type: i64,
    /// Even abscissa: `(start, step)` as in record 7; `None` for uneven.
    pub even: Option<(f64, f64)>,
    /// Z-axis value of record 7.
    pub z_axis_value: f64,
    /// Records 8–11: abscissa, ordinate (numerator), ordinate denominator, z axis.
    pub axes: [AxisSpec; 4],
    /// Abscissa of every point.
    pub x: Vec<f64>,
    /// Values (imaginary part 0 for real data).
    pub y: Vec<Complex64>,
    /// Where each point came from.
    pub sources: Vec<PointSource>,
}

impl UffFunction {
    /// Complex data (types 5 and 6).
    pub fn is_complex(&self) -> bool {
        matches!(self.ord_data_type, 5 | 6)
    }

    /// Double precision (types 4 and 6).
    pub fn is_double(&self) -> bool {
        matches!(self.ord_data_type, 4 | 6)
    }

    /// Numbers stored per point.
    fn per_point(&self) -> usize {
        per_point(self.ord_data_type, self.even.is_some())
    }

    /// A short description: `dataset 3 (line 40): response node 1 direction +3, reference
    /// node 1 direction +3`.
    pub fn describe(&self) -> String {
        format!(
            "dataset {} (line {}): function type {}, response node {} direction {:+}, reference node {} direction {:+}",
            self.dataset, self.start_line, self.func_type, self.rsp_node, self.rsp_dir, self.ref_node, self.ref_dir
        )
    }
}

fn per_point(ord_data_type: i64, even: bool) -> usize {
    let complex = matches!(ord_data_type, 5 | 6);
    usize::from(!even) + if complex { 2 } else { 1 }
}

/// Dataset 164.
#[derive(Debug, Clone, PartialEq)]
pub struct Units164 {
    /// Position of the dataset in the file.
    pub dataset: usize,
    /// Units code (1 SI, 2 BG, 3 MG, 4 BA, 5 MM, 6 CM, 7 IN, 8 GM, 9 user).
    pub code: i64,
    /// Description.
    pub description: String,
    /// Temperature mode.
    pub temp_mode: i64,
    /// Length factor (SI = file / factor).
    pub length: f64,
    /// Force factor.
    pub force: f64,
    /// Temperature factor.
    pub temp: f64,
    /// Temperature offset.
    pub temp_offset: f64,
}

impl Units164 {
    /// The SI system (all factors 1).
    pub fn si() -> Units164 {
        Units164 {
            dataset: 0,
            code: 1,
            description: "SI".into(),
            temp_mode: 2,
            length: 1.0,
            force: 1.0,
            temp: 1.0,
            temp_offset: 273.15,
        }
    }
}

/// Everything read from a UFF file.
#[derive(Debug, Clone, PartialEq)]
pub struct UffFile {
    /// The dataset 58/58b records, in file order.
    pub functions: Vec<UffFunction>,
    /// The dataset 164 records, in file order.
    pub units: Vec<Units164>,
    /// What was skipped.
    pub notes: Vec<String>,
}

impl UffFile {
    /// The units in force for `f`: the last dataset 164 before it, else the first one after
    /// it, else none.
    pub fn units_for(&self, f: &UffFunction) -> Option<&Units164> {
        self.units
            .iter()
            .rev()
            .find(|u| u.dataset < f.dataset)
            .or_else(|| self.units.first())
    }
}

/// An error at `location` of `path`.
pub(crate) fn bad(path: &Path, location: impl Into<String>, why: impl Into<String>) -> IoError {
    IoError::FrfInput {
        path: path.to_path_buf(),
        location: location.into(),
        why: why.into(),
    }
}

/// Read a whole input file, refusing one larger than [`MAX_FILE_BYTES`].
pub(crate) fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    let meta = std::fs::metadata(path).map_err(IoError::os(path))?;
    if meta.is_dir() {
        return Err(bad(path, "", "is a directory, not a file"));
    }
    if meta.len() > MAX_FILE_BYTES {
        return Err(bad(
            path,
            "",
            format!(
                "the file has {} bytes; at most {MAX_FILE_BYTES} are read",
                meta.len()
            ),
        ));
    }
    std::fs::read(path).map_err(IoError::os(path))
}

/// Whether the first non-blank line of `bytes` is `-1`, as in every universal file.
pub fn looks_like_uff(bytes: &[u8]) -> bool {
    bytes
        .split(|&b| b == b'\n')
        .map(|l| l.trim_ascii())
        .find(|l| !l.is_empty())
        .is_some_and(|l| l == b"-1")
}

/// A cursor over the bytes of a file, by lines.
struct Cursor<'a> {
    path: &'a Path,
    bytes: &'a [u8],
    pos: usize,
    /// Number of the next line (1-based).
    line: usize,
    /// Notes gathered while reading.
    notes: Vec<String>,
}

impl<'a> Cursor<'a> {
    /// The next line without its end (`\n`, `\r\n`) and its number; `None` at the end.
    fn next_line(&mut self) -> Option<(usize, &'a str)> {
        if self.pos >= self.bytes.len() {
            return None;
        }
        let rest = &self.bytes[self.pos..];
        let end = rest.iter().position(|&b| b == b'\n');
        let (raw, adv) = match end {
            Some(e) => (&rest[..e], e + 1),
            None => (rest, rest.len()),
        };
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        self.pos += adv;
        let n = self.line;
        self.line += 1;
        // Header and ASCII data lines are ASCII; anything else reads as replacement characters
        // and fails to parse with its line named.
        Some((n, std::str::from_utf8(raw).unwrap_or("\u{fffd}")))
    }

    /// The next line, or a truncation error naming what was expected.
    fn expect_line(&mut self, what: &str) -> Result<(usize, &'a str)> {
        let line = self.line;
        self.next_line().ok_or_else(|| {
            bad(
                self.path,
                format!("line {line}"),
                format!("the file ends where {what} should be (truncated)"),
            )
        })
    }

    /// Skip `n` bytes (binary data); line numbers count their newline bytes.
    fn skip_bytes(&mut self, n: usize) -> &'a [u8] {
        let s = &self.bytes[self.pos..self.pos + n];
        self.line += s.iter().filter(|&&b| b == b'\n').count();
        self.pos += n;
        s
    }
}

/// Parse a Fortran number (`D` exponents accepted).
fn parse_f64(s: &str) -> Option<f64> {
    let t = s.trim();
    if t.is_empty() {
        return None;
    }
    if t.contains(['d', 'D']) {
        t.replace(['d', 'D'], "E").parse().ok()
    } else {
        t.parse().ok()
    }
}

/// Fixed-width fields of a line (padded with blanks to the widths).
fn fields<'s>(line: &'s str, widths: &[usize]) -> Vec<&'s str> {
    let mut out = Vec::with_capacity(widths.len());
    let mut at = 0;
    for &w in widths {
        let a = at.min(line.len());
        let b = (at + w).min(line.len());
        out.push(line.get(a..b).unwrap_or("").trim());
        at += w;
    }
    out
}

/// One header record parsed: integer and float fields by position.
struct Header<'a> {
    path: &'a Path,
    dataset: usize,
    record: usize,
    line: usize,
}

impl Header<'_> {
    fn err(&self, why: impl Into<String>) -> IoError {
        bad(
            self.path,
            format!(
                "line {} (dataset {}, record {})",
                self.line, self.dataset, self.record
            ),
            why,
        )
    }

    fn int(&self, text: &str, name: &str) -> Result<i64> {
        let t = text.trim();
        if t.is_empty() {
            return Ok(0);
        }
        t.parse::<i64>()
            .map_err(|_| self.err(format!("{name} must be a whole number, got {t:?}")))
    }

    fn float(&self, text: &str, name: &str) -> Result<f64> {
        let t = text.trim();
        if t.is_empty() {
            return Ok(0.0);
        }
        let v =
            parse_f64(t).ok_or_else(|| self.err(format!("{name} must be a number, got {t:?}")))?;
        if !v.is_finite() {
            return Err(self.err(format!("{name} must be finite, got {t:?}")));
        }
        Ok(v)
    }
}

/// Fields of a numeric header record: fixed widths, or, where those do not parse, the
/// whitespace-separated tokens (files written in free format).
fn numeric_fields<'s>(line: &'s str, widths: &[usize], numeric: &[bool]) -> Vec<&'s str> {
    let fixed = fields(line, widths);
    let ok = fixed
        .iter()
        .zip(numeric)
        .all(|(f, &num)| !num || f.is_empty() || parse_f64(f).is_some());
    if ok {
        return fixed;
    }
    let toks: Vec<&str> = line.split_whitespace().collect();
    if toks.len() == widths.len() {
        toks
    } else {
        fixed
    }
}

/// Read a universal file: its datasets 58/58b and 164; others skipped with a note.
pub fn read_uff(path: &Path) -> Result<UffFile> {
    let bytes = read_bytes(path)?;
    parse_uff(path, &bytes)
}

/// [`read_uff`] on bytes already read (`path` names them in errors).
pub fn parse_uff(path: &Path, bytes: &[u8]) -> Result<UffFile> {
    let mut c = Cursor {
        path,
        bytes,
        pos: 0,
        line: 1,
        notes: Vec::new(),
    };
    let mut out = UffFile {
        functions: Vec::new(),
        units: Vec::new(),
        notes: Vec::new(),
    };
    let mut dataset = 0usize;
    loop {
        // Blank lines between datasets are tolerated.
        let (start_line, text) = loop {
            match c.next_line() {
                None => {
                    if dataset == 0 {
                        return Err(bad(path, "", "not a universal file (UFF): it is empty"));
                    }
                    out.notes.append(&mut c.notes);
                    return Ok(out);
                }
                Some((_, t)) if t.trim().is_empty() => continue,
                Some(x) => break x,
            }
        };
        if text.trim() != "-1" {
            let why = if dataset == 0 {
                format!(
                    "not a universal file (UFF): the first line should be \"    -1\", found {:?}",
                    clip(text)
                )
            } else {
                format!(
                    "expected \"    -1\" to open the next dataset, found {:?}",
                    clip(text)
                )
            };
            return Err(bad(path, format!("line {start_line}"), why));
        }
        dataset += 1;
        let (id_line, id) = c.expect_line("the dataset number")?;
        let num_text = id.get(..6.min(id.len())).unwrap_or("").trim();
        let number: i64 = num_text.parse().map_err(|_| {
            bad(
                path,
                format!("line {id_line} (dataset {dataset})"),
                format!(
                    "the dataset number (columns 1–6) must be a whole number, found {:?}",
                    clip(id)
                ),
            )
        })?;
        let binary = id
            .as_bytes()
            .get(6)
            .is_some_and(|b| b.eq_ignore_ascii_case(&b'b'));
        match (number, binary) {
            (58, _) => {
                let f = read_58(&mut c, dataset, start_line, id_line, id, binary)?;
                out.functions.push(f);
            }
            (164, false) => {
                let u = read_164(&mut c, dataset, start_line)?;
                out.units.push(u);
            }
            (n, false) => {
                skip_ascii(&mut c, dataset, start_line, n)?;
                out.notes.push(format!(
                    "dataset {dataset} (type {n}, line {start_line}) skipped: only datasets 58, 58b and 164 are read"
                ));
            }
            (n, true) => {
                skip_binary(&mut c, dataset, start_line, id_line, id, n)?;
                out.notes.push(format!(
                    "dataset {dataset} (type {n}b, line {start_line}) skipped: only datasets 58, 58b and 164 are read"
                ));
            }
        }
    }
}

/// At most 60 characters of a line, for messages.
fn clip(s: &str) -> String {
    s.chars().take(60).collect()
}

/// Skip an ASCII dataset to its closing `-1`.
fn skip_ascii(c: &mut Cursor<'_>, dataset: usize, start: usize, n: i64) -> Result<()> {
    loop {
        let (_, t) = c.expect_line(&format!(
            "the end (\"    -1\") of dataset {dataset} (type {n}, opened at line {start})"
        ))?;
        if t.trim() == "-1" {
            return Ok(());
        }
    }
}

/// The fields of a binary ID line: byte order, float format, ASCII lines, bytes.
fn binary_id(c: &Cursor<'_>, dataset: usize, id_line: usize, id: &str) -> Result<[i64; 4]> {
    let h = Header {
        path: c.path,
        dataset,
        record: 0,
        line: id_line,
    };
    let rest = id.get(7..).unwrap_or("");
    let f = numeric_fields(rest, &[6, 6, 12, 12, 6, 6, 12, 12], &[true; 8]);
    let names = [
        "the byte order",
        "the floating-point format",
        "the number of ASCII lines",
        "the number of bytes",
    ];
    let mut v = [0i64; 4];
    for i in 0..4 {
        v[i] = h.int(f[i], names[i]).map_err(|_| {
            h.err(format!(
                "the binary ID line: {} must be a whole number, got {:?}",
                names[i], f[i]
            ))
        })?;
    }
    Ok(v)
}

/// Skip a binary dataset of another number: its ASCII lines, its bytes, the closing `-1`.
fn skip_binary(
    c: &mut Cursor<'_>,
    dataset: usize,
    start: usize,
    id_line: usize,
    id: &str,
    n: i64,
) -> Result<()> {
    let [_, _, lines, nbytes] = binary_id(c, dataset, id_line, id)?;
    let h = Header {
        path: c.path,
        dataset,
        record: 0,
        line: id_line,
    };
    if !(0..=10_000).contains(&lines) || nbytes < 0 {
        return Err(h.err(format!(
            "binary dataset {n}b announces {lines} ASCII lines and {nbytes} bytes; allowed [0, 10000] lines and ≥ 0 bytes"
        )));
    }
    for _ in 0..lines {
        c.expect_line(&format!("an ASCII header line of dataset {dataset}"))?;
    }
    let remaining = c.bytes.len() - c.pos;
    if nbytes as u64 > remaining as u64 {
        return Err(h.err(format!(
            "binary dataset {n}b announces {nbytes} data bytes but only {remaining} remain (truncated)"
        )));
    }
    c.skip_bytes(nbytes as usize);
    close_binary(c, dataset, start)
}

/// After binary data: an optional line end, then `-1`.
fn close_binary(c: &mut Cursor<'_>, dataset: usize, start: usize) -> Result<()> {
    let at = c.line;
    let (l, t) = c.expect_line(&format!(
        "the end (\"    -1\") of dataset {dataset} (opened at line {start})"
    ))?;
    let t = if t.trim().is_empty() {
        c.expect_line(&format!(
            "the end (\"    -1\") of dataset {dataset} (opened at line {start})"
        ))?
        .1
    } else {
        t
    };
    if t.trim() != "-1" {
        return Err(bad(
            c.path,
            format!("line {} (dataset {dataset})", l.max(at)),
            format!(
                "expected \"    -1\" right after the binary data (the byte count of the ID line is wrong, or the file is damaged), found {:?}",
                clip(t)
            ),
        ));
    }
    Ok(())
}

/// Dataset 164 after its ID line.
fn read_164(c: &mut Cursor<'_>, dataset: usize, start: usize) -> Result<Units164> {
    let (l1, r1) = c.expect_line("record 1 of dataset 164")?;
    let h = Header {
        path: c.path,
        dataset,
        record: 1,
        line: l1,
    };
    let f = fields(r1, &[10, 20, 10]);
    let code = h.int(f[0], "the units code")?;
    let temp_mode = h.int(f[2], "the temperature mode")?;
    let mut nums: Vec<(usize, f64)> = Vec::new();
    loop {
        let (l, t) = c.expect_line(&format!(
            "record 2 and the end (\"    -1\") of dataset {dataset} (units, opened at line {start})"
        ))?;
        if t.trim() == "-1" {
            break;
        }
        let h = Header {
            path: c.path,
            dataset,
            record: 2,
            line: l,
        };
        for tok in t.split_whitespace() {
            if nums.len() >= 4 {
                return Err(h.err("record 2 has more than 4 factors"));
            }
            nums.push((l, h.float(tok, "a unit factor")?));
        }
    }
    if nums.len() < 3 {
        return Err(bad(
            c.path,
            format!("line {l1} (dataset {dataset}, record 2)"),
            format!(
                "dataset 164 needs the length, force and temperature factors; found {}",
                nums.len()
            ),
        ));
    }
    for (i, name) in [(0, "length"), (1, "force")] {
        let (l, v) = nums[i];
        if v.is_nan() || v <= 0.0 {
            return Err(bad(
                c.path,
                format!("line {l} (dataset {dataset}, record 2)"),
                format!("the {name} factor must be > 0, got {v}"),
            ));
        }
    }
    Ok(Units164 {
        dataset,
        code,
        description: f[1].to_string(),
        temp_mode,
        length: nums[0].1,
        force: nums[1].1,
        temp: nums[2].1,
        temp_offset: nums.get(3).map_or(0.0, |n| n.1),
    })
}

/// Widths of the values of one data line (record 12), by data type and spacing.
fn data_widths(ord_data_type: i64, even: bool) -> &'static [usize] {
    match (ord_data_type, even) {
        (2 | 5, _) => &[13, 13, 13, 13, 13, 13],
        (4, true) | (6, true) => &[20, 20, 20, 20],
        (4, false) => &[13, 20, 13, 20],
        _ => &[13, 20, 20],
    }
}

/// Dataset 58 or 58b after its ID line.
fn read_58(
    c: &mut Cursor<'_>,
    dataset: usize,
    start_line: usize,
    id_line: usize,
    id: &str,
    binary: bool,
) -> Result<UffFunction> {
    let path = c.path;
    let mut byte_order = 1;
    let mut nbytes = 0i64;
    if binary {
        let [bo, fp, lines, nb] = binary_id(c, dataset, id_line, id)?;
        let h = Header {
            path,
            dataset,
            record: 0,
            line: id_line,
        };
        if bo != 1 && bo != 2 {
            return Err(h.err(format!(
                "the 58b byte order is {bo}; allowed 1 (little endian) or 2 (big endian)"
            )));
        }
        if fp != 2 {
            return Err(h.err(format!(
                "the 58b floating-point format is {fp}; only 2 (IEEE 754) is read (1 DEC VMS and 3 IBM 370 are not)"
            )));
        }
        if lines != 11 {
            return Err(h.err(format!(
                "the 58b ID line announces {lines} ASCII header lines; dataset 58 has 11"
            )));
        }
        byte_order = bo;
        nbytes = nb;
    }
    let mut ids: [String; 5] = Default::default();
    for (k, slot) in ids.iter_mut().enumerate() {
        let (_, t) = c.expect_line(&format!("record {} (ID line {})", k + 1, k + 1))?;
        *slot = t.trim_end().to_string();
    }
    // Record 6.
    let (l6, r6) = c.expect_line("record 6 (DOF identification)")?;
    let h6 = Header {
        path,
        dataset,
        record: 6,
        line: l6,
    };
    let f6 = {
        let fixed = fields(r6, &[5, 10, 5, 10, 11, 10, 4, 11, 10, 4]);
        let nums = [0, 1, 2, 3, 5, 6, 8, 9];
        if nums
            .iter()
            .all(|&i| fixed[i].is_empty() || fixed[i].parse::<i64>().is_ok())
        {
            fixed
        } else {
            let t: Vec<&str> = r6.split_whitespace().collect();
            if t.len() == 10 {
                t
            } else {
                fixed
            }
        }
    };
    let func_type = h6.int(f6[0], "the function type (field 1)")?;
    let func_id = h6.int(f6[1], "the function identification number (field 2)")?;
    let version = h6.int(f6[2], "the version number (field 3)")?;
    let load_case = h6.int(f6[3], "the load case (field 4)")?;
    let rsp_node = h6.int(f6[5], "the response node (field 6)")?;
    let rsp_dir = h6.int(f6[6], "the response direction (field 7)")?;
    let ref_node = h6.int(f6[8], "the reference node (field 9)")?;
    let ref_dir = h6.int(f6[9], "the reference direction (field 10)")?;
    for (d, name) in [(rsp_dir, "response"), (ref_dir, "reference")] {
        if !(-6..=6).contains(&d) {
            return Err(h6.err(format!(
                "the {name} direction is {d}; allowed −6…6 (0 scalar, ±1…±3 translations, ±4…±6 rotations)"
            )));
        }
    }
    // Record 7.
    let (l7, r7) = c.expect_line("record 7 (data form)")?;
    let h7 = Header {
        path,
        dataset,
        record: 7,
        line: l7,
    };
    let f7 = numeric_fields(r7, &[10, 10, 10, 13, 13, 13], &[true; 6]);
    let ord_data_type = h7.int(f7[0], "the ordinate data type (field 1)")?;
    if ![2, 4, 5, 6].contains(&ord_data_type) {
        return Err(h7.err(format!(
            "the ordinate data type is {ord_data_type}; allowed 2 (real single), 4 (real double), 5 (complex single), 6 (complex double)"
        )));
    }
    let npts = h7.int(f7[1], "the number of points (field 2)")?;
    if npts < 1 || npts as u64 > MAX_FRF_LINES as u64 {
        return Err(h7.err(format!(
            "the number of points is {npts}; allowed [1, {MAX_FRF_LINES}]"
        )));
    }
    let npts = npts as usize;
    let spacing = h7.int(f7[2], "the abscissa spacing (field 3)")?;
    if spacing != 0 && spacing != 1 {
        return Err(h7.err(format!(
            "the abscissa spacing is {spacing}; allowed 0 (uneven) or 1 (even)"
        )));
    }
    let start = h7.float(f7[3], "the abscissa minimum (field 4)")?;
    let step = h7.float(f7[4], "the abscissa increment (field 5)")?;
    let z_axis_value = h7.float(f7[5], "the z-axis value (field 6)")?;
    let even = if spacing == 1 {
        if (step.is_nan() || step <= 0.0) && npts > 1 {
            return Err(h7.err(format!(
                "the abscissa increment of an even abscissa is {step}; it must be > 0 (the lines must increase)"
            )));
        }
        Some((start, step))
    } else {
        None
    };
    // Records 8–11.
    let mut axes: [AxisSpec; 4] = Default::default();
    for (k, axis) in axes.iter_mut().enumerate() {
        let record = 8 + k;
        let (l, t) = c.expect_line(&format!("record {record} (axis characteristics)"))?;
        let h = Header {
            path,
            dataset,
            record,
            line: l,
        };
        let f = fields(t, &[10, 5, 5, 5, 21, 21]);
        let f = if f[..4]
            .iter()
            .all(|s| s.is_empty() || s.parse::<i64>().is_ok())
        {
            f
        } else {
            let t: Vec<&str> = t.split_whitespace().collect();
            if t.len() >= 4 {
                t
            } else {
                f
            }
        };
        axis.data_type = h.int(f[0], "the specific data type (field 1)")?;
        axis.length_exp = h.int(f[1], "the length units exponent (field 2)")?;
        axis.force_exp = h.int(f[2], "the force units exponent (field 3)")?;
        axis.temp_exp = h.int(f[3], "the temperature units exponent (field 4)")?;
        axis.label = f.get(4).copied().unwrap_or("").to_string();
        axis.units_label = f.get(5).copied().unwrap_or("").to_string();
    }
    // Record 12.
    let per = per_point(ord_data_type, even.is_some());
    let nvals = npts * per;
    let double = matches!(ord_data_type, 4 | 6);
    let mut vals: Vec<f64> = Vec::new();
    let mut srcs: Vec<PointSource> = Vec::new();
    if binary {
        let size = if double { 8 } else { 4 };
        let expected = nvals * size;
        let hb = Header {
            path,
            dataset,
            record: 0,
            line: id_line,
        };
        // pyuff writes the byte count of real data (8 per point) for complex data too: the
        // data are accepted where they end exactly as record 7 says, followed by "-1".
        let ends_as_record_7 = {
            let rest = c.bytes.get(c.pos + expected..).unwrap_or(b"");
            let rest = rest
                .strip_prefix(b"\r\n")
                .or_else(|| rest.strip_prefix(b"\n"))
                .unwrap_or(rest);
            rest.starts_with(b"    -1")
        };
        if nbytes as u64 != expected as u64 && ends_as_record_7 {
            c.notes.push(format!(
                "dataset {dataset} (line {start_line}): the 58b ID line announces {nbytes} data bytes, record 7 needs {expected}; the data end where record 7 says, so they were read (a byte count written by some tools for complex data)"
            ));
        } else if nbytes < 0 || nbytes as u64 != expected as u64 {
            return Err(hb.err(format!(
                "the 58b ID line announces {nbytes} data bytes; record 7 ({npts} points, data type {ord_data_type}, {} abscissa) needs {expected}",
                if even.is_some() { "even" } else { "uneven" }
            )));
        }
        let remaining = c.bytes.len() - c.pos;
        if expected > remaining {
            return Err(bad(
                path,
                format!("byte {} (dataset {dataset}, record 12)", c.pos),
                format!("the binary data need {expected} bytes but only {remaining} remain (truncated record)"),
            ));
        }
        let base = c.pos;
        let data = c.skip_bytes(expected);
        vals.reserve(nvals);
        for k in 0..nvals {
            let b = &data[k * size..(k + 1) * size];
            let v = match (double, byte_order) {
                (true, 1) => f64::from_le_bytes(b.try_into().expect("8 bytes")),
                (true, _) => f64::from_be_bytes(b.try_into().expect("8 bytes")),
                (false, 1) => f64::from(f32::from_le_bytes(b.try_into().expect("4 bytes"))),
                (false, _) => f64::from(f32::from_be_bytes(b.try_into().expect("4 bytes"))),
            };
            if k % per == 0 {
                srcs.push(PointSource::Byte(base + k * size));
            }
            vals.push(v);
        }
        close_binary(c, dataset, start_line)?;
    } else {
        let widths = data_widths(ord_data_type, even.is_some());
        while vals.len() < nvals {
            let (l, t) = c.expect_line(&format!(
                "value {} of the {nvals} that record 7 announces (record 12)",
                vals.len() + 1
            ))?;
            if t.trim() == "-1" {
                return Err(bad(
                    path,
                    format!("line {l} (dataset {dataset}, record 12)"),
                    format!(
                        "the dataset ends after {} of the {nvals} values that record 7 announces ({npts} points): truncated record",
                        vals.len()
                    ),
                ));
            }
            let before = vals.len();
            let mut ok = true;
            for tok in t.split_whitespace() {
                match parse_f64(tok) {
                    Some(v) => vals.push(v),
                    None => {
                        ok = false;
                        break;
                    }
                }
            }
            if !ok {
                // Fields that fill their width run together: read the columns.
                vals.truncate(before);
                let mut at = 0;
                let mut k = 0;
                while at < t.len() {
                    let w = widths[k % widths.len()];
                    let s = t.get(at..(at + w).min(t.len())).unwrap_or("");
                    if !s.trim().is_empty() {
                        let v = parse_f64(s).ok_or_else(|| {
                            bad(
                                path,
                                format!("line {l} (dataset {dataset}, record 12)"),
                                format!("{:?} is not a number", s.trim()),
                            )
                        })?;
                        vals.push(v);
                    }
                    at += w;
                    k += 1;
                }
            }
            if vals.len() > nvals {
                return Err(bad(
                    path,
                    format!("line {l} (dataset {dataset}, record 12)"),
                    format!("more values than the {nvals} that record 7 announces ({npts} points)"),
                ));
            }
            // Points starting on this line.
            let first_point = before.div_ceil(per);
            let end_point = vals.len().div_ceil(per);
            for _ in first_point..end_point {
                srcs.push(PointSource::Line(l));
            }
        }
        let at = c.line;
        let (l, t) = c.expect_line(&format!(
            "the end (\"    -1\") of dataset {dataset} (opened at line {start_line})"
        ))?;
        if t.trim() != "-1" {
            return Err(bad(
                path,
                format!("line {} (dataset {dataset}, record 12)", l.max(at)),
                format!(
                    "expected \"    -1\" after the {nvals} values record 7 announces, found {:?}",
                    clip(t)
                ),
            ));
        }
    }
    // Points.
    let complex = matches!(ord_data_type, 5 | 6);
    let mut x = Vec::with_capacity(npts);
    let mut y = Vec::with_capacity(npts);
    for p in 0..npts {
        let v = &vals[p * per..(p + 1) * per];
        let (xv, rest) = match even {
            Some((s, d)) => (s + p as f64 * d, v),
            None => (v[0], &v[1..]),
        };
        let yv = if complex {
            Complex64::new(rest[0], rest[1])
        } else {
            Complex64::new(rest[0], 0.0)
        };
        let loc = || {
            format!(
                "{} (dataset {dataset}, record 12, point {})",
                srcs[p],
                p + 1
            )
        };
        if !xv.is_finite() {
            return Err(bad(path, loc(), format!("the abscissa {xv} is not finite")));
        }
        if !(yv.re.is_finite() && yv.im.is_finite()) {
            return Err(bad(
                path,
                loc(),
                format!("the value {} + {}i is not finite", yv.re, yv.im),
            ));
        }
        if p > 0 && xv <= x[p - 1] {
            return Err(bad(
                path,
                loc(),
                format!(
                    "the abscissa {xv} is not above the one before it ({}); the lines must increase",
                    x[p - 1]
                ),
            ));
        }
        x.push(xv);
        y.push(yv);
    }
    Ok(UffFunction {
        dataset,
        start_line,
        binary: binary.then_some(BinaryForm { byte_order }),
        ids,
        func_type,
        func_id,
        version,
        load_case,
        rsp_entity: f6[4].to_string(),
        rsp_node,
        rsp_dir,
        ref_entity: f6[7].to_string(),
        ref_node,
        ref_dir,
        ord_data_type,
        even,
        z_axis_value,
        axes,
        x,
        y,
        sources: srcs,
    })
}

// ---------------------------------------------------------------------------------------------
// writing

/// `x` as Fortran `Ew.d` (C's `%w.de` with an upper-case `E`): `d` digits after the point,
/// an exponent of at least two digits, right-aligned in `w` columns.
pub fn fmt_e(x: f64, w: usize, d: usize) -> String {
    let s = format!("{x:.d$e}");
    let (mant, exp) = s.split_once('e').expect("{:e} has an exponent");
    let e: i32 = exp.parse().expect("{:e} has an integer exponent");
    let sign = if e < 0 { '-' } else { '+' };
    format!("{:>w$}", format!("{mant}E{sign}{:02}", e.abs()))
}

/// The value a number has after writing it as `E13.5` and reading it back.
pub fn round_e13_5(x: f64) -> f64 {
    parse_f64(&fmt_e(x, 13, 5)).expect("formatted number")
}

/// A label field: `NONE` when empty (the format asks for it).
fn label(s: &str) -> &str {
    if s.trim().is_empty() {
        "NONE"
    } else {
        s
    }
}

/// Write datasets: `units` (dataset 164) first if given, then every function, as 58b when
/// `binary` (little endian, IEEE) and ASCII 58 otherwise. Atomic, under the output-path policy.
pub fn write_uff(
    path: &Path,
    units: Option<&Units164>,
    functions: &[UffFunction],
    binary: bool,
) -> Result<()> {
    for (k, f) in functions.iter().enumerate() {
        check_writable(path, k, f, binary)?;
    }
    crate::atomic::write_with(path, |w| {
        if let Some(u) = units {
            write_164(w, u)?;
        }
        for f in functions {
            write_58(w, f, binary)?;
        }
        Ok(())
    })
}

/// What a function needs to be written and read back.
fn check_writable(path: &Path, k: usize, f: &UffFunction, binary: bool) -> Result<()> {
    let here = format!("function {} to write", k + 1);
    let why = |w: String| Err(bad(path, here.clone(), w));
    if ![2, 4, 5, 6].contains(&f.ord_data_type) {
        return why(format!(
            "ordinate data type {}; allowed 2, 4, 5, 6",
            f.ord_data_type
        ));
    }
    if f.x.len() != f.y.len() || f.x.is_empty() || f.x.len() > MAX_FRF_LINES {
        return why(format!(
            "{} abscissae and {} values; need the same number in [1, {MAX_FRF_LINES}]",
            f.x.len(),
            f.y.len()
        ));
    }
    for (i, (x, y)) in f.x.iter().zip(&f.y).enumerate() {
        if !(x.is_finite() && y.re.is_finite() && y.im.is_finite()) {
            return why(format!("point {} is not finite ({x} Hz, {y})", i + 1));
        }
    }
    if let Some((s, d)) = f.even {
        for (i, &x) in f.x.iter().enumerate() {
            if x.to_bits() != (s + i as f64 * d).to_bits() {
                return why(format!(
                    "the abscissa of point {} ({x}) is not start + i·step ({s} + {i}·{d}) of an even abscissa",
                    i + 1
                ));
            }
        }
        if round_e13_5(s) != s || round_e13_5(d) != d {
            return why(format!(
                "an even abscissa's start {s} and step {d} must have at most 6 significant digits (record 7 keeps E13.5)"
            ));
        }
    } else if !binary {
        for i in 1..f.x.len() {
            if round_e13_5(f.x[i]) <= round_e13_5(f.x[i - 1]) {
                return why(format!(
                    "the lines {} and {} Hz are equal to the 6 significant digits that the ASCII format keeps for an uneven abscissa; write binary (58b)",
                    f.x[i - 1], f.x[i]
                ));
            }
        }
    }
    Ok(())
}

fn write_164(w: &mut dyn Write, u: &Units164) -> std::io::Result<()> {
    let d = |x: f64| fmt_e(x, 25, 16).replace('E', "D");
    write!(
        w,
        "    -1\n   164\n{:>10}{:>20}{:>10}\n{}{}{}\n{}\n    -1\n",
        u.code,
        u.description.chars().take(20).collect::<String>(),
        u.temp_mode,
        d(u.length),
        d(u.force),
        d(u.temp),
        d(u.temp_offset)
    )
}

fn write_58(w: &mut dyn Write, f: &UffFunction, binary: bool) -> std::io::Result<()> {
    let per = f.per_point();
    let double = f.is_double();
    let complex = f.is_complex();
    let n = f.x.len();
    let mut head = String::new();
    head.push_str("    -1\n    58");
    if binary {
        let nbytes = n * per * if double { 8 } else { 4 };
        let _ = writeln!(
            head,
            "b{:>6}{:>6}{:>12}{:>12}{:>6}{:>6}{:>12}{:>12}",
            1, 2, 11, nbytes, 0, 0, 0, 0
        );
    } else {
        head.push('\n');
    }
    for id in &f.ids {
        let _ = writeln!(head, "{:<80}", label(id));
    }
    let _ = writeln!(
        head,
        "{:>5}{:>10}{:>5}{:>10} {:>10}{:>10}{:>4} {:>10}{:>10}{:>4}",
        f.func_type,
        f.func_id,
        f.version,
        f.load_case,
        label(&f.rsp_entity),
        f.rsp_node,
        f.rsp_dir,
        label(&f.ref_entity),
        f.ref_node,
        f.ref_dir
    );
    let (s, d) = f.even.unwrap_or((0.0, 0.0));
    let _ = writeln!(
        head,
        "{:>10}{:>10}{:>10}{}{}{}",
        f.ord_data_type,
        n,
        i32::from(f.even.is_some()),
        fmt_e(s, 13, 5),
        fmt_e(d, 13, 5),
        fmt_e(f.z_axis_value, 13, 5)
    );
    for a in &f.axes {
        let _ = writeln!(
            head,
            "{:>10}{:>5}{:>5}{:>5} {:<20} {:<20}",
            a.data_type,
            a.length_exp,
            a.force_exp,
            a.temp_exp,
            label(&a.label),
            label(&a.units_label)
        );
    }
    w.write_all(head.as_bytes())?;
    // The stored numbers, point by point.
    let mut vals = Vec::with_capacity(n * per);
    for (x, y) in f.x.iter().zip(&f.y) {
        if f.even.is_none() {
            vals.push(*x);
        }
        vals.push(y.re);
        if complex {
            vals.push(y.im);
        }
    }
    if binary {
        let mut buf = Vec::with_capacity(vals.len() * 8);
        for v in &vals {
            if double {
                buf.extend_from_slice(&v.to_le_bytes());
            } else {
                buf.extend_from_slice(&(*v as f32).to_le_bytes());
            }
        }
        w.write_all(&buf)?;
    } else {
        // Column formats of one line (the Fortran formats of record 12).
        let widths = data_widths(f.ord_data_type, f.even.is_some());
        let mut line = String::with_capacity(100);
        for (k, v) in vals.iter().enumerate() {
            let col = k % widths.len();
            let wdt = widths[col];
            line.push_str(&if wdt == 13 {
                fmt_e(*v, 13, 5)
            } else {
                fmt_e(*v, 20, 11)
            });
            if col == widths.len() - 1 || k == vals.len() - 1 {
                line.push('\n');
                w.write_all(line.as_bytes())?;
                line.clear();
            }
        }
    }
    w.write_all(b"    -1\n")
}
