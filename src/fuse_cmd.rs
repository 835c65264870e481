//! `scanrig fuse`: mean-shift fusion of a registered cloud — the pipeline's fuse stage on a file.

use crate::cli::FuseArgs;
use anyhow::{Context, Result};
use process::pipeline::stages;
use std::io::Write;

pub fn run(args: &FuseArgs) -> Result<()> {
    let params = args.fuse.params()?;
    crate::outputs::plan(
        &[("INPUT", &args.input)],
        &[("--out", Some(&args.out)), ("--outliers", args.outliers.as_deref())],
    )?;
    let mut cloud = crate::inputs::read_cloud(&args.input)?;
    let opts = crate::outputs::write_options_like(&args.input)?;
    // Fusion takes its input: kept here only when the outliers are to be written from it.
    let input = if args.outliers.is_some() { cloud.clone() } else { std::mem::take(&mut cloud) };
    let mut progress = crate::progress::Progress::new();
    let total = input.len();
    let (fused, r) = process::pipeline::watch::watched(
        total,
        |moved| stages::fuse_counting(input, &params, moved),
        |done, total| progress.update("fusing", done, total),
    )
    .with_context(|| format!("fusing {}", args.input.display()))?;
    progress.finish();
    crate::outputs::write_cloud(&args.out, &fused.cloud, &opts)?;
    if let Some(path) = &args.outliers {
        rig::write_cloud(path, &fused.outliers(&cloud), &opts)?;
    }
    let mut o = std::io::stdout().lock();
    if args.json {
        serde_json::to_writer_pretty(&mut o, &crate::outputs::versioned(&r))?;
        writeln!(o)?;
    } else {
        let m = &r.mean_shift;
        writeln!(
            o,
            "{}: {} → {} points ({} outliers removed), {:.1} s",
            args.out.display(),
            m.points_in,
            m.points_out,
            r.points_removed,
            m.seconds_kernels + m.seconds_shift + m.seconds_cluster
        )?;
        if let Some(parts) = r.oriented_parts {
            writeln!(o, "  the input had no normals: oriented by a spanning tree ({parts} connected parts)")?;
        }
    }
    Ok(())
}
