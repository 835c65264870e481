//! ChArUco boards: a chessboard with an ArUco marker in each light square, so every corner seen is
//! known by the markers beside it — a board half hidden or cut by the image's edge still numbers
//! its corners (FabScanPi moved to these boards for that). Detected by the `calib-targets-charuco`
//! crate (pure Rust, OpenCV's board layout since 4.6 and its predefined dictionaries) rather than by
//! hand: the marker decoding, its error correction and the dictionaries' bit tables are its job.
//!
//! A board of `squares_x × squares_y` squares has `(squares_x − 1) × (squares_y − 1)` inner corners,
//! numbered row by row as OpenCV numbers them — which is how [`crate::find_corners`] numbers a
//! chessboard's, from the same first corner (the square diagonally outside it is dark). So a
//! ChArUco board is, to every calibration step, a chessboard whose corners come with their numbers.

use crate::NotFound;
use crate::partial_board::{BoardCorners, Placement};
use calib_targets_charuco::{CharucoBoardSpec, CharucoDetector, CharucoParams, Dictionary, GrayImageView};
use rig::image::Image8;
use rig::math::{Point2, Real};
use serde::Serialize;

/// A ChArUco board's markers: their size and dictionary (its squares are the board's).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CharucoMarkers {
    /// A marker's side (mm), its black border included.
    pub marker_mm: Real,
    /// The dictionary, as OpenCV names it without `DICT_` (`4X4_50`).
    pub dictionary: &'static str,
}

/// The dictionary called `name` (`4x4_50`, `DICT_4X4_50`, any case), among OpenCV's predefined
/// square ones (4×4 to 7×7 bits, 50 to 1000 markers).
pub fn dictionary(name: &str) -> Option<Dictionary> {
    let upper = name.trim().to_ascii_uppercase();
    let bare = upper.strip_prefix("DICT_").unwrap_or(&upper);
    let ok = bare.len() >= 5 && bare.as_bytes()[1] == b'X' && !bare.starts_with("APRIL") && !bare.starts_with("ARUCO");
    ok.then(|| calib_targets_charuco::resolve_dictionary(bare)).flatten()
}

/// A marker dictionary's bits for drawing its markers (the simulator's `Markers`): the data bits
/// along a side, and each marker's bits row-major from its top-left, black = 1, the first bit the
/// lowest.
pub fn marker_bits(dictionary: &Dictionary) -> (usize, &'static [u64]) {
    (dictionary.marker_size(), dictionary.codes())
}

/// Why a ChArUco board description is refused.
fn bad(what: impl std::fmt::Display) -> String {
    format!("{what} (a ChArUco board reads charuco:SQUARESxSQUARES:square=MM:marker=MM:dict=4x4_50)")
}

/// A ChArUco board from its description, `charuco:11x9:square=10:marker=7:dict=4x4_50`: squares
/// across and down, the square and marker sides in mm, the dictionary. Returns the inner corners
/// across and down, the square (mm) and the markers.
pub fn parse(text: &str) -> Result<(u32, u32, Real, CharucoMarkers), String> {
    let mut parts = text.split(':');
    if parts.next().map(str::trim) != Some("charuco") {
        return Err(bad(format!("{text:?} does not start with charuco:")));
    }
    let size = parts.next().ok_or_else(|| bad("no squares given"))?;
    let (x, y) = size
        .split_once(['x', 'X'])
        .and_then(|(a, b)| Some((a.trim().parse::<u32>().ok()?, b.trim().parse::<u32>().ok()?)))
        .ok_or_else(|| bad(format!("{size:?} is not SQUARESxSQUARES")))?;
    if !(3..=100).contains(&x) || !(3..=100).contains(&y) {
        return Err(bad(format!("{x}x{y} squares: a ChArUco board has 3 to 100 squares a side")));
    }
    let (mut square, mut marker, mut dict) = (None, None, None);
    for part in parts {
        let (key, value) = part.split_once('=').ok_or_else(|| bad(format!("{part:?} is not KEY=VALUE")))?;
        let mm = || {
            value
                .trim()
                .parse::<Real>()
                .ok()
                .filter(|v| v.is_finite() && *v > 0.0 && *v <= 10_000.0)
                .ok_or_else(|| bad(format!("{key}={value}: a length in mm, above 0 and at most 10000")))
        };
        match key.trim() {
            "square" => square = Some(mm()?),
            "marker" => marker = Some(mm()?),
            "dict" => dict = Some(dictionary(value).ok_or_else(|| bad(format!("dict={value}: not a dictionary")))?),
            other => return Err(bad(format!("{other}: not a field (square, marker, dict)"))),
        }
    }
    let square = square.ok_or_else(|| bad("no square=MM"))?;
    let marker = marker.ok_or_else(|| bad("no marker=MM"))?;
    let dict = dict.ok_or_else(|| bad("no dict="))?;
    if marker >= square {
        return Err(bad(format!("marker={marker} mm must be smaller than square={square} mm")));
    }
    let markers_needed = (x * y / 2) as usize;
    if markers_needed > dict.codes().len() {
        return Err(bad(format!(
            "{x}x{y} squares need {markers_needed} markers; {} has {}",
            dict.name(),
            dict.codes().len()
        )));
    }
    let name = dict.name().strip_prefix("DICT_").unwrap_or(dict.name());
    Ok((x - 1, y - 1, square, CharucoMarkers { marker_mm: marker, dictionary: name }))
}

/// The share of [`crate::chessboard::refine_all`]'s window (0.3 of the square) kept on a ChArUco
/// board, whose markers come within an eighth of a square of each corner.
const REFINE_SHARE: Real = 0.4;

/// The farthest the refinement may move a corner the crate found (px).
const MAX_REFINE_PX: Real = 0.5;

/// The square in pixels: the median distance between corners next to each other in a row.
pub(crate) fn square_px(ids: &[usize], pixels: &[Point2], cols: usize) -> Real {
    let mut d: Vec<Real> = ids
        .windows(2)
        .zip(pixels.windows(2))
        .filter(|(i, _)| i[1] == i[0] + 1 && i[1] % cols != 0)
        .map(|(_, p)| (p[1] - p[0]).norm())
        .collect();
    d.sort_by(Real::total_cmp);
    d.get(d.len() / 2).copied().unwrap_or(20.0)
}

/// The board's corners in `img` (any channels), numbered by their markers: `cols × rows` inner
/// corners of `square_mm` squares.
pub fn find_charuco(
    img: &Image8,
    cols: usize,
    rows: usize,
    square_mm: Real,
    markers: &CharucoMarkers,
) -> Result<BoardCorners, NotFound> {
    let expected = cols * rows;
    let Some(dict) = dictionary(markers.dictionary) else { return Err(NotFound::TooFewCorners(0, expected)) };
    let spec = CharucoBoardSpec::new(
        rows as u32 + 1,
        cols as u32 + 1,
        square_mm as f32,
        (markers.marker_mm / square_mm) as f32,
        dict,
    );
    let Ok(detector) = CharucoDetector::new(CharucoParams::for_board(spec)) else {
        return Err(NotFound::TooFewCorners(0, expected));
    };
    let grey = if img.channels == 1 { img.clone() } else { img.to_gray() };
    let view = GrayImageView { width: grey.width as usize, height: grey.height as usize, data: &grey.data };
    let detection = detector.detect(&view).map_err(|_| NotFound::TooFewCorners(0, expected))?;
    let mut found: Vec<(usize, Point2)> = detection
        .corners
        .iter()
        .filter(|c| (c.id as usize) < expected)
        .map(|c| (c.id as usize, Point2::new(c.position.x as Real, c.position.y as Real)))
        .collect();
    found.sort_by_key(|f| f.0);
    found.dedup_by_key(|f| f.0);
    if found.len() < crate::partial_board::min_corners(cols, rows).min(expected) {
        return Err(NotFound::Partial { found: found.len(), expected });
    }
    let placement = if found.len() == expected { Placement::Whole } else { Placement::Identified };
    let ids: Vec<usize> = found.iter().map(|f| f.0).collect();
    let pixels: Vec<Point2> = found.iter().map(|f| f.1).collect();
    // The crate numbers the corners; their positions are refined as a chessboard's are, in a
    // window that stays inside the checker around each corner (a marker's border begins an eighth
    // of a square from it).
    let step = square_px(&ids, &pixels, cols);
    let refined = crate::chessboard::refine_all(&crate::Gray::from_image(&grey), &pixels, REFINE_SHARE * step);
    // A refinement that wanders (a cover's edge, a shadow beside the corner) keeps the crate's.
    let pixels =
        pixels.iter().zip(&refined).map(|(p, r)| if (r - p).norm() < MAX_REFINE_PX { *r } else { *p }).collect();
    Ok(BoardCorners { ids, pixels, placement })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn descriptions_parse_and_each_mistake_is_named() {
        let (cols, rows, square, m) = parse("charuco:11x9:square=10:marker=7:dict=4x4_50").unwrap();
        assert_eq!((cols, rows, square, m.marker_mm, m.dictionary), (10, 8, 10.0, 7.0, "4X4_50"));
        for (text, names) in [
            ("chess:11x9:square=10:marker=7:dict=4x4_50", "charuco:"),
            ("charuco:11:square=10:marker=7:dict=4x4_50", "SQUARESxSQUARES"),
            ("charuco:11x9:square=10:marker=12:dict=4x4_50", "smaller than"),
            ("charuco:11x9:square=10:marker=7:dict=9x9_50", "dict=9x9_50"),
            ("charuco:21x9:square=10:marker=7:dict=4x4_50", "need 94 markers"),
            ("charuco:11x9:square=NaN:marker=7:dict=4x4_50", "square=NaN"),
            ("charuco:11x9:marker=7:dict=4x4_50", "no square"),
            ("charuco:11x9:square=10:marker=7:dict=4x4_50:colour=red", "colour"),
        ] {
            let e = parse(text).unwrap_err();
            assert!(e.contains(names), "{text}: {e}");
        }
        assert!(dictionary("DICT_4X4_50").is_some() && dictionary("apriltag_36h11").is_none());
    }
}
