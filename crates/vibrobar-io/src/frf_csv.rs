//! The FRF table of `vibrobar frf` and `vibrobar.frf`: `frequency_hz`, then per curve
//! `{curve}_re_m_per_n`, `{curve}_im_m_per_n`, `{curve}_mag_m_per_n`, `{curve}_phase_deg`
//! (phase of the displacement against the force, in (−180, 180]) and the curve's own columns
//! (`stepped_sine_rms_m`, `stepped_sine_impacts_per_cycle`, `tap_coherence`).

use crate::csv::{write_csv, Column, Format, Schema, Value};
use crate::error::Result;
use std::borrow::Cow;
use std::path::Path;
use vibrobar_core::analysis::frf::FrfCurve;

fn column(name: String, format: Format) -> Column {
    Column {
        name: Cow::Owned(name),
        format,
        optional: false,
    }
}

/// The columns of an FRF table of `curves`.
pub fn frf_schema(curves: &[FrfCurve]) -> Schema {
    let mut columns = vec![Column {
        name: Cow::Borrowed("frequency_hz"),
        format: Format::Coord,
        optional: false,
    }];
    for c in curves {
        for suffix in ["re_m_per_n", "im_m_per_n", "mag_m_per_n"] {
            columns.push(column(format!("{}_{suffix}", c.name), Format::Sci));
        }
        columns.push(column(format!("{}_phase_deg", c.name), Format::Plain));
        for (suffix, _) in &c.extra {
            let format = if suffix.ends_with("_m") {
                Format::Sci
            } else {
                Format::Plain
            };
            columns.push(column(format!("{}_{suffix}", c.name), format));
        }
    }
    Schema { columns }
}

/// The rows of an FRF table, one per line, in the columns of [`frf_schema`].
pub fn frf_rows(lines_hz: &[f64], curves: &[FrfCurve]) -> Vec<Vec<Value>> {
    lines_hz
        .iter()
        .enumerate()
        .map(|(i, &f)| {
            let mut row = vec![Value::F(f)];
            for c in curves {
                let g = c.values_m_per_n[i];
                row.extend([
                    Value::F(g.re),
                    Value::F(g.im),
                    Value::F(g.norm()),
                    Value::F(g.arg().to_degrees()),
                ]);
                for (_, v) in &c.extra {
                    row.push(Value::F(v[i]));
                }
            }
            row
        })
        .collect()
}

/// Write an FRF table (atomic, under the output-path policy; a non-finite value refuses the
/// write and leaves nothing).
pub fn write_frf_csv(path: &Path, lines_hz: &[f64], curves: &[FrfCurve]) -> Result<()> {
    write_csv(path, &frf_schema(curves), frf_rows(lines_hz, curves))
}
