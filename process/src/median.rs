//! The median of a set of figures, one function for the stages that judge a value against the rest.

use rig::math::Real;

/// The median of `v` (reordered: the upper middle of an even count), or `None` when empty.
pub fn median(v: &mut [Real]) -> Option<Real> {
    if v.is_empty() {
        return None;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, Real::total_cmp);
    Some(*m)
}
