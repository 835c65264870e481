//! `scanrig decode`: structured-light images from other tools into a correspondence map.

use crate::cli::{DecodeArgs, FrameOrder};
use anyhow::{Context, Result, bail};
use rig::Pattern;
use std::path::Path;

pub fn run(args: &DecodeArgs) -> Result<()> {
    let ext = args.out.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    if !matches!(ext.as_deref(), Some("npy" | "ply")) {
        bail!(
            "--out {}: the map is written as NumPy .npy (or, with --rig, a triangulated .ply); name it so",
            args.out.display()
        );
    }
    let preview = preview_path(&args.out);
    rig::run_files::input_folder(&args.dir);
    crate::outputs::plan(
        &[("DIR", &args.dir)],
        &[("--out", Some(&args.out)), ("the preview", (ext.as_deref() == Some("npy")).then_some(preview.as_path()))],
    )?;
    let rig = args.rig.as_ref().map(|p| rig::Rig::read(p)).transpose()?;
    let projector = match (&rig, args.rig.as_ref()) {
        (Some(r), Some(path)) => Some(r.projector.as_ref().with_context(|| {
            format!("{} has no [projector]: triangulating Gray codes needs the projector's calibration", path.display())
        })?),
        _ => None,
    };
    let (pw, ph) = match (args.projector, projector) {
        (Some(size), None) => size,
        (None, Some(p)) => (p.lens.width, p.lens.height),
        (Some(size), Some(p)) if size == (p.lens.width, p.lens.height) => size,
        (Some((w, h)), Some(p)) => bail!(
            "--projector {w}x{h} but the rig's projector is {}x{}: the captures belong to one of them",
            p.lens.width,
            p.lens.height
        ),
        (None, None) => {
            bail!("give the projector's size (--projector WxH) or a rig with its projector (--rig rig.toml)")
        }
    };
    let to_ply = args.out.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("ply"));
    if to_ply && rig.is_none() {
        bail!(
            "--out {} is a PLY: triangulating needs the rig (--rig rig.toml); without it write a .npy map",
            args.out.display()
        );
    }
    // The library lists the folder in frame order (by number, never as text) and refuses a duplicate,
    // a gap or an extra image by name.
    let frames_of = match args.order {
        FrameOrder::Opencv => rig::gray_code_folders::pose_frames,
    };
    let (order, files): (Vec<Pattern>, Vec<std::path::PathBuf>) = frames_of(&args.dir, pw, ph)?.into_iter().unzip();
    let turn = rig.as_ref().map(|r| r.image).unwrap_or_default();
    let images = files
        .iter()
        .map(|f| {
            let g = rig::image::read_image(f)?.to_gray();
            Ok(if turn.is_identity() { g } else { g.transformed(&turn) })
        })
        .collect::<Result<Vec<_>, rig::Error>>()?;
    let frames: Vec<(Pattern, &rig::image::Image8)> = order.iter().copied().zip(images.iter()).collect();
    let names: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
    let params = process::DecodeParams { force: args.force, ..args.decode.params()? };
    let (map, mut report) = match process::decode_view(&frames, pw, ph, &params) {
        Ok(r) => r,
        Err(e) => return Err(e.name_frames(&names)).with_context(|| format!("decoding {}", args.dir.display())),
    };
    report.name_frames(&names);
    for w in report.warnings() {
        eprintln!("warning: {w}");
    }
    if let (true, Some(rig), Some(projector)) = (to_ply, &rig, projector) {
        let tri = process::triangulate::Triangulator::new(&rig.camera, projector);
        let tp = process::triangulate::TriangulateParams::default();
        let (grid, gr) = process::pipeline::stages::triangulate(
            &map,
            &tri,
            &tp,
            process::ProcessParams::default().normal_max_jump_mm,
        )
        .with_context(|| {
            format!(
                "triangulating {} with {}",
                args.dir.display(),
                args.rig.as_deref().unwrap_or(Path::new("the rig")).display()
            )
        })?;
        rig::ply::write_range_grid(&args.out, &grid, &rig::ply::WriteOptions::default().with_units("mm"))?;
        if args.json {
            let json = crate::json_outputs::Triangulated { output: &args.out, report: &report, triangulate: &gr };
            println!("{}", serde_json::to_string_pretty(&crate::outputs::versioned(&json))?);
            return Ok(());
        }
        println!(
            "{}: {} points triangulated from {} decoded of {} pixels (camera frame, mm)",
            args.out.display(),
            grid.valid.iter().filter(|&&v| v).count(),
            report.decoded,
            report.pixels
        );
        return Ok(());
    }
    rig::npy::write(&args.out, &map.to_npy())?;
    rig::image::write_png(&preview, &map.preview(pw, ph), false)?;
    if args.json {
        let json = crate::json_outputs::Decoded { output: &args.out, preview: &preview, report: &report };
        println!("{}", serde_json::to_string_pretty(&crate::outputs::versioned(&json))?);
        return Ok(());
    }
    println!(
        "{}: {} of {} pixels decoded ({} lit, {} with rows); preview {}",
        args.out.display(),
        report.decoded,
        report.pixels,
        report.lit,
        report.decoded_rows,
        preview.display()
    );
    Ok(())
}

/// The map's preview beside it: `map.npy` → `map.preview.png`, never the name of a data file.
fn preview_path(out: &Path) -> std::path::PathBuf {
    let stem = out.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "map".into());
    out.with_file_name(format!("{stem}.preview.png"))
}
