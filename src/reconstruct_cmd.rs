//! `scanrig reconstruct`: a watertight mesh from an oriented cloud — the pipeline's reconstruct stage
//! on a file.

use crate::cli::ReconstructArgs;
use anyhow::{Context, Result};
use process::pipeline::stages::{self, ReconstructReport};
use rig::topology::topology;
use std::io::Write;

pub fn run(args: &ReconstructArgs) -> Result<()> {
    let params = args.reconstruct.params()?;
    crate::outputs::plan(&[("INPUT", &args.input)], &[("--out", Some(&args.out))])?;
    let mut cloud = crate::inputs::read_cloud(&args.input)?;
    if args.close {
        let (closed, r) =
            stages::close(&cloud, &Default::default()).with_context(|| format!("closing {}", args.input.display()))?;
        for (what, cap) in [("base", r.bottom), ("top", r.top)] {
            if let Some(c) = cap {
                eprintln!("closed the {what} at z = {:.3} with {} samples", c.z, c.points);
            }
        }
        if let Some(b) = r.bottom.filter(|b| b.z != 0.0) {
            eprintln!(
                "warning: {} does not start at z = 0, so its base was capped at z = {:.3}: --close is for clouds in a \
                 turntable scan's object frame (z up, the platter at z = 0); elsewhere the caps may close the wrong \
                 sides",
                args.input.display(),
                b.z
            );
        }
        cloud = closed;
    }
    let opts = crate::outputs::write_options_like(&args.input)?;
    // The platter plane is known for a cloud in a turntable scan's object frame: its header says so
    // (`process` writes that), or --close says it is.
    let in_frame = opts.comments.iter().any(|c| c == rig::ply::TURNTABLE_FRAME) || args.close;
    let (finish, base_named) = args.reconstruct.finish()?;
    if base_named && finish.base != stages::Base::Closed && !in_frame {
        anyhow::bail!(
            "--base {:?} cuts at the platter plane, but {} does not say it is in a turntable scan's object frame \
             (z up, the platter at z = 0): give --close if it is",
            finish.base,
            args.input.display()
        );
    }
    let start = std::time::Instant::now();
    let context = || format!("reconstructing {}", args.input.display());
    // The mesh stage `process` runs, on this cloud: the platter plane where the cloud is in a
    // turntable scan's object frame; no working volume's top (a file has none).
    let mp = stages::MeshParams {
        reconstruct: params,
        finish,
        platter_z: in_frame.then_some(0.0),
        top_z: None,
        force: args.force,
    };
    // Progress from inside: AdFFT's sweep, plane by plane (minutes at depth 10).
    let mut progress = crate::progress::Progress::new();
    let made = process::pipeline::watch::watched(
        mp.reconstruct.counted_steps(),
        |steps| stages::mesh_counting(&cloud, &mp, steps),
        |done, total| progress.update("reconstructing", done, total),
    );
    progress.finish();
    let made = made.with_context(context)?;
    let (report, finished, mesh) = (&made.report.reconstruct, &made.report.finish, &made.mesh);
    if let Some(b) = finished.base {
        eprintln!(
            "base: cut at z = {} ({:?}; {} triangles below removed, {} in the cap; mesh {})",
            b.z,
            b.base,
            b.removed,
            b.cap_triangles,
            if b.closed { "closed" } else { "open" }
        );
    }
    if let Some(t) = finished.trim {
        eprintln!(
            "trim: {} triangles farther than {} from the cloud removed, {} holes",
            t.removed, t.max_distance, t.holes
        );
    }
    for w in &made.warnings {
        eprintln!("warning: {}: {w}", args.out.display());
    }
    let seconds = start.elapsed().as_secs_f64();
    crate::outputs::write_mesh(&args.out, &made.output, &opts)?;
    let t = topology(mesh);
    let peak = rig::memory::peak_resident_bytes();
    let mut o = std::io::stdout().lock();
    if args.json {
        let json = crate::json_outputs::Reconstructed {
            report,
            finish: finished,
            genus: t.genus(),
            topology: t,
            seconds,
            peak_resident_bytes: peak,
        };
        serde_json::to_writer_pretty(&mut o, &crate::outputs::versioned(&json))?;
        writeln!(o)?;
    } else {
        let patches = match report {
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
        if let ReconstructReport::Adfft(r) = report {
            if let Some(why) = r.shallower_than_asked() {
                writeln!(o, "  {why}")?;
            }
            let f = &r.fit;
            writeln!(
                o,
                "  drawn onto the samples: {} vertices moved, {:.4} on average ({} held at half a cell)",
                f.moved, f.mean_move, f.limited
            )?;
        }
        match t.genus() {
            Some(g) => writeln!(o, "  closed, oriented 2-manifold: {} component(s), genus {g}", t.components)?,
            None => writeln!(o, "  not a closed manifold: {t:?}")?,
        }
    }
    Ok(())
}
