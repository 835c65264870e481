//! # sim — the virtual rig
//!
//! Renders exactly the frames a real rig records — structured-light patterns, laser lines, chessboards
//! for calibration — of any mesh on a virtual turntable, with ground truth, and writes them as the same
//! scan folder a capture session writes. It is how users without hardware, and every regression test,
//! see the pipeline work.
//!
//! - [`SimConfig`]: a rig plus the physics a rig file does not hold (noise, gamma, defocus, emitters).
//! - [`Scene`] of [`Part`]s: analytic [`Sphere`], [`Rectangle`], [`Disc`] and triangle meshes
//!   ([`MeshSurface`], a BVH built once per mesh), on the turntable or fixed to the camera.
//! - [`view_geometry`]: one ray per pixel and the shadow rays toward the projector and the laser emitters,
//!   once per view; [`render_frame`] then forms each frame from it (Lambertian shading, pattern light with
//!   gamma and defocus, Gaussian laser profile, shot and read noise, 8-bit quantisation).
//! - [`simulate_scan`]: the whole capture program into a scan folder with `truth/`; deterministic per seed.
//! - [`simulate_board`]: calibration captures of a chessboard at given poses or swept on the turntable.
//!
//! ```
//! use sim::{Part, PartKind, Mount, Albedo, Scene, Sphere, SimConfig, view_geometry, pixel_rays};
//! use rig::math::{Isometry3, Point3};
//! let cfg = SimConfig::from_toml_str(
//!     "format = 1\n[rig]\nformat = 1\n[rig.camera]\nwidth_px = 64\nheight_px = 48\n\
//!      fx_px = 60.0\nfy_px = 60.0\ncx_px = 31.5\ncy_px = 23.5\n",
//! ).unwrap();
//! let sphere = Sphere { center: Point3::new(0.0, 0.0, 200.0), radius: 50.0 };
//! let scene = Scene { parts: vec![Part { kind: PartKind::Object, surface: Box::new(sphere),
//!     pose: Isometry3::identity(), mount: Mount::Fixed, albedo: Albedo::Constant(0.8) }] };
//! let g = view_geometry(&scene, &cfg, &pixel_rays(&cfg.rig.camera), &Isometry3::identity());
//! // The centre pixel sees the sphere's near pole, 150 mm away.
//! let centre = 24 * 64 + 32;
//! assert!((g.point[centre].z - 150.0).abs() < 0.5);
//! ```
#![deny(missing_docs)]

pub mod board;
pub mod bvh;
pub mod colour;
pub mod config;
pub mod geometry;
pub mod light;
pub mod object;
pub mod render;
pub mod scan;
pub mod scene;
pub mod surface;
pub mod truth;

pub use board::{Board, BoardPoses, Cover, simulate_board};
pub use config::SimConfig;
pub use geometry::{ViewGeometry, pixel_rays, view_geometry};
pub use object::{
    UpAxis, fluted_vase, fluted_vase_tessellated, object_on_platter, place_on_platter, turned_over, validate_placement,
};
pub use render::render_frame;
pub use scan::{ScanOptions, ScanReport, SimPass, simulate_passes, simulate_scan};
pub use scene::{Albedo, Markers, Mount, Part, PartKind, Scene};
pub use surface::{Disc, MeshSurface, Rectangle, Sphere, Surface};

/// What can go wrong in a simulation.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Reading or writing a file.
    #[error(transparent)]
    File(#[from] rig::Error),
    /// A configuration that cannot make the requested captures.
    #[error("{0}")]
    Setup(String),
}
