//! `scanrig process`: a scan folder through every stage — decode, triangulate (with grid normals),
//! denoise, place by turntable pose and merge, register, fuse, reconstruct, remesh. Each stage is a
//! function in [`stages`] that the single-stage subcommands call too; this module only chains them,
//! owns the output folder's [`layout`], and decides from [`records`] which outputs are current. Each
//! output is written atomically; the next stage gets exactly what the file holds (read back from the
//! bytes written), so a resumed run and a fresh one give the same files.
//!
//! The output folder is locked while a run works in it ([`rig::folder_lock`]); `report.json` is merged stage by
//! stage, so a resumed or partial run keeps the sections of the stages it did not touch.

pub mod layout;
pub mod memory;
mod out;
pub mod parts;
pub mod records;
mod report;
mod run;
mod scan_steps;
pub mod stages;
mod view_steps;
pub mod volume;
pub mod watch;

pub use report::{GridReport, LaserViewReport, ProcessReport, REPORT_SCHEMA_VERSION, Section, StageRow, ViewReport};
pub use run::{process_scan, register_processed};

use crate::merge::CropParams;
use crate::reconstruct::closing::CloseParams;
use crate::register::register_scan::RegisterParams;
use crate::remesh::RemeshParams;
use crate::triangulate::TriangulateParams;
use crate::triangulate::laser_line::LaserParams;
use decode::structured_light::DecodeParams;
use rig::math::Real;
use serde::{Deserialize, Serialize};
use stages::{DenoiseStage, FinishParams, FuseParams, ReconstructParams};

/// The stages, in order; `--until` stops after one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Stage {
    /// Projector maps (structured light).
    Decode,
    /// Per-view range grids with normals.
    Triangulate,
    /// Non-local denoising of each structured-light range grid (ch. 4).
    Denoise,
    /// Views placed in the object frame, cropped and merged.
    Merge,
    /// View poses refined by multi-view ICP (ch. 2.2), views merged again.
    Register,
    /// Mean-shift fusion (ch. 3).
    Fuse,
    /// A watertight mesh of the fused cloud (ch. 5).
    Reconstruct,
    /// A quad mesh of the watertight one (ch. 6).
    Remesh,
}

impl Stage {
    /// Every stage, in order.
    pub const ALL: [Stage; 8] = [
        Stage::Decode,
        Stage::Triangulate,
        Stage::Denoise,
        Stage::Merge,
        Stage::Register,
        Stage::Fuse,
        Stage::Reconstruct,
        Stage::Remesh,
    ];

    /// The stage of a name (see [`Stage::name`]).
    pub fn from_name(name: &str) -> Option<Stage> {
        Stage::ALL.into_iter().find(|s| s.name() == name)
    }

    /// The stage's name as the command line and the reports spell it.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Decode => "decode",
            Stage::Triangulate => "triangulate",
            Stage::Denoise => "denoise",
            Stage::Merge => "merge",
            Stage::Register => "register",
            Stage::Fuse => "fuse",
            Stage::Reconstruct => "reconstruct",
            Stage::Remesh => "remesh",
        }
    }
}

impl std::fmt::Display for Stage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Everything `process_scan` can be told; every stage's parameters, with the same defaults the
/// single-stage subcommands use.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProcessParams {
    /// Structured-light decoding.
    pub decode: DecodeParams,
    /// Triangulation.
    pub triangulate: TriangulateParams,
    /// Laser-line extraction.
    pub laser: LaserParams,
    /// Grid neighbours farther apart than this (mm) are not used for a view's normals.
    pub normal_max_jump_mm: Real,
    /// Per-view denoising of structured-light grids; `None` skips the stage.
    pub denoise: Option<DenoiseStage>,
    /// The object cylinder; a `None` radius takes the rig's platter radius.
    pub crop: CropParams,
    /// Multi-view registration.
    pub register: RegisterParams,
    /// Mean-shift fusion.
    pub fuse: FuseParams,
    /// Flat caps over the fused cloud's open base and top before reconstruction (object frame);
    /// `None` reconstructs the cloud as fused.
    pub close: Option<CloseParams>,
    /// Reconstruction.
    pub reconstruct: ReconstructParams,
    /// The mesh's base (cut at the platter) and trim, before it is written.
    pub finish: FinishParams,
    /// Quad remeshing.
    pub remesh: RemeshParams,
    /// The last stage to run.
    pub until: Stage,
    /// Redo stages whose outputs are current.
    pub redo: bool,
    /// Go on past results that cannot be right (a registration correction beyond the tolerance),
    /// with a warning, instead of failing.
    pub force: bool,
    /// Only these views (of the complete ones); `None` takes every complete view. A distributed run
    /// processes each view on its own worker this way ([`parts`]), then the scan with all of them.
    pub views: Option<Vec<usize>>,
}

impl Default for ProcessParams {
    fn default() -> Self {
        ProcessParams {
            decode: DecodeParams::default(),
            triangulate: TriangulateParams::default(),
            laser: LaserParams::default(),
            normal_max_jump_mm: 2.0,
            denoise: Some(DenoiseStage::default()),
            crop: CropParams::default(),
            register: RegisterParams::default(),
            fuse: FuseParams::default(),
            close: Some(CloseParams::default()),
            reconstruct: ReconstructParams::default(),
            finish: FinishParams::default(),
            remesh: RemeshParams::default(),
            until: Stage::Remesh,
            redo: false,
            force: false,
            views: None,
        }
    }
}

/// A progress callback: `(stage, done, total)`, called as work completes.
pub trait Progress: FnMut(Stage, usize, usize) {}
impl<F: FnMut(Stage, usize, usize)> Progress for F {}
