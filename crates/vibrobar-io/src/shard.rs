//! Sharding a grid over processes or cluster jobs, and merging the shard files back.
//!
//! `--shard K/N` selects the grid indices `i` with `i mod N = K − 1`: every shard gets points
//! spread over the whole grid (similar cost per shard), and the union of the N shards is the grid
//! exactly once. `vibrobar merge` reads each shard's data file and `FILE.meta.json`, checks that
//! they come from the same job (fingerprint), that the shards are 1..N of the same N and that
//! every grid index appears exactly once, and writes the rows sorted by grid index.

use crate::atomic::write_atomic;
use crate::csv::{map_extra_axes, map_key, Schema};
use crate::error::{IoError, Result};
use crate::meta::{meta_path, GridInfo, Metadata, ShardInfo};
use crate::params::{EnsembleFileParams, MapParams, PlacementParams, SweepParams};
use crate::target::{check_not_input, resolve_output};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Parse `K/N`.
pub fn parse_shard(text: &str) -> Result<ShardInfo> {
    let bad = || IoError::ShardSpec(text.to_string());
    let (k, n) = text.split_once('/').ok_or_else(bad)?;
    let k: usize = k.trim().parse().map_err(|_| bad())?;
    let n: usize = n.trim().parse().map_err(|_| bad())?;
    if n == 0 || k == 0 || k > n {
        return Err(bad());
    }
    check_shard_count(n).map_err(|e| IoError::ShardSpec(format!("{text}: {e}")))?;
    Ok(ShardInfo { k, n })
}

/// `N` of `--shard K/N` (from the flag or a shard's metadata) within the core's limit: `merge`
/// walks every shard 1..N.
fn check_shard_count(n: usize) -> std::result::Result<usize, vibrobar_core::ParamError> {
    vibrobar_core::limits::check_count(
        "N of --shard K/N",
        n,
        1,
        vibrobar_core::limits::MAX_SHARDS,
        "",
    )
}

/// Grid indices of a shard (all of them for `None`).
pub fn shard_indices(total: usize, shard: Option<ShardInfo>) -> Vec<usize> {
    match shard {
        None => (0..total).collect(),
        Some(ShardInfo { k, n }) => (k - 1..total).step_by(n).collect(),
    }
}

/// The key columns of each grid index of a shard's job, from its typed metadata; `None` when
/// the metadata does not say (files of older versions), and then rows are not matched.
#[allow(clippy::type_complexity)]
fn grid_key(
    meta: &Metadata,
    path: &Path,
    schema: &Schema,
) -> Option<Box<dyn Fn(usize) -> Option<String>>> {
    match meta.kind.as_str() {
        "map" => {
            let p: MapParams = meta.parameters_as(path).ok()?;
            let grid = p.grid()?;
            let extra = map_extra_axes(&meta.header)?;
            let schema = schema.clone();
            Some(Box::new(move |i| {
                grid.point(i).map(|pt| schema.format(&map_key(&pt, &extra)))
            }))
        }
        "sweep" => {
            let p: SweepParams<serde_json::Value> = meta.parameters_as(path).ok()?;
            Some(Box::new(move |i| p.key(i)))
        }
        "placement" => {
            let p: PlacementParams = meta.parameters_as(path).ok()?;
            Some(Box::new(move |i| p.key(i)))
        }
        "ensemble" => {
            let p: EnsembleFileParams = meta.parameters_as(path).ok()?;
            Some(Box::new(move |i| p.key(i)))
        }
        _ => None,
    }
}

/// Merge shard data files into `out` (plus `out.meta.json`). Returns the number of rows. Every
/// row is read with the file kind's schema (field count, finite numbers), and `out` may not be
/// one of the inputs or their metadata.
pub fn merge(inputs: &[PathBuf], out: &Path) -> Result<usize> {
    if inputs.is_empty() {
        return Err(IoError::Merge("no input files".into()));
    }
    let metas: Vec<PathBuf> = inputs.iter().map(|p| meta_path(p)).collect();
    let all: Vec<&Path> = inputs.iter().chain(&metas).map(|p| p.as_path()).collect();
    for p in &all {
        crate::target::register_input(p);
    }
    check_not_input(out, &all)?;
    resolve_output(out)?.require_regular("merge")?;
    check_not_input(&meta_path(out), &all)?;
    let read_err = |p: &Path, why: String| IoError::Metadata {
        path: meta_path(p),
        why,
    };
    let mut first: Option<Metadata> = None;
    let mut seen_shards = BTreeMap::new();
    let mut rows: BTreeMap<usize, String> = BTreeMap::new();
    for path in inputs {
        let meta = Metadata::read_beside(path)?;
        let grid = meta.grid.clone().ok_or_else(|| {
            read_err(
                path,
                "metadata has no grid: not a sweep, map, placement or ensemble file".into(),
            )
        })?;
        if let Some(f) = &first {
            if f.fingerprint != meta.fingerprint || f.kind != meta.kind || f.header != meta.header {
                return Err(IoError::Merge(format!(
                    "{} comes from another job (fingerprint {} vs {})",
                    path.display(),
                    meta.fingerprint,
                    f.fingerprint
                )));
            }
            let total = f.grid.as_ref().map(|g| g.total).unwrap_or(0);
            if total != grid.total {
                return Err(IoError::Merge(format!(
                    "{}: grid of {} points, others {}",
                    path.display(),
                    grid.total,
                    total
                )));
            }
        }
        let shard = grid.shard.unwrap_or(ShardInfo { k: 1, n: 1 });
        check_shard_count(shard.n).map_err(|e| read_err(path, e.to_string()))?;
        vibrobar_core::limits::check_count(
            "grid.total",
            grid.total,
            1,
            vibrobar_core::limits::MAX_GRID_POINTS,
            "",
        )
        .map_err(|e| read_err(path, e.to_string()))?;
        if let Some(prev) = seen_shards.insert(shard.k, path.clone()) {
            return Err(IoError::Merge(format!(
                "shard {}/{} given twice ({} and {})",
                shard.k,
                shard.n,
                prev.display(),
                path.display()
            )));
        }
        let indices = grid
            .indices
            .clone()
            .unwrap_or_else(|| shard_indices(grid.total, grid.shard));
        let schema = Schema::for_file(&meta.kind, &meta.header).ok_or_else(|| {
            read_err(
                path,
                format!("unknown {} header {:?}", meta.kind, meta.header),
            )
        })?;
        let text = std::fs::read_to_string(path).map_err(IoError::os(path))?;
        let mut lines = text.lines();
        if lines.next() != Some(meta.header.as_str()) {
            return Err(IoError::Corrupt {
                path: path.clone(),
                line: 1,
                why: "header differs from its metadata".into(),
            });
        }
        let body: Vec<&str> = lines.collect();
        if body.len() != indices.len() {
            return Err(read_err(
                path,
                format!(
                    "{} rows in the data file, metadata lists {}",
                    body.len(),
                    indices.len()
                ),
            ));
        }
        let key = grid_key(&meta, path, &schema);
        for (k, (row, i)) in body.iter().zip(&indices).enumerate() {
            schema.parse_at(row, path, k + 2)?;
            if let Some(want) = key.as_ref().and_then(|key| key(*i)) {
                if !row.starts_with(&want) || row.as_bytes().get(want.len()) != Some(&b',') {
                    return Err(IoError::Corrupt {
                        path: path.clone(),
                        line: k + 2,
                        why: format!(
                            "the metadata lists grid index {i} (grid point {want}) for this row"
                        ),
                    });
                }
            }
        }
        for (i, row) in indices.iter().zip(body) {
            if rows.insert(*i, row.to_string()).is_some() {
                return Err(IoError::Merge(format!(
                    "grid index {i} appears in more than one file"
                )));
            }
        }
        first.get_or_insert(meta);
    }
    let meta = first.expect("at least one input");
    let total = meta.grid.as_ref().map(|g| g.total).unwrap_or(0);
    let n = meta
        .grid
        .as_ref()
        .and_then(|g| g.shard)
        .map(|s| s.n)
        .unwrap_or(1);
    let missing_shards: Vec<usize> = (1..=n).filter(|k| !seen_shards.contains_key(k)).collect();
    if !missing_shards.is_empty() || rows.len() != total {
        return Err(IoError::Merge(format!(
            "grid incomplete: {} of {} points present; missing shards {:?} of {}",
            rows.len(),
            total,
            missing_shards,
            n
        )));
    }
    let mut text = String::new();
    text.push_str(&meta.header);
    text.push('\n');
    for r in rows.values() {
        text.push_str(r);
        text.push('\n');
    }
    write_atomic(out, text.as_bytes())?;
    let merged = Metadata {
        grid: Some(GridInfo {
            total,
            shard: None,
            indices: None,
        }),
        created_utc: super::meta::utc_now_rfc3339(),
        command: std::env::args().collect(),
        ..meta
    };
    merged.write_beside(out)?;
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_accepts_only_valid_slices() {
        assert_eq!(parse_shard("2/5").unwrap(), ShardInfo { k: 2, n: 5 });
        for bad in ["0/3", "4/3", "1/0", "a/b", "3", "-1/2", ""] {
            assert!(parse_shard(bad).is_err(), "{bad} accepted");
        }
    }

    #[test]
    fn shards_partition_the_grid() {
        for total in [0, 1, 7, 100, 20_000] {
            for n in [1, 2, 3, 7, 64] {
                let mut all: Vec<usize> = (1..=n)
                    .flat_map(|k| shard_indices(total, Some(ShardInfo { k, n })))
                    .collect();
                all.sort_unstable();
                assert_eq!(all, (0..total).collect::<Vec<_>>(), "total {total}, n {n}");
            }
        }
    }

    fn row(i: usize) -> String {
        format!(
            "{},0.1,none,exact,1e-5,{:e},50.0000,{i}",
            i as f64 * 0.25,
            5e-6 + i as f64 * 1e-7
        )
    }

    /// Shards 1/2 and 2/2 of a 6-point sweep, as `merge` takes them.
    fn two_shards_of_six(dir: &Path) -> Vec<PathBuf> {
        (1..=2).map(|k| write_shard(dir, k, 2, 6, 1.0)).collect()
    }

    fn write_shard(dir: &Path, k: usize, n: usize, total: usize, fp_param: f64) -> PathBuf {
        let idx = shard_indices(total, Some(ShardInfo { k, n }));
        let p = dir.join(format!("s{k}.csv"));
        let mut text = format!("{}\n", crate::csv::sweep_schema().header());
        for i in &idx {
            text.push_str(&format!("{}\n", row(*i)));
        }
        std::fs::write(&p, text).unwrap();
        Metadata::new(
            "sweep",
            &crate::csv::sweep_schema().header(),
            SweepParams {
                scenario: serde_json::json!({ "p": fp_param }),
                solver: "exact".into(),
                settings: vibrobar_core::RunSettings::default(),
                gaps_m: vec![1e-4],
                ratios: (0..total).map(|i| i as f64 * 0.25).collect(),
                order: "gap-major".into(),
                frequencies_hz: None,
            },
            Some(GridInfo {
                total,
                shard: Some(ShardInfo { k, n }),
                indices: Some(idx),
            }),
        )
        .write_beside(&p)
        .unwrap();
        p
    }

    #[test]
    fn merge_restores_the_full_grid_in_order() {
        let dir = tempfile::tempdir().unwrap();
        let files: Vec<PathBuf> = [3, 1, 2]
            .iter()
            .map(|&k| write_shard(dir.path(), k, 3, 10, 1.0))
            .collect();
        let out = dir.path().join("all.csv");
        assert_eq!(merge(&files, &out).unwrap(), 10);
        let want: String = std::iter::once(crate::csv::sweep_schema().header())
            .chain((0..10).map(row))
            .map(|l| l + "\n")
            .collect();
        assert_eq!(std::fs::read_to_string(&out).unwrap(), want);
        let meta = Metadata::read_beside(&out).unwrap();
        assert_eq!(meta.grid.unwrap().shard, None);
    }

    #[test]
    fn merge_refuses_missing_duplicate_or_foreign_shards() {
        let dir = tempfile::tempdir().unwrap();
        let a = write_shard(dir.path(), 1, 3, 10, 1.0);
        let b = write_shard(dir.path(), 2, 3, 10, 1.0);
        let out = dir.path().join("all.csv");
        let e = merge(&[a.clone(), b.clone()], &out)
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing shards [3]"), "{e}");
        assert!(!out.exists());
        let e = merge(&[a.clone(), a.clone()], &out)
            .unwrap_err()
            .to_string();
        assert!(e.contains("given twice"), "{e}");
        let sub = dir.path().join("other");
        std::fs::create_dir(&sub).unwrap();
        let c = write_shard(&sub, 3, 3, 10, 2.0);
        let e = merge(&[a, b, c], &out).unwrap_err().to_string();
        assert!(e.contains("another job"), "{e}");
    }

    #[test]
    fn regression_nan_edited_into_a_shard_row_is_refused_with_its_line() {
        let dir = tempfile::tempdir().unwrap();
        let files = two_shards_of_six(dir.path());
        // Shard 2 holds indices 1, 3, 5: line 3 is index 3.
        let text = std::fs::read_to_string(&files[1]).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        let bad = lines[2].replace("1e-5", "NaN");
        std::fs::write(&files[1], text.replace(lines[2], &bad)).unwrap();
        let out = dir.path().join("all.csv");
        let e = merge(&files, &out).unwrap_err().to_string();
        assert!(
            e.contains("s2.csv: line 3") && e.contains("rms_solid_m = NaN is not a finite number"),
            "{e}"
        );
        assert!(!out.exists());
    }

    #[test]
    fn merge_into_a_special_file_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let files = two_shards_of_six(dir.path());
        let fifo = dir.path().join("pipe");
        crate::target::test_fifo(&fifo);
        let e = merge(&files, &fifo).unwrap_err().to_string();
        assert!(e.contains("is a FIFO"), "{e}");
    }

    #[test]
    fn shard_row_not_matching_its_listed_index_is_refused_with_its_line() {
        let dir = tempfile::tempdir().unwrap();
        let files = two_shards_of_six(dir.path());
        // Shard 1 holds indices 0, 2, 4: swap the rows of 2 and 4 (lines 3 and 4).
        let text = std::fs::read_to_string(&files[0]).unwrap();
        let mut lines: Vec<&str> = text.lines().collect();
        lines.swap(2, 3);
        std::fs::write(&files[0], lines.join("\n") + "\n").unwrap();
        let out = dir.path().join("all.csv");
        let e = merge(&files, &out).unwrap_err().to_string();
        assert!(
            e.contains("s1.csv: line 3") && e.contains("grid index 2 (grid point 0.5,0.1)"),
            "{e}"
        );
        assert!(!out.exists());
    }

    #[test]
    fn regression_merge_into_one_of_its_inputs_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let files = two_shards_of_six(dir.path());
        let before = std::fs::read(&files[0]).unwrap();
        let e = merge(&files, &files[0]).unwrap_err().to_string();
        assert!(e.contains("is also an input"), "{e}");
        assert_eq!(std::fs::read(&files[0]).unwrap(), before);
    }
}
