//! AdFFT's settings and its report (with what the report tells the user).

use crate::limits::{ADFFT_SCALE, ADFFT_SMOOTHING_CELLS, ParamError, bad, check_padding};
use crate::reconstruct::fit::FitReport;
use crate::reconstruct::self_intersect::RepairReport;
use rig::math::Real;
use serde::Serialize;

/// Settings of AdFFT.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AdFftParams {
    /// The global grid: 2^depth points per axis over the bounding cube.
    pub depth: u32,
    /// The mean distance (cloud units) of a cell's samples to its local surface above which the cell
    /// is split; `None` takes half the global grid spacing.
    pub error: Option<Real>,
    /// Points within the cell scaled by this about its centre feed its local solution (c = 1.8).
    pub scale: Real,
    /// The subdivision test's local grid: 2^test_depth points per axis (2⁵ in the thesis).
    pub test_depth: u32,
    /// Fraction of a cell's points whose distance is tested (10 % in the thesis).
    pub test_fraction: Real,
    /// A cell holding fewer than 4× this fraction of all points is not split (0.5 % in the thesis).
    pub min_points: Real,
    /// Margin of the bounding cube, as for the global method.
    pub padding: Real,
    /// Gaussian low-pass, in grid cells. On the bunny at 256³ with quadratic levels, 0.5 cells and 8
    /// area neighbours gave a mean of accuracy and completeness of 0.0579 mm, 0.25 cells and 16
    /// neighbours 0.0535 (before the ridge was lightened); with affine levels and 8 neighbours, 0.5 →
    /// 0.25 cells went 0.0667 → 0.0621. Less smoothing hardly helps the global method further (0.0595
    /// at 0.25, 0.0593 at 0.1, 0.0592 at 0).
    pub smoothing_cells: Real,
    /// Neighbours for the area weights. More neighbours give smoother weights, and the weights' noise
    /// is noise in the splatted normal field: on the bunny at 256³, AdFFT went from 0.0621 (8) to
    /// 0.0592 (16) and 0.0588 (32) with affine levels; the global method from 0.0595 (8) to 0.0533 (16,
    /// 32) and 0.0524 (64), at 0.25 cells.
    pub area_k: usize,
    /// Components under this fraction of the largest's area are dropped.
    pub min_component: Real,
    /// The coarse global solution behind the leaves: its grid depth and its blending weight (a leaf's
    /// weight is 1 at its centre). On the bunny at 512³, weights 0.01 / 0.05 / 0.15 / 0.3 gave a mean
    /// of accuracy and completeness of 0.0644 / 0.0628 / 0.0593 / 0.0593 mm: the smooth coarse χ
    /// steadies the level where neighbouring leaves disagree.
    pub coarse_depth: u32,
    /// See `coarse_depth`.
    pub coarse_weight: Real,
    /// Refuse reconstructions estimated to need more than this many bytes (default 8 GB).
    pub memory_budget: u64,
    /// The grid is made no finer than the samples carry: `depth`, or the finest depth below it at
    /// which the cells the surface crosses hold at least this many samples each on average
    /// ([`supported_depth`]); 0 keeps `depth` whatever the samples. Poisson's octree adapts the same
    /// way (PoissonRecon's `--samplesPerNode`): on the bunny's 362,272 points the peers' meshes at
    /// depth 10 have the triangles of depth 9 (Open3D 1.12 M at both, PoissonRecon 1.13 → 1.25 M),
    /// while AdFFT on the full 1024³ grid made 5.0 M triangles of genus 68 in 88 s: cells of 0.19 mm
    /// between samples 0.41 mm apart resolve their noise, not the surface. At 0.25 the bunny keeps
    /// depth 9 (0.56 samples per cell) and stops there (depth 10: 0.14).
    ///
    /// [`supported_depth`]: super::supported_depth
    pub samples_per_cell: Real,
}

impl Default for AdFftParams {
    fn default() -> Self {
        AdFftParams {
            depth: 9,
            error: None,
            scale: 1.8,
            test_depth: 5,
            test_fraction: 0.1,
            min_points: 0.005,
            padding: 0.05,
            smoothing_cells: 0.25,
            area_k: 16,
            min_component: 0.01,
            coarse_depth: 6,
            coarse_weight: 0.15,
            memory_budget: 8_000_000_000,
            samples_per_cell: 0.25,
        }
    }
}

impl AdFftParams {
    /// AdFFT's settings that no option sets but the library, Python's distributed jobs and the
    /// benches can: each a number in the range its meaning allows, so a NaN or a support smaller than
    /// its cell is refused by name before the octree instead of going on into the grid unchecked.
    /// [`reconstruct_adfft`](super::reconstruct_adfft) checks them itself too, as it checks its depth;
    /// the stage's `validate` ([`crate::validate`]) calls it with the options' checks. The bounds are
    /// [`crate::limits`]'.
    pub fn check_fields(&self) -> Result<(), ParamError> {
        let p = self;
        check_padding(p.padding)?;
        let within = |field: &'static str, x: Real, range: std::ops::RangeInclusive<Real>, why: &str| {
            if range.contains(&x) {
                Ok(())
            } else {
                Err(bad(field, x, format!("must be from {} to {}: {why}", range.start(), range.end())))
            }
        };
        within("scale", p.scale, ADFFT_SCALE, "a leaf's support must cover its cell (c = 1.8)")?;
        within("coarse_weight", p.coarse_weight, 0.0..=1.0, "a leaf weighs 1 at its centre")?;
        within("smoothing_cells", p.smoothing_cells, ADFFT_SMOOTHING_CELLS, "the low-pass in cells")?;
        within("min_points", p.min_points, 0.0..=0.25, "a fraction of all points")?;
        within("min_component", p.min_component, 0.0..=1.0, "a fraction of the largest component's area")?;
        if !(p.test_fraction > 0.0 && p.test_fraction <= 1.0) {
            return Err(bad("test_fraction", p.test_fraction, "must be a fraction above 0 and at most 1"));
        }
        if !(3..=7).contains(&p.test_depth) {
            return Err(bad("test_depth", p.test_depth, "must be from 3 to 7 (the subdivision test's local grid)"));
        }
        if !(2..=8).contains(&p.coarse_depth) {
            return Err(bad("coarse_depth", p.coarse_depth, "must be from 2 to 8 (the coarse χ's grid)"));
        }
        Ok(())
    }
}

/// What AdFFT did.
#[derive(Debug, Clone, Default, Serialize, serde::Deserialize)]
pub struct AdFftReport {
    /// The depth asked for ([`AdFftParams::depth`]).
    #[serde(default)]
    pub depth_asked: u32,
    /// The depth the grid was built at: the one asked, or less where the samples carry no finer
    /// detail ([`supported_depth`]).
    ///
    /// [`supported_depth`]: super::supported_depth
    #[serde(default)]
    pub depth: u32,
    /// The samples per cell crossing the surface at that depth, on average.
    #[serde(default)]
    pub samples_per_cell: Real,
    /// Global grid points per axis.
    pub n: usize,
    /// Global grid spacing.
    pub cell: Real,
    /// The memory the reconstruction was estimated to need before it started (bytes).
    #[serde(default)]
    pub estimated_bytes: u64,
    /// The triangles the mesh was estimated to have before it started (from the samples' area; see
    /// [`TRIANGLES_PER_AREA_CELL`]).
    ///
    /// [`TRIANGLES_PER_AREA_CELL`]: super::TRIANGLES_PER_AREA_CELL
    #[serde(default)]
    pub estimated_triangles: u64,
    /// The extracted surface's pull onto its samples ([`crate::reconstruct::fit`]).
    #[serde(default)]
    pub fit: FitReport,
    /// Self-intersections where blended leaves folded the surface, and their repair.
    #[serde(default)]
    pub self_intersections: RepairReport,
    /// The error the subdivision aimed for.
    pub error: Real,
    /// Leaves solved (the patches blended), by octree depth.
    pub leaves_by_depth: Vec<usize>,
    /// Cells whose subdivision was tested.
    pub tests: usize,
    /// Most leaves held in memory at once during the sweep (0 when swept in slabs elsewhere).
    pub peak_active_leaves: usize,
    /// Output size.
    pub vertices: usize,
    /// Output size.
    pub triangles: usize,
    /// Small components dropped.
    pub components_pruned: usize,
    /// Seconds building and testing the octree.
    pub seconds_octree: Real,
    /// Seconds solving leaves, blending and extracting.
    pub seconds_extract: Real,
}

impl AdFftReport {
    /// Leaves (patches) in all.
    pub fn leaves(&self) -> usize {
        self.leaves_by_depth.iter().sum()
    }

    /// What to tell the user when the grid was built shallower than asked
    /// ([`AdFftParams::samples_per_cell`]), `None` when it was built as asked: a depth asked and a
    /// coarser mesh made, unexplained, reads as a defect.
    pub fn shallower_than_asked(&self) -> Option<String> {
        (self.depth < self.depth_asked).then(|| {
            format!(
                "depth {} asked; built at depth {}, where the surface's cells hold {:.2} samples each: the samples \
                 carry no finer detail (--samples-per-cell 0 keeps depth {})",
                self.depth_asked, self.depth, self.samples_per_cell, self.depth_asked
            )
        })
    }

    /// What to tell the user when many vertices were further from their samples' plane than the fit
    /// may move them ([`crate::reconstruct::fit`], half a cell): over 5 % of those moved. `None` otherwise (the
    /// bunny at depth 9: 0.3 %). On a grid no finer than the default builds, it says the indicator's
    /// surface and the samples disagree — normals turned the wrong way, or scans out of alignment. On
    /// a grid finer than that (`--samples-per-cell 0`, or a sparse cloud at the depth-6 floor), it says so: there
    /// the surface strays between samples further apart than its cells, and the remedy is the grid
    /// (bun_zipper_res2's 5,923 fused points forced onto 128³, 0.15 samples per cell: 9.7 % held;
    /// the default's 64³, 0.60 per cell: 3.7 %).
    pub fn far_from_samples(&self) -> Option<String> {
        let f = &self.fit;
        if !(f.moved > 0 && f.limited as Real > 0.05 * f.moved as Real) {
            return None;
        }
        let held = format!(
            "{:.1} % of the vertices were more than half a cell ({}) from their samples' plane and moved only that far",
            100.0 * f.limited as Real / f.moved as Real,
            three_digits(0.5 * self.cell)
        );
        let default = AdFftParams::default().samples_per_cell;
        Some(if self.samples_per_cell > 0.0 && self.samples_per_cell < default {
            format!(
                "{held}: the grid is finer than the samples carry ({:.2} samples per cell on the surface, fewer than \
                 the default's {default}), so the surface strays between them (a lower --depth keeps it to what the \
                 samples show)",
                self.samples_per_cell
            )
        } else {
            format!(
                "{held}: the surface and the samples disagree there (normals turned the wrong way, or scans out of \
                 alignment?)"
            )
        })
    }
}

/// `x` to three significant digits: a half cell of a cloud in metres (0.000291) is not "0.000".
fn three_digits(x: Real) -> String {
    let decimals = if x.is_finite() && x != 0.0 { (2 - x.abs().log10().floor() as i32).max(0) as usize } else { 3 };
    format!("{x:.decimals$}")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid built shallower than asked says so, naming the depths and the option that keeps the
    /// asked one; one built as asked says nothing.
    #[test]
    fn a_shallower_grid_is_said_with_its_remedy() {
        let r = AdFftReport { depth_asked: 10, depth: 9, samples_per_cell: 0.558, ..Default::default() };
        let why = r.shallower_than_asked().unwrap();
        assert!(
            why.contains("depth 10 asked; built at depth 9")
                && why.contains("0.56 samples")
                && why.contains("--samples-per-cell 0 keeps depth 10"),
            "{why}"
        );
        let r = AdFftReport { depth_asked: 9, depth: 9, ..Default::default() };
        assert_eq!(r.shallower_than_asked(), None);
    }

    /// A fit that had to stop many vertices at its limit is said; one that moved few that far is not.
    #[test]
    fn a_fit_held_at_its_limit_is_said() {
        let fit = |moved, limited| FitReport { moved, limited, ..Default::default() };
        let r = AdFftReport { cell: 0.5, fit: fit(1000, 200), ..Default::default() };
        let why = r.far_from_samples().unwrap();
        assert!(why.contains("20.0 %") && why.contains("(0.250)") && !why.contains("  "), "{why}");
        assert!(why.contains("scans out of alignment"), "{why}");
        // On a grid finer than the samples carry, the grid is named and the remedy given, not the scans.
        let fine = AdFftReport { cell: 0.000_582, samples_per_cell: 0.15, ..r.clone() }.far_from_samples().unwrap();
        assert!(
            fine.contains("(0.000291)")
                && fine.contains("finer than the samples carry (0.15 samples per cell")
                && fine.contains("a lower --depth")
                && !fine.contains("alignment")
                && !fine.contains("  "),
            "{fine}"
        );
        assert_eq!(AdFftReport { fit: fit(1000, 3), ..r.clone() }.far_from_samples(), None);
        assert_eq!(AdFftReport { fit: fit(0, 0), ..r }.far_from_samples(), None);
    }
}
