//! Writers. Every file is written to `FILE.partial` in the same directory and renamed when
//! complete, so a half-written result never looks complete.

use anyhow::{Context, Result};
use std::io::Write;
use std::path::Path;
use vibrobar_core::State;

use crate::AtomicFile;

/// Header of sweep CSVs (`sweep`, Figs. 3 and 5).
pub const SWEEP_HEADER: &str =
    "ratio,gap_mm,friction,solver,rms_solid_m,rms_damped_m,reduction_pct,impacts";

/// Header of time-history CSVs (`run`, Figs. 2 and 4).
pub const HISTORY_HEADER: &str = "t_s,u_m,du_m_s,v_m,dv_m_s,w_m,dw_m_s";

pub use crate::partial_path;

/// Create the parent directory of `path` if needed.
pub fn ensure_parent(path: &Path) -> Result<()> {
    crate::atomic::ensure_parent(path)
        .with_context(|| format!("cannot create the directory of {}", path.display()))
}

/// Write `path` atomically through [`crate::AtomicFile`]: `fill` writes into
/// `path.partial`, renamed on success. On failure the partial file is removed, so a failed
/// command leaves nothing that could be mistaken for a result.
pub fn write_atomic(path: &Path, fill: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<()> {
    let res = (|| -> Result<()> {
        let mut f = AtomicFile::create(path)?;
        fill(&mut f)?;
        f.commit()?;
        Ok(())
    })();
    if res.is_err() {
        let _ = std::fs::remove_file(partial_path(path));
    }
    res.with_context(|| format!("while writing {}", path.display()))
}

/// One row of a sweep CSV.
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

/// Short decimal for grid values (ratios, gaps): rounds away binary noise like 1.0000000000000002.
pub fn grid_num(x: f64) -> String {
    let s = format!("{x:.9}");
    let s = s.trim_end_matches('0');
    s.trim_end_matches('.').to_string()
}

/// One sweep CSV line (no newline); the same text whether written directly or via the journal.
pub fn sweep_csv_line(r: &SweepCsvRow) -> String {
    format!(
        "{},{},{},{},{:e},{:e},{:.4},{}",
        grid_num(r.ratio),
        grid_num(r.gap_mm),
        r.friction,
        r.solver,
        r.rms_solid_m,
        r.rms_damped_m,
        r.reduction_pct,
        r.impacts
    )
}

/// Write a sweep CSV.
pub fn write_sweep_csv(path: &Path, rows: &[SweepCsvRow]) -> Result<()> {
    write_atomic(path, |w| {
        writeln!(w, "{SWEEP_HEADER}")?;
        for r in rows {
            writeln!(w, "{}", sweep_csv_line(r))?;
        }
        Ok(())
    })
}

/// Write a time-history CSV.
pub fn write_history_csv(path: &Path, samples: &[State]) -> Result<()> {
    write_atomic(path, |w| {
        writeln!(w, "{HISTORY_HEADER}")?;
        for s in samples {
            writeln!(
                w,
                "{:e},{:e},{:e},{:e},{:e},{:e},{:e}",
                s.t_s,
                s.u_m,
                s.du_m_s,
                s.v_m,
                s.dv_m_s,
                s.w_m(),
                s.dw_m_s()
            )?;
        }
        Ok(())
    })
}

/// Write any serializable value as pretty JSON.
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    write_atomic(path, |w| {
        serde_json::to_writer_pretty(&mut *w, value)?;
        writeln!(w)?;
        Ok(())
    })
}

/// Write a text file.
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    write_atomic(path, |w| Ok(w.write_all(text.as_bytes())?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn partial_sits_beside_the_target() {
        let p = partial_path(Path::new("out/dir/sweep.csv"));
        assert_eq!(p, Path::new("out/dir/sweep.csv.partial"));
    }

    #[test]
    fn failed_write_leaves_neither_file_nor_partial() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("a/b.csv");
        let err = write_atomic(&target, |w| {
            writeln!(w, "half a file")?;
            anyhow::bail!("simulated failure")
        });
        assert!(err.is_err());
        assert!(!target.exists());
        assert!(!partial_path(&target).exists());
        write_text(&target, "ok\n").unwrap();
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "ok\n");
        assert!(!partial_path(&target).exists());
    }

    #[test]
    fn grid_numbers_lose_binary_noise_only() {
        assert_eq!(grid_num(0.95 + 5.0 * 0.01), "1");
        assert_eq!(grid_num(0.1), "0.1");
        assert_eq!(grid_num(0.25), "0.25");
        assert_eq!(grid_num(1.0e-3 * 1e3), "1");
        assert_eq!(grid_num(20.0), "20");
    }
}
