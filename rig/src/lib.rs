//! # rig — scanrig's shared vocabulary
//!
//! Every scanrig crate speaks in the types defined here, and nothing else: the stage crates (`calib`,
//! `process`, `sim`, `acquire`) depend on this one and never on each other.
//!
//! - **The rig model**: a [`PinholeCamera`] with OpenCV's five-term [`Distortion`]; a [`Projector`] (an
//!   inverse camera placed by `X_p = R·X_c + t`); [`LaserPlane`]s (`n·X = d`); a [`TurntableAxis`] and
//!   the pose of the view at angle θ; all gathered in a [`Rig`] that reads and writes TOML.
//! - **Geometry**: [`RangeGrid`] (one scan on its pixel grid, with validity, normals, confidence and its
//!   [`Sensor`]), [`SparseView`] (one scan as its points and their pixels: a laser line), [`PointCloud`], [`TriMesh`] and [`PolyMesh`] (quads and n-gons).
//! - **Files**: [`ply`] (every variant in, binary or ASCII out), [`obj`], [`off`], [`opencv_yaml`]
//!   (camera intrinsics as OpenCV writes them), and [`read_mesh`]/[`write_mesh`] choosing by extension.
//!   Errors name the file and the line, element entry or field ([`Error`]).
//! - **Captures**: [`patterns`] (Gray code and phase-shift sequences, generated once for the simulator,
//!   the capture session and the decoder), [`image`] (8-bit PNG frames), [`npy`] (NumPy arrays for
//!   per-pixel truth maps) and the [`scan_folder`] manifest.
//!
//! Conventions (see each type's `# Conventions`): millimetres and degrees; OpenCV camera frame (x right,
//! y down, z forward); pixel (0, 0) is the centre of the top-left pixel. [`math`] pins `Real = f64`.
//!
//! ```
//! use rig::{LaserPlane, PinholeCamera, Point2, Vector3};
//! // A camera ray through a pixel meets a laser plane at z = 500 mm.
//! let cam = PinholeCamera::ideal(640, 480, 536.0);
//! let ray = cam.unproject(Point2::new(400.0, 120.0)).unwrap();
//! let plane = LaserPlane::new(Vector3::z(), 500.0).unwrap();
//! let hit = plane.intersect_ray(&rig::Point3::origin(), &ray).unwrap();
//! assert!((hit.z - 500.0).abs() < 1e-9);
//! // …and projects back onto the same pixel.
//! let px = cam.project(&hit).unwrap();
//! assert!((px - Point2::new(400.0, 120.0)).norm() < 1e-9);
//! ```
#![deny(missing_docs)]

pub mod math;
pub use math::{Isometry3, Matrix3, Point2, Point3, Real, Rotation3, UnitVector3, Vector2, Vector3};

/// Errors naming the file and the spot in it.
pub mod error;
pub use error::{Error, Location, ParseError, Problem};
pub use run_files::write_atomic;

/// Which files a run may write: inputs and input folders are never replaced.
pub mod run_files;

/// One run at a time per output folder.
pub mod folder_lock;

/// The pinhole camera and lens distortion.
pub mod camera;
pub use camera::{Distortion, PinholeCamera};

/// The projector.
pub mod projector;
pub use projector::Projector;

/// Laser light planes.
pub mod laser;
pub use laser::{LaserColour, LaserPlane};

/// The turntable axis and view poses.
pub mod turntable;
pub use turntable::{TurntableAxis, WorkingVolume};

/// The rig description and its TOML file.
pub mod rig_file;
pub use rig_file::{Laser, Rig, RigProblem};

/// Range grids.
pub mod range_grid;
pub use range_grid::{RangeGrid, Sensor};

/// Sparse views: measured points with their pixels.
pub mod sparse_view;
pub use sparse_view::SparseView;

/// Point clouds and bounding boxes.
pub mod point_cloud;
pub use point_cloud::{Aabb, CloudRef, PointCloud};

/// Triangle and polygon meshes.
pub mod mesh;
pub use mesh::{FaceSizes, PolyMesh, TriMesh};

/// Polygons other tools can read: ear clipping, convexity.
pub mod polygon;
pub mod precision;

/// Separable convolution with clamped edges (the Gaussian blurs).
pub mod convolve;
pub mod e57;
pub mod glb;
pub mod image;
pub mod input;
mod jpeg_check;
pub mod limits;
pub mod npy;
pub mod obj;
pub mod off;
pub mod opencv_yaml;
pub mod ply;
pub mod remesh_inputs;
pub mod stl;

/// Structured-light and laser pattern sequences.
pub mod patterns;
pub use patterns::{Axis, Pattern, PhaseShift};

pub mod fabscan_scan;
pub mod frame_order;
pub mod gray_code_folders;
pub mod scan_folder;
pub mod scanner_calibration;
pub use scan_folder::{Manifest, Method};

/// Meshes and clouds by file extension.
pub mod memory;
pub mod mesh_io;
pub mod split_mix;
pub mod topology;
pub mod union_find;
pub use mesh_io::{
    MeshFormat, Reported, cloud_losses, data_units, mesh_losses, read_cloud, read_cloud_reported, read_mesh,
    read_mesh_reported, write_cloud, write_mesh,
};
