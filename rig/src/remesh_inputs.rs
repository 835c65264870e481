//! The two text files `scanrig remesh` takes besides the mesh.
//!
//! **Constraint lines** (`--constraints`): one line per polyline; `#` starts a comment, blank lines
//! are skipped. A polyline is either mesh vertex indices (0-based), or `p` followed by points
//! (`x y z` triples) that are snapped to the surface:
//!
//! ```text
//! # a crease given by its vertices, and a sketched curve
//! 12 45 78 90
//! p 0.0 1.0 2.0   0.5 1.2 2.1   1.0 1.4 2.3
//! ```
//!
//! **Per-face values** (`--conductivity`): one non-negative number per face, in face order,
//! separated by white space or new lines; `#` comments allowed.

use crate::error::{Error, Location, ParseError, Problem};
use crate::math::{Point3, Real};
use crate::run_files::read_bytes;
use std::path::Path;

/// One constraint polyline as written.
#[derive(Debug, Clone, PartialEq)]
pub enum ConstraintLine {
    /// Mesh vertex indices.
    Vertices(Vec<usize>),
    /// Points to snap to the surface.
    Points(Vec<Point3>),
}

fn text(bytes: &[u8]) -> Result<&str, ParseError> {
    std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count() + 1;
        ParseError::new(Location::Line(line), Problem::Invalid("the file is not UTF-8 text".into()))
    })
}

/// Parses a constraint-line file (see the module notes).
pub fn parse_constraints(bytes: &[u8]) -> Result<Vec<ConstraintLine>, ParseError> {
    Ok(parse_numbered_constraints(bytes)?.into_iter().map(|(_, c)| c).collect())
}

/// [`parse_constraints`], each polyline with the file's line it is on (from 1): a polyline found
/// unusable later (a vertex not in the mesh) is named by that line, not by its place among the
/// polylines, which comments and blank lines shift.
pub fn parse_numbered_constraints(bytes: &[u8]) -> Result<Vec<(usize, ConstraintLine)>, ParseError> {
    let mut out = Vec::new();
    for (i, raw) in text(bytes)?.lines().enumerate() {
        let at = || Location::Line(i + 1);
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let mut tokens = line.split_whitespace().peekable();
        if tokens.peek() == Some(&"p") {
            tokens.next();
            let values: Vec<Real> = tokens
                .map(|t| t.parse::<Real>().map_err(|_| ParseError::new(at(), Problem::NotANumber(t.into()))))
                .collect::<Result<_, _>>()?;
            if !values.len().is_multiple_of(3) {
                return Err(ParseError::new(
                    at(),
                    Problem::Invalid(format!("{} coordinates do not make x y z points", values.len())),
                ));
            }
            if let Some(v) = values.iter().find(|v| !v.is_finite()) {
                return Err(ParseError::new(at(), Problem::NonFinite(v.to_string())));
            }
            let points: Vec<Point3> = values.chunks(3).map(|c| Point3::new(c[0], c[1], c[2])).collect();
            if points.len() < 2 {
                return Err(ParseError::new(at(), Problem::Invalid("a line needs at least two points".into())));
            }
            out.push((i + 1, ConstraintLine::Points(points)));
        } else {
            let vertices: Vec<usize> = tokens
                .map(|t| t.parse::<usize>().map_err(|_| ParseError::new(at(), Problem::NotANumber(t.into()))))
                .collect::<Result<_, _>>()?;
            if vertices.len() < 2 {
                return Err(ParseError::new(at(), Problem::Invalid("a line needs at least two vertices".into())));
            }
            out.push((i + 1, ConstraintLine::Vertices(vertices)));
        }
    }
    Ok(out)
}

/// Parses a per-face value file and checks it has exactly `faces` non-negative finite values.
pub fn parse_face_values(bytes: &[u8], faces: usize) -> Result<Vec<Real>, ParseError> {
    let mut out = Vec::with_capacity(faces);
    for (i, raw) in text(bytes)?.lines().enumerate() {
        let at = || Location::Line(i + 1);
        for t in raw.split('#').next().unwrap_or("").split_whitespace() {
            let v: Real = t.parse().map_err(|_| ParseError::new(at(), Problem::NotANumber(t.into())))?;
            if !v.is_finite() || v < 0.0 {
                return Err(ParseError::new(at(), Problem::Invalid(format!("{t}: values must be finite and ≥ 0"))));
            }
            out.push(v);
        }
    }
    if out.len() != faces {
        return Err(ParseError::new(
            Location::File,
            Problem::Invalid(format!("{} values for a mesh of {faces} faces", out.len())),
        ));
    }
    Ok(out)
}

/// Reads a constraint-line file, each polyline with its line ([`parse_numbered_constraints`]).
pub fn read_constraints(path: &Path) -> Result<Vec<(usize, ConstraintLine)>, Error> {
    parse_numbered_constraints(&read_bytes(path)?).map_err(|e| e.with_path(path))
}

/// Reads a per-face value file for a mesh of `faces` faces.
pub fn read_face_values(path: &Path, faces: usize) -> Result<Vec<Real>, Error> {
    parse_face_values(&read_bytes(path)?, faces).map_err(|e| e.with_path(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_kinds_of_line_and_comments_parse() {
        let text = b"# header\n12 45 78\n\np 0 0 0  1 0 0 # a sketch\n";
        let lines = parse_constraints(text).unwrap();
        assert_eq!(lines[0], ConstraintLine::Vertices(vec![12, 45, 78]));
        assert_eq!(lines[1], ConstraintLine::Points(vec![Point3::origin(), Point3::new(1.0, 0.0, 0.0)]));
        let at: Vec<usize> = parse_numbered_constraints(text).unwrap().iter().map(|l| l.0).collect();
        assert_eq!(at, [2, 4], "each polyline's line in the file, comments and blank lines counted");
    }

    #[test]
    fn mistakes_name_their_line() {
        let e = parse_constraints(b"1 2\n3 x 4\n").unwrap_err();
        assert_eq!(e.at, Location::Line(2));
        assert!(matches!(e.problem, Problem::NotANumber(ref t) if t == "x"));
        assert!(parse_constraints(b"p 1 2 3 4\n").unwrap_err().to_string().contains("line 1"));
        assert!(parse_constraints(b"7\n").is_err());
        assert!(parse_constraints(b"p 1 2 3 nan 0 0\n").is_err());
        assert!(parse_face_values(b"1 2\n-1\n", 3).unwrap_err().to_string().contains("line 2"));
        assert!(parse_face_values(b"1 2\n", 3).unwrap_err().to_string().contains("2 values for a mesh of 3 faces"));
        assert_eq!(parse_face_values(b"1 # one\n 2e3\n0", 3).unwrap(), vec![1.0, 2000.0, 0.0]);
    }
}
