//! `scanrig calibrate camera|projector|laser|turntable|all`: a rig from chessboard captures, merged
//! into a rig file, with a JSON report beside it; `scanrig calibrate import` takes a camera from
//! OpenCV YAML instead. The calibration itself is `calib::calibrate_rig`; this only turns the
//! arguments into its parameters, shows progress and writes the files.

use crate::cli::{CalibrateArgs, CalibrateTarget};
use crate::progress::Progress;
use anyhow::{Context, Result};
use calib::CalibReport;
use calib::workflow::{Orientation, Step, Target, camera_only};
use calib::{BoardSpec, CameraOptions, RigCalibParams};
use rig::Rig;
use std::io::Write;
use std::path::{Path, PathBuf};

/// How the captures are turned: --transpose and --flip where given, else the base rig's `[image]`
/// (a rig imported from Horus or FabScanPi says how its camera is mounted).
fn orientation(args: &CalibrateArgs) -> Result<Orientation> {
    if args.transpose || args.flip {
        return Ok(Orientation(rig::image::ImageTransform {
            transpose: args.transpose,
            hflip: args.flip,
            vflip: false,
        }));
    }
    let base = args.rig.as_deref().filter(|p| p.is_file()).map(Rig::read).transpose()?;
    Ok(Orientation(base.map(|r| r.image).unwrap_or_default()))
}

pub fn run(args: &CalibrateArgs) -> Result<()> {
    let source = args.captures.clone().or_else(|| args.images.clone()).expect("clap requires one of them");
    if args.target == CalibrateTarget::Import {
        return import(args, &source);
    }
    let (report, report_path) = calibrate_into_files(args, &source)?;
    print(args, &report, &report_path)
}

/// The calibration, its rig file (when plausible), report and page written; nothing printed on
/// stdout (the station calls it too, and its stdout may be gone). The report and its path.
pub fn calibrate_into_files(args: &CalibrateArgs, source: &Path) -> Result<(CalibReport, PathBuf)> {
    let source = source.to_path_buf();
    let params = RigCalibParams {
        target: match args.target {
            CalibrateTarget::Camera => Target::Only(Step::Camera),
            CalibrateTarget::Projector => Target::Only(Step::Projector),
            CalibrateTarget::Laser => Target::Only(Step::Laser),
            CalibrateTarget::Turntable => Target::Only(Step::Turntable),
            CalibrateTarget::All | CalibrateTarget::Import => Target::All,
        },
        board: BoardSpec {
            cols: args.board.cols as usize,
            rows: args.board.rows as usize,
            square_mm: args.board.charuco.map_or(args.square, |c| c.0),
            markers: args.board.charuco.map(|c| c.1),
        },
        orientation: orientation(args)?,
        lens: CameraOptions {
            fix_aspect_ratio: args.fix_aspect_ratio,
            fix_principal_point: args.fix_principal_point,
            zero_tangential: args.zero_tangential,
            fix_k3: args.fix_k3,
        },
        lens_model: args.lens_model.into(),
        corner_height_mm: args.corner_height,
        projector_size: args.projector,
    };
    let mut params = params;
    if params.projector_size.is_none()
        && let Some(size) = calib::workflow::captures::pose_layout_projector(&source)
    {
        let base_has_projector =
            args.rig.as_deref().and_then(|p| Rig::read(p).ok()).is_some_and(|r| r.projector.is_some());
        if !base_has_projector {
            eprintln!(
                "note: pose folders of Gray codes without --projector: taken as a {}x{} projector from their image count \
                 (the decoded coordinates do not depend on it; set the rig's projector width_px and height_px to the \
                 real one)",
                size.0, size.1
            );
            params.projector_size = Some(size);
        }
    }
    // Checked before the images are read (minutes on a large sweep), not after.
    params.validate()?;
    // The captures are only read: nothing the run writes may land among them or replace one.
    let report_path = report_path(&args.out);
    let page_path = report_path.with_extension("html");
    // A folder of captures is read whole; images named by a pattern are each registered as read.
    let captures: Vec<(&str, &Path)> = if source.is_dir() { vec![("CAPTURES", &source)] } else { Vec::new() };
    crate::outputs::plan(
        &captures,
        &[
            ("--out", Some(&args.out)),
            ("--yaml", args.yaml.as_deref()),
            ("its report", Some(&report_path)),
            ("its report page", Some(&page_path)),
        ],
    )?;
    if source.is_dir() {
        rig::run_files::input_folder(&source);
    }
    let mut progress = Progress::new();
    let positions = calib::workflow::load(&source, params.orientation, params.projector_size, |done, total| {
        progress.update("reading images", done, total)
    })?;
    // The rig file is read and rewritten on purpose: each step adds to the rig already there.
    rig::run_files::updates(&args.out);
    let base = [args.rig.clone().unwrap_or_default(), args.out.clone(), source.join("rig.toml")]
        .into_iter()
        .find(|p| p.is_file());
    let base = base.as_deref().map(Rig::read).transpose()?;
    let (rig, mut report) = calib::calibrate_rig(&positions, base.as_ref(), &params, |what, done, total| {
        progress.update(what, done, total)
    })?;
    progress.finish();
    let warnings = report.warnings.clone();
    for s in &report.skipped {
        eprintln!("note: skipped the {} step: {}", s.step, s.why);
    }
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    let implausible = !warnings.is_empty() && !args.force;
    // An implausible rig is not written (an existing rig file stays as it was); its report is, so
    // the figures can be looked at.
    if !implausible {
        rig.write(&args.out)?;
        if let Some(yaml) = &args.yaml {
            rig::opencv_yaml::write_camera(yaml, &rig.camera)?;
        }
        report.rig = Some(args.out.clone());
    }
    rig::write_atomic(&report_path, serde_json::to_string_pretty(&report)?.as_bytes())?;
    // The page too, implausible or not: that is when a user most needs to look.
    let turn = params.orientation;
    // The rig and the JSON report are written; a page that cannot be is a warning.
    match web::calib_report::write(&page_path, &report, &|p: &Path| turn.read(p).ok()) {
        Ok(bytes) => {
            crate::progress::note(format!("report page {} ({:.1} MB)", page_path.display(), bytes as f64 / 1e6))
        }
        Err(e) => eprintln!("warning: {} was not written: {e}", page_path.display()),
    }
    if implausible {
        anyhow::bail!(
            "the calibration cannot be right ({} finding(s) above; report in {}); {} was not written — fix the \
             captures or the options, or give --force to write it anyway",
            warnings.len(),
            report_path.display(),
            args.out.display()
        );
    }
    Ok((report, report_path))
}

/// `rig.toml` → `rig.report.json`.
fn report_path(out: &Path) -> PathBuf {
    let stem = out.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "rig".into());
    out.with_file_name(format!("{stem}.report.json"))
}
/// `scanrig calibrate import camera.yml -o rig.toml`: an OpenCV YAML camera into a rig file.
fn import(args: &CalibrateArgs, source: &Path) -> Result<()> {
    let camera = rig::opencv_yaml::read_camera(source)?;
    rig::run_files::updates(&args.out);
    let mut rig = match [args.rig.clone().unwrap_or_default(), args.out.clone()].into_iter().find(|p| p.is_file()) {
        Some(p) => Rig::read(&p)?,
        None => camera_only("imported camera", camera),
    };
    rig.camera = camera;
    rig.validate().map_err(|p| anyhow::anyhow!("{}: {p}", source.display()))?;
    rig.write(&args.out).with_context(|| format!("writing {}", args.out.display()))?;
    println!(
        "{}: camera {}x{} from {} (fx {:.3}, fy {:.3}, cx {:.3}, cy {:.3})",
        args.out.display(),
        camera.width,
        camera.height,
        source.display(),
        camera.fx,
        camera.fy,
        camera.cx,
        camera.cy
    );
    Ok(())
}

/// `v`'s numbers with `digits` decimals, space- or comma-joined by the caller.
fn list(v: &[f64], digits: usize) -> Vec<String> {
    v.iter().map(|x| format!("{x:.digits$}")).collect()
}

/// "  NAME WxH: fx …  fy …  cx …  cy … px" of a lens.
fn lens_line(o: &mut impl Write, name: &str, size: (u32, u32), f: [f64; 4]) -> Result<()> {
    writeln!(o, "  {name} {}x{}: fx {:.3}  fy {:.3}  cx {:.3}  cy {:.3} px", size.0, size.1, f[0], f[1], f[2], f[3])?;
    Ok(())
}

fn print(args: &CalibrateArgs, r: &CalibReport, report_path: &Path) -> Result<()> {
    let mut o = std::io::stdout().lock();
    if args.json {
        serde_json::to_writer_pretty(&mut o, r)?;
        writeln!(o)?;
        return Ok(());
    }
    let partial = match r.board_found.partial {
        0 => String::new(),
        n => format!(" ({n} of them in part)"),
    };
    writeln!(
        o,
        "{}: board found in {} of {} images{partial}",
        args.out.display(),
        r.board_found.found,
        r.board_found.of
    )?;
    if let Some(c) = &r.camera {
        lens_line(&mut o, "camera", (c.lens.width, c.lens.height), [c.lens.fx, c.lens.fy, c.lens.cx, c.lens.cy])?;
        writeln!(o, "    distortion (k1 k2 p1 p2 k3) {}", list(&c.lens.distortion, 5).join(" "))?;
        writeln!(o, "    lens model: estimated {}", c.model.estimated.join(" "))?;
        for held in &c.model.held {
            writeln!(o, "      {held}")?;
        }
        if !c.coverage.advice.is_empty() {
            writeln!(o, "    next captures: {}", c.coverage.advice)?;
        }
        writeln!(o, "    RMS reprojection error {:.3} px", c.rms_px)?;
        for v in &c.outlier_views {
            writeln!(o, "    outlier view: {}", v.display())?;
        }
    }
    if let Some(t) = &r.turntable {
        let fit = match t.rms_px {
            Some(rms) => format!("RMS {rms:.3} px"),
            None => format!("circles RMS {:.3} mm", t.circle_rms_mm.unwrap_or(f64::NAN)),
        };
        writeln!(
            o,
            "  turntable: platter centre ({}) mm, axis ({}); {} views, {fit}",
            list(&t.point_mm, 3).join(", "),
            list(&t.direction, 5).join(", "),
            t.views
        )?;
    }
    for l in r.lasers.iter().flatten() {
        writeln!(
            o,
            "  laser {}: normal ({}), distance {:.3} mm; {} points from {} views, spread RMS {:.3} mm",
            l.laser,
            list(&l.normal, 5).join(", "),
            l.distance_mm,
            l.inliers,
            l.views,
            l.spread_rms_mm
        )?;
    }
    if let Some(p) = &r.projector {
        lens_line(&mut o, "projector", (p.lens.width, p.lens.height), [p.lens.fx, p.lens.fy, p.lens.cx, p.lens.cy])?;
        writeln!(o, "    camera → projector translation ({}) mm", list(&p.translation_mm, 3).join(", "))?;
        writeln!(o, "    lens model: estimated {}", p.model.estimated.join(" "))?;
        for held in &p.model.held {
            writeln!(o, "      {held}")?;
        }
        writeln!(
            o,
            "    RMS: projector alone {:.3} px; stereo {:.3} px (camera {:.3}, projector {:.3}); {} corners, {} skipped",
            p.projector_rms_px,
            p.stereo_rms_px,
            p.stereo_camera_rms_px,
            p.stereo_projector_rms_px,
            p.corners_used,
            p.corners_skipped
        )?;
    }
    for m in &r.not_found {
        writeln!(o, "  no board in {}: {}", m.image.display(), m.why)?;
    }
    writeln!(o, "  report: {}", report_path.display())?;
    Ok(())
}
