//! `scanrig decode`: structured-light images from other tools into a correspondence map.

use crate::cli::{DecodeArgs, FrameOrder};
use anyhow::{Context, Result, bail};
use rig::patterns::bits_for;
use rig::{Axis, Pattern};

/// The patterns of OpenCV's `GrayCodePattern` capture order for a projector of `w × h`.
pub fn opencv_order(w: u32, h: u32) -> Vec<Pattern> {
    let mut seq = Vec::new();
    for (axis, size) in [(Axis::Columns, w), (Axis::Rows, h)] {
        let bits = bits_for(size);
        for bit in 0..bits {
            for inverse in [false, true] {
                seq.push(Pattern::Gray { axis, bit, bits, inverse });
            }
        }
    }
    seq.push(Pattern::White);
    seq.push(Pattern::Black);
    seq
}

pub fn run(args: &DecodeArgs) -> Result<()> {
    crate::outputs::distinct(&[("--out", Some(&args.out))])?;
    let (pw, ph) = args.projector;
    let order = match args.order {
        FrameOrder::Opencv => opencv_order(pw, ph),
    };
    let mut files: Vec<_> = std::fs::read_dir(&args.dir)
        .with_context(|| format!("reading {}", args.dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("png")))
        .collect();
    files.sort();
    if files.len() != order.len() {
        bail!(
            "{}: {} PNG images, but a {pw}x{ph} projector in OpenCV order needs {} ({} Gray-code pairs, then white and black)",
            args.dir.display(),
            files.len(),
            order.len(),
            (order.len() - 2) / 2
        );
    }
    let images =
        files.iter().map(|f| Ok(rig::image::read_png(f)?.to_gray())).collect::<Result<Vec<_>, rig::Error>>()?;
    let frames: Vec<(Pattern, &rig::image::Image8)> = order.iter().copied().zip(images.iter()).collect();
    let params = args.decode.params()?;
    let (map, report) = process::pipeline::stages::decode(&frames, (pw, ph), &params)
        .with_context(|| format!("decoding {}", args.dir.display()))?;
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
