//! What a calibration reads: board positions, each with its lit frame and whatever else was
//! captured there (laser frames, the structured-light program), from a capture folder's manifest or
//! from a plain folder of images.
//!
//! In a plain folder (other tools' captures, such as FabScan's calibration sweep) the frames are
//! taken in the order of their numbers (never as text); a frame much darker than the lit frame before
//! it is a laser frame of that position — the first such frame laser 0, the next laser 1 — as FabScan
//! and Horus capture them.

use super::WorkflowError as E;
use rig::image::Image8;
use rig::math::Real;
use rig::{Manifest, Pattern};
use std::path::{Path, PathBuf};

/// How images are turned before use (a camera mounted on its side): the rig's `[image]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Orientation(pub rig::image::ImageTransform);

impl Orientation {
    /// Reads a PNG or JPEG as grey, turned.
    pub fn read(&self, path: &Path) -> Result<Image8, E> {
        let img = rig::image::read_image(path)?.to_gray();
        Ok(if self.0.is_identity() { img } else { img.transformed(&self.0) })
    }
}

/// One board position.
#[derive(Debug, Clone, PartialEq)]
pub struct Position {
    /// The lit frame (the board under full light).
    pub lit: PathBuf,
    /// The turntable angle, where the board stood on the turntable and the angle was recorded.
    pub angle_deg: Option<Real>,
    /// Laser frames by laser index.
    pub lasers: Vec<(usize, PathBuf)>,
    /// The frame with every laser off, if one was taken.
    pub laser_off: Option<PathBuf>,
    /// The structured-light frames (with white and black), if the projector's program was captured.
    pub structured: Vec<(Pattern, PathBuf)>,
}

/// The positions of a capture folder, a folder of pose folders (or a `*` pattern naming them: each
/// one board pose's Gray-code program in OpenCV order, [`rig::gray_code_folders`], for a `projector`
/// of that size, else of the size its image count suggests) or an image folder; `progress(done,
/// total)` while images are read.
pub fn load(
    source: &Path,
    turn: Orientation,
    projector: Option<(u32, u32)>,
    progress: impl FnMut(usize, usize),
) -> Result<Vec<Position>, E> {
    if source.join("scan.json").is_file() {
        return from_manifest(source);
    }
    let poses = pose_dirs(source);
    if !poses.is_empty() {
        return from_pose_folders(&poses, projector);
    }
    from_images(&image_files(source)?, turn, progress)
}

/// The pose folders a source names: the image-holding subfolders of a folder that holds no images
/// itself, or the folders a `*` pattern matches.
pub fn pose_dirs(source: &Path) -> Vec<PathBuf> {
    let name = source.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    if name.contains('*') {
        let parent = source.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        return rig::gray_code_folders::pose_folders(parent)
            .into_iter()
            .filter(|d| d.file_name().is_some_and(|n| wildcard(&name, &n.to_string_lossy())))
            .collect();
    }
    if rig::gray_code_folders::pose_images(source).is_ok_and(|f| f.is_empty()) {
        return rig::gray_code_folders::pose_folders(source);
    }
    Vec::new()
}

/// The projector size the pose folders of `source` suggest by their image count (see
/// [`rig::gray_code_folders::infer_projector_size`]); `None` where `source` is not such a layout.
pub fn pose_layout_projector(source: &Path) -> Option<(u32, u32)> {
    let first = pose_dirs(source).into_iter().next()?;
    rig::gray_code_folders::infer_projector_size(rig::gray_code_folders::pose_images(&first).ok()?.len())
}

/// One position per pose folder: its white frame lit, its whole program structured.
fn from_pose_folders(dirs: &[PathBuf], projector: Option<(u32, u32)>) -> Result<Vec<Position>, E> {
    let count = rig::gray_code_folders::pose_images(&dirs[0])?.len();
    let (w, h) = projector
        .or_else(|| rig::gray_code_folders::infer_projector_size(count))
        .ok_or_else(|| E::NoImages { path: dirs[0].clone() })?;
    dirs.iter()
        .map(|d| {
            let frames = rig::gray_code_folders::pose_frames(d, w, h)?;
            let lit = frames
                .iter()
                .find(|(p, _)| *p == Pattern::White)
                .map(|(_, f)| f.clone())
                .expect("OpenCV order ends in white, black");
            Ok(Position { lit, angle_deg: None, lasers: Vec::new(), laser_off: None, structured: frames })
        })
        .collect()
}

fn from_manifest(dir: &Path) -> Result<Vec<Position>, E> {
    let mut manifest = Manifest::read(dir)?;
    // Board folders written before views could be marked `held` recorded hand-held poses at one
    // angle; a sweep never repeats its angle, so such a folder is all held poses.
    if manifest.method == rig::Method::Board
        && manifest.views.len() > 1
        && manifest.views.iter().all(|v| !v.held && v.angle_deg == manifest.views[0].angle_deg)
    {
        manifest.views.iter_mut().for_each(|v| v.held = true);
    }
    let positions: Vec<Position> = manifest
        .views
        .iter()
        .filter(|v| v.complete)
        .filter_map(|v| {
            let lit = v.frames.iter().find(|f| f.pattern == Pattern::White)?;
            let file = |f: &rig::scan_folder::Frame| dir.join(&f.file);
            let structured: Vec<(Pattern, PathBuf)> = v
                .frames
                .iter()
                .filter(|f| {
                    matches!(f.pattern, Pattern::White | Pattern::Black | Pattern::Gray { .. } | Pattern::Phase { .. })
                })
                .map(|f| (f.pattern, file(f)))
                .collect();
            Some(Position {
                lit: file(lit),
                angle_deg: (!v.held).then_some(v.angle_deg),
                lasers: v
                    .frames
                    .iter()
                    .filter_map(|f| match f.pattern {
                        Pattern::Laser { index } => Some((index, file(f))),
                        _ => None,
                    })
                    .collect(),
                laser_off: v.frames.iter().find(|f| f.pattern == Pattern::LaserOff).map(file),
                structured: if structured.iter().any(|(p, _)| matches!(p, Pattern::Gray { .. })) {
                    structured
                } else {
                    Vec::new()
                },
            })
        })
        .collect();
    if positions.is_empty() {
        return Err(E::NoLitFrame { folder: dir.to_path_buf() });
    }
    Ok(positions)
}

/// Every PNG or JPEG a source names: a folder's, or those matching a `*` pattern in the file name
/// (`'captures/*.png'`), in the order of their numbers ([`rig::frame_order`]).
fn image_files(source: &Path) -> Result<Vec<PathBuf>, E> {
    let name = source.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let (dir, pattern) = if name.contains('*') {
        (source.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new(".")).to_path_buf(), Some(name))
    } else {
        (source.to_path_buf(), None)
    };
    let files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map_err(|e| E::File(rig::Error::io(&dir, e)))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| rig::image::is_image_file(p))
        .filter(|p| pattern.as_deref().is_none_or(|pat| wildcard(pat, &p.file_name().unwrap().to_string_lossy())))
        .collect();
    // By number, never as text (`shot_2` before `shot_10`); a sweep may skip an image deleted as
    // blurred, so gaps are not refused here.
    let files = rig::frame_order::order(files).files;
    if files.is_empty() {
        return Err(E::NoImages { path: source.to_path_buf() });
    }
    Ok(files)
}

/// Whether `name` matches `pattern`, where `*` stands for any run of characters.
fn wildcard(pattern: &str, name: &str) -> bool {
    let parts: Vec<&str> = pattern.split('*').collect();
    let (first, last) = (parts[0], parts[parts.len() - 1]);
    if parts.len() == 1 {
        return pattern == name;
    }
    if !name.starts_with(first) || name.len() < first.len() + last.len() || !name.ends_with(last) {
        return false;
    }
    let mut rest = &name[first.len()..name.len() - last.len()];
    for part in &parts[1..parts.len() - 1] {
        match rest.find(part) {
            Some(i) => rest = &rest[i + part.len()..],
            None => return false,
        }
    }
    true
}

/// A frame this much darker (mean grey) than the last lit frame is a laser frame.
const LASER_FRAME_DARKNESS: Real = 0.4;

fn from_images(
    files: &[PathBuf],
    turn: Orientation,
    mut progress: impl FnMut(usize, usize),
) -> Result<Vec<Position>, E> {
    let mut positions: Vec<Position> = Vec::new();
    let mut lit_mean: Option<Real> = None;
    let mut first: Option<(u32, u32)> = None;
    for (k, file) in files.iter().enumerate() {
        progress(k + 1, files.len());
        let img = turn.read(file)?;
        match first {
            None => first = Some((img.width, img.height)),
            Some((w, h)) if (w, h) != (img.width, img.height) => {
                return Err(E::SizeMismatch {
                    image: file.clone(),
                    size: (img.width, img.height),
                    first: files[0].clone(),
                    first_size: (w, h),
                });
            }
            _ => {}
        }
        let mean = img.data.iter().map(|&v| v as Real).sum::<Real>() / img.data.len().max(1) as Real;
        match (lit_mean, positions.last_mut()) {
            (Some(lit), Some(p)) if mean < LASER_FRAME_DARKNESS * lit => {
                let index = p.lasers.len();
                p.lasers.push((index, file.clone()));
            }
            _ => {
                lit_mean = Some(mean);
                positions.push(Position {
                    lit: file.clone(),
                    angle_deg: None,
                    lasers: Vec::new(),
                    laser_off: None,
                    structured: Vec::new(),
                });
            }
        }
    }
    Ok(positions)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wildcards_match_runs() {
        assert!(wildcard("*.png", "a.png") && wildcard("cal_*_x.jpg", "cal_12_x.jpg") && wildcard("a*b*c", "abc"));
        assert!(!wildcard("*.png", "a.jpg") && !wildcard("a*b*c", "acb") && !wildcard("ab*ba", "aba"));
        assert!(wildcard("exact.png", "exact.png") && !wildcard("exact.png", "other.png"));
    }
}
