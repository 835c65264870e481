//! Projector–camera calibration captures in the layout other tools use: one folder per board pose,
//! each holding the Gray-code program in OpenCV's `GrayCodePattern` order (for each column bit, MSB
//! first, the pattern then its inverse; then the row bits the same way), then an all-white and an
//! all-black image (`graycode_00.png … graycode_41.png` for a 1024×768 projector). The layout of
//! kamino410/procam-calibration and OpenCV's structured_light samples; see PROTOCOLS.md.

use crate::error::{Error, Location, ParseError, Problem};
use crate::patterns::{Axis, Pattern, bits_for};
use crate::scan_folder::Manifest;
use std::path::{Path, PathBuf};

/// The patterns of OpenCV's capture order for a `width × height` projector, white and black last.
pub fn opencv_order(width: u32, height: u32) -> Vec<Pattern> {
    let mut seq = Vec::new();
    for (axis, size) in [(Axis::Columns, width), (Axis::Rows, height)] {
        let bits = bits_for(size);
        for bit in 0..bits {
            for inverse in [false, true] {
                seq.push(Pattern::Gray { axis, bit, bits, inverse });
            }
        }
    }
    seq.push(Pattern::White);
    seq.push(Pattern::Black);
    seq
}

/// Images in OpenCV order for a `width × height` projector: `2·(⌈log₂ w⌉ + ⌈log₂ h⌉) + 2`.
pub fn image_count(width: u32, height: u32) -> usize {
    2 * (bits_for(width) + bits_for(height)) as usize + 2
}

/// A projector size that `count` images in OpenCV order can belong to, when the size was not given:
/// the bits split evenly between columns and rows (one more column bit when odd), each axis the
/// largest its bits can address. The decoded projector coordinates are the same whatever the true
/// size within those bits; only the rig's projector width and height may need setting by hand.
pub fn infer_projector_size(count: usize) -> Option<(u32, u32)> {
    if count < 6 || !count.is_multiple_of(2) {
        return None;
    }
    let bits = (count - 2) / 2;
    let (cols, rows) = (bits.div_ceil(2), bits / 2);
    (cols <= 16 && rows >= 1).then(|| (1u32 << cols, 1u32 << rows))
}

/// The images of one pose folder (PNG or JPEG) in frame order: by their numbers, never as text
/// ([`crate::frame_order`]), so `graycode_0 … graycode_41` and `img1 … img42` come in capture order.
/// Duplicates, gaps and extra images are not refused here (see [`pose_frames`]).
pub fn pose_images(dir: &Path) -> Result<Vec<PathBuf>, Error> {
    Ok(crate::frame_order::list_images(dir)?.files)
}

/// The pose folders under `dir` (its subfolders holding images), in natural order of their names;
/// empty when `dir` is not laid out that way.
pub fn pose_folders(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else { return Vec::new() };
    let dirs: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir() && pose_images(p).is_ok_and(|f| !f.is_empty()))
        .collect();
    crate::frame_order::order(dirs).files
}

/// One pose folder's frames, each with the pattern it shows for a `width × height` projector, taken in
/// the order of their numbers; refuses a folder whose images are not one numbered series (a duplicate,
/// a gap, an extra image, each named) or whose image count is not that projector's program, saying
/// what it expected.
pub fn pose_frames(dir: &Path, width: u32, height: u32) -> Result<Vec<(Pattern, PathBuf)>, Error> {
    let listed = crate::frame_order::list_images(dir)?;
    let order = opencv_order(width, height);
    if listed.files.len() != order.len() || !listed.problems.is_empty() {
        let msg = format!(
            "{} images, but a {width}x{height} projector in OpenCV order needs {} ({} Gray-code pairs, then white and \
             black){}{}",
            listed.files.len(),
            order.len(),
            (order.len() - 2) / 2,
            infer_projector_size(listed.files.len())
                .filter(|_| listed.files.len() != order.len())
                .map(|(w, h)| format!("; that many fit a projector of up to {w}x{h}"))
                .unwrap_or_default(),
            if listed.problems.is_empty() { String::new() } else { format!("; {}", listed.describe()) },
        );
        let msg = if listed.files.len() == order.len() { listed.describe() } else { msg };
        return Err(ParseError::new(Location::File, Problem::Invalid(msg)).with_path(dir));
    }
    Ok(order.into_iter().zip(listed.files).collect())
}

/// Writes the Gray-code frames of a scanrig capture folder's views (those that captured the whole
/// program, with white and black) as pose folders `out/pose_NN/graycode_MM.png` in OpenCV order, for
/// a `width × height` projector. Returns how many poses were written.
pub fn write_pose_folders(scan: &Path, out: &Path, width: u32, height: u32) -> Result<usize, Error> {
    let m = Manifest::read(scan)?;
    let order = opencv_order(width, height);
    let mut written = 0;
    for view in &m.views {
        let files: Option<Vec<&str>> =
            order.iter().map(|p| view.frames.iter().find(|f| f.pattern == *p).map(|f| f.file.as_str())).collect();
        let Some(files) = files else { continue };
        let dir = out.join(format!("pose_{written:02}"));
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        for (k, file) in files.iter().enumerate() {
            let from = Manifest::inside(scan, file, "frame")?;
            let img = crate::image::read_image(&from)?;
            crate::image::write_png(&dir.join(format!("graycode_{k:02}.png")), &img, true)?;
        }
        written += 1;
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_inference_agree_with_opencv() {
        assert_eq!(image_count(1024, 768), 42);
        assert_eq!(opencv_order(1024, 768).len(), 42);
        assert_eq!(infer_projector_size(42), Some((1024, 1024)));
        assert_eq!(infer_projector_size(44), Some((2048, 1024)));
        assert_eq!(infer_projector_size(5), None);
        assert_eq!(infer_projector_size(41), None);
        let o = opencv_order(1024, 768);
        assert!(matches!(o[0], Pattern::Gray { axis: Axis::Columns, bit: 0, inverse: false, .. }));
        assert!(matches!(o[1], Pattern::Gray { axis: Axis::Columns, bit: 0, inverse: true, .. }));
        assert!(matches!(o[20], Pattern::Gray { axis: Axis::Rows, bit: 0, inverse: false, .. }));
        assert_eq!((o[40], o[41]), (Pattern::White, Pattern::Black));
    }

    /// Issue 37: `graycode_0 … graycode_41` and `img1 … img42` were taken as text (`0, 1, 10, 11, …`),
    /// so 32 of 42 frames were decoded as the wrong pattern. They now come in number order, and a
    /// duplicate or an extra image is named instead of shifting every frame after it.
    #[test]
    fn unpadded_frame_numbers_are_taken_in_number_order() {
        for (first, name) in [(0, "graycode_"), (1, "img")] {
            let d = tempfile::tempdir().unwrap();
            for k in (first..first + 42).rev() {
                std::fs::write(d.path().join(format!("{name}{k}.png")), b"").unwrap();
            }
            let frames = pose_frames(d.path(), 1024, 768).unwrap();
            for (k, (p, f)) in frames.iter().enumerate() {
                assert_eq!(f.file_name().unwrap().to_string_lossy(), format!("{name}{}.png", k + first));
                assert_eq!(*p, opencv_order(1024, 768)[k]);
            }
            // img01.png beside img1.png: 43 images, the duplicate named.
            std::fs::write(d.path().join(format!("{name}0{}.png", first + 1)), b"").unwrap();
            let e = pose_frames(d.path(), 1024, 768).unwrap_err().to_string();
            assert!(e.contains("43 images") && e.contains("carry the same frame number"), "{e}");
            // One removed instead: 42 images with a gap and an extra named.
            std::fs::remove_file(d.path().join(format!("{name}{}.png", first + 7))).unwrap();
            std::fs::rename(d.path().join(format!("{name}0{}.png", first + 1)), d.path().join("preview.png")).unwrap();
            let e = pose_frames(d.path(), 1024, 768).unwrap_err().to_string();
            assert!(e.contains(&format!("frame number {} is missing", first + 7)), "{e}");
            assert!(e.contains("preview.png is not numbered like the other frames"), "{e}");
        }
    }
}
