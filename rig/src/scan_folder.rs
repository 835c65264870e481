//! The scan folder: what a capture session (real or simulated) writes and the pipeline reads.
//!
//! ```text
//! scan/
//!   scan.json                 the manifest (below), written atomically at the start and the end
//!   scan.progress             while a scan runs: the views completed since, one index per line
//!   rig.toml                  the rig the scan was taken with
//!   frames/view_000/00_white.png, 01_black.png, 02_gray_col_00.png, …
//!   truth/                    simulator only: object.ply (object frame), view_000/depth.npy, …
//! ```
//!
//! The manifest, field by field (`scan.json`):
//! - `format`: this layout's version, [`SCAN_FORMAT`];
//! - `method`: `structured_light`, `laser` or `board` (calibration captures of a chessboard);
//! - `rig`: the rig file, relative to the folder;
//! - `source`: who wrote the scan (`simulator`, `acquire`);
//! - `seed`: the simulator's noise seed, where there is one;
//! - `views`: one entry per turntable step or board pose, each with `angle_deg` (turntable angle, counter-
//!   clockwise seen from above), `frames` (relative `file` and the [`Pattern`] it shows) and `complete`
//!   (false until every frame of the view is on disk, so an interrupted scan resumes at the first
//!   incomplete view), and `pass` (absent for 1: see below).
//!
//! **Passes.** An object scanned, turned over (on its side, upside down) and scanned again is one scan
//! with several passes: each view says which (`pass`, counted from 1, absent for the first), the
//! passes' views follow each other (all of pass 1, then all of pass 2), each pass its own turntable
//! program, and view numbers run on across passes (`frames/view_036` is pass 2's first view of a
//! 36-view program). `process` registers each pass from its turntable poses, then aligns the passes
//! with each other by their shape (the object was placed by hand: no pose is known).
//!
//! Completing a view appends its index to `scan.progress` (a few bytes, flushed to disk) instead of
//! rewriting `scan.json`, whose size grows with the views: rewriting it after each of n views cost
//! time in n² (a thousand-view scan spent most of its time renaming a 12 MB manifest). Reading a
//! folder applies the journal, so an interrupted scan resumes where it stopped; writing the manifest
//! folds the journal in and removes it.

use crate::error::{Error, Location, ParseError, Problem};
use crate::patterns::Pattern;
use crate::run_files::{read_bytes, write_atomic};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The manifest's file name inside a scan folder.
pub const MANIFEST_NAME: &str = "scan.json";
/// The journal of views completed since the manifest was written (see the module doc).
pub const PROGRESS_NAME: &str = "scan.progress";
/// The scan-folder format this code reads and writes.
pub const SCAN_FORMAT: u32 = 1;

/// Every path inside a scan folder, spelled once (relative to the folder): each view's frames and
/// the simulator's truth (the manifest and its journal are [`MANIFEST_NAME`] and [`PROGRESS_NAME`]).
/// The simulator, a capture session and the importers write these; `process` reads them through the
/// manifest.
pub struct ScanLayout;

impl ScanLayout {
    /// View `v`'s frame folder.
    pub fn frames(v: usize) -> String {
        format!("frames/view_{v:03}")
    }

    /// Frame `f` of view `v`, showing `pattern`.
    pub fn frame(v: usize, f: usize, pattern: &Pattern) -> String {
        format!("{}/{f:02}_{}.png", Self::frames(v), pattern.name())
    }

    /// View `v`'s ground truth (a simulated scan's).
    pub fn truth(v: usize) -> String {
        format!("truth/view_{v:03}")
    }
}

/// How the scan was captured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Camera + projector.
    StructuredLight,
    /// Camera + line lasers.
    Laser,
    /// Chessboard captures for calibration.
    Board,
}

/// One captured frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Frame {
    /// The PNG, relative to the scan folder.
    pub file: String,
    /// What the frame shows.
    pub pattern: Pattern,
}

/// One view: a turntable step or a board pose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct View {
    /// Turntable angle (degrees, counter-clockwise seen from above).
    pub angle_deg: f64,
    /// The frames in capture order.
    pub frames: Vec<Frame>,
    /// True once every frame is written.
    pub complete: bool,
    /// Calibration captures: the board was held in front of the camera, off the turntable, so the
    /// angle says nothing about its pose (absent, false, for turntable views).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub held: bool,
    /// The pass this view belongs to, from 1 (see the module doc; absent in the file for pass 1).
    #[serde(default = "first_pass", skip_serializing_if = "is_first_pass")]
    pub pass: u32,
}

fn first_pass() -> u32 {
    1
}

fn is_first_pass(p: &u32) -> bool {
    *p == 1
}

/// Most passes a scan may hold: an object has six sides to lie on.
pub const MAX_PASSES: u32 = 6;

/// The scan manifest (see the module doc for the file).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Layout version.
    pub format: u32,
    /// Capture method.
    pub method: Method,
    /// Rig file, relative to the folder.
    pub rig: String,
    /// Who wrote the scan.
    pub source: String,
    /// Noise seed of a simulated scan.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// The views.
    pub views: Vec<View>,
}

/// The view indices a `scan.progress` journal lists, each below `views`. A last line without its
/// newline is an append cut short by a crash and is ignored (its view is simply taken again).
pub fn parse_progress(bytes: &[u8], views: usize) -> Result<Vec<usize>, ParseError> {
    let mut done = Vec::new();
    let mut rest = bytes;
    let mut line = 0;
    while let Some(end) = rest.iter().position(|&b| b == b'\n') {
        line += 1;
        let text = std::str::from_utf8(&rest[..end]).unwrap_or("");
        let bad = |what: String| ParseError::new(Location::Line(line), Problem::Invalid(what));
        let v: usize = text.trim().parse().map_err(|_| {
            bad(format!("`{}` is not a view index", text.chars().take(40).collect::<String>().escape_debug()))
        })?;
        if v >= views {
            return Err(bad(format!("view {v} is not in the scan ({views} views)")));
        }
        done.push(v);
        rest = &rest[end + 1..];
    }
    Ok(done)
}

impl Manifest {
    /// A new scan's manifest: one incomplete view per angle, each with the frames of `patterns`
    /// named `frames/view_NNN/FF_<pattern>.png` — the layout the simulator and capture sessions share,
    /// so their folders are interchangeable frame for frame.
    pub fn fresh(
        method: Method,
        source: &str,
        seed: Option<u64>,
        angles: &[f64],
        patterns: &[crate::Pattern],
    ) -> Manifest {
        Manifest {
            format: SCAN_FORMAT,
            method,
            rig: "rig.toml".into(),
            source: source.into(),
            seed,
            views: angles
                .iter()
                .enumerate()
                .map(|(v, &angle_deg)| View {
                    angle_deg,
                    frames: patterns
                        .iter()
                        .enumerate()
                        .map(|(f, p)| Frame { file: ScanLayout::frame(v, f, p), pattern: *p })
                        .collect(),
                    complete: false,
                    held: false,
                    pass: 1,
                })
                .collect(),
        }
    }

    /// Passes in the scan (1 for a scan without a `pass` field).
    pub fn passes(&self) -> u32 {
        self.views.iter().map(|v| v.pass).max().unwrap_or(1)
    }

    /// `more` views of a further pass appended: numbered on from the last view, each with the same
    /// frames (patterns) as `fresh` lays out, for pass `pass`.
    pub fn append_pass(&mut self, pass: u32, angles: &[f64], patterns: &[crate::Pattern]) {
        let first = self.views.len();
        let fresh = Manifest::fresh(self.method, &self.source, self.seed, angles, patterns);
        self.views.extend(fresh.views.into_iter().enumerate().map(|(k, mut v)| {
            let n = first + k;
            for (f, frame) in v.frames.iter_mut().enumerate() {
                frame.file = ScanLayout::frame(n, f, &frame.pattern);
            }
            v.pass = pass;
            v
        }));
    }

    /// Parses manifest JSON.
    pub fn from_json(bytes: &[u8]) -> Result<Manifest, ParseError> {
        let m: Manifest = serde_json::from_slice(bytes)
            .map_err(|e| ParseError::new(Location::Line(e.line()), Problem::Syntax(e.to_string())))?;
        if m.format != SCAN_FORMAT {
            let msg = format!("scan format {} is not supported (this scanrig reads {SCAN_FORMAT})", m.format);
            return Err(ParseError::new(Location::Field("format".into()), Problem::Invalid(msg)));
        }
        let relative = |p: &str| {
            let p = Path::new(p);
            !p.is_absolute() && !p.components().any(|c| matches!(c, std::path::Component::ParentDir))
        };
        if !relative(&m.rig) {
            let msg = format!("rig file `{}` must be a relative path inside the scan folder", m.rig);
            return Err(ParseError::new(Location::Field("rig".into()), Problem::Invalid(msg)));
        }
        // Passes from 1, each after the one before, none skipped: a view of pass 3 before pass 2's, or
        // a pass 0, is a manifest no capture writes.
        let mut last = 0;
        for (i, v) in m.views.iter().enumerate() {
            if v.pass == 0 || !(v.pass == last || v.pass == last + 1) || v.pass > MAX_PASSES {
                let after = if last == 0 { "opens the scan".to_string() } else { format!("follows pass {last}") };
                let msg = format!(
                    "pass {} {after}: passes count from 1 up to {MAX_PASSES}, each after the one before",
                    v.pass
                );
                return Err(ParseError::new(Location::Field(format!("views[{i}].pass")), Problem::Invalid(msg)));
            }
            last = v.pass;
        }
        let mut owner: std::collections::HashMap<&str, usize> = std::collections::HashMap::new();
        for (i, v) in m.views.iter().enumerate() {
            let max = crate::limits::MAX_ABS_ANGLE_DEG;
            if !(v.angle_deg.is_finite() && v.angle_deg.abs() <= max) {
                let msg = format!("{} is not a turntable angle (finite, within ±{max} degrees)", v.angle_deg);
                return Err(ParseError::new(Location::Field(format!("views[{i}].angle_deg")), Problem::Invalid(msg)));
            }
            for f in &v.frames {
                let p = Path::new(&f.file);
                if p.is_absolute() || p.components().any(|c| matches!(c, std::path::Component::ParentDir)) {
                    let msg = format!("frame file `{}` must be a relative path inside the scan folder", f.file);
                    return Err(ParseError::new(Location::Field(format!("views[{i}].frames")), Problem::Invalid(msg)));
                }
            }
            // A file another view lists (a view copied in twice): its frames would be registered at
            // two angles, and the error came from deep in registration ("the target has no points").
            for f in &v.frames {
                if let Some(j) = owner.get(f.file.as_str()).filter(|&&j| j != i) {
                    let msg = format!("frame file `{}` is view {j}'s too: a view listed twice?", f.file);
                    return Err(ParseError::new(Location::Field(format!("views[{i}].frames")), Problem::Invalid(msg)));
                }
                owner.insert(&f.file, i);
            }
            // A file listed twice, or two files for one pattern: one of them would be decoded as a frame it
            // is not (or ignored).
            for (k, f) in v.frames.iter().enumerate() {
                if let Some(e) = v.frames[..k].iter().find(|e| e.file == f.file || e.pattern == f.pattern) {
                    let msg = if e.file == f.file {
                        format!("frame file `{}` is listed twice", f.file)
                    } else {
                        format!("`{}` and `{}` both show {}", e.file, f.file, f.pattern.name())
                    };
                    return Err(ParseError::new(Location::Field(format!("views[{i}].frames")), Problem::Invalid(msg)));
                }
            }
        }
        Ok(m)
    }

    /// Reads `scan.json` from a scan folder, with the views its `scan.progress` journal completes.
    ///
    /// The journal is read first. A capture folds it into `scan.json` at the end ([`Manifest::write`]:
    /// the new `scan.json` in place, then the journal removed), while the station's live view reads
    /// the manifest of the view just captured: reading `scan.json` first, a reader could get the
    /// manifest before the fold and then find the journal gone, and the last view incomplete. Read in
    /// this order, either the journal holds the view or the `scan.json` read after it does.
    pub fn read(dir: &Path) -> Result<Manifest, Error> {
        let journal = dir.join(PROGRESS_NAME);
        // Gone between the look and the read: folded, as above.
        let progress = match journal.is_file().then(|| read_bytes(&journal)) {
            Some(Err(_)) if !journal.exists() => None,
            other => other.transpose()?,
        };
        let path = dir.join(MANIFEST_NAME);
        let mut m = Manifest::from_json(&read_bytes(&path)?).map_err(|e| e.with_path(&path))?;
        if let Some(bytes) = progress {
            let done = parse_progress(&bytes, m.views.len()).map_err(|e| e.with_path(&journal))?;
            for v in done {
                m.views[v].complete = true;
            }
        }
        Ok(m)
    }

    /// Writes `scan.json` atomically (a crash leaves the previous manifest, never half of one); it
    /// then holds every completed view, so the journal is removed.
    pub fn write(&self, dir: &Path) -> Result<(), Error> {
        let json = serde_json::to_vec_pretty(self).expect("a manifest always serialises");
        write_atomic(&dir.join(MANIFEST_NAME), &json)?;
        let journal = dir.join(PROGRESS_NAME);
        match std::fs::remove_file(&journal) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(Error::io(&journal, e)),
            _ => Ok(()),
        }
    }

    /// Marks view `v` complete, here and on disk: its index is appended to the journal and flushed,
    /// which costs the same at the thousandth view as at the first. [`Manifest::write`] at the end
    /// folds the journal into `scan.json`.
    pub fn complete_view(&mut self, dir: &Path, v: usize) -> Result<(), Error> {
        use std::io::Write;
        let journal = dir.join(PROGRESS_NAME);
        let io = |e| Error::io(&journal, e);
        let mut f = std::fs::OpenOptions::new().create(true).append(true).open(&journal).map_err(io)?;
        f.write_all(format!("{v}\n").as_bytes()).map_err(io)?;
        f.sync_data().map_err(io)?;
        self.views[v].complete = true;
        Ok(())
    }

    /// The first view not yet complete: where an interrupted scan resumes.
    pub fn first_incomplete(&self) -> Option<usize> {
        self.views.iter().position(|v| !v.complete)
    }

    /// The absolute path of a frame.
    pub fn frame_path(dir: &Path, frame: &Frame) -> PathBuf {
        dir.join(&frame.file)
    }

    /// `dir.join(relative)` after checking that it stays inside the scan folder `dir` once symbolic
    /// links are followed (a `frames/` linked elsewhere, a frame linked to a file outside): nothing a
    /// scan folder names may lead a reader out of it. A path that does not exist is returned as it is
    /// (reading it then says it is missing). `field` names the manifest field for the error.
    pub fn inside(dir: &Path, relative: &str, field: &str) -> Result<PathBuf, Error> {
        let path = dir.join(relative);
        let (Ok(root), Ok(real)) = (dir.canonicalize(), path.canonicalize()) else { return Ok(path) };
        if real.starts_with(&root) {
            Ok(path)
        } else {
            let msg = format!("`{relative}` leads outside the scan folder (a symbolic link?), to {}", real.display());
            Err(ParseError::new(Location::Field(field.into()), Problem::Invalid(msg))
                .with_path(&dir.join(MANIFEST_NAME)))
        }
    }
}
