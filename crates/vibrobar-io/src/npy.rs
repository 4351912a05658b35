//! NumPy `.npy` (format 1.0) for little-endian `f64` arrays, so that `numpy.load` and MATLAB
//! readers (e.g. `readNPY`) open time histories and Poincaré points directly.

use crate::atomic::write_atomic;
use crate::error::{IoError, Result};
use std::path::{Path, PathBuf};

const MAGIC: &[u8] = b"\x93NUMPY";

/// The header block: magic, version 1.0, header length, the dict padded so that the data start
/// on a 64-byte boundary (the format's requirement for version 1.0 readers that memory-map).
pub fn header(shape: &[usize]) -> Vec<u8> {
    let dims = match shape.len() {
        1 => format!("({},)", shape[0]),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(|d| d.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    let mut dict = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': {dims}, }}");
    let unpadded = MAGIC.len() + 2 + 2 + dict.len() + 1;
    dict.push_str(&" ".repeat((64 - unpadded % 64) % 64));
    dict.push('\n');
    let mut out = Vec::with_capacity(MAGIC.len() + 4 + dict.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&[1, 0]);
    out.extend_from_slice(&(dict.len() as u16).to_le_bytes());
    out.extend_from_slice(dict.as_bytes());
    out
}

/// Encode a C-order `f64` array of the given shape (`path` names the file in errors).
pub fn encode_f64(path: &Path, shape: &[usize], data: &[f64]) -> Result<Vec<u8>> {
    let expected: usize = shape.iter().product();
    if expected != data.len() {
        return Err(IoError::NpyShape {
            path: path.to_path_buf(),
            shape: shape.to_vec(),
            expected,
            got: data.len(),
        });
    }
    let mut out = header(shape);
    out.reserve(8 * data.len());
    for x in data {
        out.extend_from_slice(&x.to_le_bytes());
    }
    Ok(out)
}

/// Write a C-order `f64` array atomically (`path.partial`, then rename); on failure nothing is
/// left behind and the error names the file.
pub fn write_f64(path: &Path, shape: &[usize], data: &[f64]) -> Result<()> {
    let bytes = encode_f64(path, shape, data)?;
    write_atomic(path, &bytes)
}

/// Decode what [`encode_f64`] writes: `(shape, data)`.
pub fn decode_f64(bytes: &[u8], path: &str) -> Result<(Vec<usize>, Vec<f64>)> {
    let bad = |why: &str| IoError::NpyFormat {
        path: PathBuf::from(path),
        why: why.to_string(),
    };
    if bytes.len() < 10 || &bytes[..6] != MAGIC {
        return Err(bad("missing NUMPY magic"));
    }
    if bytes[6] != 1 {
        return Err(bad("only format version 1.x is supported"));
    }
    let hlen = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let start = 10 + hlen;
    let dict = std::str::from_utf8(
        bytes
            .get(10..start)
            .ok_or_else(|| bad("truncated header"))?,
    )
    .map_err(|_| bad("header is not UTF-8"))?;
    if !dict.contains("'descr': '<f8'") || !dict.contains("'fortran_order': False") {
        return Err(bad("only little-endian f64 in C order is supported"));
    }
    let open = dict.find("'shape': (").ok_or_else(|| bad("no shape"))? + "'shape': (".len();
    let close = open
        + dict[open..]
            .find(')')
            .ok_or_else(|| bad("unterminated shape"))?;
    let shape = dict[open..close]
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<usize>().map_err(|_| bad("bad shape entry")))
        .collect::<Result<Vec<_>, _>>()?;
    let n: usize = shape.iter().product();
    let body = &bytes[start..];
    if body.len() != 8 * n {
        return Err(bad("data length does not match the shape"));
    }
    let data = body
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("chunks of 8")))
        .collect();
    Ok((shape, data))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_is_64_byte_aligned_and_newline_terminated() {
        for shape in [
            vec![0],
            vec![7],
            vec![3, 4],
            vec![100_000, 7],
            vec![2, 3, 5],
        ] {
            let h = header(&shape);
            assert_eq!(
                h.len() % 64,
                0,
                "shape {shape:?}: header length {}",
                h.len()
            );
            assert_eq!(*h.last().unwrap(), b'\n');
        }
    }

    #[test]
    fn round_trip_keeps_every_bit() {
        let data: Vec<f64> = (0..12)
            .map(|i| (i as f64 * 0.1).sin() * 1e-5)
            .chain([f64::MIN_POSITIVE, -0.0])
            .collect();
        let bytes = encode_f64(Path::new("mem"), &[7, 2], &data).unwrap();
        let (shape, back) = decode_f64(&bytes, "mem").unwrap();
        assert_eq!(shape, vec![7, 2]);
        assert!(data
            .iter()
            .zip(&back)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
    }

    #[test]
    fn one_dimensional_shape_has_trailing_comma() {
        let h = header(&[5]);
        let s = String::from_utf8_lossy(&h);
        assert!(s.contains("'shape': (5,)"), "{s}");
    }

    #[test]
    fn shape_mismatch_is_an_error() {
        assert!(matches!(
            encode_f64(Path::new("x.npy"), &[2, 2], &[1.0, 2.0, 3.0]),
            Err(IoError::NpyShape {
                expected: 4,
                got: 3,
                ..
            })
        ));
    }
}
