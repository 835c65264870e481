//! `scanrig register`: a processed scan's views refined by multi-view ICP and merged again.

use crate::cli::RegisterArgs;
use anyhow::{Context, Result};
use std::io::Write;

pub fn run(args: &RegisterArgs) -> Result<()> {
    let processed = args.processed.clone().unwrap_or_else(|| args.scan.join("processed"));
    let out = args.out.clone().unwrap_or_else(|| processed.join("registered.ply"));
    eprintln!("registering the views of {} …", processed.display());
    let (cloud, poses) =
        process::register_scan::register_scan(&args.scan, &processed, &Default::default(), &Default::default())
            .with_context(|| format!("registering {}", args.scan.display()))?;
    rig::write_cloud(&out, &cloud, &rig::ply::WriteOptions::default().with_units("mm"))?;
    let poses_path = out.with_extension("poses.json");
    rig::write_atomic(&poses_path, &serde_json::to_vec_pretty(&poses)?)?;
    let mut o = std::io::stdout().lock();
    if args.json {
        serde_json::to_writer_pretty(&mut o, &poses)?;
        writeln!(o)?;
    } else {
        let worst = poses.iter().map(|p| p.rotation_change_deg).fold(0.0, f64::max);
        let shift = poses.iter().map(|p| p.shift_mm).fold(0.0, f64::max);
        writeln!(
            o,
            "{}: {} views, {} points; largest correction {worst:.3}° / {shift:.3} mm; poses in {}",
            out.display(),
            poses.len(),
            cloud.len(),
            poses_path.display()
        )?;
    }
    Ok(())
}
