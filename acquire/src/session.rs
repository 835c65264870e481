//! A scan session: for each turntable step, move, settle, then capture the program — per pattern,
//! show it and capture; per laser, switch it on, capture, switch it off — write the frames, and
//! rewrite the manifest atomically. A view counts only once its last frame is on disk and the
//! manifest says so, so an interrupted session (Ctrl-C, an unplugged board) loses nothing completed,
//! and `resume` continues from the first incomplete view.
//!
//! Angles are absolute from the platter's position when the board was greeted: the driver zeroes it
//! then, as the reference host does. A Horus board has no homing switch, and after an unplug or a
//! power cycle nothing knows where the platter stands, so a resumed session takes the platter to be
//! back at the scan's starting mark.

use crate::camera::{Camera, CameraError, PatternOutput, Shot};
use crate::turntable::{Turntable, TurntableError};
use rig::scan_folder::{Manifest, Method};
use rig::{Pattern, Rig};
use std::path::Path;
use std::time::{Duration, Instant};

/// What to capture.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// Capture method recorded in the manifest.
    pub method: Method,
    /// The frames of every view, in capture order.
    pub patterns: Vec<Pattern>,
    /// Turntable angle of every view (degrees).
    pub angles: Vec<f64>,
    /// Turning speed (degrees per second) and acceleration (degrees per second²).
    pub speed: f64,
    /// See `speed`.
    pub acceleration: f64,
    /// Pause after each move before the first frame.
    pub settle: Duration,
    /// A simulated capture's noise seed, recorded in the manifest.
    pub seed: Option<u64>,
    /// The pass (from 1): a pass after the first is the object turned over and scanned again into
    /// the same folder, its views appended (`rig::scan_folder`'s passes).
    pub pass: u32,
}

impl Plan {
    /// `views` evenly spaced steps over a full turn with `patterns`, at the reference host's speed
    /// and acceleration (200 °/s, 200 °/s²).
    pub fn full_turn(method: Method, patterns: Vec<Pattern>, views: usize) -> Plan {
        let step = 360.0 / views.max(1) as f64;
        Plan {
            method,
            patterns,
            angles: (0..views).map(|v| v as f64 * step).collect(),
            speed: 200.0,
            acceleration: 200.0,
            settle: Duration::from_millis(200),
            seed: None,
            pass: 1,
        }
    }
}

/// The longest pause after a move: a turntable settles in well under a second; a minute is a typo.
pub const MAX_SETTLE: Duration = Duration::from_secs(60);
/// The most views a plan may have: a view every 0.01° (Horus' finest step is 0.45°).
pub const MAX_VIEWS: usize = 36_000;

impl Plan {
    /// Checks the plan before anything moves or is written: views and frames present and not
    /// absurdly many, angles finite and within [`rig::limits::MAX_ABS_ANGLE_DEG`], speed and
    /// acceleration positive and finite, the settle pause at most [`MAX_SETTLE`]. A refusal names
    /// the option `scan` sets it with.
    pub fn validate(&self) -> Result<(), rig::limits::ParamError> {
        use rig::limits::{MAX_ABS_ANGLE_DEG, ParamError};
        let bad = |option: &'static str, value: String, why: String| Err(ParamError { option, value, why });
        if !(1..=MAX_VIEWS).contains(&self.angles.len()) {
            return bad("--views", self.angles.len().to_string(), format!("a scan has 1 to {MAX_VIEWS} views"));
        }
        if self.patterns.is_empty() {
            return bad("--method", format!("{:?}", self.method), "its capture program has no frames".into());
        }
        if let Some(a) = self.angles.iter().find(|a| !(a.is_finite() && a.abs() <= MAX_ABS_ANGLE_DEG)) {
            return bad("angle_deg", a.to_string(), format!("an angle is finite and within ±{MAX_ABS_ANGLE_DEG}°"));
        }
        for (option, v) in [("speed", self.speed), ("acceleration", self.acceleration)] {
            if !(v > 0.0 && v.is_finite()) {
                return bad(option, v.to_string(), "must be positive and finite".into());
            }
        }
        if !(1..=rig::scan_folder::MAX_PASSES).contains(&self.pass) {
            return bad(
                "--pass",
                self.pass.to_string(),
                format!("passes count from 1 to {}", rig::scan_folder::MAX_PASSES),
            );
        }
        if self.settle > MAX_SETTLE {
            return bad(
                "--settle-ms",
                self.settle.as_millis().to_string(),
                format!("the pause after each move is at most {} ms", MAX_SETTLE.as_millis()),
            );
        }
        Ok(())
    }
}

/// Set by [`request_stop`]: the session stops before its next view.
static STOP: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Asks a running session to stop before its next view (a Ctrl-C handler calls it): the views
/// complete on disk stay, the session returns [`SessionError::Stopped`], and `--resume` continues.
pub fn request_stop() {
    STOP.store(true, std::sync::atomic::Ordering::SeqCst);
}

/// Forgets a stop asked for before a session began (a host that starts sessions one after another,
/// as `scanrig serve` does, so a late request cannot stop the next one at its first view).
pub fn clear_stop() {
    STOP.store(false, std::sync::atomic::Ordering::SeqCst);
}

/// What a session did.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SessionReport {
    /// Views captured by this run.
    pub captured: usize,
    /// Views complete on disk now (of `total`).
    pub complete: usize,
    /// Views in the plan.
    pub total: usize,
    /// The view this run started from (0 for a fresh scan).
    pub started_at: usize,
    /// Wall time (s).
    pub seconds: f64,
}

/// Why a session stopped.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The output folder cannot take this scan.
    #[error("{0}")]
    Folder(String),
    /// The plan asks for what no rig can do ([`Plan::validate`]).
    #[error(transparent)]
    Plan(#[from] rig::limits::ParamError),
    /// Writing frames, the rig or the manifest.
    #[error(transparent)]
    File(#[from] rig::Error),
    /// Another run is writing into the folder.
    #[error(transparent)]
    Busy(#[from] rig::folder_lock::LockError),
    /// The turntable failed at a view.
    #[error(
        "view {view} ({angle_deg}°): {error}; {complete} of {total} views are complete on disk (--resume continues)"
    )]
    Turntable {
        /// The view.
        view: usize,
        /// Its angle.
        angle_deg: f64,
        /// Complete views.
        complete: usize,
        /// Views planned.
        total: usize,
        /// What failed.
        error: TurntableError,
    },
    /// Stopped on request ([`request_stop`], Ctrl-C) before a view.
    #[error("stopped before view {view}: {complete} of {total} views are complete on disk; --resume continues")]
    Stopped {
        /// The first view not captured.
        view: usize,
        /// Complete views.
        complete: usize,
        /// Views planned.
        total: usize,
    },
    /// The camera or projector failed at a view.
    #[error("view {view}: {error}; {complete} of {total} views are complete on disk (--resume continues)")]
    Camera {
        /// The view.
        view: usize,
        /// Complete views.
        complete: usize,
        /// Views planned.
        total: usize,
        /// What failed.
        error: Box<CameraError>,
    },
}

/// The devices of a session.
pub struct Devices<'a> {
    /// The turntable (and its lasers).
    pub turntable: &'a mut dyn Turntable,
    /// The camera.
    pub camera: &'a mut dyn Camera,
    /// The projector's output.
    pub projector: &'a mut dyn PatternOutput,
}

/// Runs `plan` into `out` with `rig` (written beside the frames). `progress(done, total, eta)` after
/// every view.
pub fn run(
    out: &Path,
    rig: &Rig,
    plan: &Plan,
    resume: bool,
    dev: Devices,
    mut progress: impl FnMut(usize, usize, Option<Duration>),
) -> Result<SessionReport, SessionError> {
    run_dyn(out, rig, plan, resume, dev, &mut progress)
}

/// [`run`]'s body, compiled once here rather than into every caller's crate.
fn run_dyn(
    out: &Path,
    rig: &Rig,
    plan: &Plan,
    resume: bool,
    dev: Devices,
    progress: &mut dyn FnMut(usize, usize, Option<Duration>),
) -> Result<SessionReport, SessionError> {
    let start = Instant::now();
    plan.validate()?;
    let (w, h) = dev.camera.size();
    if (w, h) != (rig.camera.width, rig.camera.height) {
        return Err(SessionError::Folder(format!(
            "the camera delivers {w}x{h} frames but the rig's camera is {}x{}",
            rig.camera.width, rig.camera.height
        )));
    }
    std::fs::create_dir_all(out).map_err(|e| rig::Error::io(out, e))?;
    // Two sessions writing one folder would interleave their frames and manifests.
    let _lock = rig::folder_lock::Lock::acquire(out)?;
    let (mut manifest, offset) = open_manifest(out, rig, plan, resume)?;
    let total = manifest.views.len();
    // This pass's views are the manifest's last: capture from its first incomplete one.
    let first = manifest.views[offset..].iter().position(|v| !v.complete).map_or(total, |k| offset + k);
    let complete = |m: &Manifest| m.views.iter().filter(|v| v.complete).count();
    if first == total {
        return Ok(SessionReport { captured: 0, complete: total, total, started_at: total, seconds: 0.0 });
    }
    let lasers = plan
        .patterns
        .iter()
        .filter_map(|p| if let Pattern::Laser { index } = p { Some(index + 1) } else { None })
        .max()
        .unwrap_or(0);
    let Devices { turntable, camera, projector } = dev;
    let tt_err = |view: usize, m: &Manifest, e: TurntableError| SessionError::Turntable {
        view,
        angle_deg: m.views[view].angle_deg,
        complete: complete(m),
        total,
        error: e,
    };
    // The reference host's scan setup: lasers off, motor on, position zero, speed and acceleration.
    let setup = |t: &mut dyn Turntable| -> Result<(), TurntableError> {
        for i in 0..lasers {
            t.laser(i, false)?;
        }
        t.motor(true)?;
        // A pass starts where the platter stands: the object was just placed on it.
        if first == offset {
            t.set_zero()?;
        }
        t.set_speed(plan.speed)?;
        t.set_acceleration(plan.acceleration)
    };
    setup(turntable).map_err(|e| tt_err(first, &manifest, e))?;
    let mut captured = 0;
    for v in first..total {
        if manifest.views[v].complete {
            continue;
        }
        if STOP.swap(false, std::sync::atomic::Ordering::SeqCst) {
            return Err(SessionError::Stopped { view: v, complete: complete(&manifest), total });
        }
        turntable.move_to(manifest.views[v].angle_deg).map_err(|e| tt_err(v, &manifest, e))?;
        std::thread::sleep(plan.settle);
        let dir = out.join(rig::scan_folder::ScanLayout::frames(v));
        std::fs::create_dir_all(&dir).map_err(|e| rig::Error::io(&dir, e))?;
        for (f, frame) in manifest.views[v].frames.clone().iter().enumerate() {
            let shot = Shot { view: v, frame: f, pattern: frame.pattern };
            let cam_err = |m: &Manifest, e: CameraError| SessionError::Camera {
                view: v,
                complete: complete(m),
                total,
                error: Box::new(e),
            };
            if matches!(frame.pattern, Pattern::LaserOff | Pattern::Laser { .. } | Pattern::Texture) {
                // Laser and texture frames are taken with the projector dark (the texture under the
                // work light, every laser off).
                projector.show(None).map_err(|e| cam_err(&manifest, e))?;
            }
            let img = match frame.pattern {
                Pattern::LaserOff | Pattern::Texture => camera.capture(&shot),
                Pattern::Laser { index } => {
                    turntable.laser(index, true).map_err(|e| tt_err(v, &manifest, e))?;
                    let img = camera.capture(&shot);
                    turntable.laser(index, false).map_err(|e| tt_err(v, &manifest, e))?;
                    img
                }
                p => {
                    projector.show(Some(p)).map_err(|e| cam_err(&manifest, e))?;
                    camera.capture(&shot)
                }
            }
            .map_err(|e| cam_err(&manifest, e))?;
            // Frames are plain writes: the view counts only once the manifest says it is complete.
            let path = out.join(&frame.file);
            // Plain writes, but under the one rule of rig::run_files (never over a file the run read).
            rig::run_files::check_write(&path)?;
            std::fs::write(&path, rig::image::png_bytes(&img, true)).map_err(|e| rig::Error::io(&path, e))?;
        }
        projector.show(None).map_err(|e| SessionError::Camera {
            view: v,
            complete: complete(&manifest),
            total,
            error: Box::new(e),
        })?;
        manifest.complete_view(out, v)?;
        captured += 1;
        let per_view = start.elapsed().as_secs_f64() / captured as f64;
        let left = total - complete(&manifest);
        progress(complete(&manifest), total, Some(Duration::from_secs_f64(per_view * left as f64)));
    }
    // Every view journalled: fold the journal into scan.json.
    manifest.write(out)?;
    // Finish: lasers off, motor released.
    let finish = |t: &mut dyn Turntable| -> Result<(), TurntableError> {
        for i in 0..lasers {
            t.laser(i, false)?;
        }
        t.motor(false)
    };
    finish(turntable).map_err(|e| tt_err(total - 1, &manifest, e))?;
    Ok(SessionReport {
        captured,
        complete: complete(&manifest),
        total,
        started_at: first,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// The manifest this session captures into and the index of its pass's first view: a new scan; the
/// same scan resumed; or, for a pass after the first, the folder's scan with this pass's views
/// appended once every earlier pass is complete.
fn open_manifest(out: &Path, rig: &Rig, plan: &Plan, resume: bool) -> Result<(Manifest, usize), SessionError> {
    let fresh = Manifest::fresh(plan.method, "scanrig scan", plan.seed, &plan.angles, &plan.patterns);
    let folder = |msg: String| Err(SessionError::Folder(msg));
    if !out.join("scan.json").is_file() {
        if plan.pass > 1 {
            return folder(format!(
                "{} holds no scan: pass {} continues a scan of the same object; capture pass 1 there first (leave out \
                 --pass)",
                out.display(),
                plan.pass
            ));
        }
        rig.write(&out.join("rig.toml"))?;
        fresh.write(out)?;
        return Ok((fresh, 0));
    }
    let mut old = Manifest::read(out)?;
    // The frames already on disk were taken with the folder's rig: a resumed session with another
    // camera (another resolution, say) would mix two cameras in one scan.
    let recorded = Rig::read(&out.join(&old.rig))?;
    if recorded.camera != rig.camera {
        let (a, b) = (&recorded.camera, &rig.camera);
        return folder(format!(
            "{} was captured with a {}x{} camera (fx {}), this session's is {}x{} (fx {}): resume with the same \
             camera and --resolution",
            out.display(),
            a.width,
            a.height,
            a.fx,
            b.width,
            b.height,
            b.fx
        ));
    }
    let passes = old.passes();
    let offset = old.views.iter().position(|v| v.pass == plan.pass).unwrap_or(old.views.len());
    if plan.pass == passes + 1 {
        // A new pass: every view before it on disk, the same capture program, the views appended.
        if let Some(v) = old.views.iter().position(|v| !v.complete) {
            return folder(format!(
                "{} has view {v} of pass {} incomplete: finish it first (scanrig scan --out {} --resume{})",
                out.display(),
                old.views[v].pass,
                out.display(),
                if old.views[v].pass > 1 { format!(" --pass {}", old.views[v].pass) } else { String::new() }
            ));
        }
        if old.method != plan.method || old.views.first().is_some_and(|v| v.frames != fresh.views[0].frames) {
            return folder(format!(
                "{} was captured with another program (method or frames): a pass must capture what the first did",
                out.display()
            ));
        }
        old.append_pass(plan.pass, &plan.angles, &plan.patterns);
        old.write(out)?;
        return Ok((old, offset));
    }
    if plan.pass != passes {
        let last_done = old.views.iter().all(|v| v.complete);
        let next = match last_done {
            true => format!("the next pass is --pass {}", passes + 1),
            false => format!("pass {passes} is unfinished: continue it with --resume --pass {passes}"),
        };
        let what = match plan.pass < passes {
            true => format!("pass {} is already captured", plan.pass),
            false => format!("--pass {} would leave a gap", plan.pass),
        };
        return folder(format!("{} holds {passes} pass(es): {what}; {next}", out.display()));
    }
    if !resume {
        return folder(format!(
            "{} already holds {}: pass --resume to continue it, or choose another folder",
            out.display(),
            if passes > 1 { format!("pass {passes} of a scan") } else { "a scan".into() }
        ));
    }
    // The pass's views as this plan lays them out, files included: a session writes only the files
    // of the standard layout, never a name a hand-edited manifest put there.
    let mine = &old.views[offset..];
    let same = old.method == fresh.method
        && old.seed == fresh.seed
        && mine.len() == fresh.views.len()
        && mine.iter().zip(&fresh.views).enumerate().all(|(k, (a, b))| {
            let standard = |f: usize, frame: &rig::scan_folder::Frame| {
                frame.file == rig::scan_folder::ScanLayout::frame(offset + k, f, &frame.pattern)
            };
            a.angle_deg == b.angle_deg
                && a.frames.iter().map(|f| f.pattern).eq(b.frames.iter().map(|f| f.pattern))
                && a.frames.iter().enumerate().all(|(f, frame)| standard(f, frame))
        });
    if !same {
        return folder(format!(
            "{} holds a different scan (views, angles, frames or seed differ): it cannot be resumed with this plan",
            out.display()
        ));
    }
    Ok((old, offset))
}
