//! Nodes of a bending mode: the points of the bar (other than the clamp) where mode `n` does not
//! move. A cavity at a node of mode `n` cannot damp that mode (its impulse has no share in it:
//! `Δq̇ₙ ∝ φₙ(x_d) = 0`), which is why the placement figure marks them.
//!
//! Mode `n` of a clamped–free bar has `n − 1` nodes in `(0, L)`. They are found as sign changes
//! of the shape on a fine scan (a closed-form mode: `NODE_SCAN_PER_MODE·n` samples, far finer than
//! the `n` half-waves; an FE mode: its nodal values, one per element), each refined by bisection
//! to the last bit of the shape's own evaluation: the closed form ([`super::analytic`]) for a
//! uniform bar, the Hermite interpolation of the FE shape ([`super::fe::Mesh::interpolate`])
//! otherwise. So the nodes of an FE model are those of its shapes, not of the uniform bar.

use super::analytic::UniformMode;
use super::beam::Beam;
use crate::error::ParamError;
use crate::limits;

/// Samples per mode of the scan of a closed-form shape.
const NODE_SCAN_PER_MODE: usize = 64;

/// The `n − 1` nodes of mode `n ≥ 1` of `beam` in `(0, L)`, from the clamp, ascending, m.
/// Errors name the mode number and its range, or the beam's field (the beam is validated).
pub fn mode_nodes_m(beam: &Beam, n: usize) -> Result<Vec<f64>, ParamError> {
    beam.validate()?;
    limits::check_count(
        "mode number of the nodes",
        n,
        1,
        limits::MAX_BEAM_MODES,
        "modes of the beam",
    )?;
    let l = beam.length_m;
    let nodes = if beam.is_uniform() {
        let m = UniformMode::new(n);
        let f = |x: f64| m.shape(x / l);
        let k = NODE_SCAN_PER_MODE * n;
        let xs: Vec<f64> = (0..=k).map(|i| l * i as f64 / k as f64).collect();
        sign_changes(&xs, &f)
    } else {
        let mesh = beam.mesh(n)?;
        let fe = mesh.modes(n)?;
        let (w, th) = (&fe.deflection[n - 1], &fe.slope[n - 1]);
        let f = |x: f64| mesh.interpolate(w, th, x);
        sign_changes(&mesh.nodes_m, &f)
    };
    if nodes.len() != n - 1 {
        return Err(ParamError::NonFiniteResult {
            quantity: "nodes of the mode (a clamped–free mode n has n − 1)",
            value: nodes.len() as f64,
            cause: "the shape has more or fewer sign changes than a bending mode: the section or \
                    tip mass is outside the model's range",
        });
    }
    Ok(nodes)
}

/// Roots of `f` between consecutive `xs` (skipping the clamp `xs[0]`, where every mode is 0),
/// each refined by bisection until the bracket stops shrinking.
fn sign_changes(xs: &[f64], f: &dyn Fn(f64) -> f64) -> Vec<f64> {
    let mut out = Vec::new();
    // Start just off the clamp: φ(0) = 0 is not a node.
    for w in xs.windows(2).skip(1) {
        let (mut a, mut b) = (w[0], w[1]);
        let (fa, fb) = (f(a), f(b));
        if fa == 0.0 {
            out.push(a);
            continue;
        }
        if fa.signum() == fb.signum() || fb == 0.0 {
            continue;
        }
        loop {
            let m = 0.5 * (a + b);
            if m <= a || m >= b {
                break;
            }
            if f(m).signum() == fa.signum() {
                a = m;
            } else {
                b = m;
            }
        }
        out.push(if f(a).abs() <= f(b).abs() { a } else { b });
    }
    // A node exactly on the last sample before the tip (never the tip: φ(L) = 1).
    if let [.., x, _] = xs {
        if f(*x) == 0.0 && !out.contains(x) && xs.len() > 2 {
            out.push(*x);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::structure::{CavitySection, TipMass};

    /// The textbook shape `cosh βx − cos βx − σ(sinh βx − sin βx)` (fine for low modes): an
    /// independent evaluation of the closed form.
    fn textbook(n: usize, xi: f64) -> f64 {
        let b = super::super::analytic::beta_l(n);
        let s = (b.cosh() + b.cos()) / (b.sinh() + b.sin());
        let x = b * xi;
        x.cosh() - x.cos() - s * (x.sinh() - x.sin())
    }

    #[test]
    fn uniform_nodes_are_the_tabulated_ones() {
        let beam = Beam::default();
        let l = beam.length_m;
        assert!(mode_nodes_m(&beam, 1).unwrap().is_empty());
        let n2 = mode_nodes_m(&beam, 2).unwrap();
        assert_eq!(n2.len(), 1);
        assert!((n2[0] / l - 0.7834).abs() < 5e-5, "{}", n2[0] / l);
        let n3 = mode_nodes_m(&beam, 3).unwrap();
        assert_eq!(n3.len(), 2);
        assert!((n3[0] / l - 0.5035).abs() < 5e-5, "{}", n3[0] / l);
        assert!((n3[1] / l - 0.8677).abs() < 5e-5, "{}", n3[1] / l);
        // Roots of the independent textbook formula, to its rounding (the shape's slope there
        // is O(β); the textbook form loses a few digits to cosh − σ sinh).
        for (n, nodes) in [(2, &n2), (3, &n3)] {
            for &x in nodes.iter() {
                assert!(textbook(n, x / l).abs() < 1e-9, "mode {n} at {x}");
            }
        }
        // Higher modes: n − 1 nodes, ascending, inside the bar.
        for n in [6, 12] {
            let v = mode_nodes_m(&beam, n).unwrap();
            assert_eq!(v.len(), n - 1);
            assert!(v.windows(2).all(|w| w[0] < w[1]) && v[0] > 0.0 && v[n - 2] < l);
        }
    }

    #[test]
    fn fe_nodes_follow_the_fe_shapes() {
        // A massless tip body forces the FE path on the uniform bar: same nodes to the mesh's
        // accuracy.
        let fe = Beam {
            tip_mass: Some(TipMass {
                mass_kg: 0.0,
                rotary_inertia_kg_m2: 0.0,
            }),
            ..Beam::default()
        };
        let uni = Beam::default();
        for n in [2, 3] {
            let (a, b) = (
                mode_nodes_m(&fe, n).unwrap(),
                mode_nodes_m(&uni, n).unwrap(),
            );
            for (x, y) in a.iter().zip(&b) {
                assert!((x - y).abs() < 1e-6 * uni.length_m, "mode {n}: {x} vs {y}");
            }
        }
        // A heavy tip mass moves the nodes of mode 2 toward the tip (the tip moves less).
        let heavy = Beam {
            tip_mass: Some(TipMass {
                mass_kg: uni.mass_kg(),
                rotary_inertia_kg_m2: 0.0,
            }),
            ..Beam::default()
        };
        assert!(mode_nodes_m(&heavy, 2).unwrap()[0] > mode_nodes_m(&uni, 2).unwrap()[0]);
        // With a cavity section the FE shape is zero at the node it reports.
        let holed = Beam {
            cavity_section: Some(CavitySection {
                hole_diameter_m: 0.018,
                length_m: 0.012,
            }),
            ..Beam::default()
        };
        let nodes = mode_nodes_m(&holed, 3).unwrap();
        let mesh = holed.mesh(3).unwrap();
        let m = mesh.modes(3).unwrap();
        for x in nodes {
            let v = mesh.interpolate(&m.deflection[2], &m.slope[2], x);
            assert!(v.abs() < 1e-12, "φ₃({x}) = {v}");
        }
    }

    #[test]
    fn bad_mode_numbers_name_the_range() {
        for n in [0, 33] {
            let e = mode_nodes_m(&Beam::default(), n).unwrap_err().to_string();
            assert!(e.contains("mode number of the nodes"), "{e}");
        }
    }
}
