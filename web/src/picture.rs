//! Images for the pages: depth maps coloured over the object's own depth range, thumbnails, marks
//! on images, and data URLs that embed them.

use base64::Engine as _;
use process::preview::turbo;
use rig::RangeGrid;
use rig::image::{Image8, jpeg_bytes, png_bytes};

/// An image as a PNG `data:` URL.
pub fn png_url(img: &Image8) -> String {
    format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(png_bytes(img, false)))
}

/// An image as a JPEG `data:` URL (photographs: several times smaller than PNG).
pub fn jpeg_url(img: &Image8, quality: u8) -> String {
    format!("data:image/jpeg;base64,{}", base64::engine::general_purpose::STANDARD.encode(jpeg_bytes(img, quality)))
}

/// The image shrunk to at most `max_width` pixels wide by averaging boxes (never enlarged).
pub fn thumbnail(img: &Image8, max_width: u32) -> Image8 {
    // Never a box taller than the image (a strip of a frame would index past its last row).
    let f = img.width.div_ceil(max_width.max(1)).max(1).min(img.height.max(1));
    if f == 1 || img.height == 0 {
        return img.clone();
    }
    let (w, h, c) = (img.width / f, (img.height / f).max(1), img.channels as usize);
    let mut data = Vec::with_capacity((w * h) as usize * c);
    for y in 0..h {
        for x in 0..w {
            for k in 0..c {
                let mut s = 0u32;
                for dy in 0..f {
                    for dx in 0..f {
                        let i = (((y * f + dy) * img.width + x * f + dx) as usize) * c + k;
                        s += img.data[i] as u32;
                    }
                }
                data.push((s / (f * f)) as u8);
            }
        }
    }
    Image8 { width: w, height: h, channels: img.channels, data }
}

/// The image in colour (grey repeated), for drawing coloured marks on.
pub fn to_rgb(img: &Image8) -> Image8 {
    match img.channels {
        3 => img.clone(),
        c => Image8 {
            width: img.width,
            height: img.height,
            channels: 3,
            data: img.data.chunks(c as usize).flat_map(|p| [p[0]; 3]).collect(),
        },
    }
}

/// Draws filled discs of `radius` pixels at `points` (x, y in pixels) on an RGB image.
pub fn mark(img: &mut Image8, points: &[[f64; 2]], radius: i64, colour: [u8; 3]) {
    for p in points.iter().filter(|p| p[0].is_finite() && p[1].is_finite()) {
        let (cx, cy) = (p[0].round() as i64, p[1].round() as i64);
        for y in cy - radius..=cy + radius {
            for x in cx - radius..=cx + radius {
                if (x - cx).pow(2) + (y - cy).pow(2) > radius * radius
                    || x < 0
                    || y < 0
                    || x >= img.width as i64
                    || y >= img.height as i64
                {
                    continue;
                }
                let i = ((y as usize) * img.width as usize + x as usize) * 3;
                img.data[i..i + 3].copy_from_slice(&colour);
            }
        }
    }
}

/// The depth range (2nd to 98th percentile of z, mm) of the valid cells `on_object` marks.
pub fn object_range(grid: &RangeGrid, on_object: &[bool]) -> Option<(f64, f64)> {
    let mut z: Vec<f64> = (0..grid.points.len())
        .filter(|&i| grid.valid[i] && on_object.get(i).copied().unwrap_or(false))
        .map(|i| grid.points[i].z)
        .collect();
    z.sort_by(f64::total_cmp);
    match z.len() {
        0 => None,
        n => Some((z[n / 50], z[(n - 1) - n / 50].max(z[n / 50] + 1e-6))),
    }
}

/// A range grid's depth map, coloured over the depth range of the cells `on_object` marks (its 2nd
/// to 98th percentile), so the object uses the whole colour scale however much of the frame the
/// platter and walls fill. Other valid cells are grey (lighter is nearer), holes black. Returns the
/// image and the range (mm) its colours span, near to far.
pub fn object_depth(grid: &RangeGrid, on_object: &[bool]) -> (Image8, Option<(f64, f64)>) {
    let range = object_range(grid, on_object);
    let all: Vec<f64> = (0..grid.points.len()).filter(|&i| grid.valid[i]).map(|i| grid.points[i].z).collect();
    let (zmin, zmax) = all.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    let mut data = Vec::with_capacity(grid.points.len() * 3);
    for i in 0..grid.points.len() {
        let z = grid.points[i].z;
        let px = match (grid.valid[i], on_object.get(i).copied().unwrap_or(false), range) {
            (false, _, _) => [0, 0, 0],
            (true, true, Some((lo, hi))) => turbo((z - lo) / (hi - lo)),
            (true, _, _) => {
                let t = if zmax > zmin { (zmax - z) / (zmax - zmin) } else { 0.5 };
                [(70.0 + 110.0 * t) as u8; 3]
            }
        };
        data.extend(px);
    }
    (Image8 { width: grid.width as u32, height: grid.height as u32, channels: 3, data }, range)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig::math::Point3;

    #[test]
    fn object_depth_spans_the_object_not_the_background() {
        // A 10 × 10 grid: the object (left half) at 300–310 mm, a wall (right half) at 900 mm.
        let (w, h) = (10usize, 10usize);
        let points: Vec<Point3> =
            (0..w * h).map(|i| Point3::new(0.0, 0.0, if i % w < 5 { 300.0 + (i / w) as f64 } else { 900.0 })).collect();
        let on: Vec<bool> = (0..w * h).map(|i| i % w < 5).collect();
        let mut grid = RangeGrid::empty(w, h, rig::Sensor::Center(Point3::origin()));
        grid.points = points;
        grid.valid = vec![true; w * h];
        let (img, range) = object_depth(&grid, &on);
        let (lo, hi) = range.unwrap();
        assert!((lo - 300.0).abs() < 1e-9 && (hi - 309.0).abs() < 1e-9, "{lo}..{hi}");
        // Nearest object row is the scale's start, the wall grey.
        assert_eq!(&img.data[0..3], &turbo(0.0));
        let wall = &img.data[3 * 7..3 * 7 + 3];
        assert!(wall[0] == wall[1] && wall[1] == wall[2], "background is grey: {wall:?}");
    }

    #[test]
    fn thumbnails_shrink_by_whole_boxes() {
        let img = Image8 { width: 8, height: 4, channels: 1, data: (0..32).map(|i| (i * 8) as u8).collect() };
        let strip = Image8 { width: 100, height: 2, channels: 1, data: vec![7; 200] };
        assert_eq!(thumbnail(&strip, 10).height, 1, "a strip shrinks without reading past it");
        let t = thumbnail(&img, 4);
        assert_eq!((t.width, t.height), (4, 2));
        // Pixels 0, 1, 8 and 9 of the source (values 0, 8, 64, 72).
        assert_eq!(t.data[0], ((8 + 64 + 72) / 4) as u8);
        let mut rgb = to_rgb(&t);
        mark(&mut rgb, &[[1.0, 1.0], [f64::NAN, 0.0], [-9.0, 99.0]], 0, [255, 0, 0]);
        assert_eq!(&rgb.data[3 * 5..3 * 5 + 3], &[255, 0, 0]);
        assert!(png_url(&rgb).starts_with("data:image/png;base64,iVBOR"));
    }
}
