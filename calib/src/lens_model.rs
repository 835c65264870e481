//! Which lens terms the board views can support, and what they leave uncovered.
//!
//! A distortion term is only measured where corners were seen: k3 (the sixth-order radial term)
//! bends the image's far corners, so views that keep to the middle leave it free to take any value
//! — the 4-pose real captures that gave k3 = 16.8 fitted the corners they had and would have
//! warped everything outside them. So the model follows from the views, by one documented rule:
//!
//! | term | estimated when |
//! |---|---|
//! | fx, fy, cx, cy, k1, k2 | always (3 views at least, as Zhang's method needs) |
//! | p1, p2 (tangential) | at least [`TANGENTIAL_VIEWS`] views and corners in at least [`TANGENTIAL_COVER`] of the image's cells |
//! | k3 | at least [`K3_VIEWS`] views, corners in at least [`K3_COVER`] of the cells, and reaching [`K3_REACH`] of the way from the centre to the image's corners |
//!
//! The cells are a [`CELLS_X`] × [`CELLS_Y`] grid over the image. A term the user holds fixed stays
//! fixed; [`LensModel::Full`] estimates every term the user did not fix, as before this rule.

use crate::CameraOptions;
use rig::math::{Point2, Real};
use serde::{Deserialize, Serialize};

/// Image cells across, for coverage.
pub const CELLS_X: usize = 6;
/// Image cells down, for coverage.
pub const CELLS_Y: usize = 4;
/// Views needed before p1, p2 are estimated.
pub const TANGENTIAL_VIEWS: usize = 6;
/// Share of the cells that must hold a corner before p1, p2 are estimated.
pub const TANGENTIAL_COVER: Real = 0.5;
/// Views needed before k3 is estimated.
pub const K3_VIEWS: usize = 8;
/// Share of the cells that must hold a corner before k3 is estimated.
pub const K3_COVER: Real = 0.6;
/// How far out (share of the centre-to-corner distance) some corner must be before k3 is estimated.
pub const K3_REACH: Real = 0.75;

/// How the lens model is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LensModel {
    /// The terms the views support (the module's rule).
    #[default]
    Auto,
    /// Every term the options do not fix.
    Full,
}

/// Where the board's corners fell, over every view.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Coverage {
    /// Views.
    pub views: usize,
    /// Which of the [`CELLS_X`] × [`CELLS_Y`] cells hold a corner, row by row from the top.
    pub cells: Vec<bool>,
    /// The farthest corner from the image centre, as a share of the centre-to-corner distance.
    pub reach: Real,
}

impl Coverage {
    /// The coverage of `views` (each a list of corner pixels) in a `width × height` image.
    pub fn of<'a>(views: impl IntoIterator<Item = &'a [Point2]>, width: u32, height: u32) -> Coverage {
        let (w, h) = (width as Real, height as Real);
        let (cx, cy) = (w / 2.0, h / 2.0);
        let half_diagonal = (cx * cx + cy * cy).sqrt();
        let mut cov = Coverage { views: 0, cells: vec![false; CELLS_X * CELLS_Y], reach: 0.0 };
        for corners in views {
            cov.views += 1;
            for p in corners {
                if !(p.x >= 0.0 && p.y >= 0.0 && p.x < w && p.y < h) {
                    continue;
                }
                let (i, j) = ((p.x / w * CELLS_X as Real) as usize, (p.y / h * CELLS_Y as Real) as usize);
                cov.cells[j.min(CELLS_Y - 1) * CELLS_X + i.min(CELLS_X - 1)] = true;
                cov.reach = cov.reach.max(((p.x - cx).powi(2) + (p.y - cy).powi(2)).sqrt() / half_diagonal);
            }
        }
        cov
    }

    /// The share of cells holding a corner.
    pub fn covered(&self) -> Real {
        self.cells.iter().filter(|&&c| c).count() as Real / self.cells.len().max(1) as Real
    }

    /// The regions of the image (a 3 × 3 split: "top left" … "bottom right") none of whose cells
    /// holds a corner.
    pub fn missing(&self) -> Vec<String> {
        // The first and last rows of cells are the image's top and bottom, the rows between its middle.
        let row = |j: usize| {
            if j == 0 {
                0
            } else if j + 1 == CELLS_Y {
                2
            } else {
                1
            }
        };
        let mut covered = [[false; 3]; 3];
        for (k, _) in self.cells.iter().enumerate().filter(|(_, c)| **c) {
            covered[row(k / CELLS_X)][k % CELLS_X * 3 / CELLS_X] = true;
        }
        let mut out = Vec::new();
        for (row, name) in covered.iter().zip(["top", "middle", "bottom"]) {
            for (seen, side) in row.iter().zip(["left", "centre", "right"]) {
                if !seen {
                    out.push(format!("{name} {side}"));
                }
            }
        }
        out
    }
}

/// The lens terms chosen, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct ModelChoice {
    /// The terms estimated besides fx, fy, cx, cy (OpenCV's names: k1, k2, p1, p2, k3), in that order.
    pub estimated: Vec<String>,
    /// The terms held at zero, each with why.
    pub held: Vec<String>,
}

/// The options the camera fit runs with: `user`'s, plus what `model` holds fixed for `coverage`.
pub fn choose(model: LensModel, user: CameraOptions, coverage: &Coverage) -> (CameraOptions, ModelChoice) {
    let mut opts = user;
    let mut held = Vec::new();
    let cover = coverage.covered();
    if user.zero_tangential {
        held.push("p1, p2: held at zero (--zero-tangential)".to_string());
    } else if model == LensModel::Auto && (coverage.views < TANGENTIAL_VIEWS || cover < TANGENTIAL_COVER) {
        opts.zero_tangential = true;
        held.push(format!(
            "p1, p2: held at zero: {} views with corners in {:.0} % of the image (estimated from {TANGENTIAL_VIEWS} \
             views and {:.0} %)",
            coverage.views,
            100.0 * cover,
            100.0 * TANGENTIAL_COVER
        ));
    }
    if user.fix_k3 {
        held.push("k3: held at zero (--fix-k3)".to_string());
    } else if model == LensModel::Auto && (coverage.views < K3_VIEWS || cover < K3_COVER || coverage.reach < K3_REACH) {
        opts.fix_k3 = true;
        held.push(format!(
            "k3: held at zero: {} views, corners in {:.0} % of the image and out to {:.0} % of the way to its \
             corners (estimated from {K3_VIEWS} views, {:.0} % and {:.0} %)",
            coverage.views,
            100.0 * cover,
            100.0 * coverage.reach,
            100.0 * K3_COVER,
            100.0 * K3_REACH
        ));
    }
    let mut estimated = vec!["k1".to_string(), "k2".to_string()];
    if !opts.zero_tangential {
        estimated.extend(["p1".to_string(), "p2".to_string()]);
    }
    if !opts.fix_k3 {
        estimated.push("k3".to_string());
    }
    (opts, ModelChoice { estimated, held })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid_views(n: usize, x0: Real, x1: Real, y0: Real, y1: Real) -> Vec<Vec<Point2>> {
        (0..n)
            .map(|_| {
                (0..=10)
                    .flat_map(|i| (0..=10).map(move |j| (i, j)))
                    .map(|(i, j)| Point2::new(x0 + (x1 - x0) * i as Real / 10.0, y0 + (y1 - y0) * j as Real / 10.0))
                    .collect()
            })
            .collect()
    }

    #[test]
    fn few_central_views_hold_k3_and_the_tangential_terms() {
        let views = grid_views(4, 250.0, 390.0, 180.0, 300.0);
        let cov = Coverage::of(views.iter().map(|v| v.as_slice()), 640, 480);
        let (opts, choice) = choose(LensModel::Auto, CameraOptions::default(), &cov);
        assert!(opts.fix_k3 && opts.zero_tangential, "{choice:?}");
        assert_eq!(choice.estimated, ["k1", "k2"]);
        assert!(choice.held[1].contains("4 views"), "{:?}", choice.held);
        assert!(cov.missing().contains(&"top left".to_string()), "{:?}", cov.missing());
        // Full: every term the user did not fix.
        let (opts, _) = choose(LensModel::Full, CameraOptions::default(), &cov);
        assert!(!opts.fix_k3 && !opts.zero_tangential);
    }

    #[test]
    fn views_that_cover_the_image_estimate_every_term() {
        let views = grid_views(10, 5.0, 635.0, 5.0, 475.0);
        let cov = Coverage::of(views.iter().map(|v| v.as_slice()), 640, 480);
        assert_eq!(cov.covered(), 1.0);
        assert!(cov.reach > 0.95 && cov.missing().is_empty());
        let (opts, choice) = choose(LensModel::Auto, CameraOptions::default(), &cov);
        assert_eq!(opts, CameraOptions::default());
        assert_eq!(choice.estimated, ["k1", "k2", "p1", "p2", "k3"]);
        // What the user fixes stays fixed, and is said.
        let (opts, choice) = choose(LensModel::Auto, CameraOptions { fix_k3: true, ..Default::default() }, &cov);
        assert!(opts.fix_k3 && choice.held[0].contains("--fix-k3"));
    }
}
