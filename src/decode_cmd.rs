//! `scanrig decode`: structured-light images from other tools into a correspondence map.

use crate::cli::{DecodeArgs, FrameOrder};
use anyhow::{Context, Result, bail};
use rig::Pattern;
use std::path::Path;

pub fn run(args: &DecodeArgs) -> Result<()> {
    crate::outputs::distinct(&[("--out", Some(&args.out))])?;
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
    let order = match args.order {
        FrameOrder::Opencv => rig::gray_code_folders::opencv_order(pw, ph),
    };
    let image_ext = |p: &std::path::Path| {
        p.extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| ["png", "jpg", "jpeg"].iter().any(|x| e.eq_ignore_ascii_case(x)))
    };
    let mut files: Vec<_> = std::fs::read_dir(&args.dir)
        .with_context(|| format!("reading {}", args.dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| image_ext(p))
        .collect();
    files.sort();
    if files.len() != order.len() {
        bail!(
            "{}: {} images, but a {pw}x{ph} projector in OpenCV order needs {} ({} Gray-code pairs, then white and black)",
            args.dir.display(),
            files.len(),
            order.len(),
            (order.len() - 2) / 2
        );
    }
    let turn = rig.as_ref().map(|r| r.image).unwrap_or_default();
    let images = files
        .iter()
        .map(|f| {
            let g = rig::image::read_image(f)?.to_gray();
            Ok(if turn.is_identity() { g } else { g.transformed(&turn) })
        })
        .collect::<Result<Vec<_>, rig::Error>>()?;
    let frames: Vec<(Pattern, &rig::image::Image8)> = order.iter().copied().zip(images.iter()).collect();
    let params = args.decode.params()?;
    let (map, report) = process::pipeline::stages::decode(&frames, (pw, ph), &params)
        .with_context(|| format!("decoding {}", args.dir.display()))?;
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
            let json = serde_json::json!({"output": args.out, "report": report, "triangulate": gr});
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
    let preview = args.out.with_extension("png");
    rig::image::write_png(&preview, &map.preview(pw, ph), false)?;
    if args.json {
        let json = serde_json::json!({"output": args.out, "preview": preview, "report": report});
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
