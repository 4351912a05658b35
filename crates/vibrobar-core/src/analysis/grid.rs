//! Grids of parameter values: inclusive ranges, the axes a grid (or a bifurcation diagram) can
//! vary, and rectangular grids with a stable row-major index and round-robin shards.
//!
//! **Grid index**: row-major over the axes in the order given, the last axis varying fastest.
//! With axes `[ratio (n_r values), gap (n_g values)]`, point `i` has ratio index `i / n_g` and gap
//! index `i % n_g`. The index is stable: it depends only on the axes, never on sharding or on the
//! thread count, so a caller can resume by index.
//!
//! **Shards**: [`Grid::shard`]`(k, n)` holds the points with `index ≡ k − 1 (mod n)`
//! (round-robin, so expensive regions such as the resonance band spread over all shards).

use crate::error::ParamError;
use crate::params::{BarModel, Frequency, System};

/// `start + i·step` for `i = 0..=n`, where `n` is the number of whole steps to `stop` (inclusive,
/// with a tolerance of 1e-9 steps for the rounding of decimal input). Computed from `i`, so no
/// rounding drift builds up.
///
/// Input that [`checked_linspace_inclusive`] rejects (non-finite, `step ≤ 0`, `stop < start`,
/// more than [`MAX_GRID_POINTS`] points) gives an empty vector instead of a hang or an
/// out-of-memory abort; use the checked version to report why.
pub fn linspace_inclusive(start: f64, stop: f64, step: f64) -> Vec<f64> {
    checked_linspace_inclusive(start, stop, step).unwrap_or_default()
}

/// Largest grid [`checked_linspace_inclusive`] builds.
pub const MAX_GRID_POINTS: usize = crate::limits::MAX_GRID_POINTS;

/// [`linspace_inclusive`] with an error naming the bad argument.
pub fn checked_linspace_inclusive(
    start: f64,
    stop: f64,
    step: f64,
) -> Result<Vec<f64>, ParamError> {
    crate::params::finite("grid.start", start)?;
    crate::params::finite("grid.stop", stop)?;
    crate::params::positive("grid.step", step)?;
    if stop < start {
        return Err(ParamError::OutOfRange {
            field: "grid.stop",
            value: stop,
            allowed: "[start, ∞)",
        });
    }
    let n = ((stop - start) / step + 1e-9).floor();
    if n >= MAX_GRID_POINTS as f64 {
        return Err(ParamError::OutOfRange {
            field: "grid.step",
            value: step,
            allowed: "[(stop − start)/1e7, ∞) (at most 1e7 points)",
        });
    }
    let n = n as i64;
    Ok((0..=n).map(|i| start + i as f64 * step).collect())
}

/// A parameter a grid (or a bifurcation diagram) can vary.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Axis {
    /// Forcing frequency over the natural frequency of the bar simulated.
    FreqRatio,
    /// Total clearance `gap_m`.
    GapM,
    /// Friction force level (sets the override `friction_force_n`).
    FrictionForceN,
    /// Coefficient of restitution.
    Restitution,
    /// Mass ratio `μ = m_d / M` (sets the ball mass from the damped bar's mass).
    MassRatio,
}

impl Axis {
    /// All axes, in a stable order.
    pub const ALL: [Axis; 5] = [
        Axis::FreqRatio,
        Axis::GapM,
        Axis::FrictionForceN,
        Axis::Restitution,
        Axis::MassRatio,
    ];

    /// Column name: `freq_ratio`, `gap_m`, `friction_force_n`, `restitution`, `mass_ratio`.
    pub fn as_str(&self) -> &'static str {
        match self {
            Axis::FreqRatio => "freq_ratio",
            Axis::GapM => "gap_m",
            Axis::FrictionForceN => "friction_force_n",
            Axis::Restitution => "restitution",
            Axis::MassRatio => "mass_ratio",
        }
    }

    /// Parse [`Axis::as_str`].
    pub fn parse(s: &str) -> Option<Axis> {
        Self::ALL.into_iter().find(|a| a.as_str() == s)
    }

    /// Set this parameter of `sys` to `value`. Axes other than the ratio need a damper.
    /// The value itself is checked later by [`System::validate`].
    pub fn apply(&self, sys: &mut System, value: f64) -> Result<(), ParamError> {
        if *self == Axis::FreqRatio {
            sys.forcing.frequency = Frequency::Ratio(value);
            return Ok(());
        }
        let bar_mass = if *self == Axis::MassRatio {
            mass_ratio_reference_kg(sys, value)?
        } else {
            0.0
        };
        let d = sys.damper.as_mut().ok_or(ParamError::OutOfRange {
            field: self.as_str(),
            value,
            allowed: "only with a damper (the system has no ball)",
        })?;
        match self {
            Axis::FreqRatio => unreachable!("handled above"),
            Axis::GapM => d.gap_m = value,
            Axis::FrictionForceN => d.friction_force_n = Some(value),
            Axis::Restitution => d.restitution = value,
            Axis::MassRatio => d.ball_mass_kg = value * bar_mass,
        }
        Ok(())
    }
}

/// The bar mass `M` of the mass ratio `μ = m_d/M`: the lumped bar's `M`; for a modal bar the
/// first mode's effective mass at the cavity, `m₁/φ₁(x_d)²` (the mass the ball sees in the mode
/// it damps; `M` itself for the lumped bar's unit mode, and independent of how many modes are
/// kept, unlike `1/Σφₙ²/mₙ`, which goes to 0 as N grows). A cavity at a node of mode 1 has no
/// such mass: refused with the axis named.
fn mass_ratio_reference_kg(sys: &System, value: f64) -> Result<f64, ParamError> {
    match &sys.bar {
        BarModel::Lumped(b) => Ok(b.mass_kg),
        BarModel::Modal(m) => {
            let m1 = m.modes()[0];
            let phi = m1.shape_cavity;
            if phi == 0.0 || !(m1.modal_mass_kg / (phi * phi)).is_finite() {
                return Err(ParamError::OutOfRange {
                    field: "mass_ratio (m_d / (m₁/φ₁(x_d)²) on a modal bar)",
                    value,
                    allowed: "only with the cavity off mode 1's node (φ₁(x_d) ≠ 0)",
                });
            }
            Ok(m1.modal_mass_kg / (phi * phi))
        }
    }
}

/// One axis of a grid: a parameter and its values.
#[derive(Debug, Clone, PartialEq)]
pub struct GridAxis {
    /// Parameter.
    pub axis: Axis,
    /// Values, in the order they index.
    pub values: Vec<f64>,
}

/// A point of a grid: its stable index and the value of each axis.
#[derive(Debug, Clone, PartialEq)]
pub struct GridPoint {
    /// Row-major index.
    pub index: usize,
    /// `(axis, value)` in the grid's axis order.
    pub coords: Vec<(Axis, f64)>,
}

impl GridPoint {
    /// Value of `axis` at this point, if the grid has that axis.
    pub fn get(&self, axis: Axis) -> Option<f64> {
        self.coords.iter().find(|(a, _)| *a == axis).map(|c| c.1)
    }
}

/// A rectangular grid over several axes.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    axes: Vec<GridAxis>,
}

impl Grid {
    /// Build a grid. Each axis needs at least one finite value; an axis may appear only once.
    pub fn new(axes: Vec<GridAxis>) -> Result<Grid, ParamError> {
        for (i, a) in axes.iter().enumerate() {
            if a.values.is_empty() {
                return Err(ParamError::OutOfRange {
                    field: a.axis.as_str(),
                    value: 0.0,
                    allowed: "at least one value",
                });
            }
            for &v in &a.values {
                crate::params::finite(a.axis.as_str(), v)?;
            }
            if axes[..i].iter().any(|b| b.axis == a.axis) {
                return Err(ParamError::OutOfRange {
                    field: a.axis.as_str(),
                    value: a.values[0],
                    allowed: "each axis once per grid",
                });
            }
        }
        // Checked in floating point before anything is built: 1e5 × 1e5 points would
        // overflow nothing but memory.
        let n: f64 = axes.iter().map(|a| a.values.len() as f64).product();
        crate::limits::check(
            "grid points (product of the axis lengths)",
            n,
            1.0,
            crate::limits::MAX_GRID_POINTS as f64,
            "use a coarser STEP or split the grid",
        )?;
        Ok(Grid { axes })
    }

    /// The axes.
    pub fn axes(&self) -> &[GridAxis] {
        &self.axes
    }

    /// Number of points (product of the axis lengths; 1 for no axes).
    pub fn len(&self) -> usize {
        self.axes.iter().map(|a| a.values.len()).product()
    }

    /// True when the grid has no point (never: every axis has a value).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Point `index` (row-major, last axis fastest); `None` past the end.
    pub fn point(&self, index: usize) -> Option<GridPoint> {
        if index >= self.len() {
            return None;
        }
        let mut coords = vec![(Axis::FreqRatio, 0.0); self.axes.len()];
        let mut rest = index;
        for (slot, a) in coords.iter_mut().zip(&self.axes).rev() {
            let n = a.values.len();
            *slot = (a.axis, a.values[rest % n]);
            rest /= n;
        }
        Some(GridPoint { index, coords })
    }

    /// All points, in index order.
    pub fn points(&self) -> Vec<GridPoint> {
        (0..self.len()).filter_map(|i| self.point(i)).collect()
    }

    /// Shard `k` of `n` (1-based `k`): the points with `index ≡ k − 1 (mod n)`, in index order.
    pub fn shard(&self, k: usize, n: usize) -> Result<Vec<GridPoint>, ParamError> {
        if n == 0 {
            return Err(ParamError::OutOfRange {
                field: "shard count",
                value: 0.0,
                allowed: "[1, ∞)",
            });
        }
        if k == 0 || k > n {
            return Err(ParamError::OutOfRange {
                field: "shard index",
                value: k as f64,
                allowed: "[1, shard count]",
            });
        }
        Ok((k - 1..self.len())
            .step_by(n)
            .filter_map(|i| self.point(i))
            .collect())
    }
}
