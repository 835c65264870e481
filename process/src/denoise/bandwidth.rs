//! Automatic bandwidths (section 4.3.2): over random valid points p_k, the largest distance from p_k to
//! the points of its neighbourhood N(p_k) averages to μ_d, and the standard deviation of their offsets
//! from the plane through p_k (normal d_k) averages to σ_s; then d = 0.75·μ_d and s = σ_s.

use rayon::prelude::*;
use rig::RangeGrid;
use rig::math::{Real, Vector3};

/// (d, s) in mm from `samples` random valid points of the grid (seeded), neighbourhood half-size `half`.
/// `direction(i)` is cell i's displacement direction (zero where it has none; such samples are skipped),
/// asked only at the samples, so a frame's directions need not all be computed for its bandwidths.
/// (1, 1) where no sample has two valid neighbours ([`measured`] says so instead).
pub fn estimate(
    grid: &RangeGrid,
    direction: impl Fn(usize) -> Vector3 + Sync,
    half: usize,
    samples: usize,
    seed: u64,
) -> (Real, Real) {
    measured(grid, direction, half, samples, seed).unwrap_or((1.0, 1.0))
}

/// [`estimate`], `None` where no sample has two valid neighbours: nothing was measured.
pub fn measured(
    grid: &RangeGrid,
    direction: impl Fn(usize) -> Vector3 + Sync,
    half: usize,
    samples: usize,
    seed: u64,
) -> Option<(Real, Real)> {
    let valid: Vec<usize> = (0..grid.valid.len()).filter(|&i| grid.valid[i]).collect();
    if valid.is_empty() {
        return None;
    }
    let (w, h) = (grid.width as isize, grid.height as isize);
    let mut state = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    let picks: Vec<usize> = (0..samples)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            valid[(state % valid.len() as u64) as usize]
        })
        .collect();
    // Per sample: the largest neighbour distance and the standard deviation of the plane offsets, or
    // `None` with fewer than 2 neighbours. Collected in order, then summed, so the result does not
    // depend on the number of threads.
    let per_sample: Vec<Option<(Real, Real)>> = picks
        .par_iter()
        .map(|&i| {
            let (c, r) = ((i as isize) % w, (i as isize) / w);
            let (p, d) = (grid.points[i], direction(i));
            if d.norm_squared() == 0.0 {
                return None;
            }
            let (mut max_dist, mut sum, mut sum_sq, mut count) = (0.0f64, 0.0, 0.0, 0usize);
            for rr in (r - half as isize).max(0)..=(r + half as isize).min(h - 1) {
                for cc in (c - half as isize).max(0)..=(c + half as isize).min(w - 1) {
                    let j = (rr * w + cc) as usize;
                    if grid.valid[j] && j != i {
                        let q = grid.points[j];
                        max_dist = max_dist.max((q - p).norm());
                        let o = (q - p).dot(&d);
                        (sum, sum_sq, count) = (sum + o, sum_sq + o * o, count + 1);
                    }
                }
            }
            (count >= 2).then(|| {
                let mean = sum / count as Real;
                (max_dist, (sum_sq / count as Real - mean * mean).max(0.0).sqrt())
            })
        })
        .collect();
    let (mut sum_max, mut sum_sd, mut n) = (0.0, 0.0, 0usize);
    for (max_dist, sd) in per_sample.into_iter().flatten() {
        sum_max += max_dist;
        sum_sd += sd;
        n += 1;
    }
    if n == 0 {
        return None;
    }
    Some((0.75 * sum_max / n as Real, (sum_sd / n as Real).max(1e-9)))
}
