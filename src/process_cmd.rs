//! `scanrig process`: a scan folder through the pipeline.

use crate::cli::{ProcessArgs, StageArg};
use anyhow::{Context, Result};
use process::{ProcessParams, ProcessReport, Stage};
use std::io::Write;
use std::path::Path;

pub fn params(args: &ProcessArgs) -> ProcessParams {
    let defaults = ProcessParams::default();
    ProcessParams {
        until: match args.until {
            StageArg::Decode => Stage::Decode,
            StageArg::Triangulate => Stage::Triangulate,
            StageArg::Denoise => Stage::Denoise,
            StageArg::Merge => Stage::Merge,
            StageArg::Register => Stage::Register,
            StageArg::Fuse => Stage::Fuse,
            StageArg::Reconstruct => Stage::Reconstruct,
            StageArg::Remesh => Stage::Remesh,
        },
        denoise: if args.no_denoise { None } else { defaults.denoise },
        force: args.force,
        crop: process::placement::CropParams {
            radius_mm: args.crop_radius,
            min_height_mm: args.crop_min_height,
            ..defaults.crop
        },
        ..defaults
    }
}

/// Runs the pipeline with a progress line on stderr.
pub fn run_pipeline(scan: &Path, out: &Path, params: &ProcessParams) -> Result<ProcessReport> {
    let report = process::process_scan(scan, out, params, |stage, done, total| {
        eprint!("\r  {stage} {done}/{total}   ");
        if done == total {
            eprintln!();
        }
    })
    .with_context(|| format!("processing {}", scan.display()))?;
    Ok(report)
}

pub fn run(args: &ProcessArgs) -> Result<()> {
    let out = args.out.clone().unwrap_or_else(|| args.scan.join("processed"));
    let report = run_pipeline(&args.scan, &out, &params(args))?;
    let mut o = std::io::stdout().lock();
    if args.json {
        serde_json::to_writer_pretty(&mut o, &report)?;
        writeln!(o)?;
    } else {
        let points: usize = report.views.iter().map(|v| v.points).sum();
        let reused = report.views.iter().filter(|v| v.reused).count();
        writeln!(
            o,
            "{}: {} views ({reused} reused), {points} points, merged cloud {} points, {:.1} s",
            out.display(),
            report.views.len(),
            report.merged_points,
            report.total_seconds
        )?;
        if !report.incomplete_views.is_empty() {
            writeln!(o, "  left out incomplete views {:?}", report.incomplete_views)?;
        }
        if let Some(r) = &report.register {
            writeln!(
                o,
                "  registered {} views: moved up to {:.3}° and {:.3} mm from the turntable poses{}",
                r.views,
                r.max_rotation_change_deg,
                r.max_shift_mm,
                if r.reused { " (reused)" } else { "" }
            )?;
        }
        if let Some(f) = &report.fuse {
            writeln!(
                o,
                "  fused: {} → {} points, {} outliers removed, {:.1} s",
                f.points_in,
                f.points_out,
                f.strays + f.outliers_removed,
                f.seconds_kernels + f.seconds_shift + f.seconds_cluster
            )?;
        }
        if let Some(r) = &report.reconstruct {
            writeln!(
                o,
                "  mesh: {} triangles, {}³ grid (cell {:.3} mm), {:.1} s",
                r.triangles,
                r.n,
                r.cell,
                r.seconds_splat + r.seconds_fft + r.seconds_extract
            )?;
        }
        if let Some(r) = &report.remesh {
            let q = &r.quality;
            writeln!(
                o,
                "  quads: {} faces, {:.1} % quads, Hausdorff {:.3} mm, {:.1} s",
                q.faces,
                100.0 * q.quad_fraction,
                q.hausdorff,
                r.seconds.field + r.seconds.streamlines + r.seconds.quads
            )?;
        }
        for s in &report.skipped {
            writeln!(o, "  skipped {s}")?;
        }
        writeln!(o, "  report: {}", out.join("report.json").display())?;
    }
    Ok(())
}
