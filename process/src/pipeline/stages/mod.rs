//! The stages as functions: plain data in, a new value and a report out, or a typed error. `scanrig
//! process` and every single-stage subcommand (`denoise`, `register`, `fuse`, `reconstruct`,
//! `remesh`) call these same functions with the same parameter types, whose `Default`s are the one
//! source of defaults — so a stage run alone and the same stage inside `process` write identical
//! files for identical inputs.

mod apart;
mod fuse_stage;
mod merge_stage;
mod mesh_stage;
mod passes_stage;
mod register_stage;
mod remesh_stage;
mod view_stages;

pub use apart::*;
pub use fuse_stage::*;
pub use merge_stage::*;
pub use mesh_stage::*;
pub use passes_stage::*;
pub use register_stage::*;
pub use remesh_stage::*;
pub use view_stages::*;

use crate::denoise::DenoiseError;
use crate::reconstruct::global_fft::ReconstructError;
use crate::register::icp::IcpError;
use crate::remesh::RemeshError;
use rig::math::Real;

/// Why a stage could not run on its input.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StageError {
    /// The frames cannot be decoded.
    #[error(transparent)]
    Decode(#[from] decode::structured_light::DecodeError),
    /// A projector map of another size than the rig's camera.
    #[error(
        "the frames are {}×{} pixels but the rig's camera is {}×{}: the rig does not belong to these frames \
         (check width_px and height_px in rig.toml)",
        map.0, map.1, camera.0, camera.1
    )]
    MapSize {
        /// The map's (frames') size.
        map: (usize, usize),
        /// The camera's size.
        camera: (u32, u32),
    },
    /// Fusion needs more points than its neighbourhoods hold.
    #[error(
        "the cloud has {points} points; fusion with {k} neighbours per kernel needs more (lower --k, or check \
         that the scan found the object)"
    )]
    TooFewPoints {
        /// Points in the cloud.
        points: usize,
        /// Neighbours per kernel.
        k: usize,
    },
    /// A point or normal that is not a finite number.
    #[error("point {index} of the cloud is not finite (position or normal NaN or infinite)")]
    NonFinite {
        /// The point.
        index: usize,
    },
    /// Normals of zero length: they face no side.
    #[error(
        "point {index} of the cloud has a zero normal ({count} such points): a normal without a side cannot \
         say where the outside is; drop the cloud's normals (fusion then estimates and orients them) or fix them"
    )]
    ZeroNormal {
        /// The first such point.
        index: usize,
        /// How many.
        count: usize,
    },
    /// Many points at exactly one place: a scanner's missing pixels written as a point (often the
    /// origin) rather than left out.
    #[error(
        "{count} of the cloud's points ({:.1} %) lie at exactly ({}, {}, {}): {}",
        100.0 * *count as Real / *points as Real, at[0], at[1], at[2],
        if count == points {
            "the cloud has no extent (check how it was exported)"
        } else {
            "missing measurements written as a point rather than left out? Remove them; they are not the \
             object's surface"
        }
    )]
    Pile {
        /// How many points lie there.
        count: usize,
        /// Points in the cloud.
        points: usize,
        /// Where.
        at: [Real; 3],
    },
    /// The base could not be cut.
    #[error(transparent)]
    Base(#[from] crate::reconstruct::base::BaseError),
    /// The reconstruction found no surface.
    #[error("the reconstruction found no surface in {points} points: {why}")]
    NoSurface {
        /// Points in the cloud.
        points: usize,
        /// The likely causes, naming the option to change where one is to blame.
        why: String,
    },
    /// A streamline spacing so small the quad mesh could not be built in reasonable time.
    #[error(
        "--spacing {spacing:.3e}: {ratio:.0} times finer than the default for a mesh {diagonal:.4} across; \
         give at least {smallest:.4}"
    )]
    SpacingTooSmall {
        /// The spacing asked for.
        spacing: Real,
        /// The mesh's bounding-box diagonal.
        diagonal: Real,
        /// Default spacing over the asked one.
        ratio: Real,
        /// The smallest spacing accepted.
        smallest: Real,
    },
    /// A parameter outside what the stage can use (`process::limits`).
    #[error(transparent)]
    Param(#[from] rig::limits::ParamError),
    /// Denoising refused the grid.
    #[error(transparent)]
    Denoise(#[from] DenoiseError),
    /// Registration found too few views.
    #[error("registration needs at least two views, found {0}")]
    TooFewViews(usize),
    /// Pairwise registration failed.
    #[error("registration: {0}")]
    Icp(#[from] IcpError),
    /// Passes that cannot be aligned by their shape.
    #[error("aligning the passes: {0}")]
    Global(#[from] crate::register::global::GlobalError),
    /// A result that cannot be right: refused unless forced.
    #[error("{what}; {hint}")]
    Implausible {
        /// What is wrong, with the figures.
        what: String,
        /// What may cause it and what the user can do.
        hint: String,
    },
    /// A mesh its cloud does not support ([`judge_support`]): refused unless forced. Apart from
    /// [`StageError::Implausible`] so a caller can tell which finding it is by its kind, not by the
    /// wording of its message.
    #[error("{what}; {hint}")]
    Unsupported {
        /// Which finding.
        finding: Finding,
        /// What is wrong, with the figures.
        what: String,
        /// What may cause it and what the user can do.
        hint: String,
    },
    /// The cloud cannot be meshed.
    #[error(transparent)]
    Reconstruct(#[from] ReconstructError),
    /// The mesh cannot be remeshed.
    #[error(transparent)]
    Remesh(#[from] RemeshError),
}
