//! Decoding a structured-light view: Gray code with inverses for the projector index, shadow and contrast
//! masks from the white and black frames, and N-step phase shift, unwrapped by the Gray code and checked
//! against it, for sub-pixel projector coordinates. One fused, parallel pass over the frames.

use crate::frame_checks::{BLOCK, Counts, FrameIssue, IssueKind};
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
    /// Decode even where the frames contradict themselves so much that the map is mostly wrong
    /// ([`crate::frame_checks`]): the failed checks are then in the report, as warnings, instead of an
    /// error. Not part of what the map depends on (left out of its fingerprint).
    #[serde(skip)]
    pub force: bool,
}

impl Default for DecodeParams {
    fn default() -> Self {
        DecodeParams {
            shadow_threshold: 12.0,
            bit_threshold: 1,
            min_modulation: 3.0,
            phase_tolerance_px: 1.5,
            gray_fit_radius: 4,
            force: false,
        }
    }
}

/// The largest [`DecodeParams::gray_fit_radius`] (`--gray-fit-radius`): a 33 × 33 window, 13 times the
/// default's work per pixel. The fit's work and memory grow with the window's area, and past this the
/// quadratic no longer follows a real surface's projector coordinates (radius 1000 ran for hours; 2³² and
/// more asked for terabytes).
pub const MAX_GRAY_FIT_RADIUS: usize = 16;

impl DecodeParams {
    /// Checks every threshold (what the command line calls each option): the shadow threshold a grey
    /// level from 0 to 255, the fit radius 0 or from 2 to [`MAX_GRAY_FIT_RADIUS`], the modulation and
    /// phase tolerance finite and non-negative (the tolerance positive). [`decode_view`] calls it first.
    pub fn validate(&self) -> Result<(), DecodeError> {
        let bad = |option: &'static str, value: String, why: &str| {
            Err(DecodeError::Param(rig::limits::ParamError { option, value, why: why.to_string() }))
        };
        if !(self.shadow_threshold >= 0.0 && self.shadow_threshold <= 255.0) {
            return bad("--shadow-threshold", self.shadow_threshold.to_string(), "must be a grey level from 0 to 255");
        }
        if self.gray_fit_radius == 1 {
            return bad(
                "--gray-fit-radius",
                "1".into(),
                "holds 9 neighbours, too few for the quadratic's 6 terms: give 0 (off) or 2 and up",
            );
        }
        if self.gray_fit_radius > MAX_GRAY_FIT_RADIUS {
            return bad(
                "--gray-fit-radius",
                self.gray_fit_radius.to_string(),
                &format!(
                    "must be 0 (off) or from 2 to {MAX_GRAY_FIT_RADIUS} camera pixels (the fit's work grows with the \
                     window's area)"
                ),
            );
        }
        if !(self.min_modulation >= 0.0 && self.min_modulation.is_finite()) {
            return bad("min_modulation", self.min_modulation.to_string(), "must be a finite grey level, 0 or more");
        }
        if !(self.phase_tolerance_px > 0.0 && self.phase_tolerance_px.is_finite()) {
            return bad(
                "phase_tolerance_px",
                self.phase_tolerance_px.to_string(),
                "must be a positive, finite number of projector pixels",
            );
        }
        Ok(())
    }
}

/// What decoding a view found.
#[derive(Debug, Clone, PartialEq, Default, Serialize, serde::Deserialize)]
pub struct DecodeReport {
    /// Camera pixels.
    pub pixels: usize,
    /// Pixels the projector lights (white − black above the shadow threshold).
    pub lit: usize,
    /// Pixels with a decoded column.
    pub decoded: usize,
    /// Pixels with a decoded column and row.
    pub decoded_rows: usize,
    /// Where rows are coded: pixels whose column decoded but whose row did not, left out of the map (a
    /// pixel whose row code fails is not reliable for its column either: on real captures such pixels
    /// triangulated millimetres to metres off).
    #[serde(default)]
    pub column_only: usize,
    /// The frame checks that failed ([`crate::frame_checks`]): warnings, or, when forced, the
    /// failures decoding went on past.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub issues: Vec<FrameIssue>,
}

impl DecodeReport {
    /// Names the frames of every issue by `names` (one per frame given to the decoder, such as its file).
    pub fn name_frames(&mut self, names: &[String]) {
        name_issue_frames(&mut self.issues, names);
    }

    /// One warning per failed check, and one where 5 % or more of the decoded pixels were left
    /// out for lack of a row code.
    pub fn warnings(&self) -> Vec<String> {
        let mut w: Vec<String> =
            self.issues.iter().map(|i| if i.fatal { format!("{i} (kept: --force)") } else { i.to_string() }).collect();
        // Stripe-edge pixels always lose some rows (1.3 % on the simulator's vase, 2.1 % on its beetle;
        // real board captures with the default threshold lose 2.4 to 4 %): they are left out and
        // counted, and warned about from 5 %.
        if self.column_only * 20 >= self.decoded + self.column_only && self.column_only > 0 {
            w.push(format!(
                "{} pixels ({:.1} % of those decoded) had a column code but no valid row code and were left out \
                 (a low --shadow-threshold?)",
                self.column_only,
                100.0 * self.column_only as f64 / (self.decoded + self.column_only).max(1) as f64
            ));
        }
        w
    }
}

fn name_issue_frames(issues: &mut [FrameIssue], names: &[String]) {
    for i in issues {
        for (k, f) in i.frames.iter().enumerate() {
            if let (Some(n), Some(slot)) = (names.get(*f), i.names.get_mut(k)) {
                *slot = n.clone();
            }
        }
    }
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
    /// A parameter outside what the decoder can use: the option as the command line spells it.
    #[error(transparent)]
    Param(#[from] rig::limits::ParamError),
    /// The frames contradict themselves so that the map would be mostly wrong
    /// ([`crate::frame_checks`]); not raised when forced.
    #[error(
        "the frames contradict themselves: {}. The map would be mostly wrong; check the frames (their order, \
         white and black, the projector's flips), or give --force to keep it anyway",
        crate::frame_checks::describe(.0)
    )]
    Contradictory(Vec<FrameIssue>),
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

impl DecodeError {
    /// Names the frames a [`DecodeError::Contradictory`] concerns by `names` (one per frame given to
    /// the decoder, such as its file); other errors are left as they are.
    pub fn name_frames(mut self, names: &[String]) -> Self {
        if let DecodeError::Contradictory(issues) = &mut self {
            name_issue_frames(issues, names);
        }
        self
    }
}

/// The frames of one coded axis.
struct AxisFrames<'a> {
    size: u32,
    gray: Vec<(&'a Image8, &'a Image8)>,
    /// The frames' indices in the view, per pair (pattern, inverse).
    gray_index: Vec<(usize, usize)>,
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
    let mut bits: Vec<(u32, u32, bool, &Image8, usize)> = frames
        .iter()
        .enumerate()
        .filter_map(|(k, (p, img))| match *p {
            Pattern::Gray { axis: a, bit, bits, inverse } if a == axis => Some((bit, bits, inverse, *img, k)),
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
    let gray_index = bits.chunks(2).map(|c| (c[0].4, c[1].4)).collect();
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
    Ok(Some(AxisFrames { size, gray, gray_index, phase }))
}

/// One axis decoded over a block of pixels `[i0, i0 + n)`: coordinate (NaN where undecoded) and
/// confidence, written into `out`. Frame-major loops: each frame is read once, contiguously, per block.
/// `want[k]` false skips pixel k's final step (a row is not needed where the column failed, unless the
/// inverted column code fitted somewhere in the block, and the rows are asked the same question).
/// Returns how many pixels the phase rejected that the inverted Gray code (every pattern taken for
/// its inverse) would have matched: a capture whose `_inv` frames are its patterns decodes almost
/// nowhere with a phase, and almost everywhere so inverted ([`IssueKind::AllInversesSwapped`]).
fn decode_axis_block(
    a: &AxisFrames<'_>,
    i0: usize,
    swing: &[f32],
    want: &[bool],
    p: &DecodeParams,
    out: &mut [(f64, f32)],
) -> usize {
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
    // The code's bits all set (a code of 32 bits would overflow a shift of 1 << 32).
    let all_bits = u32::MAX.checked_shr(32 - a.gray.len() as u32).unwrap_or(0);
    let mut inverted_fits = 0;
    for k in 0..n {
        out[k] = (f64::NAN, 0.0);
        if !want[k] || swing[k] < p.shadow_threshold as f32 {
            continue;
        }
        let index = rig::patterns::gray_inverse(code[k]);
        match (&a.phase, &sums) {
            (Some((steps, _)), Some((s, c))) => {
                let (wrapped, modulation) = steps.finish(s[k] as f64, c[k] as f64);
                if modulation < p.min_modulation {
                    continue;
                }
                let fit = |index: u32| {
                    (index < a.size).then(|| unwrap(wrapped, index, steps.period_px, p.phase_tolerance_px)).flatten()
                };
                match fit(index) {
                    Some(x) => out[k] = (x, (modulation / (0.5 * swing[k] as f64)).min(1.0) as f32),
                    None => {
                        inverted_fits += usize::from(fit(rig::patterns::gray_inverse(!code[k] & all_bits)).is_some())
                    }
                }
            }
            _ if index >= a.size => {}
            _ if weakest[k] >= p.bit_threshold => out[k] = (index as f64, (weakest[k] as f32 / swing[k]).min(1.0)),
            _ => {}
        }
    }
    inverted_fits
}

/// Decodes a view's frames (each with the pattern it shows) for a projector of `proj_width ×
/// proj_height`: column coordinates, and row coordinates where rows are coded (where they are, a pixel
/// without a valid row is left out, counted in [`DecodeReport::column_only`]). The frames are checked
/// against each other as they are read ([`crate::frame_checks`]); a view they say is mostly wrong is
/// refused with the frames named ([`DecodeError::Contradictory`]) unless `params.force`.
pub fn decode_view(
    frames: &[(Pattern, &Image8)],
    proj_width: u32,
    proj_height: u32,
    params: &DecodeParams,
) -> Result<(ProjectorMap, DecodeReport), DecodeError> {
    params.validate()?;
    let find = |want: Pattern, name| {
        frames.iter().position(|(p, _)| *p == want).map(|k| (k, frames[k].1)).ok_or(DecodeError::Missing(name))
    };
    let ((white_k, white), (black_k, black)) = (find(Pattern::White, "white")?, find(Pattern::Black, "black")?);
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
    let axes: Vec<&AxisFrames<'_>> = std::iter::once(&cols).chain(&rows).collect();
    let pairs: Vec<(&Image8, &Image8)> = axes.iter().flat_map(|a| a.gray.iter().copied()).collect();
    let pair_frames: Vec<(usize, usize)> = axes.iter().flat_map(|a| a.gray_index.iter().copied()).collect();
    let (counts, column_only, inverted, decoded) = map
        .u
        .par_chunks_mut(BLOCK)
        .zip(map.v.par_chunks_mut(BLOCK))
        .zip(map.confidence.par_chunks_mut(BLOCK))
        .zip(lit.par_chunks_mut(BLOCK))
        .enumerate()
        .map(|(b, (((u, v), conf), lit))| {
            let i0 = b * BLOCK;
            let n = u.len();
            let mut counts = Counts::new(pairs.len());
            let slices: Vec<(&[u8], &[u8])> =
                pairs.iter().map(|(p, q)| (&p.data[i0..i0 + n], &q.data[i0..i0 + n])).collect();
            crate::frame_checks::check_block(&white.data[i0..i0 + n], &black.data[i0..i0 + n], &slices, &mut counts);
            let mut swing = [0f32; BLOCK];
            for k in 0..n {
                swing[k] = white.data[i0 + k] as f32 - black.data[i0 + k] as f32;
                lit[k] = swing[k] >= params.shadow_threshold as f32;
            }
            // Background and shadow come in whole blocks: skip reading the other frames there.
            if !lit.iter().any(|&l| l) {
                return (counts, 0, [0, 0], [0, 0]);
            }
            let mut col = [(f64::NAN, 0f32); BLOCK];
            let mut inverted = [decode_axis_block(&cols, i0, &swing[..n], &lit[..n], params, &mut col[..n]), 0];
            let mut row = [(f64::NAN, 0f32); BLOCK];
            if let Some(r) = &rows {
                // Rows are asked where columns decoded, or (to test the inversion) where only their
                // inversion fitted: the whole lit block then.
                let mut want = [false; BLOCK];
                for ((w, c), l) in want.iter_mut().zip(&col[..n]).zip(&lit[..n]) {
                    *w = c.0.is_finite() || (inverted[0] > 0 && *l);
                }
                inverted[1] = decode_axis_block(r, i0, &swing[..n], &want[..n], params, &mut row[..n]);
            }
            // Each axis's own decoded pixels (the map keeps a column only where its row decoded too).
            let finite = |a: &[(f64, f32)]| a.iter().filter(|c| c.0.is_finite()).count();
            let decoded = [finite(&col[..n]), finite(&row[..n])];
            let mut column_only = 0;
            for k in 0..n {
                if !col[k].0.is_finite() {
                    continue;
                }
                if rows.is_some() && !row[k].0.is_finite() {
                    column_only += 1;
                    continue;
                }
                u[k] = col[k].0;
                v[k] = row[k].0;
                conf[k] = if row[k].0.is_finite() { col[k].1.min(row[k].1) } else { col[k].1 };
            }
            (counts, column_only, inverted, decoded)
        })
        .reduce(
            || (Counts::new(pairs.len()), 0, [0, 0], [0, 0]),
            |a, b| (a.0.add(b.0), a.1 + b.1, [a.2[0] + b.2[0], a.2[1] + b.2[1]], [a.3[0] + b.3[0], a.3[1] + b.3[1]]),
        );
    let lit_count = lit.iter().filter(|&&l| l).count();
    let name = |k: usize| frames[k].0.name();
    let mut issues = frame_issues(&counts, lit_count, (white_k, black_k), &pair_frames, &name);
    // Every pattern taken for its inverse: with a phase, the inverted code fits where the code does not
    // (by chance it hardly fits: flipping every bit moves the index by 3 or more, past the tolerance).
    let mut all_swapped = [false, false];
    for (k, a) in std::iter::once(&cols).chain(&rows).enumerate() {
        all_swapped[k] = a.phase.is_some() && inverted[k] >= 100 && inverted[k] > 2 * decoded[k];
    }
    // The codes' continuity and handedness, on the integer indices before they are refined.
    for (k, (a, coord)) in std::iter::once((&cols, &map.u)).chain(rows.as_ref().map(|r| (r, &map.v))).enumerate() {
        let index: Vec<u32> =
            coord.iter().map(|c| if c.is_finite() { (c + 0.5).floor().max(0.0) as u32 } else { u32::MAX }).collect();
        let bits = a.gray.len() as u32;
        all_swapped[k] |= crate::frame_checks::all_swapped(&index, w, h, bits);
        if all_swapped[k] {
            let (first, last) = (a.gray_index[0], a.gray_index[a.gray_index.len() - 1]);
            let frames = vec![first.0, first.1, last.0, last.1];
            let names = frames.iter().map(|&f| name(f)).collect();
            issues.push(FrameIssue::new(IssueKind::AllInversesSwapped, frames, names, 1.0));
            continue;
        }
        for bit in crate::frame_checks::swapped_bits(&index, w, h, bits) {
            let (p, q) = a.gray_index[bit as usize];
            issues.push(FrameIssue::new(IssueKind::InverseSwapped, vec![p, q], vec![name(p), name(q)], 1.0));
        }
    }
    // A swapped lower bit reverses the code within its stripes, which looks mirrored too.
    if let Some(r) = &rows
        && issues.iter().all(|i| !matches!(i.kind, IssueKind::InverseSwapped | IssueKind::AllInversesSwapped))
        && let Some(columns) = crate::frame_checks::mirrored(&map.u, &map.v, w, h)
    {
        let (p, q) = if columns { cols.gray_index[0] } else { r.gray_index[0] };
        issues.push(FrameIssue::new(IssueKind::Mirrored, vec![p, q], vec![name(p), name(q)], 1.0));
    }
    if !params.force && issues.iter().any(|i| i.fatal) {
        return Err(DecodeError::Contradictory(issues));
    }
    // Integer Gray-code coordinates refined after the fact: the fit needs whole neighbourhoods.
    if cols.phase.is_none() {
        crate::gray_subpixel::refine(&mut map.u, w, h, params.gray_fit_radius);
    }
    if rows.as_ref().is_some_and(|r| r.phase.is_none()) {
        crate::gray_subpixel::refine(&mut map.v, w, h, params.gray_fit_radius);
    }
    let report = DecodeReport {
        pixels: w * h,
        lit: lit_count,
        decoded: map.decoded(),
        decoded_rows: map.v.iter().filter(|v| v.is_finite()).count(),
        column_only,
        issues,
    };
    Ok((map, report))
}

/// The failed pair and white/black checks from the counts of a view (see [`crate::frame_checks`]).
fn frame_issues(
    counts: &Counts,
    lit: usize,
    (white, black): (usize, usize),
    pair_frames: &[(usize, usize)],
    name: &dyn Fn(usize) -> String,
) -> Vec<FrameIssue> {
    use crate::frame_checks::WARN_FRACTION;
    let mut issues = Vec::new();
    let wb = vec![white, black];
    let wb_names = vec![name(white), name(black)];
    // Swapped, nearly every pixel where they differ has black the brighter (two pattern frames in their
    // place split about evenly: the pair checks name those).
    if counts.reversed > 4 * counts.checked && counts.reversed >= 100 {
        let fraction = counts.reversed as f64 / (counts.reversed + counts.checked) as f64;
        issues.push(FrameIssue::new(IssueKind::WhiteBlackSwapped, wb, wb_names, fraction));
        return issues;
    }
    if lit == 0 {
        issues.push(FrameIssue::new(IssueKind::NothingLit, wb, wb_names, 1.0));
        return issues;
    }
    // Too few pixels with a clear swing say nothing either way.
    if counts.checked < 100 {
        return issues;
    }
    let checked = counts.checked as f64;
    for (q, &(p, i)) in pair_frames.iter().enumerate() {
        let fraction = counts.not_complementary[q] as f64 / checked;
        if fraction < WARN_FRACTION {
            continue;
        }
        let (dark_p, dark_i) = (counts.dark[q].0 as f64 / checked, counts.dark[q].1 as f64 / checked);
        let (kind, frames) = match (dark_p >= 0.95, dark_i >= 0.95) {
            (true, false) => (IssueKind::DarkFrame, vec![p, i]),
            (false, true) => (IssueKind::DarkFrame, vec![i, p]),
            _ => (IssueKind::NotComplementary, vec![p, i]),
        };
        let names = frames.iter().map(|&k| name(k)).collect();
        issues.push(FrameIssue::new(kind, frames, names, fraction));
    }
    issues
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

    /// An ideal capture of a tilted surface in OpenCV's order for a 1024 × 768 projector: each camera
    /// pixel sees projector column `100 + 4.5·x + 0.2·y` and row `50 + 5.1·y + 0.1·x`, with an albedo
    /// that varies across the image.
    fn ideal_view() -> (Vec<Pattern>, Vec<Image8>) {
        let (w, h) = (160u32, 120u32);
        let order = rig::gray_code_folders::opencv_order(1024, 768);
        let px = |x: u32, y: u32| {
            let (xf, yf) = (x as f64, y as f64);
            let u = (100.0 + 4.5 * xf + 0.2 * yf) as u32;
            let v = (50.0 + 5.1 * yf + 0.1 * xf) as u32;
            let albedo = 0.5 + 0.5 * ((x * 7 + y * 13) % 17) as f64 / 17.0;
            (u, v, (20.0 + 200.0 * albedo) as u8)
        };
        let frames = order
            .iter()
            .map(|p| {
                let data = (0..h)
                    .flat_map(|y| (0..w).map(move |x| (x, y)))
                    .map(|(x, y)| {
                        let (u, v, white) = px(x, y);
                        let on = match *p {
                            Pattern::White => true,
                            Pattern::Black => false,
                            Pattern::Gray { axis, bit, bits, inverse } => {
                                let i = if axis == Axis::Columns { u } else { v };
                                (((i ^ (i >> 1)) >> (bits - 1 - bit)) & 1 == 1) != inverse
                            }
                            _ => unreachable!(),
                        };
                        if on { white } else { 20 }
                    })
                    .collect();
                Image8::gray(w, h, data)
            })
            .collect();
        (order, frames)
    }

    fn decode_frames(order: &[Pattern], imgs: &[Image8], force: bool) -> Result<DecodeReport, DecodeError> {
        let frames: Vec<(Pattern, &Image8)> = order.iter().copied().zip(imgs).collect();
        let params = DecodeParams { force, ..DecodeParams::default() };
        decode_view(&frames, 1024, 768, &params).map(|r| r.1)
    }

    fn fatal(order: &[Pattern], imgs: &[Image8]) -> Vec<FrameIssue> {
        match decode_frames(order, imgs, false) {
            Err(DecodeError::Contradictory(issues)) => issues,
            other => panic!("not refused: {other:?}"),
        }
    }

    /// Issue 37, acceptance 4: frames that contradict themselves are refused with the frames named,
    /// and kept (with the failures reported) only when forced. A clean capture raises nothing.
    #[test]
    fn contradicting_frames_are_caught_and_named() {
        let (order, clean) = ideal_view();
        let r = decode_frames(&order, &clean, false).unwrap();
        assert!(r.issues.is_empty() && r.decoded == r.pixels && r.column_only == 0, "{r:?}");

        // A pattern and its inverse swapped (column bit 3: frames 6 and 7).
        let mut imgs = clean.clone();
        imgs.swap(6, 7);
        let issues = fatal(&order, &imgs);
        assert_eq!(issues.len(), 1, "{issues:?}");
        assert_eq!((issues[0].kind, issues[0].frames.clone()), (IssueKind::InverseSwapped, vec![6, 7]));
        assert_eq!(issues[0].names, ["gray_col_03", "gray_col_03_inv"]);
        let forced = decode_frames(&order, &imgs, true).unwrap();
        assert_eq!(forced.issues, issues);
        assert!(forced.warnings()[0].contains("(kept: --force)"), "{:?}", forced.warnings());
        let e =
            DecodeError::Contradictory(issues).name_frames(&(0..42).map(|k| format!("img{k}.png")).collect::<Vec<_>>());
        let text = e.to_string();
        assert!(text.contains("img6.png and img7.png look swapped") && text.contains("--force"), "{text}");

        // The most significant pair swapped mirrors the map (rows here: frames 20 and 21).
        let mut imgs = clean.clone();
        imgs.swap(20, 21);
        let issues = fatal(&order, &imgs);
        assert_eq!((issues[0].kind, issues[0].frames.clone()), (IssueKind::Mirrored, vec![20, 21]), "{issues:?}");

        // Every pattern swapped with its inverse (the `_inv` frames named as the patterns): as decoded
        // the code jumps at every stripe, and no one bit flipped back mends it.
        for (axis, first) in [("columns", 0usize), ("rows", 20)] {
            let mut imgs = clean.clone();
            for k in (first..first + 20).step_by(2) {
                imgs.swap(k, k + 1);
            }
            let issues = fatal(&order, &imgs);
            assert_eq!(issues[0].kind, IssueKind::AllInversesSwapped, "{axis}: {issues:?}");
            assert_eq!(issues[0].frames, vec![first, first + 1, first + 18, first + 19], "{axis}");
            assert!(issues.iter().all(|i| i.kind != IssueKind::InverseSwapped), "{axis}: {issues:?}");
        }

        // White and black swapped: no longer an empty map without a word.
        let mut imgs = clean.clone();
        imgs.swap(40, 41);
        let issues = fatal(&order, &imgs);
        assert_eq!((issues[0].kind, issues[0].frames.clone()), (IssueKind::WhiteBlackSwapped, vec![40, 41]));

        // One Gray frame black (a missed projector flip): named, its inverse beside it.
        let mut imgs = clean.clone();
        imgs[9] = clean[41].clone();
        let issues = fatal(&order, &imgs);
        assert_eq!((issues[0].kind, issues[0].frames.clone()), (IssueKind::DarkFrame, vec![9, 8]), "{issues:?}");

        // Unpadded names sorted as text: 0, 1, 10, 11, …, 19, 2, 20, …
        let mut names: Vec<String> = (0..42).map(|k| k.to_string()).collect();
        names.sort();
        let imgs: Vec<Image8> = names.iter().map(|n| clean[n.parse::<usize>().unwrap()].clone()).collect();
        let issues = fatal(&order, &imgs);
        assert!(issues.iter().any(|i| i.kind == IssueKind::NotComplementary && i.fatal), "{issues:?}");
    }

    /// Issue 37: where rows are projected, a pixel whose row code fails is left out and counted, not
    /// triangulated from its column alone.
    #[test]
    fn pixels_without_a_valid_row_are_left_out_and_counted() {
        let (order, mut imgs) = ideal_view();
        // The row MSB pair ties over the first 10 rows: their rows cannot be decoded.
        let tie = imgs[20].clone();
        for k in 0..160 * 10 {
            imgs[21].data[k] = tie.data[k];
        }
        let frames: Vec<(Pattern, &Image8)> = order.iter().copied().zip(&imgs).collect();
        let (map, r) = decode_view(&frames, 1024, 768, &DecodeParams::default()).unwrap();
        assert_eq!(r.column_only, 1600);
        assert_eq!(r.decoded, r.pixels - 1600);
        assert!(map.u[..1600].iter().all(|u| u.is_nan()) && map.u[1600..].iter().all(|u| u.is_finite()));
        assert!(r.warnings().iter().any(|w| w.contains("1600 pixels")), "{:?}", r.warnings());
    }

    /// Issue 37: `--gray-fit-radius 9223372036854775807` panicked, 4294967296 aborted on a 3 TB
    /// allocation, 1000 ran for hours. The library refuses them first, naming the option.
    #[test]
    fn the_fit_radius_is_bounded_before_any_work() {
        assert!(DecodeParams::default().validate().is_ok());
        let (order, imgs) = ideal_view();
        let frames: Vec<(Pattern, &Image8)> = order.iter().copied().zip(&imgs).collect();
        for radius in [1, 17, 1000, 1 << 32, usize::MAX >> 1, usize::MAX] {
            let p = DecodeParams { gray_fit_radius: radius, ..DecodeParams::default() };
            let e = decode_view(&frames, 1024, 768, &p).unwrap_err().to_string();
            assert!(e.starts_with(&format!("--gray-fit-radius {radius}: ")), "{e}");
        }
        let p = DecodeParams { gray_fit_radius: MAX_GRAY_FIT_RADIUS, ..DecodeParams::default() };
        assert!(decode_view(&frames, 1024, 768, &p).is_ok());
        for t in [-1.0, 256.0, f64::NAN] {
            let p = DecodeParams { shadow_threshold: t, ..DecodeParams::default() };
            assert!(p.validate().unwrap_err().to_string().starts_with("--shadow-threshold"), "{t}");
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
        // Random frames contradict themselves everywhere: forced, to compare every decision.
        let params = DecodeParams { gray_fit_radius: 0, force: true, ..DecodeParams::default() };
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
        let (map, report) = decode_view(&frames, 40, 30, &params).unwrap();
        let steps = PhaseSteps::new(4, 8.0);
        let col_pairs: Vec<(&Image8, &Image8)> = (0..6).map(|b| (&imgs[2 + 2 * b], &imgs[3 + 2 * b])).collect();
        let row_pairs: Vec<(&Image8, &Image8)> = (0..5).map(|b| (&imgs[14 + 2 * b], &imgs[15 + 2 * b])).collect();
        let phase: Vec<&Image8> = imgs[24..28].iter().collect();
        let (mut decoded, mut column_only) = (0, 0);
        for i in 0..w * h {
            let swing = imgs[0].data[i] as f64 - imgs[1].data[i] as f64;
            let (ci, _) = crate::gray_code::decode_pixel(col_pairs.iter().map(|(a, b)| (a.data[i], b.data[i])));
            let (wrapped, modulation) = steps.decode_pixel(phase.iter().map(|f| f.data[i]));
            let u = (swing >= params.shadow_threshold && ci < 40 && modulation >= params.min_modulation)
                .then(|| crate::phase_shift::unwrap(wrapped, ci, 8.0, params.phase_tolerance_px))
                .flatten();
            let (ri, weak) = crate::gray_code::decode_pixel(row_pairs.iter().map(|(a, b)| (a.data[i], b.data[i])));
            let row_ok = ri < 30 && weak >= params.bit_threshold;
            match u {
                // Rows are coded: a pixel without a valid row is left out.
                Some(u) if row_ok => {
                    assert!((map.u[i] - u).abs() < 1e-4, "pixel {i}: {} vs {u}", map.u[i]);
                    decoded += 1;
                    assert_eq!(map.v[i], ri as f64, "pixel {i} row");
                }
                Some(_) => {
                    assert!(map.u[i].is_nan(), "pixel {i} kept without its row");
                    column_only += 1;
                }
                None => assert!(map.u[i].is_nan(), "pixel {i} decoded by the block path only"),
            }
        }
        assert!(decoded > 100, "{decoded}");
        assert_eq!(report.column_only, column_only);
        assert!(!report.issues.is_empty(), "random frames are not complementary");
    }
}
