//! `vibrobar beam`: lumped M, K of a round cantilever boring bar from its geometry, for every
//! Euler–Bernoulli reduction (the paper does not say which one it used; `total-mass` is closest).

use anyhow::Result;
use clap::Args;
use vibrobar_core::euler_bernoulli::{BeamGeometry, Cavity, Reduction};

/// `vibrobar beam`.
#[derive(Debug, Args)]
pub struct BeamArgs {
    /// Overhang length L (clamp to free end), mm.
    #[arg(long, default_value_t = 175.0, allow_negative_numbers = true)]
    pub length_mm: f64,
    /// Outer diameter D, mm.
    #[arg(long, default_value_t = 25.0, allow_negative_numbers = true)]
    pub diameter_mm: f64,
    /// Young's modulus E, GPa.
    #[arg(long, default_value_t = 200.0, allow_negative_numbers = true)]
    pub youngs_modulus_gpa: f64,
    /// Density ρ, kg/m³.
    #[arg(long, default_value_t = 7850.0, allow_negative_numbers = true)]
    pub density_kg_m3: f64,
    /// Diameter of the transverse cavity hole, mm (omit for a solid bar).
    #[arg(long, allow_negative_numbers = true, requires_all = ["cavity_length_mm", "cavity_distance_mm"])]
    pub cavity_hole_mm: Option<f64>,
    /// Length of the cavity along the hole, mm (with --cavity-hole-mm; alone it was silently
    /// ignored, so clap now refuses it).
    #[arg(long, allow_negative_numbers = true, requires = "cavity_hole_mm")]
    pub cavity_length_mm: Option<f64>,
    /// Distance of the cavity centre from the free end, mm (with --cavity-hole-mm).
    #[arg(long, allow_negative_numbers = true, requires = "cavity_hole_mm")]
    pub cavity_distance_mm: Option<f64>,
}

fn name(r: Reduction) -> &'static str {
    match r {
        Reduction::StaticRayleigh => "static-rayleigh   K=3EI/L³, M=33/140 ρAL",
        Reduction::StaticExactFrequency => "static-exact-freq K=3EI/L³, M=K/ω₁²",
        Reduction::ModalTip => "modal-tip         M=ρAL/4, K=Mω₁²",
        Reduction::TotalMass => "total-mass        M=ρAL, K=Mω₁²  (closest to the paper)",
    }
}

/// Run the command.
pub fn beam(args: &BeamArgs) -> Result<()> {
    let cavity = match (
        args.cavity_hole_mm,
        args.cavity_length_mm,
        args.cavity_distance_mm,
    ) {
        (Some(d), Some(l), Some(a)) => Some(Cavity {
            hole_diameter_m: d * 1e-3,
            length_m: l * 1e-3,
            distance_from_free_end_m: a * 1e-3,
        }),
        _ => None,
    };
    let g = BeamGeometry {
        length_m: args.length_mm * 1e-3,
        outer_diameter_m: args.diameter_mm * 1e-3,
        cavity,
        youngs_modulus_pa: args.youngs_modulus_gpa * 1e9,
        density_kg_m3: args.density_kg_m3,
    };
    g.validate()?;
    println!(
        "cantilever L = {} mm, D = {} mm, E = {} GPa, ρ = {} kg/m³{}",
        args.length_mm,
        args.diameter_mm,
        args.youngs_modulus_gpa,
        args.density_kg_m3,
        match (
            cavity,
            args.cavity_hole_mm,
            args.cavity_length_mm,
            args.cavity_distance_mm
        ) {
            (Some(_), Some(d), Some(l), Some(a)) =>
                format!(", cavity {d} mm hole × {l} mm at {a} mm from the free end"),
            _ => String::new(),
        }
    );
    println!(
        "  {:<58} {:>9} {:>12} {:>10}",
        "reduction", "M (kg)", "K (MN/m)", "f_n (Hz)"
    );
    for r in Reduction::ALL {
        let l = g.lumped(r)?;
        println!(
            "  {:<58} {:>9.4} {:>12.4} {:>10.1}",
            name(r),
            l.mass_kg,
            l.stiffness_n_per_m * 1e-6,
            l.natural_freq_rad_s() / (2.0 * std::f64::consts::PI)
        );
    }
    println!("  paper: solid bar 0.668 kg, 9.26 MN/m (592.6 Hz); with cavity 0.644 kg, 9.22 MN/m (602.2 Hz)");
    Ok(())
}
