//! Points apart from the object: a few stray points far from the rest (a reflection, a speck on
//! the background, a second object's corner) widen the cloud's bounding box, and every
//! reconstruction sizes its grid to that box. Twenty points 3 m from a sphere 80 mm wide made its
//! AdFFT mesh out of 714 vertices (cells of 6.5 mm on samples 0.6 mm apart), closed and written
//! with exit 0: nothing else in the support check notices, because every vertex still lies on the
//! samples.
//!
//! So do whole pieces far apart: two objects, or two passes of one object never aligned. Two bunny
//! scans a metre apart made a mesh of 6,270 vertices (cells of 5 mm; 148,168 vertices for one
//! alone), with exit 0. The object is therefore the widest piece with those near it, and the rest,
//! few points or a second object, is what lies apart from it.

use super::mesh_stage::three_digits;
use rig::math::{Point3, Real};
use serde::{Deserialize, Serialize};

/// Cells per side of the bounding box when grouping the points: fine enough that a cluster a
/// sixty-fourth of the box away is apart, coarse enough that a scan's samples (far closer than
/// that) join into one piece.
pub const APART_CELLS: Real = 64.0;

/// A piece holding less than this share of the points may be apart from the object; larger ones are
/// the object (or one of its parts).
pub const MAX_APART_SHARE: Real = 0.01;

/// How many times wider than the object's own box the cloud's box may be before the points apart
/// are refused: at 3 the grid's cells are three times coarser than the object alone would get.
pub const MAX_WIDENING: Real = 3.0;

/// The points of a cloud apart from the object, and how much they widen its box.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Apart {
    /// How many points lie outside the object (the widest of the pieces holding at least
    /// [`MAX_APART_SHARE`] of the cloud, with those near it: [`apart`]).
    pub points: usize,
    /// Their share of the cloud.
    pub share: Real,
    /// The cloud's box's widest side over the widest side of the object's box.
    pub widening: Real,
    /// The farthest of them from the object's box (the cloud's units).
    pub farthest: Real,
    /// How many of the pieces apart hold [`MAX_APART_SHARE`] or more of the cloud each (another
    /// object, a pass not aligned); 0 when only a few stray points are apart.
    #[serde(default)]
    pub pieces: usize,
}

impl Apart {
    /// What a refusal says of them: `whose` names the points ("the cloud's points"), `coarser` what
    /// the widened box makes coarser.
    pub fn describe(&self, whose: &str, coarser: &str) -> String {
        let pieces = match self.pieces {
            0 => String::new(),
            n => {
                format!(
                    "{whose} lie in parts far apart (the widest and {n} more, each holding {} % of them or more): ",
                    100.0 * MAX_APART_SHARE
                )
            }
        };
        format!(
            "{pieces}{} of {whose} ({:.2} %) lie apart from the {}, up to {} from it (in its units), and widen its \
             box {}-fold: {coarser}",
            self.points,
            100.0 * self.share,
            if self.pieces > 0 { "widest part" } else { "rest" },
            three_digits(self.farthest),
            three_digits(self.widening.round())
        )
    }

    /// What to do about them, for a refusal: crop a few strays; reconstruct (or remesh) each of
    /// several pieces alone, or align them.
    pub fn hint(&self) -> &'static str {
        match self.pieces {
            0 => {
                "crop them off (`scanrig fuse` drops them where they are few and scattered); if they are a part of \
                 the object, --force keeps them"
            }
            _ => {
                "two objects, or passes of one object not aligned (`scanrig align`)? Give each part alone; --force \
                 keeps them together"
            }
        }
    }
}

/// The points of `positions` apart from the object: the occupied cells of a grid of [`APART_CELLS`]
/// per side of the cloud's box, joined into pieces across faces, edges and corners; the object is
/// the widest of the pieces holding at least [`MAX_APART_SHARE`] of the points with every such
/// piece within its size of it, and the rest is apart. `None` when nothing is apart, or when every
/// piece is small (a sparse cloud, which this grid cannot tell from strays).
pub fn apart(positions: &[Point3]) -> Option<Apart> {
    let bounds = rig::Aabb::of(positions)?;
    let widest = |min: &Point3, max: &Point3| (max - min).max();
    let side = widest(&bounds.min, &bounds.max);
    if !(side > 0.0 && side.is_finite()) {
        return None;
    }
    let (n, cell) = (APART_CELLS as usize, side / APART_CELLS);
    let index = |p: &Point3| {
        let k = |x: Real, lo: Real| (((x - lo) / cell) as usize).min(n - 1);
        (k(p.x, bounds.min.x) * n + k(p.y, bounds.min.y)) * n + k(p.z, bounds.min.z)
    };
    let mut counts = vec![0usize; n * n * n];
    for p in positions {
        counts[index(p)] += 1;
    }
    // Pieces: occupied cells joined across their 26 neighbours, each cell labelled once.
    let mut piece = vec![usize::MAX; counts.len()];
    let mut sizes: Vec<usize> = Vec::new();
    for start in 0..counts.len() {
        if counts[start] == 0 || piece[start] != usize::MAX {
            continue;
        }
        let label = sizes.len();
        let (mut size, mut stack) = (0, vec![start]);
        piece[start] = label;
        while let Some(c) = stack.pop() {
            size += counts[c];
            let (x, y, z) = (c / (n * n), c / n % n, c % n);
            for nx in x.saturating_sub(1)..=(x + 1).min(n - 1) {
                for ny in y.saturating_sub(1)..=(y + 1).min(n - 1) {
                    for nz in z.saturating_sub(1)..=(z + 1).min(n - 1) {
                        let m = (nx * n + ny) * n + nz;
                        if counts[m] > 0 && piece[m] == usize::MAX {
                            piece[m] = label;
                            stack.push(m);
                        }
                    }
                }
            }
        }
        sizes.push(size);
    }
    let small = |label: usize| (sizes[label] as Real) < MAX_APART_SHARE * positions.len() as Real;
    let mut boxes = vec![(Point3::from([Real::INFINITY; 3]), Point3::from([Real::NEG_INFINITY; 3])); sizes.len()];
    for p in positions {
        let b = &mut boxes[piece[index(p)]];
        *b = (b.0.inf(p), b.1.sup(p));
    }
    // The object: the widest of the pieces holding MAX_APART_SHARE or more, joined by each such
    // piece within its own size of it (a laser scan's lines, a part across a gap), until none is; a
    // second object, or a pass never aligned, lies farther.
    let big: Vec<usize> = (0..sizes.len()).filter(|&l| !small(l)).collect();
    let widest_of = |l: &usize| widest(&boxes[*l].0, &boxes[*l].1);
    let first = *big.iter().max_by(|a, b| widest_of(a).total_cmp(&widest_of(b)))?;
    let mut in_object = vec![false; sizes.len()];
    in_object[first] = true;
    let (mut lo, mut hi) = boxes[first];
    while let Some(&l) = big.iter().find(|&&l| !in_object[l] && gap(&boxes[l], &(lo, hi)) <= widest(&lo, &hi)) {
        in_object[l] = true;
        (lo, hi) = (lo.inf(&boxes[l].0), hi.sup(&boxes[l].1));
    }
    let points = positions.iter().filter(|p| !in_object[piece[index(p)]]).count();
    if points == 0 {
        return None;
    }
    let pieces = big.iter().filter(|&&l| !in_object[l]).count();
    let farthest = positions
        .iter()
        .filter(|p| !in_object[piece[index(p)]])
        .map(|p| {
            // Scaled by its largest coordinate first: far-off coordinates (1e300) square to infinity.
            let d = p.coords - p.coords.sup(&lo.coords).inf(&hi.coords);
            let m = d.amax();
            if m > 0.0 { m * (d / m).norm() } else { 0.0 }
        })
        .fold(0.0, Real::max);
    // An object of no extent (all its points at one place) is widened without bound: the largest
    // figure there is, not infinity (which JSON cannot hold).
    let body = widest(&lo, &hi);
    let widening = if body > 0.0 { (side / body).min(Real::MAX) } else { Real::MAX };
    Some(Apart { points, share: points as Real / positions.len() as Real, widening, farthest, pieces })
}

/// The distance between two boxes (0 where they overlap).
fn gap(a: &(Point3, Point3), b: &(Point3, Point3)) -> Real {
    (0..3).map(|d| (a.0[d] - b.1[d]).max(b.0[d] - a.1[d]).max(0.0).powi(2)).sum::<Real>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sphere of `n` points of radius `r` about `c`, spread evenly (a Fibonacci lattice).
    fn sphere(n: usize, r: Real, c: Point3) -> Vec<Point3> {
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        (0..n)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as Real + 0.5) / n as Real;
                let (s, t) = ((1.0 - z * z).sqrt(), golden * i as Real);
                c + r * rig::math::Vector3::new(s * t.cos(), s * t.sin(), z)
            })
            .collect()
    }

    #[test]
    fn a_few_points_far_from_the_object_are_found_and_an_object_s_parts_are_not() {
        let body = sphere(20_000, 40.0, Point3::origin());
        assert_eq!(apart(&body), None, "one sphere: nothing apart");
        // Twenty points 3 m away: 0.1 % of the cloud, its box 38 times the sphere's.
        let mut stray = body.clone();
        stray.extend(sphere(20, 3.0, Point3::new(3000.0, 0.0, 0.0)));
        let a = apart(&stray).expect("the stray cluster");
        assert_eq!(a.points, 20);
        assert!((a.widening - 3043.0 / 80.0).abs() < 0.1, "{a:?}");
        assert!((a.farthest - (3003.0 - 40.0)).abs() < 0.5, "{a:?}");
        // Two objects of the same size far apart: the grid sized to both is 63 times coarser than
        // either's alone, and the second is apart, as a piece.
        let mut two = body.clone();
        two.extend(sphere(20_000, 40.0, Point3::new(5000.0, 0.0, 0.0)));
        let a = apart(&two).expect("the second sphere");
        assert_eq!((a.points, a.pieces), (20_000, 1), "{a:?}");
        assert!((a.widening - 5080.0 / 80.0).abs() < 0.1 && (a.farthest - 5000.0).abs() < 0.5, "{a:?}");
        let said = a.describe("the cloud's points", "coarser");
        assert!(said.starts_with("the cloud's points lie in parts far apart (the widest and 1 more"), "{said}");
        // Side by side, under a sphere's width apart (a turntable's two small objects; a laser scan's
        // lines), they are one object.
        let mut near = body.clone();
        near.extend(sphere(20_000, 40.0, Point3::new(150.0, 0.0, 0.0)));
        assert_eq!(apart(&near), None);
        // A thin part joined to the body (a wire three times the sphere's width) is the object's.
        let mut wire = body.clone();
        wire.extend((0..150).map(|i| Point3::new(40.0 + 1.5 * i as Real, 0.0, 0.0)));
        assert_eq!(apart(&wire), None);
        // A sparse cloud falls into small pieces only: nothing said.
        assert_eq!(apart(&sphere(500, 40.0, Point3::origin())), None);
        // Every object point at one place: widened without bound, not divided by zero.
        let mut one = vec![Point3::new(1.0, 2.0, 3.0); 500];
        one.push(Point3::new(900.0, 2.0, 3.0));
        let a = apart(&one).unwrap();
        assert!(a.points == 1 && a.widening == Real::MAX, "{a:?}");
        assert_eq!(apart(&[]), None);
        // A stray point at 1e300: its distance is said, not infinity.
        let mut far = body.clone();
        far.push(Point3::new(1e300, 1e300, 0.0));
        let a = apart(&far).unwrap();
        assert!(a.points == 1 && a.farthest.is_finite() && a.farthest > 1e300, "{a:?}");
        let said = a.describe("the cloud's points", "coarser");
        assert!(said.starts_with("1 of the cloud's points (0.00 %)") && said.contains("up to 1.41e300"), "{said}");
    }
}
