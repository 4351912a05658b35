//! CSV schemas, each defined once: a [`Schema`] lists the columns with their formatters, and the
//! same list gives the header, formats a row and reads one back (checking the field count and
//! that every number is finite). Writers, journals, merge and the map reader all use it, so the
//! text written and the text accepted cannot drift apart.

use crate::atomic::write_with;
use crate::error::{IoError, Result};
use std::borrow::Cow;
use std::fmt::Write as _;
use std::path::Path;
use vibrobar_core::analysis::map::{Axis, GridPoint, MapRow, Optimum};
use vibrobar_core::analysis::placement::{PlacementPoint, PlacementRow};
use vibrobar_core::analysis::regime::Regime;
use vibrobar_core::solver::CutSample;
use vibrobar_core::State;

/// How a column is written (and so how it is read back).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Grid coordinate, 12 significant digits ([`fmt_coord`]).
    Coord,
    /// Short grid value, binary noise removed ([`grid_num`]).
    Grid,
    /// Rust's shortest exponent form `{:e}`.
    Sci,
    /// Fixed decimals `{:.N}`.
    Fixed(usize),
    /// Rust's shortest plain form `{}`.
    Plain,
    /// Whole count.
    Count,
    /// Text without commas.
    Text,
}

/// One column.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Column {
    /// Header name.
    pub name: Cow<'static, str>,
    /// Formatter.
    pub format: Format,
    /// May be empty ([`Value::Empty`]).
    pub optional: bool,
}

pub(crate) const fn col(name: &'static str, format: Format) -> Column {
    Column {
        name: Cow::Borrowed(name),
        format,
        optional: false,
    }
}

const fn opt(name: &'static str, format: Format) -> Column {
    Column {
        name: Cow::Borrowed(name),
        format,
        optional: true,
    }
}

/// One field of a row.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// A number (formats other than `Count` and `Text`).
    F(f64),
    /// A count.
    U(u64),
    /// Text.
    S(String),
    /// An empty field (optional columns only).
    Empty,
}

impl Value {
    /// The number (a count as f64); `NaN` for text.
    pub fn f(&self) -> f64 {
        match self {
            Value::F(x) => *x,
            Value::U(n) => *n as f64,
            Value::S(_) | Value::Empty => f64::NAN,
        }
    }
    /// The text (empty for numbers).
    pub fn s(&self) -> &str {
        match self {
            Value::S(s) => s,
            _ => "",
        }
    }
}

/// A grid coordinate for CSV: rounded to 12 significant digits, so `0.95 + 1·0.01` prints as
/// `0.96`, not `0.9600000000000001` (the run used the exact value; the difference is < 1e-15).
pub fn fmt_coord(x: f64) -> String {
    let y: f64 = format!("{x:.11e}").parse().expect("float round trip");
    format!("{y}")
}

/// Short decimal for grid values (ratios, gaps): rounds away binary noise like 1.0000000000000002.
pub fn grid_num(x: f64) -> String {
    let s = format!("{x:.9}");
    let s = s.trim_end_matches('0');
    s.trim_end_matches('.').to_string()
}

/// The columns of one CSV file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Schema {
    /// Columns, in file order.
    pub columns: Vec<Column>,
}

impl Schema {
    /// The header line (no newline).
    pub fn header(&self) -> String {
        self.columns
            .iter()
            .map(|c| c.name.as_ref())
            .collect::<Vec<_>>()
            .join(",")
    }

    /// Number of columns.
    pub fn len(&self) -> usize {
        self.columns.len()
    }

    /// True for a schema without columns.
    pub fn is_empty(&self) -> bool {
        self.columns.is_empty()
    }

    /// Append the first `values.len()` fields of a row to `out` (no newline). Panics on a value
    /// of the wrong kind: that is a bug of the caller, not of the data.
    pub fn format_into(&self, values: &[Value], out: &mut String) {
        assert!(values.len() <= self.columns.len(), "too many fields");
        for (k, (c, v)) in self.columns.iter().zip(values).enumerate() {
            if k > 0 {
                out.push(',');
            }
            let _ = match (c.format, v) {
                (Format::Coord, Value::F(x)) => write!(out, "{}", fmt_coord(*x)),
                (Format::Grid, Value::F(x)) => write!(out, "{}", grid_num(*x)),
                (Format::Sci, Value::F(x)) => write!(out, "{x:e}"),
                (Format::Fixed(d), Value::F(x)) => write!(out, "{x:.d$}"),
                (Format::Plain, Value::F(x)) => write!(out, "{x}"),
                (Format::Count, Value::U(n)) => write!(out, "{n}"),
                (Format::Text, Value::S(s)) => write!(out, "{s}"),
                (_, Value::Empty) if c.optional => Ok(()),
                (f, v) => panic!("column {}: value {v:?} does not fit {f:?}", c.name),
            };
        }
    }

    /// A row (or its first fields) as text, no newline.
    pub fn format(&self, values: &[Value]) -> String {
        let mut s = String::with_capacity(16 * values.len());
        self.format_into(values, &mut s);
        s
    }

    /// Check a row before it is written: one value per column, of the column's kind, every
    /// number finite, empty only where the column allows it. The error names the column.
    pub fn check(&self, values: &[Value]) -> std::result::Result<(), String> {
        if values.len() != self.columns.len() {
            return Err(format!(
                "{} fields, the header has {}",
                values.len(),
                self.columns.len()
            ));
        }
        for (c, v) in self.columns.iter().zip(values) {
            let name = &c.name;
            match (c.format, v) {
                (_, Value::Empty) if c.optional => {}
                (_, Value::Empty) => return Err(format!("{name} may not be empty")),
                (Format::Text, Value::S(s)) if s.contains([',', '\n']) => {
                    return Err(format!("{name} = {s:?} holds a comma or a newline"))
                }
                (Format::Text, Value::S(_)) | (Format::Count, Value::U(_)) => {}
                (Format::Text | Format::Count, _) | (_, Value::S(_) | Value::U(_)) => {
                    return Err(format!("{name}: {v:?} does not fit {:?}", c.format))
                }
                (_, Value::F(x)) if !x.is_finite() => {
                    return Err(format!("{name} = {x} is not a finite number"))
                }
                (_, Value::F(_)) => {}
            }
        }
        Ok(())
    }

    /// Read one row back. The error says which column is wrong; callers add file and line.
    pub fn parse(&self, line: &str) -> std::result::Result<Vec<Value>, String> {
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != self.columns.len() {
            return Err(format!(
                "{} fields, the header has {}",
                fields.len(),
                self.columns.len()
            ));
        }
        self.columns
            .iter()
            .zip(fields)
            .map(|(c, f)| match c.format {
                _ if c.optional && f.is_empty() => Ok(Value::Empty),
                Format::Text => Ok(Value::S(f.to_string())),
                Format::Count => f
                    .parse::<u64>()
                    .map(Value::U)
                    .map_err(|_| format!("{} = {f:?} is not a whole number", c.name)),
                _ => match f.parse::<f64>() {
                    Ok(x) if x.is_finite() => Ok(Value::F(x)),
                    Ok(_) => Err(format!("{} = {f} is not a finite number", c.name)),
                    Err(_) => Err(format!("{} = {f:?} is not a number", c.name)),
                },
            })
            .collect()
    }

    /// Read a row of `path` at 1-based `line`, as [`parse`](Self::parse) with the place named.
    pub fn parse_at(&self, text: &str, path: &Path, line: usize) -> Result<Vec<Value>> {
        self.parse(text).map_err(|why| IoError::Corrupt {
            path: path.to_path_buf(),
            line,
            why,
        })
    }

    /// The schema of a data file of `kind` (as in its metadata) with this `header`.
    pub fn for_file(kind: &str, header: &str) -> Option<Schema> {
        let s = match kind {
            "sweep" => sweep_schema(),
            "map" => map_schema(&map_extra_axes(header)?),
            "placement" => placement_schema(),
            "ensemble" => ensemble_schema(),
            WIDTH_DIAGRAM_KIND => width_diagram_schema(),
            TD_LOBES_KIND => td_lobes_schema(),
            LOBE_DESIGN_KIND => lobe_design_schema(lobe_design_axis(header)?),
            _ => return None,
        };
        (s.header() == header).then_some(s)
    }
}

// ---------------------------------------------------------------------------------------------
// sweep

/// One row of a sweep CSV (`sweep`, Figs. 3 and 5).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SweepCsvRow {
    /// Frequency ratio.
    pub ratio: f64,
    /// Total clearance in mm.
    pub gap_mm: f64,
    /// Friction model name.
    pub friction: String,
    /// Solver name.
    pub solver: String,
    /// RMS of the solid bar (last 80 %).
    pub rms_solid_m: f64,
    /// RMS of the damped bar.
    pub rms_damped_m: f64,
    /// `100(1 − damped/solid)`.
    pub reduction_pct: f64,
    /// Impacts over the whole damped run.
    pub impacts: u64,
}

/// Columns of a sweep CSV; the first two (ratio, gap) identify the grid point.
pub fn sweep_schema() -> Schema {
    Schema {
        columns: vec![
            col("ratio", Format::Grid),
            col("gap_mm", Format::Grid),
            col("friction", Format::Text),
            col("solver", Format::Text),
            col("rms_solid_m", Format::Sci),
            col("rms_damped_m", Format::Sci),
            col("reduction_pct", Format::Fixed(4)),
            col("impacts", Format::Count),
        ],
    }
}

impl SweepCsvRow {
    /// The fields in column order.
    pub fn values(&self) -> Vec<Value> {
        vec![
            Value::F(self.ratio),
            Value::F(self.gap_mm),
            Value::S(self.friction.clone()),
            Value::S(self.solver.clone()),
            Value::F(self.rms_solid_m),
            Value::F(self.rms_damped_m),
            Value::F(self.reduction_pct),
            Value::U(self.impacts),
        ]
    }
}

impl From<&vibrobar_core::analysis::SweepRow> for SweepCsvRow {
    fn from(r: &vibrobar_core::analysis::SweepRow) -> Self {
        SweepCsvRow {
            ratio: r.point.ratio,
            gap_mm: r.point.gap_m * 1e3,
            friction: r.point.friction.as_str().to_string(),
            solver: r.solver.clone(),
            rms_solid_m: r.solid.rms_m,
            rms_damped_m: r.damped.rms_m,
            reduction_pct: r.reduction_pct(),
            impacts: r.damped.impacts,
        }
    }
}

/// The key columns (ratio, gap) of a sweep grid point, as the row writes them.
pub fn sweep_key(ratio: f64, gap_mm: f64) -> String {
    sweep_schema().format(&[Value::F(ratio), Value::F(gap_mm)])
}

/// One sweep CSV line (no newline); the same text whether written directly or via the journal.
pub fn sweep_csv_line(r: &SweepCsvRow) -> String {
    sweep_schema().format(&r.values())
}

/// Write a sweep CSV (rows checked by [`write_csv`]).
pub fn write_sweep_csv(path: &Path, rows: &[SweepCsvRow]) -> Result<()> {
    write_csv(path, &sweep_schema(), rows.iter().map(SweepCsvRow::values))
}

// ---------------------------------------------------------------------------------------------
// time history

/// Columns of a time-history CSV (`run`, Figs. 2 and 4); the NPY form has the same columns.
pub fn history_schema() -> Schema {
    Schema {
        columns: ["t_s", "u_m", "du_m_s", "v_m", "dv_m_s", "w_m", "dw_m_s"]
            .into_iter()
            .map(|n| col(n, Format::Sci))
            .collect(),
    }
}

/// The columns a cutting run adds to [`history_schema`]: the chip thickness, whether the tool
/// cuts (0/1) and the cutting force on the bar.
const CUTTING_COLUMNS: [(&str, Format); 3] = [
    ("chip_thickness_m", Format::Sci),
    ("in_cut", Format::Count),
    ("cutting_force_n", Format::Sci),
];

/// Columns of a cutting run's history: [`history_schema`], then
/// `chip_thickness_m,in_cut,cutting_force_n`.
pub fn cutting_history_schema() -> Schema {
    let mut s = history_schema();
    s.columns
        .extend(CUTTING_COLUMNS.iter().map(|&(n, f)| col(n, f)));
    s
}

/// The fields of one cutting-history row, in column order.
pub fn cutting_history_values(s: &State, c: &CutSample) -> [Value; 10] {
    let h = history_values(s);
    [
        Value::F(h[0]),
        Value::F(h[1]),
        Value::F(h[2]),
        Value::F(h[3]),
        Value::F(h[4]),
        Value::F(h[5]),
        Value::F(h[6]),
        Value::F(c.chip_thickness_m),
        Value::U(u64::from(c.in_cut)),
        Value::F(c.cutting_force_n),
    ]
}

/// The fields of one history row, in column order.
pub fn history_values(s: &State) -> [f64; 7] {
    [s.t_s, s.u_m, s.du_m_s, s.v_m, s.dv_m_s, s.w_m(), s.dw_m_s()]
}

/// Columns of a two-plane run's history CSV: the bar in the cross-section's x (radial) and y
/// (tangential) and along the force, the ball relative to the cavity along and across the hole,
/// its spin.
pub fn two_plane_history_schema() -> Schema {
    Schema {
        columns: [
            "t_s",
            "u_x_m",
            "u_y_m",
            "du_x_m_s",
            "du_y_m_s",
            "u_force_m",
            "w_along_m",
            "w_across_m",
            "dw_along_m_s",
            "dw_across_m_s",
            "spin_rad_s",
        ]
        .into_iter()
        .map(|n| col(n, Format::Sci))
        .collect(),
    }
}

/// The row of [`two_plane_history_schema`] for a sample, with `force_dir` the force's unit
/// vector.
pub fn two_plane_history_values(
    s: &vibrobar_core::solver::two_plane_rk4::TwoPlaneSample,
    force_dir: [f64; 2],
) -> [f64; 11] {
    let st = &s.state;
    [
        s.t_s,
        st.u_m[0],
        st.u_m[1],
        st.du_m_s[0],
        st.du_m_s[1],
        st.u_m[0] * force_dir[0] + st.u_m[1] * force_dir[1],
        st.w_hole_m[0],
        st.w_hole_m[1],
        st.dw_hole_m_s[0],
        st.dw_hole_m_s[1],
        st.spin_rad_s,
    ]
}

/// Write a time-history CSV (small histories, rows checked by [`write_csv`]; `run` streams
/// through [`crate::history`]).
pub fn write_history_csv(path: &Path, samples: &[State]) -> Result<()> {
    write_csv(
        path,
        &history_schema(),
        samples.iter().map(|s| history_values(s).map(Value::F)),
    )
}

// ---------------------------------------------------------------------------------------------
// map

/// Fixed columns of a map before its optional axes.
const MAP_HEAD: [(&str, Format); 2] = [("ratio", Format::Coord), ("gap_mm", Format::Coord)];
/// Fixed columns after the optional axes.
const MAP_TAIL: [(&str, Format); 5] = [
    ("rms_solid_m", Format::Sci),
    ("rms_damped_m", Format::Sci),
    ("reduction_pct", Format::Plain),
    ("impacts_per_cycle", Format::Plain),
    ("regime", Format::Text),
];

/// Columns of a map CSV: `ratio,gap_mm`, one column per optional axis (named after the axis),
/// then `rms_solid_m,rms_damped_m,reduction_pct,impacts_per_cycle,regime`.
pub fn map_schema(extra: &[Axis]) -> Schema {
    let mut columns: Vec<Column> = MAP_HEAD.iter().map(|&(n, f)| col(n, f)).collect();
    columns.extend(extra.iter().map(|a| col(a.as_str(), Format::Coord)));
    columns.extend(MAP_TAIL.iter().map(|&(n, f)| col(n, f)));
    Schema { columns }
}

/// The optional axes named by a map header; `None` if it is not a map header.
pub fn map_extra_axes(header: &str) -> Option<Vec<Axis>> {
    let cols: Vec<&str> = header.split(',').collect();
    let (h, t) = (MAP_HEAD.len(), MAP_TAIL.len());
    if cols.len() < h + t
        || cols[..h] != MAP_HEAD.map(|c| c.0)[..]
        || cols[cols.len() - t..] != MAP_TAIL.map(|c| c.0)[..]
    {
        return None;
    }
    cols[h..cols.len() - t]
        .iter()
        .map(|c| Axis::parse(c).filter(|a| !matches!(a, Axis::FreqRatio | Axis::GapM)))
        .collect()
}

/// The key columns (ratio, gap, optional axes) of a grid point in a map with `extra` axes.
pub fn map_key(point: &GridPoint, extra: &[Axis]) -> Vec<Value> {
    let get = |a: Axis| Value::F(point.get(a).unwrap_or(f64::NAN));
    let mut v = vec![
        get(Axis::FreqRatio),
        Value::F(point.get(Axis::GapM).unwrap_or(f64::NAN) * 1e3),
    ];
    v.extend(extra.iter().map(|a| get(*a)));
    v
}

/// The fields of one map row, in column order.
pub fn map_values(row: &MapRow, extra: &[Axis]) -> Vec<Value> {
    let mut v = vec![Value::F(row.ratio), Value::F(row.gap_m * 1e3)];
    v.extend(
        extra
            .iter()
            .map(|a| Value::F(row.point.get(*a).unwrap_or(f64::NAN))),
    );
    v.extend([
        Value::F(row.rms_solid_m),
        Value::F(row.rms_damped_m),
        Value::F(row.reduction_pct),
        Value::F(row.impacts_per_cycle),
        Value::S(row.regime.to_string()),
    ]);
    v
}

/// A map CSV read back: optional axes, rows as [`MapRow`]s and their text fields.
pub struct MapTable {
    /// Optional axes, in column order.
    pub extra: Vec<Axis>,
    /// Rows (grid index = row number).
    pub rows: Vec<MapRow>,
    /// Text fields of each row, as in the file.
    pub fields: Vec<Vec<String>>,
}

/// Read a map CSV written by `map` or `merge`, refusing (with the line) any damaged row.
pub fn read_map_csv(path: &Path) -> Result<MapTable> {
    let text = std::fs::read_to_string(path).map_err(IoError::os(path))?;
    let mut lines = text.lines();
    let header = lines.next().unwrap_or("");
    let corrupt = |line: usize, why: String| IoError::Corrupt {
        path: path.to_path_buf(),
        line,
        why,
    };
    let extra = map_extra_axes(header)
        .ok_or_else(|| corrupt(1, format!("not a map file (header {header:?})")))?;
    let schema = map_schema(&extra);
    let mut rows = Vec::new();
    let mut fields = Vec::new();
    for (i, line) in lines.enumerate() {
        let v = schema.parse_at(line, path, i + 2)?;
        let t = 2 + extra.len();
        let regime = Regime::parse(v[t + 4].s())
            .ok_or_else(|| corrupt(i + 2, format!("unknown regime {:?}", v[t + 4].s())))?;
        let ratio = v[0].f();
        let gap_m = v[1].f() * 1e-3;
        let mut coords = vec![(Axis::FreqRatio, ratio), (Axis::GapM, gap_m)];
        coords.extend(extra.iter().enumerate().map(|(k, a)| (*a, v[2 + k].f())));
        rows.push(MapRow {
            point: GridPoint { index: i, coords },
            ratio,
            gap_m,
            rms_solid_m: v[t].f(),
            rms_damped_m: v[t + 1].f(),
            reduction_pct: v[t + 2].f(),
            impacts_per_cycle: v[t + 3].f(),
            regime,
        });
        fields.push(line.split(',').map(str::to_string).collect());
    }
    Ok(MapTable {
        extra,
        rows,
        fields,
    })
}

// ---------------------------------------------------------------------------------------------
// optimum of a map

/// Columns of a map's optimum file (`FILE.optimum.csv`).
///
/// * One row per ratio (`criterion = max-reduction`): the grid point with the largest
///   `reduction_pct` at that ratio (over all gaps and optional axes), with its damped and solid
///   RMS, impacts per cycle and regime.
/// * Two band rows (`ratio = band`): the design (gap and optional axes) best over the whole band
///   of ratios, among designs computed at every ratio: `band-mean-reduction` (largest mean
///   reduction; `best_reduction_pct` is that mean, `rms_damped_m` the largest damped RMS over the
///   band) and `band-minimax-rms` (smallest largest damped RMS: the robust choice; same columns).
///   `rms_solid_m`, `impacts_per_cycle` and `regime` are empty on band rows.
/// * `best_<axis>` columns follow for each optional axis.
/// * Last, `friction_work_j,work_input_j`: the energy books of the per-ratio optimum point, rerun
///   from rest with the energy audit over the whole run (`∫F_ball ẇ dt`, positive = friction put
///   energy in; `∫F u̇ dt`, the cutting force's work). Empty on band rows (a band design is many
///   runs, not one) and when the map's metadata is missing.
pub fn optimum_schema(extra: &[Axis]) -> Schema {
    let mut columns = vec![
        // A ratio as `fmt_coord` writes it, or `band`.
        col("ratio", Format::Text),
        col("best_gap_mm", Format::Coord),
        col("best_reduction_pct", Format::Plain),
        col("rms_damped_m", Format::Sci),
        opt("rms_solid_m", Format::Sci),
        opt("impacts_per_cycle", Format::Plain),
        opt("regime", Format::Text),
        col("criterion", Format::Text),
    ];
    columns.extend(extra.iter().map(|a| Column {
        name: Cow::Owned(format!("best_{}", a.as_str())),
        format: Format::Coord,
        optional: false,
    }));
    columns.push(opt("friction_work_j", Format::Sci));
    columns.push(opt("work_input_j", Format::Sci));
    Schema { columns }
}

/// The text of the optimum file of a map with optional axes `extra`; `energy[k]` are the
/// energy books `(friction_work_j, work_input_j)` of `o.per_ratio[k]`, if audited.
pub fn optimum_csv(extra: &[Axis], o: &Optimum, energy: &[Option<(f64, f64)>]) -> String {
    let schema = optimum_schema(extra);
    let mut s = schema.header();
    s.push('\n');
    for (k, r) in o.per_ratio.iter().enumerate() {
        let mut v = vec![
            Value::S(fmt_coord(r.ratio)),
            Value::F(r.gap_m * 1e3),
            Value::F(r.reduction_pct),
            Value::F(r.rms_damped_m),
            Value::F(r.rms_solid_m),
            Value::F(r.impacts_per_cycle),
            Value::S(r.regime.to_string()),
            Value::S("max-reduction".into()),
        ];
        v.extend(
            extra
                .iter()
                .map(|a| Value::F(r.point.get(*a).unwrap_or(f64::NAN))),
        );
        match energy.get(k).copied().flatten() {
            Some((f, w)) => v.extend([Value::F(f), Value::F(w)]),
            None => v.extend([Value::Empty, Value::Empty]),
        }
        schema.format_into(&v, &mut s);
        s.push('\n');
    }
    for (name, b) in [
        ("band-mean-reduction", &o.best_mean_reduction),
        ("band-minimax-rms", &o.best_minimax_rms),
    ] {
        let Some(b) = b else { continue };
        let coord = |axis: Axis| {
            b.design
                .iter()
                .find(|(a, _)| *a == axis)
                .map_or(f64::NAN, |d| d.1)
        };
        let mut v = vec![
            Value::S("band".into()),
            Value::F(coord(Axis::GapM) * 1e3),
            Value::F(b.mean_reduction_pct),
            Value::F(b.max_rms_damped_m),
            Value::Empty,
            Value::Empty,
            Value::Empty,
            Value::S(name.into()),
        ];
        v.extend(extra.iter().map(|a| Value::F(coord(*a))));
        v.extend([Value::Empty, Value::Empty]);
        schema.format_into(&v, &mut s);
        s.push('\n');
    }
    s
}

// ---------------------------------------------------------------------------------------------
// cavity placement (`placement`)

/// Columns of a placement CSV (`vibrobar placement`), one row per cavity position × gap, in grid
/// order (position outer, gap inner): `position_mm` (cavity centre from the clamp) and `gap_mm`
/// identify the point; over the band of ratios `Ω/ω₁` given, `mean_reduction_pct` (mean of
/// `100(1 − rms_damped/rms_solid)`, RMS at the response point, the solid bar being the same beam
/// without cavity section and ball), `worst_rms_m` (largest damped RMS) at `worst_ratio`,
/// `min_reduction_pct` (smallest reduction), `mean_impacts_per_cycle`, and the `regime` of the
/// run at `worst_ratio` (core `analysis::placement`).
pub fn placement_schema() -> Schema {
    Schema {
        columns: vec![
            col("position_mm", Format::Coord),
            col("gap_mm", Format::Coord),
            col("mean_reduction_pct", Format::Plain),
            col("worst_rms_m", Format::Sci),
            col("worst_ratio", Format::Coord),
            col("min_reduction_pct", Format::Plain),
            col("mean_impacts_per_cycle", Format::Plain),
            col("regime", Format::Text),
        ],
    }
}

/// The key columns (position, gap) of a placement point, as its row writes them.
pub fn placement_key(position_m: f64, gap_m: f64) -> Vec<Value> {
    vec![Value::F(position_m * 1e3), Value::F(gap_m * 1e3)]
}

/// The fields of one placement row, in column order.
pub fn placement_values(r: &PlacementRow) -> Vec<Value> {
    let mut v = placement_key(r.point.position_m, r.point.gap_m);
    v.extend([
        Value::F(r.mean_reduction_pct),
        Value::F(r.worst_rms_m),
        Value::F(r.worst_ratio),
        Value::F(r.min_reduction_pct),
        Value::F(r.mean_impacts_per_cycle),
        Value::S(r.regime.to_string()),
    ]);
    v
}

/// Read a placement CSV written by `placement` or `merge` (grid index = row number), refusing
/// any damaged row with its line.
pub fn read_placement_csv(path: &Path) -> Result<Vec<PlacementRow>> {
    let schema = placement_schema();
    read_csv(path, &schema)?
        .into_iter()
        .enumerate()
        .map(|(i, v)| {
            let regime = Regime::parse(v[7].s()).ok_or_else(|| IoError::Corrupt {
                path: path.to_path_buf(),
                line: i + 2,
                why: format!("unknown regime {:?}", v[7].s()),
            })?;
            Ok(PlacementRow {
                point: PlacementPoint {
                    index: i,
                    position_m: v[0].f() / 1e3,
                    gap_m: v[1].f() / 1e3,
                },
                mean_reduction_pct: v[2].f(),
                worst_rms_m: v[3].f(),
                worst_ratio: v[4].f(),
                min_reduction_pct: v[5].f(),
                mean_impacts_per_cycle: v[6].f(),
                regime,
            })
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Poincaré section, bifurcation diagram, ensembles

/// Regime counts as one text field: `regime:count` joined by `;` (no commas).
pub fn regime_counts(regimes: &[(Regime, usize)]) -> String {
    regimes
        .iter()
        .map(|(r, n)| format!("{r}:{n}"))
        .collect::<Vec<_>>()
        .join(";")
}

/// Columns of a Poincaré section (`poincare`): the state at each stroboscopic instant.
pub fn poincare_schema() -> Schema {
    Schema {
        columns: vec![
            col("t_s", Format::Plain),
            col("u_m", Format::Sci),
            col("du_m_s", Format::Sci),
            col("w_m", Format::Sci),
            col("dw_m_s", Format::Sci),
        ],
    }
}

/// The fields of one Poincaré point, in column order (the NPY form has the same columns).
pub fn poincare_values(s: &State) -> [f64; 5] {
    [s.t_s, s.u_m, s.du_m_s, s.w_m(), s.dw_m_s()]
}

/// The swept parameter's column of a bifurcation diagram (`ratio` or `gap_mm`), as the user
/// wrote it (12 significant digits).
fn param_col(param: &'static str) -> Column {
    col(param, Format::Coord)
}

/// Columns of a bifurcation diagram (`bifurcation`): `PARAM,t_s,u_m,du_m_s`, `PARAM` being
/// `ratio` or `gap_mm`.
pub fn bifurcation_schema(param: &'static str) -> Schema {
    Schema {
        columns: vec![
            param_col(param),
            col("t_s", Format::Plain),
            col("u_m", Format::Sci),
            col("du_m_s", Format::Sci),
        ],
    }
}

/// Columns of the impacts of a bifurcation diagram (`FILE.impacts.csv`):
/// `PARAM,t_s,wall,dw_m_s` (`wall` = `plus` or `minus`, `dw_m_s` the pre-impact ẇ).
pub fn bifurcation_impacts_schema(param: &'static str) -> Schema {
    Schema {
        columns: vec![
            param_col(param),
            col("t_s", Format::Plain),
            col("wall", Format::Text),
            col("dw_m_s", Format::Sci),
        ],
    }
}

/// Columns of a continuation branch (`continue`):
/// `param,rms_m,max_abs_multiplier,stable,impacts_per_period,period,event`. `param` is the
/// followed parameter in the units of `--param` (mm for `gap-mm`), `stable` is `true`/`false`,
/// `period` the orbit's period in forcing cycles (doubled on a branch switched to at a period
/// doubling), `event` empty or one of `fold`, `period-doubling`, `torus`, `branch-point`,
/// `grazing`, `stick-onset` (between the previous row of the same branch and this one).
pub fn continuation_schema() -> Schema {
    Schema {
        columns: vec![
            col("param", Format::Plain),
            col("rms_m", Format::Sci),
            col("max_abs_multiplier", Format::Plain),
            col("stable", Format::Text),
            col("impacts_per_period", Format::Count),
            col("period", Format::Count),
            opt("event", Format::Text),
        ],
    }
}

/// One row of [`continuation_schema`] from a branch point of either bar; `scale` turns the
/// parameter into the file's unit (1e3 for `gap-mm`).
pub fn continuation_values<F: vibrobar_core::analysis::orbit::Flow>(
    p: &vibrobar_core::analysis::orbit::continuation::BranchPoint<F>,
    scale: f64,
) -> Vec<Value> {
    continuation_row(
        p.param * scale,
        p.orbit.rms_m,
        p.orbit.max_abs_multiplier(),
        p.orbit.stable(),
        p.orbit.impacts_per_period,
        p.orbit.section.periods(),
        p.event.map(|e| e.as_str()),
    )
}

/// The fields of one [`continuation_schema`] row, in its column order.
fn continuation_row(
    param: f64,
    rms_m: f64,
    max_abs_multiplier: f64,
    stable: bool,
    impacts_per_period: u32,
    period: u32,
    event: Option<&str>,
) -> Vec<Value> {
    vec![
        Value::F(param),
        Value::F(rms_m),
        Value::F(max_abs_multiplier),
        Value::S(if stable { "true" } else { "false" }.into()),
        Value::U(impacts_per_period as u64),
        Value::U(period as u64),
        match event {
            Some(e) => Value::S(e.into()),
            None => Value::Empty,
        },
    ]
}

/// Columns of a two-parameter curve (`continue2`):
/// `ratio,gap_mm,kind,rms_m,max_abs_multiplier,on_boundary,test_function,residual,
/// impacts_per_period,event`. `kind` is the curve's (`fold`, `period-doubling`, `torus`,
/// `branch-point`, `grazing`), `on_boundary` `true` where no other multiplier is outside the unit
/// circle (the point is on the edge of stability), `test_function` the augmented system's test
/// value (≈ 0), `residual` the orbit's `max |P(x) − x|` in scaled units, `event` empty or a
/// codimension-two point (`meets-fold`, `meets-branch-point`, `meets-period-doubling`,
/// `meets-torus`, `meets-grazing`, `strong-resonance`).
pub fn curve2_schema() -> Schema {
    Schema {
        columns: vec![
            col("ratio", Format::Plain),
            col("gap_mm", Format::Plain),
            col("kind", Format::Text),
            col("rms_m", Format::Sci),
            col("max_abs_multiplier", Format::Plain),
            col("on_boundary", Format::Text),
            col("test_function", Format::Sci),
            col("residual", Format::Sci),
            col("impacts_per_period", Format::Count),
            opt("event", Format::Text),
        ],
    }
}

/// One row of [`curve2_schema`].
pub fn curve2_values<F: vibrobar_core::analysis::orbit::Flow>(
    kind: vibrobar_core::analysis::orbit::two_param::CurveKind,
    p: &vibrobar_core::analysis::orbit::two_param::CurvePoint<F>,
) -> Vec<Value> {
    let edge = vibrobar_core::analysis::orbit::two_param::on_boundary(p);
    vec![
        Value::F(p.ratio),
        Value::F(p.gap_m * 1e3),
        Value::S(kind.as_str().into()),
        Value::F(p.orbit.rms_m),
        Value::F(p.orbit.max_abs_multiplier()),
        Value::S(if edge { "true" } else { "false" }.into()),
        Value::F(p.test),
        Value::F(p.residual),
        Value::U(p.orbit.impacts_per_period as u64),
        match p.event {
            Some(e) => Value::S(e.as_str().into()),
            None => Value::Empty,
        },
    ]
}

/// One row of an ensemble CSV (`ensemble`).
#[derive(Debug, Clone, PartialEq)]
pub struct EnsembleCsvRow {
    /// Frequency ratio.
    pub ratio: f64,
    /// Gap in mm.
    pub gap_mm: f64,
    /// Members run.
    pub members: u64,
    /// Mean, standard deviation, smallest and largest damped RMS over the members, m.
    pub rms_m: [f64; 4],
    /// `regime:count` joined by `;` ([`regime_counts`]).
    pub regimes: String,
}

/// Columns of an ensemble CSV.
pub fn ensemble_schema() -> Schema {
    Schema {
        columns: vec![
            col("ratio", Format::Coord),
            col("gap_mm", Format::Coord),
            col("members", Format::Count),
            col("mean_rms_m", Format::Sci),
            col("std_rms_m", Format::Sci),
            col("min_rms_m", Format::Sci),
            col("max_rms_m", Format::Sci),
            col("regimes", Format::Text),
        ],
    }
}

impl EnsembleCsvRow {
    /// The fields in column order.
    pub fn values(&self) -> Vec<Value> {
        let mut v = vec![
            Value::F(self.ratio),
            Value::F(self.gap_mm),
            Value::U(self.members),
        ];
        v.extend(self.rms_m.iter().map(|x| Value::F(*x)));
        v.push(Value::S(self.regimes.clone()));
        v
    }

    /// A row read back by [`ensemble_schema`].
    pub fn from_values(v: &[Value]) -> Self {
        EnsembleCsvRow {
            ratio: v[0].f(),
            gap_mm: v[1].f(),
            members: v[2].f() as u64,
            rms_m: [v[3].f(), v[4].f(), v[5].f(), v[6].f()],
            regimes: v[7].s().to_string(),
        }
    }
}

/// One row of the paper's initial-condition ensemble (`ic_ensemble.csv`).
#[derive(Debug, Clone, PartialEq)]
pub struct IcEnsembleCsvRow {
    /// Parameter set (variant key).
    pub set: String,
    /// Friction model name (empty when the set is unknown).
    pub friction: String,
    /// Friction force override in N (`None`: the stated η/r·m_d·g).
    pub friction_force_n: Option<f64>,
    /// Gap in mm.
    pub gap_mm: f64,
    /// Frequency ratio.
    pub ratio: f64,
    /// Solver name.
    pub solver: String,
    /// Seed.
    pub seed: u64,
    /// Members.
    pub members: u64,
    /// RMS of the run from the paper's start, m.
    pub rms_rest_m: f64,
    /// Impacts per cycle of that run.
    pub impacts_per_cycle_rest: f64,
    /// Mean and standard deviation of the members' RMS, m.
    pub mean_rms_m: f64,
    /// Standard deviation.
    pub std_rms_m: f64,
    /// `std/mean`.
    pub rel_spread: f64,
    /// `mean/rest − 1`.
    pub mean_vs_rest: f64,
    /// Smallest member RMS, m.
    pub min_rms_m: f64,
    /// Largest member RMS, m.
    pub max_rms_m: f64,
    /// Members with at least one impact in the RMS window.
    pub impacting_members: u64,
    /// Their fraction.
    pub impacting_fraction: f64,
    /// `regime:count` joined by `;` ([`regime_counts`]).
    pub regimes: String,
}

/// Columns of `ic_ensemble.csv`.
pub fn ic_ensemble_schema() -> Schema {
    Schema {
        columns: vec![
            col("set", Format::Text),
            opt("friction", Format::Text),
            opt("friction_force_n", Format::Plain),
            col("gap_mm", Format::Grid),
            col("ratio", Format::Grid),
            col("solver", Format::Text),
            col("seed", Format::Count),
            col("members", Format::Count),
            col("rms_rest_m", Format::Sci),
            col("impacts_per_cycle_rest", Format::Sci),
            col("mean_rms_m", Format::Sci),
            col("std_rms_m", Format::Sci),
            col("rel_spread", Format::Sci),
            col("mean_vs_rest", Format::Sci),
            col("min_rms_m", Format::Sci),
            col("max_rms_m", Format::Sci),
            col("impacting_members", Format::Count),
            col("impacting_fraction", Format::Plain),
            col("regimes", Format::Text),
        ],
    }
}

impl IcEnsembleCsvRow {
    /// The fields in column order.
    pub fn values(&self) -> Vec<Value> {
        vec![
            Value::S(self.set.clone()),
            if self.friction.is_empty() {
                Value::Empty
            } else {
                Value::S(self.friction.clone())
            },
            self.friction_force_n.map_or(Value::Empty, Value::F),
            Value::F(self.gap_mm),
            Value::F(self.ratio),
            Value::S(self.solver.clone()),
            Value::U(self.seed),
            Value::U(self.members),
            Value::F(self.rms_rest_m),
            Value::F(self.impacts_per_cycle_rest),
            Value::F(self.mean_rms_m),
            Value::F(self.std_rms_m),
            Value::F(self.rel_spread),
            Value::F(self.mean_vs_rest),
            Value::F(self.min_rms_m),
            Value::F(self.max_rms_m),
            Value::U(self.impacting_members),
            Value::F(self.impacting_fraction),
            Value::S(self.regimes.clone()),
        ]
    }

    /// A row read back by [`ic_ensemble_schema`].
    pub fn from_values(v: &[Value]) -> Self {
        let opt_f = |x: &Value| match x {
            Value::Empty => None,
            x => Some(x.f()),
        };
        IcEnsembleCsvRow {
            set: v[0].s().into(),
            friction: v[1].s().into(),
            friction_force_n: opt_f(&v[2]),
            gap_mm: v[3].f(),
            ratio: v[4].f(),
            solver: v[5].s().into(),
            seed: v[6].f() as u64,
            members: v[7].f() as u64,
            rms_rest_m: v[8].f(),
            impacts_per_cycle_rest: v[9].f(),
            mean_rms_m: v[10].f(),
            std_rms_m: v[11].f(),
            rel_spread: v[12].f(),
            mean_vs_rest: v[13].f(),
            min_rms_m: v[14].f(),
            max_rms_m: v[15].f(),
            impacting_members: v[16].f() as u64,
            impacting_fraction: v[17].f(),
            regimes: v[18].s().into(),
        }
    }
}

/// Write a CSV of `schema` from its rows' fields, atomically. Every row is checked as it will
/// be read back ([`Schema::check`]): a NaN or inf stops the write and nothing is left.
pub fn write_csv<I>(path: &Path, schema: &Schema, rows: I) -> Result<()>
where
    I: IntoIterator,
    I::Item: AsRef<[Value]>,
{
    let mut bad: Option<(usize, String)> = None;
    let res = write_with(path, |w| {
        writeln!(w, "{}", schema.header())?;
        let mut line = String::with_capacity(128);
        for (i, r) in rows.into_iter().enumerate() {
            if let Err(why) = schema.check(r.as_ref()) {
                bad = Some((i + 2, why));
                return Err(std::io::Error::other("row refused"));
            }
            line.clear();
            schema.format_into(r.as_ref(), &mut line);
            line.push('\n');
            w.write_all(line.as_bytes())?;
        }
        Ok(())
    });
    match bad {
        Some((line, why)) => Err(IoError::BadFileRow {
            path: path.to_path_buf(),
            line,
            why,
        }),
        None => res,
    }
}

/// Read a whole CSV of `schema`: the header must be the schema's, and every row is parsed by
/// it (field count, numbers, finiteness), errors naming the file and line.
pub fn read_csv(path: &Path, schema: &Schema) -> Result<Vec<Vec<Value>>> {
    let text = std::fs::read_to_string(path).map_err(IoError::os(path))?;
    let mut lines = text.lines();
    let header = lines.next().unwrap_or("");
    if header != schema.header() {
        return Err(IoError::Corrupt {
            path: path.to_path_buf(),
            line: 1,
            why: format!("header {header:?}, expected {:?}", schema.header()),
        });
    }
    lines
        .enumerate()
        .map(|(i, l)| schema.parse_at(l, path, i + 2))
        .collect()
}

// ---------------------------------------------------------------------------------------------
// time-domain judging of cutting runs (issue #14): width diagrams and time-domain lobes

/// Metadata kind of a width–amplitude diagram (`vibrobar width-diagram`).
pub const WIDTH_DIAGRAM_KIND: &str = "width-diagram";
/// Metadata kind of time-domain lobes (`vibrobar lobes --time-domain`).
pub const TD_LOBES_KIND: &str = "td-lobes";

/// Columns of a width–amplitude diagram; `(width_m, disturbance, bar)` identify a row. The
/// measured columns are empty for a run that hit the event limit (`regime = event-limit`).
pub fn width_diagram_schema() -> Schema {
    Schema {
        columns: vec![
            col("width_m", Format::Coord),
            col("disturbance", Format::Text),
            col("bar", Format::Text),
            opt("peak_to_peak_m", Format::Sci),
            opt("out_of_cut_fraction", Format::Plain),
            opt("impacts_per_rev", Format::Plain),
            col("regime", Format::Text),
            col("static_deflection_m", Format::Sci),
            opt("growth_per_rev", Format::Sci),
            col("acceptable", Format::Count),
            col("spindle_rpm", Format::Coord),
        ],
    }
}

/// One width-diagram line from a core row.
pub fn width_diagram_values(
    r: &vibrobar_core::analysis::time_domain::DiagramRow,
    spindle_rpm: f64,
) -> Vec<Value> {
    let j = &r.judged;
    let num = |x: f64| {
        if j.event_limit {
            Value::Empty
        } else {
            Value::F(x)
        }
    };
    vec![
        Value::F(r.width_m),
        Value::S(r.disturbance.as_str().into()),
        Value::S(r.bar.as_str().into()),
        num(j.peak_to_peak_m),
        num(j.out_of_cut_fraction),
        num(j.impacts_per_rev),
        Value::S(j.regime.as_str().into_owned()),
        Value::F(j.static_deflection_m),
        num(j.growth_per_rev),
        Value::U(u64::from(j.acceptable)),
        Value::F(spindle_rpm),
    ]
}

/// The journal key of a width-diagram row.
pub fn width_diagram_key(width_m: f64, disturbance: &str, bar: &str) -> String {
    width_diagram_schema().format(&[
        Value::F(width_m),
        Value::S(disturbance.into()),
        Value::S(bar.into()),
    ])
}

/// Columns of time-domain lobes; `spindle_rpm` identifies a row. `non_monotonic` is 1 where a
/// width below a bisection result failed; `capped` counts searches still acceptable at the
/// doubling cap (their width is a lower bound).
pub fn td_lobes_schema() -> Schema {
    Schema {
        columns: vec![
            col("spindle_rpm", Format::Coord),
            col("b_lim_m", Format::Sci),
            col("b_lim_solid_m", Format::Sci),
            col("b_solid_small_m", Format::Sci),
            col("b_solid_large_m", Format::Sci),
            col("b_damped_small_m", Format::Sci),
            col("b_damped_large_m", Format::Sci),
            col("event_limit_runs", Format::Count),
            col("non_monotonic", Format::Count),
            col("capped", Format::Count),
            col("runs", Format::Count),
        ],
    }
}

/// One time-domain lobes line from a core row.
pub fn td_lobes_values(r: &vibrobar_core::analysis::time_domain::TdLobeRow) -> Vec<Value> {
    let s = &r.searches;
    vec![
        Value::F(r.spindle_rpm),
        Value::F(r.linear.b_lim_m),
        Value::F(r.linear.b_lim_solid_m),
        Value::F(s[0].width_m),
        Value::F(s[1].width_m),
        Value::F(s[2].width_m),
        Value::F(s[3].width_m),
        Value::U(u64::from(r.event_limit_runs())),
        Value::U(u64::from(r.non_monotonic())),
        Value::U(s.iter().filter(|x| x.capped).count() as u64),
        Value::U(s.iter().map(|x| u64::from(x.runs)).sum()),
    ]
}

/// The journal key of a time-domain lobes row.
pub fn td_lobes_key(spindle_rpm: f64) -> String {
    td_lobes_schema().format(&[Value::F(spindle_rpm)])
}

#[cfg(test)]
mod td_tests {
    use super::*;

    /// The issue's header prefixes, and the kinds merge knows.
    #[test]
    fn headers_start_as_the_issue_says() {
        assert!(width_diagram_schema().header().starts_with(
            "width_m,disturbance,bar,peak_to_peak_m,out_of_cut_fraction,impacts_per_rev,regime,static_deflection_m"
        ));
        assert!(td_lobes_schema().header().starts_with(
            "spindle_rpm,b_lim_m,b_lim_solid_m,b_solid_small_m,b_solid_large_m,b_damped_small_m,b_damped_large_m,event_limit_runs"
        ));
        for (kind, s) in [
            (WIDTH_DIAGRAM_KIND, width_diagram_schema()),
            (TD_LOBES_KIND, td_lobes_schema()),
        ] {
            assert_eq!(Schema::for_file(kind, &s.header()), Some(s));
        }
    }
}

// ---------------------------------------------------------------------------------------------
// design by time-domain lobes (issue #14 §3): `vibrobar lobe-design`

/// Metadata kind of a design study by time-domain lobes (`vibrobar lobe-design`).
pub const LOBE_DESIGN_KIND: &str = "lobe-design";

/// Columns of a design study by time-domain lobes, one row per design; `(gap_m, <axis>)`
/// identify a row, where `<axis>` is `ball_mass_kg` (lumped bar) or `position_m` (cavity centre
/// from the clamp, beam). The widths are the large disturbance's over the band of speeds:
/// the damped bar's worst case (at `worst_rpm`) and mean, the solid bar's over the same band,
/// and their ratios (`worst_gain`, `mean_gain`; empty when the solid bar has no acceptable
/// width). The counts are the damped searches': runs at the event limit, speeds flagged
/// non-monotonic or capped, runs made. `worst_regime` is the damped run's at the worst case;
/// where it is `chaotic`, the spread columns give the worst speed's width over seeded
/// perturbations of the disturbance (min, mean, max; empty otherwise).
pub fn lobe_design_schema(axis: vibrobar_core::analysis::lobe_design::DesignAxis) -> Schema {
    Schema {
        columns: vec![
            col("gap_m", Format::Coord),
            col(axis.column(), Format::Coord),
            col("worst_width_m", Format::Sci),
            col("worst_rpm", Format::Coord),
            col("mean_width_m", Format::Sci),
            col("solid_worst_width_m", Format::Sci),
            col("solid_worst_rpm", Format::Coord),
            col("solid_mean_width_m", Format::Sci),
            opt("worst_gain", Format::Plain),
            opt("mean_gain", Format::Plain),
            col("event_limit_runs", Format::Count),
            col("non_monotonic", Format::Count),
            col("capped", Format::Count),
            col("runs", Format::Count),
            opt("worst_regime", Format::Text),
            opt("spread_min_width_m", Format::Sci),
            opt("spread_mean_width_m", Format::Sci),
            opt("spread_max_width_m", Format::Sci),
        ],
    }
}

/// The design axis of a lobe-design header (its second column).
pub fn lobe_design_axis(header: &str) -> Option<vibrobar_core::analysis::lobe_design::DesignAxis> {
    vibrobar_core::analysis::lobe_design::DesignAxis::from_column(header.split(',').nth(1)?)
}

/// One lobe-design line from a core row.
pub fn lobe_design_values(r: &vibrobar_core::analysis::lobe_design::DesignRow) -> Vec<Value> {
    let gain = |g: Option<f64>| g.map_or(Value::Empty, Value::F);
    vec![
        Value::F(r.point.gap_m),
        Value::F(r.point.value),
        Value::F(r.damped.worst_width_m),
        Value::F(r.damped.worst_rpm),
        Value::F(r.damped.mean_width_m),
        Value::F(r.solid.worst_width_m),
        Value::F(r.solid.worst_rpm),
        Value::F(r.solid.mean_width_m),
        gain(r.worst_gain()),
        gain(r.mean_gain()),
        Value::U(u64::from(r.event_limit_runs)),
        Value::U(u64::from(r.non_monotonic)),
        Value::U(u64::from(r.capped)),
        Value::U(u64::from(r.runs)),
        r.worst_regime
            .map_or(Value::Empty, |g| Value::S(g.as_str().into_owned())),
        r.spread.map_or(Value::Empty, |s| Value::F(s.min_width_m)),
        r.spread.map_or(Value::Empty, |s| Value::F(s.mean_width_m)),
        r.spread.map_or(Value::Empty, |s| Value::F(s.max_width_m)),
    ]
}

/// The journal key of a lobe-design row (its first two columns).
pub fn lobe_design_key(
    axis: vibrobar_core::analysis::lobe_design::DesignAxis,
    gap_m: f64,
    value: f64,
) -> String {
    lobe_design_schema(axis).format(&[Value::F(gap_m), Value::F(value)])
}

/// Read a whole lobe-design CSV back into core rows (index = row order, as a whole file is
/// written), with its axis.
pub fn read_lobe_design_csv(
    path: &Path,
) -> Result<(
    vibrobar_core::analysis::lobe_design::DesignAxis,
    Vec<vibrobar_core::analysis::lobe_design::DesignRow>,
)> {
    use vibrobar_core::analysis::lobe_design::{BandScore, DesignPoint, DesignRow, WidthSpread};
    use vibrobar_core::analysis::time_domain::RevRegime;
    let text = std::fs::read_to_string(path).map_err(IoError::os(path))?;
    let header = text.lines().next().unwrap_or("");
    let axis = lobe_design_axis(header).ok_or_else(|| IoError::Corrupt {
        path: path.to_path_buf(),
        line: 1,
        why: format!("header {header:?} is not a lobe-design header"),
    })?;
    let rows = read_csv(path, &lobe_design_schema(axis))?;
    let count = |v: &Value| v.f() as u32;
    Ok((
        axis,
        rows.iter()
            .enumerate()
            .map(|(index, v)| DesignRow {
                point: DesignPoint {
                    index,
                    gap_m: v[0].f(),
                    value: v[1].f(),
                },
                damped: BandScore {
                    worst_width_m: v[2].f(),
                    worst_rpm: v[3].f(),
                    mean_width_m: v[4].f(),
                },
                solid: BandScore {
                    worst_width_m: v[5].f(),
                    worst_rpm: v[6].f(),
                    mean_width_m: v[7].f(),
                },
                event_limit_runs: count(&v[10]),
                non_monotonic: count(&v[11]),
                capped: count(&v[12]),
                runs: count(&v[13]),
                worst_regime: match &v[14] {
                    Value::S(t) => RevRegime::parse(t),
                    _ => None,
                },
                spread: match (&v[15], &v[16], &v[17]) {
                    (Value::F(lo), Value::F(mean), Value::F(hi)) => Some(WidthSpread {
                        min_width_m: *lo,
                        mean_width_m: *mean,
                        max_width_m: *hi,
                    }),
                    _ => None,
                },
            })
            .collect(),
    ))
}

#[cfg(test)]
mod lobe_design_tests {
    use super::*;
    use vibrobar_core::analysis::lobe_design::DesignAxis;

    /// Both axes' headers, and the kind merge knows.
    #[test]
    fn headers_and_kind() {
        assert_eq!(
            lobe_design_schema(DesignAxis::BallMass).header(),
            "gap_m,ball_mass_kg,worst_width_m,worst_rpm,mean_width_m,solid_worst_width_m,\
             solid_worst_rpm,solid_mean_width_m,worst_gain,mean_gain,event_limit_runs,\
             non_monotonic,capped,runs,worst_regime,spread_min_width_m,spread_mean_width_m,\
             spread_max_width_m"
        );
        for a in DesignAxis::ALL {
            let s = lobe_design_schema(a);
            assert_eq!(lobe_design_axis(&s.header()), Some(a));
            assert_eq!(Schema::for_file(LOBE_DESIGN_KIND, &s.header()), Some(s));
        }
    }
}

// ---------------------------------------------------------------------------------------------
// modes of a structure (`vibrobar modes`)

/// Columns of a modes CSV: one row per mode, shapes normalised to 1 at the tip and
/// `modal_mass_kg` in that normalisation (`ρAL/4` for a uniform bar; see core `structure`).
pub fn modes_schema() -> Schema {
    Schema {
        columns: vec![
            col("mode", Format::Count),
            col("frequency_hz", Format::Plain),
            col("modal_mass_kg", Format::Plain),
            col("shape_cavity", Format::Plain),
            col("shape_force", Format::Plain),
            col("shape_response", Format::Plain),
        ],
    }
}

/// The fields of mode `n` (1-based), in column order.
pub fn modes_values(n: usize, m: &vibrobar_core::structure::Mode) -> Vec<Value> {
    vec![
        Value::U(n as u64),
        Value::F(m.omega_rad_s / (2.0 * std::f64::consts::PI)),
        Value::F(m.modal_mass_kg),
        Value::F(m.shape_cavity),
        Value::F(m.shape_force),
        Value::F(m.shape_response),
    ]
}

/// Write a modes CSV (atomic, under the output-path policy, through [`write_csv`]: a
/// non-finite value stops the write and nothing is left).
pub fn write_modes_csv(path: &Path, model: &vibrobar_core::structure::ModalModel) -> Result<()> {
    let rows = model
        .modes()
        .iter()
        .enumerate()
        .map(|(k, m)| modes_values(k + 1, m));
    write_csv(path, &modes_schema(), rows)
}

// ---------------------------------------------------------------------------------------------
// lobes

/// `vibrobar lobes`: the stability boundary of regenerative chatter at each spindle speed, for
/// the damped bar with the ball free and stuck, and for the solid reference; the lobe index `j`
/// of each boundary (`ωτ = ε + 2πj`).
pub fn lobes_schema() -> Schema {
    Schema {
        columns: vec![
            col("spindle_rpm", Format::Coord),
            col("b_lim_m", Format::Plain),
            col("chatter_frequency_hz", Format::Plain),
            col("b_lim_ball_stuck_m", Format::Plain),
            col("chatter_frequency_ball_stuck_hz", Format::Plain),
            col("b_lim_solid_m", Format::Plain),
            col("chatter_frequency_solid_hz", Format::Plain),
            col("lobe", Format::Count),
            col("lobe_ball_stuck", Format::Count),
            col("lobe_solid", Format::Count),
        ],
    }
}

/// The fields of one lobes row, in column order.
pub fn lobes_values(r: &vibrobar_core::analysis::lobes::LobeRow) -> Vec<Value> {
    vec![
        Value::F(r.spindle_rpm),
        Value::F(r.ball_free.b_lim_m),
        Value::F(r.ball_free.chatter_frequency_hz),
        Value::F(r.ball_stuck.b_lim_m),
        Value::F(r.ball_stuck.chatter_frequency_hz),
        Value::F(r.solid.b_lim_m),
        Value::F(r.solid.chatter_frequency_hz),
        Value::U(r.ball_free.lobe),
        Value::U(r.ball_stuck.lobe),
        Value::U(r.solid.lobe),
    ]
}

/// Write a lobes CSV (atomic, under the output-path policy, through [`write_csv`]).
pub fn write_lobes_csv(
    path: &Path,
    rows: &[vibrobar_core::analysis::lobes::LobeRow],
) -> Result<()> {
    write_csv(path, &lobes_schema(), rows.iter().map(lobes_values))
}

/// `vibrobar lobes --frf`: the stability boundary of a measured receptance at each spindle
/// speed, with its chatter frequency and lobe index.
pub fn lobes_frf_schema() -> Schema {
    Schema {
        columns: vec![
            col("spindle_rpm", Format::Coord),
            col("b_lim_m", Format::Plain),
            col("chatter_frequency_hz", Format::Plain),
            col("lobe", Format::Count),
        ],
    }
}

/// One `lobes --frf` row: the speed and its boundary, by [`lobes_frf_schema`].
pub fn lobes_frf_values(
    spindle_rpm: f64,
    b: &vibrobar_core::analysis::lobes::BoundaryPoint,
) -> Vec<Value> {
    vec![
        Value::F(spindle_rpm),
        Value::F(b.b_lim_m),
        Value::F(b.chatter_frequency_hz),
        Value::U(b.lobe),
    ]
}

/// Write a `lobes --frf` CSV: `(spindle_rpm, boundary)` rows.
pub fn write_lobes_frf_csv(
    path: &Path,
    rows: &[(f64, vibrobar_core::analysis::lobes::BoundaryPoint)],
) -> Result<()> {
    write_csv(
        path,
        &lobes_frf_schema(),
        rows.iter().map(|(n, b)| lobes_frf_values(*n, b)),
    )
}

// ---------------------------------------------------------------------------------------------
// contact-test

/// `vibrobar contact-test`: one impact of the ball on a rigid fixed wall per approach speed.
pub fn contact_test_schema() -> Schema {
    Schema {
        columns: vec![
            col("speed_m_s", Format::Plain),
            col("contact_time_s", Format::Plain),
            col("restitution", Format::Plain),
            col("max_force_n", Format::Plain),
            col("max_penetration_m", Format::Plain),
        ],
    }
}

/// The fields of one impact, in column order.
pub fn contact_test_values(o: &vibrobar_core::analysis::contact_test::ImpactOutcome) -> Vec<Value> {
    vec![
        Value::F(o.speed_m_s),
        Value::F(o.contact_time_s),
        Value::F(o.restitution),
        Value::F(o.max_force_n),
        Value::F(o.max_penetration_m),
    ]
}

/// Write a contact-test CSV (atomic, under the output-path policy, through [`write_csv`]).
pub fn write_contact_test_csv(
    path: &Path,
    rows: &[vibrobar_core::analysis::contact_test::ImpactOutcome],
) -> Result<()> {
    write_csv(
        path,
        &contact_test_schema(),
        rows.iter().map(contact_test_values),
    )
}

// ---------------------------------------------------------------------------------------------
// whole files

/// Write any serializable value as pretty JSON.
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    write_with(path, |w| {
        serde_json::to_writer_pretty(&mut *w, value)?;
        writeln!(w)
    })
}

/// Write a text file.
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    crate::atomic::write_atomic(path, text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::atomic::partial_path;

    #[test]
    fn partial_sits_beside_the_target() {
        let p = partial_path(Path::new("out/dir/sweep.csv"));
        assert_eq!(p, Path::new("out/dir/sweep.csv.partial"));
    }

    #[test]
    fn grid_numbers_lose_binary_noise_only() {
        assert_eq!(grid_num(0.95 + 5.0 * 0.01), "1");
        assert_eq!(grid_num(0.1), "0.1");
        assert_eq!(grid_num(0.25), "0.25");
        assert_eq!(grid_num(1.0e-3 * 1e3), "1");
        assert_eq!(grid_num(20.0), "20");
    }

    #[test]
    fn headers_are_the_contract() {
        assert_eq!(
            sweep_schema().header(),
            "ratio,gap_mm,friction,solver,rms_solid_m,rms_damped_m,reduction_pct,impacts"
        );
        assert_eq!(
            history_schema().header(),
            "t_s,u_m,du_m_s,v_m,dv_m_s,w_m,dw_m_s"
        );
        assert_eq!(
            map_schema(&[Axis::Restitution]).header(),
            "ratio,gap_mm,restitution,rms_solid_m,rms_damped_m,reduction_pct,impacts_per_cycle,regime"
        );
        assert_eq!(
            map_extra_axes(&map_schema(&[Axis::FrictionForceN, Axis::MassRatio]).header()),
            Some(vec![Axis::FrictionForceN, Axis::MassRatio])
        );
        assert_eq!(map_extra_axes("ratio,gap_mm,x"), None);
        assert_eq!(
            placement_schema().header(),
            "position_mm,gap_mm,mean_reduction_pct,worst_rms_m,worst_ratio,min_reduction_pct,\
             mean_impacts_per_cycle,regime"
        );
        assert_eq!(
            continuation_schema().header(),
            "param,rms_m,max_abs_multiplier,stable,impacts_per_period,period,event"
        );
    }

    #[test]
    fn optimum_rows_read_back_with_their_empty_fields() {
        let sc = optimum_schema(&[Axis::Restitution]);
        assert_eq!(
            sc.header(),
            "ratio,best_gap_mm,best_reduction_pct,rms_damped_m,rms_solid_m,impacts_per_cycle,\
             regime,criterion,best_restitution,friction_work_j,work_input_j"
        );
        let band = sc
            .parse("band,0.1,47.0,1.27e-5,,,,band-mean-reduction,0.5,,")
            .unwrap();
        assert_eq!(band[4], Value::Empty);
        assert_eq!(band[9], Value::Empty);
        // Empty only where the schema allows it.
        let e = sc
            .parse("band,,47.0,1.27e-5,,,,band-mean-reduction,0.5,,")
            .unwrap_err();
        assert!(e.contains("best_gap_mm"), "{e}");
    }

    #[test]
    fn sweep_row_formats_and_reads_back() {
        let r = SweepCsvRow {
            ratio: 0.95 + 5.0 * 0.01,
            gap_mm: 0.1,
            friction: "coulomb".into(),
            solver: "exact".into(),
            rms_solid_m: 5.7e-5,
            rms_damped_m: 1.25e-5,
            reduction_pct: 78.070_175_438_596_5,
            impacts: 412,
        };
        let line = sweep_csv_line(&r);
        assert_eq!(line, "1,0.1,coulomb,exact,5.7e-5,1.25e-5,78.0702,412");
        let back = sweep_schema().parse(&line).unwrap();
        assert_eq!(back[6], Value::F(78.0702));
        assert_eq!(back[7], Value::U(412));
        assert!(line.starts_with(&(sweep_key(1.0, 0.1) + ",")));
    }

    #[test]
    fn reader_refuses_non_finite_numbers_and_wrong_field_counts() {
        let s = sweep_schema();
        for (line, want) in [
            (
                "1,0.1,none,exact,NaN,1e-5,3.0,4",
                "rms_solid_m = NaN is not a finite number",
            ),
            (
                "1,0.1,none,exact,1e-5,inf,3.0,4",
                "rms_damped_m = inf is not a finite number",
            ),
            (
                "1,0.1,none,exact,1e-5,1e-5,3.0",
                "7 fields, the header has 8",
            ),
            (
                "1,0.1,none,exact,1e-5,1e-5,3.0,-4",
                "impacts = \"-4\" is not a whole number",
            ),
        ] {
            let e = s.parse(line).unwrap_err();
            assert!(e.contains(want), "{line}: {e}");
        }
    }

    /// B3: the CSVs of poincare, bifurcation, ensemble and the paper's ic_ensemble.csv were
    /// formatted by hand beside their readers. Each is now a schema: the text is the one the
    /// hand-written `format!` gave (pinned here), and it reads back through the same schema.
    #[test]
    fn regression_explore_and_ic_ensemble_csvs_are_schemas_with_the_old_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let st = State {
            t_s: 0.041_514_264_706_963_74,
            u_m: -1.646_769_290_061_605e-5,
            du_m_s: -8.774_971_969_108_059e-2,
            v_m: -1.2e-6,
            dv_m_s: -0.165,
            cavity: None,
        };
        let p = poincare_values(&st);
        assert_eq!(
            poincare_schema().format(&p.map(Value::F)),
            format!("{},{:e},{:e},{:e},{:e}", p[0], p[1], p[2], p[3], p[4])
        );
        assert_eq!(poincare_schema().header(), "t_s,u_m,du_m_s,w_m,dw_m_s");
        let b = [
            Value::F(0.95 + 0.01),
            Value::F(0.25),
            Value::F(-4.5e-5),
            Value::F(2.7e-3),
        ];
        assert_eq!(
            bifurcation_schema("ratio").format(&b),
            format!(
                "{},{},{:e},{:e}",
                fmt_coord(0.95 + 0.01),
                0.25,
                -4.5e-5,
                2.7e-3
            )
        );
        assert_eq!(
            bifurcation_schema("gap_mm").header(),
            "gap_mm,t_s,u_m,du_m_s"
        );
        assert_eq!(
            bifurcation_impacts_schema("gap_mm").header(),
            "gap_mm,t_s,wall,dw_m_s"
        );
        let e = EnsembleCsvRow {
            ratio: 0.98,
            gap_mm: 0.1,
            members: 3,
            rms_m: [1.3e-5, 3.2e-6, 1.06e-5, 1.7e-5],
            regimes: regime_counts(&[(Regime::Chaotic, 2), (Regime::None, 1)]),
        };
        assert_eq!(
            ensemble_schema().format(&e.values()),
            "0.98,0.1,3,1.3e-5,3.2e-6,1.06e-5,1.7e-5,chaotic:2;none:1"
        );
        let path = dir.path().join("e.csv");
        write_csv(&path, &ensemble_schema(), [e.values()]).unwrap();
        let back = read_csv(&path, &ensemble_schema()).unwrap();
        assert_eq!(EnsembleCsvRow::from_values(&back[0]), e);
        let ic = IcEnsembleCsvRow {
            set: "frictionless".into(),
            friction: "none".into(),
            friction_force_n: None,
            gap_mm: 0.1,
            ratio: 0.95,
            solver: "exact".into(),
            seed: 1,
            members: 4,
            rms_rest_m: 1.16e-5,
            impacts_per_cycle_rest: 0.0,
            mean_rms_m: 1.04e-5,
            std_rms_m: 3.6e-7,
            rel_spread: 3.5e-2,
            mean_vs_rest: -0.1,
            min_rms_m: 9.9e-6,
            max_rms_m: 1.07e-5,
            impacting_members: 4,
            impacting_fraction: 1.0,
            regimes: "chaotic:4".into(),
        };
        assert_eq!(
            ic_ensemble_schema().format(&ic.values()),
            "frictionless,none,,0.1,0.95,exact,1,4,1.16e-5,0e0,1.04e-5,3.6e-7,3.5e-2,-1e-1,\
             9.9e-6,1.07e-5,4,1,chaotic:4"
        );
        let path = dir.path().join("ic.csv");
        let with_force = IcEnsembleCsvRow {
            friction_force_n: Some(20.0),
            ..ic.clone()
        };
        write_csv(
            &path,
            &ic_ensemble_schema(),
            [ic.values(), with_force.values()],
        )
        .unwrap();
        let back = read_csv(&path, &ic_ensemble_schema()).unwrap();
        assert_eq!(IcEnsembleCsvRow::from_values(&back[0]), ic);
        assert_eq!(IcEnsembleCsvRow::from_values(&back[1]), with_force);
    }

    #[test]
    fn regression_schema_writer_refuses_nan_and_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.csv");
        let row = |x: f64| {
            vec![
                Value::F(0.1),
                Value::F(x),
                Value::F(0.0),
                Value::F(0.0),
                Value::F(0.0),
            ]
        };
        let e = write_csv(&path, &poincare_schema(), [row(1.0), row(f64::NAN)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3") && e.contains("u_m = NaN"), "{e}");
        assert!(!path.exists() && !partial_path(&path).exists());
        // A damaged file is refused by the same schema, with its line.
        std::fs::write(&path, "t_s,u_m,du_m_s,w_m,dw_m_s\n0.1,1e-5,0,0\n").unwrap();
        let e = read_csv(&path, &poincare_schema()).unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("4 fields"), "{e}");
    }
}
