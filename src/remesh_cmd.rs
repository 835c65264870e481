//! `scanrig remesh`: a quad mesh from a triangle mesh, following its creases or given lines.

use crate::cli::RemeshArgs;
use anyhow::{Context, Result};
use process::pipeline::stages;
use process::remesh::quad_remesh::{Streamlines, streamlines};
use process::remesh::{RemeshError, RemeshReport, snap_lines};
use std::fmt::Write as _;
use std::io::Write;

/// A constraint polyline's error said at its line in `path` (`at_line[i]`: the line of polyline
/// `i`); any other error as it is.
fn on_its_line(e: stages::StageError, path: &std::path::Path, at_line: &[usize]) -> anyhow::Error {
    match e {
        stages::StageError::Remesh(RemeshError::BadLine(i, why)) if i < at_line.len() => {
            anyhow::anyhow!("{}: line {}: this constraint line cannot be used: {why}", path.display(), at_line[i])
        }
        e => e.into(),
    }
}

pub fn run(args: &RemeshArgs) -> Result<()> {
    let mut params = args.remesh.params()?;
    let mut inputs = vec![("INPUT", args.input.as_path())];
    inputs.extend(args.constraints.as_deref().map(|p| ("--constraints", p)));
    inputs.extend(args.conductivity.as_deref().map(|p| ("--conductivity", p)));
    crate::outputs::plan(&inputs, &[("--out", Some(&args.out)), ("--lines", args.lines.as_deref())])?;
    let mesh = crate::inputs::read_mesh(&args.input)
        .map_err(|e| match e.to_string().contains("element `face`") {
            true => anyhow::anyhow!("{e}: a point cloud? `scanrig reconstruct` makes a mesh of one"),
            false => e.into(),
        })?
        .triangulate();
    anyhow::ensure!(
        !mesh.faces.is_empty(),
        "{}: the mesh has no faces (a point cloud? `scanrig reconstruct` makes a mesh of one)",
        args.input.display()
    );
    // Each polyline's line in the file: an unusable one is named by it, not by its place among the
    // polylines (the library's count from 0, which the file's comments and blank lines shift).
    let mut at_line: Vec<usize> = Vec::new();
    if let Some(path) = &args.constraints {
        let (at, lines): (Vec<usize>, Vec<_>) = rig::remesh_inputs::read_constraints(path)?.into_iter().unzip();
        params.lines = snap_lines(&mesh, &lines).map_err(|e| match e {
            RemeshError::BadLine(..) => on_its_line(e.into(), path, &at),
            e => anyhow::Error::from(e).context(path.display().to_string()),
        })?;
        at_line = at;
    }
    if let Some(path) = &args.conductivity {
        params.conductivity = Some(rig::remesh_inputs::read_face_values(path, mesh.faces.len())?);
    }
    let context = || format!("remeshing {}", args.input.display());
    let mut warnings = stages::check_remesh_input(&mesh, args.force).with_context(context)?;
    let mut progress = crate::progress::Progress::new();
    let (quads, report) = process::pipeline::watch::watched(
        process::remesh::quad_remesh::REMESH_PHASES,
        |phases| stages::remesh_counting(&mesh, &params, phases),
        |done, total| progress.update("remeshing", done, total),
    )
    .map_err(|e| match &args.constraints {
        Some(path) => on_its_line(e, path, &at_line),
        None => e.into(),
    })
    .with_context(context)?;
    progress.finish();
    // Checked before anything is written: an unforced implausible remesh leaves no file.
    warnings.extend(stages::check_remesh(&report, args.force).with_context(context)?);
    // In the input's units, as every stage command writes (E57, glTF and STL are converted from them).
    crate::outputs::write_mesh(&args.out, &quads, &crate::outputs::write_options_like(&args.input)?)?;
    for w in &warnings {
        eprintln!("warning: {}: {w}", args.out.display());
    }
    if let Some(path) = &args.lines {
        let mut r = RemeshReport::default();
        let traced = streamlines(&mesh, &params, &mut r).with_context(context)?;
        rig::write_atomic(path, polylines_obj(&traced).as_bytes())?;
    }
    let mut o = std::io::stdout().lock();
    if args.json {
        serde_json::to_writer_pretty(&mut o, &crate::outputs::versioned(&report))?;
        writeln!(o)?;
        return Ok(());
    }
    let q = &report.quality;
    writeln!(
        o,
        "{}: {} faces ({} quads, {:.1} %; {} triangles, {} larger) from {} triangles, spacing {:.4}",
        args.out.display(),
        q.faces,
        q.quads,
        100.0 * q.quad_fraction,
        q.triangles,
        q.polygons,
        report.input_faces,
        report.spacing
    )?;
    writeln!(
        o,
        "  corners: mean |angle − 90°| {:.2}°; Hausdorff to the input {:.4} ({:.3} % of the diagonal)",
        q.mean_angle_error_deg,
        q.hausdorff,
        100.0 * q.hausdorff_relative
    )?;
    writeln!(
        o,
        "  {} constraint lines ({} as contours, {} as gradient lines), {:.1} % of their length on an edge; \
         {} singularities, {} T-junctions",
        report.contour_constraints + report.gradient_constraints,
        report.contour_constraints,
        report.gradient_constraints,
        100.0 * q.constraint_alignment,
        q.singularities,
        report.graph.t_junctions
    )?;
    writeln!(
        o,
        "  {} non-manifold and {} boundary edges; {:.2} s (field {:.2}, streamlines {:.2}, quads {:.2})",
        q.non_manifold_edges,
        q.boundary_edges,
        report.seconds.field + report.seconds.streamlines + report.seconds.quads,
        report.seconds.field,
        report.seconds.streamlines,
        report.seconds.quads
    )?;
    Ok(())
}

/// The streamlines as OBJ polylines (`l` elements), one object per family, for a look at the field.
fn polylines_obj(t: &Streamlines) -> String {
    let mut s = String::from("# scanrig remesh streamlines: constraints, gradient lines, contours\n");
    let mut next = 1usize;
    for (group, pick) in [("constraints", 0u8), ("gradient", 1), ("contours", 2)] {
        let _ = writeln!(s, "o {group}");
        for (i, line) in t.lines.iter().enumerate() {
            let kind = if i < t.constraints || t.on_boundary[i] {
                0
            } else if line.family == process::remesh::seeding::Family::Gradient {
                1
            } else {
                2
            };
            if kind != pick || line.points.len() < 2 {
                continue;
            }
            for p in &line.points {
                let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
            }
            let ids: Vec<String> = (next..next + line.points.len()).map(|k| k.to_string()).collect();
            let _ = writeln!(s, "l {}", ids.join(" "));
            next += line.points.len();
        }
    }
    s
}
