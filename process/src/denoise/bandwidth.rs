//! Automatic bandwidths (section 4.3.2): over random valid points p_k, the largest distance from p_k to
//! the points of its neighbourhood N(p_k) averages to μ_d, and the standard deviation of their offsets
//! from the plane through p_k (normal d_k) averages to σ_s; then d = 0.75·μ_d and s = σ_s.

use rig::RangeGrid;
use rig::math::{Real, Vector3};

/// (d, s) in mm from `samples` random valid points of the grid (seeded), neighbourhood half-size `half`.
pub fn estimate(grid: &RangeGrid, dirs: &[Vector3], half: usize, samples: usize, seed: u64) -> (Real, Real) {
    let valid: Vec<usize> = (0..grid.valid.len()).filter(|&i| grid.valid[i] && dirs[i].norm_squared() > 0.0).collect();
    if valid.is_empty() {
        return (1.0, 1.0);
    }
    let (w, h) = (grid.width as isize, grid.height as isize);
    let mut state = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    let (mut sum_max, mut sum_sd, mut n) = (0.0, 0.0, 0usize);
    for _ in 0..samples {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let i = valid[(state % valid.len() as u64) as usize];
        let (c, r) = ((i as isize) % w, (i as isize) / w);
        let (p, d) = (grid.points[i], dirs[i]);
        let (mut max_dist, mut offsets) = (0.0f64, Vec::new());
        for rr in (r - half as isize).max(0)..=(r + half as isize).min(h - 1) {
            for cc in (c - half as isize).max(0)..=(c + half as isize).min(w - 1) {
                let j = (rr * w + cc) as usize;
                if grid.valid[j] && j != i {
                    let q = grid.points[j];
                    max_dist = max_dist.max((q - p).norm());
                    offsets.push((q - p).dot(&d));
                }
            }
        }
        if offsets.len() < 2 {
            continue;
        }
        let mean = offsets.iter().sum::<Real>() / offsets.len() as Real;
        let var = offsets.iter().map(|o| (o - mean).powi(2)).sum::<Real>() / offsets.len() as Real;
        sum_max += max_dist;
        sum_sd += var.sqrt();
        n += 1;
    }
    if n == 0 {
        return (1.0, 1.0);
    }
    (0.75 * sum_max / n as Real, (sum_sd / n as Real).max(1e-9))
}
