//! The open output folder of a `process` run, and the one mechanism every stage goes through
//! ([`Out::step`]): decide from the records whether its output can be reused, else run it, write its
//! outputs atomically and record how they were made, and give the stage's report section.

use super::layout::Layout;
use super::records::{Decision, Fingerprint, Hash, Records, StageCode};
use super::report::Section;
use crate::Error;
use rig::math::Real;
use rig::ply::WriteOptions;
use rig::{PointCloud, RangeGrid, SparseView};
use serde::Serialize;
use serde::de::DeserializeOwned;
use serde_json::json;
use std::path::PathBuf;
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::time::Instant;

/// Copies of an output in another format (mesh.stl of mesh.ply, …): their code version.
pub const EXPORT: StageCode = StageCode { stage: "export", version: 1 };

/// What a step gave: its main output's content hash, what the output holds where it was made in this
/// run (else read from the file when a later step needs it), and its report section (`None` only
/// for a reused output whose record's report this version cannot read).
pub(super) struct Stepped<T, R> {
    pub hash: Hash,
    pub held: Option<T>,
    pub section: Option<Section<R>>,
}

impl<T, R> Stepped<T, R> {
    /// True when the output was reused.
    pub fn reused(&self) -> bool {
        self.section.as_ref().is_none_or(|s| s.reused)
    }
}

/// Whether a step is a view's (many, small) or the scan's (one each, large).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Scope {
    View,
    Scan,
}

/// The open output folder: where files go, what is recorded of them, how they are written.
pub(super) struct Out {
    pub(super) layout: Layout,
    /// Behind a lock: views write their outputs from several threads, and clouds are written on
    /// threads of their own ([`Out::put_behind`]).
    pub(super) records: Arc<Mutex<Records>>,
    /// Writes still under way ([`Out::put_behind`]), each with its file's path.
    pub(super) pending: Mutex<Vec<PendingWrite>>,
    pub(super) opts: WriteOptions,
    /// The rig has a turntable: clouds and meshes are in its object frame.
    pub(super) turntable: bool,
}

/// A file being written on a thread of its own, and its path (to name in an error).
type PendingWrite = (PathBuf, std::thread::JoinHandle<Result<(), rig::Error>>);

impl Out {
    pub(super) fn path(&self, name: &str) -> PathBuf {
        self.layout.path(name)
    }

    pub(super) fn records(&self) -> MutexGuard<'_, Records> {
        self.records.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Whether `name` can be reused for `fp` ([`Records::decide`]); the file is hashed outside the
    /// lock, so views deciding at once do not queue behind each other's reads.
    pub(super) fn decide(&self, name: &str, fp: &Fingerprint) -> Decision {
        let decider = self.records().decider(name);
        decider.decide(fp)
    }

    /// Writes the records as they stand.
    pub(super) fn save(&self) -> Result<(), Error> {
        Ok(self.records().save()?)
    }

    /// Writes `bytes` as `name` atomically and records how it was made; returns the content hash.
    pub(super) fn put(
        &self,
        name: &str,
        bytes: &[u8],
        fp: Fingerprint,
        report: &impl Serialize,
    ) -> Result<Hash, Error> {
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
    pub(super) fn put_behind(
        &self,
        name: &str,
        bytes: Vec<u8>,
        fp: Fingerprint,
        report: &impl Serialize,
    ) -> Result<Hash, Error> {
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
    pub(super) fn finish_writes(&self) -> Result<(), Error> {
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

    pub(super) fn put_grid(
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
    pub(super) fn put_cloud(
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
    pub(super) fn object_opts(&self) -> WriteOptions {
        let mut opts = self.opts.clone();
        if self.turntable {
            opts.comments.push(rig::ply::TURNTABLE_FRAME.into());
        }
        opts
    }

    pub(super) fn put_sparse(
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

    pub(super) fn read_grid(&self, name: &str) -> Result<RangeGrid, Error> {
        Ok(rig::ply::read_range_grid(&self.path(name))?)
    }

    /// Writes `name`, a copy of `source` in another format (mesh.stl of mesh.ply, …), unless the one
    /// there was made from these very bytes; `make` gets what the source holds (read from the file when
    /// the caller has not got it) and gives the copy's bytes.
    pub(super) fn export(
        &self,
        name: &str,
        source: (&str, Hash),
        held: Option<&rig::PolyMesh>,
        make: impl Fn(&rig::PolyMesh) -> Vec<u8>,
    ) -> Result<(), Error> {
        let fp = Fingerprint::new(EXPORT, json!({ "export": name })).input(source.0, source.1);
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

/// [`section`] for a scan stage: what the stage freed is handed back to the system first, so the
/// next stage's peak starts from what is still held (a view's sections skip it: 108 trims cost more
/// than they give back).
pub(super) fn stage_section<T>(decision: &Decision, seconds: Real, report: T) -> Section<T> {
    super::memory::release_freed();
    section(decision, seconds, report)
}

pub(super) fn section<T>(decision: &Decision, seconds: Real, report: T) -> Section<T> {
    // The peak since the previous section: this stage's (views and reading its inputs included).
    let peak_mb = super::memory::take_peak_mb();
    Section { reused: decision.reused(), reason: decision.reason().map(str::to_string), seconds, peak_mb, report }
}

impl Out {
    /// The one way a stage runs in `process`. Decides from the records whether the outputs `names`
    /// (the first is the one handed on) can be reused for `fp` — all of them, or the stage runs;
    /// reused, the section carries the recorded report; else `run(fp)` makes the outputs, writes
    /// them through the `put` methods (atomic, recorded) and returns what the first holds, its hash
    /// and the stage's report. Either way the section is timed (deciding and reading included) with
    /// the stage's memory peak; a scan stage hands what it freed back to the system first.
    pub(super) fn step<T, R: DeserializeOwned>(
        &self,
        names: &[&str],
        fp: Fingerprint,
        scope: Scope,
        run: impl FnOnce(Fingerprint) -> Result<(T, Hash, R), Error>,
    ) -> Result<Stepped<T, R>, Error> {
        let t = Instant::now();
        let mut decision = Decision::Run(String::new());
        for (i, name) in names.iter().enumerate() {
            decision = match (i, self.decide(name, &fp), decision) {
                (0, d, _) => d,
                (_, Decision::Reuse(_), first @ Decision::Reuse(_)) => first,
                (_, Decision::Run(why), Decision::Reuse(_)) => Decision::Run(why),
                (_, _, run) => run,
            };
        }
        let close = |decision: &Decision, seconds: Real, report: R| match scope {
            Scope::Scan => stage_section(decision, seconds, report),
            Scope::View => section(decision, seconds, report),
        };
        // A record whose report no longer reads (written by a build that wrote what this one cannot
        // read) is made again: reused without its report, the checks made on it would be skipped.
        let recorded = match &decision {
            Decision::Reuse(rec) => Some((rec.hash, serde_json::from_value::<R>(rec.report.clone()))),
            Decision::Run(_) => None,
        };
        match recorded {
            Some((hash, Ok(report))) => {
                let section = Some(close(&decision, t.elapsed().as_secs_f64(), report));
                return Ok(Stepped { hash, held: None, section });
            }
            Some((_, Err(e))) => decision = Decision::Run(format!("its recorded report does not read ({e})")),
            None => {}
        }
        let (held, hash, report) = run(fp)?;
        let section = Some(close(&decision, t.elapsed().as_secs_f64(), report));
        Ok(Stepped { hash, held: Some(held), section })
    }
}
