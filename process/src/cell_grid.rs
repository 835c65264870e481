//! Points bucketed in cubic cells, for the fixed-radius questions fusion asks of millions of points:
//! "which pairs lie within r" and "are there at least m points within r of p".
//!
//! The k-d tree ([`crate::kd_tree`]) answers k-nearest questions; asked instead "at least m within
//! r", it must still find the m nearest. Here a point's own cell usually holds the answer: the
//! query visits the cells overlapping the ball, its own first, and stops at the m-th point found —
//! on the demo's 2.8 M fused points a dozen distances per point instead of a 9-nearest search, and
//! the grid is built on all cores where the tree's construction runs on one (BENCHMARKS.md).

use rayon::prelude::*;
use rig::math::{Point3, Real};
use rustc_hash::FxHashMap;

/// Cells per axis at most: three 21-bit cell coordinates pack into one `u64` key.
const MAX_CELLS_PER_AXIS: i64 = 1 << 21;

/// Points in cubic cells of one size.
pub struct CellGrid<'a> {
    points: &'a [Point3],
    origin: Point3,
    cell: Real,
    dims: [i64; 3],
    /// Point indices sorted by cell key; a cell's points are one run.
    order: Vec<u32>,
    /// Cell key → its run in `order`.
    cells: FxHashMap<u64, (u32, u32)>,
}

impl<'a> CellGrid<'a> {
    /// Buckets `points` in cells `cell` wide; `None` when the cell is not a positive finite size, a
    /// coordinate is not finite, the points span more than 2²¹ cells along an axis, or there are more
    /// than `u32::MAX` points — callers fall back to the k-d tree.
    pub fn new(points: &'a [Point3], cell: Real) -> Option<Self> {
        if !(cell > 0.0 && cell.is_finite()) || points.is_empty() || points.len() >= u32::MAX as usize {
            return None;
        }
        let (lo, hi) = points
            .par_iter()
            .fold(
                || ([Real::INFINITY; 3], [Real::NEG_INFINITY; 3]),
                |(mut lo, mut hi), p| {
                    for k in 0..3 {
                        lo[k] = lo[k].min(p[k]);
                        hi[k] = hi[k].max(p[k]);
                    }
                    (lo, hi)
                },
            )
            .reduce(
                || ([Real::INFINITY; 3], [Real::NEG_INFINITY; 3]),
                |a, b| ([0, 1, 2].map(|k| a.0[k].min(b.0[k])), [0, 1, 2].map(|k| a.1[k].max(b.1[k]))),
            );
        if !lo.iter().chain(&hi).all(|x| x.is_finite()) {
            return None;
        }
        let dims = [0, 1, 2].map(|k| ((hi[k] - lo[k]) / cell).floor() as i64 + 1);
        if dims.iter().any(|&d| d > MAX_CELLS_PER_AXIS) {
            return None;
        }
        let origin = Point3::new(lo[0], lo[1], lo[2]);
        let mut grid = CellGrid { points, origin, cell, dims, order: Vec::new(), cells: FxHashMap::default() };
        let keys: Vec<u64> = points.par_iter().map(|p| grid.key(grid.coords(p))).collect();
        let mut order: Vec<u32> = (0..points.len() as u32).collect();
        order.par_sort_unstable_by_key(|&i| keys[i as usize]);
        let mut cells = FxHashMap::with_capacity_and_hasher(points.len() / 4, Default::default());
        let mut start = 0;
        while start < order.len() {
            let key = keys[order[start] as usize];
            let mut end = start + 1;
            while end < order.len() && keys[order[end] as usize] == key {
                end += 1;
            }
            cells.insert(key, (start as u32, end as u32));
            start = end;
        }
        grid.order = order;
        grid.cells = cells;
        Some(grid)
    }

    /// The cell coordinates of a position, clamped to the grid.
    fn coords(&self, p: &Point3) -> [i64; 3] {
        [0, 1, 2].map(|k| (((p[k] - self.origin[k]) / self.cell).floor() as i64).clamp(0, self.dims[k] - 1))
    }

    fn key(&self, c: [i64; 3]) -> u64 {
        (c[0] as u64) | (c[1] as u64) << 21 | (c[2] as u64) << 42
    }

    /// The points of one cell.
    fn cell_points(&self, c: [i64; 3]) -> &[u32] {
        match self.cells.get(&self.key(c)) {
            Some(&(s, e)) => &self.order[s as usize..e as usize],
            None => &[],
        }
    }

    /// Calls `visit` with the points of every cell the ball of radius `r` about `p` overlaps, `p`'s
    /// own cell first, until `visit` returns false.
    fn for_cells_near(&self, p: &Point3, r: Real, mut visit: impl FnMut(&[u32]) -> bool) {
        let own = self.coords(p);
        if !visit(self.cell_points(own)) {
            return;
        }
        let lo = self.coords(&Point3::new(p.x - r, p.y - r, p.z - r));
        let hi = self.coords(&Point3::new(p.x + r, p.y + r, p.z + r));
        let block: i64 = (0..3).map(|k| hi[k] - lo[k] + 1).product();
        if block > self.cells.len() as i64 {
            // A ball wider than the occupied cells are many (a far point's): the occupied cells
            // inside the block, not every cell of it.
            let own_key = self.key(own);
            for (&key, &(s, e)) in &self.cells {
                let c = [key & 0x1f_ffff, (key >> 21) & 0x1f_ffff, key >> 42].map(|x| x as i64);
                let inside = (0..3).all(|k| (lo[k]..=hi[k]).contains(&c[k]));
                if key != own_key && inside && !visit(&self.order[s as usize..e as usize]) {
                    return;
                }
            }
            return;
        }
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    if [x, y, z] != own && !visit(self.cell_points([x, y, z])) {
                        return;
                    }
                }
            }
        }
    }

    /// True when at least `m` points (the point itself included, if it is one of the grid's) lie
    /// within `r` of `p`.
    pub fn at_least_within(&self, p: &Point3, r: Real, m: usize) -> bool {
        let r2 = r * r;
        let mut found = 0;
        self.for_cells_near(p, r, |run| {
            found += run.iter().filter(|&&j| (self.points[j as usize] - p).norm_squared() <= r2).count();
            found < m
        });
        found >= m
    }

    /// The squared distances from `p` to every point within `r` of it (in no order).
    pub fn squared_distances_within(&self, p: &Point3, r: Real, out: &mut Vec<Real>) {
        out.clear();
        let r2 = r * r;
        self.for_cells_near(p, r, |run| {
            out.extend(run.iter().map(|&j| (self.points[j as usize] - p).norm_squared()).filter(|&d| d <= r2));
            true
        });
    }

    /// Every pair `(i, j)`, `i < j`, of the grid's points at most `r` apart, ordered by `i`.
    pub fn pairs_within(&self, r: Real) -> Vec<(u32, u32)> {
        let r2 = r * r;
        self.points
            .par_iter()
            .enumerate()
            .flat_map_iter(|(i, p)| {
                let mut near = Vec::new();
                self.for_cells_near(p, r, |run| {
                    near.extend(
                        run.iter()
                            .filter(|&&j| j as usize > i && (self.points[j as usize] - p).norm_squared() <= r2)
                            .map(|&j| (i as u32, j)),
                    );
                    true
                });
                near.sort_unstable();
                near
            })
            .collect()
    }
}

/// The distance from `p` to its `k`-th nearest other point of the grid (`p` one of them), or `limit`
/// when that is farther: the ball grows from `guess` until it holds `k + 1` points or reaches `limit`
/// (a median of such distances needs no more than "farther than the limit" of a far point, and a
/// ball grown across the whole cloud would cost as much as the cloud). `None` when fewer than `k + 1`
/// points exist.
pub fn kth_distance(
    grid: &CellGrid,
    p: &Point3,
    k: usize,
    guess: Real,
    limit: Real,
    scratch: &mut Vec<Real>,
) -> Option<Real> {
    if grid.points.len() <= k {
        return None;
    }
    let mut r = guess.max(grid.cell * 1e-6).min(limit);
    loop {
        grid.squared_distances_within(p, r, scratch);
        if scratch.len() > k {
            let (_, kth, _) = scratch.select_nth_unstable_by(k, Real::total_cmp);
            return Some(kth.sqrt());
        }
        if r >= limit {
            return Some(limit);
        }
        r = (r * 2.0).min(limit);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kd_tree::PointTree;
    use proptest::prelude::*;

    fn cloud(seed: u64, n: usize, spread: Real) -> Vec<Point3> {
        // A wavy sheet with a few far strays: dense cells, empty cells and isolated points.
        let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let mut next = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 11) as Real / (1u64 << 53) as Real
        };
        (0..n)
            .map(|i| {
                let (u, v) = (next() * spread, next() * spread);
                if i % 97 == 0 {
                    Point3::new(u * 3.0, v * 3.0, next() * spread * 2.0)
                } else {
                    Point3::new(u, v, 0.1 * (u * 0.7).sin() + 0.01 * next())
                }
            })
            .collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        /// Pairs, counts and k-th distances agree with the k-d tree's answers, whatever the cell size
        /// relative to the radius.
        #[test]
        fn answers_equal_the_k_d_tree_s(seed in 0u64..1000, cell in 0.05..3.0f64, r in 0.01..1.0f64) {
            let pts = cloud(seed, 600, 4.0);
            let grid = CellGrid::new(&pts, cell).unwrap();
            let tree = PointTree::new(&pts);
            let mut want: Vec<(u32, u32)> = (0..pts.len())
                .flat_map(|i| tree.within(&pts[i], r).into_iter().filter(move |&j| j > i).map(move |j| (i as u32, j as u32)))
                .collect();
            want.sort_unstable();
            prop_assert_eq!(grid.pairs_within(r), want);
            let mut scratch = Vec::new();
            for (i, p) in pts.iter().enumerate().step_by(7) {
                let n = tree.within(p, r).len();
                for m in [1, 2, 5, 9, 30] {
                    prop_assert_eq!(grid.at_least_within(p, r, m), n >= m, "point {} m {}", i, m);
                }
                let nb = tree.nearest_k(p, 9);
                let want = (pts[nb[8]] - p).norm();
                let got = kth_distance(&grid, p, 8, r, Real::INFINITY, &mut scratch).unwrap();
                prop_assert!((got - want).abs() <= 1e-12 * want.max(1.0), "point {}: {} vs {}", i, got, want);
                let capped = kth_distance(&grid, p, 8, r, 0.5 * want, &mut scratch).unwrap();
                prop_assert_eq!(capped, 0.5 * want, "point {}: the limit stands for anything farther", i);
            }
        }
    }

    #[test]
    fn a_far_point_is_answered_without_visiting_the_empty_cells_between() {
        // A sheet of fine cells and one point a million cells away: its ball's block would be 10^18
        // cells; the occupied ones are a few thousand.
        let mut pts: Vec<Point3> = (0..4000).map(|i| Point3::new((i % 80) as Real, (i / 80) as Real, 0.0)).collect();
        pts.push(Point3::new(0.0, 0.0, 1.0e6));
        let grid = CellGrid::new(&pts, 1.0).unwrap();
        let far = pts[4000];
        let mut scratch = Vec::new();
        let d = kth_distance(&grid, &far, 8, 1.0, Real::INFINITY, &mut scratch).unwrap();
        assert!((d - 1.0e6).abs() < 1.0, "{d}");
        assert!(!grid.at_least_within(&far, 2.0e6, 4002));
        assert!(grid.at_least_within(&far, 2.0e6, 4001));
    }

    #[test]
    fn unusable_inputs_fall_back() {
        let pts = vec![Point3::origin(), Point3::new(1.0, 0.0, 0.0)];
        assert!(CellGrid::new(&pts, 0.0).is_none());
        assert!(CellGrid::new(&pts, Real::NAN).is_none());
        assert!(CellGrid::new(&pts, 1e-9).is_none(), "2^21 cells per axis at most");
        assert!(CellGrid::new(&[Point3::new(Real::INFINITY, 0.0, 0.0)], 1.0).is_none());
        assert!(CellGrid::new(&[], 1.0).is_none());
    }
}
