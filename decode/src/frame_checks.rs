//! What the frames of a structured-light view say about themselves, checked while they are decoded.
//!
//! A Gray code with inverses and white and black frames is redundant, and the redundancy shows a
//! capture that went wrong before any geometry does:
//! - **white brighter than black**: where the projector reaches, the white frame is brighter; swapped,
//!   nothing would be lit and the map would be empty;
//! - **complementary pairs**: a pattern and its inverse add up to white + black on every lit pixel (light
//!   is additive; a stripe too fine for the camera is grey in both, which still adds up). A pair that does
//!   not — two frames of different bits, taken out of order — is named;
//! - **no dark frame**: a pattern frame lit nowhere while its inverse is lit in places is a missed
//!   projector flip (a frame taken of a dark screen);
//! - **continuous codes**: neighbouring pixels get neighbouring projector indices except across depth
//!   edges. A pattern and its inverse swapped flips that bit, which makes the decoded index jump at every
//!   stripe of that bit; when flipping one bit back removes most jumps, that pair is named;
//! - **not mirrored**: projector and camera see the surface from the same side, so the map keeps the
//!   image's handedness (the Jacobian of (column, row) over (x, y) is positive). A mirrored map is the
//!   most significant pair of one axis swapped (the only swap the continuity check cannot see).
//!
//! A check that fails on a fifth or more of the lit pixels ([`FATAL_FRACTION`]) makes the map mostly
//! wrong there: decoding fails with every such frame named, unless forced
//! ([`crate::DecodeParams::force`]). Smaller failures (from [`WARN_FRACTION`]) are reported as warnings.

use serde::{Deserialize, Serialize};
use std::fmt;

/// Pixels decoded per block: a fifth of a 1280-px row, so background blocks skip their frame reads (measured
/// best of 128–2048), and long enough that the inner loops over one frame vectorise. The frame checks
/// keep per-block state of the same size.
pub(crate) const BLOCK: usize = 256;

/// Fraction of the checked pixels from which a failed check makes the map fail (unless forced).
pub const FATAL_FRACTION: f64 = 0.2;
/// Fraction of the checked pixels from which a failed check is reported as a warning.
pub const WARN_FRACTION: f64 = 0.05;
/// A pixel takes part in the pair checks where white − black is at least this (grey levels): below it,
/// camera noise alone would fail them.
pub const CHECK_SWING: f32 = 32.0;
/// A pattern and its inverse fail to be complementary at a pixel where their sum differs from white +
/// black by more than this fraction of white − black (a stripe blurred to grey, through a camera's gamma,
/// stays below half).
pub const COMPLEMENT_TOLERANCE: f32 = 0.6;
/// A frame is dark where it is no brighter than black + this fraction of white − black.
pub const DARK_LEVEL: f32 = 0.25;

/// Which check failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IssueKind {
    /// The black frame is brighter than the white one where the projector reaches.
    WhiteBlackSwapped,
    /// White and black differ by the shadow threshold nowhere: nothing is lit.
    NothingLit,
    /// A pattern frame is dark where its inverse is lit (a missed projector flip); names that frame
    /// first, its partner second.
    DarkFrame,
    /// A pattern and its inverse do not add up to white + black: not one pair (frames out of order).
    NotComplementary,
    /// A pattern and its inverse swapped: flipping that bit removes most jumps in the code.
    InverseSwapped,
    /// The map is mirrored: the most significant pair of an axis swapped.
    Mirrored,
    /// Every pattern of an axis swapped with its inverse (the `_inv` frames taken as the patterns):
    /// the code inverted fits the phase, or is continuous, where as decoded it is not. Names the
    /// axis's first pair, then its last.
    AllInversesSwapped,
}

/// One failed check, with the frames it concerns.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameIssue {
    /// What failed.
    pub kind: IssueKind,
    /// The frames, as indices into the frames given to the decoder.
    pub frames: Vec<usize>,
    /// The frames' names: the patterns they show, until the caller names their files
    /// ([`crate::DecodeError::name_frames`], [`crate::DecodeReport::name_frames`]).
    pub names: Vec<String>,
    /// Fraction (0 to 1) of the checked pixels the failure concerns.
    pub fraction: f64,
    /// True when the failure makes the map mostly wrong (decoding fails unless forced).
    pub fatal: bool,
}

impl FrameIssue {
    pub(crate) fn new(kind: IssueKind, frames: Vec<usize>, names: Vec<String>, fraction: f64) -> FrameIssue {
        let fatal = fraction >= FATAL_FRACTION;
        FrameIssue { kind, frames, names, fraction, fatal }
    }

    fn name(&self, k: usize) -> &str {
        self.names.get(k).map(String::as_str).unwrap_or("?")
    }
}

impl fmt::Display for FrameIssue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let pct = 100.0 * self.fraction;
        let (a, b) = (self.name(0), self.name(1));
        match self.kind {
            IssueKind::WhiteBlackSwapped => write!(
                f,
                "white and black look swapped: {b} is brighter than {a} on {pct:.0} % of the pixels where they differ"
            ),
            IssueKind::NothingLit => {
                write!(f, "nothing is lit: {a} (white) is nowhere brighter than {b} (black) by the shadow threshold")
            }
            IssueKind::DarkFrame => write!(
                f,
                "{a} is dark where the projector lights the scene (a missed projector flip?): with {b}, its inverse, \
                 it does not add up to white + black on {pct:.0} % of lit pixels"
            ),
            IssueKind::NotComplementary => write!(
                f,
                "{a} and {b} are not a pattern and its inverse: they do not add up to white + black on {pct:.0} % of \
                 lit pixels (frames out of order or missing?)"
            ),
            IssueKind::InverseSwapped => write!(
                f,
                "{a} and {b} look swapped (the pattern and its inverse): with that bit flipped back the code is \
                 continuous, as decoded it jumps at every stripe of that bit"
            ),
            IssueKind::AllInversesSwapped => write!(
                f,
                "every Gray-code pair from {a} to {} looks swapped, each pattern with its inverse ({a} with {b}, …, \
                 {} with {}): read the other way round the code fits where as read it does not (frames named the \
                 wrong way round?)",
                self.name(3),
                self.name(2),
                self.name(3)
            ),
            IssueKind::Mirrored => write!(
                f,
                "the decoded map is mirrored, which no projector and camera facing one scene give: {a} and {b} (the \
                 most significant pair) look swapped"
            ),
        }
    }
}

/// The failed checks in one sentence, fatal ones first (the first six, and how many more).
pub fn describe(issues: &[FrameIssue]) -> String {
    const SHOWN: usize = 6;
    let mut parts: Vec<String> = issues.iter().filter(|i| i.fatal).map(ToString::to_string).collect();
    parts.extend(issues.iter().filter(|i| !i.fatal).map(ToString::to_string));
    if parts.len() > SHOWN {
        let more = parts.len() - SHOWN;
        parts.truncate(SHOWN);
        parts.push(format!("and {more} more"));
    }
    parts.join("; ")
}

/// Pixel counts the checks gather, block by block, summed over the view.
#[derive(Debug, Clone, Default)]
pub(crate) struct Counts {
    /// Pixels where white − black ≥ [`CHECK_SWING`].
    pub checked: usize,
    /// Pixels where black − white ≥ [`CHECK_SWING`].
    pub reversed: usize,
    /// Per Gray pair (columns, then rows): checked pixels where the pair does not add up.
    pub not_complementary: Vec<usize>,
    /// Per Gray pair: checked pixels where the pattern frame, and where the inverse frame, is dark.
    pub dark: Vec<(usize, usize)>,
}

impl Counts {
    pub(crate) fn new(pairs: usize) -> Counts {
        Counts { not_complementary: vec![0; pairs], dark: vec![(0, 0); pairs], ..Default::default() }
    }

    pub(crate) fn add(mut self, o: Counts) -> Counts {
        self.checked += o.checked;
        self.reversed += o.reversed;
        for (a, b) in self.not_complementary.iter_mut().zip(o.not_complementary) {
            *a += b;
        }
        for (a, b) in self.dark.iter_mut().zip(o.dark) {
            a.0 += b.0;
            a.1 += b.1;
        }
        self
    }
}

/// The pair checks over one block of pixels: `white`, `black` and each pair's frames, the same range.
pub(crate) fn check_block(white: &[u8], black: &[u8], pairs: &[(&[u8], &[u8])], counts: &mut Counts) {
    let n = white.len();
    let mut checked = [false; BLOCK];
    for k in 0..n {
        let swing = white[k] as f32 - black[k] as f32;
        checked[k] = swing >= CHECK_SWING;
        counts.checked += usize::from(checked[k]);
        counts.reversed += usize::from(-swing >= CHECK_SWING);
    }
    if !checked[..n].iter().any(|&c| c) {
        return;
    }
    for (q, (pat, inv)) in pairs.iter().enumerate() {
        let (mut nc, mut dark_p, mut dark_i) = (0, 0, 0);
        for k in (0..n).filter(|&k| checked[k]) {
            let (w, b) = (white[k] as f32, black[k] as f32);
            let swing = w - b;
            let (p, i) = (pat[k] as f32, inv[k] as f32);
            nc += usize::from((p + i - w - b).abs() > COMPLEMENT_TOLERANCE * swing);
            let dark = b + DARK_LEVEL * swing;
            dark_p += usize::from(p <= dark);
            dark_i += usize::from(i <= dark);
        }
        counts.not_complementary[q] += nc;
        counts.dark[q].0 += dark_p;
        counts.dark[q].1 += dark_i;
    }
}

/// `f(a, b)` for the decoded indices of each pixel of row `y` and its right and lower neighbours,
/// where both are decoded (`u32::MAX` is undecoded).
fn row_pairs(index: &[u32], width: usize, height: usize, y: usize, mut f: impl FnMut(u32, u32)) {
    for x in 0..width {
        let a = index[y * width + x];
        if a == u32::MAX {
            continue;
        }
        let right = (x + 1 < width).then(|| index[y * width + x + 1]);
        let down = (y + 1 < height).then(|| index[(y + 1) * width + x]);
        for b in [right, down].into_iter().flatten().filter(|&b| b != u32::MAX) {
            f(a, b);
        }
    }
}

/// Jumps in a decoded axis between neighbours, as decoded and with each bit flipped back: a bit whose
/// flip removes most of them is a swapped pair. `index` holds each pixel's integer projector index
/// (`u32::MAX` where undecoded), `bits` the code's length; returns the bit positions (0 = most
/// significant) that look swapped. The most significant bit is left out: flipping it reverses the whole
/// axis, which keeps the code continuous ([`mirrored`] looks at it).
pub(crate) fn swapped_bits(index: &[u32], width: usize, height: usize, bits: u32) -> Vec<u32> {
    use rayon::prelude::*;
    // Below a block of 8 projector pixels a flipped bit's jump is within a steep surface's slope.
    let candidates: Vec<u32> = (1..bits).filter(|&b| bits - b >= 3).collect();
    if candidates.is_empty() || width < 2 || height < 2 {
        return Vec::new();
    }
    let counts = (0..height)
        .into_par_iter()
        .map(|y| {
            let mut c = vec![(0usize, 0usize); candidates.len()];
            let mut pairs = 0usize;
            row_pairs(index, width, height, y, |a, b| {
                pairs += 1;
                for (slot, &bit) in c.iter_mut().zip(&candidates) {
                    let j = bits - 1 - bit;
                    let mask = (1u32 << (j + 1)) - 1;
                    let limit = 1i64 << (j + 1);
                    let jump = |p: u32, q: u32| (p as i64 - q as i64).abs() > limit;
                    slot.0 += usize::from(jump(a, b));
                    slot.1 += usize::from(jump(a ^ mask, b ^ mask));
                }
            });
            (c, pairs)
        })
        .reduce(
            || (vec![(0, 0); candidates.len()], 0),
            |(mut a, pa), (b, pb)| {
                for (x, y) in a.iter_mut().zip(b) {
                    x.0 += y.0;
                    x.1 += y.1;
                }
                (a, pa + pb)
            },
        );
    let (c, pairs) = counts;
    candidates
        .iter()
        .zip(c)
        .filter(|&(_, (as_decoded, flipped))| {
            as_decoded >= 20 && as_decoded as f64 >= 1e-3 * pairs as f64 && flipped * 2 < as_decoded
        })
        .map(|(&b, _)| b)
        .collect()
}

/// Whether the decoded axis is continuous only with every pair swapped back: every Gray bit flipped
/// turns the binary index `x` into `x ^ C`, `C` the inverse Gray code of all ones, so neighbours jump
/// at every stripe of every bit. Jumps over 8 projector pixels, counted as for [`swapped_bits`].
pub(crate) fn all_swapped(index: &[u32], width: usize, height: usize, bits: u32) -> bool {
    if bits < 4 || width < 2 || height < 2 {
        return false;
    }
    let c = rig::patterns::gray_inverse(u32::MAX.checked_shr(32 - bits).unwrap_or(0));
    // Counted against the neighbours whose index changes: a camera finer than the projector sees
    // many neighbours on one projector pixel, which no flip makes jump.
    let (mut as_decoded, mut flipped, mut changing) = (0usize, 0usize, 0usize);
    let jump = |p: u32, q: u32| (p as i64 - q as i64).abs() > 8;
    for y in 0..height {
        row_pairs(index, width, height, y, |a, b| {
            changing += usize::from(a != b);
            as_decoded += usize::from(jump(a, b));
            flipped += usize::from(jump(a ^ c, b ^ c));
        });
    }
    as_decoded >= 20 && as_decoded as f64 >= 0.05 * changing as f64 && flipped * 4 < as_decoded
}

/// Which axis a mirrored map has reversed, if it is mirrored: `Some(true)` columns, `Some(false)` rows,
/// from the signs of the map's Jacobian over `step`-pixel differences (`u`, `v` NaN where undecoded).
/// `None` when the map keeps the image's handedness or too few pixels say.
pub(crate) fn mirrored(u: &[f64], v: &[f64], width: usize, height: usize) -> Option<bool> {
    const STEP: usize = 3;
    if width <= STEP || height <= STEP {
        return None;
    }
    let (mut pos, mut neg, mut u_back, mut v_back) = (0usize, 0usize, 0usize, 0usize);
    for y in 0..height - STEP {
        for x in 0..width - STEP {
            let i = y * width + x;
            let (r, d) = (i + STEP, i + STEP * width);
            let (ux, uy, vx, vy) = (u[r] - u[i], u[d] - u[i], v[r] - v[i], v[d] - v[i]);
            let det = ux * vy - uy * vx;
            if !det.is_finite() || det == 0.0 {
                continue;
            }
            if det > 0.0 {
                pos += 1;
            } else {
                neg += 1;
                u_back += usize::from(ux < 0.0);
                v_back += usize::from(vy < 0.0);
            }
        }
    }
    (neg >= 100 && neg > 4 * pos).then_some(u_back >= v_back)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flipped_bit_is_found_by_the_jumps_it_makes() {
        let (w, h, bits) = (200usize, 20usize, 10u32);
        let truth: Vec<u32> = (0..w * h).map(|i| 100 + (3 * (i % w)) as u32).collect();
        assert!(swapped_bits(&truth, w, h, bits).is_empty());
        for bit in 1..bits - 2 {
            let mask = (1u32 << (bits - bit)) - 1;
            let wrong: Vec<u32> = truth.iter().map(|i| i ^ mask).collect();
            assert_eq!(swapped_bits(&wrong, w, h, bits), vec![bit], "bit {bit}");
        }
    }

    #[test]
    fn a_reversed_axis_is_a_mirror() {
        let (w, h) = (40usize, 30usize);
        let u: Vec<f64> = (0..w * h).map(|i| 2.0 * (i % w) as f64 + 0.3 * (i / w) as f64).collect();
        let v: Vec<f64> = (0..w * h).map(|i| 2.0 * (i / w) as f64).collect();
        assert_eq!(mirrored(&u, &v, w, h), None);
        let back: Vec<f64> = u.iter().map(|x| 1023.0 - x).collect();
        assert_eq!(mirrored(&back, &v, w, h), Some(true));
        let up: Vec<f64> = v.iter().map(|x| 767.0 - x).collect();
        assert_eq!(mirrored(&u, &up, w, h), Some(false));
        assert_eq!(mirrored(&back, &up, w, h), None, "turned 180°: a ceiling-mounted projector");
    }
}
