//! `scanrig sim`: a simulated scan into a scan folder.

use crate::cli::{SimArgs, SimLayout, SimMethod, SimWorld, Up};
use anyhow::{Context, Result, bail};
use rig::Method;
use sim::{Albedo, SimConfig, UpAxis};
use std::io::Write;

/// A built-in config by name (`sim::config::BUILTIN`), else a TOML file.
pub fn load_config(name: &str) -> Result<SimConfig> {
    Ok(match SimConfig::builtin(name) {
        Some(cfg) => cfg,
        None => SimConfig::read(std::path::Path::new(name))?,
    })
}

/// The config the world arguments name: its resolution and view count applied.
pub fn world_config(world: &SimWorld) -> Result<SimConfig> {
    let mut cfg = load_config(&world.config)?;
    if let Some((w, h)) = world.resolution {
        cfg = cfg.with_camera_resolution(w, h);
    }
    let (w, h) = (cfg.rig.camera.width, cfg.rig.camera.height);
    rig::memory::check(
        sim::scan::memory_estimate(&cfg),
        &format!("simulating {w}x{h} views"),
        "choose a smaller --resolution",
    )?;
    if let Some(v) = world.views {
        // Each view is a turn of the table and a set of frames on disk: more than a tenth-degree step
        // is a typo (and --views 100000 wrote a 1.2 GB manifest).
        if !(1..=3600).contains(&v) {
            bail!("--views must be 1 to 3600, got {v}");
        }
        cfg.scan.views = v;
    }
    Ok(cfg)
}

pub fn run(args: &SimArgs) -> Result<()> {
    let mut cfg = world_config(&args.world)?;
    if args.noiseless {
        cfg.sensor.full_well_e = 0.0;
    }
    let method = match args.method {
        Some(SimMethod::StructuredLight) => Method::StructuredLight,
        Some(SimMethod::Laser) => Method::Laser,
        None if cfg.rig.projector.is_some() => Method::StructuredLight,
        None => Method::Laser,
    };
    match args.layout {
        Some(SimLayout::Fabscan) if args.board.is_some() || method != Method::Laser => {
            bail!(
                "--layout fabscan writes laser scans (FabScanPi is a laser scanner): use --config laser or --method laser"
            )
        }
        Some(SimLayout::Opencv) if args.board.is_none() || cfg.rig.projector.is_none() => {
            bail!(
                "--layout opencv writes board captures of a projector's Gray codes: use --board with a structured-light rig"
            )
        }
        _ => {}
    }
    if !(1..=rig::scan_folder::MAX_PASSES).contains(&args.passes) {
        bail!("--passes must be 1 to {}, got {}", rig::scan_folder::MAX_PASSES, args.passes);
    }
    if args.passes > 1 && (args.board.is_some() || args.layout.is_some()) {
        bail!("--passes scans an object several times; it does not go with --board or --layout");
    }
    if let Some(b) = args.board {
        let board = match b.charuco {
            None => sim::Board::chessboard(b.cols, b.rows, args.square),
            Some((square_mm, m)) => {
                let dict = calib::charuco::dictionary(m.dictionary).expect("a dictionary the parser checked");
                let (bits, codes) = calib::charuco::marker_bits(&dict);
                let markers = Some(sim::Markers { size_mm: m.marker_mm, bits, codes });
                sim::Board { cols: b.cols, rows: b.rows, square_mm, markers }
            }
        };
        return run_board(args, &cfg, board);
    }
    let size = args.world.size.unwrap_or(cfg.scene.object_size_mm);
    let offset = rig::Vector3::from(args.offset.unwrap_or([0.0; 3]));
    let (object, albedo) = object_on_platter(&cfg, args.world.mesh.as_deref(), size, args.world.up, offset)?;
    // Each pass the object as it lies then: turned over, standing on the platter again.
    let scenes = sim::scan::pass_scenes(&cfg, &object, &albedo, args.passes);
    let passes: Vec<sim::SimPass> =
        scenes.iter().map(|(scene, motion)| sim::SimPass { scene, motion: *motion }).collect();
    let opts = sim::ScanOptions { method, seed: args.world.seed, truth: !args.no_truth };
    eprintln!(
        "simulating {}{} views of {} ({} triangles) at {}×{} into {}",
        if args.passes > 1 { format!("{} passes of ", args.passes) } else { String::new() },
        cfg.scan.views,
        args.world.mesh.as_ref().map(|p| p.display().to_string()).unwrap_or_else(|| "the built-in vase".into()),
        object.faces.len(),
        cfg.rig.camera.width,
        cfg.rig.camera.height,
        args.out.display()
    );
    // The scan folder is the run's own: a second run resumes it, reading and rewriting its manifest.
    rig::run_files::workspace(&args.out)?;
    let mut progress = crate::progress::Progress::new();
    let report = sim::simulate_passes(&cfg, &passes, Some(&object), opts, &args.out, |done, total| {
        progress.update("simulate", done, total)
    })
    .with_context(|| format!("simulating into {}", args.out.display()))?;
    print_report(args, &report)?;
    if args.layout == Some(SimLayout::Fabscan) {
        // FabScanPi's own turn: its camera is mounted on its side (rotate and hflip true).
        let turn = rig::image::ImageTransform { transpose: true, hflip: true, vflip: false };
        let dir = args.out.join("fabscan");
        rig::fabscan_scan::write_layout(&args.out, &dir, "sim", turn)
            .with_context(|| format!("writing {} in FabScanPi's layout", dir.display()))?;
        eprintln!(
            "FabScanPi layout: {} and {} (import with `scanrig import fabscan {} --step-deg {} -o SCAN`)",
            dir.join("config.json").display(),
            dir.join("sim").display(),
            dir.join("sim").display(),
            360.0 / report.views as f64
        );
    }
    Ok(())
}

fn run_board(args: &SimArgs, cfg: &SimConfig, board: sim::Board) -> Result<()> {
    if board.cols < 2 || board.rows < 2 || args.square.is_nan() || args.square <= 0.0 {
        bail!("--board needs at least 2x2 inner corners and a positive --square");
    }
    // Held poses unless only a sweep was asked for; both when both were.
    let held = match (args.poses, &args.sweep) {
        (Some(n), _) => n,
        (None, Some(_)) => 0,
        (None, None) => 15,
    };
    if held > 3600 {
        bail!("--poses must be at most 3600, got {held}");
    }
    let distance = cfg.rig.turntable.map(|t| t.point.coords.norm()).unwrap_or(400.0);
    let poses = sim::BoardPoses {
        held: sim::board::default_fixed_poses(&board, distance, held),
        sweep: args.sweep.as_ref().map(|s| s.0.clone()).unwrap_or_default(),
        covers: Vec::new(),
    };
    let opts = sim::ScanOptions { method: Method::Board, seed: args.world.seed, truth: !args.no_truth };
    eprintln!(
        "simulating calibration captures of a {}x{} board ({} mm squares) into {}",
        board.cols,
        board.rows,
        board.square_mm,
        args.out.display()
    );
    let mut progress = crate::progress::Progress::new();
    let report = sim::simulate_board(cfg, &board, &poses, opts, &args.out, |done, total| {
        progress.update("simulate", done, total)
    })
    .with_context(|| format!("simulating into {}", args.out.display()))?;
    print_report(args, &report)?;
    if let (Some(SimLayout::Opencv), Some(p)) = (args.layout, cfg.rig.projector.as_ref()) {
        let dir = args.out.join("opencv");
        let poses = rig::gray_code_folders::write_pose_folders(&args.out, &dir, p.lens.width, p.lens.height)
            .with_context(|| format!("writing {} in OpenCV's pose layout", dir.display()))?;
        eprintln!(
            "OpenCV layout: {poses} pose folders in {} (calibrate with `scanrig calibrate all {}`)",
            dir.display(),
            dir.display()
        );
    }
    Ok(())
}

fn print_report(args: &SimArgs, report: &sim::ScanReport) -> Result<()> {
    let mut out = std::io::stdout().lock();
    if args.json {
        serde_json::to_writer_pretty(&mut out, report)?;
        writeln!(out)?;
    } else {
        writeln!(
            out,
            "{}: {} views, {} frames written in {:.1} s ({:.0} frames/s; ray casting {:.1} s)",
            args.out.display(),
            report.views,
            report.frames_written,
            report.total_seconds,
            report.frames_per_second,
            report.geometry_seconds
        )?;
    }
    Ok(())
}

/// The object on the platter ([`sim::object_on_platter`]) with the command line's up axis.
pub fn object_on_platter(
    cfg: &SimConfig,
    mesh: Option<&std::path::Path>,
    size: f64,
    up: Up,
    offset: rig::Vector3,
) -> Result<(rig::TriMesh, Albedo)> {
    let up = if up == Up::Z { UpAxis::Z } else { UpAxis::Y };
    sim::validate_placement(cfg, size, offset)?;
    Ok(sim::object_on_platter(cfg, mesh, size, up, offset)?)
}
