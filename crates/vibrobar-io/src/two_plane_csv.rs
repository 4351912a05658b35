//! CSV schemas of the bar that bends in two planes: the tables of its design points, each an
//! ensemble of starts (`vibrobar sweep`, `ensemble` and `map` on a `[two_plane]` scenario, and
//! the same tables from Python). One definition each, so the file and the Python table cannot
//! drift apart.

use crate::csv::{col, Format, Schema, Value};
use vibrobar_core::analysis::two_plane::{DesignPoint, Spread};
use vibrobar_core::solver::two_plane_rk4::TwoPlaneSummary;

fn schema(columns: &[(&'static str, Format)]) -> Schema {
    Schema {
        columns: columns.iter().map(|&(n, f)| col(n, f)).collect(),
    }
}

fn mean(p: &DesignPoint, f: impl Fn(&TwoPlaneSummary) -> f64) -> f64 {
    p.members.iter().map(f).sum::<f64>() / p.members.len() as f64
}

fn spread(p: &DesignPoint, f: impl Fn(&TwoPlaneSummary) -> f64) -> Spread {
    Spread::of(&p.members.iter().map(f).collect::<Vec<_>>())
}

/// Columns of a sweep: one row per (gap, ratio), gap-major, the ensemble's RMS along the force
/// (mean, standard error, range), its reduction against the bar without the ball, the one-plane
/// model's from the same starts, the RMS per direction, impacts and flight, and the solver.
pub fn sweep_schema() -> Schema {
    use Format::*;
    schema(&[
        ("axial_gap_m", Plain),
        ("ratio", Plain),
        ("solver", Text),
        ("members", Count),
        ("rms_along_force_mean_m", Sci),
        ("rms_along_force_std_err_m", Sci),
        ("rms_along_force_min_m", Sci),
        ("rms_along_force_max_m", Sci),
        ("reduction_mean_pct", Fixed(4)),
        ("reduction_std_err_pct", Fixed(4)),
        ("one_plane_rms_mean_m", Sci),
        ("one_plane_reduction_mean_pct", Fixed(4)),
        ("one_plane_reduction_std_err_pct", Fixed(4)),
        ("solid_rms_m", Sci),
        ("rms_radial_mean_m", Sci),
        ("rms_tangential_mean_m", Sci),
        ("rms_total_mean_m", Sci),
        ("impacts_mean", Fixed(2)),
        ("flight_fraction_mean", Fixed(6)),
    ])
}

/// The row of [`sweep_schema`] for the point at `(gap_m, ratio)`.
pub fn sweep_values(gap_m: f64, ratio: f64, p: &DesignPoint) -> Vec<Value> {
    let s = spread(p, |m| m.rms_along_force_m);
    let red = Spread::of(&p.reductions_pct());
    let one = Spread::of(&p.one_plane_rms_m);
    let one_red = Spread::of(&p.one_plane_reductions_pct());
    use Value::F;
    vec![
        F(gap_m),
        F(ratio),
        Value::S(p.solver.to_string()),
        Value::U(p.members.len() as u64),
        F(s.mean),
        F(s.std_err),
        F(s.min),
        F(s.max),
        F(red.mean),
        F(red.std_err),
        F(one.mean),
        F(one_red.mean),
        F(one_red.std_err),
        F(p.solid_rms_m),
        F(mean(p, |m| m.rms_m[0])),
        F(mean(p, |m| m.rms_m[1])),
        F(mean(p, |m| m.rms_total_m)),
        F(mean(p, |m| m.impacts.iter().sum::<u64>() as f64)),
        F(mean(p, |m| m.flight_fraction)),
    ]
}

/// Columns of an ensemble: one row per member (gap-major, then ratio, then member), with its
/// start, its RMS along the force and reduction beside the one-plane model's from the same
/// start and the bar without its ball, the RMS per direction, impacts per wall and flight.
pub fn ensemble_schema() -> Schema {
    use Format::*;
    schema(&[
        ("axial_gap_m", Plain),
        ("ratio", Plain),
        ("member", Count),
        ("solver", Text),
        ("w_along_start_m", Sci),
        ("w_across_start_m", Sci),
        ("dw_along_start_m_s", Sci),
        ("dw_across_start_m_s", Sci),
        ("rms_along_force_m", Sci),
        ("reduction_pct", Fixed(4)),
        ("one_plane_rms_m", Sci),
        ("one_plane_reduction_pct", Fixed(4)),
        ("solid_rms_m", Sci),
        ("rms_radial_m", Sci),
        ("rms_tangential_m", Sci),
        ("rms_total_m", Sci),
        ("impacts_plug_plus", Count),
        ("impacts_plug_minus", Count),
        ("impacts_wall_plus", Count),
        ("impacts_wall_minus", Count),
        ("flight_fraction", Fixed(6)),
    ])
}

/// The rows of [`ensemble_schema`] for the point at `(gap_m, ratio)`, one per member.
pub fn ensemble_rows(gap_m: f64, ratio: f64, p: &DesignPoint) -> Vec<Vec<Value>> {
    let red = p.reductions_pct();
    let one_red = p.one_plane_reductions_pct();
    use Value::{F, U};
    p.members
        .iter()
        .zip(&p.starts)
        .enumerate()
        .map(|(k, (m, st))| {
            vec![
                F(gap_m),
                F(ratio),
                U(k as u64),
                Value::S(p.solver.to_string()),
                F(st.w_hole_m[0]),
                F(st.w_hole_m[1]),
                F(st.dw_hole_m_s[0]),
                F(st.dw_hole_m_s[1]),
                F(m.rms_along_force_m),
                F(red[k]),
                F(p.one_plane_rms_m[k]),
                F(one_red[k]),
                F(p.solid_rms_m),
                F(m.rms_m[0]),
                F(m.rms_m[1]),
                F(m.rms_total_m),
                U(m.impacts[0]),
                U(m.impacts[1]),
                U(m.impacts[2]),
                U(m.impacts[3]),
                F(m.flight_fraction),
            ]
        })
        .collect()
}

/// Where a cell of a design map lies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapCell {
    /// Frequency ratio.
    pub ratio: f64,
    /// Total axial clearance.
    pub axial_gap_m: f64,
    /// The hole's direction from the radial one.
    pub hole_angle_deg: f64,
    /// The hole's diameter.
    pub hole_diameter_m: f64,
    /// The radial clearance `c_r` it leaves around the ball.
    pub radial_clearance_m: f64,
}

/// Columns of a design map: one row per cell, its ensemble's reduction along the force (mean,
/// standard error, range) beside the one-plane model's, the RMS, impacts on the plugs and on the
/// hole's wall, and flight.
pub fn map_schema() -> Schema {
    use Format::*;
    schema(&[
        ("ratio", Coord),
        ("axial_gap_m", Coord),
        ("hole_angle_deg", Coord),
        ("hole_diameter_m", Coord),
        ("radial_clearance_m", Sci),
        ("solver", Text),
        ("members", Count),
        ("reduction_mean_pct", Fixed(4)),
        ("reduction_std_err_pct", Fixed(4)),
        ("reduction_min_pct", Fixed(4)),
        ("reduction_max_pct", Fixed(4)),
        ("one_plane_reduction_mean_pct", Fixed(4)),
        ("one_plane_reduction_std_err_pct", Fixed(4)),
        ("rms_along_force_mean_m", Sci),
        ("solid_rms_m", Sci),
        ("impacts_plugs_mean", Fixed(2)),
        ("impacts_hole_wall_mean", Fixed(2)),
        ("flight_fraction_mean", Fixed(6)),
    ])
}

/// The row of [`map_schema`] for a cell.
pub fn map_values(c: &MapCell, p: &DesignPoint) -> Vec<Value> {
    let red = Spread::of(&p.reductions_pct());
    let one = Spread::of(&p.one_plane_reductions_pct());
    use Value::F;
    vec![
        F(c.ratio),
        F(c.axial_gap_m),
        F(c.hole_angle_deg),
        F(c.hole_diameter_m),
        F(c.radial_clearance_m),
        Value::S(p.solver.to_string()),
        Value::U(p.members.len() as u64),
        F(red.mean),
        F(red.std_err),
        F(red.min),
        F(red.max),
        F(one.mean),
        F(one.std_err),
        F(mean(p, |m| m.rms_along_force_m)),
        F(p.solid_rms_m),
        F(mean(p, |m| (m.impacts[0] + m.impacts[1]) as f64)),
        F(mean(p, |m| (m.impacts[2] + m.impacts[3]) as f64)),
        F(mean(p, |m| m.flight_fraction)),
    ]
}

/// Columns of a two-plane continuation: the plane (`along_hole`, `across_hole`) and the
/// columns of the one-plane continuation ([`crate::csv::continuation_schema`]) of its branch,
/// the parameter in the two-plane scenario's units.
pub fn continuation_schema() -> Schema {
    let mut columns = vec![col("plane", Format::Text)];
    columns.extend(crate::csv::continuation_schema().columns);
    Schema { columns }
}

/// The row of [`continuation_schema`] for a point of `plane`'s branch, its parameter times
/// `inv`.
pub fn continuation_values(
    plane: &str,
    p: &vibrobar_core::analysis::orbit::continuation::BranchPoint,
    inv: f64,
) -> Vec<Value> {
    let mut v = vec![Value::S(plane.to_string())];
    v.extend(crate::csv::continuation_values(p, inv));
    v
}
