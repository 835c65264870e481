//! `scanrig demo`: the walking skeleton — a simulated 36-view structured-light scan of the built-in
//! object, processed as far as the pipeline goes, with every output's path printed.

use crate::cli::DemoArgs;
use anyhow::{Context, Result};
use rig::Method;
use sim::{Albedo, Scene, UpAxis};
use std::fmt::Write as _;

pub fn run(args: &DemoArgs) -> Result<()> {
    let mut cfg = crate::sim_cmd::load_config("structured-light")?;
    if !args.full_resolution {
        cfg = cfg.with_camera_resolution(640, 512);
    }
    anyhow::ensure!(args.views >= 1, "--views must be at least 1");
    // Refused before minutes of simulation: the accuracy below reads the triangulated range grids.
    anyhow::ensure!(
        args.until >= process::Stage::Triangulate,
        "--until {}: the demo measures its accuracy on the range grids, which triangulate makes; give \
         triangulate or a later stage",
        args.until.name()
    );
    cfg.scan.views = args.views;
    let scan = args.out.join("scan");
    let processed = args.out.join("processed");
    let size = cfg.scene.object_size_mm;
    let vase = sim::place_on_platter(&sim::fluted_vase(size).to_poly(), size, UpAxis::Z, rig::Vector3::zeros());
    let scene = Scene::on_turntable(&cfg, &vase, Albedo::Constant(cfg.scene.object_albedo));
    crate::progress::note(format!(
        "1/2 simulating {} views at {}×{} into {}",
        cfg.scan.views,
        cfg.rig.camera.width,
        cfg.rig.camera.height,
        scan.display()
    ));
    let opts = sim::ScanOptions { method: Method::StructuredLight, seed: args.seed, truth: true };
    let mut progress = crate::progress::Progress::new();
    let sim_report = sim::simulate_scan(&cfg, &scene, Some(&vase), opts, &scan, |done, total| {
        progress.update("simulate", done, total)
    })
    .with_context(|| format!("simulating into {}", scan.display()))?;
    if let Some(path) = &args.rig {
        use_rig(&scan, path, &cfg.rig.camera)?;
    }
    progress.finish();
    crate::progress::note(format!("2/2 processing into {}", processed.display()));
    let params = process::ProcessParams { until: args.until, ..Default::default() };
    let (report, page) = crate::process_cmd::run_pipeline(&scan, &processed, &params)?;
    let points: usize = report.views.iter().map(|v| v.points).sum();
    let mut text = String::new();
    writeln!(
        text,
        "scanrig demo: {} views simulated ({} frames, {:.1} s) and processed ({:.1} s)",
        sim_report.views, sim_report.frames_written, sim_report.total_seconds, report.total_seconds
    )?;
    writeln!(text, "  scan folder        {}  (frames, scan.json, rig.toml, truth/)", scan.display())?;
    writeln!(text, "  projector maps     {}", processed.join("decode").display())?;
    writeln!(
        text,
        "  range grids        {}  ({points} points over {} views)",
        processed.join("views").display(),
        report.views.len()
    )?;
    writeln!(text, "  denoised grids     {}  (non-local filter, thesis ch. 4)", processed.join("denoised").display())?;
    writeln!(text, "  depth previews     {}", processed.join("preview").display())?;
    writeln!(
        text,
        "  merged cloud       {}  ({} points, object frame, mm)",
        processed.join("merged.ply").display(),
        report.merged_points()
    )?;
    if let Some(r) = report.register.as_ref().map(|s| &s.report) {
        writeln!(
            text,
            "  registered cloud   {}  ({} points; views moved up to {:.3}° and {:.3} mm from the turntable poses)",
            processed.join("registered.ply").display(),
            r.points,
            r.max_rotation_change_deg,
            r.max_shift_mm
        )?;
    }
    if let Some(f) = report.fuse.as_ref().map(|s| &s.report) {
        writeln!(
            text,
            "  fused cloud        {}  ({} points with normals; {} outliers removed; mean shift, thesis ch. 3)",
            processed.join("fused.ply").display(),
            f.mean_shift.points_out,
            f.points_removed
        )?;
    }
    if let Some(r) = report.reconstruct.as_ref().map(|s| &s.report.reconstruct) {
        let mesh = rig::read_mesh(&processed.join("mesh.ply"))?.triangulate();
        let t = rig::topology::topology(&mesh);
        writeln!(
            text,
            "  watertight mesh    {}  ({} triangles, {}³ FFT grid, cell {:.2} mm; {})",
            processed.join("mesh.ply").display(),
            mesh.faces.len(),
            r.n(),
            r.cell(),
            match t.genus() {
                Some(g) => format!("closed 2-manifold, {} component(s), genus {g}", t.components),
                None => "NOT closed".to_string(),
            }
        )?;
    }
    if let Some(r) = report.remesh.as_ref().map(|s| &s.report) {
        let q = &r.quality;
        writeln!(
            text,
            "  quad mesh          {}  ({} faces, {:.1} % quads, corners {:.1}° from square on average; \
             within {:.2} mm of the mesh; harmonic-field streamlines, thesis ch. 6)",
            processed.join("quads.obj").display(),
            q.faces,
            100.0 * q.quad_fraction,
            q.mean_angle_error_deg,
            q.hausdorff
        )?;
    }
    writeln!(text, "  report             {}", processed.join("report.json").display())?;
    if let Some(page) = &page {
        writeln!(
            text,
            "  report page        {}  ({:.1} MB; views, plots, the cloud and mesh in 3D, error against the truth)",
            page.path.display(),
            page.bytes as f64 / 1e6
        )?;
    }
    let diag = vase.bounding_box().map_or(size, |b| b.diagonal());
    let acc = accuracy(&scan, &processed, &cfg.rig.camera, report.views.len(), diag)?;
    writeln!(
        text,
        "  accuracy           {}  (median {:.4} mm = {:.4} % of the object's diagonal from the truth surface; \
         {:.2} % of visible lit pixels decoded; {:.4} % of points over 1 % of the diagonal off{})",
        args.out.join("accuracy.json").display(),
        acc.median_mm,
        acc.median_percent_of_diagonal,
        acc.decoded_percent,
        acc.outlier_percent,
        if args.rig.is_some() { "; with the given rig" } else { "" }
    )?;
    rig::write_atomic(&args.out.join("accuracy.json"), serde_json::to_string_pretty(&acc)?.as_bytes())?;
    writeln!(text, "  the ground-truth object is {}", scan.join("truth/object.ply").display())?;
    if args.json {
        let json = crate::json_outputs::Demo { simulation: &sim_report, process: &report, accuracy: &acc };
        println!("{}", serde_json::to_string_pretty(&crate::outputs::versioned(&json))?);
    } else {
        print!("{text}");
    }
    Ok(())
}

/// Puts `path`'s rig in the scan folder in place of the simulator's, which moves to `truth/`.
fn use_rig(scan: &std::path::Path, path: &std::path::Path, camera: &rig::PinholeCamera) -> Result<()> {
    let given = rig::Rig::read(path)?;
    if (given.camera.width, given.camera.height) != (camera.width, camera.height) {
        anyhow::bail!(
            "{}: its camera is {}x{} but the demo simulates {}x{} (calibrate from captures at that size, \
             e.g. `scanrig sim --resolution {}x{} --board …`, or pass --full-resolution)",
            path.display(),
            given.camera.width,
            given.camera.height,
            camera.width,
            camera.height,
            camera.width,
            camera.height
        );
    }
    std::fs::copy(scan.join("rig.toml"), scan.join("truth/rig.toml"))
        .with_context(|| format!("keeping the simulator's rig in {}", scan.join("truth").display()))?;
    given.write(&scan.join("rig.toml"))?;
    Ok(())
}

/// Issue 4's accuracy measures over every view's range grid, against the truth.
fn accuracy(
    scan: &std::path::Path,
    processed: &std::path::Path,
    camera: &rig::PinholeCamera,
    views: usize,
    diag: f64,
) -> Result<crate::json_outputs::Accuracy> {
    let mut acc = sim::truth::ViewAccuracy::default();
    for v in 0..views {
        let grid = rig::ply::read_range_grid(&processed.join(process::pipeline::layout::Layout::grid(v)))?;
        acc.add(sim::truth::view_accuracy(
            &scan.join(rig::scan_folder::ScanLayout::truth(v)),
            camera,
            &grid,
            0.01 * diag,
        )?);
    }
    let median = acc.median();
    Ok(crate::json_outputs::Accuracy {
        views,
        points_on_object: acc.distances.len(),
        median_mm: median,
        diagonal_mm: diag,
        median_percent_of_diagonal: 100.0 * median / diag,
        decoded_percent: 100.0 * acc.decoded_of_visible_lit as f64 / acc.visible_lit.max(1) as f64,
        outlier_percent: 100.0 * acc.far as f64 / acc.decoded.max(1) as f64,
    })
}
