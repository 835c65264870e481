//! `scanrig process`: a scan folder through the pipeline.

use crate::cli::ProcessArgs;
use crate::progress::Progress;
use anyhow::{Context, Result};
use process::pipeline::Section;
use process::{ProcessParams, ProcessReport, Stage};
use std::io::Write;
use std::path::Path;

pub fn params(args: &ProcessArgs) -> Result<ProcessParams> {
    let defaults = ProcessParams::default();
    Ok(ProcessParams {
        until: args.until,
        decode: args.decode.params()?,
        denoise: if args.no_denoise { None } else { Some(args.denoise.params()?) },
        redo: args.redo,
        force: args.register.force,
        crop: args.crop.params()?,
        register: args.register.params()?,
        fuse: args.fuse.params()?,
        close: if args.no_close { None } else { defaults.close },
        reconstruct: args.reconstruct.params()?,
        finish: args.reconstruct.finish()?.0,
        remesh: args.remesh.params()?,
        ..defaults
    })
}

/// Runs the pipeline with progress on stderr, names each stage that ran again and why, and writes
/// the report page (a page that cannot be made is a warning: `None`). The page's 3D scene is made
/// on a thread of its own once the mesh is written, while the remesher runs: the remesher keeps
/// about one core of two busy, and the scene (the cloud, the mesh, their error against the truth)
/// is most of the page's cost.
pub fn run_pipeline(
    scan: &Path,
    out: &Path,
    params: &ProcessParams,
) -> Result<(ProcessReport, Option<web::scan_report::ScanPage>)> {
    run_pipeline_watched(scan, out, params, |_, _, _| {})
}

/// [`run_pipeline`], telling `watch` each stage's progress too (the station's page shows it).
pub fn run_pipeline_watched(
    scan: &Path,
    out: &Path,
    params: &ProcessParams,
    mut watch: impl FnMut(Stage, usize, usize),
) -> Result<(ProcessReport, Option<web::scan_report::ScanPage>)> {
    let mut progress = Progress::new();
    let mut scene: Option<std::thread::JoinHandle<_>> = None;
    let report = process::process_scan(scan, out, params, |stage: Stage, done, total| {
        let phase = if stage <= Stage::Denoise { "views" } else { stage.name() };
        progress.update(phase, done, total);
        watch(stage, done, total);
        if stage == Stage::Reconstruct && done == total && params.until > Stage::Reconstruct && scene.is_none() {
            let (scan, out) = (scan.to_path_buf(), out.to_path_buf());
            scene = Some(std::thread::spawn(move || web::scan_report::prepare_scene(&scan, &out)));
        }
    })
    .with_context(|| format!("processing {}", scan.display()))?;
    progress.finish();
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    // A scene that could not be made is made again with the page, which then says why.
    let prepared = scene.and_then(|s| s.join().ok()).and_then(|r| r.ok());
    let page = crate::pages::scan_report_after_run(scan, out, prepared);
    Ok((report, page))
}

/// The scan folder is read, the processed folder written: refuses a processed folder that is the scan
/// folder, holds it, or lies among its frames, then declares both to the run (`rig::run_files`), so
/// no stage can write over a capture.
pub fn guard_folders(scan: &Path, out: &Path) -> Result<()> {
    guard(scan, out, "--out", false)
}

/// [`guard_folders`] for an output file's `folder` (`option` names it): a folder holding the scan
/// may take one file (`scanrig register -o`), never the scan folder itself or its frames' folder
/// (a registered cloud had been written among the frames); `holding_ok` says which.
pub fn guard(scan: &Path, folder: &Path, option: &str, holding_ok: bool) -> Result<()> {
    let scan_c = scan.canonicalize().with_context(|| format!("reading the scan folder {}", scan.display()))?;
    // The nearest folder that exists, made canonical, with the rest of the path after it.
    let out_c = folder.ancestors().find_map(|a| Some(a.canonicalize().ok()?.join(folder.strip_prefix(a).ok()?)));
    let among_frames = out_c.as_ref().is_some_and(|o| o.starts_with(scan_c.join("frames")));
    let holds = out_c.as_ref().is_some_and(|o| if holding_ok { *o == scan_c } else { scan_c.starts_with(o) });
    if holds || among_frames {
        anyhow::bail!(
            "{option} {} would mix the results with the captures of {}: give a folder of its own (the default is {})",
            folder.display(),
            scan.display(),
            scan.join("processed").display()
        );
    }
    rig::run_files::input_folder(scan);
    rig::run_files::workspace(folder)?;
    Ok(())
}

/// "reused", "made in 12.3 s" (the first time) or "made again in 12.3 s: why" — the wall time a
/// person waited on the stage, not its threads' sum.
fn status<T>(s: &Section<T>) -> String {
    match s.reason.as_deref() {
        None => "reused".into(),
        Some(process::pipeline::records::NOT_MADE_YET) => format!("made in {:.1} s", s.seconds),
        Some(why) => format!("made again in {:.1} s: {why}", s.seconds),
    }
}

pub fn run(args: &ProcessArgs) -> Result<()> {
    let out = args.out.clone().unwrap_or_else(|| args.scan.join("processed"));
    // Every option first (the library's limits), then the folders: a refused run creates nothing.
    let params = params(args)?;
    params.validate()?;
    guard_folders(&args.scan, &out)?;
    let (report, page) = run_pipeline(&args.scan, &out, &params)?;
    let mut o = std::io::stdout().lock();
    if args.json {
        serde_json::to_writer_pretty(&mut o, &report)?;
        writeln!(o)?;
        return Ok(());
    }
    print_summary(&mut o, &out, &report)?;
    if let Some(page) = page {
        writeln!(o, "  page: {}", page.path.display())?;
    }
    Ok(())
}

pub fn print_summary(o: &mut impl Write, out: &Path, report: &ProcessReport) -> Result<()> {
    let points: usize = report.views.iter().map(|v| v.points).sum();
    let reused = report.views.iter().filter(|v| v.reused).count();
    writeln!(
        o,
        "{}: {} views ({reused} reused), {points} points, {:.1} s",
        out.display(),
        report.views.len(),
        report.total_seconds
    )?;
    // Why views ran again, once per distinct reason.
    let mut reasons: Vec<String> = Vec::new();
    for v in &report.views {
        let sections = [
            v.decode.as_ref().and_then(|s| s.reason.as_ref().map(|r| format!("decode: {r}"))),
            v.triangulate.as_ref().and_then(|s| s.reason.as_ref().map(|r| format!("triangulate: {r}"))),
            v.denoise.as_ref().and_then(|s| s.reason.as_ref().map(|r| format!("denoise: {r}"))),
        ];
        for r in sections.into_iter().flatten().chain(v.lasers.iter().filter_map(|s| s.reason.clone())) {
            let r = r.replace(&format!("view_{:03}", v.view), "view_NNN");
            if !reasons.contains(&r) {
                reasons.push(r);
            }
        }
    }
    for r in &reasons {
        writeln!(o, "  views ran: {r}")?;
    }
    if !report.incomplete_views.is_empty() {
        writeln!(o, "  left out incomplete views {:?}", report.incomplete_views)?;
    }
    if let Some(s) = &report.merge {
        writeln!(o, "  merged: {} points ({})", s.report.points, status(s))?;
    }
    if let Some(s) = &report.register
        && let Some(lr) = &s.report.lasers
    {
        for a in &lr.lasers {
            writeln!(
                o,
                "  registered laser {} onto laser {}: corrected {:.3}° and {:.3} mm; surfaces {:.3} mm apart, {:.3} mm \
                 after (lines' noise {:.3} mm) ({})",
                a.laser,
                lr.reference,
                a.rotation_deg,
                a.shift_mm,
                a.gap_before_mm,
                a.gap_after_mm,
                lr.noise_mm,
                status(s)
            )?;
        }
    } else if let Some(s) = &report.register {
        let r = &s.report;
        writeln!(
            o,
            "  registered {} views: moved up to {:.3}° and {:.3} mm from the turntable poses ({})",
            r.views,
            r.max_rotation_change_deg,
            r.max_shift_mm,
            status(s)
        )?;
    }
    if let Some(s) = &report.fuse {
        let f = &s.report;
        writeln!(
            o,
            "  fused: {} → {} points, {} outliers removed ({})",
            f.mean_shift.points_in,
            f.mean_shift.points_out,
            f.points_removed,
            status(s)
        )?;
    }
    if let Some(s) = &report.close {
        let caps: Vec<String> = [("base", &s.report.bottom), ("top", &s.report.top)]
            .iter()
            .filter_map(|(what, cap)| {
                cap.map(|c| format!("{what} at z = {:.2} mm ({} samples, {:.0} mm²)", c.z, c.points, c.area))
            })
            .collect();
        let caps = if caps.is_empty() { "nothing open".to_string() } else { caps.join(", ") };
        writeln!(o, "  closed: {caps} ({})", status(s))?;
    }
    if let Some(s) = &report.reconstruct {
        let r = &s.report.reconstruct;
        writeln!(o, "  mesh: {} triangles, {}³ grid (cell {:.3} mm) ({})", r.triangles(), r.n(), r.cell(), status(s))?;
        if let process::pipeline::stages::ReconstructReport::Adfft(a) = r
            && let Some(why) = a.shallower_than_asked()
        {
            writeln!(o, "    {why}")?;
        }
        if let Some(b) = &s.report.finish.base {
            let how = match b.base {
                process::pipeline::stages::Base::Flat => {
                    format!("flat, {} cap triangles, {:.0} mm²", b.cap_triangles, b.cap_area)
                }
                _ => format!("{:?}", b.base).to_lowercase(),
            };
            let closed = if b.closed { "closed" } else { "open" };
            writeln!(o, "  base: cut at z = {} ({how}; {} triangles below removed; mesh {closed})", b.z, b.removed)?;
        }
        if let Some(t) = &s.report.finish.trim {
            writeln!(
                o,
                "  trim: {} triangles farther than {} mm from the data removed, {} holes{}",
                t.removed,
                t.max_distance,
                t.holes,
                if t.fill_triangles > 0 { " (filled)" } else { "" }
            )?;
        }
    }
    if let Some(s) = &report.remesh {
        let q = &s.report.quality;
        writeln!(
            o,
            "  quads: {} faces, {:.1} % quads, Hausdorff {:.3} mm ({})",
            q.faces,
            100.0 * q.quad_fraction,
            q.hausdorff,
            status(s)
        )?;
    }
    for s in &report.skipped {
        writeln!(o, "  skipped {s}")?;
    }
    writeln!(o, "  report: {}", out.join("report.json").display())?;
    Ok(())
}
