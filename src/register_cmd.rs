//! `scanrig register`: a processed scan's views refined by multi-view ICP and merged again — the
//! pipeline's register stage on a processed folder.

use crate::cli::RegisterArgs;
use anyhow::{Context, Result};
use std::io::Write;

pub fn run(args: &RegisterArgs) -> Result<()> {
    let processed = args.processed.clone().unwrap_or_else(|| args.scan.join("processed"));
    let out = args.out.clone().unwrap_or_else(|| processed.join(process::pipeline::layout::REGISTERED));
    let poses_path = out.with_extension("poses.json");
    // The scan is read and its captures never written among, as `process` guards them (an output
    // named into the frames' folder had been written there).
    let folder = out.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(std::path::Path::new("."));
    crate::process_cmd::guard(&args.scan, folder, "-o", true)?;
    let crop = args.crop.params()?;
    let params = args.register.params()?;
    crate::progress::note(format!("registering the views of {} …", processed.display()));
    let (cloud, poses, report) = process::pipeline::register_processed(&args.scan, &processed, &crop, &params)
        .with_context(|| format!("registering {}", args.scan.display()))?;
    // Before anything is written: a refused correction fails unless forced.
    let warnings = report
        .check(&params.tolerance, args.register.force)
        .with_context(|| format!("registering {}", args.scan.display()))?;
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    // In the turntable's object frame, as `process` writes it: the header says so.
    let mut opts = rig::ply::WriteOptions::default().with_units("mm");
    opts.comments.push(rig::ply::TURNTABLE_FRAME.into());
    crate::outputs::write_cloud(&out, &cloud, &opts)?;
    rig::write_atomic(&poses_path, &process::pipeline::stages::poses_json(&poses))?;
    let mut o = std::io::stdout().lock();
    if args.json {
        let json = crate::json_outputs::Registered { report: &report, poses: &poses };
        serde_json::to_writer_pretty(&mut o, &crate::outputs::versioned(&json))?;
        writeln!(o)?;
    } else {
        writeln!(
            o,
            "{}: {} views, {} points; largest correction {:.3}° / {:.3} mm; poses in {}",
            out.display(),
            report.views,
            cloud.len(),
            report.max_rotation_change_deg,
            report.max_shift_mm,
            poses_path.display()
        )?;
    }
    Ok(())
}
