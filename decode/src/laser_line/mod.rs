//! Laser-line extraction: per image row, the sub-pixel centre of the laser line in a laser frame
//! (`process` triangulates the centres against the laser's plane, eq. 2.3's general form).
//!
//! Built for real frames, against Horus' method as the baseline (red channel, threshold, box blur, a
//! window around the row's brightest pixel, centre of mass):
//! - [`signal`]: colour frames by the laser's colour (red minus the larger of green and blue for a red
//!   laser), the laser-off frame subtracted where there is one, the background estimated from the frame
//!   where there is none;
//! - [`window`]: each row searched only where the laser's plane meets the working volume, on the
//!   camera's side of the axis, so the line on the scanner's back wall, the table or the floor, and
//!   light in the half of the plane no object's line can reach, is never a candidate;
//! - per row every peak is a candidate; candidates too wide for a laser line (a lit patch, a
//!   highlight) are rejected; a saturated line's centre is the middle of its clipped top (flat-top lines
//!   and blooming); where several candidates remain the one continuing the neighbouring rows' line is
//!   taken, and a row with two indistinguishable candidates is rejected, not guessed;
//! - the centre: a Gaussian through the peak and its two neighbours (Blais and Rioux's estimators are
//!   the same family) or the centre of mass above half the peak.
//!
//! [`LineReport`] counts, per frame, the rows with a line and why the others have none.

pub mod signal;
pub mod window;

use rayon::prelude::*;
use rig::LaserColour;
use rig::image::Image8;
use rig::math::Real;
use serde::Serialize;
pub use signal::Background;
pub use window::{RowWindows, lit_side_windows, working_volume_windows};

/// How the line's centre is found in a row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PeakMethod {
    /// A Gaussian through the brightest pixel and its two neighbours (a parabola of the logarithms).
    Gaussian,
    /// The intensity-weighted mean over a window around the brightest pixel.
    CentreOfMass,
}

/// Line-extraction thresholds (levels of 8-bit frames).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LaserParams {
    /// The line must rise at least this much above the background.
    pub min_peak: f64,
    /// Half-width of the window around a peak (pixels): peaks closer than this are one candidate.
    pub window: usize,
    /// Frames at or above this level are saturated.
    pub saturation: u8,
    /// Of two candidates neither of which continues the neighbouring rows' line, the weaker must be below
    /// this fraction of the stronger for the stronger to be taken.
    pub double_peak_ratio: f64,
    /// Sub-pixel method.
    pub method: PeakMethod,
    /// Candidates wider than this at half their height (pixels) are not a laser line.
    pub max_width_px: f64,
    /// Half-width of the background estimate without a laser-off frame (pixels): wider than a line.
    pub background_px: usize,
    /// A candidate continues a neighbouring row's line if within this many pixels of it, per row apart.
    pub continuity_px: f64,
    /// The working volume grown by this much (mm) when windows are computed from it.
    pub volume_margin_mm: f64,
    /// How far past the turntable axis, away from the camera, the line is still searched (mm): the
    /// plane's far half holds no line of an object over the platter's centre ([`lit_side_windows`]);
    /// this much of it is kept for hollows and objects a little off centre.
    pub past_axis_mm: f64,
}

impl Default for LaserParams {
    fn default() -> Self {
        LaserParams {
            min_peak: 12.0,
            window: 6,
            saturation: 250,
            double_peak_ratio: 0.6,
            method: PeakMethod::Gaussian,
            max_width_px: 24.0,
            background_px: 16,
            continuity_px: 2.0,
            volume_margin_mm: 5.0,
            past_axis_mm: 10.0,
        }
    }
}

/// The line's centre in one row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinePeak {
    /// Image row.
    pub row: usize,
    /// Sub-pixel column.
    pub col: Real,
    /// Height above the background (levels).
    pub peak: Real,
}

/// Why a row has no peak (counted in reports).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, serde::Deserialize)]
#[serde(default)]
pub struct LineReport {
    /// Rows with a peak.
    pub found: usize,
    /// Rows (inside the working volume where there is one) without any candidate above `min_peak`.
    pub faint: usize,
    /// Rows whose only candidates were saturated over more than a line's width.
    pub saturated: usize,
    /// Rows with two candidates and no way to tell which is the laser.
    pub doubled: usize,
    /// Rows whose only candidates were too wide for a laser line.
    pub too_wide: usize,
    /// Rows whose only candidates lay outside the working volume (the wall, the table).
    pub outside: usize,
    /// Rows the working volume does not reach (not searched).
    pub unsearched: usize,
    /// Whether the background was estimated (no laser-off frame).
    pub estimated_background: bool,
}

/// Lines wider than this at half their height (pixels) are centred by their centre of mass.
const WIDE_LINE_PX: Real = 4.0;

/// A peak in one row, before the choice.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    col: Real,
    peak: Real,
    width: Real,
    saturated: bool,
}

/// The half-maximum crossings either side of peak `m` (sub-pixel, linear between pixels).
fn half_crossings(s: &[f32], m: usize) -> (Real, Real) {
    let half = 0.5 * s[m];
    let mut l = m;
    while l > 0 && s[l - 1] >= half {
        l -= 1;
    }
    let mut r = m;
    while r + 1 < s.len() && s[r + 1] >= half {
        r += 1;
    }
    let cross = |inside: usize, outside: Option<usize>| -> Real {
        match outside {
            Some(o) => {
                let (a, b) = (s[o] as Real, s[inside] as Real);
                let t = if b > a { (half as Real - a) / (b - a) } else { 0.5 };
                o as Real + t * (inside as Real - o as Real)
            }
            None => inside as Real,
        }
    };
    (cross(l, l.checked_sub(1)), cross(r, (r + 1 < s.len()).then_some(r + 1)))
}

/// The centre of an unsaturated peak at `m`.
fn centre(s: &[f32], m: usize, p: &LaserParams) -> Real {
    if p.method == PeakMethod::Gaussian && m > 0 && m + 1 < s.len() {
        let (a, b, c) = (s[m - 1] as Real, s[m] as Real, s[m + 1] as Real);
        if a > 0.0 && c > 0.0 {
            let (la, lb, lc) = (a.ln(), b.ln(), c.ln());
            let denom = la - 2.0 * lb + lc;
            if denom < -1e-9 {
                let off = 0.5 * (la - lc) / denom;
                if off.abs() <= 1.0 {
                    return m as Real + off;
                }
            }
        }
    }
    let (lo, hi) = (m.saturating_sub(p.window), (m + p.window).min(s.len() - 1));
    // Weights above half the peak only: the tails carry noise and the other side's shading.
    let floor = 0.5 * s[m] as Real;
    let (mut sum, mut sw) = (0.0, 0.0);
    for (c, &v) in s.iter().enumerate().take(hi + 1).skip(lo) {
        let wgt = (v as Real - floor).max(0.0);
        sum += c as Real * wgt;
        sw += wgt;
    }
    if sw > 0.0 { sum / sw } else { m as Real }
}

/// Every peak of a row's signal: local maxima above `min_peak` that are the largest within
/// `±window`, leftmost of a plateau.
fn candidates(s: &[f32], raw: &[u8], p: &LaserParams, out: &mut Vec<Candidate>) {
    out.clear();
    let (min, hi) = (p.min_peak as f32, s.len() - 1);
    let mut c = 0;
    while c <= hi {
        let v = s[c];
        if v < min {
            c += 1;
            continue;
        }
        let (a, b) = (c.saturating_sub(p.window), (c + p.window).min(hi));
        // The largest in its window, and the first of equals (a clipped top is one peak).
        let is_peak = (a..=b).all(|k| if k < c { s[k] < v } else { s[k] <= v });
        if !is_peak {
            c += 1;
            continue;
        }
        let (l, r) = half_crossings(s, c);
        let saturated =
            raw[(l.ceil() as usize).min(c)..=(r.floor() as usize).max(c)].iter().any(|&x| x >= p.saturation);
        // A wide line (a defocused or far laser, a JPEG's smeared one) is sampled by many pixels: their
        // centre of mass above half the peak averages their noise, where three pixels of a Gaussian fit
        // would see only the top. Narrow lines keep the fit, which the few pixels of their flanks bias
        // least.
        let col = if saturated {
            0.5 * (l + r)
        } else if r - l > WIDE_LINE_PX {
            let floor = 0.5 * v as Real;
            let (lo, hi) = ((l.ceil() as usize).min(c), (r.floor() as usize).max(c));
            let (sum, sw) = (lo..=hi).fold((0.0, 0.0), |(a, b), k| {
                let wgt = (s[k] as Real - floor).max(0.0);
                (a + k as Real * wgt, b + wgt)
            });
            if sw > 0.0 { sum / sw } else { c as Real }
        } else {
            centre(s, c, p)
        };
        out.push(Candidate { col, peak: v as Real, width: r - l, saturated });
        // Skip the rest of this peak's window: nothing in it can be another peak.
        c = b + 1;
    }
}

/// A row's candidates sorted by what rejected them, or the usable ones.
enum RowFind {
    Unsearched,
    Outside,
    Faint,
    TooWide,
    Saturated,
    Usable(Vec<Candidate>),
}

/// What became of one row: its peak found, or why it has none (the reasons [`LineReport`] counts).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RowOutcome {
    /// A peak was chosen.
    Found,
    /// Outside the working volume's reach: not searched.
    Unsearched,
    /// Candidates only outside the working volume.
    Outside,
    /// No candidate above `min_peak`.
    Faint,
    /// Only candidates too wide for a laser line.
    TooWide,
    /// Only saturated candidates wider than a line.
    Saturated,
    /// Comparable candidates and no neighbour to tell them apart.
    Doubled,
}

/// Finds the laser line in every row of `frame`.
///
/// `windows` limits each row's search (see [`window`]); `keep` masks single pixels out (the printed
/// board during calibration). Rows are independent and run in parallel; the continuity choice then
/// resolves rows with several candidates from their neighbours.
pub fn extract_line(
    frame: &Image8,
    background: Background<'_>,
    colour: LaserColour,
    windows: Option<&RowWindows>,
    p: &LaserParams,
    keep: impl Fn(usize, usize) -> bool + Sync,
) -> (Vec<LinePeak>, LineReport) {
    let (peaks, report, _) = extract_line_explained(frame, background, colour, windows, p, keep);
    (peaks, report)
}

/// [`extract_line`], with what became of each row (for a live view that marks rejected rows by
/// their reason).
pub fn extract_line_explained(
    frame: &Image8,
    background: Background<'_>,
    colour: LaserColour,
    windows: Option<&RowWindows>,
    p: &LaserParams,
    keep: impl Fn(usize, usize) -> bool + Sync,
) -> (Vec<LinePeak>, LineReport, Vec<RowOutcome>) {
    let (w, h) = (frame.width as usize, frame.height as usize);
    let finds: Vec<RowFind> = (0..h)
        .into_par_iter()
        .map_init(
            || (vec![0.0f32; w], vec![0u8; w], Vec::new(), signal::Scratch::default()),
            |(s, raw, all, scratch): &mut (Vec<f32>, Vec<u8>, Vec<Candidate>, signal::Scratch), r| {
                if windows.is_some_and(|win| win.row(r).is_none()) {
                    return RowFind::Unsearched;
                }
                signal::row_signal(frame, background, colour, r, p.background_px, s, scratch);
                for (c, (x, v)) in raw.iter_mut().zip(s.iter_mut()).enumerate() {
                    *x = signal::raw_max(frame, r * w + c);
                    if !keep(c, r) {
                        *v = 0.0;
                    }
                }
                // Candidates over the whole row, so one outside the window is known to be there.
                candidates(s, raw, p, all);
                let inside: Vec<Candidate> =
                    all.iter().copied().filter(|k| windows.is_none_or(|win| win.contains(r, k.col))).collect();
                if inside.is_empty() {
                    return if all.is_empty() { RowFind::Faint } else { RowFind::Outside };
                }
                let line_like: Vec<Candidate> = inside.iter().copied().filter(|k| k.width <= p.max_width_px).collect();
                if line_like.is_empty() {
                    return if inside.iter().any(|k| k.saturated) { RowFind::Saturated } else { RowFind::TooWide };
                }
                RowFind::Usable(line_like)
            },
        )
        .collect();
    let (peaks, mut report, outcomes) = choose(&finds, p);
    report.estimated_background = matches!(background, Background::Estimated);
    (peaks, report, outcomes)
}

/// Picks one candidate per row: a row's only (or clearly strongest) candidate first, then, in rows
/// with several comparable ones, the one continuing the nearest chosen rows' line.
fn choose(finds: &[RowFind], p: &LaserParams) -> (Vec<LinePeak>, LineReport, Vec<RowOutcome>) {
    let mut report = LineReport::default();
    let h = finds.len();
    let mut chosen: Vec<Option<Candidate>> = vec![None; h];
    let mut outcomes = vec![RowOutcome::Found; h];
    let mut ambiguous = Vec::new();
    for (r, f) in finds.iter().enumerate() {
        let mut reject = |count: &mut usize, why: RowOutcome| {
            *count += 1;
            outcomes[r] = why;
        };
        match f {
            RowFind::Unsearched => reject(&mut report.unsearched, RowOutcome::Unsearched),
            RowFind::Outside => reject(&mut report.outside, RowOutcome::Outside),
            RowFind::Faint => reject(&mut report.faint, RowOutcome::Faint),
            RowFind::TooWide => reject(&mut report.too_wide, RowOutcome::TooWide),
            RowFind::Saturated => reject(&mut report.saturated, RowOutcome::Saturated),
            RowFind::Usable(c) => {
                let mut sorted = c.clone();
                sorted.sort_by(|a, b| b.peak.total_cmp(&a.peak));
                if sorted.len() == 1 || sorted[1].peak <= p.double_peak_ratio * sorted[0].peak {
                    chosen[r] = Some(sorted[0]);
                } else {
                    ambiguous.push(r);
                }
            }
        }
    }
    // Rows with comparable candidates: the one nearest the line of the closest decided rows.
    const REACH: usize = 8;
    let anchors = chosen.clone();
    for r in ambiguous {
        let near = |range: &mut dyn Iterator<Item = usize>| {
            range.take(REACH).find_map(|k| anchors[k].map(|c| (k.abs_diff(r), c.col)))
        };
        let above = near(&mut (0..r).rev());
        let below = near(&mut (r + 1..h));
        let predicted = match (above, below) {
            (Some((da, a)), Some((db, b))) => Some(((a * db as Real + b * da as Real) / (da + db) as Real, da.min(db))),
            (Some((d, a)), None) | (None, Some((d, a))) => Some((a, d)),
            (None, None) => None,
        };
        let RowFind::Usable(cands) = &finds[r] else { continue };
        let pick = predicted.and_then(|(col, d)| {
            let tol = p.continuity_px * d as Real;
            let mut near: Vec<&Candidate> = cands.iter().filter(|c| (c.col - col).abs() <= tol).collect();
            near.sort_by(|a, b| (a.col - col).abs().total_cmp(&(b.col - col).abs()));
            match near.as_slice() {
                [one] => Some(**one),
                [a, b, ..] if (b.col - col).abs() > 2.0 * (a.col - col).abs() + 1.0 => Some(**a),
                _ => None,
            }
        });
        match pick {
            Some(c) => chosen[r] = Some(c),
            None => {
                report.doubled += 1;
                outcomes[r] = RowOutcome::Doubled;
            }
        }
    }
    let peaks: Vec<LinePeak> = chosen
        .iter()
        .enumerate()
        .filter_map(|(row, c)| c.map(|c| LinePeak { row, col: c.col, peak: c.peak }))
        .collect();
    report.found = peaks.len();
    (peaks, report, outcomes)
}

/// Finds the line in every row of `on` (laser on) against `off` (laser off), grey levels, no
/// working volume.
pub fn detect_line(on: &Image8, off: &Image8, p: &LaserParams) -> (Vec<LinePeak>, LineReport) {
    extract_line(on, Background::Frame(off), LaserColour::White, None, p, |_, _| true)
}

/// [`detect_line`] over only the pixels `(column, row)` for which `keep` holds — the printed board
/// during laser calibration, where the platter and background would otherwise win rows or double
/// them.
pub fn detect_line_within(
    on: &Image8,
    off: &Image8,
    p: &LaserParams,
    keep: impl Fn(usize, usize) -> bool + Sync,
) -> (Vec<LinePeak>, LineReport) {
    extract_line(on, Background::Frame(off), LaserColour::White, None, p, keep)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn profile(centre: Real, sigma: Real, amp: Real) -> Vec<Real> {
        (0..64).map(|c| amp * (-0.5 * ((c as Real - centre) / sigma).powi(2)).exp()).collect()
    }

    fn row(values: Vec<Real>) -> Image8 {
        Image8::gray(
            values.len() as u32,
            1,
            values.iter().map(|v| (10.0 + v).round().clamp(0.0, 255.0) as u8).collect(),
        )
    }

    #[test]
    fn gaussian_and_centre_of_mass_find_a_sub_pixel_line() {
        let off = Image8::gray(64, 1, vec![10; 64]);
        for centre in [20.0, 20.25, 31.5, 40.8] {
            for method in [PeakMethod::Gaussian, PeakMethod::CentreOfMass] {
                let (peaks, _) =
                    detect_line(&row(profile(centre, 1.8, 180.0)), &off, &LaserParams { method, ..Default::default() });
                assert!((peaks[0].col - centre).abs() < 0.06, "{method:?} at {centre}: {}", peaks[0].col);
            }
        }
    }

    #[test]
    fn a_saturated_line_is_centred_on_its_clipped_top() {
        let off = Image8::gray(64, 1, vec![10; 64]);
        for centre in [30.0, 30.3, 30.5] {
            let (peaks, r) = detect_line(&row(profile(centre, 2.0, 900.0)), &off, &LaserParams::default());
            assert_eq!(r.found, 1);
            assert!((peaks[0].col - centre).abs() < 0.15, "at {centre}: {}", peaks[0].col);
        }
    }

    #[test]
    fn faint_wide_and_double_lines_are_rejected() {
        let off = Image8::gray(64, 1, vec![10; 64]);
        let p = LaserParams::default();
        assert_eq!(detect_line(&row(profile(30.0, 1.5, 5.0)), &off, &p).1.faint, 1);
        assert_eq!(detect_line(&row(profile(30.0, 14.0, 150.0)), &off, &p).1.too_wide, 1);
        let two: Vec<Real> =
            profile(15.0, 1.5, 150.0).iter().zip(profile(45.0, 1.5, 140.0)).map(|(a, b)| a + b).collect();
        assert_eq!(detect_line(&row(two), &off, &p).1.doubled, 1);
        // A clearly weaker second line (a faint reflection) leaves the strong one.
        let weak: Vec<Real> =
            profile(15.0, 1.5, 150.0).iter().zip(profile(45.0, 1.5, 50.0)).map(|(a, b)| a + b).collect();
        let (peaks, _) = detect_line(&row(weak), &off, &p);
        assert!((peaks[0].col - 15.0).abs() < 0.1);
    }

    #[test]
    fn each_row_s_outcome_is_the_reason_the_report_counts() {
        // Five rows: a line, a faint one, a wide one, two comparable lines, nothing.
        let rows = [
            profile(30.0, 1.5, 150.0),
            profile(30.0, 1.5, 5.0),
            profile(30.0, 14.0, 150.0),
            profile(15.0, 1.5, 150.0).iter().zip(profile(45.0, 1.5, 140.0)).map(|(a, b)| a + b).collect(),
            vec![0.0; 64],
        ];
        let data: Vec<u8> = rows.iter().flatten().map(|v| (10.0 + v).round().clamp(0.0, 255.0) as u8).collect();
        let on = Image8::gray(64, 5, data);
        let off = Image8::gray(64, 5, vec![10; 64 * 5]);
        let (peaks, r, outcomes) = extract_line_explained(
            &on,
            Background::Frame(&off),
            LaserColour::White,
            None,
            &LaserParams::default(),
            |_, _| true,
        );
        use RowOutcome::*;
        assert_eq!(outcomes, vec![Found, Faint, TooWide, Doubled, Faint]);
        assert_eq!((peaks.len(), r.found, r.faint, r.too_wide, r.doubled), (1, 1, 2, 1, 1));
        assert_eq!(
            extract_line(&on, Background::Frame(&off), LaserColour::White, None, &LaserParams::default(), |_, _| true)
                .0,
            peaks
        );
    }

    #[test]
    fn a_brighter_reflection_outside_the_window_is_not_the_line() {
        let off = Image8::gray(64, 1, vec![10; 64]);
        let values: Vec<Real> =
            profile(15.0, 1.5, 60.0).iter().zip(profile(50.0, 1.5, 200.0)).map(|(a, b)| a + b).collect();
        let win = RowWindows { rows: vec![Some((5, 30))] };
        let (peaks, r) = extract_line(
            &row(values.clone()),
            Background::Frame(&off),
            LaserColour::White,
            Some(&win),
            &LaserParams::default(),
            |_, _| true,
        );
        assert_eq!(r.found, 1);
        assert!((peaks[0].col - 15.0).abs() < 0.1);
        let only_wall = RowWindows { rows: vec![Some((20, 40))] };
        let frame = row(profile(50.0, 1.5, 200.0));
        let (_, r) = extract_line(
            &frame,
            Background::Frame(&off),
            LaserColour::White,
            Some(&only_wall),
            &LaserParams::default(),
            |_, _| true,
        );
        assert_eq!(r.outside, 1);
    }

    #[test]
    fn continuity_with_the_neighbouring_rows_resolves_two_comparable_candidates() {
        // Rows 0–9: one line drifting right; row 5 also holds an equally bright spot 20 px away.
        let (w, h) = (64usize, 10usize);
        let mut data = vec![10u8; w * h];
        for r in 0..h {
            let line = profile(20.0 + 0.3 * r as Real, 1.5, 150.0);
            let spot = if r == 5 { profile(42.0, 1.5, 150.0) } else { vec![0.0; w] };
            for c in 0..w {
                data[r * w + c] = (10.0 + line[c] + spot[c]).round() as u8;
            }
        }
        let on = Image8::gray(w as u32, h as u32, data);
        let off = Image8::gray(w as u32, h as u32, vec![10; w * h]);
        let (peaks, r) = detect_line(&on, &off, &LaserParams::default());
        assert_eq!((r.found, r.doubled), (10, 0));
        assert!((peaks[5].col - 21.5).abs() < 0.1, "{}", peaks[5].col);
    }

    #[test]
    fn a_red_line_is_found_in_a_colour_frame_under_white_light_without_a_laser_off_frame() {
        // White light (all channels) with a bright white patch, and a red line.
        let w = 128;
        let line = (0..w).map(|c| 120.0 * (-0.5 * ((c as Real - 80.3) / 1.6).powi(2)).exp());
        let data: Vec<u8> = line
            .enumerate()
            .flat_map(|(c, l)| {
                let white = 60.0 + if (20..40).contains(&c) { 150.0 } else { 0.0 };
                [(white + l).min(255.0) as u8, white as u8, (white - 3.0) as u8]
            })
            .collect();
        let frame = Image8 { width: w as u32, height: 1, channels: 3, data };
        let (peaks, r) =
            extract_line(&frame, Background::Estimated, LaserColour::Red, None, &LaserParams::default(), |_, _| true);
        assert_eq!(r.found, 1, "{r:?}");
        assert!((peaks[0].col - 80.3).abs() < 0.1, "{}", peaks[0].col);
    }
}
