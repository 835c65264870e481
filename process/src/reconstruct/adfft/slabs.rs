//! The sweep in slabs of cube layers, for other machines: each solved leaf cut into the parts the
//! slabs need, each slab swept from its parts.

use super::leaf::{LeafGrid, LeafTask, SolvedLeaf};
use super::octree::CoarseChi;
use super::sweep::{ActiveLeaf, extract};
use rig::TriMesh;
use rig::math::Real;
use std::ops::Range;
use std::sync::atomic::AtomicUsize;

/// A sweep to be done in slabs of cube layers, on other machines say ([`reconstruct_adfft_slabs`]):
/// every leaf is solved once, somewhere ([`LeafSolver`]), and cut into the parts the slabs its
/// support reaches need ([`slab_part`]); each slab is then swept from its parts ([`sweep_slab`]).
///
/// [`reconstruct_adfft_slabs`]: super::reconstruct_adfft_slabs
/// [`LeafSolver`]: super::LeafSolver
#[derive(Debug, Clone)]
pub struct SlabJob<'a> {
    /// Every leaf, in the octree's order (a leaf's index is its id in [`sweep_slab`]).
    pub tasks: Vec<LeafTask>,
    /// The global grid.
    pub grid: LeafGrid,
    /// The samples' area weights, as the leaf solves need them.
    pub weights: &'a [Real],
    /// The coarse χ behind the leaves.
    pub coarse: CoarseChi,
    /// Each slab's cube layers (layer k: the cubes between planes k and k + 1), in order, covering
    /// 0..n − 1; balanced by the blend's work (the grid's plane plus the supports crossing it).
    pub layers: Vec<Range<usize>>,
}

/// Cube layers 0..n − 1 cut into `slabs` runs of about equal blending work: each plane costs its n²
/// points (the coarse χ and marching cubes) plus the points of every support crossing it.
pub(super) fn slab_layers(ranges: &[([usize; 3], [usize; 3])], n: usize, slabs: usize) -> Vec<Range<usize>> {
    let mut change = vec![0i64; n + 1];
    for (lo, hi) in ranges {
        let area = ((hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1)) as i64;
        change[lo[2]] += area;
        change[hi[2] + 1] -= area;
    }
    let mut cost = Vec::with_capacity(n);
    let mut running = 0i64;
    for c in change.iter().take(n) {
        running += c;
        cost.push((n * n) as i64 + running);
    }
    let total: i64 = cost.iter().sum();
    let mut layers = Vec::new();
    let (mut start, mut done) = (0, 0i64);
    for (k, c) in cost.iter().enumerate().take(n - 1) {
        done += c;
        let wanted = total * (layers.len() as i64 + 1) / slabs as i64;
        // Every slab keeps at least one layer, the last included.
        if done >= wanted && layers.len() + 1 < slabs && k + 1 < n - 1 {
            layers.push(start..k + 1);
            start = k + 1;
        }
    }
    layers.push(start..n - 1);
    layers
}

/// The part of a solved leaf a slab of `layers` blends: its planes from one below the first layer
/// to one above the last (the planes [`marching_cubes_layers`] reads), `None` where it has none.
///
/// [`marching_cubes_layers`]: crate::reconstruct::marching_cubes::marching_cubes_layers
pub fn slab_part(solved: &SolvedLeaf, layers: &Range<usize>, n: usize) -> Option<SolvedLeaf> {
    let first = layers.start.saturating_sub(1).max(solved.lo[2]);
    let last = (layers.end + 1).min(n - 1).min(solved.lo[2] + solved.dims[2] - 1);
    if first > last {
        return None;
    }
    let plane = solved.dims[0] * solved.dims[1];
    let (a, b) = (first - solved.lo[2], last - solved.lo[2] + 1);
    Some(SolvedLeaf {
        lo: [solved.lo[0], solved.lo[1], first],
        dims: [solved.dims[0], solved.dims[1], b - a],
        values: solved.values[a * plane..b * plane].to_vec(),
        weight: [solved.weight[0].clone(), solved.weight[1].clone(), solved.weight[2][a..b].to_vec()],
    })
}

/// One slab of a distributed sweep: marching cubes over the blend (eqs. 5.19–5.20) of `layers`,
/// from the parts of every leaf whose support reaches them (`(id, part)`: the leaf's index in
/// [`SlabJob::tasks`] and [`slab_part`] of its solve) and the coarse χ. A part that does not fit
/// the grid, lies beyond the slab's planes or comes twice is refused, naming the leaf.
pub fn sweep_slab(
    mut parts: Vec<(usize, SolvedLeaf)>,
    coarse: &CoarseChi,
    grid: &LeafGrid,
    layers: Range<usize>,
) -> Result<TriMesh, String> {
    grid.check(std::slice::from_ref(&layers))?;
    let n = grid.n;
    if coarse.n == 0 || coarse.values.len() != coarse.n.pow(3) {
        return Err(format!("coarse χ of {} values for {}³ points", coarse.values.len(), coarse.n));
    }
    // The planes this slab reads ([`slab_part`] cuts each leaf to them).
    let (first, last) = (layers.start.saturating_sub(1), (layers.end + 1).min(n - 1));
    let mut seen = std::collections::HashSet::new();
    for (id, p) in &parts {
        let fits = (0..3).all(|d| p.dims[d] > 0 && p.lo[d] + p.dims[d] <= n && p.weight[d].len() == p.dims[d])
            && p.values.len() == p.dims.iter().product::<usize>();
        if !fits {
            return Err(format!("leaf {id}: its part does not fit the grid"));
        }
        // Parts handed between machines: one of another slab, or a leaf's twice, would be blended
        // into this slab's surface without a sign.
        let (a, b) = (p.lo[2], p.lo[2] + p.dims[2] - 1);
        if a < first || b > last {
            return Err(format!("leaf {id}: its part (planes {a}–{b}) is not this slab's (planes {first}–{last})"));
        }
        if !seen.insert(*id) {
            return Err(format!("leaf {id}: its part came twice"));
        }
    }
    parts.sort_by_key(|(id, p)| (p.lo[2], *id));
    let mut parts = parts.into_iter().peekable();
    let (mesh, _) = extract(grid, coarse, layers, &AtomicUsize::new(0), 1, |k| {
        let mut starting = Vec::new();
        while let Some((id, part)) = parts.next_if(|(_, p)| p.lo[2] <= k) {
            starting.push(ActiveLeaf::new(id, part));
        }
        starting
    });
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Slabs cover every layer once, in order, none empty, however many are asked for.
    #[test]
    fn slab_layers_cover_the_grid() {
        let ranges = vec![([0, 0, 2], [5, 5, 9]), ([0, 0, 20], [5, 5, 30])];
        for slabs in [1, 2, 3, 7, 31, 32, 100] {
            let layers = slab_layers(&ranges, 32, slabs);
            assert!(layers.len() <= slabs.min(31) && !layers.is_empty(), "{slabs}: {layers:?}");
            assert_eq!((layers[0].start, layers[layers.len() - 1].end), (0, 31));
            assert!(layers.iter().all(|l| !l.is_empty()) && layers.windows(2).all(|w| w[0].end == w[1].start));
        }
        assert_eq!(slab_layers(&ranges, 32, 2).len(), 2);
    }

    /// Parts come from other machines: a part of another slab or a leaf's part twice is refused,
    /// naming the leaf, where it would have been blended in silence.
    #[test]
    fn a_slab_refuses_parts_that_are_not_its_own() {
        let n = 16;
        let grid = LeafGrid { origin: [0.0; 3], h: 1.0, n, scale: 2.0, smoothing_cells: 1.0 };
        let coarse = CoarseChi { n: 4, values: vec![0.5; 64], iso: 0.5, weight: 0.1 };
        let leaf = SolvedLeaf {
            lo: [2, 2, 0],
            dims: [4, 4, 16],
            values: vec![0.25; 4 * 4 * 16],
            weight: [vec![1.0; 4], vec![1.0; 4], vec![1.0; 16]],
        };
        let (low, high) = (0..7, 7..15);
        let part = |layers: &Range<usize>| slab_part(&leaf, layers, n).unwrap();
        assert!(sweep_slab(vec![(3, part(&low))], &coarse, &grid, low.clone()).is_ok());
        let e = sweep_slab(vec![(3, part(&high))], &coarse, &grid, low.clone()).unwrap_err();
        assert!(e.contains("leaf 3") && e.contains("not this slab's"), "{e}");
        let e = sweep_slab(vec![(3, part(&low)), (3, part(&low))], &coarse, &grid, low).unwrap_err();
        assert!(e.contains("leaf 3: its part came twice"), "{e}");
    }
}
