//! The run: each view's stages, then the scan's, each output reused or made again as its record says.

use super::layout::{self, Layout};
use super::lock::Lock;
use super::records::{Decision, Fingerprint, Hash, Records};
use super::report::{GridReport, LaserViewReport, ProcessReport, REPORT_SCHEMA_VERSION, Section, ViewReport};
use super::stages;
use super::{ProcessParams, Progress, Stage};
use crate::Error;
use crate::merge::CropParams;
use crate::merge::object_top::TopParams;
use crate::merge::views::{ViewData, ViewGrid};
use crate::register::register_scan::ViewPose;
use crate::triangulate::Triangulator;
use crate::triangulate::laser_line::{Background, RowWindows, extract_line, lit_side_windows, triangulate_line};
use decode::projector_map::ProjectorMap;
use rayon::prelude::*;
use rig::image::{Image8, ImageTransform};
use rig::math::Real;
use rig::ply::WriteOptions;
use rig::scan_folder::{Manifest, Method};
use rig::{Pattern, PointCloud, RangeGrid, Rig, SparseView};
use serde::Serialize;
use serde::de::DeserializeOwned;
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, OnceLock, PoisonError};
use std::time::Instant;

/// The open output folder: where files go, what is recorded of them, how they are written.
struct Out {
    layout: Layout,
    /// Behind a lock: views write their outputs from several threads, and clouds are written on
    /// threads of their own ([`Out::put_behind`]).
    records: Arc<Mutex<Records>>,
    /// Writes still under way ([`Out::put_behind`]), each with its file's path.
    pending: Mutex<Vec<PendingWrite>>,
    opts: WriteOptions,
    /// The rig has a turntable: clouds and meshes are in its object frame.
    turntable: bool,
}

/// A file being written on a thread of its own, and its path (to name in an error).
type PendingWrite = (PathBuf, std::thread::JoinHandle<Result<(), rig::Error>>);

impl Out {
    fn path(&self, name: &str) -> PathBuf {
        self.layout.path(name)
    }

    fn records(&self) -> MutexGuard<'_, Records> {
        self.records.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Whether `name` can be reused for `fp` ([`Records::decide`]); the file is hashed outside the
    /// lock, so views deciding at once do not queue behind each other's reads.
    fn decide(&self, name: &str, fp: &Fingerprint) -> Decision {
        let decider = self.records().decider(name);
        decider.decide(fp)
    }

    /// Writes the records as they stand.
    fn save(&self) -> Result<(), Error> {
        Ok(self.records().save()?)
    }

    /// Writes `bytes` as `name` atomically and records how it was made; returns the content hash.
    fn put(&self, name: &str, bytes: &[u8], fp: Fingerprint, report: &impl Serialize) -> Result<Hash, Error> {
        // Forget the old record first: a crash between the write and the save then leaves no record
        // claiming the new file is the old one.
        self.records().remove(name);
        rig::write_atomic(&self.path(name), bytes)?;
        let hash = Hash::of(bytes);
        self.records().insert(name, fp, hash, serde_json::to_value(report).expect("reports serialise"));
        Ok(hash)
    }

    /// [`Out::put`] on a thread of its own, so the next stage starts while a 100 MB cloud goes to
    /// disk (a third of a second each on the demo, on a core the stages leave half idle). The record
    /// is made once the file is written: records saved meanwhile do not claim it, and a crash leaves
    /// the stage to run again. [`Out::finish_writes`] waits for every such write.
    fn put_behind(&self, name: &str, bytes: Vec<u8>, fp: Fingerprint, report: &impl Serialize) -> Result<Hash, Error> {
        self.records().remove(name);
        let hash = Hash::of(&bytes);
        let report = serde_json::to_value(report).expect("reports serialise");
        let (path, records, name) = (self.path(name), Arc::clone(&self.records), name.to_string());
        let target = path.clone();
        let handle = std::thread::spawn(move || {
            rig::write_atomic(&target, &bytes)?;
            records.lock().unwrap_or_else(PoisonError::into_inner).insert(&name, fp, hash, report);
            Ok(())
        });
        self.pending.lock().unwrap_or_else(PoisonError::into_inner).push((path, handle));
        Ok(hash)
    }

    /// Waits for the writes [`Out::put_behind`] started; the first that failed is the error.
    fn finish_writes(&self) -> Result<(), Error> {
        let pending = std::mem::take(&mut *self.pending.lock().unwrap_or_else(PoisonError::into_inner));
        let mut first = Ok(());
        for (path, handle) in pending {
            let written = handle
                .join()
                .unwrap_or_else(|_| Err(rig::Error::io(&path, std::io::Error::other("the thread writing it stopped"))));
            if first.is_ok() {
                first = written.map_err(Error::from);
            }
        }
        first
    }

    /// Writes PLY `bytes` as `name` ([`Out::put`], or [`Out::put_behind`] when `behind`) and hands
    /// on what they hold: the next stage gets exactly what the file says — `as_written` where it can
    /// tell without parsing (the same values, a fraction of the time on millions of points), else
    /// read back by `read`.
    #[allow(clippy::too_many_arguments)]
    fn put_ply<T>(
        &self,
        name: &str,
        bytes: Vec<u8>,
        fp: Fingerprint,
        r: &impl Serialize,
        as_written: Option<T>,
        read: impl Fn(&rig::ply::PlyFile) -> Result<T, rig::ParseError>,
        behind: bool,
    ) -> Result<(T, Hash), Error> {
        let held = match as_written {
            Some(held) => held,
            None => {
                let ply = rig::ply::parse(&bytes).map_err(|e| e.with_path(&self.path(name)))?;
                read(&ply).map_err(|e| e.with_path(&self.path(name)))?
            }
        };
        let hash = if behind { self.put_behind(name, bytes, fp, r)? } else { self.put(name, &bytes, fp, r)? };
        Ok((held, hash))
    }

    fn put_grid(
        &self,
        name: &str,
        grid: &RangeGrid,
        fp: Fingerprint,
        r: &impl Serialize,
    ) -> Result<(RangeGrid, Hash), Error> {
        let held = rig::ply::range_grid_as_written(grid, &self.opts);
        let bytes = rig::ply::range_grid_to_bytes(grid, &self.opts);
        self.put_ply(name, bytes, fp, r, held, rig::ply::range_grid_from_ply, false)
    }

    /// Writes a cloud ([`Out::put_ply`]), on a thread of its own when `behind` (see
    /// [`Out::put_behind`]; not the merged cloud, whose bytes would otherwise still be held when
    /// registration reaches the run's peak).
    fn put_cloud(
        &self,
        name: &str,
        cloud: &PointCloud,
        fp: Fingerprint,
        r: &impl Serialize,
        behind: bool,
    ) -> Result<(PointCloud, Hash), Error> {
        let opts = self.object_opts();
        let held = rig::ply::cloud_as_written(cloud, &opts);
        self.put_ply(name, rig::ply::cloud_to_bytes(cloud, &opts), fp, r, held, rig::ply::cloud_from_ply, behind)
    }

    /// The write options of a file in the object frame: on a turntable, the header says so, and
    /// `reconstruct` takes the platter plane from it.
    fn object_opts(&self) -> WriteOptions {
        let mut opts = self.opts.clone();
        if self.turntable {
            opts.comments.push(rig::ply::TURNTABLE_FRAME.into());
        }
        opts
    }

    fn put_sparse(
        &self,
        name: &str,
        view: &SparseView,
        fp: Fingerprint,
        r: &impl Serialize,
    ) -> Result<(SparseView, Hash), Error> {
        self.put_ply(
            name,
            rig::ply::sparse_view_to_bytes(view, &self.opts),
            fp,
            r,
            None,
            rig::ply::sparse_view_from_ply,
            false,
        )
    }

    fn read_grid(&self, name: &str) -> Result<RangeGrid, Error> {
        Ok(rig::ply::read_range_grid(&self.path(name))?)
    }

    /// Writes `name`, a copy of `source` in another format (mesh.stl of mesh.ply, …), unless the one
    /// there was made from these very bytes; `make` gets what the source holds (read from the file when
    /// the caller has not got it) and gives the copy's bytes.
    fn export(
        &self,
        name: &str,
        source: (&str, Hash),
        held: Option<&rig::PolyMesh>,
        make: impl Fn(&rig::PolyMesh) -> Vec<u8>,
    ) -> Result<(), Error> {
        let fp = Fingerprint::new(json!({ "export": name })).input(source.0, source.1);
        if let Decision::Run(_) = self.decide(name, &fp) {
            let bytes = match held {
                Some(m) => make(m),
                None => make(&rig::read_mesh(&self.path(source.0))?),
            };
            self.put(name, &bytes, fp, &json!({ "from": source.0 }))?;
        }
        Ok(())
    }
}

impl Drop for Out {
    /// A run that ends early still finishes the clouds it was writing, and records them.
    fn drop(&mut self) {
        if !self.pending.get_mut().unwrap_or_else(PoisonError::into_inner).is_empty() {
            let _ = self.finish_writes();
            let _ = self.save();
        }
    }
}

/// A recorded report, typed (the default where an old record lacks it).
fn recorded<T: DeserializeOwned + Default>(v: &Value) -> T {
    serde_json::from_value(v.clone()).unwrap_or_default()
}

/// [`section`] for a scan stage: what the stage freed is handed back to the system first, so the
/// next stage's peak starts from what is still held (a view's sections skip it: 108 trims cost more
/// than they give back).
fn stage_section<T>(decision: &Decision, seconds: Real, report: T) -> Section<T> {
    super::memory::release_freed();
    section(decision, seconds, report)
}

fn section<T>(decision: &Decision, seconds: Real, report: T) -> Section<T> {
    // The peak since the previous section: this stage's (views and reading its inputs included).
    let peak_mb = super::memory::take_peak_mb();
    Section { reused: decision.reused(), reason: decision.reason().map(str::to_string), seconds, peak_mb, report }
}

/// Parameters and rig parts as fingerprint values: the rig's parts by their exact debug text (every
/// f64 printed so it reads back the same), so any edit of the part a stage uses reruns the stage.
fn rig_part(part: &impl std::fmt::Debug) -> Value {
    Value::String(format!("{part:?}"))
}

/// Where laser `laser`'s line is searched: the image rows of the working volume, on the camera's side of
/// the axis ([`lit_side_windows`]). A rig that does not
/// know its volume is searched whole, with a warning; a plane that meets the volume nowhere in view is
/// a rig of another scanner (or a mistyped plane) and fails unless `--force`.
fn laser_windows(
    rig: &Rig,
    laser: &rig::Laser,
    params: &ProcessParams,
    warnings: &mut Vec<String>,
) -> Result<Option<RowWindows>, Error> {
    let Some(volume) = rig.working_volume() else {
        warnings.push(format!(
            "laser `{}`: the rig has no working volume ([turntable] with platter_radius_mm), so its line is searched \
             in the whole image and a reflection on the scanner's walls can be taken for the object",
            laser.name
        ));
        return Ok(None);
    };
    // The camera's side of the axis only: the far half of the plane holds no line of the object.
    let lp = &params.laser;
    let found = lit_side_windows(&rig.camera, &laser.plane, &volume, lp.volume_margin_mm, lp.past_axis_mm);
    if found.rows_open() > 0 {
        return Ok(Some(found));
    }
    let what = format!(
        "laser `{}`'s plane meets the working volume (platter radius {} mm, height {} mm above the turntable axis \
         point) nowhere in the camera's view",
        laser.name, volume.radius_mm, volume.height_mm
    );
    if params.force {
        warnings.push(format!("{what}: its line is searched in the whole image (--force)"));
        return Ok(None);
    }
    let hint = "check the laser's normal and distance_mm and the [turntable] in rig.toml (a rig of another scanner?); \
                --force searches the whole image"
        .into();
    Err(Error::Stage { stage: Stage::Triangulate, source: stages::StageError::Implausible { what, hint } })
}

/// Reads frames (PNG or JPEG) as grey, what decoding takes, turned as the rig's `[image]` says.
fn load_frames(frames: &[(Pattern, PathBuf)], turn: &ImageTransform) -> Result<Vec<(Pattern, Image8)>, Error> {
    let loaded = frames.par_iter().map(|(p, path)| Ok((*p, turned(rig::image::read_image(path)?.to_gray(), turn))));
    loaded.collect::<Result<Vec<_>, rig::Error>>().map_err(Error::File)
}

/// Reads frames (PNG or JPEG) with their colour, which picks a laser's line out, turned as the rig's
/// `[image]` says.
fn load_colour_frames(frames: &[(Pattern, PathBuf)], turn: &ImageTransform) -> Result<Vec<(Pattern, Image8)>, Error> {
    let loaded = frames.par_iter().map(|(p, path)| Ok((*p, turned(rig::image::read_image(path)?, turn))));
    loaded.collect::<Result<Vec<_>, rig::Error>>().map_err(Error::File)
}

/// A frame as the rig's camera sees it: other scanners' cameras are mounted on their side, and their
/// frames are kept as captured (never converted copies), turned here on reading.
fn turned(frame: Image8, turn: &ImageTransform) -> Image8 {
    if turn.is_identity() { frame } else { frame.transformed(turn) }
}

/// The content hash of every frame, by file name.
fn frame_hashes(frames: &[(Pattern, PathBuf)], scan: &Path) -> Result<BTreeMap<String, Hash>, Error> {
    frames
        .par_iter()
        .map(|(_, path)| {
            // Only a regular file, read no further than its size: a FIFO or a device is refused, not waited on.
            let bytes = rig::input::read_regular(path, None).map_err(Error::File)?;
            let name = path.strip_prefix(scan).unwrap_or(path).display().to_string();
            Ok((name, Hash::of(&bytes)))
        })
        .collect()
}

fn with_inputs(mut fp: Fingerprint, inputs: &BTreeMap<String, Hash>) -> Fingerprint {
    fp.inputs.extend(inputs.iter().map(|(k, v)| (k.clone(), *v)));
    fp
}

/// What a view measured, owned.
enum Measured {
    Grid(RangeGrid),
    Sparse(SparseView),
}

/// A view's measurements as handed to the scan's stages: its name, content hash and, where they were
/// made in this run, the measurements themselves (else read when a later stage needs them). Laser
/// views are one per laser, each a sparse view.
struct ViewOutput {
    view: usize,
    angle_deg: Real,
    laser: Option<usize>,
    name: String,
    hash: Hash,
    data: Option<Measured>,
}

/// Runs the stages on the scan folder `scan`, writing into `out`; `progress(stage, done, total)`.
pub fn process_scan(
    scan: &Path,
    out: &Path,
    params: &ProcessParams,
    mut progress: impl Progress,
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
    let layout = Layout::new(out);
    layout.create()?;
    let lock = Lock::acquire(out)?;
    let mut o = Out {
        layout,
        records: Arc::new(Mutex::new(Records::open(out, params.redo))),
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
            out.join(super::lock::LOCK_NAME).display()
        ));
    }
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

    // The views' stages, then what they said, in view order.
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
    if !untextured.is_empty() && untextured.len() < complete.len() {
        report.warnings.push(format!(
            "{} of {} views have no texture frame (first: view {}): the merged cloud and mesh have no colour",
            untextured.len(),
            complete.len(),
            untextured[0]
        ));
    }
    // A laser the capture program never switched on is a choice (one laser of two); one whose frame
    // some views lack is a capture that lost frames.
    for (k, views) in &missing_laser_frames {
        if views.len() < complete.len() {
            report.warnings.push(format!(
                "laser {k} (`{}`) has no frame in {} of {} views ({}): those views lack its line",
                rig.lasers[*k].name,
                views.len(),
                complete.len(),
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

    // The phase's peak: every view section read the high-water mark and reset it, so the phase's is
    // the largest of their readings and what is left since the last (the last reading alone was
    // only the tail of the phase, and with two views in flight not even that view's).
    let last = super::memory::take_peak_mb();
    report.views_peak_mb = report
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
        .reduce(Real::max);
    super::memory::release_freed();
    let crop = CropParams { radius_mm: params.crop.radius_mm.or(rig.platter_radius_mm), ..params.crop };
    let result = scan_stages(&mut o, &mut report, &rig, manifest.method, outputs, &crop, params, &mut progress);
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

/// What one view's stages gave, to be added to the scan's report in view order.
struct ViewDone {
    report: ViewReport,
    /// The stage the view got to, for progress.
    stage: Stage,
    outputs: Vec<ViewOutput>,
    /// Output names, for the report's list.
    names: Vec<String>,
    warnings: Vec<String>,
    /// The capture has no texture frame for the view.
    untextured: bool,
    /// Lasers whose frame the view lacks.
    missing_lasers: Vec<usize>,
}

/// A laser's windows (`None`: the whole image) and what computing them warned of.
type LaserWindows = (Option<RowWindows>, Vec<String>);

/// What every view's stages share.
struct ViewCx<'a> {
    scan: &'a Path,
    rig: &'a Rig,
    rig_path: &'a PathBuf,
    manifest: &'a Manifest,
    params: &'a ProcessParams,
    /// Built by the first view that triangulates.
    triangulator: OnceLock<Triangulator>,
    /// Each laser's working-volume windows, computed by the first view that needs them, with what
    /// computing them warned of (said once, in laser order, whichever view it was).
    windows: Mutex<BTreeMap<usize, LaserWindows>>,
}

impl ViewCx<'_> {
    /// The triangulator, built outside any lock: building it runs rayon loops, and a thread waiting
    /// in one may take up another view that would then wait on the lock its own stack holds.
    fn triangulator(&self, projector: &rig::Projector) -> &Triangulator {
        if let Some(t) = self.triangulator.get() {
            return t;
        }
        let built = Triangulator::new(&self.rig.camera, projector);
        self.triangulator.get_or_init(|| built)
    }

    /// Laser `k`'s windows, computed (again, for the same reason) outside the lock.
    fn windows(&self, k: usize, laser: &rig::Laser) -> Result<Option<RowWindows>, Error> {
        if let Some((w, _)) = self.windows.lock().unwrap_or_else(PoisonError::into_inner).get(&k) {
            return Ok(w.clone());
        }
        let mut warnings = Vec::new();
        let w = laser_windows(self.rig, laser, self.params, &mut warnings)?;
        self.windows.lock().unwrap_or_else(PoisonError::into_inner).entry(k).or_insert((w.clone(), warnings));
        Ok(w)
    }
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

/// One view's stages: decoding and triangulation (structured light) or line extraction (laser),
/// then denoising, each output reused where its record allows.
fn run_view(o: &Out, cx: &ViewCx, v: usize) -> Result<ViewDone, Error> {
    let t0 = Instant::now();
    let ViewCx { scan, rig, rig_path, manifest, params, .. } = *cx;
    let mut made = ViewDone {
        report: ViewReport::default(),
        stage: Stage::Decode,
        outputs: Vec::new(),
        names: Vec::new(),
        warnings: Vec::new(),
        untextured: false,
        missing_lasers: Vec::new(),
    };
    let view = &manifest.views[v];
    let frames: Vec<(Pattern, PathBuf)> = view
        .frames
        .iter()
        .map(|f| Ok((f.pattern, Manifest::inside(scan, &f.file, &format!("views[{v}].frames"))?)))
        .collect::<Result<_, Error>>()?;
    let mut vr = ViewReport { view: v, angle_deg: view.angle_deg, reused: true, ..Default::default() };
    // The view's colour frame, if the capture took one; read (in colour, turned) only when needed.
    if !frames.iter().any(|f| f.0 == Pattern::Texture) {
        made.untextured = true;
    }
    let texture: Vec<(Pattern, PathBuf)> = frames.iter().filter(|f| f.0 == Pattern::Texture).take(1).cloned().collect();
    let texture_hashes = frame_hashes(&texture, scan)?;
    let mut texture_image: Option<Image8> = None;
    let read_texture = |cache: &mut Option<Image8>| -> Result<Option<Image8>, Error> {
        if cache.is_none() && !texture.is_empty() {
            *cache = load_colour_frames(&texture, &rig.image)?.pop().map(|t| t.1);
        }
        Ok(cache.clone())
    };
    match manifest.method {
        Method::StructuredLight => {
            let projector = rig.projector.as_ref().ok_or_else(|| Error::NoProjector { rig: rig_path.clone() })?;
            let (pw, ph) = (projector.lens.width, projector.lens.height);
            // Decode.
            let t = Instant::now();
            let fp = with_inputs(
                Fingerprint::new(json!({"decode": params.decode, "projector_px": [pw, ph], "rig.image": rig.image})),
                &frame_hashes(&frames, scan)?,
            );
            let name = Layout::decode(v);
            let decision = o.decide(&name, &fp);
            let (map_hash, mut map) = match &decision {
                Decision::Reuse(rec) => {
                    vr.decode = Some(section(&decision, 0.0, recorded(&rec.report)));
                    (rec.hash, None)
                }
                Decision::Run(_) => {
                    let imgs = load_frames(&frames, &rig.image)?;
                    let refs: Vec<(Pattern, &Image8)> = imgs.iter().map(|(p, i)| (*p, i)).collect();
                    // Frame checks name the scan's files; forced, their failures become warnings.
                    let names: Vec<String> = view.frames.iter().map(|f| f.file.clone()).collect();
                    let dp = decode::structured_light::DecodeParams { force: params.force, ..params.decode };
                    let (map, mut dr) = stages::decode(&refs, (pw, ph), &dp).map_err(|source| {
                        let source = match source {
                            stages::StageError::Decode(e) => stages::StageError::Decode(e.name_frames(&names)),
                            other => other,
                        };
                        Error::View { view: v, stage: Stage::Decode, source }
                    })?;
                    dr.name_frames(&names);
                    let hash = o.put(&name, &rig::npy::to_bytes(&map.to_npy()), fp, &dr)?;
                    // Previews are for looking at: fast compression (deflating them was a sixth of a view's time).
                    rig::image::write_png(&o.path(&Layout::projector_preview(v)), &map.preview(pw, ph), true)?;
                    vr.decode = Some(section(&decision, t.elapsed().as_secs_f64(), dr));
                    (hash, Some(map))
                }
            };
            vr.reused &= decision.reused();
            if let Some(d) = &vr.decode {
                made.warnings.extend(d.report.warnings().into_iter().map(|w| format!("view {v}: {w}")));
            }
            made.names.push(name.clone());
            if params.until < Stage::Triangulate {
                // Stopping after decoding still reports the view and records its map.
                vr.seconds = t0.elapsed().as_secs_f64();
                o.save()?;
                (made.report, made.stage) = (vr, Stage::Decode);
                return Ok(made);
            }
            // Triangulate.
            let t = Instant::now();
            let fp = with_inputs(
                Fingerprint::new(json!({
                    "triangulate": params.triangulate,
                    "normal_max_jump_mm": params.normal_max_jump_mm,
                    "rig.camera": rig_part(&rig.camera),
                    "rig.projector": rig_part(projector),
                }))
                .input(&name, map_hash),
                &texture_hashes,
            );
            let grid_name = Layout::grid(v);
            let decision = o.decide(&grid_name, &fp);
            let (mut hash, mut grid) = match &decision {
                Decision::Reuse(rec) => {
                    vr.triangulate = Some(section(&decision, 0.0, recorded::<GridReport>(&rec.report)));
                    (rec.hash, None)
                }
                Decision::Run(_) => {
                    let map = match map.take() {
                        Some(m) => m,
                        None => read_map(&o.path(&name))?,
                    };
                    // Checked before the rig's ray tables are built: a rig of the wrong camera
                    // (or an absurd size) must fail here, not allocate.
                    let camera = (rig.camera.width, rig.camera.height);
                    if (map.width, map.height) != (camera.0 as usize, camera.1 as usize) {
                        let source = stages::StageError::MapSize { map: (map.width, map.height), camera };
                        return Err(Error::View { view: v, stage: Stage::Triangulate, source });
                    }
                    let tri = cx.triangulator(projector);
                    let (mut grid, gr) = stages::triangulate(&map, tri, &params.triangulate, params.normal_max_jump_mm)
                        .map_err(|source| Error::View { view: v, stage: Stage::Triangulate, source })?;
                    if let Some(t) = read_texture(&mut texture_image)? {
                        grid.colors = stages::grid_colours(&grid, &t);
                        if grid.colors.is_none() {
                            made.warnings.push(format!(
                                "view {v}: its texture frame is {}x{}, not the camera's {}x{}: the view has no colour",
                                t.width, t.height, grid.width, grid.height
                            ));
                        }
                    }
                    let (grid, hash) = o.put_grid(&grid_name, &grid, fp, &gr)?;
                    let depth = crate::preview::depth_image(&grid);
                    rig::image::write_png(&o.path(&Layout::depth_preview(v)), &depth, true)?;
                    vr.triangulate = Some(section(&decision, t.elapsed().as_secs_f64(), gr));
                    (hash, Some(grid))
                }
            };
            vr.reused &= decision.reused();
            vr.points = vr.triangulate.as_ref().map_or(0, |s| s.report.points);
            made.names.push(grid_name.clone());
            let mut handed = grid_name;
            // Denoise.
            if let (Some(dp), true) = (&params.denoise, params.until >= Stage::Denoise) {
                let t = Instant::now();
                let fp = Fingerprint::new(json!({ "denoise": dp })).input(&handed, hash);
                let name = Layout::denoised(v);
                let decision = o.decide(&name, &fp);
                match &decision {
                    Decision::Reuse(rec) => {
                        let dr: crate::denoise::DenoiseReport = recorded(&rec.report);
                        vr.points = dr.points;
                        vr.denoise = Some(section(&decision, 0.0, dr));
                        (hash, grid) = (rec.hash, None);
                    }
                    Decision::Run(_) => {
                        let input = match grid.take() {
                            Some(g) => g,
                            None => o.read_grid(&handed)?,
                        };
                        let (clean, dr) = stages::denoise(std::slice::from_ref(&input), 0, 0, dp)
                            .map_err(|source| Error::View { view: v, stage: Stage::Denoise, source })?;
                        let (clean, h) = o.put_grid(&name, &clean, fp, &dr)?;
                        vr.points = clean.valid_count();
                        vr.denoise = Some(section(&decision, t.elapsed().as_secs_f64(), dr));
                        (hash, grid) = (h, Some(clean));
                    }
                }
                vr.reused &= decision.reused();
                made.names.push(name.clone());
                handed = name;
            }
            let data = grid.map(Measured::Grid);
            made.outputs.push(ViewOutput { view: v, angle_deg: view.angle_deg, laser: None, name: handed, hash, data });
        }
        Method::Laser => {
            if let Some(index) = frames.iter().find_map(|f| match f.0 {
                Pattern::Laser { index } if index >= rig.lasers.len() => Some(index),
                _ => None,
            }) {
                return Err(Error::UnknownLaser { view: v, index, lasers: rig.lasers.len(), rig: rig_path.clone() });
            }
            // FabScanPi and other scanners record no laser-off frame: the background is then
            // estimated from the laser frame itself.
            let off = frames.iter().find(|f| f.0 == Pattern::LaserOff);
            for (k, laser) in rig.lasers.iter().enumerate() {
                let Some(on) = frames.iter().find(|f| f.0 == Pattern::Laser { index: k }) else {
                    made.missing_lasers.push(k);
                    continue;
                };
                let t = Instant::now();
                let pair: Vec<(Pattern, PathBuf)> = off.into_iter().chain([on]).cloned().collect();
                let fp = with_inputs(
                    Fingerprint::new(json!({
                        "laser": params.laser,
                        "rig.camera": rig_part(&rig.camera),
                        "rig.image": rig.image,
                        "rig.laser": rig_part(laser),
                        "rig.working_volume": rig_part(&rig.working_volume()),
                    })),
                    &frame_hashes(&pair, scan)?.into_iter().chain(texture_hashes.clone()).collect(),
                );
                let name = Layout::laser_grid(v, k);
                let decision = o.decide(&name, &fp);
                let (hash, line, lr) = match &decision {
                    Decision::Reuse(rec) => (rec.hash, None, recorded::<LaserViewReport>(&rec.report)),
                    Decision::Run(_) => {
                        let imgs = load_colour_frames(&pair, &rig.image)?;
                        let camera = (rig.camera.width, rig.camera.height);
                        if let Some((_, img)) = imgs.iter().find(|(_, i)| (i.width, i.height) != camera) {
                            let map = (img.width as usize, img.height as usize);
                            let source = stages::StageError::MapSize { map, camera };
                            return Err(Error::View { view: v, stage: Stage::Triangulate, source });
                        }
                        let frame = &imgs[imgs.len() - 1].1;
                        let background = match off {
                            Some(_) => Background::Frame(&imgs[0].1),
                            None => Background::Estimated,
                        };
                        let windows = cx.windows(k, laser)?;
                        let (peaks, line) =
                            extract_line(frame, background, laser.colour, windows.as_ref(), &params.laser, |_, _| true);
                        let mut points = triangulate_line(&peaks, &rig.camera, &laser.plane);
                        if let Some(t) = read_texture(&mut texture_image)? {
                            points.colors = Some(points.pixels.iter().map(|&px| stages::colour_at(&t, px)).collect());
                        }
                        let lr = LaserViewReport { laser: k, line, points: points.len() };
                        let (points, hash) = o.put_sparse(&name, &points, fp, &lr)?;
                        (hash, Some(points), lr)
                    }
                };
                vr.reused &= decision.reused();
                vr.points += lr.points;
                vr.lasers.push(section(&decision, t.elapsed().as_secs_f64(), lr));
                made.names.push(name.clone());
                let data = line.map(Measured::Sparse);
                made.outputs.push(ViewOutput { view: v, angle_deg: view.angle_deg, laser: Some(k), name, hash, data });
            }
        }
        Method::Board => unreachable!("refused above"),
    }
    vr.seconds = t0.elapsed().as_secs_f64();
    o.save()?;
    (made.report, made.stage) = (vr, Stage::Triangulate.min(params.until));
    Ok(made)
}

fn read_map(path: &Path) -> Result<ProjectorMap, Error> {
    ProjectorMap::from_npy(&rig::npy::read(path)?).ok_or_else(|| Error::NotAProjectorMap { path: path.to_path_buf() })
}

/// Loads the views' measurements a scan stage needs that are not in memory.
fn load_grids(o: &Out, outputs: &mut [ViewOutput]) -> Result<(), Error> {
    let loaded: Vec<Option<Measured>> = outputs
        .par_iter()
        .map(|vo| match (&vo.data, vo.laser) {
            (Some(_), _) => Ok(None),
            (None, None) => o.read_grid(&vo.name).map(|g| Some(Measured::Grid(g))),
            (None, Some(_)) => Ok(Some(Measured::Sparse(rig::ply::read_sparse_view(&o.path(&vo.name))?))),
        })
        .collect::<Result<_, Error>>()?;
    for (vo, g) in outputs.iter_mut().zip(loaded) {
        if g.is_some() {
            vo.data = g;
        }
    }
    Ok(())
}

fn view_grids(outputs: &[ViewOutput]) -> Vec<ViewGrid<'_>> {
    outputs
        .iter()
        .map(|vo| {
            let data = match vo.data.as_ref().expect("loaded") {
                Measured::Grid(g) => ViewData::Grid(g),
                Measured::Sparse(s) => ViewData::Sparse(s),
            };
            ViewGrid { view: vo.view, angle_deg: vo.angle_deg, laser: vo.laser, data }
        })
        .collect()
}

fn grid_inputs(fp: Fingerprint, outputs: &[ViewOutput]) -> Fingerprint {
    outputs.iter().fold(fp, |fp, vo| fp.input(&vo.name, vo.hash))
}

/// Merge, register, fuse, reconstruct, remesh.
#[allow(clippy::too_many_arguments)]
fn scan_stages(
    o: &mut Out,
    report: &mut ProcessReport,
    rig: &Rig,
    method: Method,
    mut outputs: Vec<ViewOutput>,
    crop: &CropParams,
    params: &ProcessParams,
    progress: &mut impl Progress,
) -> Result<(), Error> {
    if params.until < Stage::Merge || outputs.is_empty() {
        return Ok(());
    }
    // Merge, within the working volume: a laser scan's capped at the object's top its lines show.
    let t = Instant::now();
    let top = (method == Method::Laser).then(TopParams::default);
    let fp = grid_inputs(
        Fingerprint::new(json!({"crop": crop, "object_top": top, "rig.turntable": rig_part(&rig.turntable)})),
        &outputs,
    );
    let decision = o.decide(layout::MERGED, &fp);
    let (mut cloud_name, mut cloud_hash, mut cloud) = match &decision {
        Decision::Reuse(rec) => {
            report.merge = Some(stage_section(&decision, 0.0, recorded(&rec.report)));
            (layout::MERGED, rec.hash, None)
        }
        Decision::Run(_) => {
            load_grids(o, &mut outputs)?;
            let volume =
                super::volume::working_volume(&view_grids(&outputs), rig.turntable.as_ref(), crop, top.as_ref());
            let (merged, mut mr) = stages::merge(&view_grids(&outputs), rig.turntable.as_ref(), &volume.crop(crop));
            mr.volume = Some(volume);
            let measured: usize = outputs
                .iter()
                .map(|vo| match vo.data.as_ref() {
                    Some(Measured::Grid(g)) => g.valid.iter().filter(|&&v| v).count(),
                    Some(Measured::Sparse(s)) => s.points.len(),
                    None => 0,
                })
                .sum();
            if measured == 0 {
                return Err(Error::LeftNothing {
                    stage: Stage::Triangulate,
                    why: format!(
                        "none of the {} view(s) gave a point: check that the scan's method ({method:?} in scan.json) \
                         is how its frames were captured, and that its frames show the object lit",
                        outputs.len()
                    ),
                });
            }
            if merged.positions.is_empty() {
                return Err(Error::LeftNothing {
                    stage: Stage::Merge,
                    why: format!(
                        "no point of the {} view(s) lies inside the object cylinder (radius {}, at least {} mm above \
                         the platter): check --crop-radius and --crop-min-height, and the rig's turntable axis",
                        outputs.len(),
                        crop.radius_mm.map_or("the platter's".to_string(), |r| format!("{r} mm")),
                        crop.min_height_mm
                    ),
                });
            }
            let (merged, hash) = o.put_cloud(layout::MERGED, &merged, fp, &mr, false)?;
            report.merge = Some(stage_section(&decision, t.elapsed().as_secs_f64(), mr));
            (layout::MERGED, hash, Some(merged))
        }
    };
    report.outputs.push(layout::MERGED.into());
    o.save()?;
    progress(Stage::Merge, 1, 1);
    // Registration places the views again: within the same volume.
    let volume = report.merge.as_ref().and_then(|m| m.report.volume.clone());
    report.warnings.extend(volume.iter().flat_map(|v| v.warnings()));
    let line_spacing = volume.as_ref().and_then(|v| v.spacing);
    let crop = &volume.map_or(*crop, |v| v.crop(crop));

    // Register.
    if params.until >= Stage::Register {
        // A laser scan registers laser against laser: it needs two lasers' lines.
        let enough = match method {
            Method::Laser => outputs.iter().filter_map(|o| o.laser).max().is_some_and(|k| k >= 1),
            _ => outputs.len() >= 2,
        };
        match (method, rig.turntable.as_ref()) {
            (_, Some(axis)) if enough => {
                let t = Instant::now();
                let fp = grid_inputs(
                    Fingerprint::new(json!({
                        "crop": crop,
                        "register": params.register,
                        "rig.turntable": rig_part(&rig.turntable),
                    })),
                    &outputs,
                );
                let decision = match o.decide(layout::REGISTERED, &fp) {
                    Decision::Reuse(rec) => match o.decide(layout::POSES, &fp) {
                        Decision::Reuse(_) => Decision::Reuse(rec),
                        run => run,
                    },
                    run => run,
                };
                match &decision {
                    Decision::Reuse(rec) => {
                        let rr: stages::RegisterReport = recorded(&rec.report);
                        report.warnings.extend(register_check(&rr, params)?);
                        report.register = Some(stage_section(&decision, 0.0, rr));
                        (cloud_hash, cloud) = (rec.hash, None);
                    }
                    Decision::Run(_) => {
                        // Registration starts from the grids; the merged cloud is on disk.
                        drop(cloud.take());
                        load_grids(o, &mut outputs)?;
                        let (registered, poses, rr) =
                            stages::register(&view_grids(&outputs), axis, crop, &params.register)
                                .map_err(|source| Error::Stage { stage: Stage::Register, source })?;
                        // Checked before anything is written: an unforced implausible registration
                        // leaves the folder as the merge left it.
                        report.warnings.extend(register_check(&rr, params)?);
                        let (registered, hash) = o.put_cloud(layout::REGISTERED, &registered, fp.clone(), &rr, true)?;
                        o.put(layout::POSES, &stages::poses_json(&poses), fp, &rr)?;
                        report.register = Some(stage_section(&decision, t.elapsed().as_secs_f64(), rr));
                        (cloud_hash, cloud) = (hash, Some(registered));
                    }
                }
                cloud_name = layout::REGISTERED;
                report.outputs.push(layout::REGISTERED.into());
                report.outputs.push(layout::POSES.into());
                o.save()?;
                progress(Stage::Register, 1, 1);
            }
            (Method::StructuredLight, Some(_)) => report.skipped.push("register: needs at least two views".into()),
            (_, None) => report.skipped.push("register: the rig has no [turntable] to start from".into()),
            _ => report.skipped.push(
                "register: one laser's lines only: a line alone fixes no pose, and there is no second laser to check \
                 it against"
                    .into(),
            ),
        }
    }
    drop(outputs);
    if params.until < Stage::Fuse {
        return Ok(());
    }

    // Fuse.
    let t = Instant::now();
    let fp = Fingerprint::new(json!({ "fuse": params.fuse })).input(cloud_name, cloud_hash);
    let decision = o.decide(layout::FUSED, &fp);
    let (fused_hash, mut fused) = match &decision {
        Decision::Reuse(rec) => {
            report.fuse = Some(stage_section(&decision, 0.0, recorded(&rec.report)));
            (rec.hash, None)
        }
        Decision::Run(_) => {
            let input = match cloud.take() {
                Some(c) => c,
                None => rig::read_cloud(&o.path(cloud_name))?,
            };
            // Progress from inside: the samples whose shift has begun, out of all of them.
            let (total, fp_params) = (input.len(), &params.fuse);
            let (result, fr) = super::watch::watched(
                total,
                |moved| stages::fuse_counting(input, fp_params, moved),
                |done, total| progress(Stage::Fuse, done, total),
            )
            .map_err(|source| Error::Stage { stage: Stage::Fuse, source })?;
            let (fused, hash) = o.put_cloud(layout::FUSED, &result.cloud, fp, &fr, true)?;
            report.fuse = Some(stage_section(&decision, t.elapsed().as_secs_f64(), fr));
            (hash, Some(fused))
        }
    };
    report.outputs.push(layout::FUSED.into());
    o.save()?;
    progress(Stage::Fuse, 1, 1);
    if params.until < Stage::Reconstruct {
        return Ok(());
    }

    // Close: flat caps over the open base and top, in the object frame a turntable gives.
    let (input_name, input_hash, mut input_cloud) = match (&params.close, rig.turntable.is_some()) {
        (Some(cp), true) => {
            let t = Instant::now();
            let fp = Fingerprint::new(json!({ "close": cp })).input(layout::FUSED, fused_hash);
            let decision = o.decide(layout::CLOSED, &fp);
            let made = match &decision {
                Decision::Reuse(rec) => {
                    report.close = Some(stage_section(&decision, 0.0, recorded(&rec.report)));
                    (layout::CLOSED, rec.hash, None)
                }
                Decision::Run(_) => {
                    let input = match fused.take() {
                        Some(c) => c,
                        None => rig::read_cloud(&o.path(layout::FUSED))?,
                    };
                    let (closed, cr) = crate::reconstruct::closing::close_openings(&input, cp);
                    let (closed, hash) = o.put_cloud(layout::CLOSED, &closed, fp, &cr, true)?;
                    report.close = Some(stage_section(&decision, t.elapsed().as_secs_f64(), cr));
                    (layout::CLOSED, hash, Some(closed))
                }
            };
            report.outputs.push(layout::CLOSED.into());
            o.save()?;
            made
        }
        (Some(_), false) => {
            report.skipped.push("close: the rig has no [turntable], so no platter and no up to cap by".into());
            (layout::FUSED, fused_hash, fused.take())
        }
        (None, _) => (layout::FUSED, fused_hash, fused.take()),
    };

    // Reconstruct.
    let t = Instant::now();
    // The platter plane, where the base is cut: object z = 0 on a turntable.
    let platter_z = rig.turntable.is_some().then_some(0.0);
    // The working volume's top (the object's, as the merge found it): no surface above it.
    let top_z = crop.max_height_mm.filter(|_| rig.turntable.is_some());
    let fp = Fingerprint::new(json!({
        "reconstruct": params.reconstruct,
        "finish": params.finish,
        "platter_z": platter_z,
        "top_z": top_z,
    }))
    .input(input_name, input_hash);
    let decision = o.decide(layout::MESH, &fp);
    // The mesh as written (normals, colours), for its copies in other formats.
    let mut written_mesh: Option<rig::PolyMesh> = None;
    let (mesh_hash, mut mesh) = match &decision {
        Decision::Reuse(rec) => {
            let r: Option<stages::MeshReport> = serde_json::from_value(rec.report.clone()).ok();
            report.reconstruct = r.map(|r| stage_section(&decision, 0.0, r));
            (rec.hash, None)
        }
        Decision::Run(_) => {
            let input = match input_cloud.take() {
                Some(c) => c,
                None => rig::read_cloud(&o.path(input_name))?,
            };
            // One k-d tree over the samples serves the area weights, the support check and the
            // colours (each built its own: three serial builds over 2.8 M points on the demo).
            let tree = crate::kd_tree::PointTree::new(&input.positions);
            let (mesh, rr) = stages::reconstruct_in(&input, &params.reconstruct, Some(&tree))
                .map_err(|source| Error::Stage { stage: Stage::Reconstruct, source })?;
            let (mut mesh, mut finish) = stages::finish(mesh, &input, &params.finish, platter_z, rr.cell())
                .map_err(|source| Error::Stage { stage: Stage::Reconstruct, source })?;
            if let Some(z) = top_z {
                let high = mesh.vertices.iter().map(|p| p.z).fold(Real::NEG_INFINITY, Real::max);
                let cut = crate::reconstruct::top_cut::cut_top(&mesh, z)
                    .map_err(|e| Error::Stage { stage: Stage::Reconstruct, source: e.into() })?;
                if let Some((cut, r)) = cut {
                    // A millimetre of the low-pass's rounding is the reconstruction's own: recorded, not warned of.
                    if high > z + 1.0 {
                        report.warnings.push(format!(
                        "mesh.ply: the reconstruction rose to {high:.1} mm, above the working volume's top at {z:.1} mm \
                         (the object's top as the merge found it): cut flat there ({} triangles removed)",
                        r.removed
                    ));
                    }
                    (mesh, finish.top) = (cut, Some(r));
                }
            }
            if let Some(b) = finish.base.filter(|b| b.outline_edges == 0) {
                report.warnings.push(format!(
                    "mesh.ply: the mesh does not reach {} mm above the platter, so its base was not cut ({:?}): \
                     the object seems not to stand on the platter (check the rig's [turntable])",
                    b.z + b.skirt,
                    b.base
                ));
            }
            if let Some(b) = finish.base.filter(|b| b.base == stages::Base::Flat && !b.closed) {
                report.warnings.push(format!(
                    "mesh.ply: the flat base at z = {} did not close the mesh ({} outline edges capped by {} triangles); \
                     slicers may refuse it (--base open or closed to choose otherwise)",
                    b.z, b.outline_edges, b.cap_triangles
                ));
            }
            // Checked before the mesh is written: unforced, an unsupported mesh leaves no mesh.ply.
            let support = stages::check_support(&mesh, &input, &tree, params.force).map_err(|source| {
                // A laser scan's surface between its lines is only what reconstruction makes up: too
                // few views is the usual cause, and the fix.
                let views = report.views.len();
                let source = match (source, method) {
                    (stages::StageError::Implausible { what, hint }, Method::Laser) => stages::StageError::Implausible {
                        what,
                        hint: format!(
                            "this laser scan's {} views put its lines {:.1}° apart: take more views (`scan --views`, \
                             `sim --views`); or {hint}",
                            views,
                            360.0 / views.max(1) as Real
                        ),
                    },
                    (other, _) => other,
                };
                Error::Stage { stage: Stage::Reconstruct, source }
            })?;
            report.warnings.extend(support);
            let colours = stages::mesh_colours(&mesh, &input, &tree);
            drop(tree);
            let poly = stages::mesh_for_output(&mesh, colours);
            let bytes = rig::ply::mesh_to_bytes(&poly, &o.object_opts());
            written_mesh = Some(poly);
            let rr = stages::MeshReport { reconstruct: rr, finish };
            let hash = o.put(layout::MESH, &bytes, fp, &rr)?;
            let back = rig::ply::parse(&bytes).and_then(|p| rig::ply::mesh_from_ply(&p));
            let back = back.map_err(|e| e.with_path(&o.path(layout::MESH)))?.triangulate();
            if let stages::ReconstructReport::Adfft(a) = &rr.reconstruct
                && a.self_intersections.remaining > 0
            {
                report.warnings.push(format!(
                    "mesh.ply still intersects itself in {} triangle pairs after repair; slicers may refuse it",
                    a.self_intersections.remaining
                ));
            }
            report.reconstruct = Some(stage_section(&decision, t.elapsed().as_secs_f64(), rr));
            (hash, Some(back))
        }
    };
    // A laser scan's lines far apart for this mesh's cell: ribs, said whether the mesh ran or was reused.
    let cell = report.reconstruct.as_ref().map(|r| r.report.reconstruct.cell());
    if let (Some(s), Some(cell)) = (line_spacing, cell) {
        report.warnings.extend(s.warning(cell, params.reconstruct.depth()));
    }
    report.outputs.push(layout::MESH.into());
    // The same surface for printing (binary STL) and for web viewers (GLB).
    let held = written_mesh.take();
    o.export(layout::MESH_STL, (layout::MESH, mesh_hash), held.as_ref(), rig::stl::mesh_to_binary)?;
    o.export(layout::MESH_GLB, (layout::MESH, mesh_hash), held.as_ref(), rig::glb::mesh_to_bytes)?;
    report.outputs.extend([layout::MESH_STL.into(), layout::MESH_GLB.into()]);
    // Whoever follows the run (the report page's scene) may read the clouds as soon as it is told.
    o.finish_writes()?;
    o.save()?;
    progress(Stage::Reconstruct, 1, 1);
    if params.until < Stage::Remesh {
        return Ok(());
    }

    // Remesh.
    let t = Instant::now();
    let fp = Fingerprint::new(json!({ "remesh": params.remesh })).input(layout::MESH, mesh_hash);
    let decision = o.decide(layout::QUADS, &fp);
    let (quads_hash, quads) = match &decision {
        Decision::Reuse(rec) => {
            report.remesh = Some(stage_section(&decision, 0.0, recorded(&rec.report)));
            (rec.hash, None)
        }
        Decision::Run(_) => {
            let input = match mesh.take() {
                Some(m) => m,
                None => rig::read_mesh(&o.path(layout::MESH))?.triangulate(),
            };
            // Progress from inside: the remesh's phases (fields and streamlines, quads, quality).
            let rp = &params.remesh;
            let (quads, rr) = super::watch::watched(
                crate::remesh::quad_remesh::REMESH_PHASES,
                |phases| stages::remesh_counting(&input, rp, phases),
                |done, total| progress(Stage::Remesh, done, total),
            )
            .map_err(|source| Error::Stage { stage: Stage::Remesh, source })?;
            let hash = o.put(layout::QUADS, &rig::obj::mesh_to_bytes(&quads), fp, &rr)?;
            report.remesh = Some(stage_section(&decision, t.elapsed().as_secs_f64(), rr));
            (hash, Some(quads))
        }
    };
    // PLY as well: Open3D's OBJ reader skips polygons unless asked to triangulate; its PLY reader keeps them.
    let opts = o.opts.clone();
    o.export(layout::QUADS_PLY, (layout::QUADS, quads_hash), quads.as_ref(), |m| rig::ply::mesh_to_bytes(m, &opts))?;
    report.outputs.extend([layout::QUADS.into(), layout::QUADS_PLY.into()]);
    progress(Stage::Remesh, 1, 1);
    Ok(())
}

/// The plausibility check of a registration (run or reused), as a pipeline error.
fn register_check(rr: &stages::RegisterReport, params: &ProcessParams) -> Result<Vec<String>, Error> {
    rr.check(&params.register.tolerance, params.force).map_err(|source| Error::Stage { stage: Stage::Register, source })
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
    stages::register(&views, &axis, &crop, params).map_err(|source| Error::Stage { stage: Stage::Register, source })
}
