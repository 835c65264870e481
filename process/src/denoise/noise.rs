//! The noise level and sampling of one range grid, measured before filtering, so the filter's sizes
//! can follow the data (the thesis sets them by hand per dataset, table 4.1; scanrig's defaults come
//! from these two figures, see [`super::DenoiseParams::sized_for`]).
//!
//! Sampling `h`: the median distance between grid neighbours, less the noise's share. Noise `σ`: each
//! cell's height over the mean of its four neighbours, along the normal of the cross two cells out,
//! `e = (p − p̄₄)·n`; for noise
//! of deviation σ along the surface normal `var e = σ²(1 + 4/16)`, so `σ = 1.4826·MAD(e)/√1.25`. The
//! median absolute deviation ignores flying pixels and the few cells on creases; the curvature's
//! share, `κh²/4`, is small wherever the grid samples its surface finely (the bunny's 0.7 mm cells on
//! ≥ 15 mm radii: ≤ 0.01 mm).

use crate::median::median;
use rig::RangeGrid;
use rig::math::Real;

/// What [`measure`] found.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NoiseLevel {
    /// Median distance between grid neighbours, in the grid's units.
    pub spacing: Real,
    /// Robust deviation of the noise along the surface normal, in the grid's units.
    pub sigma: Real,
    /// Cells whose neighbours out to two cells are valid: the figures come from them.
    pub cells: usize,
    /// The same deviation two cells out (heights over the mean of the neighbours two cells away): white
    /// noise reads σ again; structure that patches two cells apart differ by — curvature, scanner error
    /// correlated over cells — reads more (the bunny's scans 1.6 σ, the simulator's white noise 1.02 σ).
    pub sigma_wide: Real,
    /// Median of 1 / |cos| between the surface normal and the line of sight: a height along the line of
    /// sight is this many times the same height along the normal (noise that moves points along their
    /// rays reads σ·cos along the normal).
    #[serde(default = "one")]
    pub sight: Real,
}

fn one() -> Real {
    1.0
}

impl NoiseLevel {
    /// Noise over sampling, σ/h: how many cells' worth of noise each sample carries.
    pub fn ratio(&self) -> Real {
        self.sigma / self.spacing
    }
}

/// Measures the grid's sampling and noise from the cells whose neighbours out to two cells along the
/// rows and columns are valid; `None` when
/// fewer than 16 such cells exist or the grid has no extent.
pub fn measure(grid: &RangeGrid) -> Option<NoiseLevel> {
    let (w, h) = (grid.width, grid.height);
    let (mut heights, mut gaps, mut wide, mut slant) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for r in 2..h.saturating_sub(2) {
        for c in 2..w.saturating_sub(2) {
            let i = r * w + c;
            let (l, rt, u, d) = (i - 1, i + 1, i - w, i + w);
            let (l2, r2, u2, d2) = (i - 2, i + 2, i - 2 * w, i + 2 * w);
            if ![i, l, rt, u, d, l2, r2, u2, d2].iter().all(|&k| grid.valid[k]) {
                continue;
            }
            let p = &grid.points;
            // The normal from the cross two cells out: noise tilts it half as much as the near one's.
            let n = (p[r2] - p[l2]).cross(&(p[d2] - p[u2]));
            let len = n.norm();
            if !(len > 0.0 && len.is_finite()) {
                continue;
            }
            let mean = (p[l].coords + p[rt].coords + p[u].coords + p[d].coords) / 4.0;
            heights.push((p[i].coords - mean).dot(&n) / len);
            let mean2 = (p[l2].coords + p[r2].coords + p[u2].coords + p[d2].coords) / 4.0;
            wide.push((p[i].coords - mean2).dot(&n) / len);
            // Grazing cells (|cos| < 0.2) would make the factor meaningless; they count as 5.
            slant.push((len / n.dot(&grid.line_of_sight(i)).abs()).min(5.0));
            gaps.push((p[rt] - p[i]).norm_squared());
            gaps.push((p[d] - p[i]).norm_squared());
        }
    }
    if heights.len() < 16 {
        return None;
    }
    let cells = heights.len();
    let centre = median(&mut heights)?;
    let mut dev: Vec<Real> = heights.iter().map(|e| (e - centre).abs()).collect();
    let sigma = 1.4826 * median(&mut dev)? / 1.25f64.sqrt();
    let c2 = median(&mut wide)?;
    let mut dev2: Vec<Real> = wide.iter().map(|e| (e - c2).abs()).collect();
    let sigma_wide = 1.4826 * median(&mut dev2)? / 1.25f64.sqrt();
    // A gap squared is h² plus the two cells' noise difference squared, 2σ²·χ²₁, whose median is
    // 0.455 of its mean.
    let gap2 = median(&mut gaps)?;
    let spacing = (gap2 - 0.91 * sigma * sigma).max(0.25 * gap2).sqrt();
    let sight = median(&mut slant)?;
    (spacing > 0.0 && spacing.is_finite() && sigma.is_finite()).then_some(NoiseLevel {
        spacing,
        sigma,
        cells,
        sigma_wide,
        sight,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig::Sensor;
    use rig::math::{Point3, Vector3};

    /// A plane tilted 30° seen on a 0.5 mm grid, with Gaussian noise of `sigma` along its normal.
    fn tilted_plane(sigma: Real, seed: u64) -> RangeGrid {
        let (w, h) = (120, 100);
        let mut g = RangeGrid::empty(w, h, Sensor::Center(Point3::origin()));
        let n = Vector3::new(0.0, 0.5, 0.866_025_4);
        let mut state = seed | 1;
        let mut uniform = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as Real / (1u64 << 53) as Real
        };
        for r in 0..h {
            for c in 0..w {
                let (u1, u2) = (uniform().max(1e-12), uniform());
                let gauss = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
                let y = r as Real * 0.5;
                let p = Point3::new(c as Real * 0.5, y * 0.866_025_4, 300.0 - y * 0.5) + n * (sigma * gauss);
                g.points[r * w + c] = p;
                g.valid[r * w + c] = true;
            }
        }
        g
    }

    #[test]
    fn the_noise_and_spacing_of_a_noisy_plane_are_found() {
        for sigma in [0.01, 0.05, 0.2] {
            let level = measure(&tilted_plane(sigma, 3)).unwrap();
            assert!((level.spacing - 0.5).abs() < 0.02 + sigma, "spacing {} at σ {sigma}", level.spacing);
            // At σ/h = 0.4 the cross's own normal tilts with the noise and the height reads 7 % low.
            assert!((level.sigma / sigma - 1.0).abs() < 0.08, "σ {} for {sigma}", level.sigma);
        }
    }

    #[test]
    fn flying_pixels_do_not_move_the_estimate() {
        let mut g = tilted_plane(0.05, 5);
        // One cell in two hundred thrown 20 mm off (each spoils five heights: its own and its
        // neighbours').
        for i in (0..g.points.len()).step_by(200) {
            g.points[i].z += 20.0;
        }
        let level = measure(&g).unwrap();
        assert!((level.sigma / 0.05 - 1.0).abs() < 0.06, "σ {}", level.sigma);
    }

    #[test]
    fn a_grid_without_four_connected_cells_has_no_estimate() {
        let mut g = tilted_plane(0.05, 7);
        for (i, v) in g.valid.iter_mut().enumerate() {
            *v = i % 2 == 0;
        }
        assert_eq!(measure(&g), None);
    }
}
