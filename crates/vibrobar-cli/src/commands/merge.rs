//! `merge`: join the shard files of a map (`map --shard K/N`), a placement study, an ensemble, a
//! width diagram, time-domain lobes or a lobe-design study into the whole
//! file, then write `FILE.optimum.csv` and the figures as an unsharded `map` (or `placement`) would. The merged file is byte-identical
//! to the file an unsharded run writes.
use anyhow::Context;
use std::path::PathBuf;
use vibrobar_io::shard;

/// `vibrobar merge --out FILE.csv SHARD.csv...`.
#[derive(Debug, Clone, clap::Args)]
pub struct MergeArgs {
    /// Merged output CSV.
    #[arg(long)]
    pub out: PathBuf,
    /// Shard files (each with its FILE.meta.json), in any order.
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
    /// Only merge; skip FILE.optimum.csv and the figures.
    #[arg(long)]
    pub no_figures: bool,
}

/// `vibrobar merge`.
pub fn run(args: &MergeArgs) -> anyhow::Result<()> {
    let n = shard::merge(&args.shards, &args.out)?;
    eprintln!(
        "{}: {n} rows from {} shards",
        args.out.display(),
        args.shards.len()
    );
    let meta = vibrobar_io::Metadata::read_beside(&args.out)
        .with_context(|| format!("metadata beside {}", args.out.display()))?;
    if !args.no_figures {
        match meta.kind.as_str() {
            "map" => super::map::postprocess(&args.out)?,
            "placement" => super::placement::postprocess(&args.out)?,
            vibrobar_io::csv::WIDTH_DIAGRAM_KIND => {
                super::time_domain::width_diagram_figure(&args.out)?
            }
            vibrobar_io::csv::TD_LOBES_KIND => super::time_domain::td_lobes_figure(&args.out)?,
            vibrobar_io::csv::LOBE_DESIGN_KIND => super::lobe_design::postprocess(&args.out, true)?,
            _ => {}
        }
    }
    Ok(())
}
