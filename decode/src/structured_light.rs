//! Decoding a structured-light view: Gray code with inverses for the projector index, shadow and contrast
//! masks from the white and black frames, and N-step phase shift, unwrapped by the Gray code and checked
//! against it, for sub-pixel projector coordinates. One fused, parallel pass over the frames.

use crate::phase_shift::{PhaseSteps, unwrap};
use crate::projector_map::ProjectorMap;
use rayon::prelude::*;
use rig::image::Image8;
use rig::{Axis, Pattern};
use serde::Serialize;

/// Thresholds of the decoder (grey levels of 8-bit frames).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DecodeParams {
    /// A pixel is in shadow (not decoded) where white − black is below this.
    pub shadow_threshold: f64,
    /// Without phase shift, a pixel whose weakest Gray bit has |pattern − inverse| below this is dropped;
    /// above it, the weakest bit sets the confidence. A Gray-code bit decided wrongly near its stripe
    /// edge moves the index by one only, so the default drops exact ties alone; OpenCV drops below 5.
    /// (With phase shift the phase decides the fine position and this is not used.)
    pub bit_threshold: u8,
    /// Phase modulation B below this (grey levels) drops the pixel.
    pub min_modulation: f64,
    /// Phase and Gray code must agree within this many projector pixels (the period consistency check).
    pub phase_tolerance_px: f64,
    /// Without phase shift, a Gray-code coordinate is refined from a quadratic fitted to its decoded
    /// neighbours within this radius (camera pixels, 2 or more; [`crate::gray_subpixel`]). 0 keeps the
    /// integer column, as OpenCV's GrayCodePattern gives it.
    pub gray_fit_radius: usize,
}

impl Default for DecodeParams {
    fn default() -> Self {
        DecodeParams {
            shadow_threshold: 12.0,
            bit_threshold: 1,
            min_modulation: 3.0,
            phase_tolerance_px: 1.5,
            gray_fit_radius: 4,
        }
    }
}

/// What decoding a view found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, serde::Deserialize)]
pub struct DecodeReport {
    /// Camera pixels.
    pub pixels: usize,
    /// Pixels the projector lights (white − black above the shadow threshold).
    pub lit: usize,
    /// Pixels with a decoded column.
    pub decoded: usize,
    /// Pixels with a decoded column and row.
    pub decoded_rows: usize,
}

/// A frame set that cannot be decoded.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum DecodeError {
    /// A frame the decoder needs is not in the set.
    #[error("the view has no {0} frame")]
    Missing(&'static str),
    /// Frames of one view differ in size.
    #[error("frame {index} is {found_w}×{found_h}, the view's first frame {w}×{h}")]
    SizeMismatch {
        /// Which frame.
        index: usize,
        /// Its width.
        found_w: u32,
        /// Its height.
        found_h: u32,
        /// The expected width.
        w: u32,
        /// The expected height.
        h: u32,
    },
    /// The Gray-code frames of an axis are incomplete.
    #[error("the {0} Gray code is incomplete (a bit without its inverse, or a bit missing)")]
    IncompleteGray(&'static str),
    /// The Gray code's bit count does not fit the projector's size: the rig's projector is not the
    /// one the frames were made for, and most indices would be thrown away.
    #[error(
        "the {axis} Gray code has {bits} bits, but the projector's {size} {axis}s need {expected}: the rig's \
         projector size does not match the captures"
    )]
    BitsForProjector {
        /// The axis.
        axis: &'static str,
        /// Bits in the frames.
        bits: u32,
        /// The projector's size along the axis.
        size: u32,
        /// Bits that size needs.
        expected: u32,
    },
    /// Phase-shift frames whose period or step count cannot be right.
    #[error(
        "the {axis} phase-shift frames have period {period_px} px and {steps} steps: the period must be a \
             positive number of projector pixels and the steps at least 3"
    )]
    BadPhase {
        /// The axis.
        axis: &'static str,
        /// The period.
        period_px: f64,
        /// The steps.
        steps: u32,
    },
}

/// The frames of one coded axis.
struct AxisFrames<'a> {
    size: u32,
    gray: Vec<(&'a Image8, &'a Image8)>,
    phase: Option<(PhaseSteps, Vec<&'a Image8>)>,
}

fn axis_name(a: Axis) -> &'static str {
    if a == Axis::Columns { "column" } else { "row" }
}

fn collect_axis<'a>(
    frames: &[(Pattern, &'a Image8)],
    axis: Axis,
    size: u32,
) -> Result<Option<AxisFrames<'a>>, DecodeError> {
    let mut bits: Vec<(u32, u32, bool, &Image8)> = frames
        .iter()
        .filter_map(|(p, img)| match *p {
            Pattern::Gray { axis: a, bit, bits, inverse } if a == axis => Some((bit, bits, inverse, *img)),
            _ => None,
        })
        .collect();
    if bits.is_empty() {
        return Ok(None);
    }
    bits.sort_by_key(|b| (b.0, b.2));
    let nbits = bits[0].1;
    let expected = rig::patterns::bits_for(size);
    if nbits != expected {
        return Err(DecodeError::BitsForProjector { axis: axis_name(axis), bits: nbits, size, expected });
    }
    if bits.len() != 2 * nbits as usize
        || bits.iter().enumerate().any(|(k, b)| b.0 != k as u32 / 2 || b.2 != (k % 2 == 1))
    {
        return Err(DecodeError::IncompleteGray(axis_name(axis)));
    }
    let gray = bits.chunks(2).map(|c| (c[0].3, c[1].3)).collect();
    // The first complete phase set of this axis, in step order.
    let mut phase: Vec<(f64, u32, u32, &Image8)> = frames
        .iter()
        .filter_map(|(p, img)| match *p {
            Pattern::Phase { axis: a, period_px, step, steps } if a == axis => Some((period_px, step, steps, *img)),
            _ => None,
        })
        .collect();
    if let Some(&(period_px, _, steps, _)) =
        phase.iter().find(|f| !(f.0.is_finite() && f.0 > 0.0 && f.2 >= 3 && f.1 < f.2))
    {
        return Err(DecodeError::BadPhase { axis: axis_name(axis), period_px, steps });
    }
    let phase = phase.first().map(|&(period, _, steps, _)| (period, steps)).and_then(|(period, steps)| {
        phase.retain(|f| f.0 == period && f.2 == steps);
        phase.sort_by_key(|f| f.1);
        (phase.len() == steps as usize && phase.iter().enumerate().all(|(k, f)| f.1 == k as u32))
            .then(|| (PhaseSteps::new(steps as usize, period), phase.iter().map(|f| f.3).collect()))
    });
    Ok(Some(AxisFrames { size, gray, phase }))
}

/// Pixels decoded per block: a fifth of a 1280-px row, so background blocks skip their frame reads (measured
/// best of 128–2048), and long enough that the inner loops over one frame vectorise.
const BLOCK: usize = 256;

/// One axis decoded over a block of pixels `[i0, i0 + n)`: coordinate (NaN where undecoded) and
/// confidence, written into `out`. Frame-major loops: each frame is read once, contiguously, per block.
/// `want[k]` false skips pixel k's final step (a row is not needed where the column failed).
fn decode_axis_block(
    a: &AxisFrames<'_>,
    i0: usize,
    swing: &[f32],
    want: &[bool],
    p: &DecodeParams,
    out: &mut [(f64, f32)],
) {
    let n = out.len();
    let mut code = [0u32; BLOCK];
    let mut weakest = [u8::MAX; BLOCK];
    // Zipped slices rather than indices: no bounds checks, so these loops vectorise.
    for (pat, inv) in &a.gray {
        let pairs = pat.data[i0..i0 + n].iter().zip(&inv.data[i0..i0 + n]);
        for ((code, weak), (&pa, &pb)) in code[..n].iter_mut().zip(&mut weakest[..n]).zip(pairs) {
            *code = (*code << 1) | u32::from(pa > pb);
            *weak = (*weak).min(pa.abs_diff(pb));
        }
    }
    let mut sums: Option<([f32; BLOCK], [f32; BLOCK])> = None;
    if let Some((steps, frames)) = &a.phase {
        let (mut s, mut c) = ([0f32; BLOCK], [0f32; BLOCK]);
        for (k, f) in frames.iter().enumerate() {
            let (sk, ck) = steps.weights(k);
            for ((s, c), &v) in s[..n].iter_mut().zip(&mut c[..n]).zip(&f.data[i0..i0 + n]) {
                *s += v as f32 * sk;
                *c += v as f32 * ck;
            }
        }
        sums = Some((s, c));
    }
    for k in 0..n {
        out[k] = (f64::NAN, 0.0);
        if !want[k] || swing[k] < p.shadow_threshold as f32 {
            continue;
        }
        let index = rig::patterns::gray_inverse(code[k]);
        if index >= a.size {
            continue;
        }
        match (&a.phase, &sums) {
            (Some((steps, _)), Some((s, c))) => {
                let (wrapped, modulation) = steps.finish(s[k] as f64, c[k] as f64);
                if modulation < p.min_modulation {
                    continue;
                }
                if let Some(x) = unwrap(wrapped, index, steps.period_px, p.phase_tolerance_px) {
                    out[k] = (x, (modulation / (0.5 * swing[k] as f64)).min(1.0) as f32);
                }
            }
            _ if weakest[k] >= p.bit_threshold => out[k] = (index as f64, (weakest[k] as f32 / swing[k]).min(1.0)),
            _ => {}
        }
    }
}

/// Decodes a view's frames (each with the pattern it shows) for a projector of `proj_width ×
/// proj_height`: column coordinates, and row coordinates where rows are coded.
pub fn decode_view(
    frames: &[(Pattern, &Image8)],
    proj_width: u32,
    proj_height: u32,
    params: &DecodeParams,
) -> Result<(ProjectorMap, DecodeReport), DecodeError> {
    let find =
        |want: Pattern, name| frames.iter().find(|(p, _)| *p == want).map(|f| f.1).ok_or(DecodeError::Missing(name));
    let (white, black) = (find(Pattern::White, "white")?, find(Pattern::Black, "black")?);
    for (index, (_, img)) in frames.iter().enumerate() {
        if (img.width, img.height) != (white.width, white.height) {
            let (w, h) = (white.width, white.height);
            return Err(DecodeError::SizeMismatch { index, found_w: img.width, found_h: img.height, w, h });
        }
    }
    let cols = collect_axis(frames, Axis::Columns, proj_width)?.ok_or(DecodeError::Missing("Gray-code column"))?;
    let rows = collect_axis(frames, Axis::Rows, proj_height)?;
    let (w, h) = (white.width as usize, white.height as usize);
    let mut map = ProjectorMap::empty(w, h);
    let mut lit = vec![false; w * h];
    map.u
        .par_chunks_mut(BLOCK)
        .zip(map.v.par_chunks_mut(BLOCK))
        .zip(map.confidence.par_chunks_mut(BLOCK))
        .zip(lit.par_chunks_mut(BLOCK))
        .enumerate()
        .for_each(|(b, (((u, v), conf), lit))| {
            let i0 = b * BLOCK;
            let n = u.len();
            let mut swing = [0f32; BLOCK];
            for k in 0..n {
                swing[k] = white.data[i0 + k] as f32 - black.data[i0 + k] as f32;
                lit[k] = swing[k] >= params.shadow_threshold as f32;
            }
            // Background and shadow come in whole blocks: skip reading the other frames there.
            if !lit.iter().any(|&l| l) {
                return;
            }
            let mut col = [(f64::NAN, 0f32); BLOCK];
            decode_axis_block(&cols, i0, &swing[..n], &lit[..n], params, &mut col[..n]);
            let mut row = [(f64::NAN, 0f32); BLOCK];
            if let Some(r) = &rows {
                let mut want = [false; BLOCK];
                for (w, c) in want.iter_mut().zip(&col[..n]) {
                    *w = c.0.is_finite();
                }
                decode_axis_block(r, i0, &swing[..n], &want[..n], params, &mut row[..n]);
            }
            for k in 0..n {
                if col[k].0.is_finite() {
                    u[k] = col[k].0;
                    v[k] = row[k].0;
                    conf[k] = if row[k].0.is_finite() { col[k].1.min(row[k].1) } else { col[k].1 };
                }
            }
        });
    // Integer Gray-code coordinates refined after the fact: the fit needs whole neighbourhoods.
    if cols.phase.is_none() {
        crate::gray_subpixel::refine(&mut map.u, w, h, params.gray_fit_radius);
    }
    if rows.as_ref().is_some_and(|r| r.phase.is_none()) {
        crate::gray_subpixel::refine(&mut map.v, w, h, params.gray_fit_radius);
    }
    let report = DecodeReport {
        pixels: w * h,
        lit: lit.iter().filter(|&&l| l).count(),
        decoded: map.decoded(),
        decoded_rows: map.v.iter().filter(|v| v.is_finite()).count(),
    };
    Ok((map, report))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::phase_shift::PhaseSteps;

    /// Issue 19, defect 4: frames made for another projector, or phase frames whose period cannot be
    /// right, are refused instead of decoding to (mostly) nothing.
    #[test]
    fn frames_that_do_not_fit_the_projector_are_refused() {
        let img = Image8::gray(4, 3, vec![100; 12]);
        let phases = [rig::PhaseShift { axis: Axis::Columns, period_px: 8.0, steps: 4 }];
        let seq = rig::patterns::structured_light_sequence(1024, 768, &phases);
        let frames: Vec<(Pattern, &Image8)> = seq.iter().map(|p| (*p, &img)).collect();
        let e = decode_view(&frames, 512, 384, &DecodeParams::default()).unwrap_err().to_string();
        assert_eq!(
            e,
            "the column Gray code has 10 bits, but the projector's 512 columns need 9: the rig's projector size \
             does not match the captures"
        );
        for period in [0.0, -16.0, f64::NAN] {
            let bad: Vec<(Pattern, &Image8)> = frames
                .iter()
                .map(|&(p, i)| match p {
                    Pattern::Phase { axis, step, steps, .. } => {
                        (Pattern::Phase { axis, period_px: period, step, steps }, i)
                    }
                    p => (p, i),
                })
                .collect();
            let e = decode_view(&bad, 1024, 768, &DecodeParams::default()).unwrap_err();
            assert!(matches!(e, DecodeError::BadPhase { .. }), "{period}: {e}");
        }
    }

    /// The block decoder against the per-pixel reference primitives on random frames: the fast path
    /// must not change a single decision.
    #[test]
    fn block_decoding_matches_the_per_pixel_reference() {
        let (w, h) = (97usize, 61usize);
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut byte = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 24) as u8
        };
        // The block path alone: integers, as the reference primitives give them.
        let params = DecodeParams { gray_fit_radius: 0, ..DecodeParams::default() };
        let seq = rig::patterns::structured_light_sequence(
            40,
            30,
            &[rig::PhaseShift { axis: Axis::Columns, period_px: 8.0, steps: 4 }],
        );
        let imgs: Vec<Image8> = seq
            .iter()
            .map(|p| match p {
                Pattern::White => Image8::gray(w as u32, h as u32, (0..w * h).map(|_| 200 + byte() % 50).collect()),
                Pattern::Black => Image8::gray(w as u32, h as u32, (0..w * h).map(|_| byte() % 60).collect()),
                _ => Image8::gray(w as u32, h as u32, (0..w * h).map(|_| byte()).collect()),
            })
            .collect();
        let frames: Vec<(Pattern, &Image8)> = seq.iter().copied().zip(imgs.iter()).collect();
        let (map, _) = decode_view(&frames, 40, 30, &params).unwrap();
        let steps = PhaseSteps::new(4, 8.0);
        let col_pairs: Vec<(&Image8, &Image8)> = (0..6).map(|b| (&imgs[2 + 2 * b], &imgs[3 + 2 * b])).collect();
        let row_pairs: Vec<(&Image8, &Image8)> = (0..5).map(|b| (&imgs[14 + 2 * b], &imgs[15 + 2 * b])).collect();
        let phase: Vec<&Image8> = imgs[24..28].iter().collect();
        let mut decoded = 0;
        for i in 0..w * h {
            let swing = imgs[0].data[i] as f64 - imgs[1].data[i] as f64;
            let (ci, _) = crate::gray_code::decode_pixel(col_pairs.iter().map(|(a, b)| (a.data[i], b.data[i])));
            let (wrapped, modulation) = steps.decode_pixel(phase.iter().map(|f| f.data[i]));
            let u = (swing >= params.shadow_threshold && ci < 40 && modulation >= params.min_modulation)
                .then(|| crate::phase_shift::unwrap(wrapped, ci, 8.0, params.phase_tolerance_px))
                .flatten();
            match u {
                Some(u) => {
                    assert!((map.u[i] - u).abs() < 1e-4, "pixel {i}: {} vs {u}", map.u[i]);
                    decoded += 1;
                    let (ri, weak) =
                        crate::gray_code::decode_pixel(row_pairs.iter().map(|(a, b)| (a.data[i], b.data[i])));
                    let row_ok = ri < 30 && weak >= params.bit_threshold;
                    assert_eq!(map.v[i].is_finite(), row_ok, "pixel {i} row");
                    if row_ok {
                        assert_eq!(map.v[i], ri as f64);
                    }
                }
                None => assert!(map.u[i].is_nan(), "pixel {i} decoded by the block path only"),
            }
        }
        assert!(decoded > 100, "{decoded}");
    }
}
