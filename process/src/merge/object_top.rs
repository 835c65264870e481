//! The object's top as the data shows it, and the working volume it closes.
//!
//! The rig's working volume (platter radius, working height) bounds any object the scanner takes; the
//! object on the platter is usually far lower than that, and light above it that lands inside the
//! volume — a second laser's line, a reflection off the housing — triangulates into points nobody can
//! tell from the object by position alone (FabScanPi's sample: a ring 100–124 mm up over a 78 mm
//! bust, which the mesh closed into a lid). What a real object is: it stands on the platter, so each
//! view's laser line runs unbroken from the platter up its profile, as far as the object goes. A line
//! is followed in image-row order from its lowest point; a height jump of more than
//! [`TopParams::max_gap_mm`] ends a run (an overhang or an occlusion ends it too, but other views see
//! the profile whole). The highest point of a run that starts on the platter, over every view, is the
//! object's top; nothing may lie more than [`TopParams::margin_mm`] above it.

use rig::math::Real;
use serde::{Deserialize, Serialize};

/// How the top is found.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TopParams {
    /// Consecutive points of a line (in row order) whose heights differ by more than this (mm) are
    /// not one run: rows are a fraction of a millimetre apart on the object, and the stray light of
    /// the sample lies 20 mm above the head.
    pub max_gap_mm: Real,
    /// A run starts on the platter when its lowest point is at most this high (mm): the line crosses
    /// the platter at 0, give or take the calibration's tilt.
    pub ground_mm: Real,
    /// Points up to this far above the top (mm) are kept: a bit of the head's line cut off by a gap.
    pub margin_mm: Real,
}

impl Default for TopParams {
    fn default() -> Self {
        TopParams { max_gap_mm: 10.0, ground_mm: 5.0, margin_mm: 1.0 }
    }
}

/// The top of one line: the highest point of its runs that start on the platter (`None`: no run
/// does). `heights`: the line's points' heights above the platter (mm), in image-row order.
pub fn grounded_top(heights: &[Real], p: &TopParams) -> Option<Real> {
    let mut best: Option<Real> = None;
    let mut start = 0;
    for i in 1..=heights.len() {
        if i < heights.len() && (heights[i] - heights[i - 1]).abs() <= p.max_gap_mm {
            continue;
        }
        let run = &heights[start..i];
        let low = run.iter().copied().fold(Real::INFINITY, Real::min);
        if low <= p.ground_mm {
            let high = run.iter().copied().fold(Real::NEG_INFINITY, Real::max);
            best = Some(best.map_or(high, |b: Real| b.max(high)));
        }
        start = i;
    }
    best
}

/// The object's top over a scan's lines.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ObjectTop {
    /// Height above the platter (mm).
    pub top_mm: Real,
    /// The view whose line reached it.
    pub view: usize,
    /// That line's laser.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub laser: Option<usize>,
    /// Lines with a run from the platter up (of all lines).
    pub grounded_lines: usize,
}

/// The top over `lines` (view, laser, heights in row order): the highest grounded top of any line.
pub fn object_top<'a>(
    lines: impl IntoIterator<Item = (usize, Option<usize>, &'a [Real])>,
    p: &TopParams,
) -> Option<ObjectTop> {
    let mut best: Option<ObjectTop> = None;
    let mut grounded = 0;
    for (view, laser, heights) in lines {
        let Some(top) = grounded_top(heights, p) else { continue };
        grounded += 1;
        if best.is_none_or(|b| top > b.top_mm) {
            best = Some(ObjectTop { top_mm: top, view, laser, grounded_lines: 0 });
        }
    }
    best.map(|b| ObjectTop { grounded_lines: grounded, ..b })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_from_the_platter_reaches_the_top_and_stray_light_above_does_not() {
        let p = TopParams::default();
        // Rows top to bottom: stray light 126 → 100 mm, a 22 mm gap, the head 78 mm down to the platter.
        let mut line: Vec<Real> = (0..60).map(|k| 126.0 - 0.45 * k as Real).collect();
        line.extend((0..400).map(|k| 78.0 - 0.2 * k as Real));
        assert_eq!(grounded_top(&line, &p), Some(78.0));
        // An occlusion (the chin) breaks the line: the run from the platter ends at the neck.
        let chin: Vec<Real> =
            (0..50).map(|k| 78.0 - 0.3 * k as Real).chain((0..200).map(|k| 40.0 - 0.2 * k as Real)).collect();
        assert_eq!(grounded_top(&chin, &p), Some(40.0));
        // A line that never reaches the platter has no top.
        assert_eq!(grounded_top(&[90.0, 89.5, 89.0], &p), None);
        assert_eq!(grounded_top(&[], &p), None);
        // Over views: the highest grounded top, and how many lines had one.
        let lines = [(0, Some(0), &chin[..]), (1, Some(0), &line[..]), (2, None, &[90.0][..])];
        let top = object_top(lines, &p).unwrap();
        assert_eq!((top.top_mm, top.view, top.grounded_lines), (78.0, 1, 2));
    }
}
