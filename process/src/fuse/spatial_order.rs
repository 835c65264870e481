//! A cache-friendly processing order for scattered points.
//!
//! Per-point neighbourhood work (kernels, k-nearest queries) over a cloud in arbitrary order jumps
//! across the k-d tree and the per-point arrays; once the cloud outgrows the caches that costs more
//! than the arithmetic, and time per point climbs with N. Visiting points along a Morton (Z-order)
//! curve keeps consecutive queries in the same region, so time stays linear in N.

use rig::math::{Point3, Real};

/// Spreads the low 21 bits of `v` to every third bit.
fn spread(mut v: u64) -> u64 {
    v &= 0x1f_ffff;
    v = (v | v << 32) & 0x1f_0000_0000_ffff;
    v = (v | v << 16) & 0x1f_0000_ff00_00ff;
    v = (v | v << 8) & 0x100f_00f0_0f00_f00f;
    v = (v | v << 4) & 0x10c3_0c30_c30c_30c3;
    v = (v | v << 2) & 0x1249_2492_4924_9249;
    v
}

/// The indices of `points` sorted along a Morton curve over their bounding box (21 bits per axis).
/// Non-finite coordinates sort as the box's minimum.
pub fn morton_order(points: &[Point3]) -> Vec<usize> {
    let finite = points.iter().filter(|p| p.iter().all(|c| c.is_finite()));
    let Some(first) = finite.clone().next() else { return (0..points.len()).collect() };
    let (lo, hi) = finite.fold((*first, *first), |(lo, hi), p| (lo.inf(p), hi.sup(p)));
    let scale = ((1u64 << 21) - 1) as Real / (hi - lo).max().max(Real::MIN_POSITIVE);
    let code = |p: &Point3| {
        let q = |c: Real, l: Real| {
            let v = ((c - l) * scale).clamp(0.0, ((1u64 << 21) - 1) as Real);
            if v.is_finite() { v as u64 } else { 0 }
        };
        spread(q(p.x, lo.x)) | spread(q(p.y, lo.y)) << 1 | spread(q(p.z, lo.z)) << 2
    };
    let mut keyed: Vec<(u64, usize)> = points.iter().enumerate().map(|(i, p)| (code(p), i)).collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_interleaves_bits() {
        assert_eq!(spread(0b1), 0b1);
        assert_eq!(spread(0b11), 0b1001);
        assert_eq!(spread(0x1f_ffff).count_ones(), 21);
        assert_eq!(spread(0x1f_ffff), 0x1249_2492_4924_9249);
    }

    #[test]
    fn order_is_a_permutation_that_groups_octants() {
        // Points in the 8 octants of a cube, interleaved; the Morton order visits each octant's points
        // together.
        let mut points = Vec::new();
        for rep in 0..5 {
            for o in 0..8 {
                let c = |bit: usize| if o >> bit & 1 == 1 { 0.75 } else { 0.25 } + rep as Real * 0.01;
                points.push(Point3::new(c(0), c(1), c(2)));
            }
        }
        points.push(Point3::new(Real::NAN, 0.0, 0.0));
        let order = morton_order(&points);
        let mut seen = order.clone();
        seen.sort();
        assert_eq!(seen, (0..points.len()).collect::<Vec<_>>());
        let octants: Vec<usize> = order.iter().filter(|&&i| i < 40).map(|&i| i % 8).collect();
        for run in octants.chunks(5) {
            assert!(run.iter().all(|&o| o == run[0]), "{octants:?}");
        }
    }
}
