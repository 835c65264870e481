//! `scanrig scan`: a capture session on a rig — a Horus turntable on a serial port or the virtual
//! board, the simulator's camera or a folder of recorded frames — into a scan folder that resumes;
//! `scanrig turntable`, `scanrig virtual-turntable` and `scanrig camera` for the devices alone.

use crate::cli::{CameraCommand, ScanArgs, TurntableArgs, TurntableCommand, VirtualTurntableArgs};
use crate::virtual_rig::{self, SimCamera, SimProjector, open_port};
use acquire::camera::{Camera, PatternOutput};
use acquire::virtual_horus::{Faults, VirtualBoard};
use acquire::{HorusOptions, HorusTurntable, Turntable};
use anyhow::{Result, bail};
use rig::Pattern;
use sim::Scene;
use std::io::Write;
use std::sync::{Arc, Mutex};
use std::time::Duration;

pub fn scan(args: &ScanArgs) -> Result<()> {
    let cfg = crate::sim_cmd::world_config(&args.world)?;
    let rig = match &args.rig {
        Some(p) => rig::Rig::read(p)?,
        None => virtual_rig::default_rig(&cfg),
    };
    let (method, program) = virtual_rig::capture_program(&rig, &cfg)?;
    let mut plan = acquire::Plan::full_turn(method, program.clone(), cfg.scan.views as usize);
    plan.seed = Some(args.world.seed);
    plan.pass = args.pass;
    plan.settle = Duration::from_millis(args.settle_ms);
    // The session checks it again; here before the turntable is opened.
    plan.validate()?;

    // The turntable: a board on a serial port, or the virtual one.
    let board = match &args.port {
        None => Some(VirtualBoard::start(Faults { unplug_after: args.virtual_unplug_after, ..Faults::default() })?),
        Some(_) => None,
    };
    let port = args.port.clone().unwrap_or_else(|| board.as_ref().expect("virtual").port.clone());
    let opts = HorusOptions {
        motor_settle: if board.is_some() { Duration::ZERO } else { Duration::from_secs(1) },
        ..HorusOptions::default()
    };
    let mut turntable = HorusTurntable::connect(open_port(&port)?, &port, opts)?;

    // The camera: the simulator (watching the virtual board), or recorded frames.
    let size = args.world.size.unwrap_or(cfg.scene.object_size_mm);
    let (object, albedo) = crate::sim_cmd::object_on_platter(
        &cfg,
        args.world.mesh.as_deref(),
        size,
        args.world.up,
        rig::Vector3::zeros(),
    )?;
    // A later pass: the object turned over as `sim --passes` turns it (on its side, upside down …).
    let object = if args.pass > 1 { sim::turned_over(&object, args.pass).0 } else { object };
    let scene = Scene::on_turntable(&cfg, &object, albedo);
    let shown = Arc::new(Mutex::new(None));
    let mut projector: Box<dyn PatternOutput> = match args.projector_monitor {
        Some(m) => open_window(m, &rig)?,
        None => Box::new(SimProjector(shown.clone())),
    };
    // The scan folder is the run's own (a resumed scan reads and rewrites its manifest); a replayed
    // camera's folder is only read.
    rig::run_files::workspace(&args.out)?;
    if let Some(dir) = args.camera.as_deref().filter(|d| d.is_dir()) {
        rig::run_files::input_folder(dir);
    }
    let mut camera: Box<dyn Camera> = match &args.camera {
        Some(dev) if dev.starts_with("/dev/video") => open_v4l2(&dev.display().to_string(), &rig)?,
        Some(dir) if dir.as_os_str() != "sim" => {
            let mut replay = acquire::FolderCamera::open(dir)?;
            // A resumed session replays from the first frame of its pass's first incomplete view
            // (the folder holds this pass's frames).
            if args.resume
                && let Ok(m) = rig::Manifest::read(&args.out)
            {
                let done = m.views.iter().filter(|v| v.pass == args.pass && v.complete).count();
                replay.skip(done * program.len());
            }
            Box::new(replay)
        }
        _ => {
            let Some(b) = &board else {
                bail!("the simulator camera needs the virtual turntable (leave out --port), or give --camera FOLDER");
            };
            Box::new(SimCamera::new(&cfg, &scene, &program, args.world.seed, b.state.clone(), shown.clone()))
        }
    };
    eprintln!(
        "scanning {} views ({} frames each) on {} into {}{}",
        plan.angles.len(),
        program.len(),
        if board.is_some() { format!("the virtual turntable at {port}") } else { port.clone() },
        args.out.display(),
        if args.resume { " (resuming; the platter is taken to be at its starting mark, 0°)" } else { "" }
    );
    let devices =
        acquire::Devices { turntable: &mut turntable, camera: camera.as_mut(), projector: projector.as_mut() };
    // Ctrl-C: the session stops before its next view, keeping every complete view and saying how to
    // resume; a second Ctrl-C ends at once (the manifest only ever lists complete views).
    let presses = std::sync::atomic::AtomicUsize::new(0);
    let resume_with = format!(
        "scanrig scan --out {} --resume{}",
        args.out.display(),
        if args.pass > 1 { format!(" --pass {}", args.pass) } else { String::new() }
    );
    let handler = ctrlc::set_handler(move || {
        if presses.fetch_add(1, std::sync::atomic::Ordering::SeqCst) == 0 {
            eprintln!("\nstopping after this view (Ctrl-C again to quit now); `{resume_with}` continues");
            acquire::session::request_stop();
        } else {
            std::process::exit(130);
        }
    });
    if let Err(e) = handler {
        eprintln!(
            "warning: Ctrl-C will end the scan at once, mid-view ({e}); --resume continues from the last complete view"
        );
    }
    let mut progress = crate::progress::Progress::new();
    let report = acquire::session::run(&args.out, &rig, &plan, args.resume, devices, |done, total, _eta| {
        progress.update("capture", done, total)
    })?;
    progress.finish();
    let mut o = std::io::stdout().lock();
    if args.json {
        serde_json::to_writer_pretty(&mut o, &crate::outputs::versioned(&report))?;
        writeln!(o)?;
        return Ok(());
    }
    writeln!(
        o,
        "{}: {} of {} views complete ({} captured now, from view {}) in {:.1} s",
        args.out.display(),
        report.complete,
        report.total,
        report.captured,
        report.started_at,
        report.seconds
    )?;
    Ok(())
}

pub fn turntable(args: &TurntableArgs) -> Result<()> {
    let board = if args.port.is_none() { Some(VirtualBoard::start(Faults::default())?) } else { None };
    let port = args.port.clone().unwrap_or_else(|| board.as_ref().expect("virtual").port.clone());
    let mut t = HorusTurntable::connect(open_port(&port)?, &port, HorusOptions::default())?;
    match &args.command {
        TurntableCommand::Move { degrees, speed } => {
            t.set_speed(*speed)?;
            t.move_to(*degrees)?;
            println!("{port}: turned to {degrees}°");
        }
        TurntableCommand::Laser { index, state } => {
            t.laser(*index, state.on())?;
            println!("{port}: laser {index} {}", if state.on() { "on" } else { "off" });
        }
        TurntableCommand::Motor { state } => {
            t.motor(state.on())?;
            println!("{port}: motor {}", if state.on() { "on" } else { "off" });
        }
        TurntableCommand::Check => println!("{port}: Horus 0.2 firmware answered"),
    }
    Ok(())
}

pub fn virtual_turntable(args: &VirtualTurntableArgs) -> Result<()> {
    let faults = Faults {
        unplug_after: args.unplug_after,
        drop_reply: args.drop_reply.clone(),
        garble: args.garble.clone(),
        slow: Duration::from_millis(args.slow_ms),
        real_time_moves: !args.instant,
        greeting: args.greeting.clone().unwrap_or_else(|| Faults::default().greeting),
        ..Faults::default()
    };
    let board = VirtualBoard::start(faults)?;
    println!("{}", board.port);
    std::io::stdout().flush()?;
    eprintln!("virtual Horus 0.2 turntable on {} (115200 baud); Ctrl-C stops it", board.port);
    let seconds = args.seconds.unwrap_or(u64::MAX);
    for _ in 0..seconds.saturating_mul(10) {
        std::thread::sleep(Duration::from_millis(100));
    }
    Ok(())
}

#[cfg(feature = "v4l2")]
pub(crate) fn open_v4l2(path: &str, rig: &rig::Rig) -> Result<Box<dyn Camera>> {
    let opts =
        acquire::v4l2_camera::V4l2Options { width: rig.camera.width, height: rig.camera.height, ..Default::default() };
    let cam = acquire::v4l2_camera::V4l2Camera::open(path, &opts)?;
    for r in &cam.refused {
        eprintln!("warning: {path}: {r}");
    }
    Ok(Box::new(cam))
}

#[cfg(not(feature = "v4l2"))]
pub(crate) fn open_v4l2(path: &str, _rig: &rig::Rig) -> Result<Box<dyn Camera>> {
    bail!("{path}: this scanrig was built without V4L2 support; rebuild with `--features v4l2`")
}

/// The projector's fullscreen window on `monitor`, at the size of `rig`'s projector (`scan` and the
/// station's `--projector-monitor`).
#[cfg(feature = "projector-window")]
pub(crate) fn open_window(monitor: usize, rig: &rig::Rig) -> Result<Box<dyn PatternOutput + Send>> {
    let p = rig.projector.as_ref().ok_or_else(|| anyhow::anyhow!("the rig has no projector to show patterns on"))?;
    Ok(Box::new(acquire::projector_window::WindowProjector::open(Some(monitor), p.lens.width, p.lens.height, p.gamma)?))
}

#[cfg(not(feature = "projector-window"))]
pub(crate) fn open_window(_monitor: usize, _rig: &rig::Rig) -> Result<Box<dyn PatternOutput + Send>> {
    bail!("this scanrig was built without the projector window; rebuild with `--features projector-window`")
}

pub fn projector(cmd: &crate::cli::ProjectorCommand) -> Result<()> {
    let crate::cli::ProjectorCommand::Show { pattern, size, monitor, seconds, gamma } = cmd;
    let phase = [
        rig::patterns::PhaseShift { axis: rig::patterns::Axis::Columns, period_px: 16.0, steps: 4 },
        rig::patterns::PhaseShift { axis: rig::patterns::Axis::Rows, period_px: 16.0, steps: 4 },
    ];
    let program = rig::patterns::structured_light_sequence(size.0, size.1, &phase);
    let Some(p) = program.iter().find(|p| p.name() == *pattern) else {
        let names: Vec<String> = program.iter().take(6).map(|p| p.name()).collect();
        bail!("no pattern `{pattern}` for a {}x{} projector (names look like {}, …)", size.0, size.1, names.join(", "));
    };
    show_window(*p, *size, *monitor, *seconds, *gamma)
}

#[cfg(feature = "projector-window")]
fn show_window(p: Pattern, size: (u32, u32), monitor: Option<usize>, seconds: f64, gamma: f64) -> Result<()> {
    let mut w = acquire::projector_window::WindowProjector::open(monitor, size.0, size.1, gamma)?;
    w.show(Some(p))?;
    println!("showing {} at {}x{}", p.name(), size.0, size.1);
    std::io::stdout().flush()?;
    std::thread::sleep(Duration::from_secs_f64(seconds.max(0.0)));
    Ok(())
}

#[cfg(not(feature = "projector-window"))]
fn show_window(_p: Pattern, _size: (u32, u32), _monitor: Option<usize>, _seconds: f64, _gamma: f64) -> Result<()> {
    bail!("this scanrig was built without the projector window; rebuild with `--features projector-window`")
}

#[cfg(feature = "v4l2")]
fn video_devices() -> Vec<String> {
    acquire::v4l2_camera::list_devices().into_iter().map(|(path, name)| format!("{path}  {name}")).collect()
}

#[cfg(not(feature = "v4l2"))]
fn video_devices() -> Vec<String> {
    let mut devices: Vec<String> = std::fs::read_dir("/dev")
        .map(|d| {
            d.filter_map(|e| e.ok())
                .map(|e| e.path().display().to_string())
                .filter(|p| p.starts_with("/dev/video"))
                .collect()
        })
        .unwrap_or_default();
    devices.sort();
    devices
        .into_iter()
        .map(|d| format!("{d}  (this scanrig was built without V4L2 support: `--features v4l2` to capture from it)"))
        .collect()
}

pub fn camera(cmd: &CameraCommand) -> Result<()> {
    match cmd {
        CameraCommand::List => {
            let devices = video_devices();
            if devices.is_empty() {
                println!("no camera found: there is no /dev/video* device on this machine");
            } else {
                for d in devices {
                    println!("{d}");
                }
            }
        }
    }
    Ok(())
}
