//! The sweep: marching cubes over the blend of the leaves' χ (eqs. 5.19–5.20) plane by plane, each
//! leaf held only while the sweep crosses its support.

use super::leaf::{LeafGrid, SolvedLeaf};
use super::octree::CoarseChi;
use crate::reconstruct::marching_cubes::{GridFrame, marching_cubes_layers};
use half::f16;
use half::slice::HalfFloatSliceExt;
use rayon::prelude::*;
use rig::TriMesh;
use rig::math::{Point3, Real};
use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};

/// A solved leaf as the sweep holds it: its values plane by plane, each freed once the sweep has
/// passed it, so a leaf costs memory only for the part of its support still ahead; and in 16-bit
/// floats, half the bytes again. The values are χ − iso, within a few units of 0, where f16 keeps
/// 11 significant bits: a zero crossing moves by ~10⁻⁴ of a cell (the bunny at 512³: the mean of
/// accuracy and completeness 0.053765 mm with f32 values, 0.053761 with f16). Planes freed and f16
/// took AdFFT's peak there from 510–620 MiB to 350–380 MiB (issue 42: PoissonRecon's is ~372).
pub(super) struct ActiveLeaf {
    /// The leaf's index in the octree's list: the blend sums the leaves in this order wherever a plane
    /// is computed (the local sweep or a slab of a distributed one), so its value is the same bits.
    pub(super) id: usize,
    pub(super) lo: [usize; 3],
    pub(super) dims: [usize; 3],
    /// χ − iso on each plane of the support (x fastest), empty once swept.
    pub(super) planes: Vec<Vec<f16>>,
    pub(super) weight: [Vec<f32>; 3],
}

impl ActiveLeaf {
    pub(super) fn new(id: usize, s: SolvedLeaf) -> Self {
        let planes = s
            .values
            .chunks(s.dims[0] * s.dims[1])
            .map(|plane| {
                let mut half = vec![f16::ZERO; plane.len()];
                half.convert_from_f32_slice(plane);
                half
            })
            .collect();
        ActiveLeaf { id, lo: s.lo, dims: s.dims, planes, weight: s.weight }
    }
}

/// Eq. 5.19 plane by plane: Σ w_i f_i / Σ w_i over the leaves whose support holds a point, with the
/// coarse χ at its small constant weight.
struct Blend<'a> {
    pub(super) coarse: &'a CoarseChi,
    pub(super) n: usize,
    /// Trilinear interpolation is linear along each axis in turn, so a plane interpolates the coarse
    /// grid once in z, a row once in y, and each point once in x (eight lookups per point had been a
    /// sixth of the run). `taps[i]`: the two coarse planes about fine index i (the coarse grid wraps,
    /// as `sample` reads it) and the weight of the second.
    taps: Vec<(usize, usize, Real)>,
}

impl<'a> Blend<'a> {
    pub(super) fn new(coarse: &'a CoarseChi, n: usize) -> Self {
        // Both grids span the same cube: a fine index i is at coarse index i·coarse_n/n.
        let ratio = coarse.n as Real / n as Real;
        let taps = (0..n)
            .map(|i| {
                let u = i as Real * ratio;
                let b = u.floor();
                let wrap = |v: Real| (v as isize).rem_euclid(coarse.n as isize) as usize;
                (wrap(b), wrap(b + 1.0), u - b)
            })
            .collect();
        Blend { coarse, n, taps }
    }

    /// Plane k of the blend over `active` (which must be in id order; the border stays outside).
    pub(super) fn plane(&self, k: usize, active: &[ActiveLeaf]) -> Vec<f32> {
        let (n, cn, taps) = (self.n, self.coarse.n, &self.taps);
        let (coarse, eps, coarse_iso) = (&self.coarse.values, self.coarse.weight as f32, self.coarse.iso);
        // The coarse χ interpolated to this plane (cn² values, x fastest).
        let (z0, z1, fz) = taps[k];
        let slice: Vec<Real> = (0..cn * cn)
            .map(|xy| {
                let at = |z: usize| coarse[xy + cn * cn * z] as Real;
                (1.0 - fz) * at(z0) + fz * at(z1)
            })
            .collect();
        let mut plane = vec![f32::NAN; n * n];
        plane.par_chunks_mut(n).enumerate().for_each(|(j, row)| {
            if j == 0 || j == n - 1 || k == 0 || k == n - 1 {
                return; // the border stays outside, closing the surface
            }
            let (y0, y1, fy) = taps[j];
            let line: Vec<Real> = (0..cn).map(|x| (1.0 - fy) * slice[x + cn * y0] + fy * slice[x + cn * y1]).collect();
            let mut num: Vec<f32> = taps
                .iter()
                .map(|&(x0, x1, fx)| eps * ((1.0 - fx) * line[x0] + fx * line[x1] - coarse_iso) as f32)
                .collect();
            let mut den = vec![eps; n];
            let mut values = Vec::new();
            for s in active {
                if j < s.lo[1] || j >= s.lo[1] + s.dims[1] || k < s.lo[2] {
                    continue;
                }
                let (y, z) = (j - s.lo[1], k - s.lo[2]);
                let wyz = s.weight[1][y] * s.weight[2][z];
                values.resize(s.dims[0], 0f32);
                s.planes[z][s.dims[0] * y..s.dims[0] * (y + 1)].convert_to_f32_slice(&mut values);
                for (x, v) in values.iter().enumerate() {
                    let w = wyz * s.weight[0][x];
                    num[s.lo[0] + x] += w * v;
                    den[s.lo[0] + x] += w;
                }
            }
            for i in 1..n - 1 {
                row[i] = num[i] / den[i];
            }
        });
        plane
    }
}

/// Marching cubes over the blend of the cube layers `layers` (steps 3–4): `start(k)` hands over the
/// leaves whose values begin at plane k (or before, not yet handed over), which are held until the
/// sweep has passed them, a plane at a time. Each plane adds `step` to `planes`. Returns the mesh and
/// the most leaves held at once.
pub(super) fn extract(
    grid: &LeafGrid,
    coarse: &CoarseChi,
    layers: Range<usize>,
    planes: &AtomicUsize,
    step: usize,
    mut start: impl FnMut(usize) -> Vec<ActiveLeaf> + Send,
) -> (TriMesh, usize) {
    let n = grid.n;
    let frame = GridFrame { dims: [n; 3], origin: Point3::from(grid.origin), spacing: grid.h };
    let blend = Blend::new(coarse, n);
    let mut active: Vec<ActiveLeaf> = Vec::new();
    let mut peak = 0;
    let mesh = marching_cubes_layers(&frame, 0.0, layers, |k| {
        active.extend(start(k));
        active.retain(|s| s.lo[2] + s.dims[2] > k);
        active.sort_by_key(|s| s.id);
        peak = peak.max(active.len());
        let plane = blend.plane(k, &active);
        // This plane of every leaf is done with.
        for s in &mut active {
            s.planes[k - s.lo[2]] = Vec::new();
        }
        planes.fetch_add(step, Ordering::Relaxed);
        plane
    });
    (mesh, peak)
}
