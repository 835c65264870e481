//! Deciding reuse: every output of `process` is recorded in `processed/stages.json` with the
//! fingerprint of what made it — the scanrig version, the stage's parameters and the content hashes
//! of its inputs — and the content hash of the file itself. A stage is reused only when both still
//! match; otherwise it runs again and the reason is reported ("crop.radius_mm changed", "rig.toml's
//! camera changed", "the file was changed since it was written").
//!
//! File times decide nothing: a rig edited and given an old time, or a parameter changed between
//! runs, still reruns exactly the stages it affects.

use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The records file inside the output folder.
pub const RECORDS_NAME: &str = "stages.json";
/// Its layout version.
pub const RECORDS_FORMAT: u32 = 1;

/// The reason a stage runs when its output does not exist yet (a first run).
pub const NOT_MADE_YET: &str = "not made yet";

/// A 128-bit content hash (XXH3), as 32 hex digits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct Hash(pub u128);

impl Hash {
    /// The hash of some bytes.
    pub fn of(bytes: &[u8]) -> Hash {
        Hash(xxhash_rust::xxh3::xxh3_128(bytes))
    }

    /// The hash of a file's content; `None` when it cannot be read.
    pub fn of_file(path: &Path) -> Option<Hash> {
        // Only a regular file: a FIFO or a device is "cannot be read", not waited on.
        rig::input::read_regular(path, None).ok().map(|b| Hash::of(&b))
    }

    fn hex(self) -> String {
        format!("{:032x}", self.0)
    }
}

impl Serialize for Hash {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.hex())
    }
}

impl<'de> Deserialize<'de> for Hash {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        u128::from_str_radix(&s, 16).map(Hash).map_err(serde::de::Error::custom)
    }
}

/// A stage and the version of its code. Each stage declares its own next to its function
/// (`pipeline::stages`); a change to a stage that alters what it writes for the same inputs raises
/// that stage's version, so its outputs — and only its, and what follows from them — are made again.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StageCode {
    /// The stage's name, as the report and the records say it.
    pub stage: &'static str,
    /// Its code version.
    pub version: u32,
}

/// What made an output: the stage and its code version, its parameters (any JSON) and its inputs by
/// name and content hash.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Fingerprint {
    /// The scanrig version that wrote the output.
    pub version: String,
    /// The stage that made it (empty in records older than stage code versions).
    #[serde(default)]
    pub stage: String,
    /// That stage's code version ([`StageCode`]; 0 in older records, so they are made again once).
    #[serde(default)]
    pub code_version: u32,
    /// The stage's parameters, as they affect the output.
    pub params: Value,
    /// Inputs: a name (a frame, `rig.toml`, an upstream output) and the hash of its content.
    pub inputs: BTreeMap<String, Hash>,
}

impl Fingerprint {
    /// A fingerprint of stage `code` with the running version.
    pub fn new(code: StageCode, params: Value) -> Self {
        Fingerprint {
            version: env!("CARGO_PKG_VERSION").to_string(),
            stage: code.stage.to_string(),
            code_version: code.version,
            params,
            inputs: BTreeMap::new(),
        }
    }

    /// Adds an input.
    pub fn input(mut self, name: impl Into<String>, hash: Hash) -> Self {
        self.inputs.insert(name.into(), hash);
        self
    }

    /// Why `self` (now) differs from `old` (recorded), in words; `None` when they agree.
    pub fn difference(&self, old: &Fingerprint) -> Option<String> {
        if self.version != old.version {
            return Some(format!("it was made by scanrig {}, this is {}", old.version, self.version));
        }
        if (&self.stage, self.code_version) != (&old.stage, old.code_version) {
            return Some(match old.code_version {
                0 => format!(
                    "the {} stage's code has a version now ({}), the record has none",
                    self.stage, self.code_version
                ),
                v => format!("the {} stage's code changed (version {v}, now {})", self.stage, self.code_version),
            });
        }
        let mut changed = Vec::new();
        diff_values("", &self.params, &old.params, &mut changed);
        if !changed.is_empty() {
            return Some(format!("{} changed", list(&changed)));
        }
        let mut inputs: Vec<String> = Vec::new();
        for (name, hash) in &self.inputs {
            match old.inputs.get(name) {
                Some(h) if h == hash => {}
                Some(_) => inputs.push(name.clone()),
                None => inputs.push(format!("{name} (new)")),
            }
        }
        inputs.extend(old.inputs.keys().filter(|k| !self.inputs.contains_key(*k)).map(|k| format!("{k} (gone)")));
        (!inputs.is_empty()).then(|| format!("input {} changed", list(&inputs)))
    }
}

/// A rig part as a fingerprint value: its exact debug text (every f64 printed so it reads back the
/// same), so any edit of the part a stage uses reruns the stage.
pub fn rig_part(part: &impl std::fmt::Debug) -> Value {
    Value::String(format!("{part:?}"))
}

fn list(items: &[String]) -> String {
    const MAX: usize = 4;
    if items.len() <= MAX {
        items.join(", ")
    } else {
        format!("{} and {} more", items[..MAX].join(", "), items.len() - MAX)
    }
}

/// The dotted paths where two JSON values differ.
fn diff_values(path: &str, new: &Value, old: &Value, out: &mut Vec<String>) {
    match (new, old) {
        (Value::Object(a), Value::Object(b)) => {
            let keys: std::collections::BTreeSet<&String> = a.keys().chain(b.keys()).collect();
            for k in keys {
                let p = if path.is_empty() { k.clone() } else { format!("{path}.{k}") };
                match (a.get(k), b.get(k)) {
                    (Some(x), Some(y)) => diff_values(&p, x, y, out),
                    _ => out.push(p),
                }
            }
        }
        _ if new != old => out.push(if path.is_empty() { "the parameters".into() } else { path.to_string() }),
        _ => {}
    }
}

/// One recorded output.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Record {
    /// What made it.
    pub fingerprint: Fingerprint,
    /// The hash of the file as written.
    pub hash: Hash,
    /// The stage's report when it made the file (reported again when the file is reused).
    #[serde(default)]
    pub report: Value,
}

#[derive(Debug, Default, Serialize, Deserialize)]
struct RecordsFile {
    format: u32,
    outputs: BTreeMap<String, Record>,
    /// The scan the outputs are of (absent in records from before it was kept).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    scan: Option<ScanMark>,
}

/// Which scan an output folder holds the results of, kept in its records so that `process` of
/// another scan into the folder is refused rather than replacing them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScanMark {
    /// The scan folder (canonical where it could be made so).
    pub folder: PathBuf,
    /// The content hash of its first frame, which a copy or a move of the scan keeps.
    pub first_frame: Option<Hash>,
}

impl ScanMark {
    /// The mark of the scan in `folder` with the manifest `manifest`: its first frame is that of
    /// the first view with one.
    pub fn of_scan(folder: &Path, manifest: &rig::scan_folder::Manifest) -> ScanMark {
        let first = manifest.views.iter().flat_map(|v| &v.frames).next();
        ScanMark {
            folder: std::fs::canonicalize(folder).unwrap_or_else(|_| folder.to_path_buf()),
            first_frame: first.and_then(|f| Hash::of_file(&folder.join(&f.file))),
        }
    }

    /// Whether `other` marks the same scan: the same folder, or the same first frame (the scan
    /// copied or moved).
    pub fn same_scan(&self, other: &ScanMark) -> bool {
        self.folder == other.folder || (self.first_frame.is_some() && self.first_frame == other.first_frame)
    }
}

/// The outcome of asking whether an output can be reused.
#[derive(Debug, Clone)]
pub enum Decision {
    /// The file is current: its record (the hash of its content, its report).
    Reuse(Record),
    /// It must be made again, for this reason.
    Run(String),
}

impl Decision {
    /// True for [`Decision::Reuse`].
    pub fn reused(&self) -> bool {
        matches!(self, Decision::Reuse(_))
    }

    /// The reason to run, if it must run.
    pub fn reason(&self) -> Option<&str> {
        match self {
            Decision::Run(r) => Some(r),
            Decision::Reuse(_) => None,
        }
    }
}

/// One output's record as it stood, to decide on ([`Records::decider`]).
pub struct Decider {
    redo: bool,
    path: PathBuf,
    record: Option<Record>,
}

impl Decider {
    /// Whether the output can be reused for `now`.
    pub fn decide(self, now: &Fingerprint) -> Decision {
        if self.redo {
            return Decision::Run("--redo".into());
        }
        let Some(record) = self.record else {
            return Decision::Run(if self.path.exists() {
                "no record of how the file was made".into()
            } else {
                NOT_MADE_YET.into()
            });
        };
        if let Some(why) = now.difference(&record.fingerprint) {
            return Decision::Run(why);
        }
        match Hash::of_file(&self.path) {
            None => Decision::Run("the file is missing".into()),
            Some(h) if h != record.hash => Decision::Run("the file was changed since it was written".into()),
            Some(_) => Decision::Reuse(record),
        }
    }
}

/// The records of one output folder.
#[derive(Debug)]
pub struct Records {
    path: PathBuf,
    out: PathBuf,
    file: RecordsFile,
    redo: bool,
}

impl Records {
    /// Reads the records of the output folder `out` (none yet, or unreadable, is an empty set: every
    /// stage then runs). `redo` makes every decision [`Decision::Run`].
    pub fn open(out: &Path, redo: bool) -> Records {
        let path = out.join(RECORDS_NAME);
        let file = rig::input::read_regular(&path, None)
            .ok()
            .and_then(|b| serde_json::from_slice::<RecordsFile>(&b).ok())
            .filter(|f| f.format == RECORDS_FORMAT)
            .unwrap_or(RecordsFile { format: RECORDS_FORMAT, outputs: BTreeMap::new(), scan: None });
        Records { path, out: out.to_path_buf(), file, redo }
    }

    /// Whether `name` (relative to the output folder) can be reused for `now`.
    pub fn decide(&self, name: &str, now: &Fingerprint) -> Decision {
        self.decider(name).decide(now)
    }

    /// What [`Records::decide`] needs of `name`, owned: the decision (which reads and hashes the
    /// whole file) can then be made without holding whatever guards the records.
    pub fn decider(&self, name: &str) -> Decider {
        Decider { redo: self.redo, path: self.out.join(name), record: self.file.outputs.get(name).cloned() }
    }

    /// The record of `name`, if any.
    pub fn get(&self, name: &str) -> Option<&Record> {
        self.file.outputs.get(name)
    }

    /// Notes that `name` was written with content hash `hash`, by `fingerprint`, reporting `report`.
    pub fn insert(&mut self, name: &str, fingerprint: Fingerprint, hash: Hash, report: Value) {
        self.file.outputs.insert(name.to_string(), Record { fingerprint, hash, report });
    }

    /// The scan these records are of, where they say.
    pub fn scan(&self) -> Option<&ScanMark> {
        self.file.scan.as_ref()
    }

    /// Marks these records as of the scan `mark`.
    pub fn set_scan(&mut self, mark: ScanMark) {
        self.file.scan = Some(mark);
    }

    /// Forgets `name` (an output that is about to be rewritten, or no longer made).
    pub fn remove(&mut self, name: &str) {
        self.file.outputs.remove(name);
    }

    /// The records of another folder's `stages.json` bytes; `None` if they are not records of this
    /// layout version.
    pub fn parse(bytes: &[u8]) -> Option<BTreeMap<String, Record>> {
        let file: RecordsFile = serde_json::from_slice(bytes).ok()?;
        (file.format == RECORDS_FORMAT).then_some(file.outputs)
    }

    /// Takes over records made elsewhere (outputs copied in beside them), replacing this folder's
    /// record of the same output.
    pub fn merge(&mut self, outputs: BTreeMap<String, Record>) {
        self.file.outputs.extend(outputs);
    }

    /// Writes the records atomically.
    pub fn save(&self) -> Result<(), rig::Error> {
        let json = serde_json::to_vec_pretty(&self.file).expect("records serialise");
        rig::write_atomic(&self.path, &json)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    const TEST: StageCode = StageCode { stage: "test", version: 1 };

    #[test]
    fn differences_name_the_parameter_or_the_input() {
        let a = Fingerprint::new(TEST, json!({"crop": {"radius_mm": 20.0, "min_height_mm": 1.0}, "k": 64}))
            .input("rig.toml camera", Hash(1));
        let mut b = a.clone();
        assert_eq!(a.difference(&b), None);
        b.params = json!({"crop": {"radius_mm": null, "min_height_mm": 1.0}, "k": 64});
        assert_eq!(a.difference(&b).as_deref(), Some("crop.radius_mm changed"));
        let c = a.clone().input("rig.toml camera", Hash(2));
        assert_eq!(c.difference(&a).as_deref(), Some("input rig.toml camera changed"));
        let mut d = a.clone();
        d.version = "0.0.1".into();
        assert!(a.difference(&d).unwrap().contains("made by scanrig 0.0.1"));
    }

    #[test]
    fn a_new_code_version_of_the_stage_makes_its_output_again() {
        let params = json!({"depth": 8});
        let old = Fingerprint::new(TEST, params.clone()).input("fused.ply", Hash(7));
        let new = Fingerprint::new(StageCode { version: 2, ..TEST }, params.clone()).input("fused.ply", Hash(7));
        assert_ne!(old, new);
        assert_eq!(new.difference(&old).as_deref(), Some("the test stage's code changed (version 1, now 2)"));
        // A record written before stages had code versions reads as version 0, and runs once.
        let mut older: serde_json::Value = serde_json::to_value(&old).unwrap();
        let fields = older.as_object_mut().unwrap();
        fields.remove("stage");
        fields.remove("code_version");
        let older: Fingerprint = serde_json::from_value(older).unwrap();
        assert!(old.difference(&older).unwrap().contains("has a version now (1)"));
    }

    #[test]
    fn a_file_is_reused_only_while_its_fingerprint_and_content_hold() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        let fp = Fingerprint::new(TEST, json!({"depth": 8}));
        let mut r = Records::open(dir, false);
        assert_eq!(r.decide("mesh.ply", &fp).reason(), Some("not made yet"));
        std::fs::write(dir.join("mesh.ply"), b"mesh").unwrap();
        assert_eq!(r.decide("mesh.ply", &fp).reason(), Some("no record of how the file was made"));
        r.insert("mesh.ply", fp.clone(), Hash::of(b"mesh"), json!({"triangles": 4}));
        r.save().unwrap();
        let r = Records::open(dir, false);
        match r.decide("mesh.ply", &fp) {
            Decision::Reuse(rec) => assert_eq!(rec.report["triangles"], 4),
            Decision::Run(why) => panic!("{why}"),
        }
        assert_eq!(r.decide("mesh.ply", &Fingerprint::new(TEST, json!({"depth": 9}))).reason(), Some("depth changed"));
        assert_eq!(Records::open(dir, true).decide("mesh.ply", &fp).reason(), Some("--redo"));
        std::fs::write(dir.join("mesh.ply"), b"edited").unwrap();
        assert_eq!(r.decide("mesh.ply", &fp).reason(), Some("the file was changed since it was written"));
    }
}
