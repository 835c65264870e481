//! NumPy `.npy` arrays: how the simulator's ground truth (depth, normals, projector coordinates) and
//! other per-pixel maps are stored, so `numpy.load` opens them directly.
//!
//! Version 1.0 files, little-endian `f64`, `f32` or `u8`, C order. The reader takes the same and refuses
//! anything else with a clear error.

use crate::error::{Error, Location, ParseError, Problem};
use crate::run_files::{read_bytes, write_atomic};
use std::path::Path;

/// The element data of an array.
#[derive(Debug, Clone, PartialEq)]
pub enum NpyData {
    /// `<f8`.
    F64(Vec<f64>),
    /// `<f4`.
    F32(Vec<f32>),
    /// `|u1`.
    U8(Vec<u8>),
}

/// An n-dimensional array in C order.
#[derive(Debug, Clone, PartialEq)]
pub struct NpyArray {
    /// The shape, e.g. `[height, width, 3]`.
    pub shape: Vec<usize>,
    /// `shape.iter().product()` elements.
    pub data: NpyData,
}

impl NpyArray {
    /// The values as `f64` (any element type).
    pub fn to_f64(&self) -> Vec<f64> {
        match &self.data {
            NpyData::F64(v) => v.clone(),
            NpyData::F32(v) => v.iter().map(|&x| x as f64).collect(),
            NpyData::U8(v) => v.iter().map(|&x| x as f64).collect(),
        }
    }
}

/// The bytes of a `.npy` file.
pub fn to_bytes(a: &NpyArray) -> Vec<u8> {
    let descr = match &a.data {
        NpyData::F64(_) => "<f8",
        NpyData::F32(_) => "<f4",
        NpyData::U8(_) => "|u1",
    };
    let shape = match a.shape.len() {
        1 => format!("({},)", a.shape[0]),
        _ => format!("({})", a.shape.iter().map(usize::to_string).collect::<Vec<_>>().join(", ")),
    };
    let mut header = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
    // Pad so the data starts on a 64-byte boundary, as NumPy does; the header ends with a newline.
    let total = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - total % 64) % 64));
    header.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    // Straight into the output (a simulated view's truth is tens of MB a view): no body built apart.
    match &a.data {
        NpyData::F64(v) => {
            out.reserve(8 * v.len());
            v.iter().for_each(|x| out.extend_from_slice(&x.to_le_bytes()));
        }
        NpyData::F32(v) => {
            out.reserve(4 * v.len());
            v.iter().for_each(|x| out.extend_from_slice(&x.to_le_bytes()));
        }
        NpyData::U8(v) => out.extend_from_slice(v),
    }
    out
}

/// Parses `.npy` bytes.
pub fn parse(bytes: &[u8]) -> Result<NpyArray, ParseError> {
    let bad = |p: Problem| ParseError::new(Location::File, p);
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        let found = String::from_utf8_lossy(&bytes[..bytes.len().min(6)]).into_owned();
        return Err(bad(Problem::BadMagic { format: "NumPy .npy", found }));
    }
    let (hlen, start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 if bytes.len() >= 12 => (u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize, 12),
        v => return Err(bad(Problem::UnsupportedFormat(format!(".npy version {v}")))),
    };
    let header =
        bytes.get(start..start + hlen).ok_or_else(|| bad(Problem::Truncated("the end of the header".into())))?;
    let header = String::from_utf8_lossy(header);
    let field = |key: &str| -> Option<String> {
        let i = header.find(&format!("'{key}'"))? + key.len() + 2;
        let rest = header[i..].trim_start().strip_prefix(':')?.trim_start();
        let end = if rest.starts_with('(') { rest.find(')')? + 1 } else { rest.find([',', '}'])? };
        Some(rest[..end].trim().trim_matches('\'').to_string())
    };
    let descr = field("descr").ok_or_else(|| bad(Problem::Missing("'descr' in the header".into())))?;
    if field("fortran_order").as_deref() != Some("False") {
        return Err(bad(Problem::UnsupportedFormat("Fortran-order arrays".into())));
    }
    let shape_text = field("shape").ok_or_else(|| bad(Problem::Missing("'shape' in the header".into())))?;
    let shape: Vec<usize> = shape_text
        .trim_matches(|c| c == '(' || c == ')')
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<usize>().map_err(|_| bad(Problem::NotANumber(s.chars().take(40).collect()))))
        .collect::<Result<_, _>>()?;
    let count = shape.iter().try_fold(1usize, |a, &d| a.checked_mul(d));
    let body = &bytes[start + hlen..];
    let size = match descr.as_str() {
        "<f8" => 8,
        "<f4" => 4,
        "|u1" | "<u1" => 1,
        other => return Err(bad(Problem::UnsupportedFormat(format!("element type {other}")))),
    };
    let count = count.filter(|c| c.checked_mul(size).is_some_and(|b| b <= body.len())).ok_or_else(|| {
        bad(Problem::Truncated(format!("the {shape_text} array of {descr} ({} data bytes present)", body.len())))
    })?;
    let body = &body[..count * size];
    let data = match size {
        8 => NpyData::F64(body.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap())).collect()),
        4 => NpyData::F32(body.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect()),
        _ => NpyData::U8(body.to_vec()),
    };
    Ok(NpyArray { shape, data })
}

/// Writes a `.npy` file atomically.
pub fn write(path: &Path, a: &NpyArray) -> Result<(), Error> {
    write_atomic(path, &to_bytes(a))
}

/// Reads a `.npy` file.
pub fn read(path: &Path) -> Result<NpyArray, Error> {
    parse(&read_bytes(path)?).map_err(|e| e.with_path(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_each_type_and_header_alignment() {
        for a in [
            NpyArray { shape: vec![2, 3], data: NpyData::F64(vec![1.0, -2.5, f64::NAN.abs(), 0.0, 1e300, -0.0]) },
            NpyArray { shape: vec![4], data: NpyData::F32(vec![1.0, 2.0, 3.0, 4.5]) },
            NpyArray { shape: vec![1, 2, 3], data: NpyData::U8(vec![1, 2, 3, 4, 5, 6]) },
        ] {
            let b = to_bytes(&a);
            assert_eq!((10 + u16::from_le_bytes([b[8], b[9]]) as usize) % 64, 0);
            let back = parse(&b).unwrap();
            assert_eq!(back.shape, a.shape);
            assert_eq!(format!("{:?}", back.data), format!("{:?}", a.data));
        }
    }
}
