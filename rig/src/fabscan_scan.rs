//! FabScanPi scan folders: its laser frames as scanrig views, and scanrig views written in its layout.
//!
//! # Layouts (PROTOCOLS.md), recognised from the folder and the names, never from the frame count
//! - **`raw_laser_raw/`** (FabScanPi-Server since 2022): each laser frame, as the camera captured it
//!   (before the `rotate`/`hflip` turn), as `raw_laser_raw/<id>_<NNN>.jpg`: one counter over every
//!   laser frame, from 1, so position k (1 ..= N) and laser l (0-based, of L) is
//!   NNN = (k − 1)·L + l + 1, zero-padded to three digits.
//! - **`laser_raw/`** (older servers): the same names and counter. A one-laser scan is numbered by
//!   position; a two-laser one interleaves its lasers as above — the config's `laser.numbers` says
//!   which, so 16 frames of a two-laser scan are 8 positions, not 16.
//! - **flat**: the frames directly in the folder, as the server's recorded scans (its `dummy/` driver)
//!   keep them: `<id>_<NNN>.jpg` counted from 000, so position k (0-based) and laser l is NNN = k·L + l.
//!
//! `.png` frames are taken too (the simulator writes those, losslessly). Frame numbers are numbers
//! (`_7` and `_007` are one frame, `_10` comes after `_9`).
//!
//! # Angles
//! FabScanPi's config does not record the scan's resolution (its `<id>.fab` keeps only a setting's
//! index), so the turntable step comes from the user ([`manifest`]'s `step_deg`), never from the
//! frame count: a scan stopped after 4 of 8 positions would otherwise be taken for a whole turn of 4.
//! Position k stands at FabScanPi's angle a = k·step, and its points are the platform frame's turned
//! by **+a** about the platform's z (`FSImageProcessor.compute_point_cloud`). scanrig's object frame
//! undoes a view's angle θ (`Rz(−θ)`), so θ = −a (mod 360°): of N = 360°/step positions, position N
//! (or 0) is view 0 and position 1 the last. With the sign the other way every profile would land at
//! its mirror angle and the object come out mirrored, which nothing downstream could notice.

use crate::error::{Error, Location, ParseError, Problem};
use crate::patterns::Pattern;
use crate::scan_folder::{Frame, Manifest, Method, SCAN_FORMAT, View};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The folders FabScanPi kept laser frames in, newest layout first.
pub const FRAME_FOLDERS: [&str; 2] = ["raw_laser_raw", "laser_raw"];

/// Frame file extensions taken as laser frames.
const FRAME_EXTENSIONS: [&str; 3] = ["jpg", "jpeg", "png"];

/// A FabScanPi scan's laser frames, by position (FabScanPi's numbering, see the module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct FabscanFrames {
    /// The scan's id (the files' prefix).
    pub id: String,
    /// The folder the frames are in, relative to the scan folder (empty: the folder itself).
    pub folder: String,
    /// FabScanPi's number of each position below (1-based in the server's layouts, 0-based flat).
    pub positions: Vec<usize>,
    /// Frame files (names inside `folder`), by position then laser.
    pub files: Vec<Vec<String>>,
    /// What the user should know: positions missing whole, files that are not frames.
    pub notes: Vec<String>,
}

/// scanrig's turntable angle (degrees) of FabScanPi's position `k` (1 ..= `n`) of a whole turn of `n`;
/// see the module doc.
pub fn angle_deg(k: usize, n: usize) -> f64 {
    ((n - k % n) % n) as f64 * (360.0 / n as f64)
}

/// scanrig's turntable angle (degrees, in [0, 360)) of FabScanPi's position `k` at `step_deg` a step:
/// θ = −k·step. Where the step divides the turn it is computed as [`angle_deg`] does, so an imported
/// scan's angles are the ones scanrig writes for the same turn, bit for bit.
pub fn position_angle_deg(k: usize, step_deg: f64) -> f64 {
    let n = 360.0 / step_deg;
    if (n - n.round()).abs() < 1e-9 && n.round() >= 1.0 {
        let n = n.round() as usize;
        return ((n - k % n) % n) as f64 * step_deg;
    }
    let a = (-(k as f64) * step_deg).rem_euclid(360.0);
    if 360.0 - a < 1e-9 { 0.0 } else { a }
}

fn invalid(path: &Path, msg: String) -> Error {
    ParseError::new(Location::File, Problem::Invalid(msg)).with_path(path)
}

/// Whether `name` is a laser frame's name, `<id>_<number>.<jpg|jpeg|png>`: its id and number.
fn frame_name(name: &str) -> Option<(&str, usize)> {
    let (stem, ext) = name.rsplit_once('.')?;
    if !FRAME_EXTENSIONS.iter().any(|e| ext.eq_ignore_ascii_case(e)) {
        return None;
    }
    let (id, number) = stem.rsplit_once('_')?;
    if number.is_empty() || !number.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    Some((id, number.parse().ok()?))
}

/// The folder (relative to `dir`) holding the scan's laser frames: one of [`FRAME_FOLDERS`], or `dir`
/// itself (empty) when it holds frames directly; `None` when neither.
pub fn frame_folder(dir: &Path) -> Option<&'static str> {
    if let Some(f) = FRAME_FOLDERS.iter().find(|f| dir.join(f).is_dir()) {
        return Some(f);
    }
    let entries = std::fs::read_dir(dir).ok()?;
    let flat = entries.flatten().any(|e| e.path().is_file() && frame_name(&e.file_name().to_string_lossy()).is_some());
    flat.then_some("")
}

/// Finds the laser frames of the FabScanPi scan folder `dir` for a scanner of `lasers` lasers (the
/// config's `laser.numbers`) in whichever layout it is (module doc). Refuses a folder without frames,
/// frames of two scans, one number twice, and a position that lacks one laser's frame but has
/// another's, naming the frame; positions missing whole (a sample, a lost file) and files that are not
/// frames are named in [`FabscanFrames::notes`].
pub fn find_frames(dir: &Path, lasers: usize) -> Result<FabscanFrames, Error> {
    let lasers = lasers.max(1);
    let Some(folder) = frame_folder(dir) else {
        return Err(invalid(
            dir,
            format!(
                "no {} folder and no <id>_<NNN>.jpg frames in it: not a FabScanPi scan kept with its raw images \
                 (keep_raw_images)",
                FRAME_FOLDERS.join(" or ")
            ),
        ));
    };
    // The server's layouts count from 1, the flat one from 0.
    let first = usize::from(!folder.is_empty());
    let path = if folder.is_empty() { dir.to_path_buf() } else { dir.join(folder) };
    let mut numbered: BTreeMap<usize, String> = BTreeMap::new();
    let mut ids: Vec<String> = Vec::new();
    let mut others: Vec<String> = Vec::new();
    let entries = std::fs::read_dir(&path).map_err(|e| Error::io(&path, e))?;
    for entry in entries {
        let entry = entry.map_err(|e| Error::io(&path, e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some((id, n)) = frame_name(&name) else {
            if entry.path().is_file() {
                others.push(name);
            }
            continue;
        };
        if !ids.iter().any(|i| i == id) {
            ids.push(id.to_string());
        }
        if n < first {
            return Err(invalid(&path, format!("frame `{name}` is numbered 0: {folder}/ counts its frames from 1")));
        }
        if let Some(before) = numbered.insert(n, name.clone()) {
            return Err(invalid(&path, format!("frame number {n} appears twice (`{before}` and `{name}`)")));
        }
    }
    if ids.len() > 1 {
        ids.sort();
        return Err(invalid(
            &path,
            format!("frames of {} scans ({}): import one scan at a time", ids.len(), ids.join(", ")),
        ));
    }
    if numbered.is_empty() {
        return Err(invalid(&path, "holds no <id>_<NNN>.jpg frames".into()));
    }
    // Position and laser of each frame, from its number and the config's laser count.
    let mut by_position: BTreeMap<usize, Vec<Option<String>>> = BTreeMap::new();
    for (n, name) in numbered {
        let (k, l) = ((n - first) / lasers + first, (n - first) % lasers);
        by_position.entry(k).or_insert_with(|| vec![None; lasers])[l] = Some(name);
    }
    let mut notes = Vec::new();
    let (mut positions, mut files) = (Vec::new(), Vec::new());
    for (k, frames) in by_position {
        if let Some(l) = frames.iter().position(Option::is_none) {
            let missing = (k - first) * lasers + l + first;
            return Err(invalid(
                &path,
                format!(
                    "frame {missing:03} is missing: position {k} has {} of its {lasers} laser frames (the config says \
                     {lasers} lasers, numbered one after another)",
                    frames.iter().flatten().count()
                ),
            ));
        }
        positions.push(k);
        files.push(frames.into_iter().flatten().collect());
    }
    // Positions missing whole are left out, and said: the others keep their angles. Counted from the
    // gaps between the positions there are (a number like 99999999 must not be walked to).
    let (low, high) = (positions[0], positions[positions.len() - 1]);
    let missing = high - low + 1 - positions.len();
    if missing > 0 {
        let shown: Vec<usize> = positions.windows(2).flat_map(|w| (w[0] + 1..w[1]).take(8)).take(8).collect();
        notes.push(format!(
            "{}: {missing} of the positions {low} to {high} have no frames ({}{}): imported without them",
            path.display(),
            list(&shown),
            if missing > shown.len() { ", …" } else { "" }
        ));
    }
    if !others.is_empty() {
        others.sort();
        notes.push(format!(
            "{}: not laser frames (<id>_<NNN>.jpg|png), not imported: {}",
            path.display(),
            others.iter().take(8).cloned().collect::<Vec<_>>().join(", ") + if others.len() > 8 { ", …" } else { "" }
        ));
    }
    Ok(FabscanFrames { id: ids.remove(0), folder: folder.to_string(), positions, files, notes })
}

/// Numbers as `a, b, c`.
fn list(n: &[usize]) -> String {
    n.iter().map(|k| k.to_string()).collect::<Vec<_>>().join(", ")
}

/// The scan manifest of `frames` (their files referenced under `frames_dir`, relative to the new scan
/// folder) taken `step_deg` apart: one laser view per position at scanrig's angle
/// ([`position_angle_deg`]), and notes on what was left out. Refuses a step that is not a turntable
/// step and positions beyond a whole turn (stray frames, or a wrong `--step-deg`), naming their frames;
/// a position a whole turn from another (a turn closed on its first position) is left out and said.
/// `dir` names the scan in messages.
pub fn manifest(
    frames: &FabscanFrames,
    step_deg: f64,
    frames_dir: &str,
    source: &str,
    dir: &Path,
) -> Result<(Manifest, Vec<String>), Error> {
    if !(step_deg.is_finite() && step_deg > 0.0 && step_deg <= 180.0) {
        return Err(invalid(
            dir,
            format!("--step-deg {step_deg}: a turntable step must be more than 0° and at most 180°"),
        ));
    }
    // Tolerance of a whole turn: a step given to a few decimals (3.6) times 100 is 360 within it.
    const TURN_EPS: f64 = 1e-6;
    let turn = |k: usize| k as f64 * step_deg;
    let beyond: Vec<usize> =
        (0..frames.positions.len()).filter(|&i| turn(frames.positions[i]) > 360.0 + TURN_EPS).collect();
    if let Some(&i) = beyond.first() {
        let names: Vec<&str> = beyond.iter().flat_map(|&i| frames.files[i].iter().map(String::as_str)).collect();
        return Err(invalid(
            &dir.join(&frames.folder),
            format!(
                "{} frame(s) lie beyond a whole turn at --step-deg {step_deg} (position {} would be at {:.2}°): {}; \
                 stray frames (remove them) or a wrong --step-deg",
                names.len(),
                frames.positions[i],
                turn(frames.positions[i]),
                names.iter().take(8).copied().collect::<Vec<_>>().join(", ")
            ),
        ));
    }
    let mut notes = Vec::new();
    let mut views: Vec<(f64, View)> = Vec::new();
    for (&k, files) in frames.positions.iter().zip(&frames.files) {
        // A whole turn after position 0 is position 0 again: its frames would be a second view at 0°.
        if k > 0 && (turn(k) - 360.0).abs() <= TURN_EPS && frames.positions[0] == 0 {
            notes.push(format!(
                "position {k} ({}) is a whole turn ({:.1}°) after position 0, which it repeats: not imported",
                files.join(", "),
                turn(k)
            ));
            continue;
        }
        let view = View {
            angle_deg: position_angle_deg(k, step_deg),
            frames: files
                .iter()
                .enumerate()
                .map(|(l, f)| Frame { file: format!("{frames_dir}/{f}"), pattern: Pattern::Laser { index: l } })
                .collect(),
            complete: true,
            held: false,
            pass: 1,
        };
        views.push((view.angle_deg, view));
    }
    // Views in turntable order from 0°, as scanrig's own scans list them.
    views.sort_by(|a, b| a.0.total_cmp(&b.0));
    // The turn the positions span, each standing for one step of it.
    let (first, last) = (frames.positions[0], frames.positions[frames.positions.len() - 1]);
    let covered = turn(last) - turn(first) + step_deg;
    if covered < 360.0 - TURN_EPS {
        notes.push(format!(
            "a partial turn: positions {first} to {last} at {step_deg}° a step span {covered:.1}° of 360° \
             (FabScanPi's angles {:.1}° to {:.1}°)",
            turn(first),
            turn(last),
        ));
    }
    let manifest = Manifest {
        format: SCAN_FORMAT,
        method: Method::Laser,
        rig: "rig.toml".into(),
        source: source.into(),
        seed: None,
        views: views.into_iter().map(|(_, v)| v).collect(),
    };
    Ok((manifest, notes))
}

/// Where FabScanPi would have kept view `view` (of `n`, at scanrig's angle `view·360°/n`) laser `l`
/// of `lasers`: `raw_laser_raw/<id>_<NNN>.<ext>`.
pub fn frame_path(id: &str, view: usize, n: usize, l: usize, lasers: usize, ext: &str) -> PathBuf {
    let k = if view == 0 { n } else { n - view };
    Path::new(FRAME_FOLDERS[0]).join(format!("{id}_{:03}.{ext}", (k - 1) * lasers + l + 1))
}

/// Writes the scanrig scan `scan` (laser views at `v·360°/N`, frames as its rig's camera sees them)
/// in FabScanPi's layout under `out`: `config.json` (the rig, its frames turned as `turn` says) and
/// `<id>/raw_laser_raw/<id>_<NNN>.png`, each frame as a camera mounted as `turn` says would have
/// captured it. What the simulator writes to test importers on; PNG keeps it lossless.
pub fn write_layout(scan: &Path, out: &Path, id: &str, turn: crate::image::ImageTransform) -> Result<(), Error> {
    let m = Manifest::read(scan)?;
    let mut rig = crate::Rig::read(&Manifest::inside(scan, &m.rig, "rig")?)?;
    let bad = |msg: String| invalid(&scan.join(crate::scan_folder::MANIFEST_NAME), msg);
    if m.method != Method::Laser || !rig.image.is_identity() {
        return Err(bad("only laser scans whose frames need no turning can be written in FabScanPi's layout".into()));
    }
    let (n, lasers) = (m.views.len(), rig.lasers.len());
    for (v, view) in m.views.iter().enumerate() {
        if view.angle_deg != v as f64 * (360.0 / n as f64) {
            return Err(bad(format!(
                "view {v} is at {}°, not an even turn: FabScanPi's positions are",
                view.angle_deg
            )));
        }
        for f in &view.frames {
            let Pattern::Laser { index } = f.pattern else { continue };
            let img = crate::image::read_image(&Manifest::inside(scan, &f.file, "frame")?)?;
            let path = out.join(id).join(frame_path(id, v, n, index, lasers, "png"));
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent).map_err(|e| Error::io(parent, e))?;
            }
            crate::image::write_png(&path, &img.untransformed(&turn), true)?;
        }
    }
    rig.image = turn;
    let config = crate::scanner_calibration::rig_to_fabscan(&rig).map_err(bad)?;
    crate::run_files::write_atomic(&out.join("config.json"), config.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_map_to_views_and_back() {
        let n = 100;
        for view in 0..n {
            let p = frame_path("s", view, n, 1, 2, "jpg");
            let number: usize =
                p.to_str().unwrap().rsplit_once('_').unwrap().1.trim_end_matches(".jpg").parse().unwrap();
            let k = (number - 1) / 2 + 1;
            assert_eq!(angle_deg(k, n), view as f64 * (360.0 / n as f64), "view {view}");
        }
        // Position 1 is FabScanPi's first turn, +3.6°: scanrig's −3.6°, i.e. 356.4°.
        assert!((angle_deg(1, 100) - 356.4).abs() < 1e-9);
        assert_eq!(angle_deg(100, 100), 0.0);
        for k in 0..=100 {
            assert_eq!(position_angle_deg(k, 3.6), angle_deg(k.max(1), 100) * f64::from(u8::from(k > 0)), "{k}");
        }
        assert!((position_angle_deg(3, 7.0) - 339.0).abs() < 1e-12);
    }

    /// A folder of empty files named `names` under `sub` (the frames' content is not read here).
    fn folder(sub: &str, names: &[String]) -> tempfile::TempDir {
        let d = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(d.path().join(sub)).unwrap();
        for n in names {
            std::fs::write(d.path().join(sub).join(n), b"").unwrap();
        }
        d
    }

    fn numbered(id: &str, numbers: impl IntoIterator<Item = usize>, ext: &str) -> Vec<String> {
        numbers.into_iter().map(|n| format!("{id}_{n:03}.{ext}")).collect()
    }

    fn angles(m: &Manifest) -> Vec<f64> {
        m.views.iter().map(|v| v.angle_deg).collect()
    }

    #[test]
    fn frames_directly_in_the_folder_count_from_000_and_keep_their_angles_across_gaps() {
        // The recorded scan's sample: frames 000, 020, …, 080 of a 3.6° scan, one laser.
        let mut names = numbered("20210213-230202", (0..=80).step_by(20), "jpg");
        names.push("notes.txt".into());
        let d = folder("", &names);
        let f = find_frames(d.path(), 1).unwrap();
        assert_eq!((f.folder.as_str(), f.positions.clone()), ("", vec![0, 20, 40, 60, 80]));
        assert!(f.notes.iter().any(|n| n.contains("no frames") && n.contains("76 of the positions")), "{:?}", f.notes);
        assert!(f.notes.iter().any(|n| n.contains("notes.txt")), "{:?}", f.notes);
        let (m, notes) = manifest(&f, 3.6, "frames", "test", d.path()).unwrap();
        // FabScanPi's +k·3.6° is scanrig's −k·3.6°: frame 080 (288°) is the view at 72°.
        let a = angles(&m);
        assert_eq!(a.len(), 5);
        for (got, want) in a.iter().zip([0.0, 72.0, 144.0, 216.0, 288.0]) {
            assert!((got - want).abs() < 1e-9, "{a:?}");
        }
        assert_eq!(m.views[1].frames[0].file, "frames/20210213-230202_080.jpg");
        assert!(notes.iter().any(|n| n.contains("partial turn")), "{notes:?}");
    }

    #[test]
    fn a_scan_stopped_after_4_of_8_positions_is_the_partial_turn_it_is() {
        let d = folder("raw_laser_raw", &numbered("s", 1..=8, "png"));
        let f = find_frames(d.path(), 2).unwrap();
        assert_eq!(f.positions, vec![1, 2, 3, 4]);
        let (m, notes) = manifest(&f, 45.0, "frames", "test", d.path()).unwrap();
        // Positions 1–4 at FabScanPi's 45°…180°: scanrig's 315°, 270°, 225°, 180° — not 0/90/180/270.
        assert_eq!(angles(&m), vec![180.0, 225.0, 270.0, 315.0]);
        assert_eq!(
            m.views[3].frames.iter().map(|f| f.file.as_str()).collect::<Vec<_>>(),
            ["frames/s_001.png", "frames/s_002.png"]
        );
        assert!(notes.iter().any(|n| n.contains("partial turn") && n.contains("180.0° of 360°")), "{notes:?}");
    }

    #[test]
    fn stray_frames_beyond_a_whole_turn_are_refused_by_name() {
        let d = folder("raw_laser_raw", &numbered("s", 1..=18, "png"));
        let f = find_frames(d.path(), 2).unwrap();
        let e = manifest(&f, 45.0, "frames", "test", d.path()).unwrap_err().to_string();
        assert!(e.contains("s_017.png") && e.contains("s_018.png") && e.contains("--step-deg"), "{e}");
        // One stray frame leaves position 9 short of a laser: refused as well, naming the gap.
        let d = folder("raw_laser_raw", &numbered("s", 1..=17, "png"));
        let e = find_frames(d.path(), 2).unwrap_err().to_string();
        assert!(e.contains("frame 018 is missing"), "{e}");
        // A whole turn closed on position 0 (flat frames 000 … 008 at 45°): the last repeats the first.
        let d = folder("", &numbered("s", 0..=8, "jpg"));
        let (m, notes) = manifest(&find_frames(d.path(), 1).unwrap(), 45.0, "frames", "test", d.path()).unwrap();
        assert_eq!(m.views.len(), 8);
        assert!(notes.iter().any(|n| n.contains("s_008.jpg") && n.contains("repeats")), "{notes:?}");
        assert!(!notes.iter().any(|n| n.contains("partial")), "{notes:?}");
        for bad in [0.0, -3.6, f64::NAN, f64::INFINITY, 400.0] {
            let e = manifest(&find_frames(d.path(), 1).unwrap(), bad, "f", "t", d.path()).unwrap_err().to_string();
            assert!(e.contains("--step-deg"), "{e}");
        }
    }

    #[test]
    fn a_two_laser_scan_in_the_legacy_layout_has_two_lasers_per_position() {
        let d = folder("laser_raw", &numbered("old", 1..=16, "jpg"));
        let f = find_frames(d.path(), 2).unwrap();
        assert_eq!(f.positions, (1..=8).collect::<Vec<_>>());
        assert!(f.files.iter().all(|p| p.len() == 2));
        let (m, notes) = manifest(&f, 45.0, "frames", "test", d.path()).unwrap();
        assert_eq!(angles(&m), (0..8).map(|k| 45.0 * k as f64).collect::<Vec<_>>());
        assert!(notes.is_empty(), "{notes:?}");
        // Position 8 (360°) is view 0, with laser 0 on frame 015 and laser 1 on 016.
        let files: Vec<&str> = m.views[0].frames.iter().map(|f| f.file.as_str()).collect();
        assert_eq!(files, ["frames/old_015.jpg", "frames/old_016.jpg"]);
        assert_eq!(m.views[0].frames[1].pattern, Pattern::Laser { index: 1 });
    }

    #[test]
    fn a_far_number_is_refused_as_beyond_the_turn_without_walking_to_it() {
        let names: Vec<String> = ["s_000.jpg", "s_99999999999.jpg"].map(String::from).to_vec();
        let d = folder("", &names);
        let f = find_frames(d.path(), 1).unwrap();
        assert!(
            f.notes[0].contains("99999999998 of the positions") && f.notes[0].contains("(1, 2, 3, 4, 5, 6, 7, 8, …)")
        );
        let e = manifest(&f, 3.6, "frames", "test", d.path()).unwrap_err().to_string();
        assert!(e.contains("s_99999999999.jpg") && e.contains("beyond a whole turn"), "{e}");
    }

    #[test]
    fn numbers_are_numbers_and_one_number_twice_is_refused() {
        let names: Vec<String> = ["s_1.png", "s_2.png", "s_10.png", "s_9.png"].map(String::from).to_vec();
        let d = folder("raw_laser_raw", &names);
        assert_eq!(find_frames(d.path(), 1).unwrap().positions, vec![1, 2, 9, 10]);
        let names: Vec<String> = ["s_1.png", "s_001.jpg"].map(String::from).to_vec();
        let e = find_frames(folder("raw_laser_raw", &names).path(), 1).unwrap_err().to_string();
        assert!(e.contains("appears twice"), "{e}");
    }
}
