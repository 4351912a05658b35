//! `vibrobar placement` on a `[two_plane]` scenario with a `[beam]`: where along the round bar,
//! and with which axial gap, the ball in its hole damps the response along the force best over a
//! band of frequency ratios. Each (position, gap, ratio) is an ensemble of starts; a row
//! summarises one position × gap over the band: the mean and the smallest of the ensembles' mean
//! reductions, the largest mean RMS and its ratio, the one-plane model's mean reduction from the
//! same starts, impacts and flight. Reductions are against the same beam without its ball. The
//! file is written whole at the end (atomically); the best row is printed.

use anyhow::{bail, Context, Result};
use std::fmt::Write as _;
use vibrobar_core::analysis::two_plane::Spread;
use vibrobar_io::csv::fmt_coord;

use super::parse_range;
use super::placement::{beam_scenario, PlacementArgs};
use super::sweep_two_plane::run_points;

/// The columns.
pub const HEADER: &str = "position_mm,axial_gap_mm,solver,members,mean_reduction_pct,\
min_reduction_pct,worst_rms_along_force_m,worst_ratio,one_plane_mean_reduction_pct,impacts_mean,\
flight_fraction_mean";

/// Run the command on a scenario with `[two_plane]` and `[beam]`.
pub fn run(args: &PlacementArgs) -> Result<()> {
    let t0 = std::time::Instant::now();
    if args.shard.is_some() || args.resume {
        bail!(
            "--shard and --resume: the placement of a [two_plane] scenario writes its file whole \
             at the end; run it without them"
        );
    }
    let (sc, beam) = beam_scenario(&args.system)?;
    let Some(section) = &sc.two_plane else {
        bail!("no [two_plane] section");
    };
    super::sweep_two_plane::refuse_system_flags(&args.system)?;
    let positions_mm = parse_range(
        "--positions-mm",
        &args.positions_mm,
        |x| x >= 0.0 && x <= beam.length_m * 1e3,
        &format!(
            "[0, {}] mm (the bar's length)",
            fmt_coord(beam.length_m * 1e3)
        ),
    )?;
    let gaps_mm = parse_range("--gaps-mm", &args.gaps_mm, |x| x > 0.0, "(0, ∞) mm")?;
    let ratios = parse_range("--ratios", &args.ratios, |x| x > 0.0, "(0, ∞)")?;
    let ens = section.ensemble()?;
    let settings = sc.settings();
    settings.validate()?;
    let cells = positions_mm.len() * gaps_mm.len() * ratios.len();
    vibrobar_core::limits::check(
        "placement runs (positions × gaps × ratios × members)",
        (cells * ens.members) as f64,
        0.0,
        vibrobar_core::limits::MAX_RUNS as f64,
        "fewer positions, gaps, ratios or members",
    )?;
    let mut systems = Vec::with_capacity(cells);
    let mut method = None;
    for &x in &positions_mm {
        for &g in &gaps_mm {
            for &r in &ratios {
                let mut s = sc.clone();
                if let Some(b) = s.beam.as_mut() {
                    *b = beam.clone();
                    b.cavity_position_m = x / 1e3;
                }
                s.damper.gap_m = g * 1e-3;
                s.forcing.frequency = vibrobar_core::Frequency::Ratio(r);
                let (sys, m) = s.two_plane_run().with_context(|| {
                    format!("--positions-mm: the cavity at {} mm", fmt_coord(x))
                })?;
                method = Some(m);
                systems.push(sys);
            }
        }
    }
    let method = method.context("no cell")?;
    eprintln!(
        "placement: {} positions × {} gaps × {} ratios, {} modes in each plane",
        positions_mm.len(),
        gaps_mm.len(),
        ratios.len(),
        beam.modes.unwrap_or(0)
    );
    let points = run_points(
        "placement",
        &systems,
        &ens,
        method,
        &settings,
        args.threads,
        &section.solver,
    )?;
    let mut csv = format!("{HEADER}\n");
    let mut best: Option<(f64, usize)> = None;
    let mut rows = Vec::new();
    for (c, band) in points.chunks(ratios.len()).enumerate() {
        let (x, g) = (positions_mm[c / gaps_mm.len()], gaps_mm[c % gaps_mm.len()]);
        let means: Vec<f64> = band
            .iter()
            .map(|p| Spread::of(&p.reductions_pct()).mean)
            .collect();
        let one: Vec<f64> = band
            .iter()
            .map(|p| Spread::of(&p.one_plane_reductions_pct()).mean)
            .collect();
        let rms: Vec<f64> = band
            .iter()
            .map(|p| {
                Spread::of(
                    &p.members
                        .iter()
                        .map(|m| m.rms_along_force_m)
                        .collect::<Vec<_>>(),
                )
                .mean
            })
            .collect();
        let worst = (0..band.len())
            .max_by(|&i, &j| rms[i].total_cmp(&rms[j]))
            .expect("a band has ratios");
        let n = band.iter().map(|p| p.members.len()).sum::<usize>() as f64;
        let impacts = band
            .iter()
            .flat_map(|p| &p.members)
            .map(|m| m.impacts.iter().sum::<u64>() as f64)
            .sum::<f64>()
            / n;
        let flight = band
            .iter()
            .flat_map(|p| &p.members)
            .map(|m| m.flight_fraction)
            .sum::<f64>()
            / n;
        let mean = Spread::of(&means);
        writeln!(
            csv,
            "{},{},{},{},{:.4},{:.4},{:e},{},{:.4},{:.2},{:.6}",
            fmt_coord(x),
            fmt_coord(g),
            band[0].solver,
            ens.members,
            mean.mean,
            mean.min,
            rms[worst],
            fmt_coord(ratios[worst]),
            Spread::of(&one).mean,
            impacts,
            flight
        )?;
        if best.is_none_or(|b| mean.mean > b.0) {
            best = Some((mean.mean, rows.len()));
        }
        rows.push((x, g, mean.mean, Spread::of(&one).mean));
    }
    vibrobar_io::csv::write_text(&args.out, &csv)
        .with_context(|| format!("writing {}", args.out.display()))?;
    if let Some((_, i)) = best {
        let (x, g, m, o) = rows[i];
        println!(
            "best: the cavity at {} mm from the clamp, axial gap {} mm: {m:.1} % mean reduction \
             along the force over the band (one plane from the same starts: {o:.1} %)",
            fmt_coord(x),
            fmt_coord(g)
        );
    }
    println!(
        "wrote {} ({} rows, {:.1} s)",
        args.out.display(),
        rows.len(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
