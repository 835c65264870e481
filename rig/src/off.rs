//! Object File Format (OFF), as Geomview and libigl write it: an `OFF` keyword (optionally prefixed by
//! `C`, `N` or `ST` for per-vertex extras, and optionally followed by the counts on the same line), a
//! `vertices faces edges` line, vertex lines, then faces as `k i1 … ik [colour]`. `#` starts a comment.

use crate::PolyMesh;
use crate::error::{Error, Location, ParseError, Problem};
use crate::math::Point3;
use crate::run_files::read_bytes;
use std::path::Path;

/// Parses OFF text into a polygon mesh (positions and faces; see [`parse_reported`] for what is not kept).
pub fn parse(bytes: &[u8]) -> Result<PolyMesh, ParseError> {
    parse_reported(bytes).map(|(mesh, _)| mesh)
}

/// [`parse`], with what it does not keep named, one sentence each: the per-vertex colours, normals or
/// texture coordinates a `C`, `N` or `ST` prefix announces, and per-face colours.
pub fn parse_reported(bytes: &[u8]) -> Result<(PolyMesh, Vec<String>), ParseError> {
    let text = String::from_utf8_lossy(bytes);
    // Non-empty lines with comments removed, keeping their 1-based numbers for messages.
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.split('#').next().unwrap_or("").trim()))
        .filter(|(_, l)| !l.is_empty());
    let err = |line: usize, p: Problem| ParseError::new(Location::Line(line), p);
    let num = |tok: &str, line: usize| {
        tok.parse::<f64>().map_err(|_| err(line, Problem::NotANumber(tok.chars().take(40).collect())))
    };

    let (first_no, first) =
        lines.next().ok_or_else(|| err(1, Problem::BadMagic { format: "OFF", found: String::new() }))?;
    let mut toks = first.split_whitespace();
    let magic = toks.next().unwrap_or("");
    let Some(prefix) = magic.strip_suffix("OFF") else {
        return Err(err(first_no, Problem::BadMagic { format: "OFF", found: magic.chars().take(40).collect() }));
    };
    // C, N and ST add per-vertex colours, normals or texture coordinates after x y z: only x y z are read.
    if !matches!(prefix, "" | "C" | "N" | "ST" | "NC" | "CN" | "STC" | "STN" | "STNC") {
        return Err(err(first_no, Problem::UnsupportedFormat(magic.chars().take(40).collect())));
    }
    let mut counts: Vec<&str> = toks.collect();
    let mut counts_line = first_no;
    if counts.is_empty() {
        let (n, l) =
            lines.next().ok_or_else(|| err(first_no, Problem::Truncated("the vertex and face counts".into())))?;
        counts = l.split_whitespace().collect();
        counts_line = n;
    }
    let count = |i: usize| -> Result<usize, ParseError> {
        let tok = counts.get(i).ok_or_else(|| err(counts_line, Problem::Missing("vertex and face counts".into())))?;
        tok.parse::<usize>().map_err(|_| err(counts_line, Problem::NotANumber(tok.chars().take(40).collect())))
    };
    let (nv, nf) = (count(0)?, count(1)?);
    // Every vertex line takes at least 6 bytes (`0 0 0\n`) and every face line 8: refuse counts the file
    // cannot hold before allocating for them.
    let need = (nv as u128) * 6 + (nf as u128) * 8;
    if need > bytes.len() as u128 {
        let problem = Problem::CountTooLarge {
            count: (nv as u64).saturating_add(nf as u64),
            min_bytes: 6,
            available: bytes.len() as u64,
        };
        return Err(err(counts_line, problem));
    }
    let mut mesh = PolyMesh { vertices: Vec::with_capacity(nv), ..Default::default() };
    for i in 0..nv {
        let (line, l) =
            lines.next().ok_or_else(|| err(counts_line, Problem::Truncated(format!("vertex {i} of {nv}"))))?;
        let c: Vec<f64> = l.split_whitespace().take(3).map(|t| num(t, line)).collect::<Result<_, _>>()?;
        if c.len() < 3 {
            return Err(err(line, Problem::Invalid(format!("a vertex needs 3 coordinates, has {}", c.len()))));
        }
        if c.iter().any(|v| !v.is_finite()) {
            return Err(err(line, Problem::NonFinite("vertex position".into())));
        }
        mesh.vertices.push(Point3::new(c[0], c[1], c[2]));
    }
    let mut warnings = Vec::new();
    let extras: Vec<&str> = [("ST", "texture coordinates"), ("N", "normals"), ("C", "colours")]
        .iter()
        .filter(|(p, _)| prefix.contains(p))
        .map(|(_, what)| *what)
        .collect();
    if !extras.is_empty() {
        warnings
            .push(format!("its per-vertex {} ({magic}) are not kept: only positions are read", extras.join(" and ")));
    }
    let mut coloured_faces = 0usize;
    let mut face = Vec::new();
    for i in 0..nf {
        let (line, l) =
            lines.next().ok_or_else(|| err(counts_line, Problem::Truncated(format!("face {i} of {nf}"))))?;
        let mut toks = l.split_whitespace();
        let k = toks.next().unwrap_or("");
        let k = k.parse::<usize>().map_err(|_| err(line, Problem::NotANumber(k.chars().take(40).collect())))?;
        if k < 3 {
            return Err(err(line, Problem::DegenerateFace(k)));
        }
        face.clear();
        for _ in 0..k {
            let t =
                toks.next().ok_or_else(|| err(line, Problem::Truncated(format!("the {k} indices of this face"))))?;
            let idx = t.parse::<i64>().map_err(|_| err(line, Problem::NotANumber(t.chars().take(40).collect())))?;
            if idx < 0 || idx as usize >= nv {
                return Err(err(
                    line,
                    Problem::IndexOutOfRange { index: idx.to_string().into(), what: "vertex", count: nv, first: 0 },
                ));
            }
            face.push(idx as u32);
        }
        coloured_faces += usize::from(toks.next().is_some());
        mesh.push_face(&face);
    }
    if coloured_faces > 0 {
        warnings.push(format!("the colours of {coloured_faces} faces are not kept (scanrig keeps colours per vertex)"));
    }
    Ok((mesh, warnings))
}

/// Reads an OFF file.
pub fn read(path: &Path) -> Result<PolyMesh, Error> {
    parse(&read_bytes(path)?).map_err(|e| e.with_path(path))
}

/// Reads an OFF file with what was not kept named (see [`parse_reported`]).
pub fn read_reported(path: &Path) -> Result<(PolyMesh, Vec<String>), Error> {
    parse_reported(&read_bytes(path)?).map_err(|e| e.with_path(path))
}
