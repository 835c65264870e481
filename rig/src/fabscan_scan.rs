//! FabScanPi scan folders: its laser frames as scanrig views, and scanrig views written in its layout.
//!
//! # Layout (FabScanPi-Server since 2022; PROTOCOLS.md)
//! A scan `<id>/` keeps each laser frame, as the camera captured it (before the `rotate`/`hflip`
//! turn), as `raw_laser_raw/<id>_<NNN>.jpg`: one counter over every laser frame, from 1, so position
//! k (1 ..= N) and laser l (0-based, of L) is NNN = (k − 1)·L + l + 1, zero-padded to three digits.
//! Older servers wrote `laser_raw/<id>_<k>.jpg`, one laser, numbered by position. `.png` frames are
//! taken too (the simulator writes those, losslessly).
//!
//! # Angles
//! Position k of N stands at FabScanPi's angle a = k·360°/N, and its points are the platform frame's
//! turned by **+a** about the platform's z (`FSImageProcessor`). scanrig's object frame undoes a view's
//! angle θ (`Rz(−θ)`), so θ = −a, which is (N − k)·360°/N: position N is view 0, position 1 the last.
//! With the sign the other way every profile would land at its mirror angle and the object come out
//! mirrored, which nothing downstream could notice.

use crate::error::{Error, Location, ParseError, Problem};
use crate::patterns::Pattern;
use crate::scan_folder::{Frame, Manifest, Method, SCAN_FORMAT, View};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The folders FabScanPi kept laser frames in, newest layout first.
pub const FRAME_FOLDERS: [&str; 2] = ["raw_laser_raw", "laser_raw"];

/// A FabScanPi scan's laser frames: `files[k][l]`, position k (0-based here: FabScanPi's k + 1), laser l.
#[derive(Debug, Clone, PartialEq)]
pub struct FabscanFrames {
    /// The scan's id (the files' prefix).
    pub id: String,
    /// The folder the frames are in, relative to the scan folder.
    pub folder: String,
    /// Frame files (names inside `folder`), by position then laser.
    pub files: Vec<Vec<String>>,
}

/// scanrig's turntable angle (degrees) of FabScanPi's position `k` (1 ..= `n`); see the module doc.
pub fn angle_deg(k: usize, n: usize) -> f64 {
    ((n - k % n) % n) as f64 * (360.0 / n as f64)
}

fn invalid(path: &Path, msg: String) -> Error {
    ParseError::new(Location::File, Problem::Invalid(msg)).with_path(path)
}

/// Finds the laser frames of the FabScanPi scan folder `dir` for a scanner of `lasers` lasers;
/// refuses a folder without frames, frames of two scans, and a count or numbering with gaps, naming
/// what is missing.
pub fn find_frames(dir: &Path, lasers: usize) -> Result<FabscanFrames, Error> {
    let lasers = lasers.max(1);
    let Some(folder) = FRAME_FOLDERS.iter().find(|f| dir.join(f).is_dir()) else {
        return Err(invalid(
            dir,
            format!(
                "no {} folder: not a FabScanPi scan kept with its raw images (keep_raw_images)",
                FRAME_FOLDERS.join(" or ")
            ),
        ));
    };
    let path = dir.join(folder);
    let mut numbered: BTreeMap<usize, String> = BTreeMap::new();
    let mut ids: Vec<String> = Vec::new();
    let entries = std::fs::read_dir(&path).map_err(|e| Error::io(&path, e))?;
    for entry in entries {
        let entry = entry.map_err(|e| Error::io(&path, e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some((stem, ext)) = name.rsplit_once('.') else { continue };
        if !["jpg", "jpeg", "png"].iter().any(|e| ext.eq_ignore_ascii_case(e)) {
            continue;
        }
        let Some((id, number)) = stem.rsplit_once('_') else { continue };
        let Ok(n) = number.parse::<usize>() else { continue };
        if !ids.iter().any(|i| i == id) {
            ids.push(id.to_string());
        }
        if numbered.insert(n, name.clone()).is_some() || n == 0 {
            return Err(invalid(&path, format!("frame number {n} appears twice or is 0 (`{name}`)")));
        }
    }
    if ids.len() > 1 {
        ids.sort();
        return Err(invalid(
            &path,
            format!("frames of {} scans ({}): import one scan at a time", ids.len(), ids.join(", ")),
        ));
    }
    let count = numbered.len();
    if count == 0 {
        return Err(invalid(&path, "holds no <id>_<NNN>.jpg frames".into()));
    }
    if let Some(gap) = (1..=count).find(|n| !numbered.contains_key(n)) {
        return Err(invalid(
            &path,
            format!(
                "frame {gap:03} is missing (frames 1 to {} expected, {count} found)",
                numbered.keys().last().unwrap_or(&0)
            ),
        ));
    }
    // The older layout numbers by position only, one laser.
    let per = if *folder == "laser_raw" { 1 } else { lasers };
    if !count.is_multiple_of(per) {
        return Err(invalid(
            &path,
            format!(
                "{count} frames do not divide among {per} lasers: a position lacks a laser's frame (the config says {lasers} lasers)"
            ),
        ));
    }
    let names: Vec<String> = numbered.into_values().collect();
    Ok(FabscanFrames {
        id: ids.remove(0),
        folder: folder.to_string(),
        files: names.chunks(per).map(|c| c.to_vec()).collect(),
    })
}

/// The scan manifest of `frames` (their files referenced under `frames_dir`, relative to the new scan
/// folder), one laser view per position at scanrig's angle.
pub fn manifest(frames: &FabscanFrames, frames_dir: &str, source: &str) -> Manifest {
    let n = frames.files.len();
    let mut views: Vec<(usize, View)> = frames
        .files
        .iter()
        .enumerate()
        .map(|(i, files)| {
            let k = i + 1;
            let view = View {
                angle_deg: angle_deg(k, n),
                frames: files
                    .iter()
                    .enumerate()
                    .map(|(l, f)| Frame { file: format!("{frames_dir}/{f}"), pattern: Pattern::Laser { index: l } })
                    .collect(),
                complete: true,
                held: false,
            };
            ((n - k) % n, view)
        })
        .collect();
    // Views in turntable order from 0°, as scanrig's own scans list them.
    views.sort_by_key(|(v, _)| *v);
    Manifest {
        format: SCAN_FORMAT,
        method: Method::Laser,
        rig: "rig.toml".into(),
        source: source.into(),
        seed: None,
        views: views.into_iter().map(|(_, v)| v).collect(),
    }
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
    crate::error::write_atomic(&out.join("config.json"), config.as_bytes())
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
    }
}
