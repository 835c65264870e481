//! # process — the geometry pipeline
//!
//! Each stage is a plain function over plain data from [`rig`] (a projector map, a range grid, a
//! point cloud, a mesh), usable without the command line; [`pipeline::stages`] holds the stage
//! functions `scanrig process` and the single-stage subcommands share, and [`pipeline::process_scan`]
//! chains them over a scan folder. The catalogue, by stage, with the thesis chapter each algorithm
//! implements:
//!
//! - **decode** ([`decode::structured_light`], [`decode::gray_code`], [`decode::phase_shift`], [`decode::projector_map`]; the `decode`
//!   crate, shared with calibration): Gray code with inverses, shadow and contrast masks, N-step
//!   phase shift unwrapped by the Gray code;
//! - **triangulate** ([`triangulate`]): camera ray against the projector's column surface
//!   (distortion-aware) or least-squares ray–ray, and against laser planes ([`triangulate::laser_line`]) — the
//!   general form of eq. 2.3 (ch. 2), which [`triangulate::depth_eq_2_3`] states; [`triangulate::grid_normals`]:
//!   normals from range-grid neighbours, oriented toward the sensor;
//! - **denoise** ([`denoise`]): per-scan non-local denoising of range grids, static and time-varying
//!   (ch. 4, eqs. 4.3–4.6), with the bilateral filter in the same framework;
//! - **merge** ([`merge`]): views into the object frame by turntable pose, cropped to the platter
//!   cylinder and merged with view ids and confidences;
//! - **register** ([`register`]): robust point-to-plane ICP (ch. 2.2, [`register::icp`]) and all views refined
//!   together from their turntable poses ([`register::multiview`], [`register::register_scan`]);
//! - **fuse** ([`fuse`]): anisotropic mean shift with adaptive neighbourhoods, clustering and outlier
//!   removal (ch. 3, eqs. 3.2–3.10, [`fuse::mean_shift`]); consistent normal orientation ([`fuse::orient`]);
//! - **reconstruct** ([`reconstruct`]): the global FFT method and AdFFT's partition of unity,
//!   marching cubes (ch. 5);
//! - **remesh** ([`remesh`]): harmonic and quasi-harmonic fields with line constraints, streamlines
//!   of their gradient and co-gradient, and the quads between them (ch. 6).
//!
//! Shared pieces: [`kd_tree`] (every neighbourhood query), [`normals`] (PCA normals),
//! [`mesh_distance`] (the accuracy metric against a reference surface), [`preview`] (images).
//!
//! ```
//! use process::triangulate::depth_eq_2_3;
//! // A 100 mm baseline with the beam and the view both at 60° to it: an equilateral triangle.
//! let d = depth_eq_2_3(100.0, 60f64.to_radians(), 60f64.to_radians());
//! assert!((d - 100.0).abs() < 1e-9);
//! ```
#![deny(missing_docs)]

pub mod cell_grid;
pub mod triangulate;

pub mod denoise;

pub mod merge;

pub mod register;

pub mod fuse;

pub mod reconstruct;

pub mod remesh;

pub mod pipeline;

/// Every stage's parameter limits.
pub mod limits;
pub use limits::ParamError;
/// The `validate` each stage calls first, against those limits.
pub mod validate;

pub mod kd_tree;
pub mod median;
pub mod mesh_distance;
pub mod normals;
pub mod preview;

pub use decode::projector_map::ProjectorMap;
pub use decode::structured_light::{DecodeError, DecodeParams, DecodeReport, decode_view};
pub use pipeline::stages::StageError;
pub use pipeline::{ProcessParams, ProcessReport, Stage, process_scan};

use std::path::PathBuf;

/// What can go wrong in processing.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Reading or writing a file.
    #[error(transparent)]
    File(#[from] rig::Error),
    /// A view's frames cannot be decoded.
    #[error("view {view}: {source}")]
    Decode {
        /// The view.
        view: usize,
        /// Why.
        source: DecodeError,
    },
    /// A stage left nothing to go on with: which options or inputs did it.
    #[error("{stage} left nothing: {why}")]
    LeftNothing {
        /// The stage.
        stage: Stage,
        /// What removed everything, naming the option or input.
        why: String,
    },
    /// A parameter no stage could use, refused before the first stage.
    #[error(transparent)]
    Param(#[from] ParamError),
    /// A stage could not run on one view.
    #[error("view {view}: {stage}: {source}")]
    View {
        /// The view.
        view: usize,
        /// The stage.
        stage: Stage,
        /// Why.
        source: StageError,
    },
    /// A stage over the whole scan could not run.
    #[error("{stage}: {source}")]
    Stage {
        /// The stage.
        stage: Stage,
        /// Why.
        source: StageError,
    },
    /// A structured-light scan whose rig has no projector.
    #[error("{}: a structured-light scan needs a rig with a [projector]", rig.display())]
    NoProjector {
        /// The rig file.
        rig: PathBuf,
    },
    /// Registration from turntable poses without a turntable.
    #[error("{}: registration from turntable poses needs a [turntable]", rig.display())]
    NoTurntable {
        /// The rig file.
        rig: PathBuf,
    },
    /// A view lacks a frame the method needs.
    #[error("view {view} has no {frame} frame")]
    MissingFrame {
        /// The view.
        view: usize,
        /// The frame's pattern name.
        frame: &'static str,
    },
    /// A pack of outputs (from a distributed run's worker) that cannot be adopted.
    #[error("output {name} of a packed part: {why}")]
    Part {
        /// The file's name in the pack.
        name: String,
        /// What is wrong with it.
        why: String,
    },
    /// A view asked for by number that the scan does not have complete.
    #[error("{} has no complete view {view} ({views} views in its manifest)", scan.display())]
    NoSuchView {
        /// The scan folder.
        scan: PathBuf,
        /// The view asked for.
        view: usize,
        /// Views in the manifest.
        views: usize,
    },
    /// A scan without a complete view.
    #[error(
        "{}: none of its {views} views is complete (an interrupted capture? `scanrig scan --resume` finishes it)",
        scan.display()
    )]
    NoCompleteViews {
        /// The scan folder.
        scan: PathBuf,
        /// Views in the manifest.
        views: usize,
    },
    /// A laser frame of a laser the rig does not have.
    #[error("view {view} has a frame of laser {index}, but {} has {lasers} laser(s)", rig.display())]
    UnknownLaser {
        /// The view.
        view: usize,
        /// The laser index in the frame.
        index: usize,
        /// Lasers in the rig.
        lasers: usize,
        /// The rig file.
        rig: PathBuf,
    },
    /// Calibration captures given to `process`.
    #[error("{}: a board capture is for `scanrig calibrate`, not `scanrig process`", scan.display())]
    BoardCapture {
        /// The scan folder.
        scan: PathBuf,
    },
    /// A cached projector map of the wrong shape.
    #[error("{}: not a projector map (an H × W × 3 array); rerun with --redo", path.display())]
    NotAProjectorMap {
        /// The file.
        path: PathBuf,
    },
    /// The output folder is in use.
    #[error(transparent)]
    Lock(#[from] rig::folder_lock::LockError),
    /// An output folder that is not this scan's to write in: the user's files, or another scan's
    /// results.
    #[error("{}: not written: {why}", out.display())]
    NotThisScansFolder {
        /// The output folder.
        out: PathBuf,
        /// Whose it is, and what to do.
        why: String,
    },
}
