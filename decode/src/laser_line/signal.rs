//! From a frame to the laser's signal along each row: the laser's colour picked out of a colour frame,
//! and the background removed — the laser-off frame subtracted where one was captured, otherwise
//! estimated from the frame itself.
//!
//! Without a laser-off frame (FabScanPi records none) the background is the row's morphological
//! opening: the largest profile of width `2·background_px + 1` that fits under the signal. A laser line
//! is narrower than that and stands out of it whole; ambient light, a lit object's shading and a red
//! object's own colour vary slowly and are removed (the white top-hat transform, as in line-structure
//! extraction for welding and rail profiles).

use rig::LaserColour;
use rig::image::Image8;

/// Where the background comes from.
#[derive(Debug, Clone, Copy)]
pub enum Background<'a> {
    /// The laser-off frame of the same view.
    Frame(&'a Image8),
    /// Estimated from the laser frame (no laser-off frame).
    Estimated,
}

/// One pixel's laser signal (grey frames: the grey level).
#[inline]
fn pixel(img: &Image8, i: usize, colour: LaserColour) -> f32 {
    if img.channels == 3 {
        let p = &img.data[3 * i..3 * i + 3];
        colour.signal([p[0], p[1], p[2]])
    } else {
        f32::from(img.data[i])
    }
}

/// The brightest channel of a pixel: what saturates first.
#[inline]
pub fn raw_max(img: &Image8, i: usize) -> u8 {
    if img.channels == 3 { img.data[3 * i..3 * i + 3].iter().copied().max().unwrap_or(0) } else { img.data[i] }
}

/// Scratch rows for [`row_signal`], reused across the rows a thread handles (its hot loop
/// allocates nothing).
#[derive(Debug, Default)]
pub struct Scratch {
    pre: Vec<f32>,
    suf: Vec<f32>,
    eroded: Vec<f32>,
    opened: Vec<f32>,
}

/// Running minimum (or maximum) of `src` over windows of `±half`, in O(n) whatever the window (van
/// Herk–Gil–Werman: block-wise prefix and suffix extrema).
fn running_extreme(src: &[f32], half: usize, out: &mut [f32], max: bool, pre: &mut Vec<f32>, suf: &mut Vec<f32>) {
    let n = src.len();
    let pick = |a: f32, b: f32| if max { a.max(b) } else { a.min(b) };
    let k = 2 * half + 1;
    if n == 0 {
        return;
    }
    pre.resize(n, 0.0);
    suf.resize(n, 0.0);
    for i in 0..n {
        pre[i] = if i % k == 0 { src[i] } else { pick(pre[i - 1], src[i]) };
    }
    for i in (0..n).rev() {
        suf[i] = if i % k == k - 1 || i == n - 1 { src[i] } else { pick(suf[i + 1], src[i]) };
    }
    for (i, o) in out.iter_mut().enumerate() {
        let (lo, hi) = (i.saturating_sub(half), (i + half).min(n - 1));
        // The window [lo, hi] spans at most two blocks: the suffix of lo's and the prefix up to hi.
        *o = if lo / k == hi / k { src[lo..=hi].iter().copied().fold(src[lo], pick) } else { pick(suf[lo], pre[hi]) };
    }
}

/// Fills `out` with row `r`'s laser signal above the background.
pub fn row_signal(
    frame: &Image8,
    background: Background<'_>,
    colour: LaserColour,
    r: usize,
    half: usize,
    out: &mut [f32],
    scratch: &mut Scratch,
) {
    let w = frame.width as usize;
    for (c, o) in out.iter_mut().enumerate() {
        *o = pixel(frame, r * w + c, colour);
    }
    match background {
        Background::Frame(off) => {
            for (c, o) in out.iter_mut().enumerate() {
                *o = (*o - pixel(off, r * w + c, colour)).max(0.0);
            }
        }
        Background::Estimated => {
            let Scratch { pre, suf, eroded, opened } = scratch;
            eroded.resize(w, 0.0);
            opened.resize(w, 0.0);
            running_extreme(out, half, eroded, false, pre, suf);
            running_extreme(eroded, half, opened, true, pre, suf);
            for (o, b) in out.iter_mut().zip(opened.iter()) {
                *o = (*o - b).max(0.0);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_running_extreme_matches_the_naive_one() {
        let src: Vec<f32> = (0..97).map(|i| ((i * 37 % 23) as f32).sin() * 10.0).collect();
        for half in [0, 1, 3, 8, 60] {
            let mut fast = vec![0.0; src.len()];
            running_extreme(&src, half, &mut fast, false, &mut Vec::new(), &mut Vec::new());
            for (i, &f) in fast.iter().enumerate() {
                let naive = src[i.saturating_sub(half)..=(i + half).min(src.len() - 1)]
                    .iter()
                    .copied()
                    .fold(f32::INFINITY, f32::min);
                assert_eq!(f, naive, "half {half}, at {i}");
            }
        }
    }

    #[test]
    fn the_estimated_background_keeps_a_narrow_line_and_removes_a_broad_glow() {
        // A slope of ambient light, a broad glow and a 3 px line on top.
        let w = 200;
        let row: Vec<u8> = (0..w)
            .map(|c| {
                let c = c as f32;
                let glow = 60.0 * (-0.5 * ((c - 50.0) / 25.0).powi(2)).exp();
                let line = 120.0 * (-0.5 * ((c - 140.0) / 1.3).powi(2)).exp();
                (20.0 + 0.2 * c + glow + line).round() as u8
            })
            .collect();
        let img = Image8::gray(w as u32, 1, row);
        let mut out = vec![0.0; w];
        row_signal(&img, Background::Estimated, LaserColour::Red, 0, 10, &mut out, &mut Scratch::default());
        assert!(out[140] > 110.0, "the line keeps its height: {}", out[140]);
        // A broad glow leaves only the curvature of its top within the window (60·(1 − e^{−½(10/25)²}) ≈ 4.6).
        assert!(out[..120].iter().all(|&v| v < 6.0), "the glow and slope are gone");
    }
}
