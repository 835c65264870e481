//! Laser-line extraction: per image row, the sub-pixel centre of the laser stripe in the laser frame
//! minus the laser-off frame (`process` triangulates the centres against the laser's plane).
//!
//! Rows are rejected, not guessed, where the stripe is too faint, saturated (its centre is then the
//! middle of a clipped plateau, biased by the clipping) or doubled (a second stripe of comparable
//! strength: a reflection or an occlusion edge, and no way to tell which is the laser).

use rig::image::Image8;
use rig::math::Real;
use serde::Serialize;

/// How the stripe's centre is found in a row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PeakMethod {
    /// A Gaussian through the brightest pixel and its two neighbours (a parabola of the logarithms).
    Gaussian,
    /// The intensity-weighted mean over a window around the brightest pixel.
    CentreOfMass,
}

/// Line-extraction thresholds (grey levels of 8-bit frames).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LaserParams {
    /// The stripe must rise at least this much above the laser-off frame.
    pub min_peak: f64,
    /// Half-width of the window around the brightest pixel (pixels).
    pub window: usize,
    /// Frames at or above this grey level are saturated.
    pub saturation: u8,
    /// A second peak outside the window stronger than this fraction of the first rejects the row.
    pub double_peak_ratio: f64,
    /// Sub-pixel method.
    pub method: PeakMethod,
}

impl Default for LaserParams {
    fn default() -> Self {
        LaserParams { min_peak: 12.0, window: 6, saturation: 250, double_peak_ratio: 0.6, method: PeakMethod::Gaussian }
    }
}

/// The stripe's centre in one row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinePeak {
    /// Image row.
    pub row: usize,
    /// Sub-pixel column.
    pub col: Real,
    /// Height above the laser-off frame (grey levels).
    pub peak: Real,
}

/// Why a row has no peak (counted in reports).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, serde::Deserialize)]
pub struct LineReport {
    /// Rows with a peak.
    pub found: usize,
    /// Rows without any stripe above `min_peak`.
    pub faint: usize,
    /// Rows rejected as saturated.
    pub saturated: usize,
    /// Rows rejected for a second stripe.
    pub doubled: usize,
}

fn sub_pixel(diff: &[f64], m: usize, p: &LaserParams) -> Real {
    if p.method == PeakMethod::Gaussian && m > 0 && m + 1 < diff.len() {
        let (a, b, c) = (diff[m - 1], diff[m], diff[m + 1]);
        if a > 0.0 && c > 0.0 {
            let (la, lb, lc) = (a.ln(), b.ln(), c.ln());
            let denom = la - 2.0 * lb + lc;
            if denom < -1e-9 {
                return m as Real + 0.5 * (la - lc) / denom;
            }
        }
    }
    let (lo, hi) = (m.saturating_sub(p.window), (m + p.window).min(diff.len() - 1));
    // Weights above half the peak only: the tails carry noise and the other side's shading.
    let floor = 0.5 * diff[m];
    let (mut s, mut sw) = (0.0, 0.0);
    for (c, &v) in diff.iter().enumerate().take(hi + 1).skip(lo) {
        let wgt = (v - floor).max(0.0);
        s += c as Real * wgt;
        sw += wgt;
    }
    if sw > 0.0 { s / sw } else { m as Real }
}

/// Finds the stripe in every row of `on` (laser on) against `off` (laser off).
pub fn detect_line(on: &Image8, off: &Image8, p: &LaserParams) -> (Vec<LinePeak>, LineReport) {
    detect_line_within(on, off, p, |_, _| true)
}

/// [`detect_line`] over only the pixels `(column, row)` for which `keep` holds — the printed board
/// during laser calibration, where the platter and background would otherwise win rows or double
/// them.
pub fn detect_line_within(
    on: &Image8,
    off: &Image8,
    p: &LaserParams,
    keep: impl Fn(usize, usize) -> bool,
) -> (Vec<LinePeak>, LineReport) {
    let (w, h) = (on.width as usize, on.height as usize);
    let mut peaks = Vec::new();
    let mut report = LineReport::default();
    let mut diff = vec![0.0; w];
    for r in 0..h {
        for (c, d) in diff.iter_mut().enumerate() {
            *d = if keep(c, r) { (on.data[r * w + c] as Real - off.data[r * w + c] as Real).max(0.0) } else { 0.0 };
        }
        let (m, &top) = diff.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).expect("rows are not empty");
        if top < p.min_peak {
            report.faint += 1;
            continue;
        }
        if on.data[r * w + m] >= p.saturation {
            report.saturated += 1;
            continue;
        }
        let reach = 2 * p.window;
        let second =
            diff.iter().enumerate().filter(|(c, _)| c.abs_diff(m) > reach).map(|(_, &v)| v).fold(0.0, Real::max);
        if second > p.double_peak_ratio * top {
            report.doubled += 1;
            continue;
        }
        report.found += 1;
        peaks.push(LinePeak { row: r, col: sub_pixel(&diff, m, p), peak: top });
    }
    (peaks, report)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stripe(centre: Real, sigma: Real, amp: Real) -> Image8 {
        Image8::gray(
            64,
            1,
            (0..64)
                .map(|c| (10.0 + amp * (-0.5 * ((c as Real - centre) / sigma).powi(2)).exp()).round() as u8)
                .collect(),
        )
    }

    #[test]
    fn gaussian_and_centre_of_mass_find_a_sub_pixel_stripe() {
        let off = Image8::gray(64, 1, vec![10; 64]);
        for centre in [20.0, 20.25, 31.5, 40.8] {
            for method in [PeakMethod::Gaussian, PeakMethod::CentreOfMass] {
                let (peaks, _) =
                    detect_line(&stripe(centre, 1.8, 180.0), &off, &LaserParams { method, ..Default::default() });
                assert!((peaks[0].col - centre).abs() < 0.06, "{method:?} at {centre}: {}", peaks[0].col);
            }
        }
    }

    #[test]
    fn faint_saturated_and_double_stripes_are_rejected() {
        let off = Image8::gray(64, 1, vec![10; 64]);
        let p = LaserParams::default();
        assert_eq!(detect_line(&stripe(30.0, 1.5, 5.0), &off, &p).1.faint, 1);
        assert_eq!(detect_line(&stripe(30.0, 1.5, 400.0), &off, &p).1.saturated, 1);
        let mut two = stripe(15.0, 1.5, 150.0);
        for (c, v) in stripe(45.0, 1.5, 140.0).data.iter().enumerate().skip(30) {
            two.data[c] = *v;
        }
        assert_eq!(detect_line(&two, &off, &p).1.doubled, 1);
    }
}
