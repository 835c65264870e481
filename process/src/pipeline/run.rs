//! The run: each view's stages, then the scan's, each output reused or made again as its record says.

use super::layout::{self, Layout};
use super::out::Out;
use super::records::{Records, ScanMark};
use super::report::{LaserViewReport, ProcessReport, REPORT_SCHEMA_VERSION};
use super::scan_steps::{ScanCx, close_step, fuse_step, merge_step, mesh_step, register_step, remesh_step};
use super::stages;
use super::view_steps::{ViewCx, ViewDone, ViewOutput, run_view};
use super::{ProcessParams, Progress, Stage};
use crate::Error;
use crate::merge::CropParams;
use crate::merge::object_top::TopParams;
use crate::merge::views::{ViewData, ViewGrid};
use crate::register::register_scan::ViewPose;
use rig::folder_lock::Lock;
use rig::math::Real;
use rig::ply::WriteOptions;
use rig::scan_folder::{Manifest, Method};
use rig::{PointCloud, Rig};
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock, PoisonError};
use std::time::Instant;

/// Refuses an output folder that is not the scan's (`mark`) to write in, before anything is
/// written (the caller holds the folder's lock, so no other run passes the check meanwhile): one
/// holding files but no records of scanrig's (a user's folder given to --out, whose merged.ply and
/// report.html a run had replaced), or records of another scan (a laser scan's run into a
/// structured-light scan's folder had replaced its results and left the two mixed). A new or empty
/// folder (hidden files, the lock and the layout's own folders aside), one of this scan's (the same
/// folder, or its copy), or records that say no scan (written before scans were marked) are the
/// scan's.
pub(crate) fn claim(out: &Path, mark: &ScanMark) -> Result<(), Error> {
    let refuse = |why: String| Err(Error::NotThisScansFolder { out: out.to_path_buf(), why });
    if out.join(super::records::RECORDS_NAME).symlink_metadata().is_ok() {
        return match Records::open(out, false).scan() {
            Some(theirs) if !theirs.same_scan(mark) => refuse(format!(
                "it holds the results of another scan ({}), which process would replace and leave mixed with this \
                 one's; give --out a folder of this scan's own (the default is SCAN/processed), or remove that one",
                theirs.folder.display()
            )),
            _ => Ok(()),
        };
    }
    let Ok(entries) = std::fs::read_dir(out) else { return Ok(()) };
    let mut found: Vec<String> = entries
        .filter_map(|e| e.ok())
        .filter(|e| !(e.path().is_dir() && Layout::FOLDERS.contains(&e.file_name().to_string_lossy().as_ref())))
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| !n.starts_with('.'))
        .collect();
    if found.is_empty() {
        return Ok(());
    }
    found.sort();
    let more = if found.len() > 3 { format!(" and {} more", found.len() - 3) } else { String::new() };
    refuse(format!(
        "it holds files scanrig did not make for a scan ({}{more}) and no {}; process would replace any of the \
         same name. Give --out a new or empty folder, or remove those files",
        found.iter().take(3).cloned().collect::<Vec<_>>().join(", "),
        super::records::RECORDS_NAME
    ))
}

/// Runs the stages on the scan folder `scan`, writing into `out`; `progress(stage, done, total)`.
/// The pipeline's table of contents: the views' steps (`pipeline/view_steps.rs`), what they said,
/// then the scan's steps (`pipeline/scan_steps.rs`), and the report.
pub fn process_scan(
    scan: &Path,
    out: &Path,
    params: &ProcessParams,
    mut progress: impl Progress,
) -> Result<ProcessReport, Error> {
    process_scan_dyn(scan, out, params, &mut progress)
}

/// [`process_scan`]'s body, compiled once here: generic over the caller's closure, the whole
/// pipeline was compiled again at full optimisation into every crate that calls it (each test
/// binary, each example, the command line).
fn process_scan_dyn(
    scan: &Path,
    out: &Path,
    params: &ProcessParams,
    mut progress: &mut dyn FnMut(Stage, usize, usize),
) -> Result<ProcessReport, Error> {
    // Every stage's options before any work: a late stage's bad option must not cost the early ones.
    params.validate()?;
    let start = Instant::now();
    let _ = super::memory::take_peak_mb();
    let manifest = Manifest::read(scan)?;
    let rig_path = Manifest::inside(scan, &manifest.rig, "rig")?;
    let rig = Rig::read(&rig_path)?;
    if manifest.method == Method::Board {
        return Err(Error::BoardCapture { scan: scan.to_path_buf() });
    }
    std::fs::create_dir_all(out).map_err(|e| rig::Error::io(out, e))?;
    let lock = Lock::acquire(out)?;
    let mark = ScanMark::of_scan(scan, &manifest);
    claim(out, &mark)?;
    let layout = Layout::new(out);
    layout.create()?;
    let mut records = Records::open(out, params.redo);
    // The folder is claimed before any output is written: a run cut short leaves records saying
    // whose it is, and the next run goes on.
    records.set_scan(mark);
    records.save()?;
    let o = Out {
        layout,
        records: Arc::new(Mutex::new(records)),
        pending: Mutex::new(Vec::new()),
        opts: WriteOptions::default().with_units("mm"),
        turntable: rig.turntable.is_some(),
    };
    let old_report: Option<ProcessReport> = std::fs::read(o.path(layout::REPORT))
        .ok()
        .and_then(|b| serde_json::from_slice::<ProcessReport>(&b).ok())
        .filter(|r| r.schema_version == REPORT_SCHEMA_VERSION);
    let mut report = ProcessReport {
        schema_version: REPORT_SCHEMA_VERSION,
        scanrig_version: env!("CARGO_PKG_VERSION").into(),
        scan: scan.display().to_string(),
        method: Some(manifest.method),
        ..Default::default()
    };
    if let Some(pid) = lock.replaced_stale {
        report.warnings.push(format!(
            "{}: replaced a stale lock left by process {pid}, which is no longer running (a killed run?)",
            out.join(rig::folder_lock::LOCK_NAME).display()
        ));
    }
    let complete = complete_views(scan, &manifest, params, &mut report)?;

    // The views' steps, then what they said, in view order.
    let cx = ViewCx {
        scan,
        rig: &rig,
        rig_path: &rig_path,
        manifest: &manifest,
        params,
        triangulator: OnceLock::new(),
        windows: Mutex::new(BTreeMap::new()),
    };
    let t_views = Instant::now();
    let views_done = run_views(&o, &cx, &complete, &mut progress)?;
    report.views_seconds = Some(t_views.elapsed().as_secs_f64());
    let windows = cx.windows.into_inner().unwrap_or_else(PoisonError::into_inner);
    report.warnings.extend(windows.into_values().flat_map(|(_, w)| w));
    let outputs = gather_views(views_done, &rig, &rig_path, complete.len(), &mut report);
    report.views_peak_mb = views_peak_mb(&report);
    super::memory::release_freed();

    // The scan's steps.
    let crop = CropParams { radius_mm: params.crop.radius_mm.or(rig.platter_radius_mm), ..params.crop };
    // Each view's pass; several passes only where the views processed hold several (a pass begun but
    // not yet captured, or left out by --views, changes nothing).
    let pass_of: Vec<u32> = manifest.views.iter().map(|v| v.pass).collect();
    let several = complete.iter().any(|&v| pass_of[v] != pass_of[complete[0]]);
    let scx = ScanCx { o: &o, rig: &rig, method: manifest.method, params, pass_of, several };
    if scx.passes() && params.until == Stage::Merge {
        report.warnings.push(format!(
            "{}: this scan has {} passes, each in its own turntable frame until register aligns them: --until {} \
             leaves them apart",
            layout::MERGED,
            complete.iter().map(|&v| scx.pass_of[v]).max().unwrap_or(1),
            params.until.name()
        ));
    }
    let result = scan_steps(&scx, &mut report, outputs, &crop, &mut progress);
    // Clouds still being written are finished before the records and the report say what exists;
    // the report is written whatever happened, so what did finish is described.
    let written = o.finish_writes();
    o.save()?;
    report.total_seconds = start.elapsed().as_secs_f64();
    report.outputs.push(layout::REPORT.into());
    if let Some(old) = old_report {
        report.keep_sections_of(old);
    }
    report.stages = report.stage_rows();
    let json = serde_json::to_vec_pretty(&report).expect("reports serialise");
    rig::write_atomic(&o.path(layout::REPORT), &json)?;
    drop(lock);
    result.and(written).map(|()| report)
}

/// The views to process: the scan's complete views (those `--views` names, when given); the
/// incomplete ones are listed in the report.
fn complete_views(
    scan: &Path,
    manifest: &Manifest,
    params: &ProcessParams,
    report: &mut ProcessReport,
) -> Result<Vec<usize>, Error> {
    let complete: Vec<usize> = (0..manifest.views.len()).filter(|&v| manifest.views[v].complete).collect();
    if let Some(&v) = params.views.iter().flatten().find(|&&v| !complete.contains(&v)) {
        return Err(Error::NoSuchView { scan: scan.to_path_buf(), view: v, views: manifest.views.len() });
    }
    report.incomplete_views = (0..manifest.views.len()).filter(|v| !complete.contains(v)).collect();
    // A view subset (a distributed run's per-view part) leaves the others alone.
    let complete: Vec<usize> = match &params.views {
        Some(only) => complete.into_iter().filter(|v| only.contains(v)).collect(),
        None => complete,
    };
    if complete.is_empty() {
        return Err(Error::NoCompleteViews { scan: scan.to_path_buf(), views: manifest.views.len() });
    }
    Ok(complete)
}

/// Adds what the views said to the report, in view order, with what only all views together show
/// (views without texture, lasers whose frames some views lack or that gave nearly no line); returns
/// their outputs for the scan's steps.
fn gather_views(
    views_done: Vec<ViewDone>,
    rig: &Rig,
    rig_path: &Path,
    complete: usize,
    report: &mut ProcessReport,
) -> Vec<ViewOutput> {
    let mut outputs: Vec<ViewOutput> = Vec::new();
    // Per laser, the views whose capture lacks its frame.
    let mut missing_laser_frames: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    // Views without a texture frame: colour only holds if every view has one (merge drops it otherwise).
    let mut untextured: Vec<usize> = Vec::new();
    for d in views_done {
        let v = d.report.view;
        if d.untextured {
            untextured.push(v);
        }
        for k in d.missing_lasers {
            missing_laser_frames.entry(k).or_default().push(v);
        }
        report.warnings.extend(d.warnings);
        report.outputs.extend(d.names);
        report.views.push(d.report);
        outputs.extend(d.outputs);
    }
    if !untextured.is_empty() && untextured.len() < complete {
        report.warnings.push(format!(
            "{} of {} views have no texture frame (first: view {}): the merged cloud and mesh have no colour",
            untextured.len(),
            complete,
            untextured[0]
        ));
    }
    // A laser the capture program never switched on is a choice (one laser of two); one whose frame
    // some views lack is a capture that lost frames.
    for (k, views) in &missing_laser_frames {
        if views.len() < complete {
            report.warnings.push(format!(
                "laser {k} (`{}`) has no frame in {} of {} views ({}): those views lack its line",
                rig.lasers[*k].name,
                views.len(),
                complete,
                views.iter().take(8).map(|v| v.to_string()).collect::<Vec<_>>().join(", ")
            ));
        }
    }
    // A laser whose frames give (almost) no line: a wrong `colour` in the rig, or frames that do not
    // show it — not to be left as empty views.
    for (k, laser) in rig.lasers.iter().enumerate() {
        let sections: Vec<&LaserViewReport> =
            report.views.iter().flat_map(|v| &v.lasers).map(|s| &s.report).filter(|r| r.laser == k).collect();
        let points: usize = sections.iter().map(|r| r.points).sum();
        if !sections.is_empty() && (points as Real) < 0.01 * rig.camera.height as Real * sections.len() as Real {
            report.warnings.push(format!(
                "laser {k} (`{}`, colour {:?}) gave {points} points in {} frames, nearly none: check its `colour` \
                 under [[lasers]] in {} and that its frames show the line",
                laser.name,
                laser.colour,
                sections.len(),
                rig_path.display()
            ));
        }
    }
    outputs
}

/// The views phase's peak: every view section read the high-water mark and reset it, so the phase's
/// is the largest of their readings and what is left since the last (the last reading alone was
/// only the tail of the phase, and with two views in flight not even that view's).
fn views_peak_mb(report: &ProcessReport) -> Option<Real> {
    let last = super::memory::take_peak_mb();
    report
        .views
        .iter()
        .flat_map(|v| {
            let stages = [v.decode.as_ref().map(|s| s.peak_mb), v.triangulate.as_ref().map(|s| s.peak_mb)];
            stages
                .into_iter()
                .chain([v.denoise.as_ref().map(|s| s.peak_mb)])
                .flatten()
                .flatten()
                .chain(v.lasers.iter().filter_map(|s| s.peak_mb))
        })
        .chain(last)
        .reduce(Real::max)
}

/// The scan's steps, as far as `--until` asks: merge, register, fuse, close, mesh (with its STL and
/// GLB copies), remesh.
fn scan_steps(
    cx: &ScanCx,
    report: &mut ProcessReport,
    mut outputs: Vec<ViewOutput>,
    crop: &CropParams,
    progress: &mut impl Progress,
) -> Result<(), Error> {
    let until = cx.params.until;
    if until < Stage::Merge || outputs.is_empty() {
        return Ok(());
    }
    let mut cloud = merge_step(cx, report, &mut outputs, crop)?;
    progress(Stage::Merge, 1, 1);
    // Registration places the views again: within the same volume.
    let volume = report.merge.as_ref().and_then(|m| m.report.volume.clone());
    report.warnings.extend(volume.iter().flat_map(|v| v.warnings()));
    let line_spacing = volume.as_ref().and_then(|v| v.spacing);
    let crop = &volume.map_or(*crop, |v| v.crop(crop));
    if until >= Stage::Register && register_step(cx, report, &mut outputs, crop, &mut cloud)? {
        progress(Stage::Register, 1, 1);
    }
    drop(outputs);
    if until < Stage::Fuse {
        return Ok(());
    }
    let fused = fuse_step(cx, report, cloud, progress)?;
    progress(Stage::Fuse, 1, 1);
    if until < Stage::Reconstruct {
        return Ok(());
    }
    let input = close_step(cx, report, fused)?;
    let mesh = mesh_step(cx, report, input, crop, progress)?;
    // A laser scan's lines far apart for this mesh's cell: ribs, said whether the mesh ran or was reused.
    let cell = report.reconstruct.as_ref().map(|r| r.report.reconstruct.cell());
    if let (Some(s), Some(cell)) = (line_spacing, cell) {
        report.warnings.extend(s.warning(cell, cx.params.reconstruct.depth()));
    }
    // Whoever follows the run (the report page's scene) may read the clouds as soon as it is told.
    cx.o.finish_writes()?;
    cx.o.save()?;
    progress(Stage::Reconstruct, 1, 1);
    if until < Stage::Remesh {
        return Ok(());
    }
    remesh_step(cx, report, mesh, progress)?;
    progress(Stage::Remesh, 1, 1);
    Ok(())
}

/// Runs the views' stages, several views at once (one per rayon thread, at most four): a view alone
/// keeps about 1.3 of 2 cores busy (its frames are read and its files written one at a time), two
/// keep both. Views start in order and
/// none starts after one has failed, so the error returned is the lowest failing view's, as when
/// they ran one by one; every view that finished has its record saved. The calling thread runs views
/// too and reports progress between them (`progress` stays on it): it never only waits, so a caller
/// on rayon's own pool — the Python bindings, a pool of one thread — cannot starve the helpers.
fn run_views(o: &Out, cx: &ViewCx, views: &[usize], progress: &mut impl Progress) -> Result<Vec<ViewDone>, Error> {
    let workers = rayon::current_num_threads().clamp(1, 4).min(views.len());
    let next = AtomicUsize::new(0);
    let failed = AtomicBool::new(false);
    let results: Mutex<Vec<Option<Result<ViewDone, Error>>>> = Mutex::new((0..views.len()).map(|_| None).collect());
    // Runs the next view not yet started; false when there is none (or one failed). A view taken is
    // always run, and none is taken after a failure, so every view below the failing one ran.
    let one = |tx: &std::sync::mpsc::Sender<Stage>| -> bool {
        if failed.load(Ordering::SeqCst) {
            return false;
        }
        let i = next.fetch_add(1, Ordering::SeqCst);
        if i >= views.len() {
            return false;
        }
        // A view that panics stops the others from starting too (the panic then reaches the caller).
        let guard = FailOnUnwind(&failed);
        let r = run_view(o, cx, views[i]);
        std::mem::forget(guard);
        match &r {
            Ok(d) => {
                let _ = tx.send(d.stage);
            }
            Err(_) => failed.store(true, Ordering::SeqCst),
        }
        results.lock().unwrap_or_else(PoisonError::into_inner)[i] = Some(r);
        true
    };
    let (tx, rx) = std::sync::mpsc::channel::<Stage>();
    let mut reported = 0;
    let mut report = |rx: &std::sync::mpsc::Receiver<Stage>| {
        for stage in rx.try_iter() {
            reported += 1;
            progress(stage, reported, views.len());
        }
    };
    rayon::in_place_scope(|s| {
        for _ in 1..workers {
            let tx = tx.clone();
            let one = &one;
            s.spawn(move |_| while one(&tx) {});
        }
        while one(&tx) {
            report(&rx);
        }
    });
    drop(tx);
    report(&rx);
    let mut done = Vec::with_capacity(views.len());
    for r in results.into_inner().unwrap_or_else(PoisonError::into_inner).into_iter().flatten() {
        done.push(r?);
    }
    Ok(done)
}

/// Sets its flag if dropped while a panic unwinds (forgotten otherwise).
struct FailOnUnwind<'a>(&'a AtomicBool);

impl Drop for FailOnUnwind<'_> {
    fn drop(&mut self) {
        self.0.store(true, Ordering::SeqCst);
    }
}

/// `scanrig register`: the views of a processed scan (their denoised grids where the folder has them)
/// registered from their turntable poses exactly as `process` registers them. Returns the cloud,
/// the poses and the report.
pub fn register_processed(
    scan: &Path,
    processed: &Path,
    crop: &CropParams,
    params: &crate::register::register_scan::RegisterParams,
) -> Result<(PointCloud, Vec<ViewPose>, stages::RegisterReport), Error> {
    let manifest = Manifest::read(scan)?;
    let rig_path = Manifest::inside(scan, &manifest.rig, "rig")?;
    let rig = Rig::read(&rig_path)?;
    let axis = rig.turntable.ok_or_else(|| Error::NoTurntable { rig: rig_path.clone() })?;
    let (mut grids, mut lines) = (Vec::new(), Vec::new());
    for (v, view) in manifest.views.iter().enumerate().filter(|(_, view)| view.complete) {
        if manifest.method == Method::Laser {
            for k in 0..rig.lasers.len() {
                let p = processed.join(Layout::laser_grid(v, k));
                if p.is_file() {
                    lines.push((v, view.angle_deg, k, rig::ply::read_sparse_view(&p)?));
                }
            }
            continue;
        }
        for name in [Layout::denoised(v), Layout::grid(v)] {
            let p = processed.join(&name);
            if p.is_file() {
                grids.push((v, view.angle_deg, rig::ply::read_range_grid(&p)?));
                break;
            }
        }
    }
    let crop = CropParams { radius_mm: crop.radius_mm.or(rig.platter_radius_mm), ..*crop };
    let mut views: Vec<ViewGrid> = grids.iter().map(|(v, a, g)| ViewGrid::grid(*v, *a, g)).collect();
    views.extend(lines.iter().map(|(v, a, k, s)| ViewGrid {
        view: *v,
        angle_deg: *a,
        laser: Some(*k),
        data: ViewData::Sparse(s),
    }));
    // Within the working volume the merge of `process` applies (a laser scan's capped at its top).
    let top = (manifest.method == Method::Laser).then(TopParams::default);
    let crop = super::volume::working_volume(&views, Some(&axis), &crop, top.as_ref()).crop(&crop);
    // Several passes only where the views registered hold several (as `process` decides).
    let pass_of = |v: usize| manifest.views.get(v).map_or(1, |view| view.pass);
    match views.iter().any(|v| pass_of(v.view) != views.first().map_or(1, |f| pass_of(f.view))) {
        false => stages::register(&views, &axis, &crop, params),
        true => stages::register_passes(&views, &pass_of, &axis, &crop, params),
    }
    .map_err(|source| Error::Stage { stage: Stage::Register, source })
}
