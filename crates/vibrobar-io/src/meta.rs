//! JSON metadata written beside every data file (`FILE.meta.json`): every parameter, solver
//! settings, tool version, time stamp, the command line, and a fingerprint of the job that
//! resume and merge use to refuse mixing different jobs.

use crate::atomic::write_atomic;
use crate::error::{IoError, Result};
use crate::target::resolve_output;
use serde::{de::DeserializeOwned, Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Sharding of a grid: this file holds slice `k` of `n` (1-based).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ShardInfo {
    /// Slice number, 1..=n.
    pub k: usize,
    /// Number of slices.
    pub n: usize,
}

/// Grid bookkeeping of a sweep or map.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GridInfo {
    /// Points in the full grid.
    pub total: usize,
    /// Which slice this file holds, if sharded.
    pub shard: Option<ShardInfo>,
    /// Grid indices of the rows, in file order (present for shards).
    pub indices: Option<Vec<usize>>,
}

/// Metadata of one data file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Metadata {
    /// Always "vibrobar".
    pub tool: String,
    /// Tool version.
    pub version: String,
    /// UTC time stamp, RFC 3339.
    pub created_utc: String,
    /// The command line that made the file.
    pub command: Vec<String>,
    /// What the file is (`map`, `sweep`, `run`, `poincare`, …).
    pub kind: String,
    /// CSV header of the data file (empty for binary files).
    pub header: String,
    /// Hash of `kind` and `parameters`: equal for the same job, whatever the shard or the time.
    pub fingerprint: String,
    /// Every parameter and solver setting, in SI units.
    pub parameters: serde_json::Value,
    /// Grid bookkeeping, for sweeps and maps.
    pub grid: Option<GridInfo>,
}

impl Metadata {
    /// Metadata for a job whose parameters are the typed value `parameters` (the spec types
    /// themselves, serialised by serde); the fingerprint is computed from `kind` and them.
    pub fn new<P: Serialize>(
        kind: &str,
        header: &str,
        parameters: P,
        grid: Option<GridInfo>,
    ) -> Self {
        let parameters = serde_json::to_value(parameters).expect("parameters serialise to JSON");
        Metadata {
            tool: "vibrobar".into(),
            version: env!("CARGO_PKG_VERSION").into(),
            created_utc: utc_now_rfc3339(),
            command: std::env::args().collect(),
            kind: kind.into(),
            header: header.into(),
            fingerprint: fingerprint(kind, &parameters),
            parameters,
            grid,
        }
    }

    /// Write beside `data_path` (atomically) and return its path; `None` when `data_path` is a
    /// device or FIFO, which gets no sidecar files (see [`crate::target`]).
    pub fn write_beside(&self, data_path: &Path) -> Result<Option<PathBuf>> {
        if !resolve_output(data_path)?.is_regular() {
            return Ok(None);
        }
        let p = meta_path(data_path);
        let text = serde_json::to_string_pretty(self).expect("metadata serialises");
        write_atomic(&p, (text + "\n").as_bytes())?;
        Ok(Some(p))
    }

    /// Read the metadata beside `data_path`.
    pub fn read_beside(data_path: &Path) -> Result<Metadata> {
        let p = meta_path(data_path);
        let text = std::fs::read_to_string(&p).map_err(IoError::os(&p))?;
        serde_json::from_str(&text).map_err(|e| IoError::Metadata {
            path: p.clone(),
            why: e.to_string(),
        })
    }

    /// The parameters as the typed value they were written from (`data_path` names the file
    /// in errors).
    pub fn parameters_as<P: DeserializeOwned>(&self, data_path: &Path) -> Result<P> {
        P::deserialize(&self.parameters).map_err(|e| IoError::Metadata {
            path: meta_path(data_path),
            why: format!("parameters: {e}"),
        })
    }
}

/// `FILE.meta.json` beside `FILE`.
pub fn meta_path(data_path: &Path) -> PathBuf {
    let mut name = data_path
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(".meta.json");
    data_path.with_file_name(name)
}

/// FNV-1a 64 of `kind` and the compact JSON of `parameters` (serde_json keeps map order stable).
pub fn fingerprint(kind: &str, parameters: &serde_json::Value) -> String {
    let text = format!(
        "{kind}\n{}",
        serde_json::to_string(parameters).expect("json")
    );
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in text.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// Current UTC time as `YYYY-MM-DDTHH:MM:SSZ`.
pub fn utc_now_rfc3339() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0);
    rfc3339(secs)
}

/// Unix seconds to RFC 3339 (proleptic Gregorian; days-from-civil inverse of H. Hinnant).
pub fn rfc3339(unix_s: i64) -> String {
    let days = unix_s.div_euclid(86_400);
    let sod = unix_s.rem_euclid(86_400);
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        sod / 3600,
        sod % 3600 / 60,
        sod % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rfc3339_known_instants() {
        assert_eq!(rfc3339(0), "1970-01-01T00:00:00Z");
        assert_eq!(rfc3339(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(rfc3339(1_795_320_000), "2026-11-22T04:00:00Z");
    }

    #[test]
    fn fingerprint_depends_on_parameters_only() {
        let a = serde_json::json!({"gap_m": 1e-4, "ratio": [0.95, 1.05]});
        let b = serde_json::json!({"gap_m": 1e-3, "ratio": [0.95, 1.05]});
        assert_eq!(fingerprint("map", &a), fingerprint("map", &a.clone()));
        assert_ne!(fingerprint("map", &a), fingerprint("map", &b));
        assert_ne!(fingerprint("map", &a), fingerprint("sweep", &a));
    }

    #[test]
    fn regression_special_file_gets_no_metadata_sidecar() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe");
        crate::target::test_fifo(&fifo);
        let m = Metadata::new("run", "", serde_json::json!({}), None);
        assert_eq!(m.write_beside(&fifo).unwrap(), None);
        assert!(!meta_path(&fifo).exists());
    }

    #[test]
    fn round_trip_beside_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("m.csv");
        let m = Metadata::new(
            "map",
            "a,b",
            serde_json::json!({"x": 1.5}),
            Some(GridInfo {
                total: 4,
                shard: Some(ShardInfo { k: 1, n: 2 }),
                indices: Some(vec![0, 2]),
            }),
        );
        let p = m.write_beside(&data).unwrap().unwrap();
        assert!(p.ends_with("m.csv.meta.json"));
        assert_eq!(Metadata::read_beside(&data).unwrap(), m);
    }
}
