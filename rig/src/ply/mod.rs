//! PLY files: a reader for every variant we meet and a writer the common viewers open.
//!
//! The reader takes ASCII, binary little- and big-endian, every scalar type, list properties of any
//! count and item type, any property order, and elements it does not know (kept, never fatal). On top of
//! the raw [`PlyFile`] sit conversions to the vocabulary types: [`read_cloud`], [`read_mesh`] (faces of
//! any size, or Stanford `tristrips` turned into triangles) and [`read_range_grid`] (scanrig's
//! `grid_col grid_row` per vertex, or Stanford's `range_grid` element, with `obj_info num_cols/num_rows`).
//!
//! Bad files give an [`Error`] naming the file, the element and the entry (or the header
//! line). Counts are checked against the bytes left before anything is allocated, so a header that
//! claims a billion vertices in a 1 kB file is refused, not attempted.
//!
//! The writer produces binary little-endian by default (ASCII on request), `float` or `double`
//! coordinates, `uchar` colours, and faces as `list uchar int vertex_indices`, which MeshLab, Open3D
//! and CloudCompare all open.

mod as_written;
mod body;
mod convert;
mod header;
mod write;

pub use as_written::{cloud_as_written, range_grid_as_written};
pub use convert::{cloud_from_ply, mesh_from_ply, range_grid_from_ply, sparse_view_from_ply};
pub use header::{ElementDef, Encoding, Header, PropertyDef, PropertyKind, ScalarType};
pub use write::{
    Precision, WriteOptions, cloud_to_bytes, mesh_to_bytes, range_grid_to_bytes, sparse_view_to_bytes, write_cloud,
    write_mesh, write_range_grid,
};

use crate::error::{Error, ParseError};
use crate::run_files::read_bytes;
use crate::{PointCloud, PolyMesh, RangeGrid, SparseView};
use std::path::Path;

/// The values of one property across all entries of an element.
#[derive(Debug, Clone, PartialEq)]
pub enum Column {
    /// One value per entry (integers are exact in `f64`: every PLY type fits).
    Scalar(Vec<f64>),
    /// One list per entry: entry `i` is `values[offsets[i]..offsets[i + 1]]`.
    List {
        /// Start of each entry's list, plus a final end.
        offsets: Vec<usize>,
        /// All lists' items, one list after another.
        values: Vec<f64>,
    },
}

/// An element's definition and its data, one [`Column`] per property in header order.
#[derive(Debug, Clone, PartialEq)]
pub struct Element {
    /// The header's definition.
    pub def: ElementDef,
    /// The data, one column per property.
    pub columns: Vec<Column>,
}

impl Element {
    fn column(&self, name: &str) -> Option<&Column> {
        let i = self.def.properties.iter().position(|p| p.name == name)?;
        Some(&self.columns[i])
    }

    /// A scalar property's values, if the element has it.
    pub fn scalar(&self, name: &str) -> Option<&[f64]> {
        match self.column(name)? {
            Column::Scalar(v) => Some(v),
            Column::List { .. } => None,
        }
    }

    /// A list property's (offsets, values), if the element has it.
    pub fn list(&self, name: &str) -> Option<(&[usize], &[f64])> {
        match self.column(name)? {
            Column::List { offsets, values } => Some((offsets, values)),
            Column::Scalar(_) => None,
        }
    }

    /// The first list property, whatever its name (Stanford files disagree on `vertex_indices` vs
    /// `vertex_index` vs `vertex_ind`).
    pub fn first_list(&self) -> Option<(&str, &[usize], &[f64])> {
        self.def.properties.iter().zip(&self.columns).find_map(|(p, c)| match c {
            Column::List { offsets, values } => Some((p.name.as_str(), offsets.as_slice(), values.as_slice())),
            Column::Scalar(_) => None,
        })
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        self.def.count as usize
    }

    /// True without entries.
    pub fn is_empty(&self) -> bool {
        self.def.count == 0
    }
}

/// A whole PLY file: header and every element's data.
#[derive(Debug, Clone, PartialEq)]
pub struct PlyFile {
    /// The header.
    pub header: Header,
    /// The elements in file order.
    pub elements: Vec<Element>,
}

impl PlyFile {
    /// The element called `name`, if present.
    pub fn element(&self, name: &str) -> Option<&Element> {
        self.elements.iter().find(|e| e.def.name == name)
    }
}

/// Parses PLY bytes.
pub fn parse(bytes: &[u8]) -> Result<PlyFile, ParseError> {
    let (header, body_start) = header::parse_header(bytes)?;
    let elements = body::parse_body(&header, &bytes[body_start..], header.body_line)?;
    Ok(PlyFile { header, elements })
}

/// Reads a PLY file.
pub fn read(path: &Path) -> Result<PlyFile, Error> {
    parse(&read_bytes(path)?).map_err(|e| e.with_path(path))
}

/// Reads only a PLY file's header (fast for large files: it had read the whole file, and every
/// write that keeps its input's unit reads the input's header).
pub fn read_header(path: &Path) -> Result<Header, Error> {
    let bytes = crate::run_files::read_prefix(path, header::MAX_HEADER_BYTES as u64 + 1)?;
    header::parse_header(&bytes).map(|(h, _)| h).map_err(|e| e.with_path(path))
}

/// Reads a PLY file's `vertex` element as a point cloud (positions, and normals, colours, confidence and
/// view ids where present).
pub fn read_cloud(path: &Path) -> Result<PointCloud, Error> {
    cloud_from_ply(&read(path)?).map_err(|e| e.with_path(path))
}

/// Reads a PLY mesh: `face` lists of any size, or `tristrips`.
pub fn read_mesh(path: &Path) -> Result<PolyMesh, Error> {
    mesh_from_ply(&read(path)?).map_err(|e| e.with_path(path))
}

/// The header comment of a file in a turntable scan's object frame (`comment frame …`): z up the turntable
/// axis, the platter at z = 0. `process` writes it; `reconstruct` takes the platter plane from it.
pub const TURNTABLE_FRAME: &str = "frame turntable object: z up the axis, platter at z = 0";

/// Whether a PLY header says its data are in a turntable scan's object frame ([`TURNTABLE_FRAME`]).
pub fn in_turntable_frame(header: &Header) -> bool {
    header.comments.iter().any(|c| c == TURNTABLE_FRAME)
}

/// Whether a PLY file holds a range grid (either layout [`range_grid_from_ply`] reads).
pub fn is_range_grid(ply: &PlyFile) -> bool {
    ply.element("range_grid").is_some()
        || ply.element("vertex").is_some_and(|v| v.scalar("grid_col").is_some() && v.scalar("grid_row").is_some())
}

/// Reads a range scan (scanrig's `grid_col grid_row` or Stanford's `range_grid`, and `obj_info
/// num_cols/num_rows`).
pub fn read_range_grid(path: &Path) -> Result<RangeGrid, Error> {
    range_grid_from_ply(&read(path)?).map_err(|e| e.with_path(path))
}

/// Reads a sparse view (vertices with `px_col px_row`, `obj_info num_cols/num_rows`).
pub fn read_sparse_view(path: &Path) -> Result<SparseView, Error> {
    sparse_view_from_ply(&read(path)?).map_err(|e| e.with_path(path))
}
