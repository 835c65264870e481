//! `scanrig calibrate camera`: camera intrinsics from chessboard captures, into a rig file.

use crate::cli::{CalibrateArgs, CalibrateTarget};
use anyhow::{Context, Result, bail};
use calib::{CameraOptions, Gray, View, calibrate_camera, find_corners};
use rig::math::{Point3, Real};
use rig::{Manifest, Pattern, Rig};
use std::io::Write;
use std::path::{Path, PathBuf};

pub fn run(args: &CalibrateArgs) -> Result<()> {
    match args.target {
        CalibrateTarget::Camera => camera(args),
    }
}

/// The images to look for the board in: a capture folder's lit frames, or every PNG or JPEG in a
/// folder, in name order.
fn images(dir: &Path) -> Result<Vec<PathBuf>> {
    if dir.join("scan.json").is_file() {
        let manifest = Manifest::read(dir)?;
        let lit: Vec<PathBuf> = manifest
            .views
            .iter()
            .filter(|v| v.complete)
            .filter_map(|v| v.frames.iter().find(|f| f.pattern == Pattern::White).map(|f| dir.join(&f.file)))
            .collect();
        if lit.is_empty() {
            bail!("{}: the capture folder has no lit (white) frames", dir.display());
        }
        return Ok(lit);
    }
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("reading {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| ["png", "jpg", "jpeg"].iter().any(|x| e.eq_ignore_ascii_case(x))))
        .collect();
    files.sort();
    if files.is_empty() {
        bail!("{}: no scan.json and no PNG images", dir.display());
    }
    Ok(files)
}

fn camera(args: &CalibrateArgs) -> Result<()> {
    let (cols, rows) = args.board;
    if cols < 2 || rows < 2 || !(args.square > 0.0 && args.square.is_finite()) {
        bail!("--board needs at least 2x2 inner corners and --square a positive size");
    }
    let files = images(&args.captures)?;
    let object: Vec<Point3> = (0..rows)
        .flat_map(|j| (0..cols).map(move |i| Point3::new(i as Real * args.square, j as Real * args.square, 0.0)))
        .collect();
    let mut size: Option<(u32, u32, PathBuf)> = None;
    let (mut views, mut used, mut missed) = (Vec::new(), Vec::new(), Vec::new());
    for (k, file) in files.iter().enumerate() {
        let mut img = rig::image::read_image(file)?;
        if args.transpose {
            img = img.transposed();
        }
        if args.flip {
            img = img.mirrored();
        }
        match &size {
            None => size = Some((img.width, img.height, file.clone())),
            Some((w, h, first)) if (*w, *h) != (img.width, img.height) => bail!(
                "{} is {}x{} but {} is {w}x{h}: one camera's images must share one size",
                file.display(),
                img.width,
                img.height,
                first.display()
            ),
            _ => {}
        }
        eprint!("\r  looking for the board: {}/{}   ", k + 1, files.len());
        match find_corners(&Gray::from_image(&img), cols as usize, rows as usize) {
            Ok(image) => {
                views.push(View { object: object.clone(), image });
                used.push(file.clone());
            }
            Err(e) => missed.push((file.clone(), e.to_string())),
        }
    }
    eprintln!();
    let (width, height, _) = size.expect("at least one image");
    let opts = CameraOptions {
        fix_aspect_ratio: args.fix_aspect_ratio,
        fix_principal_point: args.fix_principal_point,
        zero_tangential: args.zero_tangential,
        fix_k3: args.fix_k3,
    };
    let result = calibrate_camera(&views, width, height, opts).map_err(|e| {
        let names: Vec<String> = missed.iter().take(5).map(|(f, why)| format!("{}: {why}", f.display())).collect();
        anyhow::anyhow!(
            "{e} ({} of {} images had the {cols}x{rows} board{})",
            views.len(),
            files.len(),
            if names.is_empty() { String::new() } else { format!("; not found in {}", names.join(", ")) }
        )
    })?;

    // Merge into the output rig if it exists, else the capture folder's, else a new one.
    let base = [args.out.clone(), args.captures.join("rig.toml")].into_iter().find(|p| p.is_file());
    let mut rig = match &base {
        Some(p) => Rig::read(p)?,
        None => Rig {
            name: "calibrated camera".into(),
            camera: result.camera,
            projector: None,
            lasers: Vec::new(),
            turntable: None,
            platter_radius_mm: None,
        },
    };
    rig.camera = result.camera;
    rig.write(&args.out)?;
    if let Some(yaml) = &args.yaml {
        rig::opencv_yaml::write_camera(yaml, &result.camera)?;
    }

    let mut o = std::io::stdout().lock();
    if args.json {
        let json = serde_json::json!({
            "camera": {
                "width": width, "height": height,
                "fx": result.camera.fx, "fy": result.camera.fy, "cx": result.camera.cx, "cy": result.camera.cy,
                "distortion": result.camera.distortion.to_opencv(),
            },
            "rms_px": result.rms,
            "views": used.iter().zip(&result.view_rms).map(|(f, r)| serde_json::json!({"image": f, "rms_px": r})).collect::<Vec<_>>(),
            "outlier_views": result.outlier_views.iter().map(|&v| &used[v]).collect::<Vec<_>>(),
            "not_found": missed.iter().map(|(f, why)| serde_json::json!({"image": f, "why": why})).collect::<Vec<_>>(),
            "iterations": result.iterations,
            "rig": args.out,
        });
        serde_json::to_writer_pretty(&mut o, &json)?;
        writeln!(o)?;
        return Ok(());
    }
    let c = &result.camera;
    writeln!(o, "{}: camera {}x{} from {} of {} images", args.out.display(), width, height, views.len(), files.len())?;
    writeln!(o, "  fx {:.3}  fy {:.3}  cx {:.3}  cy {:.3} px", c.fx, c.fy, c.cx, c.cy)?;
    let d = c.distortion.to_opencv();
    writeln!(o, "  distortion k1 {:.5}  k2 {:.5}  p1 {:.5}  p2 {:.5}  k3 {:.5}", d[0], d[1], d[2], d[3], d[4])?;
    writeln!(o, "  RMS reprojection error {:.3} px ({} iterations)", result.rms, result.iterations)?;
    for &v in &result.outlier_views {
        writeln!(o, "  outlier view: {} (RMS {:.3} px)", used[v].display(), result.view_rms[v])?;
    }
    for (f, why) in &missed {
        writeln!(o, "  no board in {}: {why}", f.display())?;
    }
    Ok(())
}
