//! `scanrig process`: a scan folder through the stages that exist — decode, triangulate (with grid
//! normals), denoise, place by turntable pose and merge, register, fuse, reconstruct, remesh — each stage's output
//! written atomically beside the scan
//! and skipped when it is already there and newer than its inputs, so an interrupted run resumes.
//!
//! Output folder:
//! ```text
//! decode/view_NNN.npy          structured light: (H, W, 3) projector u, v, confidence (NaN undecoded)
//! views/view_NNN.ply           the view's range grid (camera frame, mm; Stanford range_grid layout)
//! views/view_NNN_laserK.ply    laser scans: one grid per laser
//! denoised/view_NNN.ply        the range grid after non-local denoising (structured light)
//! preview/view_NNN_depth.png   colour depth map; preview/view_NNN_projector.png the decoded map
//! merged.ply                   all views in the object frame, cropped to the platter cylinder, with
//!                              normals, confidence and view_id per point
//! registered.ply               the views again, placed by multi-view ICP from their turntable poses
//! registered.poses.json        each view's refined pose and how far it moved
//! fused.ply                    mean-shift fusion of the registered (else merged) cloud: outliers
//!                              removed, noise averaged out, oriented normals
//! mesh.ply                     watertight surface of the fused cloud (global FFT, ch. 5)
//! quads.obj                    quad remesh of mesh.ply along a harmonic field's streamlines (ch. 6)
//! report.json                  what every stage did (the `ProcessReport` below)
//! ```

use crate::Error;
use crate::grid_normals::estimate_normals;
use crate::laser_line::{LaserParams, LineReport, detect_line, triangulate_line};
use crate::placement::{CropParams, merge, place_view};
use crate::projector_map::ProjectorMap;
use crate::structured_light::{DecodeParams, DecodeReport, decode_view};
use crate::triangulate::{TriangulateParams, Triangulator};
use rayon::prelude::*;
use rig::image::Image8;
use rig::math::Real;
use rig::ply::WriteOptions;
use rig::scan_folder::{Manifest, Method};
use rig::{Pattern, PointCloud, RangeGrid, Rig};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The stages, in order; `--until` stops after one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
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

/// The settings of the remesh stage (the rest of [`crate::remesh::RemeshParams`] at its defaults).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RemeshSettings {
    /// Streamline spacing, mm; `None`: the default fraction of the mesh's diagonal.
    pub spacing: Option<Real>,
    /// Creases sharper than this (degrees) are followed; `None`: none.
    pub feature_angle: Option<Real>,
}

impl Default for RemeshSettings {
    fn default() -> Self {
        let d = crate::remesh::RemeshParams::default();
        RemeshSettings { spacing: d.spacing, feature_angle: d.feature_angle }
    }
}

/// Everything `process_scan` can be told.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ProcessParams {
    /// Structured-light decoding.
    pub decode: DecodeParams,
    /// Triangulation.
    pub triangulate: TriangulateParams,
    /// Laser-line extraction.
    pub laser: LaserParams,
    /// The object cylinder; a `None` radius takes the rig's platter radius.
    pub crop: CropParams,
    /// Per-view denoising of structured-light grids; `None` skips the stage.
    pub denoise: Option<crate::denoise::DenoiseParams>,
    /// Grid neighbours farther apart than this (mm) are not used for normals.
    pub normal_max_jump_mm: Real,
    /// Multi-view registration.
    pub register: crate::multiview::MultiViewParams,
    /// Mean-shift fusion.
    pub fuse: crate::mean_shift::MeanShiftParams,
    /// Reconstruction.
    pub reconstruct: crate::reconstruct::global_fft::FftParams,
    /// Quad remeshing.
    pub remesh: RemeshSettings,
    /// The last stage to run.
    pub until: Stage,
    /// Redo stages whose outputs are current.
    pub force: bool,
}

impl Default for ProcessParams {
    fn default() -> Self {
        ProcessParams {
            decode: DecodeParams::default(),
            triangulate: TriangulateParams::default(),
            laser: LaserParams::default(),
            crop: CropParams::default(),
            denoise: Some(crate::denoise::DenoiseParams::default()),
            normal_max_jump_mm: 2.0,
            register: crate::multiview::MultiViewParams::default(),
            fuse: crate::mean_shift::MeanShiftParams::default(),
            reconstruct: crate::reconstruct::global_fft::FftParams::default(),
            remesh: RemeshSettings::default(),
            until: Stage::Remesh,
            force: false,
        }
    }
}

/// One view's part of the report.
#[derive(Debug, Clone, Default, Serialize)]
pub struct ViewReport {
    /// View index.
    pub view: usize,
    /// Turntable angle (degrees).
    pub angle_deg: Real,
    /// Structured light: what decoding found.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub decode: Option<DecodeReport>,
    /// Laser: what line extraction found, per laser.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub lines: Vec<LineReport>,
    /// Valid cells of the view's range grid(s).
    pub points: usize,
    /// Cells with a grid normal.
    pub normals: usize,
    /// What denoising did, where it ran.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub denoise: Option<crate::denoise::DenoiseReport>,
    /// Points kept in the object cylinder.
    pub placed: usize,
    /// Whether the view's outputs were current and reused.
    pub reused: bool,
    /// Milliseconds spent on this view.
    pub milliseconds: Real,
}

/// What registration did.
#[derive(Debug, Clone, Default, Serialize)]
pub struct RegisterSummary {
    /// Views registered.
    pub views: usize,
    /// Whether `registered.ply` was current and reused.
    pub reused: bool,
    /// The largest rotation of a view away from its turntable pose (degrees).
    pub max_rotation_change_deg: Real,
    /// The largest movement of a view's centroid away from its turntable pose (mm).
    pub max_shift_mm: Real,
    /// Points in the registered cloud.
    pub points: usize,
    /// Seconds spent.
    pub seconds: Real,
}

/// What `process_scan` did: the JSON `report.json` holds.
#[derive(Debug, Clone, Default, Serialize)]
pub struct ProcessReport {
    /// The scan folder.
    pub scan: String,
    /// The capture method.
    pub method: String,
    /// Complete views processed.
    pub views: Vec<ViewReport>,
    /// Incomplete views left out (a scan still running, or interrupted).
    pub incomplete_views: Vec<usize>,
    /// Points in the merged cloud.
    pub merged_points: usize,
    /// What registration did (absent where it did not run).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub register: Option<RegisterSummary>,
    /// What fusion did (absent where it did not run).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fuse: Option<crate::mean_shift::MeanShiftReport>,
    /// What reconstruction did (absent where it did not run).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reconstruct: Option<crate::reconstruct::global_fft::FftReport>,
    /// What remeshing did (absent where it did not run).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub remesh: Option<crate::remesh::RemeshReport>,
    /// Stages that were asked for but could not run here, with the reason.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub skipped: Vec<String>,
    /// Files written or reused, relative to the output folder.
    pub outputs: Vec<String>,
    /// Seconds in all.
    pub total_seconds: Real,
}

/// True when `output` exists and is at least as new as every input.
fn is_current(output: &Path, inputs: &[PathBuf]) -> bool {
    let modified = |p: &Path| std::fs::metadata(p).and_then(|m| m.modified()).ok();
    let Some(out) = modified(output) else { return false };
    inputs.iter().all(|i| modified(i).is_some_and(|t| t <= out))
}

fn load_frames(frames: &[(Pattern, PathBuf)]) -> Result<Vec<(Pattern, Image8)>, Error> {
    let loaded = frames.par_iter().map(|(p, path)| Ok((*p, rig::image::read_png(path)?.to_gray())));
    loaded.collect::<Result<Vec<_>, rig::Error>>().map_err(Error::File)
}

fn mkdir(p: &Path) -> Result<(), Error> {
    std::fs::create_dir_all(p).map_err(|e| Error::File(rig::Error::io(p, e)))
}

/// Runs the stages on the scan folder `scan`, writing into `out`. `progress(stage, done, total)`.
pub fn process_scan(
    scan: &Path,
    out: &Path,
    params: &ProcessParams,
    mut progress: impl FnMut(&str, usize, usize),
) -> Result<ProcessReport, Error> {
    let start = Instant::now();
    let manifest = Manifest::read(scan)?;
    let rig_path = scan.join(&manifest.rig);
    let rig = Rig::read(&rig_path)?;
    for d in ["decode", "views", "denoised", "preview"] {
        mkdir(&out.join(d))?;
    }
    let mut report = ProcessReport {
        scan: scan.display().to_string(),
        method: format!("{:?}", manifest.method),
        ..Default::default()
    };
    let write_opts = WriteOptions::default().with_units("mm");
    let mut grids: Vec<(usize, Real, RangeGrid)> = Vec::new();
    let mut triangulator: Option<Triangulator> = None;
    let complete: Vec<usize> = (0..manifest.views.len()).filter(|&v| manifest.views[v].complete).collect();
    report.incomplete_views = (0..manifest.views.len()).filter(|v| !complete.contains(v)).collect();
    for (done, &v) in complete.iter().enumerate() {
        let t0 = Instant::now();
        let view = &manifest.views[v];
        let frames: Vec<(Pattern, PathBuf)> =
            view.frames.iter().map(|f| (f.pattern, Manifest::frame_path(scan, f))).collect();
        let mut inputs: Vec<PathBuf> = frames.iter().map(|f| f.1.clone()).collect();
        inputs.push(rig_path.clone());
        let mut vr = ViewReport { view: v, angle_deg: view.angle_deg, ..Default::default() };
        match manifest.method {
            Method::StructuredLight => {
                let projector = rig.projector.as_ref().ok_or_else(|| {
                    Error::Setup(format!(
                        "{}: a structured-light scan needs a rig with a projector",
                        rig_path.display()
                    ))
                })?;
                let decode_path = out.join(format!("decode/view_{v:03}.npy"));
                let grid_path = out.join(format!("views/view_{v:03}.ply"));
                report.outputs.push(format!("decode/view_{v:03}.npy"));
                report.outputs.push(format!("views/view_{v:03}.ply"));
                if !params.force && is_current(&grid_path, &inputs) && (params.until >= Stage::Triangulate) {
                    let grid = rig::ply::read_range_grid(&grid_path)?;
                    vr.points = grid.valid_count();
                    vr.reused = true;
                    grids.push((v, view.angle_deg, grid));
                } else {
                    let map = if !params.force && is_current(&decode_path, &inputs) {
                        vr.reused = true;
                        ProjectorMap::from_npy(&rig::npy::read(&decode_path)?)
                            .ok_or_else(|| Error::Setup(format!("{}: not a projector map", decode_path.display())))?
                    } else {
                        let imgs = load_frames(&frames)?;
                        let refs: Vec<(Pattern, &Image8)> = imgs.iter().map(|(p, i)| (*p, i)).collect();
                        let (map, dr) = decode_view(&refs, projector.lens.width, projector.lens.height, &params.decode)
                            .map_err(|source| Error::Decode { view: v, source })?;
                        vr.decode = Some(dr);
                        rig::npy::write(&decode_path, &map.to_npy())?;
                        let preview = map.preview(projector.lens.width, projector.lens.height);
                        rig::image::write_png(
                            &out.join(format!("preview/view_{v:03}_projector.png")),
                            &preview,
                            false,
                        )?;
                        map
                    };
                    if params.until >= Stage::Triangulate {
                        let tri = triangulator.get_or_insert_with(|| Triangulator::new(&rig.camera, projector));
                        let mut grid = tri.triangulate(&map, &params.triangulate);
                        vr.normals = estimate_normals(&mut grid, params.normal_max_jump_mm);
                        vr.points = grid.valid_count();
                        rig::ply::write_range_grid(&grid_path, &grid, &write_opts)?;
                        rig::image::write_png(
                            &out.join(format!("preview/view_{v:03}_depth.png")),
                            &crate::preview::depth_image(&grid),
                            false,
                        )?;
                        grids.push((v, view.angle_deg, grid));
                    }
                }
            }
            Method::Laser => {
                let off = frames
                    .iter()
                    .find(|f| f.0 == Pattern::LaserOff)
                    .ok_or_else(|| Error::Setup(format!("view {v} has no laser-off frame")))?;
                for (k, laser) in rig.lasers.iter().enumerate() {
                    let Some(on) = frames.iter().find(|f| f.0 == Pattern::Laser { index: k }) else { continue };
                    let grid_path = out.join(format!("views/view_{v:03}_laser{k}.ply"));
                    report.outputs.push(format!("views/view_{v:03}_laser{k}.ply"));
                    let grid = if !params.force && is_current(&grid_path, &inputs) {
                        vr.reused = true;
                        rig::ply::read_range_grid(&grid_path)?
                    } else {
                        let imgs = load_frames(&[off.clone(), on.clone()])?;
                        let (peaks, lr) = detect_line(&imgs[1].1, &imgs[0].1, &params.laser);
                        vr.lines.push(lr);
                        let grid = triangulate_line(&peaks, &rig.camera, &laser.plane);
                        rig::ply::write_range_grid(&grid_path, &grid, &write_opts)?;
                        grid
                    };
                    vr.points += grid.valid_count();
                    grids.push((v, view.angle_deg, grid));
                }
            }
            Method::Board => {
                return Err(Error::Setup("a board capture is for `scanrig calibrate`, not `scanrig process`".into()));
            }
        }
        if let (Method::StructuredLight, Some(dp), true) =
            (manifest.method, &params.denoise, params.until >= Stage::Denoise)
            && let Some((_, _, grid)) = grids.last_mut().filter(|g| g.0 == v)
        {
            let path = out.join(format!("denoised/view_{v:03}.ply"));
            report.outputs.push(format!("denoised/view_{v:03}.ply"));
            let grid_path = out.join(format!("views/view_{v:03}.ply"));
            *grid = if !params.force && is_current(&path, &[grid_path]) {
                rig::ply::read_range_grid(&path)?
            } else {
                let (mut clean, dr) =
                    crate::denoise::denoise(grid, dp).map_err(|e| Error::Setup(format!("view {v}: {e}")))?;
                estimate_normals(&mut clean, params.normal_max_jump_mm);
                rig::ply::write_range_grid(&path, &clean, &write_opts)?;
                vr.denoise = Some(dr);
                clean
            };
        }
        vr.milliseconds = t0.elapsed().as_secs_f64() * 1e3;
        report.views.push(vr);
        progress("views", done + 1, complete.len());
    }
    let crop = CropParams { radius_mm: params.crop.radius_mm.or(rig.platter_radius_mm), ..params.crop };
    let view_files: Vec<PathBuf> = report
        .outputs
        .iter()
        .filter(|o| o.starts_with("views/") || o.starts_with("denoised/"))
        .map(|o| out.join(o))
        .collect();
    let mut cloud: Option<(PointCloud, PathBuf)> = None;
    if params.until >= Stage::Merge && !grids.is_empty() {
        let path = out.join("merged.ply");
        let merged = if !params.force && is_current(&path, &view_files) {
            rig::read_cloud(&path)?
        } else {
            let placed: Vec<(usize, PointCloud)> = grids
                .par_iter()
                .map(|(v, angle, grid)| {
                    let pose =
                        rig.turntable.map(|t| t.object_from_camera(*angle)).unwrap_or_else(rig::Isometry3::identity);
                    (*v, place_view(grid, &pose, &crop, *v as u32))
                })
                .collect();
            for (v, cloud) in &placed {
                if let Some(r) = report.views.iter_mut().find(|r| r.view == *v) {
                    r.placed += cloud.len();
                }
            }
            let merged = merge(placed.into_iter().map(|p| p.1).collect());
            rig::ply::write_cloud(&path, &merged, &write_opts)?;
            merged
        };
        report.merged_points = merged.len();
        report.outputs.push("merged.ply".into());
        progress("merge", 1, 1);
        cloud = Some((merged, path));
    }
    if params.until >= Stage::Register && cloud.is_some() {
        match (manifest.method, rig.turntable) {
            (Method::StructuredLight, Some(axis)) if grids.len() >= 2 => {
                let t = Instant::now();
                let (path, poses_path) = (out.join("registered.ply"), out.join("registered.poses.json"));
                let merged_path = out.join("merged.ply");
                let mut summary = RegisterSummary { views: grids.len(), ..Default::default() };
                let registered = if !params.force && is_current(&path, &[merged_path]) && poses_path.is_file() {
                    summary.reused = true;
                    rig::read_cloud(&path)?
                } else {
                    let refs: Vec<(usize, Real, &RangeGrid)> = grids.iter().map(|(v, a, g)| (*v, *a, g)).collect();
                    let (registered, poses, _) =
                        crate::register_scan::register_grids(&refs, &axis, &crop, &params.register)?;
                    summary.max_rotation_change_deg = poses.iter().map(|p| p.rotation_change_deg).fold(0.0, Real::max);
                    summary.max_shift_mm = poses.iter().map(|p| p.shift_mm).fold(0.0, Real::max);
                    let json = serde_json::to_vec_pretty(&poses).expect("poses serialise");
                    rig::write_atomic(&poses_path, &json)?;
                    rig::ply::write_cloud(&path, &registered, &write_opts)?;
                    registered
                };
                summary.points = registered.len();
                summary.seconds = t.elapsed().as_secs_f64();
                report.register = Some(summary);
                report.outputs.push("registered.ply".into());
                report.outputs.push("registered.poses.json".into());
                progress("register", 1, 1);
                cloud = Some((registered, path));
            }
            (Method::StructuredLight, Some(_)) => report.skipped.push("register: needs at least two views".into()),
            (Method::StructuredLight, None) => {
                report.skipped.push("register: the rig has no [turntable] to start from".into())
            }
            _ => report
                .skipped
                .push("register: laser views are single lines per laser, without the surface normals ICP needs".into()),
        }
    }
    if params.until >= Stage::Fuse
        && let Some((input, input_path)) = cloud
    {
        let path = out.join("fused.ply");
        // Kept in memory when computed here, so reconstruction does not read it straight back.
        let mut fused = None;
        if params.force || !is_current(&path, &[input_path]) {
            let input = with_sensor_normals(input, &grids, &rig);
            let result = crate::mean_shift::mean_shift(&input, &params.fuse);
            rig::ply::write_cloud(&path, &result.cloud, &write_opts)?;
            report.fuse = Some(result.report);
            fused = Some(result.cloud);
        }
        report.outputs.push("fused.ply".into());
        progress("fuse", 1, 1);
        if params.until >= Stage::Reconstruct {
            let mesh_path = out.join("mesh.ply");
            let mut mesh = None;
            if params.force || !is_current(&mesh_path, std::slice::from_ref(&path)) {
                let fused = match fused {
                    Some(cloud) => cloud,
                    None => rig::read_cloud(&path)?,
                };
                let (m, r) = crate::reconstruct::global_fft::reconstruct_fft(&fused, &params.reconstruct)
                    .map_err(|e| Error::Setup(format!("{}: {e}", path.display())))?;
                rig::ply::write_mesh(&mesh_path, &m.to_poly(), &write_opts)?;
                report.reconstruct = Some(r);
                mesh = Some(m);
            }
            report.outputs.push("mesh.ply".into());
            progress("reconstruct", 1, 1);
            if params.until >= Stage::Remesh {
                let quads_path = out.join("quads.obj");
                if params.force || !is_current(&quads_path, std::slice::from_ref(&mesh_path)) {
                    let mesh = match mesh {
                        Some(m) => m,
                        None => rig::read_mesh(&mesh_path)?.triangulate(),
                    };
                    let remesh_params = crate::remesh::RemeshParams {
                        spacing: params.remesh.spacing,
                        feature_angle: params.remesh.feature_angle,
                        ..Default::default()
                    };
                    let (quads, r) = crate::remesh::remesh(&mesh, &remesh_params)
                        .map_err(|e| Error::Setup(format!("{}: {e}", mesh_path.display())))?;
                    rig::obj::write_mesh(&quads_path, &quads)?;
                    report.remesh = Some(r);
                }
                report.outputs.push("quads.obj".into());
                progress("remesh", 1, 1);
            }
        }
    }
    report.total_seconds = start.elapsed().as_secs_f64();
    report.outputs.push("report.json".into());
    let json = serde_json::to_vec_pretty(&report).expect("reports serialise");
    rig::write_atomic(&out.join("report.json"), &json)?;
    Ok(report)
}

/// The cloud with normals: its own where every point has one, else PCA normals turned toward the
/// camera of each point's view (line of sight from the turntable pose), as laser clouds need.
///
/// 48 neighbours, because laser samples are dense along each line and sparse across lines (a 2° step
/// puts lines 1.7 mm apart at 50 mm from the axis, rows 0.3 mm apart): a dozen neighbours lie on one
/// line, and their "plane" turns freely about it (the laser test's normals were then no better than
/// random).
fn with_sensor_normals(mut cloud: PointCloud, grids: &[(usize, Real, RangeGrid)], rig: &Rig) -> PointCloud {
    let usable = cloud.normals.as_ref().is_some_and(|n| n.iter().all(|n| n.norm_squared() > 0.5));
    if usable || cloud.is_empty() {
        return cloud;
    }
    // Each view's camera centre in the object frame, from its turntable pose.
    let centres: std::collections::HashMap<u32, rig::Point3> = grids
        .iter()
        .map(|(v, angle, _)| {
            let pose = rig.turntable.map(|t| t.object_from_camera(*angle)).unwrap_or_else(rig::Isometry3::identity);
            (*v as u32, pose * rig::Point3::origin())
        })
        .collect();
    let tree = crate::normals::PointTree::new(&cloud.positions);
    let normals = crate::normals::pca_normals(&cloud.positions, &tree, 48, |i| {
        let v = cloud.view_id.as_ref().map_or(0, |v| v[i]);
        centres.get(&v).map_or(rig::Vector3::z(), |c| c - cloud.positions[i])
    });
    cloud.normals = Some(normals);
    cloud
}
