//! The steps of one view: decode → triangulate → denoise (structured light), or one laser line per
//! laser (laser), each through [`Out::step`] with the fingerprint its stage declares
//! ([`super::stages`]).

use super::layout::Layout;
use super::out::{Out, Scope};
use super::records::{Fingerprint, Hash};
use super::report::{GridReport, ViewReport};
use super::stages::{self, LaserFrames, StageError};
use super::{ProcessParams, Stage};
use crate::Error;
use crate::triangulate::Triangulator;
use crate::triangulate::laser_line::RowWindows;
use decode::projector_map::ProjectorMap;
use rayon::prelude::*;
use rig::image::{Image8, ImageTransform};
use rig::math::Real;
use rig::scan_folder::{Manifest, Method};
use rig::{Pattern, RangeGrid, Rig, SparseView};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock, PoisonError};
use std::time::Instant;

/// What a view measured, owned.
pub(super) enum Measured {
    Grid(RangeGrid),
    Sparse(SparseView),
}

/// A view's measurements as handed to the scan's stages: its name, content hash and, where they were
/// made in this run, the measurements themselves (else read when a later stage needs them). Laser
/// views are one per laser, each a sparse view.
pub(super) struct ViewOutput {
    pub view: usize,
    pub angle_deg: Real,
    pub laser: Option<usize>,
    pub name: String,
    pub hash: Hash,
    pub data: Option<Measured>,
}

/// What one view's stages gave, to be added to the scan's report in view order.
pub(super) struct ViewDone {
    pub report: ViewReport,
    /// The stage the view got to, for progress.
    pub stage: Stage,
    pub outputs: Vec<ViewOutput>,
    /// Output names, for the report's list.
    pub names: Vec<String>,
    pub warnings: Vec<String>,
    /// The capture has no texture frame for the view.
    pub untextured: bool,
    /// Lasers whose frame the view lacks.
    pub missing_lasers: Vec<usize>,
}

/// A laser's windows (`None`: the whole image) and what computing them warned of.
type LaserWindows = (Option<RowWindows>, Vec<String>);

/// What every view's stages share.
pub(super) struct ViewCx<'a> {
    pub scan: &'a Path,
    pub rig: &'a Rig,
    pub rig_path: &'a PathBuf,
    pub manifest: &'a Manifest,
    pub params: &'a ProcessParams,
    /// Built by the first view that triangulates.
    pub triangulator: OnceLock<Triangulator>,
    /// Each laser's working-volume windows, computed by the first view that needs them, with what
    /// computing them warned of (said once, in laser order, whichever view it was).
    pub windows: Mutex<BTreeMap<usize, LaserWindows>>,
}

impl ViewCx<'_> {
    /// The triangulator, built outside any lock: building it runs rayon loops, and a thread waiting
    /// in one may take up another view that would then wait on the lock its own stack holds.
    fn triangulator(&self, projector: &rig::Projector) -> &Triangulator {
        if let Some(t) = self.triangulator.get() {
            return t;
        }
        let built = Triangulator::new(&self.rig.camera, projector);
        self.triangulator.get_or_init(|| built)
    }

    /// Laser `k`'s windows ([`stages::laser_windows`]), computed (again, for the same reason)
    /// outside the lock.
    fn windows(&self, k: usize, laser: &rig::Laser) -> Result<Option<RowWindows>, Error> {
        if let Some((w, _)) = self.windows.lock().unwrap_or_else(PoisonError::into_inner).get(&k) {
            return Ok(w.clone());
        }
        let (w, warnings) = stages::laser_windows(self.rig, laser, &self.params.laser, self.params.force)
            .map_err(|source| Error::Stage { stage: Stage::Triangulate, source })?;
        self.windows.lock().unwrap_or_else(PoisonError::into_inner).entry(k).or_insert((w.clone(), warnings));
        Ok(w)
    }
}

/// Reads frames (PNG or JPEG) as grey, what decoding takes, turned as the rig's `[image]` says.
fn load_frames(frames: &[(Pattern, PathBuf)], turn: &ImageTransform) -> Result<Vec<(Pattern, Image8)>, Error> {
    let loaded = frames.par_iter().map(|(p, path)| Ok((*p, turned(rig::image::read_image(path)?.to_gray(), turn))));
    loaded.collect::<Result<Vec<_>, rig::Error>>().map_err(Error::File)
}

/// Reads frames (PNG or JPEG) with their colour, which picks a laser's line out, turned as the rig's
/// `[image]` says.
fn load_colour_frames(frames: &[(Pattern, PathBuf)], turn: &ImageTransform) -> Result<Vec<(Pattern, Image8)>, Error> {
    let loaded = frames.par_iter().map(|(p, path)| Ok((*p, turned(rig::image::read_image(path)?, turn))));
    loaded.collect::<Result<Vec<_>, rig::Error>>().map_err(Error::File)
}

/// A frame as the rig's camera sees it: other scanners' cameras are mounted on their side, and their
/// frames are kept as captured (never converted copies), turned here on reading.
fn turned(frame: Image8, turn: &ImageTransform) -> Image8 {
    if turn.is_identity() { frame } else { frame.transformed(turn) }
}

/// The content hash of every frame, by file name.
fn frame_hashes(frames: &[(Pattern, PathBuf)], scan: &Path) -> Result<BTreeMap<String, Hash>, Error> {
    frames
        .par_iter()
        .map(|(_, path)| {
            // Only a regular file, read no further than its size: a FIFO or a device is refused, not waited on.
            let bytes = rig::input::read_regular(path, None).map_err(Error::File)?;
            let name = path.strip_prefix(scan).unwrap_or(path).display().to_string();
            Ok((name, Hash::of(&bytes)))
        })
        .collect()
}

fn with_inputs(mut fp: Fingerprint, inputs: &BTreeMap<String, Hash>) -> Fingerprint {
    fp.inputs.extend(inputs.iter().map(|(k, v)| (k.clone(), *v)));
    fp
}

fn read_map(path: &Path) -> Result<ProjectorMap, Error> {
    ProjectorMap::from_npy(&rig::npy::read(path)?).ok_or_else(|| Error::NotAProjectorMap { path: path.to_path_buf() })
}

/// A view's colour frame, if the capture took one: hashed for the fingerprints, read (in colour,
/// turned) only when a step needs it.
struct Texture {
    frame: Vec<(Pattern, PathBuf)>,
    hashes: BTreeMap<String, Hash>,
    image: Option<Image8>,
}

impl Texture {
    fn image(&mut self, turn: &ImageTransform) -> Result<Option<&Image8>, Error> {
        if self.image.is_none() && !self.frame.is_empty() {
            self.image = load_colour_frames(&self.frame, turn)?.pop().map(|t| t.1);
        }
        Ok(self.image.as_ref())
    }
}

/// One view's frames, by pattern, with paths inside the scan folder.
struct ViewFrames<'a> {
    v: usize,
    view: &'a rig::scan_folder::View,
    frames: Vec<(Pattern, PathBuf)>,
    texture: Texture,
}

/// One view's stages: decoding and triangulation (structured light) or line extraction (laser),
/// then denoising, each output reused where its record allows.
pub(super) fn run_view(o: &Out, cx: &ViewCx, v: usize) -> Result<ViewDone, Error> {
    let t0 = Instant::now();
    let view = &cx.manifest.views[v];
    let frames: Vec<(Pattern, PathBuf)> = view
        .frames
        .iter()
        .map(|f| Ok((f.pattern, Manifest::inside(cx.scan, &f.file, &format!("views[{v}].frames"))?)))
        .collect::<Result<_, Error>>()?;
    let frame: Vec<(Pattern, PathBuf)> = frames.iter().filter(|f| f.0 == Pattern::Texture).take(1).cloned().collect();
    let texture = Texture { hashes: frame_hashes(&frame, cx.scan)?, frame, image: None };
    let mut made = ViewDone {
        report: ViewReport { view: v, angle_deg: view.angle_deg, reused: true, ..Default::default() },
        stage: Stage::Triangulate.min(cx.params.until),
        outputs: Vec::new(),
        names: Vec::new(),
        warnings: Vec::new(),
        untextured: texture.frame.is_empty(),
        missing_lasers: Vec::new(),
    };
    let mut vf = ViewFrames { v, view, frames, texture };
    match cx.manifest.method {
        Method::StructuredLight => structured_light_view(o, cx, &mut vf, &mut made)?,
        Method::Laser => laser_view(o, cx, &mut vf, &mut made)?,
        Method::Board => unreachable!("refused before the views"),
    }
    made.report.seconds = t0.elapsed().as_secs_f64();
    o.save()?;
    Ok(made)
}

/// Decode → triangulate → denoise, as far as `--until` asks.
fn structured_light_view(o: &Out, cx: &ViewCx, vf: &mut ViewFrames, made: &mut ViewDone) -> Result<(), Error> {
    let projector = cx.rig.projector.as_ref().ok_or_else(|| Error::NoProjector { rig: cx.rig_path.clone() })?;
    let (map_name, map_hash, map) = decode_step(o, cx, vf, made, projector)?;
    if cx.params.until < Stage::Triangulate {
        // Stopping after decoding still reports the view and records its map.
        made.stage = Stage::Decode;
        return Ok(());
    }
    let (mut name, mut hash, mut grid) = triangulate_step(o, cx, vf, made, projector, (&map_name, map_hash, map))?;
    if let (Some(dp), true) = (&cx.params.denoise, cx.params.until >= Stage::Denoise) {
        (name, hash, grid) = denoise_step(o, vf.v, made, dp, (name, hash, grid))?;
    }
    let data = grid.map(Measured::Grid);
    made.outputs.push(ViewOutput { view: vf.v, angle_deg: vf.view.angle_deg, laser: None, name, hash, data });
    Ok(())
}

/// Decodes the view's frames into a projector map (`decode/view_NNN.npy`) and its preview.
fn decode_step(
    o: &Out,
    cx: &ViewCx,
    vf: &ViewFrames,
    made: &mut ViewDone,
    projector: &rig::Projector,
) -> Result<(String, Hash, Option<ProjectorMap>), Error> {
    let (params, rig, v) = (cx.params, cx.rig, vf.v);
    let (pw, ph) = (projector.lens.width, projector.lens.height);
    let fp = stages::decode_fingerprint(&params.decode, (pw, ph), &rig.image);
    let fp = with_inputs(fp, &frame_hashes(&vf.frames, cx.scan)?);
    let name = Layout::decode(v);
    let step = o.step(&[&name], fp, Scope::View, |fp| {
        let imgs = load_frames(&vf.frames, &rig.image)?;
        let refs: Vec<(Pattern, &Image8)> = imgs.iter().map(|(p, i)| (*p, i)).collect();
        // Frame checks name the scan's files; forced, their failures become warnings.
        let names: Vec<String> = vf.view.frames.iter().map(|f| f.file.clone()).collect();
        let dp = decode::structured_light::DecodeParams { force: params.force, ..params.decode };
        let (map, mut dr) = stages::decode(&refs, (pw, ph), &dp).map_err(|source| {
            let source = match source {
                StageError::Decode(e) => StageError::Decode(e.name_frames(&names)),
                other => other,
            };
            Error::View { view: v, stage: Stage::Decode, source }
        })?;
        dr.name_frames(&names);
        let hash = o.put(&name, &rig::npy::to_bytes(&map.to_npy()), fp, &dr)?;
        // Previews are for looking at: fast compression (deflating them was a sixth of a view's time).
        rig::image::write_png(&o.path(&Layout::projector_preview(v)), &map.preview(pw, ph), true)?;
        Ok((map, hash, dr))
    })?;
    made.report.reused &= step.reused();
    if let Some(d) = &step.section {
        // Reused, a map a forced run kept from contradictory frames fails again without --force,
        // as it did when it was made, instead of passing on as a warning.
        if step.reused() && !params.force && d.report.issues.iter().any(|i| i.fatal) {
            let source = StageError::Decode(decode::DecodeError::Contradictory(d.report.issues.clone()));
            return Err(Error::View { view: v, stage: Stage::Decode, source });
        }
        made.warnings.extend(d.report.warnings().into_iter().map(|w| format!("view {v}: {w}")));
    }
    made.report.decode = step.section;
    made.names.push(name.clone());
    Ok((name, step.hash, step.held))
}

/// Triangulates the view's map into a range grid (`views/view_NNN.ply`), coloured from its texture
/// frame, and its depth preview.
fn triangulate_step(
    o: &Out,
    cx: &ViewCx,
    vf: &mut ViewFrames,
    made: &mut ViewDone,
    projector: &rig::Projector,
    map: (&str, Hash, Option<ProjectorMap>),
) -> Result<(String, Hash, Option<RangeGrid>), Error> {
    let (params, rig, v) = (cx.params, cx.rig, vf.v);
    let fp = stages::triangulate_fingerprint(&params.triangulate, params.normal_max_jump_mm, &rig.camera, projector);
    let fp = with_inputs(fp.input(map.0, map.1), &vf.texture.hashes);
    let name = Layout::grid(v);
    let step = o.step(&[&name], fp, Scope::View, |fp| {
        let map = match map.2 {
            Some(m) => m,
            None => read_map(&o.path(map.0))?,
        };
        // Checked before the rig's ray tables are built: a rig of the wrong camera (or an absurd
        // size) must fail here, not allocate.
        let camera = (rig.camera.width, rig.camera.height);
        if (map.width, map.height) != (camera.0 as usize, camera.1 as usize) {
            let source = StageError::MapSize { map: (map.width, map.height), camera };
            return Err(Error::View { view: v, stage: Stage::Triangulate, source });
        }
        let tri = cx.triangulator(projector);
        let (mut grid, gr) = stages::triangulate(&map, tri, &params.triangulate, params.normal_max_jump_mm)
            .map_err(|source| Error::View { view: v, stage: Stage::Triangulate, source })?;
        if let Some(t) = vf.texture.image(&rig.image)? {
            grid.colors = stages::grid_colours(&grid, t);
            if grid.colors.is_none() {
                made.warnings.push(format!(
                    "view {v}: its texture frame is {}x{}, not the camera's {}x{}: the view has no colour",
                    t.width, t.height, grid.width, grid.height
                ));
            }
        }
        let (grid, hash) = o.put_grid(&name, &grid, fp, &gr)?;
        rig::image::write_png(&o.path(&Layout::depth_preview(v)), &crate::preview::depth_image(&grid), true)?;
        Ok((grid, hash, gr))
    })?;
    made.report.reused &= step.reused();
    made.report.points = step.section.as_ref().map_or(0, |s: &super::Section<GridReport>| s.report.points);
    made.report.triangulate = step.section;
    made.names.push(name.clone());
    Ok((name, step.hash, step.held))
}

/// Denoises the view's grid (`denoised/view_NNN.ply`).
fn denoise_step(
    o: &Out,
    v: usize,
    made: &mut ViewDone,
    params: &stages::DenoiseStage,
    grid: (String, Hash, Option<RangeGrid>),
) -> Result<(String, Hash, Option<RangeGrid>), Error> {
    let fp = stages::denoise_fingerprint(params).input(&grid.0, grid.1);
    let name = Layout::denoised(v);
    let step = o.step(&[&name], fp, Scope::View, |fp| {
        let input = match grid.2 {
            Some(g) => g,
            None => o.read_grid(&grid.0)?,
        };
        let (clean, dr) = stages::denoise(std::slice::from_ref(&input), 0, 0, params)
            .map_err(|source| Error::View { view: v, stage: Stage::Denoise, source })?;
        let (clean, hash) = o.put_grid(&name, &clean, fp, &dr)?;
        Ok((clean, hash, dr))
    })?;
    made.report.reused &= step.reused();
    made.report.points = step.section.as_ref().map_or(0, |s| s.report.points);
    made.report.denoise = step.section;
    made.names.push(name.clone());
    Ok((name, step.hash, step.held))
}

/// One laser line per laser whose frame the view has (`views/view_NNN_laserK.ply`).
fn laser_view(o: &Out, cx: &ViewCx, vf: &mut ViewFrames, made: &mut ViewDone) -> Result<(), Error> {
    let (rig, v) = (cx.rig, vf.v);
    if let Some(index) = vf.frames.iter().find_map(|f| match f.0 {
        Pattern::Laser { index } if index >= rig.lasers.len() => Some(index),
        _ => None,
    }) {
        return Err(Error::UnknownLaser { view: v, index, lasers: rig.lasers.len(), rig: cx.rig_path.clone() });
    }
    for k in 0..rig.lasers.len() {
        if !vf.frames.iter().any(|f| f.0 == Pattern::Laser { index: k }) {
            made.missing_lasers.push(k);
            continue;
        }
        laser_step(o, cx, vf, made, k)?;
    }
    Ok(())
}

/// Laser `k`'s line in the view, through [`stages::laser_line`].
fn laser_step(o: &Out, cx: &ViewCx, vf: &mut ViewFrames, made: &mut ViewDone, k: usize) -> Result<(), Error> {
    let (params, rig, v, laser) = (cx.params, cx.rig, vf.v, &cx.rig.lasers[k]);
    // FabScanPi and other scanners record no laser-off frame: the background is then estimated
    // from the laser frame itself.
    let off = vf.frames.iter().find(|f| f.0 == Pattern::LaserOff);
    let on = vf.frames.iter().find(|f| f.0 == Pattern::Laser { index: k }).expect("a view with the laser's frame");
    let pair: Vec<(Pattern, PathBuf)> = off.into_iter().chain([on]).cloned().collect();
    let inputs: BTreeMap<String, Hash> =
        frame_hashes(&pair, cx.scan)?.into_iter().chain(vf.texture.hashes.clone()).collect();
    let fp = with_inputs(stages::laser_line_fingerprint(&params.laser, rig, laser), &inputs);
    let name = Layout::laser_grid(v, k);
    let step = o.step(&[&name], fp, Scope::View, |fp| {
        let imgs = load_colour_frames(&pair, &rig.image)?;
        let windows = cx.windows(k, laser)?;
        let (texture, misfit) = stages::fitting_texture(vf.texture.image(&rig.image)?, &rig.camera);
        if let Some(why) = misfit.map(|w| format!("view {v}: {w}")).filter(|w| !made.warnings.contains(w)) {
            made.warnings.push(why);
        }
        let frames = LaserFrames { on: &imgs[imgs.len() - 1].1, off: off.map(|_| &imgs[0].1), texture };
        let (points, lr) = stages::laser_line(&frames, &rig.camera, (k, laser), windows.as_ref(), &params.laser)
            .map_err(|source| Error::View { view: v, stage: Stage::Triangulate, source })?;
        let (points, hash) = o.put_sparse(&name, &points, fp, &lr)?;
        Ok((points, hash, lr))
    })?;
    made.report.reused &= step.reused();
    if let Some(s) = step.section {
        made.report.points += s.report.points;
        made.report.lasers.push(s);
    }
    made.names.push(name.clone());
    let data = step.held.map(Measured::Sparse);
    made.outputs.push(ViewOutput {
        view: v,
        angle_deg: vf.view.angle_deg,
        laser: Some(k),
        name,
        hash: step.hash,
        data,
    });
    Ok(())
}
