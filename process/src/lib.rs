//! # process — the geometry pipeline
//!
//! Each stage is a plain function over plain data from [`rig`] (frames, a projector map, a range grid, a
//! point cloud), usable without the command line; [`pipeline::process_scan`] chains them over a scan
//! folder. The catalogue, with the thesis chapter each algorithm implements:
//!
//! - [`structured_light::decode_view`]: Gray code with inverses, shadow and contrast masks, N-step phase
//!   shift unwrapped by the Gray code ([`gray_code`], [`phase_shift`]);
//! - [`triangulate`]: camera ray against the projector's column surface (distortion-aware) or least-
//!   squares ray–ray, and against laser planes — the general form of eq. 2.3 (ch. 2), which
//!   [`triangulate::depth_eq_2_3`] states;
//! - [`laser_line`]: sub-pixel laser stripe centres (Gaussian fit or centre of mass) with saturation and
//!   double-peak rejection;
//! - [`grid_normals`]: normals from range-grid neighbours, oriented toward the sensor;
//! - [`placement`]: views into the object frame by turntable pose, cropped to the platter cylinder and
//!   merged with view ids and confidences.
//!
//! - [`denoise`]: per-scan non-local denoising of range grids, static and time-varying (ch. 4,
//!   eqs. 4.3–4.6), with the bilateral filter in the same framework;
//!
//! - [`icp`]: robust point-to-plane ICP (ch. 2.2) with a shrinking correspondence distance, Tukey
//!   weights and boundary and normal rejection; [`normals`]: PCA normals over k-d-tree neighbours;
//!
//! - [`multiview`], [`register_scan`]: all views refined together from their turntable poses;
//! - [`mean_shift`]: fusion by anisotropic mean shift with adaptive neighbourhoods, clustering and
//!   outlier removal (ch. 3, eqs. 3.2–3.10); [`orient`]: consistent normal orientation;
//! - [`reconstruct`]: the global FFT method and AdFFT's partition of unity, marching cubes (ch. 5);
//! - [`remesh`]: harmonic and quasi-harmonic fields with line constraints, streamlines of their
//!   gradient and co-gradient, and the quads between them (ch. 6).
//!
//! ```
//! use process::triangulate::depth_eq_2_3;
//! // A 100 mm baseline with the beam and the view both at 60° to it: an equilateral triangle.
//! let d = depth_eq_2_3(100.0, 60f64.to_radians(), 60f64.to_radians());
//! assert!((d - 100.0).abs() < 1e-9);
//! ```
#![deny(missing_docs)]

pub mod denoise;
pub mod gray_code;
pub mod grid_normals;
pub mod icp;
pub mod laser_line;
pub mod mean_shift;
pub mod multiview;
pub mod normals;
pub mod orient;
pub mod phase_shift;
pub mod pipeline;
pub mod placement;
pub mod preview;
pub mod projector_map;
pub mod reconstruct;
pub mod register_scan;
pub mod remesh;
pub mod spatial_order;
pub mod structured_light;
pub mod triangulate;

pub use pipeline::{ProcessParams, ProcessReport, Stage, process_scan};
pub use projector_map::ProjectorMap;
pub use structured_light::{DecodeError, DecodeParams, decode_view};

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
    /// A scan or rig that cannot be processed as asked.
    #[error("{0}")]
    Setup(String),
}
