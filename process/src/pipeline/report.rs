//! `report.json`: what every stage of a `process` run did, field by field on the types below. Each
//! stage's section says whether its output was reused (and if not, why it ran) and carries that
//! stage's own report; a reused output reports what the run that made it reported.

use super::stages::{FuseReport, MergeReport, RegisterReport};
use crate::denoise::DenoiseReport;
use crate::remesh::RemeshReport;
use crate::triangulate::laser_line::LineReport;
use decode::structured_light::DecodeReport;
use rig::Method;
use rig::math::Real;
use serde::{Deserialize, Serialize};

/// The layout version of `report.json` and of every `--json` output.
pub const REPORT_SCHEMA_VERSION: u32 = 2;

/// One stage's part of the report.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Section<T> {
    /// True when the output was current and kept.
    pub reused: bool,
    /// Why the stage ran (absent when reused).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// Seconds this run spent on the stage (reading a reused output included).
    pub seconds: Real,
    /// The process' resident peak during the stage (MB; absent where the system does not say).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub peak_mb: Option<Real>,
    /// The stage's own report (from the run that made the output, when reused).
    pub report: T,
}

/// What triangulation left in a view's grid.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize)]
pub struct GridReport {
    /// Valid cells.
    pub points: usize,
    /// Cells with a grid normal.
    pub normals: usize,
}

/// One laser's line in one view.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize)]
pub struct LaserViewReport {
    /// The laser, 0-based.
    pub laser: usize,
    /// What line extraction found.
    pub line: LineReport,
    /// Points triangulated.
    pub points: usize,
}

/// One view's part of the report.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct ViewReport {
    /// View index.
    pub view: usize,
    /// Turntable angle (degrees).
    pub angle_deg: Real,
    /// Structured light: decoding.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub decode: Option<Section<DecodeReport>>,
    /// Structured light: triangulation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub triangulate: Option<Section<GridReport>>,
    /// Laser: each laser's line.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub lasers: Vec<Section<LaserViewReport>>,
    /// Denoising, where it ran.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub denoise: Option<Section<DenoiseReport>>,
    /// Valid points the view hands on (after denoising where it ran).
    pub points: usize,
    /// True when every output of the view was reused.
    pub reused: bool,
    /// Seconds spent on the view.
    pub seconds: Real,
}

/// What `process_scan` did: the JSON `report.json` holds.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct ProcessReport {
    /// [`REPORT_SCHEMA_VERSION`].
    pub schema_version: u32,
    /// The scanrig version that wrote the report.
    pub scanrig_version: String,
    /// The scan folder.
    pub scan: String,
    /// The capture method, spelled as in `scan.json`.
    pub method: Option<Method>,
    /// Complete views processed.
    pub views: Vec<ViewReport>,
    /// Incomplete views left out (a scan still running, or interrupted).
    pub incomplete_views: Vec<usize>,
    /// Merging (absent where it never ran).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub merge: Option<Section<MergeReport>>,
    /// Registration.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub register: Option<Section<RegisterReport>>,
    /// Fusion.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fuse: Option<Section<FuseReport>>,
    /// Closing the fused cloud's open base and top before reconstruction.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub close: Option<Section<crate::reconstruct::closing::CloseReport>>,
    /// Reconstruction.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reconstruct: Option<Section<crate::pipeline::stages::MeshReport>>,
    /// Remeshing.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub remesh: Option<Section<RemeshReport>>,
    /// Things the user should know that did not stop the run.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
    /// Stages that were asked for but could not run here, with the reason.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub skipped: Vec<String>,
    /// Files written or reused, relative to the output folder.
    pub outputs: Vec<String>,
    /// Seconds in all.
    pub total_seconds: Real,
    /// Wall-clock seconds of the views' stages (several views run at once, so this is less than
    /// the sum of the views' own `seconds`); absent in reports written before it was kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub views_seconds: Option<Real>,
    /// The resident peak while the views were decoded, triangulated and denoised (MB).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub views_peak_mb: Option<Real>,
    /// One row per stage that ran or was reused, in order: its seconds, peak memory and points in and
    /// out (what a benchmark table wants; the sections hold the detail).
    #[serde(default)]
    pub stages: Vec<StageRow>,
}

/// One stage's figures in [`ProcessReport::stages`].
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct StageRow {
    /// The stage.
    pub stage: String,
    /// Seconds this run spent on it.
    pub seconds: Real,
    /// Resident peak during it (MB).
    pub peak_mb: Option<Real>,
    /// Points in (views: none).
    pub points_in: Option<usize>,
    /// Points out (reconstruction: the mesh's triangles; remeshing: its faces).
    pub points_out: Option<usize>,
    /// True when its output was reused.
    pub reused: bool,
}

impl ProcessReport {
    /// The wall time of the views' stages: `views_seconds`, or for reports written before it was kept,
    /// the sum of the views' own seconds (more than was waited, as views run side by side).
    pub fn views_wall_seconds(&self) -> Real {
        self.views_seconds.unwrap_or_else(|| self.views.iter().map(|v| v.seconds).sum())
    }

    /// The [`StageRow`]s of the sections present.
    pub fn stage_rows(&self) -> Vec<StageRow> {
        let mut rows = vec![StageRow {
            stage: "views".into(),
            seconds: self.views_wall_seconds(),
            peak_mb: self.views_peak_mb,
            points_in: None,
            points_out: Some(self.views.iter().map(|v| v.points).sum()),
            reused: !self.views.is_empty() && self.views.iter().all(|v| v.reused),
        }];
        fn row<T>(stage: &str, s: &Section<T>, points_in: Option<usize>, points_out: usize) -> StageRow {
            let (seconds, peak_mb, reused) = (s.seconds, s.peak_mb, s.reused);
            StageRow { stage: stage.into(), seconds, peak_mb, points_in, points_out: Some(points_out), reused }
        }
        let merged = self.merge.as_ref().map(|m| m.report.points);
        if let Some(s) = &self.merge {
            rows.push(row("merge", s, rows[0].points_out, s.report.points));
        }
        if let Some(s) = &self.register {
            rows.push(row("register", s, merged, s.report.points));
        }
        if let Some(s) = &self.fuse {
            rows.push(row("fuse", s, Some(s.report.mean_shift.points_in), s.report.mean_shift.points_out));
        }
        let fused = self.fuse.as_ref().map(|f| f.report.mean_shift.points_out);
        if let Some(s) = &self.close {
            let caps = [s.report.bottom, s.report.top].iter().flatten().map(|c| c.points).sum::<usize>();
            rows.push(row("close", s, fused, fused.unwrap_or(0) + caps));
        }
        if let Some(s) = &self.reconstruct {
            rows.push(row("reconstruct", s, None, s.report.reconstruct.triangles()));
        }
        if let Some(s) = &self.remesh {
            rows.push(row(
                "remesh",
                s,
                self.reconstruct.as_ref().map(|r| r.report.reconstruct.triangles()),
                s.report.quality.faces,
            ));
        }
        rows
    }

    /// Points in the merged cloud (0 before merging).
    pub fn merged_points(&self) -> usize {
        self.merge.as_ref().map_or(0, |m| m.report.points)
    }

    /// Keeps the sections of stages this run did not reach from `old` (an earlier run's report of the
    /// same folder), so a resumed or shorter run never drops them.
    pub fn keep_sections_of(&mut self, old: ProcessReport) {
        if self.views.is_empty() {
            self.views = old.views;
            self.views_seconds = old.views_seconds;
        }
        self.merge = self.merge.take().or(old.merge);
        self.register = self.register.take().or(old.register);
        self.fuse = self.fuse.take().or(old.fuse);
        self.close = self.close.take().or(old.close);
        self.reconstruct = self.reconstruct.take().or(old.reconstruct);
        self.remesh = self.remesh.take().or(old.remesh);
        for o in old.outputs {
            if !self.outputs.contains(&o) {
                self.outputs.push(o);
            }
        }
    }
}
