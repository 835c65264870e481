//! Running a capture program on the virtual rig and writing a scan folder, exactly as a real session
//! does (`rig::scan_folder`), plus the simulator's `truth/`.

use crate::config::SimConfig;
use crate::geometry::{ViewGeometry, pixel_rays, view_geometry};
use crate::light::PatternLight;
use crate::render::{frame_key, render_frame};
use crate::scene::Scene;
use crate::{Error, truth};
use rayon::prelude::*;
use rig::math::{Isometry3, Real};
use rig::scan_folder::{Frame, Manifest, Method};
use rig::{Pattern, TriMesh};
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

/// What a simulated scan did, for the JSON report.
#[derive(Debug, Clone, Default, Serialize)]
pub struct ScanReport {
    /// Views in the scan.
    pub views: usize,
    /// Views rendered by this run (fewer than `views` when resuming).
    pub views_rendered: usize,
    /// Frames written by this run.
    pub frames_written: usize,
    /// Seconds spent casting rays (per-view geometry).
    pub geometry_seconds: Real,
    /// Seconds spent forming, encoding and writing frames.
    pub frame_seconds: Real,
    /// Seconds in all.
    pub total_seconds: Real,
    /// Frames written per second, everything included.
    pub frames_per_second: Real,
}

impl ScanReport {
    /// Counts a view whose geometry ran from `t0` to `t1` and whose frames were written since.
    pub(crate) fn add_view(&mut self, t0: Instant, t1: Instant, frames: usize) {
        self.geometry_seconds += (t1 - t0).as_secs_f64();
        self.frame_seconds += t1.elapsed().as_secs_f64();
        self.views_rendered += 1;
        self.frames_written += frames;
    }

    /// Closes the report of a run that started at `start`.
    pub(crate) fn finish(mut self, start: Instant) -> Self {
        self.total_seconds = start.elapsed().as_secs_f64();
        self.frames_per_second = self.frames_written as Real / self.total_seconds.max(1e-9);
        self
    }
}

/// The frames of one view of `method` on this rig.
pub fn program(cfg: &SimConfig, method: Method) -> Result<Vec<Pattern>, Error> {
    let mut seq = Vec::new();
    if matches!(method, Method::StructuredLight | Method::Board) {
        match &cfg.rig.projector {
            Some(p) => {
                seq.extend(rig::patterns::structured_light_sequence(p.lens.width, p.lens.height, &cfg.scan.phase))
            }
            None if method == Method::StructuredLight => {
                return Err(Error::Setup("a structured-light scan needs a rig with a [projector]".into()));
            }
            None => seq.push(Pattern::White),
        }
    }
    if matches!(method, Method::Laser | Method::Board) && !cfg.rig.lasers.is_empty() {
        let lasers = rig::patterns::laser_sequence(cfg.rig.lasers.len());
        // A scanner without laser-off frames (FabScanPi) captures the lasers alone; calibration keeps
        // them (the board's background frame).
        let keep_off = cfg.frames.laser_off || method == Method::Board;
        seq.extend(lasers.into_iter().filter(|p| keep_off || *p != Pattern::LaserOff));
    } else if method == Method::Laser {
        return Err(Error::Setup("a laser scan needs a rig with [[lasers]]".into()));
    }
    if cfg.scan.texture && method != Method::Board {
        seq.push(Pattern::Texture);
    }
    Ok(seq)
}

/// The rig a scan folder records: the config's exact rig, with the platter radius the scene has.
pub(crate) fn scan_rig(cfg: &SimConfig) -> rig::Rig {
    let mut r = cfg.rig.clone();
    if cfg.rig.turntable.is_some() && cfg.scene.platter_radius_mm > 0.0 {
        r.platter_radius_mm = Some(cfg.scene.platter_radius_mm);
        // The object stands within its size above the platter: the working volume's height.
        r.working_height_mm = Some(1.25 * cfg.scene.object_size_mm);
    }
    r
}

/// The camera pose of each view: the turntable's, or the identity for a rig without one.
pub fn view_pose(cfg: &SimConfig, angle_deg: Real) -> Isometry3 {
    cfg.rig.turntable.map(|t| t.camera_from_object(angle_deg)).unwrap_or_else(Isometry3::identity)
}

/// One view simulated in memory: its geometry (with truth), the capture program and the frames.
pub struct SimulatedView {
    /// The view's per-pixel geometry and truth.
    pub geometry: ViewGeometry,
    /// What each frame shows, in capture order.
    pub patterns: Vec<Pattern>,
    /// The rendered frames, one per pattern.
    pub frames: Vec<rig::image::Image8>,
}

/// Simulates one view of `method` at turntable angle `angle_deg` without writing anything: for
/// examples, benchmarks and tests that want frames in memory. `view` and `seed` pick the noise as in
/// [`simulate_scan`].
pub fn simulate_view(
    cfg: &SimConfig,
    scene: &Scene,
    method: Method,
    angle_deg: Real,
    seed: u64,
    view: usize,
) -> Result<SimulatedView, Error> {
    let patterns = program(cfg, method)?;
    let lights = lights_for(cfg, &patterns);
    let geometry = view_geometry(scene, cfg, &pixel_rays(&cfg.rig.camera), &view_pose(cfg, angle_deg));
    let frames = lights
        .par_iter()
        .enumerate()
        .map(|(f, light)| render_frame(&geometry, cfg, light, frame_key(seed, view, f)))
        .collect();
    Ok(SimulatedView { geometry, patterns, frames })
}

/// Writes one view's frames (in parallel) and, if asked, its truth.
#[allow(clippy::too_many_arguments)]
pub(crate) fn write_view(
    out: &Path,
    cfg: &SimConfig,
    g: &ViewGeometry,
    lights: &[PatternLight],
    frames: &[Frame],
    opts: ScanOptions,
    v: usize,
    pose: &Isometry3,
) -> Result<(), Error> {
    let dir = out.join(rig::scan_folder::ScanLayout::frames(v));
    std::fs::create_dir_all(&dir).map_err(|e| Error::File(rig::Error::io(&dir, e)))?;
    lights.par_iter().zip(frames).enumerate().try_for_each(|(f, (light, frame))| -> Result<(), Error> {
        let img = render_frame(g, cfg, light, frame_key(opts.seed, v, f));
        // Frames are plain writes: the view only counts once the manifest says it is complete.
        let path = out.join(&frame.file);
        let bytes = match cfg.frames.jpeg_quality {
            0 => rig::image::png_bytes(&img, true),
            q => rig::image::jpeg_bytes(&img, q),
        };
        // Plain writes, but under the one rule of rig::run_files (never over a file the run read).
        rig::run_files::check_write(&path)?;
        std::fs::write(&path, bytes).map_err(|e| Error::File(rig::Error::io(&path, e)))
    })?;
    if opts.truth {
        truth::write_view(
            &out.join(rig::scan_folder::ScanLayout::truth(v)),
            g,
            pose,
            cfg.rig.camera.fx,
            cfg.rig.projector.is_some(),
        )?;
    }
    Ok(())
}

/// The pattern lights of a program, tabulated once per scan (a capture session's simulated camera
/// uses them too).
pub fn lights_for(cfg: &SimConfig, patterns: &[Pattern]) -> Vec<PatternLight> {
    match &cfg.rig.projector {
        Some(p) => {
            patterns.iter().map(|&pat| PatternLight::new(pat, &p.lens, &cfg.projector, |v| p.drive(v))).collect()
        }
        None => patterns.iter().map(|&pat| PatternLight::new(pat, &cfg.rig.camera, &cfg.projector, |v| v)).collect(),
    }
}

/// The manifest of a fresh scan: every view incomplete, frame files named by view and pattern (`.jpg`
/// where the config writes JPEG frames).
pub(crate) fn fresh_manifest(
    cfg: &SimConfig,
    method: Method,
    seed: u64,
    angles: &[Real],
    patterns: &[Pattern],
) -> Manifest {
    let mut m = Manifest::fresh(method, "simulator", Some(seed), angles, patterns);
    if cfg.frames.jpeg_quality > 0 {
        for f in m.views.iter_mut().flat_map(|v| v.frames.iter_mut()) {
            if let Some(stem) = f.file.strip_suffix(".png") {
                f.file = format!("{stem}.jpg");
            }
        }
    }
    m
}

/// Bytes the simulator holds per camera pixel while it renders a view: the pixel rays, every hit
/// twice (as cast, then as the view's geometry), and the frames and truth arrays being written.
/// Measured peak resident memory at 1280 × 1024 divided by the pixels, rounded up (BENCHMARKS.md).
pub const BYTES_PER_PIXEL: u64 = 320;

/// The memory a simulated view at `cfg`'s camera resolution needs (`None` if the size overflows).
pub fn memory_estimate(cfg: &SimConfig) -> Option<u64> {
    let c = &cfg.rig.camera;
    rig::memory::product(&[c.width as u64, c.height as u64, BYTES_PER_PIXEL])
}

/// Options of a simulated scan.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScanOptions {
    /// The capture program.
    pub method: Method,
    /// The noise seed.
    pub seed: u64,
    /// Whether to write `truth/`.
    pub truth: bool,
}

/// One pass of a scan: the object as it lies on the platter this time, and the motion that took
/// the first pass's object there (identity for the first).
pub struct SimPass<'a> {
    /// The scene with the object as it lies.
    pub scene: &'a Scene,
    /// The motion from the first pass's object frame to this pass's.
    pub motion: Isometry3,
}

/// The scenes of a scan in `passes` passes: the object as placed, then turned over for each further
/// pass ([`crate::object::turned_over`]), each with the motion from the first pass's object frame.
pub fn pass_scenes(cfg: &SimConfig, object: &TriMesh, albedo: &crate::Albedo, passes: u32) -> Vec<(Scene, Isometry3)> {
    (1..=passes.max(1))
        .map(|p| match p {
            // The first pass as placed (an --offset kept).
            1 => (Scene::on_turntable(cfg, object, albedo.clone()), Isometry3::identity()),
            _ => {
                let (turned, motion) = crate::object::turned_over(object, p);
                (Scene::on_turntable(cfg, &turned, albedo.clone()), motion)
            }
        })
        .collect()
}

/// Simulates a turntable scan into `out`: frames, manifest (each completed view journalled), the
/// rig, and truth. A folder holding the same scan half done is resumed at its first incomplete view.
/// `progress(done, total)` is called after every view.
pub fn simulate_scan(
    cfg: &SimConfig,
    scene: &Scene,
    object: Option<&TriMesh>,
    opts: ScanOptions,
    out: &Path,
    progress: impl FnMut(usize, usize),
) -> Result<ScanReport, Error> {
    simulate_passes(cfg, &[SimPass { scene, motion: Isometry3::identity() }], object, opts, out, progress)
}

/// [`simulate_scan`] of an object scanned in several passes, turned over between them
/// ([`crate::object::turned_over`]): each pass the config's turntable program, its views numbered on
/// (`rig::scan_folder`'s passes). `object` is the first pass's (the truth's object frame), and
/// `truth/passes.json` records each pass's motion from it.
pub fn simulate_passes(
    cfg: &SimConfig,
    passes: &[SimPass],
    object: Option<&TriMesh>,
    opts: ScanOptions,
    out: &Path,
    mut progress: impl FnMut(usize, usize),
) -> Result<ScanReport, Error> {
    simulate_passes_dyn(cfg, passes, object, opts, out, &mut progress)
}

/// [`simulate_passes`]'s body, compiled once here rather than into every crate that passes it a
/// closure (each test binary, example and the command line compiled the whole renderer again).
fn simulate_passes_dyn(
    cfg: &SimConfig,
    passes: &[SimPass],
    object: Option<&TriMesh>,
    opts: ScanOptions,
    out: &Path,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<ScanReport, Error> {
    let start = Instant::now();
    if !(1..=rig::scan_folder::MAX_PASSES as usize).contains(&passes.len()) {
        return Err(Error::Setup(format!(
            "a scan has 1 to {} passes (an object has six sides to lie on), not {}",
            rig::scan_folder::MAX_PASSES,
            passes.len()
        )));
    }
    let patterns = program(cfg, opts.method)?;
    let per_pass = cfg.scan.views as usize;
    let views = per_pass * passes.len();
    let step = 360.0 / per_pass as Real;
    let mkdir = |p: &Path| std::fs::create_dir_all(p).map_err(|e| Error::File(rig::Error::io(p, e)));
    mkdir(out)?;
    let angles: Vec<Real> = (0..per_pass).map(|v| v as Real * step).collect();
    let mut fresh = fresh_manifest(cfg, opts.method, opts.seed, &angles, &patterns);
    for pass in 2..=passes.len() as u32 {
        fresh.append_pass(pass, &angles, &patterns);
    }
    if cfg.frames.jpeg_quality > 0 {
        for f in fresh.views.iter_mut().flat_map(|v| v.frames.iter_mut()) {
            if let Some(stem) = f.file.strip_suffix(".png") {
                f.file = format!("{stem}.jpg");
            }
        }
    }
    let mut manifest = match Manifest::read(out) {
        Ok(old)
            if old.views.len() == views
                && old.seed == fresh.seed
                && old.method == fresh.method
                && old.passes() == fresh.passes() =>
        {
            old
        }
        Ok(_) => {
            return Err(Error::Setup(format!(
                "{} already holds a different scan; choose another output folder or remove it",
                out.display()
            )));
        }
        Err(_) => {
            scan_rig(cfg).write(&out.join("rig.toml"))?;
            if opts.truth {
                mkdir(&out.join("truth"))?;
                if let Some(m) = object {
                    rig::ply::write_mesh(
                        &out.join("truth/object.ply"),
                        &m.to_poly(),
                        &rig::ply::WriteOptions::default().with_units("mm"),
                    )?;
                }
                if passes.len() > 1 {
                    write_passes_truth(&out.join(PASSES_TRUTH), passes, per_pass)?;
                }
            }
            fresh.write(out)?;
            fresh
        }
    };
    let lights = lights_for(cfg, &patterns);
    let rays = pixel_rays(&cfg.rig.camera);
    let mut report = ScanReport { views, ..Default::default() };
    for v in manifest.first_incomplete().unwrap_or(views)..views {
        if manifest.views[v].complete {
            continue;
        }
        let t0 = Instant::now();
        let pose = view_pose(cfg, manifest.views[v].angle_deg);
        let g = view_geometry(passes[v / per_pass].scene, cfg, &rays, &pose);
        let t1 = Instant::now();
        let frames = manifest.views[v].frames.clone();
        write_view(out, cfg, &g, &lights, &frames, opts, v, &pose)?;
        manifest.complete_view(out, v)?;
        report.add_view(t0, t1, patterns.len());
        progress(v + 1, views);
    }
    manifest.write(out)?;
    Ok(report.finish(start))
}

/// Where a simulated scan of several passes records each pass's motion (inside the scan folder).
pub const PASSES_TRUTH: &str = "truth/passes.json";

/// `truth/passes.json`: per pass (from 1) its views and `turntable_from_object`, the row-major 4 × 4
/// motion taking the first pass's object frame (`truth/object.ply`'s) into this pass's turntable frame.
fn write_passes_truth(path: &Path, passes: &[SimPass], per_pass: usize) -> Result<(), Error> {
    let list: Vec<serde_json::Value> = passes
        .iter()
        .enumerate()
        .map(|(p, pass)| {
            let m = pass.motion.to_homogeneous();
            let rows: Vec<Vec<Real>> = (0..4).map(|r| (0..4).map(|c| m[(r, c)]).collect()).collect();
            serde_json::json!({
                "pass": p + 1,
                "views": [p * per_pass, (p + 1) * per_pass - 1],
                "turntable_from_object": rows,
            })
        })
        .collect();
    let json = serde_json::to_vec_pretty(&serde_json::json!({ "passes": list })).expect("JSON serialises");
    Ok(rig::write_atomic(path, &json)?)
}
