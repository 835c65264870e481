//! Closing a turntable scan's openings before reconstruction.
//!
//! A scan leaves its object open where no sensor looked: the base standing on the platter (cropped
//! away with the platter), and for a laser rig the top, which lasers below it never light. Given an
//! open tube, the indicator function of ch. 5 has no inside to speak of there and the surface closes
//! wherever the solve puts it: the global FFT's periodic grid closed the README laser example 5 mm
//! above its rim, a bulge that printed scans and mesh-to-truth figures both pay for.
//!
//! The closing here is the usual choice of scanner software, made explicit and reported: each opening
//! gets a flat cap of oriented samples — the base on the platter plane (object z = 0, where the object
//! stands), the top at the data's highest level. An opening is found, not assumed: the data's
//! footprint in a thin slab at that level (a ring where a wall ends, a disc where the top was seen) is
//! rasterised, its gaps between laser lines bridged by the smallest dilation that encloses an area,
//! and only the enclosed cells no sample covers are capped. A top that was seen gets no cap; two legs
//! standing apart get one cap each, never a web between them.

use crate::kd_tree::PointTree;
use rig::PointCloud;
use rig::math::{Point3, Real, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// What to close and how finely.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CloseParams {
    /// Cap the base where it is open: on the platter (z = 0) when the data reaches down to it.
    pub bottom: bool,
    /// Cap the top where it is open, at the data's highest level.
    pub top: bool,
    /// Cap sample spacing, as a fraction of the cloud's bounding-box diagonal (400ths: finer than
    /// the default 256³ reconstruction's cells).
    pub spacing: Real,
    /// Thickness of the slab whose footprint outlines an opening, in cap spacings.
    pub slab_cells: Real,
    /// The widest gap in an outline that is bridged, in cap spacings (laser lines stand apart by
    /// 360° / views around the object).
    pub max_gap_cells: usize,
}

impl Default for CloseParams {
    fn default() -> Self {
        CloseParams { bottom: true, top: true, spacing: 1.0 / 400.0, slab_cells: 4.0, max_gap_cells: 10 }
    }
}

/// One cap.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Cap {
    /// Height of the cap (object frame, the cloud's units).
    pub z: Real,
    /// Samples added.
    pub points: usize,
    /// Area capped (the cloud's units squared).
    pub area: Real,
    /// The widest gap of the outline bridged to enclose it (the cloud's units).
    pub bridged: Real,
}

/// What closing did.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CloseReport {
    /// The cap sample spacing used.
    pub spacing: Real,
    /// The base's cap, if it was open.
    pub bottom: Option<Cap>,
    /// The top's cap, if it was open.
    pub top: Option<Cap>,
}

impl CloseReport {
    /// Samples added in all.
    pub fn points(&self) -> usize {
        self.bottom.map_or(0, |c| c.points) + self.top.map_or(0, |c| c.points)
    }
}

/// The slab is thickened at most this many times (to 32 times its first thickness).
const SLAB_DOUBLINGS: u32 = 6;

/// An enclosure smaller than this share of the footprint's bounding box is a pocket between nearby
/// samples, not an opening.
const MIN_ENCLOSED_SHARE: Real = 0.05;

/// Rasters larger than this many cells are not attempted (a cloud far wider than tall).
const MAX_CELLS: usize = 16_000_000;

/// Returns `cloud` (object frame, z up, platter at z = 0) with flat caps over its open base and top
/// (see the module doc); added samples carry normal ±z, the median confidence and view id `u32::MAX`.
pub fn close_openings(cloud: &PointCloud, params: &CloseParams) -> (PointCloud, CloseReport) {
    let mut out = cloud.clone();
    let Some(bounds) = cloud.bounding_box() else { return (out, CloseReport::default()) };
    let c = params.spacing * (bounds.max - bounds.min).norm();
    let mut report = CloseReport { spacing: c, ..Default::default() };
    if c.is_nan() || c <= 0.0 || cloud.len() < 16 {
        return (out, report);
    }
    // The tree (built on one core) and the heights' sort side by side.
    let (tree, z) = rayon::join(
        || PointTree::new(&cloud.positions),
        || {
            use rayon::prelude::*;
            let mut z: Vec<Real> = cloud.positions.par_iter().map(|p| p.z).collect();
            z.par_sort_unstable_by(|a, b| a.total_cmp(b));
            z
        },
    );
    let slab = params.slab_cells * c;
    // The extreme levels, robust to a few strays fusion left.
    let at = |q: Real| z[((z.len() - 1) as Real * q).round() as usize];
    let (z_low, z_high) = (at(0.0005), at(0.9995));
    // The slab outlining an opening starts thin and thickens until its footprint encloses one: a
    // real rim is ragged (the top's lines end at different heights, the base is hidden behind
    // flutes in some views), so its highest few tenths of a millimetre rarely go all the way round.
    let thickness = |k: u32| slab * (1u32 << k) as Real;
    let height = z_high - z_low;
    if params.bottom {
        // Standing on the platter: the data starts just above it (the crop), the cap lies on it.
        let level = if z_low <= slab { 0.0 } else { z_low };
        report.bottom = (0..SLAB_DOUBLINGS).take_while(|&k| thickness(k) < 0.5 * height).find_map(|k| {
            let slab_points = cloud.positions.iter().filter(|p| p.z <= z_low + thickness(k));
            cap(&mut out, &tree, slab_points, thickness(k), level, -1.0, c, params.max_gap_cells)
        });
    }
    if params.top {
        report.top = (0..SLAB_DOUBLINGS).take_while(|&k| thickness(k) < 0.5 * height).find_map(|k| {
            let slab_points = cloud.positions.iter().filter(|p| p.z >= z_high - thickness(k));
            cap(&mut out, &tree, slab_points, thickness(k), z_high, 1.0, c, params.max_gap_cells)
        });
    }
    (out, report)
}

/// Caps the enclosed, uncovered part of the footprint of `slab` (the points of a slab `thickness`
/// thick) at height `level`, normals `side`·z, on a raster of cell `c`.
#[allow(clippy::too_many_arguments)]
fn cap<'a>(
    out: &mut PointCloud,
    tree: &PointTree,
    slab: impl Iterator<Item = &'a Point3>,
    thickness: Real,
    level: Real,
    side: Real,
    c: Real,
    max_gap: usize,
) -> Option<Cap> {
    let slab: Vec<[Real; 2]> = slab.map(|p| [p.x, p.y]).collect();
    if slab.len() < 8 {
        return None;
    }
    let pad = (max_gap + 2) as Real * c;
    let lo = [0, 1].map(|k| slab.iter().map(|p| p[k]).fold(Real::INFINITY, Real::min) - pad);
    let hi = [0, 1].map(|k| slab.iter().map(|p| p[k]).fold(Real::NEG_INFINITY, Real::max) + pad);
    let (nx, ny) = (((hi[0] - lo[0]) / c).ceil() as usize + 1, ((hi[1] - lo[1]) / c).ceil() as usize + 1);
    if nx.saturating_mul(ny) > MAX_CELLS {
        return None;
    }
    let raster = Raster { nx, ny };
    let mut occupied = vec![false; nx * ny];
    for p in &slab {
        let (i, j) = (((p[0] - lo[0]) / c).round() as usize, ((p[1] - lo[1]) / c).round() as usize);
        occupied[j.min(ny - 1) * nx + i.min(nx - 1)] = true;
    }
    // Chessboard distance of every cell to the footprint: dilating by d keeps the cells within d.
    let to_footprint = raster.distance_from(&occupied, usize::MAX);
    // The smallest bridge that encloses the most: spurious pockets between nearby samples enclose a
    // cell or two before the outline closes; once it closes, more dilation only eats the inside.
    let (mut best, mut best_d) = (Vec::new(), 0);
    for d in 1..=max_gap {
        let dilated: Vec<bool> = to_footprint.iter().map(|&t| t <= d).collect();
        let inside = raster.enclosed(&dilated);
        if inside.len() > best.len() {
            (best, best_d) = (inside, d);
        }
    }
    if (best.len() as Real)
        < MIN_ENCLOSED_SHARE
            * (nx.saturating_sub(2 * (max_gap + 2)).max(1) * ny.saturating_sub(2 * (max_gap + 2)).max(1)) as Real
    {
        return None;
    }
    // Back out to the outline: the closing (dilation, then erosion by as much) of the filled
    // footprint — the cells farther than the bridge from everything outside it.
    let dilated: Vec<bool> = to_footprint.iter().map(|&t| t <= best_d).collect();
    let mut outside: Vec<bool> = dilated.iter().map(|&d| !d).collect();
    best.iter().for_each(|&k| outside[k] = false);
    let to_outside = raster.distance_from(&outside, best_d + 1);
    let confidence = out.confidence.as_ref().map(|conf| {
        let mut c = conf.clone();
        let mid = c.len() / 2;
        *c.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1
    });
    let first = out.len();
    let mut points = 0;
    let capped: Vec<usize> = (0..nx * ny).filter(|&k| to_outside[k] > best_d).collect();
    let area = capped.len() as Real * c * c;
    // Cap samples stand for as much surface each as the rim's samples do — the slab's wall (its
    // outline, at least the perimeter of a disc of the cap's area, times its thickness) over its
    // samples — so they weigh in the reconstruction (whose level is the area-weighted mean of χ over the
    // samples, the areas capped at a few times their median: a cap far denser than the wall would set
    // that median and cap the wall's areas)
    // as measured surface of their size would. Laser lines are dense along and sparse across: a
    // cap as dense as one line's samples would outweigh the whole wall.
    let wall = 2.0 * (std::f64::consts::PI * area).sqrt() * thickness;
    let stride = (((wall / slab.len() as Real).sqrt() / c).round() as usize).max(1);
    for k in capped {
        if (k % nx) % stride != 0 || (k / nx) % stride != 0 {
            continue;
        }
        let p = Point3::new(lo[0] + (k % nx) as Real * c, lo[1] + (k / nx) as Real * c, level);
        // Where a sample lies near, the surface is measured there (the rim, a seen part): no cap.
        let (near, d2) = tree.nearest(&p);
        if d2 <= (1.5 * c * stride as Real).powi(2) {
            continue;
        }
        out.positions.push(p);
        if let Some(n) = out.normals.as_mut() {
            n.push(Vector3::new(0.0, 0.0, side));
        }
        if let Some(colours) = out.colors.as_mut() {
            let nearest = colours[near];
            colours.push(nearest);
        }
        if let (Some(conf), Some(m)) = (out.confidence.as_mut(), confidence) {
            conf.push(m);
        }
        if let Some(v) = out.view_id.as_mut() {
            v.push(u32::MAX);
        }
        points += 1;
    }
    debug_assert_eq!(out.len(), first + points);
    (points > 0).then_some(Cap { z: level, points, area, bridged: 2.0 * best_d as Real * c })
}

/// A row-major raster of `nx × ny` cells.
struct Raster {
    nx: usize,
    ny: usize,
}

impl Raster {
    fn neighbours(&self, k: usize, diagonal: bool) -> impl Iterator<Item = usize> + '_ {
        let (i, j) = ((k % self.nx) as isize, (k / self.nx) as isize);
        let steps: &[(isize, isize)] = if diagonal {
            &[(-1, -1), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)]
        } else {
            &[(0, -1), (-1, 0), (1, 0), (0, 1)]
        };
        steps.iter().filter_map(move |&(di, dj)| {
            let (a, b) = (i + di, j + dj);
            (a >= 0 && b >= 0 && (a as usize) < self.nx && (b as usize) < self.ny)
                .then(|| b as usize * self.nx + a as usize)
        })
    }

    /// Chessboard distance (in cells) of each cell to the nearest `seed` cell, up to `limit`
    /// (`usize::MAX` beyond it).
    fn distance_from(&self, seed: &[bool], limit: usize) -> Vec<usize> {
        let mut dist = vec![usize::MAX; seed.len()];
        let mut queue: VecDeque<usize> = (0..seed.len()).filter(|&k| seed[k]).collect();
        queue.iter().for_each(|&k| dist[k] = 0);
        while let Some(k) = queue.pop_front() {
            if dist[k] >= limit {
                continue;
            }
            for n in self.neighbours(k, true).collect::<Vec<_>>() {
                if dist[n] == usize::MAX {
                    dist[n] = dist[k] + 1;
                    queue.push_back(n);
                }
            }
        }
        dist
    }

    /// The cells outside `wall` that cannot be reached from the raster's border without crossing it.
    fn enclosed(&self, wall: &[bool]) -> Vec<usize> {
        let mut outside = vec![false; wall.len()];
        let border = (0..wall.len()).filter(|&k| {
            let (i, j) = (k % self.nx, k / self.nx);
            i == 0 || j == 0 || i + 1 == self.nx || j + 1 == self.ny
        });
        let mut queue: VecDeque<usize> = border.filter(|&k| !wall[k]).collect();
        queue.iter().for_each(|&k| outside[k] = true);
        while let Some(k) = queue.pop_front() {
            for n in self.neighbours(k, false).collect::<Vec<_>>() {
                if !wall[n] && !outside[n] {
                    outside[n] = true;
                    queue.push_back(n);
                }
            }
        }
        (0..wall.len()).filter(|&k| !wall[k] && !outside[k]).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    /// An open cylinder wall, sampled as a laser scan samples it: `lines` meridians, dense along each.
    fn tube(radius: Real, height: Real, lines: usize, top: bool) -> PointCloud {
        let mut cloud = PointCloud::default();
        let mut normals = Vec::new();
        for l in 0..lines {
            let a = TAU * l as Real / lines as Real;
            for k in 0..=200 {
                let z = 1.0 + (height - 1.0) * k as Real / 200.0;
                cloud.positions.push(Point3::new(radius * a.cos(), radius * a.sin(), z));
                normals.push(Vector3::new(a.cos(), a.sin(), 0.0));
            }
        }
        if top {
            // A seen top: a disc of samples at the rim's height.
            for i in -40i32..=40 {
                for j in -40i32..=40 {
                    let (x, y) = (i as Real * radius / 40.0, j as Real * radius / 40.0);
                    if x * x + y * y < radius * radius {
                        cloud.positions.push(Point3::new(x, y, height));
                        normals.push(Vector3::z());
                    }
                }
            }
        }
        cloud.normals = Some(normals);
        cloud
    }

    #[test]
    fn an_open_tube_gets_a_cap_on_the_platter_and_one_at_its_rim() {
        let cloud = tube(30.0, 80.0, 36, false);
        let (closed, r) = close_openings(&cloud, &CloseParams::default());
        let (bottom, top) = (r.bottom.expect("base capped"), r.top.expect("top capped"));
        assert_eq!(bottom.z, 0.0, "the base lies on the platter");
        assert!((top.z - 80.0).abs() < 0.5, "top cap at {}", top.z);
        // The caps cover the disc (less the rim band the wall's samples cover).
        let disc = std::f64::consts::PI * 30.0 * 30.0;
        for cap in [bottom, top] {
            assert!(cap.area > 0.8 * disc && cap.area < 1.05 * disc, "cap area {} of {disc}", cap.area);
        }
        let added = &closed.positions[cloud.len()..];
        let widest = added.iter().map(|p| p.x.hypot(p.y)).fold(0.0, Real::max);
        assert!(widest < 30.0 + 2.0 * r.spacing, "a cap sample {widest} from the axis, outside the 30 mm rim");
        let normals = &closed.normals.as_ref().unwrap()[cloud.len()..];
        assert!(added.iter().zip(normals).all(|(p, n)| n.z == if p.z > 40.0 { 1.0 } else { -1.0 }));
    }

    #[test]
    fn a_seen_top_is_left_alone_and_separate_legs_are_not_webbed() {
        let (_, r) = close_openings(&tube(30.0, 80.0, 36, true), &CloseParams::default());
        assert!(r.top.is_none(), "the seen top was capped: {:?}", r.top);
        assert!(r.bottom.is_some());
        // Two tubes 40 mm apart: two caps at the base, none between them.
        let mut two = tube(10.0, 60.0, 24, false);
        let other = tube(10.0, 60.0, 24, false);
        two.positions.extend(other.positions.iter().map(|p| Point3::new(p.x + 40.0, p.y, p.z)));
        two.normals.as_mut().unwrap().extend(other.normals.unwrap());
        let (closed, r) = close_openings(&two, &CloseParams::default());
        assert!(r.bottom.is_some());
        let between = closed.positions[two.len()..].iter().filter(|p| p.x > 12.0 && p.x < 28.0).count();
        assert_eq!(between, 0, "cap samples between the legs");
    }
}
