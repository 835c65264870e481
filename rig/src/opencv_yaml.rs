//! Camera intrinsics and distortion in OpenCV's FileStorage YAML layout (`camera_matrix`,
//! `distortion_coefficients`, `image_width`, `image_height`), as OpenCV's calibration tools write them,
//! so calibrations move between scanrig and OpenCV-based tools both ways.
//!
//! OpenCV's YAML is not plain YAML (a `%YAML:1.0` directive, `!!opencv-matrix` tags), so this module reads
//! the layout itself: top-level `key: value` scalars and `key: !!opencv-matrix` blocks with `rows`,
//! `cols`, `dt` and a `data: [ … ]` list that may wrap over several lines.

use crate::camera::{Distortion, PinholeCamera};
use crate::error::{Error, Location, ParseError, Problem};
use crate::run_files::{read_bytes, write_atomic};
use std::path::Path;

/// A top-level value of an OpenCV YAML file.
#[derive(Debug, Clone, PartialEq)]
pub enum YamlValue {
    /// A number.
    Number(f64),
    /// Any other scalar, as written.
    Text(String),
    /// An `!!opencv-matrix`, data row-major.
    Matrix {
        /// Rows.
        rows: usize,
        /// Columns.
        cols: usize,
        /// `rows · cols` values, row-major.
        data: Vec<f64>,
    },
}

/// Parses the top level of an OpenCV FileStorage YAML file: `(key, value, line)` in file order.
pub fn parse(bytes: &[u8]) -> Result<Vec<(String, YamlValue, usize)>, ParseError> {
    let text = String::from_utf8_lossy(bytes);
    let lines: Vec<&str> = text.lines().collect();
    let err = |line: usize, p: Problem| ParseError::new(Location::Line(line), p);
    let first = lines.first().copied().unwrap_or("");
    if !first.starts_with("%YAML") {
        return Err(err(1, Problem::BadMagic { format: "OpenCV YAML", found: first.chars().take(40).collect() }));
    }
    let mut out = Vec::new();
    let mut i = 1;
    while i < lines.len() {
        let raw = lines[i];
        let line = i + 1;
        i += 1;
        let l = raw.split('#').next().unwrap_or("").trim_end();
        if l.trim().is_empty() || l.trim() == "---" || l.starts_with(' ') {
            continue;
        }
        let (key, value) = l.split_once(':').ok_or_else(|| {
            err(
                line,
                Problem::Invalid(format!("expected `key: value`, found `{}`", l.chars().take(60).collect::<String>())),
            )
        })?;
        let (key, value) = (key.trim().to_string(), value.trim());
        if value == "!!opencv-matrix" {
            // The block: indented `rows`, `cols`, `dt`, `data: [ … ]` until the closing bracket.
            let mut fields = std::collections::HashMap::new();
            let mut data: Option<String> = None;
            while i < lines.len() && lines[i].starts_with(' ') {
                let sub = lines[i].trim();
                i += 1;
                if let Some(d) = &mut data {
                    d.push(' ');
                    d.push_str(sub);
                } else if let Some((k, v)) = sub.split_once(':') {
                    if k.trim() == "data" {
                        data = Some(v.trim().to_string());
                    } else {
                        fields.insert(k.trim().to_string(), v.trim().to_string());
                    }
                }
                if data.as_ref().is_some_and(|d| d.contains(']')) {
                    break;
                }
            }
            let dim = |name: &str| -> Result<usize, ParseError> {
                let v = fields
                    .get(name)
                    .ok_or_else(|| err(line, Problem::Missing(format!("`{name}` of matrix `{key}`"))))?;
                v.parse::<usize>().map_err(|_| err(line, Problem::NotANumber(v.chars().take(40).collect())))
            };
            let (rows, cols) = (dim("rows")?, dim("cols")?);
            let data = data.ok_or_else(|| err(line, Problem::Missing(format!("`data` of matrix `{key}`"))))?;
            let inner = data.trim().strip_prefix('[').and_then(|d| d.strip_suffix(']')).ok_or_else(|| {
                err(line, Problem::Invalid(format!("`data` of matrix `{key}` must be a bracketed list")))
            })?;
            let values: Vec<f64> = inner
                .split(',')
                .map(str::trim)
                .filter(|s| !s.is_empty())
                .map(|s| parse_number(s).ok_or_else(|| err(line, Problem::NotANumber(s.chars().take(40).collect()))))
                .collect::<Result<_, _>>()?;
            if rows.checked_mul(cols) != Some(values.len()) {
                let msg = format!("matrix `{key}` is {rows}×{cols} but holds {} values", values.len());
                return Err(err(line, Problem::Invalid(msg)));
            }
            out.push((key, YamlValue::Matrix { rows, cols, data: values }, line));
        } else {
            let v = parse_number(value)
                .map(YamlValue::Number)
                .unwrap_or_else(|| YamlValue::Text(value.trim_matches('"').to_string()));
            out.push((key, v, line));
        }
    }
    Ok(out)
}

/// OpenCV writes `536.`, `.5`, `-.Inf` and `.Nan`; Rust's parser needs help with the last two.
fn parse_number(s: &str) -> Option<f64> {
    match s {
        ".Inf" | "+.Inf" => Some(f64::INFINITY),
        "-.Inf" => Some(f64::NEG_INFINITY),
        ".Nan" | ".NaN" => Some(f64::NAN),
        _ => s.parse().ok(),
    }
}

/// Reads a camera from OpenCV YAML bytes. Needs `camera_matrix` (3×3, no skew), `distortion_coefficients`
/// (4, 5, 8, 12 or 14 terms; terms beyond OpenCV's first five must be zero, as scanrig's model has five)
/// and `image_width`/`image_height`.
pub fn camera_from_bytes(bytes: &[u8]) -> Result<PinholeCamera, ParseError> {
    let entries = parse(bytes)?;
    let get = |k: &str| entries.iter().find(|(key, _, _)| key == k);
    let field = |k: &str| Location::Field(k.to_string());
    let number = |k: &str| -> Result<f64, ParseError> {
        match get(k) {
            Some((_, YamlValue::Number(v), _)) => Ok(*v),
            Some((_, _, line)) => {
                Err(ParseError::new(Location::Line(*line), Problem::Invalid(format!("`{k}` must be a number"))))
            }
            None => Err(ParseError::new(field(k), Problem::Missing(format!("`{k}`")))),
        }
    };
    let matrix = |k: &str| -> Result<(usize, usize, &Vec<f64>, usize), ParseError> {
        match get(k) {
            Some((_, YamlValue::Matrix { rows, cols, data }, line)) => Ok((*rows, *cols, data, *line)),
            Some((_, _, line)) => Err(ParseError::new(
                Location::Line(*line),
                Problem::Invalid(format!("`{k}` must be an !!opencv-matrix")),
            )),
            None => Err(ParseError::new(field(k), Problem::Missing(format!("`{k}`")))),
        }
    };
    let size = |k: &str| -> Result<u32, ParseError> {
        let v = number(k)?;
        if v >= 1.0 && v.fract() == 0.0 && v <= u32::MAX as f64 {
            Ok(v as u32)
        } else {
            Err(ParseError::new(field(k), Problem::Invalid(format!("`{k}` must be a positive whole number, is {v}"))))
        }
    };
    let (rows, cols, k, line) = matrix("camera_matrix")?;
    if (rows, cols) != (3, 3) {
        return Err(ParseError::new(
            Location::Line(line),
            Problem::Invalid(format!("`camera_matrix` must be 3×3, is {rows}×{cols}")),
        ));
    }
    if k[1] != 0.0 || k[3] != 0.0 || k[6] != 0.0 || k[7] != 0.0 || k[8] != 1.0 {
        return Err(ParseError::new(
            Location::Line(line),
            Problem::Invalid("`camera_matrix` must be [fx 0 cx; 0 fy cy; 0 0 1] (scanrig's model has no skew)".into()),
        ));
    }
    let (rows, cols, d, line) = matrix("distortion_coefficients")?;
    if rows.min(cols) != 1 || ![4, 5, 8, 12, 14].contains(&d.len()) {
        let msg = format!("`distortion_coefficients` must be a vector of 4, 5, 8, 12 or 14 terms, is {rows}×{cols}");
        return Err(ParseError::new(Location::Line(line), Problem::Invalid(msg)));
    }
    if d.iter().skip(5).any(|&c| c != 0.0) {
        let msg = "`distortion_coefficients` uses OpenCV's rational, thin-prism or tilt terms (beyond k3), which scanrig's five-term model cannot represent; recalibrate with the default flags";
        return Err(ParseError::new(Location::Line(line), Problem::Invalid(msg.into())));
    }
    let mut c = [0.0; 5];
    c[..d.len().min(5)].copy_from_slice(&d[..d.len().min(5)]);
    let cam = PinholeCamera {
        width: size("image_width")?,
        height: size("image_height")?,
        fx: k[0],
        fy: k[4],
        cx: k[2],
        cy: k[5],
        distortion: Distortion::from_opencv(c),
    };
    cam.distortion.validate().map_err(|m| ParseError::new(field("distortion_coefficients"), Problem::Invalid(m)))?;
    cam.validate().map_err(|m| ParseError::new(field("camera_matrix"), Problem::Invalid(m)))?;
    Ok(cam)
}

/// Formats a value so OpenCV reads it as a real: shortest round-trip digits, always with a `.` or exponent.
fn real(v: f64) -> String {
    let s = format!("{v:?}");
    if s.contains(['.', 'e', 'E', 'N', 'n', 'i']) { s } else { format!("{s}.") }
}

fn matrix_block(key: &str, rows: usize, cols: usize, data: &[f64]) -> String {
    let values: Vec<String> = data.iter().map(|&v| real(v)).collect();
    format!("{key}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n   data: [ {} ]\n", values.join(", "))
}

/// A camera as OpenCV YAML text (the layout of OpenCV's calibration sample, readable by
/// `cv::FileStorage`).
pub fn camera_to_string(cam: &PinholeCamera) -> String {
    let k = [cam.fx, 0.0, cam.cx, 0.0, cam.fy, cam.cy, 0.0, 0.0, 1.0];
    format!(
        "%YAML:1.0\n---\nimage_width: {}\nimage_height: {}\n{}{}",
        cam.width,
        cam.height,
        matrix_block("camera_matrix", 3, 3, &k),
        matrix_block("distortion_coefficients", 1, 5, &cam.distortion.to_opencv())
    )
}

/// Reads a camera from an OpenCV YAML file.
pub fn read_camera(path: &Path) -> Result<PinholeCamera, Error> {
    camera_from_bytes(&read_bytes(path)?).map_err(|e| e.with_path(path))
}

/// Writes a camera as OpenCV YAML, atomically.
pub fn write_camera(path: &Path, cam: &PinholeCamera) -> Result<(), Error> {
    write_atomic(path, camera_to_string(cam).as_bytes())
}
