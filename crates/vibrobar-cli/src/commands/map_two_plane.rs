//! `vibrobar map` on a `[two_plane]` scenario: the design map of the hole. Over frequency ratios
//! × axial gaps × (optionally) hole directions and hole diameters, each cell an ensemble of
//! starts, its RMS reduction along the force beside the one-plane model's; the best cell on the
//! screen. The file is written whole at the end (atomically), after every cell has run; where
//! the gap and exactly one other axis vary, `FILE.reduction.{png,svg}` maps the mean reduction
//! over them.

use anyhow::{bail, Context, Result};
use vibrobar_core::analysis::two_plane::Spread;

use super::map::MapArgs;
use super::parse_range;
use super::sweep_two_plane::run_points;
use crate::scenario::Scenario;
use vibrobar_io::csv::fmt_coord;
use vibrobar_io::two_plane_csv::{self, MapCell};
use vibrobar_scenario::TwoPlaneAxes;

/// Run the command on a scenario with `[two_plane]`.
pub fn run(args: &MapArgs, sc: &Scenario) -> Result<()> {
    let t0 = std::time::Instant::now();
    let Some(section) = &sc.two_plane else {
        bail!("no [two_plane] section");
    };
    super::sweep_two_plane::refuse_system_flags(&args.system)?;
    for (flag, given, why) in [
        (
            "--freqs-hz",
            args.freqs_hz.is_some(),
            "the map of a [two_plane] scenario takes frequency ratios (--ratios)",
        ),
        (
            "--friction-forces-n",
            args.friction_forces_n.is_some(),
            "friction on the hole's walls is [two_plane] friction_static and friction_kinetic",
        ),
        (
            "--restitutions",
            args.restitutions.is_some(),
            "not an axis of the two-plane map; set [damper] restitution",
        ),
        (
            "--mass-ratios",
            args.mass_ratios.is_some(),
            "not an axis of the two-plane map; set [damper] ball_mass_kg",
        ),
        (
            "--shard and --resume",
            args.shard.is_some() || args.resume,
            "the two-plane map writes its file whole at the end; run it without them",
        ),
        (
            "--stability-overlay",
            args.stability_overlay,
            "the orbit boundary is drawn for the one-plane model only",
        ),
    ] {
        if given {
            bail!("{flag}: {why}");
        }
    }
    let ratios = match &args.ratios {
        Some(spec) => parse_range("--ratios", spec, |x| x > 0.0, "(0, ∞)")?,
        None => bail!("map needs --ratios"),
    };
    let gaps_m: Vec<f64> = parse_range("--gaps-mm", &args.gaps_mm, |x| x > 0.0, "(0, ∞) mm")?
        .iter()
        .map(|g| g * 1e-3)
        .collect();
    let angles = match &args.hole_angles_deg {
        Some(spec) => parse_range(
            "--hole-angles-deg",
            spec,
            |x| x.abs() <= 360.0,
            "[−360, 360] °",
        )?,
        None => vec![section.hole_angle_deg],
    };
    let diameters_m: Vec<f64> = match &args.hole_diameters_mm {
        Some(spec) => parse_range("--hole-diameters-mm", spec, |x| x > 0.0, "(0, ∞) mm")?
            .iter()
            .map(|d| d * 1e-3)
            .collect(),
        None => vec![section.hole_diameter_m],
    };
    let ens = section.ensemble()?;
    let settings = sc.settings();
    settings.validate()?;
    let method = section.method(settings.dt_s)?;
    let grid = sc.two_plane_cells(
        &TwoPlaneAxes {
            ratios: &ratios,
            gaps_m: &gaps_m,
            hole_angles_deg: Some(&angles),
            hole_diameters_m: Some(&diameters_m),
            names: ["--hole-angles-deg", "--hole-diameters-mm"],
        },
        ens.members,
        "map runs (cells × members)",
    )?;
    let cells = grid.len();
    let keys: Vec<MapCell> = grid
        .iter()
        .map(|c| MapCell {
            ratio: c.ratio,
            axial_gap_m: c.axial_gap_m,
            hole_angle_deg: c.hole_angle_deg,
            hole_diameter_m: c.hole_diameter_m,
            radial_clearance_m: c.system.radial_clearance_m(),
        })
        .collect();
    let systems: Vec<_> = grid.iter().map(|c| c.system).collect();
    eprintln!(
        "map: {} ratios × {} gaps × {} hole angles × {} hole diameters = {cells} cells",
        ratios.len(),
        gaps_m.len(),
        angles.len(),
        diameters_m.len(),
    );
    let points = run_points(
        "map",
        &systems,
        &ens,
        method,
        &settings,
        args.threads,
        &section.solver,
    )?;
    let mut best: Option<(f64, f64, usize)> = None;
    for (i, p) in points.iter().enumerate() {
        let red = Spread::of(&p.reductions_pct());
        if best.is_none_or(|b| red.mean > b.0) {
            best = Some((red.mean, red.std_err, i));
        }
    }
    let rows = keys
        .iter()
        .zip(&points)
        .map(|(c, p)| two_plane_csv::map_values(c, p));
    vibrobar_io::csv::write_csv(&args.out, &two_plane_csv::map_schema(), rows)
        .with_context(|| format!("writing {}", args.out.display()))?;
    // The heat map of the mean reduction over the gap and the one other axis that varies.
    let others: [(&str, Vec<f64>); 3] = [
        ("frequency ratio Ω/ω₁", ratios.clone()),
        ("hole angle (°)", angles.clone()),
        (
            "hole diameter (mm)",
            diameters_m.iter().map(|d| d * 1e3).collect(),
        ),
    ];
    let varying: Vec<usize> = (0..3).filter(|&i| others[i].1.len() > 1).collect();
    if gaps_m.len() > 1 && varying.len() == 1 {
        let axis = varying[0];
        let xs = &others[axis].1;
        let ys: Vec<f64> = gaps_m.iter().map(|g| g * 1e3).collect();
        let mut z = vec![vec![f64::NAN; ys.len()]; xs.len()];
        for (c, p) in keys.iter().zip(&points) {
            let (gap_m, x) = (
                c.axial_gap_m,
                [c.ratio, c.hole_angle_deg, c.hole_diameter_m][axis],
            );
            let xi = [&ratios, &angles, &diameters_m][axis]
                .iter()
                .position(|v| v.to_bits() == x.to_bits());
            let yj = gaps_m.iter().position(|v| v.to_bits() == gap_m.to_bits());
            if let (Some(xi), Some(yj)) = (xi, yj) {
                z[xi][yj] = Spread::of(&p.reductions_pct()).mean;
            }
        }
        let best_xy = best.map(|(_, _, i)| {
            let c = &keys[i];
            (
                [c.ratio, c.hole_angle_deg, c.hole_diameter_m * 1e3][axis],
                c.axial_gap_m * 1e3,
            )
        });
        let stem = args.out.with_extension("");
        let title = format!(
            "Two planes: mean RMS reduction along the force at {:.1}° (ensembles of {})",
            systems[0].forcing.angle_deg, ens.members
        );
        let files = vibrobar_report::figures::heat_files(
            &stem.with_extension("reduction"),
            &vibrobar_report::figures::Heat {
                title: &title,
                x_label: others[axis].0,
                y_label: "axial gap (mm)",
                z_label: "reduction (%)",
                xs,
                ys: &ys,
                z: &z,
                levels: vec![20.0, 40.0, 60.0, 80.0],
                strong_level: Some(0.0),
                markers: best_xy.map(|b| ("best cell", vec![b])),
                hlines: Vec::new(),
                vlines: Vec::new(),
            },
        )?;
        for f in files {
            println!("wrote {}", f.display());
        }
    }
    if let Some((mean, se, i)) = best {
        let MapCell {
            ratio,
            axial_gap_m: gap_m,
            hole_angle_deg: angle,
            hole_diameter_m: d,
            ..
        } = keys[i];
        println!(
            "best cell: hole at {}°, {} mm across, axial gap {} mm, r = {}: {mean:.1} ± {se:.1} % \
             along the force (one plane from the same starts: {:.1} %)",
            fmt_coord(angle),
            fmt_coord(d * 1e3),
            fmt_coord(gap_m * 1e3),
            fmt_coord(ratio),
            Spread::of(&points[i].one_plane_reductions_pct()).mean
        );
    }
    println!(
        "wrote {} ({cells} cells, {:.1} s)",
        args.out.display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
