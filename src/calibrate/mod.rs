//! `scanrig calibrate camera|projector|laser|turntable|all`: a rig from chessboard captures, merged
//! into a rig file, with a JSON report beside it; `scanrig calibrate import` takes a camera from
//! OpenCV YAML instead.

mod captures;
mod steps;

use crate::cli::{CalibrateArgs, CalibrateTarget};
use anyhow::{Context, Result, anyhow, bail};
use calib::{CameraOptions, Gray, find_corners};
use captures::Orientation;
use rig::math::{Point3, Real};
use rig::{Laser, Projector, Rig};
use serde_json::{Value, json};
use std::io::Write;
use std::path::{Path, PathBuf};
use steps::{Board, Found};

pub fn run(args: &CalibrateArgs) -> Result<()> {
    let source = args.captures.clone().or_else(|| args.images.clone()).expect("clap requires one of them");
    if args.target == CalibrateTarget::Import {
        return import(args, &source);
    }
    let (cols, rows) = args.board;
    if cols < 2 || rows < 2 || !(args.square > 0.0 && args.square.is_finite()) {
        bail!("--board needs at least 2x2 inner corners and --square a positive size");
    }
    let board = Board {
        cols: cols as usize,
        rows: rows as usize,
        object: (0..rows)
            .flat_map(|j| (0..cols).map(move |i| Point3::new(i as Real * args.square, j as Real * args.square, 0.0)))
            .collect(),
    };
    let turn = Orientation { transpose: args.transpose, flip: args.flip };
    let positions = captures::load(&source, turn)?;

    // The board in every lit frame; all frames of one camera share a size.
    let mut size: Option<(u32, u32, PathBuf)> = None;
    let (mut found, mut missed) = (Vec::new(), Vec::new());
    for (k, p) in positions.iter().enumerate() {
        eprint!("\r  looking for the board: {}/{}   ", k + 1, positions.len());
        let img = turn.read(&p.lit)?;
        match &size {
            None => size = Some((img.width, img.height, p.lit.clone())),
            Some((w, h, first)) if (*w, *h) != (img.width, img.height) => bail!(
                "{} is {}x{} but {} is {w}x{h}: one camera's images must share one size",
                p.lit.display(),
                img.width,
                img.height,
                first.display()
            ),
            _ => {}
        }
        match find_corners(&Gray::from_image(&img), board.cols, board.rows) {
            Ok(corners) => found.push(Found { position: p, corners }),
            Err(e) => missed.push((p.lit.clone(), e.to_string())),
        }
    }
    eprintln!();
    let (width, height, _) = size.expect("captures::load returns at least one position");
    if found.is_empty() {
        bail!(
            "no {cols}x{rows} board found in any of the {} images ({}); check --board (inner corners) and --transpose",
            positions.len(),
            steps::some_files(missed.iter().map(|m| &m.0))
        );
    }

    let target = args.target;
    let wants = |t: CalibrateTarget| target == t || target == CalibrateTarget::All;
    let base = [args.rig.clone().unwrap_or_default(), args.out.clone(), source.join("rig.toml")]
        .into_iter()
        .find(|p| p.is_file());
    let base = base.as_deref().map(Rig::read).transpose()?;
    let mut report = serde_json::Map::new();
    let opts = CameraOptions {
        fix_aspect_ratio: args.fix_aspect_ratio,
        fix_principal_point: args.fix_principal_point,
        zero_tangential: args.zero_tangential,
        fix_k3: args.fix_k3,
    };

    let camera = if wants(CalibrateTarget::Camera) {
        let (camera, r) = steps::camera(&found, &board, (width, height), opts).map_err(|e| with_missed(e, &missed))?;
        report.insert("camera".into(), r);
        camera
    } else {
        let rig = base.as_ref().ok_or_else(|| {
            anyhow!("{target:?} calibration needs the camera: give --rig RIG, or calibrate `camera` or `all` first")
        })?;
        if (rig.camera.width, rig.camera.height) != (width, height) {
            bail!("the rig's camera is {}x{} but the images are {width}x{height}", rig.camera.width, rig.camera.height);
        }
        rig.camera
    };
    let mut rig = base.clone().unwrap_or_else(|| camera_only("calibrated rig", camera));
    rig.camera = camera;

    let on_turntable = found.iter().filter(|f| f.position.angle_deg.is_some()).count();
    let mut sweep_poses = vec![None; found.len()];
    if target == CalibrateTarget::Turntable || (target == CalibrateTarget::All && on_turntable >= 3) {
        let height = args.corner_height.unwrap_or(2.0 * args.square);
        let (axis, poses, r) = steps::turntable(&found, &board, &camera, height)?;
        rig.turntable = Some(axis);
        sweep_poses = poses;
        report.insert("turntable".into(), r);
    }
    let has_lasers = found.iter().any(|f| !f.position.lasers.is_empty());
    if target == CalibrateTarget::Laser || (target == CalibrateTarget::All && has_lasers) {
        let (planes, r) = steps::lasers(&found, &board, &camera, &sweep_poses, turn)?;
        for (i, plane) in planes.into_iter().enumerate() {
            match rig.lasers.get_mut(i) {
                Some(l) => l.plane = plane,
                None => rig.lasers.push(Laser { name: format!("laser {i}"), plane }),
            }
        }
        report.insert("lasers".into(), r);
    }
    let has_structured = found.iter().any(|f| !f.position.structured.is_empty());
    if target == CalibrateTarget::Projector || (target == CalibrateTarget::All && has_structured) {
        let size = args
            .projector
            .or_else(|| base.as_ref().and_then(|r| r.projector.as_ref()).map(|p| (p.lens.width, p.lens.height)))
            .ok_or_else(|| anyhow!("projector: give its resolution with --projector WIDTHxHEIGHT"))?;
        let (lens, from_camera, r) = steps::projector(&found, &board, &camera, size, turn, opts)?;
        let gamma = rig.projector.as_ref().map_or(1.0, |p| p.gamma);
        rig.projector = Some(Projector { lens, from_camera, gamma });
        report.insert("projector".into(), r);
    }

    rig.write(&args.out)?;
    if let Some(yaml) = &args.yaml {
        rig::opencv_yaml::write_camera(yaml, &rig.camera)?;
    }
    report.insert(
        "not_found".into(),
        missed.iter().map(|(f, why)| json!({"image": f, "why": why})).collect::<Vec<_>>().into(),
    );
    report.insert("board_found".into(), json!({"found": found.len(), "of": positions.len()}));
    report.insert("rig".into(), json!(args.out));
    let report = Value::Object(report);
    let report_path = report_path(&args.out);
    rig::error::write_atomic(&report_path, serde_json::to_string_pretty(&report)?.as_bytes())?;
    print(args, &report, &report_path)
}

/// A rig of just a camera, for a rig file that does not exist yet.
fn camera_only(name: &str, camera: rig::PinholeCamera) -> Rig {
    Rig { name: name.into(), camera, projector: None, lasers: Vec::new(), turntable: None, platter_radius_mm: None }
}

/// `rig.toml` → `rig.report.json`.
fn report_path(out: &Path) -> PathBuf {
    let stem = out.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "rig".into());
    out.with_file_name(format!("{stem}.report.json"))
}

fn with_missed(e: anyhow::Error, missed: &[(PathBuf, String)]) -> anyhow::Error {
    if missed.is_empty() {
        return e;
    }
    let names: Vec<String> = missed.iter().take(5).map(|(f, why)| format!("{}: {why}", f.display())).collect();
    anyhow!("{e}; the board was not found in {} image(s): {}", missed.len(), names.join("; "))
}

/// `scanrig calibrate import camera.yml -o rig.toml`: an OpenCV YAML camera into a rig file.
fn import(args: &CalibrateArgs, source: &Path) -> Result<()> {
    let camera = rig::opencv_yaml::read_camera(source)?;
    let mut rig = match [args.rig.clone().unwrap_or_default(), args.out.clone()].into_iter().find(|p| p.is_file()) {
        Some(p) => Rig::read(&p)?,
        None => camera_only("imported camera", camera),
    };
    rig.camera = camera;
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
fn list(v: &Value, digits: usize) -> Vec<String> {
    v.as_array().into_iter().flatten().map(|x| format!("{:.*}", digits, x.as_f64().unwrap_or(f64::NAN))).collect()
}

/// "  NAME WxH: fx …  fy …  cx …  cy … px" of a lens report.
fn lens_line(o: &mut impl Write, name: &str, v: &Value) -> Result<()> {
    let f = |k: &str| v[k].as_f64().unwrap_or(f64::NAN);
    writeln!(
        o,
        "  {name} {}x{}: fx {:.3}  fy {:.3}  cx {:.3}  cy {:.3} px",
        v["width"],
        v["height"],
        f("fx"),
        f("fy"),
        f("cx"),
        f("cy")
    )?;
    Ok(())
}

fn print(args: &CalibrateArgs, r: &Value, report_path: &Path) -> Result<()> {
    let mut o = std::io::stdout().lock();
    if args.json {
        serde_json::to_writer_pretty(&mut o, r)?;
        writeln!(o)?;
        return Ok(());
    }
    let f = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
    writeln!(
        o,
        "{}: board found in {} of {} images",
        args.out.display(),
        r["board_found"]["found"],
        r["board_found"]["of"]
    )?;
    if let Some(c) = r.get("camera") {
        lens_line(&mut o, "camera", c)?;
        let d: Vec<String> = list(&c["distortion"], 5);
        writeln!(o, "    distortion (k1 k2 p1 p2 k3) {}", d.join(" "))?;
        writeln!(o, "    RMS reprojection error {:.3} px", f(&c["rms_px"]))?;
        for v in c["outlier_views"].as_array().into_iter().flatten() {
            writeln!(o, "    outlier view: {}", v.as_str().unwrap_or("?"))?;
        }
    }
    if let Some(t) = r.get("turntable") {
        let p: Vec<String> = list(&t["point_mm"], 3);
        let d: Vec<String> = list(&t["direction"], 5);
        let fit = t
            .get("rms_px")
            .map_or(format!("circles RMS {:.3} mm", f(&t["circle_rms_mm"])), |v| format!("RMS {:.3} px", f(v)));
        writeln!(
            o,
            "  turntable: platter centre ({}) mm, axis ({}); {} views, {fit}",
            p.join(", "),
            d.join(", "),
            t["views"]
        )?;
    }
    for l in r.get("lasers").and_then(Value::as_array).into_iter().flatten() {
        let n: Vec<String> = list(&l["normal"], 5);
        writeln!(
            o,
            "  laser {}: normal ({}), distance {:.3} mm; {} points from {} views, spread RMS {:.3} mm",
            l["laser"],
            n.join(", "),
            f(&l["distance_mm"]),
            l["inliers"],
            l["views"],
            f(&l["spread_rms_mm"])
        )?;
    }
    if let Some(p) = r.get("projector") {
        lens_line(&mut o, "projector", p)?;
        let t: Vec<String> = list(&p["translation_mm"], 3);
        writeln!(o, "    camera → projector translation ({}) mm", t.join(", "))?;
        writeln!(
            o,
            "    RMS: projector alone {:.3} px; stereo {:.3} px (camera {:.3}, projector {:.3}); {} corners, {} skipped",
            f(&p["projector_rms_px"]),
            f(&p["stereo_rms_px"]),
            f(&p["stereo_camera_rms_px"]),
            f(&p["stereo_projector_rms_px"]),
            p["corners_used"],
            p["corners_skipped"]
        )?;
    }
    for m in r["not_found"].as_array().into_iter().flatten() {
        writeln!(o, "  no board in {}: {}", m["image"].as_str().unwrap_or("?"), m["why"].as_str().unwrap_or("?"))?;
    }
    writeln!(o, "  report: {}", report_path.display())?;
    Ok(())
}
