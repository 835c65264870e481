//! What the commands print with `--json`, typed and documented field by field. Each is printed through
//! [`crate::outputs::versioned`], which adds `schema_version`
//! ([`process::pipeline::REPORT_SCHEMA_VERSION`]); `process --json` prints its `report.json`
//! ([`process::pipeline::ProcessReport`]), `calibrate --json` its `NAME.report.json`
//! ([`calib::CalibReport`]), `fuse` and `remesh` their stage's report.

use process::pipeline::GridReport;
use process::pipeline::stages::{FinishReport, ReconstructReport, RegisterReport};
use process::register::register_scan::ViewPose;
use rig::topology::Topology;
use serde::Serialize;
use std::path::Path;

/// `scanrig convert --json`: what was written.
#[derive(Debug, Serialize)]
pub struct Converted<'a> {
    /// The file written.
    pub output: &'a Path,
    /// What it holds.
    #[serde(flatten)]
    pub what: ConvertedKind<'a>,
}

/// What `convert` wrote, by kind (`kind`: `range_grid`, `mesh` or `cloud`).
#[derive(Debug, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ConvertedKind<'a> {
    /// A range grid: its size and valid cells.
    RangeGrid {
        /// Columns.
        width: usize,
        /// Rows.
        height: usize,
        /// Valid cells.
        points: usize,
    },
    /// A mesh: its counts, and what the reader could not keep.
    Mesh {
        /// Vertices.
        vertices: usize,
        /// Faces (polygons as one each).
        faces: usize,
        /// What the input held that the output does not.
        warnings: &'a [String],
    },
    /// A point cloud: its count, and what the reader could not keep.
    Cloud {
        /// Points.
        points: usize,
        /// What the input held that the output does not.
        warnings: &'a [String],
    },
}

/// `scanrig decode --json` without a rig: the projector map written.
#[derive(Debug, Serialize)]
pub struct Decoded<'a> {
    /// The map (`.npy`, H×W×3: projector column, row, confidence).
    pub output: &'a Path,
    /// Its preview image.
    pub preview: &'a Path,
    /// What decoding found.
    pub report: &'a process::DecodeReport,
}

/// `scanrig decode --rig --json`: the range grid triangulated from the map.
#[derive(Debug, Serialize)]
pub struct Triangulated<'a> {
    /// The range grid (PLY, camera frame, mm).
    pub output: &'a Path,
    /// What decoding found.
    pub report: &'a process::DecodeReport,
    /// What triangulation left.
    pub triangulate: &'a GridReport,
}

/// `scanrig denoise --json`: one entry per grid.
#[derive(Debug, Serialize)]
pub struct Denoised<'a> {
    /// Each grid denoised, in the order given.
    pub grids: Vec<DenoisedGrid<'a>>,
}

/// One grid that `denoise` filtered.
#[derive(Debug, Serialize)]
pub struct DenoisedGrid<'a> {
    /// The grid read.
    pub input: &'a Path,
    /// The grid written.
    pub output: &'a Path,
    /// What the filter did (ch. 4).
    pub report: process::denoise::DenoiseReport,
}

/// `scanrig reconstruct --json`: the mesh's reconstruction and finish, and its shape.
#[derive(Debug, Serialize)]
pub struct Reconstructed<'a> {
    /// The reconstruction (ch. 5), by method.
    pub report: &'a ReconstructReport,
    /// Base, trim and top cut.
    pub finish: &'a FinishReport,
    /// Components, boundary and non-manifold counts, Euler characteristic.
    pub topology: Topology,
    /// The genus, where the mesh is a closed oriented 2-manifold.
    pub genus: Option<i64>,
    /// Wall time of the mesh stage (s).
    pub seconds: f64,
    /// The process' peak resident memory (bytes; absent where the system does not say).
    pub peak_resident_bytes: Option<u64>,
}

/// `scanrig register --json`: the registration and every view's pose.
#[derive(Debug, Serialize)]
pub struct Registered<'a> {
    /// What registration did.
    pub report: &'a RegisterReport,
    /// Each view's pose, as `registered.poses.json` holds them.
    pub poses: &'a [ViewPose],
}

/// `scanrig demo --json`: the simulation's report, the processing's and the accuracy.
#[derive(Debug, Serialize)]
pub struct Demo<'a, S: Serialize> {
    /// What the simulator wrote.
    pub simulation: &'a S,
    /// `report.json`.
    pub process: &'a process::pipeline::ProcessReport,
    /// `accuracy.json`.
    pub accuracy: &'a Accuracy,
}

/// `accuracy.json`: the demo's range grids measured against the simulator's truth (issue 4's
/// measures). Fields in alphabetical order, as the file has always had them.
#[derive(Debug, Clone, Serialize)]
pub struct Accuracy {
    /// Visible lit pixels decoded (%).
    pub decoded_percent: f64,
    /// The object's bounding-box diagonal (mm).
    pub diagonal_mm: f64,
    /// Median distance of a point from the truth surface (mm).
    pub median_mm: f64,
    /// The same, in per cent of the diagonal.
    pub median_percent_of_diagonal: f64,
    /// Points farther than 1 % of the diagonal from the truth (%).
    pub outlier_percent: f64,
    /// Points measured on the object.
    pub points_on_object: usize,
    /// Views measured.
    pub views: usize,
}

/// `scanrig align --json` (and `--pose FILE`): the motion found and how sure it is.
#[derive(Debug, Serialize)]
pub struct Aligned<'a> {
    /// Cloud A, the one moved.
    pub moving: &'a Path,
    /// Cloud B, the one it was moved onto.
    pub fixed: &'a Path,
    /// The motion taking A's coordinates into B's, as a 4 × 4 matrix (rows; the last is 0 0 0 1).
    pub pose: [[f64; 4]; 4],
    /// The spacing the clouds were thinned to for matching.
    pub voxel: f64,
    /// Whether it is trusted and why not, the matches, overlap, residual and the best rival's share
    /// ([`process::register::global::GlobalAlignment`]).
    pub alignment: &'a process::register::global::GlobalAlignment,
}
