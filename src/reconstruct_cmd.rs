//! `scanrig reconstruct`: a watertight mesh from an oriented cloud — the pipeline's reconstruct stage
//! on a file.

use crate::cli::ReconstructArgs;
use anyhow::{Context, Result};
use process::pipeline::stages::{self, ReconstructReport};
use rig::topology::topology;
use std::io::Write;

pub fn run(args: &ReconstructArgs) -> Result<()> {
    let params = args.reconstruct.params()?;
    crate::outputs::distinct(&[("--out", Some(&args.out)), ("input", Some(&args.input))])?;
    let mut cloud = rig::read_cloud(&args.input)?;
    if args.close {
        let (closed, r) = process::reconstruct::closing::close_openings(&cloud, &Default::default());
        for (what, cap) in [("base", r.bottom), ("top", r.top)] {
            if let Some(c) = cap {
                eprintln!("closed the {what} at z = {:.3} with {} samples", c.z, c.points);
            }
        }
        if let Some(b) = r.bottom.filter(|b| b.z != 0.0) {
            eprintln!(
                "warning: {} does not start at z = 0, so its base was capped at z = {:.3}: --close is for clouds in a \
                 turntable scan's object frame (z up, the platter at z = 0); elsewhere the caps may close the wrong sides",
                args.input.display(),
                b.z
            );
        }
        cloud = closed;
    }
    let opts = crate::outputs::write_options_like(&args.input)?;
    let start = std::time::Instant::now();
    let context = || format!("reconstructing {}", args.input.display());
    let (mesh, report) = stages::reconstruct(&cloud, &params).with_context(context)?;
    if let Some(w) = stages::check_support(&mesh, &cloud, args.force).with_context(context)? {
        eprintln!("warning: {w}");
    }
    let seconds = start.elapsed().as_secs_f64();
    rig::write_mesh(&args.out, &stages::mesh_for_output(&mesh), &opts)?;
    let t = topology(&mesh);
    let peak = rig::memory::peak_resident_bytes();
    let mut o = std::io::stdout().lock();
    if args.json {
        let json = serde_json::json!({
            "report": report,
            "topology": t,
            "genus": t.genus(),
            "seconds": seconds,
            "peak_resident_bytes": peak,
        });
        serde_json::to_writer_pretty(&mut o, &crate::outputs::versioned(&json))?;
        writeln!(o)?;
    } else {
        let patches = match &report {
            ReconstructReport::Adfft(r) => format!(", {} patches", r.leaves()),
            ReconstructReport::Fft(_) => String::new(),
        };
        writeln!(
            o,
            "{}: {} vertices, {} triangles from {} points; {}³ grid (cell {:.4}){patches}, {:.2} s, peak memory {}",
            args.out.display(),
            mesh.vertices.len(),
            mesh.faces.len(),
            cloud.len(),
            report.n(),
            report.cell(),
            seconds,
            peak.map_or("unknown".into(), |b| format!("{:.0} MB", b as f64 / 1e6))
        )?;
        match t.genus() {
            Some(g) => writeln!(o, "  closed, oriented 2-manifold: {} component(s), genus {g}", t.components)?,
            None => writeln!(o, "  not a closed manifold: {t:?}")?,
        }
    }
    Ok(())
}
