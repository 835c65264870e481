//! A bounding volume hierarchy over a triangle mesh, for the simulator's camera, projector and shadow rays.
//!
//! Built once per mesh and then cast against hundreds of thousands of times per view from several
//! threads, so the layout is chosen for traversal, not for the build:
//!
//! * interior nodes are one flat `Vec` in depth-first order (an interior left child right after its
//!   parent), and each holds its two children's boxes side by side, so a visit is one 128-byte fetch that
//!   tests both children at once (the two lanes of a vector register) and descends into the nearer;
//! * each leaf's triangles are copied, as vertex positions, into one contiguous run in leaf order, so a
//!   leaf costs one sequential read rather than three scattered vertex look-ups per triangle;
//! * the tree is binned-SAH (16 bins on all three axes), split down to leaves of at most 4 triangles, its
//!   depth capped at 64 so no input, however degenerate, can make the build or the cast run away.
//!
//! Triangles are intersected with the watertight test of Woop, Benthin and Wald (JCGT 2013) in double
//! precision: a ray through a shared edge or vertex hits at least one of the triangles around it.
//! Pixel rays on a regular grid meet a mesh's edges exactly more often than chance suggests (planes and
//! boxes with vertices on round coordinates), and Möller–Trumbore lets such rays slip through, leaving
//! pinholes in rendered depth maps.

use std::fmt;

use rig::{Aabb, Point3, TriMesh, Vector3};

/// Most triangles in a leaf the build aims for; only a leaf forced by the depth cap or by triangles whose
/// centroids coincide holds more.
const MAX_LEAF: usize = 4;
/// Deepest a node may be: it bounds the build's and the traversal's work on pathological input.
const MAX_DEPTH: usize = 64;
/// Pending subtrees a cast keeps in a fixed array before spilling to the heap: more than balanced trees of
/// a few million triangles reach.
const INLINE_STACK: usize = 24;
/// SAH bins per axis.
const BINS: usize = 16;
/// Relative widening of a ray's interval through a box. The slab distances are rounded (a few ulps,
/// Pharr et al., PBRT 3e §3.9.2) and a ray grazing a box edge must not cull a triangle whose own test
/// accepts the ray; visiting a few more boxes costs nothing measurable.
const SLAB_SLACK: f64 = 1e-12;

/// A ray hit: distance along the (not necessarily unit) direction, the triangle, and barycentrics (u, v) with
/// the hit point = (1-u-v)·a + u·b + v·c.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit: the point is `origin + t·dir`, in units of `dir`'s length.
    pub t: f64,
    /// Index of the hit triangle in the mesh's `faces`.
    pub triangle: u32,
    /// Barycentric weight of the triangle's second corner.
    pub u: f64,
    /// Barycentric weight of the triangle's third corner.
    pub v: f64,
}

/// Built once per mesh, cast many times (shared across rayon threads: must be Send + Sync).
#[derive(Clone)]
pub struct Bvh {
    /// Interior nodes, depth-first.
    nodes: Vec<Node>,
    /// The whole tree: an interior node, a single leaf for a handful of triangles, or `None` for a mesh
    /// without (finite) triangles.
    root: Option<Child>,
    /// The root's box, which no node holds.
    bounds: Bounds,
    /// Corner positions of each triangle, in leaf order.
    tris: Vec<Tri>,
    /// The mesh face of each entry of `tris`.
    ids: Vec<u32>,
    /// Faces in the mesh, including those left out of the tree.
    faces: usize,
}

/// A triangle's corners as plain arrays: a leaf's triangles are then one contiguous run of `f64`.
type Tri = [[f64; 3]; 3];

/// An interior node: its two children's boxes, coordinate by coordinate with the children side by side
/// (`lo[axis] = [left, right]`), so one arithmetic sequence serves both. Two cache lines, fetched together.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Node {
    lo: [[f64; 2]; 3],
    hi: [[f64; 2]; 3],
    child: [Child; 2],
}

/// A subtree: an interior node (`count == 0`, `index` into `Bvh::nodes`) or a leaf (`count` triangles from
/// `index` in `Bvh::tris`; a leaf is never empty).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Child {
    index: u32,
    count: u32,
}

impl Bvh {
    /// Builds over the mesh's triangles (degenerate triangles are kept but never hit).
    ///
    /// Degenerate means zero area up to rounding: the sine of the angle between the two sides from the first
    /// corner is below 1e-12 (or a side has zero length). Such triangles still count in [`Bvh::len`] and
    /// [`Bvh::bounds`], but their normal is meaningless, so no ray reports them. Triangles with a non-finite
    /// corner have no box at all and are left out of the tree (they count in `len` only).
    ///
    /// # Panics
    ///
    /// If a face refers to a vertex index past `mesh.vertices`.
    pub fn new(mesh: &TriMesh) -> Bvh {
        let corners = |face: &[u32; 3]| face.map(|i| xyz(&mesh.vertices[i as usize]));
        let mut prims: Vec<Prim> = mesh
            .faces
            .iter()
            .enumerate()
            .filter_map(|(f, face)| {
                let [a, b, c] = corners(face);
                if !a.iter().chain(&b).chain(&c).all(|x| x.is_finite()) {
                    return None;
                }
                let lo = [0, 1, 2].map(|k| a[k].min(b[k]).min(c[k]));
                let hi = [0, 1, 2].map(|k| a[k].max(b[k]).max(c[k]));
                Some(Prim { lo, hi, face: f as u32 })
            })
            .collect();
        let (nodes, root, bounds) = flatten(&build(&mut prims));
        let tris = prims.iter().map(|p| stored_triangle(corners(&mesh.faces[p.face as usize]))).collect();
        let ids = prims.iter().map(|p| p.face).collect();
        Bvh { nodes, root, bounds, tris, ids, faces: mesh.faces.len() }
    }

    /// Nearest hit with t in (t_min, t_max), or None.
    ///
    /// `dir` need not be unit length: `t` is in units of it. A zero or non-finite direction, or a
    /// non-finite origin, hits nothing. Directions with zero components are fine.
    pub fn cast(&self, origin: &Point3, dir: &Vector3, t_min: f64, t_max: f64) -> Option<Hit> {
        let ray = Ray::new(origin, dir)?;
        match ray.kz {
            0 => self.traverse::<0, false>(&ray, t_min, t_max),
            1 => self.traverse::<1, false>(&ray, t_min, t_max),
            _ => self.traverse::<2, false>(&ray, t_min, t_max),
        }
    }

    /// True if anything is hit with t in (t_min, t_max) — any-hit early exit, for shadow rays.
    pub fn occluded(&self, origin: &Point3, dir: &Vector3, t_min: f64, t_max: f64) -> bool {
        let Some(ray) = Ray::new(origin, dir) else { return false };
        match ray.kz {
            0 => self.traverse::<0, true>(&ray, t_min, t_max),
            1 => self.traverse::<1, true>(&ray, t_min, t_max),
            _ => self.traverse::<2, true>(&ray, t_min, t_max),
        }
        .is_some()
    }

    /// The box of all triangles; for a mesh without triangles, the empty box `min = +∞, max = −∞`, which
    /// contains nothing and leaves any box it is merged with unchanged.
    pub fn bounds(&self) -> Aabb {
        Aabb { min: self.bounds.lo.into(), max: self.bounds.hi.into() }
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.faces
    }

    /// True for a mesh without triangles.
    pub fn is_empty(&self) -> bool {
        self.faces == 0
    }

    /// Nearest hit, or with `ANY` the first found. `KZ` is the ray's dominant axis: making it a constant
    /// turns the watertight test's axis permutation into fixed indices.
    fn traverse<const KZ: usize, const ANY: bool>(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let root = self.root?;
        if ray.enter(&self.bounds, t_min, t_max) == f64::INFINITY {
            return None;
        }
        let mut best: Option<Hit> = None;
        let mut t_best = t_max;
        // Pending subtrees: the first ones in an array, any beyond in a vector. A full MAX_DEPTH array costs
        // more to initialise on every ray (~15 % of a cast) than typical trees, some 20 deep, ever use, and
        // safe Rust cannot leave it uninitialised; the vector allocates only for unusually deep trees.
        let mut stack = [(root, 0.0f64); INLINE_STACK];
        let mut overflow = Vec::new();
        let mut depth = 0;
        let mut at = root;
        loop {
            if at.count == 0 {
                let n = &self.nodes[at.index as usize];
                let [t_left, t_right] = ray.enter_both(n, t_min, t_best);
                // Nearer first: the farther one is then usually out of reach by the time it is popped.
                let (near, t_near, far, t_far) = if t_left <= t_right {
                    (n.child[0], t_left, n.child[1], t_right)
                } else {
                    (n.child[1], t_right, n.child[0], t_left)
                };
                if t_near != f64::INFINITY {
                    if t_far != f64::INFINITY {
                        if depth < INLINE_STACK {
                            stack[depth] = (far, t_far);
                        } else {
                            overflow.push((far, t_far));
                        }
                        depth += 1;
                    }
                    at = near;
                    continue;
                }
            } else {
                let first = at.index as usize;
                let tris = &self.tris[first..first + at.count as usize];
                for (k, tri) in tris.iter().enumerate() {
                    if let Some((t, u, v)) = intersect::<KZ>(ray, tri, t_min, t_best) {
                        let hit = Hit { t, triangle: self.ids[first + k], u, v };
                        if ANY {
                            return Some(hit);
                        }
                        t_best = t;
                        best = Some(hit);
                    }
                }
            }
            // Pop the next pending subtree that a hit found since it was pushed has not put out of reach.
            loop {
                if depth == 0 {
                    return best;
                }
                depth -= 1;
                let (next, t_enter) = if depth < INLINE_STACK {
                    stack[depth]
                } else {
                    overflow.pop().expect("entries past the array are in the vector")
                };
                if within(t_enter, t_best) {
                    at = next;
                    break;
                }
            }
        }
    }
}

impl fmt::Debug for Bvh {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Bvh")
            .field("triangles", &self.faces)
            .field("nodes", &self.nodes.len())
            .field("bounds", &self.bounds())
            .finish_non_exhaustive()
    }
}

/// A ray prepared for traversal: what every box and triangle test would otherwise recompute.
struct Ray {
    o: [f64; 3],
    /// `1/dir`, ±∞ for zero components.
    inv: [f64; 3],
    /// Per axis, whether the direction is negative (−0 included, by way of 1/−0 = −∞): then a box's upper
    /// plane is the one the ray meets first.
    neg: [bool; 3],
    /// The axis along which the direction is largest, and (`sx`, `sy`, `sz`) the shear that maps the
    /// direction onto it.
    kz: usize,
    sx: f64,
    sy: f64,
    sz: f64,
}

impl Ray {
    fn new(origin: &Point3, dir: &Vector3) -> Option<Ray> {
        let (o, d) = (xyz(origin), [dir.x, dir.y, dir.z]);
        if !o.iter().chain(&d).all(|x| x.is_finite()) {
            return None;
        }
        let kz = if d[0].abs() >= d[1].abs() && d[0].abs() >= d[2].abs() {
            0
        } else if d[1].abs() >= d[2].abs() {
            1
        } else {
            2
        };
        if d[kz] == 0.0 {
            return None;
        }
        let inv = d.map(|x| 1.0 / x);
        let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
        Some(Ray { o, inv, neg: inv.map(|x| x < 0.0), kz, sx: d[kx] / d[kz], sy: d[ky] / d[kz], sz: 1.0 / d[kz] })
    }

    /// Where the ray enters the box within (t_min, t_max), or +∞ for a miss (+∞ doubles as the miss mark
    /// because the callers order boxes by entry).
    fn enter(&self, b: &Bounds, t_min: f64, t_max: f64) -> f64 {
        let n = Node { lo: b.lo.map(|x| [x; 2]), hi: b.hi.map(|x| [x; 2]), child: [Child { index: 0, count: 0 }; 2] };
        self.enter_both(&n, t_min, t_max)[0]
    }

    /// [`Ray::enter`] for both children of a node at once. Written lane by lane over `[f64; 2]` with
    /// comparisons that compile to `minpd`/`maxpd`, so the two boxes share one instruction sequence.
    #[inline(always)]
    fn enter_both(&self, n: &Node, t_min: f64, t_max: f64) -> [f64; 2] {
        let (mut t_in, mut t_out) = ([t_min; 2], [t_max; 2]);
        for k in 0..3 {
            // Choosing the near and far planes by the direction's sign, instead of sorting the two plane
            // distances, keeps 0·∞ (origin on a plane of a box the ray runs parallel to) a NaN in just one
            // of them, where the comparisons below, false for NaN, let it constrain nothing. Sorting
            // would turn the pair into (+∞, +∞) and lose a ray that runs along a box face.
            let (near, far) = if self.neg[k] { (&n.hi[k], &n.lo[k]) } else { (&n.lo[k], &n.hi[k]) };
            for c in 0..2 {
                let t0 = (near[c] - self.o[k]) * self.inv[k];
                let t1 = (far[c] - self.o[k]) * self.inv[k];
                t_in[c] = if t0 > t_in[c] { t0 } else { t_in[c] };
                t_out[c] = if t1 < t_out[c] { t1 } else { t_out[c] };
            }
        }
        [0, 1].map(|c| if within(t_in[c], t_out[c]) { t_in[c] } else { f64::INFINITY })
    }
}

/// `t <= limit` up to [`SLAB_SLACK`], false for NaN.
#[inline(always)]
fn within(t: f64, limit: f64) -> bool {
    t <= limit + limit.abs() * SLAB_SLACK
}

/// The watertight ray-triangle test: `(t, u, v)` for a hit with t in (t_min, t_max).
///
/// The corners are translated to the ray origin and sheared so the ray runs along +z; the three 2-D edge
/// functions then decide the hit. A shared edge's function is computed from the same two (identically
/// transformed) corners in both its triangles and comes out as exact negatives there, so no ray passes
/// between them; exactly zero counts as inside for both.
#[inline(always)]
fn intersect<const KZ: usize>(ray: &Ray, tri: &Tri, t_min: f64, t_max: f64) -> Option<(f64, f64, f64)> {
    let (kx, ky) = ((KZ + 1) % 3, (KZ + 2) % 3);
    let [a, b, c] = tri.map(|p| [p[0] - ray.o[0], p[1] - ray.o[1], p[2] - ray.o[2]]);
    let (ax, ay) = (a[kx] - ray.sx * a[KZ], a[ky] - ray.sy * a[KZ]);
    let (bx, by) = (b[kx] - ray.sx * b[KZ], b[ky] - ray.sy * b[KZ]);
    let (cx, cy) = (c[kx] - ray.sx * c[KZ], c[ky] - ray.sy * c[KZ]);
    let e_a = cx * by - cy * bx;
    let e_b = ax * cy - ay * cx;
    let e_c = bx * ay - by * ax;
    // No culling: a hit needs the three on one side, whichever it is.
    if (e_a < 0.0 || e_b < 0.0 || e_c < 0.0) && (e_a > 0.0 || e_b > 0.0 || e_c > 0.0) {
        return None;
    }
    let det = e_a + e_b + e_c;
    if det == 0.0 {
        return None;
    }
    let t = (e_a * a[KZ] + e_b * b[KZ] + e_c * c[KZ]) * ray.sz / det;
    // Written to be false for NaN.
    if !(t > t_min && t < t_max) {
        return None;
    }
    Some((t, e_b / det, e_c / det))
}

/// A triangle's corners as stored; a degenerate one collapsed onto its first corner, where all three edge
/// functions are exactly zero and the determinant test rejects every ray.
fn stored_triangle([a, b, c]: Tri) -> Tri {
    let e1 = Vector3::from(b) - Vector3::from(a);
    let e2 = Vector3::from(c) - Vector3::from(a);
    let parallel = e1.cross(&e2).norm() <= 1e-12 * e1.norm() * e2.norm();
    if parallel { [a, a, a] } else { [a, b, c] }
}

fn xyz(p: &Point3) -> [f64; 3] {
    [p.x, p.y, p.z]
}

/// A triangle during the build: its box, whose centre stands for it in the SAH, and its face.
#[derive(Clone, Copy)]
struct Prim {
    lo: [f64; 3],
    hi: [f64; 3],
    face: u32,
}

impl Prim {
    /// Twice the box centre's coordinate: the factor 2 is the same for all triangles, so it is never removed.
    fn centroid2(&self, k: usize) -> f64 {
        self.lo[k] + self.hi[k]
    }
}

/// A box that grows to contain what it meets; the initial inverted box is empty.
#[derive(Clone, Copy)]
struct Bounds {
    lo: [f64; 3],
    hi: [f64; 3],
}

impl Bounds {
    const EMPTY: Bounds = Bounds { lo: [f64::INFINITY; 3], hi: [f64::NEG_INFINITY; 3] };

    /// Only ever given finite boxes, so plain comparisons (one `minsd` each) do instead of `f64::min`'s NaN
    /// handling, in what is the build's innermost loop.
    fn grow(&mut self, lo: &[f64; 3], hi: &[f64; 3]) {
        for k in 0..3 {
            self.lo[k] = if lo[k] < self.lo[k] { lo[k] } else { self.lo[k] };
            self.hi[k] = if hi[k] > self.hi[k] { hi[k] } else { self.hi[k] };
        }
    }

    /// Half the surface area: the SAH only compares areas.
    fn half_area(&self) -> f64 {
        let d = [0, 1, 2].map(|k| (self.hi[k] - self.lo[k]).max(0.0));
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    }
}

/// A node of the tree as built, before [`flatten`] moves its box into its parent.
struct BuildNode {
    bounds: Bounds,
    /// Interior: the right child's index (the left child is next). Leaf: the first triangle.
    index: u32,
    /// Triangles in a leaf, 0 for an interior node.
    count: u32,
}

/// A range of `prims` still to be made into a subtree.
struct Task {
    start: usize,
    end: usize,
    depth: usize,
    /// The interior node whose right child this is, to be told its index; `None` for the root and left
    /// children, whose index is implied.
    parent: Option<usize>,
}

/// Builds the tree depth-first, reordering `prims` into leaf order.
///
/// Iterative, so the depth of the tree never becomes the depth of the call stack. Popping the left
/// child right after its parent is what places it right after its parent.
fn build(prims: &mut [Prim]) -> Vec<BuildNode> {
    let mut nodes = Vec::with_capacity(2 * prims.len().div_ceil(MAX_LEAF));
    if prims.is_empty() {
        return nodes;
    }
    let mut tasks = vec![Task { start: 0, end: prims.len(), depth: 0, parent: None }];
    while let Some(Task { start, end, depth, parent }) = tasks.pop() {
        let me = nodes.len();
        if let Some(p) = parent {
            nodes[p].index = me as u32;
        }
        let range = &mut prims[start..end];
        let (mut bounds, mut centroids) = (Bounds::EMPTY, Bounds::EMPTY);
        for p in range.iter() {
            bounds.grow(&p.lo, &p.hi);
            let c = [0, 1, 2].map(|k| p.centroid2(k));
            centroids.grow(&c, &c);
        }
        let split = if range.len() <= MAX_LEAF || depth + 1 >= MAX_DEPTH { None } else { split(range, &centroids) };
        let (index, count) = match split {
            Some(mid) => {
                tasks.push(Task { start: start + mid, end, depth: depth + 1, parent: Some(me) });
                tasks.push(Task { start, end: start + mid, depth: depth + 1, parent: None });
                (0, 0)
            }
            None => (start as u32, range.len() as u32),
        };
        nodes.push(BuildNode { bounds, index, count });
    }
    nodes
}

/// Moves each node's box into its parent and drops the leaves' nodes: the traversal layout. Interior nodes
/// keep their depth-first order.
fn flatten(built: &[BuildNode]) -> (Vec<Node>, Option<Child>, Bounds) {
    let Some(first) = built.first() else { return (Vec::new(), None, Bounds::EMPTY) };
    // Index among interior nodes of each built node (meaningful for interior ones only).
    let mut interior = Vec::with_capacity(built.len());
    let mut count = 0u32;
    for b in built {
        interior.push(count);
        count += u32::from(b.count == 0);
    }
    let child = |i: usize| {
        let b = &built[i];
        if b.count == 0 { Child { index: interior[i], count: 0 } } else { Child { index: b.index, count: b.count } }
    };
    let nodes = (0..built.len())
        .filter(|&i| built[i].count == 0)
        .map(|i| {
            let (left, right) = (i + 1, built[i].index as usize);
            let (l, r) = (&built[left].bounds, &built[right].bounds);
            Node {
                lo: [0, 1, 2].map(|k| [l.lo[k], r.lo[k]]),
                hi: [0, 1, 2].map(|k| [l.hi[k], r.hi[k]]),
                child: [child(left), child(right)],
            }
        })
        .collect();
    (nodes, Some(child(0)), first.bounds)
}

/// Partitions `prims` at the cheapest binned-SAH plane over all three axes and returns the size of the
/// left part, or `None` when the centroids all coincide and no plane separates anything.
fn split(prims: &mut [Prim], centroids: &Bounds) -> Option<usize> {
    // (cost, axis, last bin on the left)
    let mut best: Option<(f64, usize, usize)> = None;
    for axis in 0..3 {
        let extent = centroids.hi[axis] - centroids.lo[axis];
        // Coincident centroids, or (coordinates near f64::MAX) no usable extent.
        if extent.is_nan() || extent <= 0.0 {
            continue;
        }
        let scale = BINS as f64 / extent;
        let mut bins = [(Bounds::EMPTY, 0usize); BINS];
        for p in prims.iter() {
            let bin = &mut bins[bin_of(p, axis, centroids.lo[axis], scale)];
            bin.0.grow(&p.lo, &p.hi);
            bin.1 += 1;
        }
        // Right-hand costs first, so one left-to-right sweep can price every plane.
        let mut right_cost = [0.0; BINS];
        let (mut right, mut right_count) = (Bounds::EMPTY, 0);
        for i in (1..BINS).rev() {
            right.grow(&bins[i].0.lo, &bins[i].0.hi);
            right_count += bins[i].1;
            right_cost[i - 1] = if right_count == 0 { f64::NAN } else { right.half_area() * right_count as f64 };
        }
        let (mut left, mut left_count) = (Bounds::EMPTY, 0);
        for i in 0..BINS - 1 {
            left.grow(&bins[i].0.lo, &bins[i].0.hi);
            left_count += bins[i].1;
            let cost = left.half_area() * left_count as f64 + right_cost[i];
            // NaN (nothing on the right) and an empty left never win.
            if left_count > 0 && best.is_none_or(|(c, ..)| cost < c) {
                best = Some((cost, axis, i));
            }
        }
    }
    let (_, axis, last) = best?;
    let lo = centroids.lo[axis];
    let scale = BINS as f64 / (centroids.hi[axis] - lo);
    // In-place two-way partition; the same `bin_of` as the binning guarantees both sides are non-empty.
    let (mut i, mut j) = (0, prims.len());
    while i < j {
        if bin_of(&prims[i], axis, lo, scale) <= last {
            i += 1;
        } else {
            j -= 1;
            prims.swap(i, j);
        }
    }
    Some(i)
}

/// `scale` is `BINS / extent`; `as` saturates (NaN to 0), so rounding past either end, or an extent so
/// small that the scale is infinite, lands in the end bins.
fn bin_of(p: &Prim, axis: usize, lo: f64, scale: f64) -> usize {
    (((p.centroid2(axis) - lo) * scale) as usize).min(BINS - 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;
    use std::time::Instant;

    /// xorshift64*: deterministic, no dependency.
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
        }

        /// Uniform in [0, 1).
        fn unit(&mut self) -> f64 {
            (self.next() >> 11) as f64 / (1u64 << 53) as f64
        }

        fn range(&mut self, lo: f64, hi: f64) -> f64 {
            lo + (hi - lo) * self.unit()
        }

        fn point(&mut self, r: f64) -> Point3 {
            Point3::new(self.range(-r, r), self.range(-r, r), self.range(-r, r))
        }

        /// Uniform on the unit sphere.
        fn direction(&mut self) -> Vector3 {
            loop {
                let v = self.point(1.0).coords;
                let n = v.norm();
                if n > 0.1 && n <= 1.0 {
                    return v / n;
                }
            }
        }
    }

    fn random_soup(n: usize, rng: &mut Rng) -> TriMesh {
        let mut mesh = TriMesh::default();
        for f in 0..n {
            let centre = rng.point(1.0);
            let size = if f % 10 == 0 { 1.0 } else { 0.15 };
            let a = centre + rng.point(size).coords;
            let b = centre + rng.point(size).coords;
            // Some exactly degenerate triangles: a repeated corner, three collinear corners.
            let c = match f % 50 {
                0 => b,
                1 => a + (b - a) * 2.0,
                _ => centre + rng.point(size).coords,
            };
            let i = mesh.vertices.len() as u32;
            mesh.vertices.extend([a, b, c]);
            mesh.faces.push([i, i + 1, i + 2]);
        }
        mesh
    }

    /// Unit icosphere: an icosahedron with each triangle split in four `levels` times, vertices on the sphere,
    /// faces counter-clockwise from outside.
    fn icosphere(levels: usize) -> TriMesh {
        let g = (1.0 + 5f64.sqrt()) / 2.0;
        let mut vertices: Vec<Point3> = [
            (-1.0, g, 0.0),
            (1.0, g, 0.0),
            (-1.0, -g, 0.0),
            (1.0, -g, 0.0),
            (0.0, -1.0, g),
            (0.0, 1.0, g),
            (0.0, -1.0, -g),
            (0.0, 1.0, -g),
            (g, 0.0, -1.0),
            (g, 0.0, 1.0),
            (-g, 0.0, -1.0),
            (-g, 0.0, 1.0),
        ]
        .iter()
        .map(|&(x, y, z)| Point3::from(Vector3::new(x, y, z).normalize()))
        .collect();
        let mut faces: Vec<[u32; 3]> = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        for _ in 0..levels {
            let mut mid = HashMap::new();
            let mut midpoint = |i: u32, j: u32, vertices: &mut Vec<Point3>| {
                *mid.entry((i.min(j), i.max(j))).or_insert_with(|| {
                    let m = (vertices[i as usize].coords + vertices[j as usize].coords).normalize();
                    vertices.push(Point3::from(m));
                    vertices.len() as u32 - 1
                })
            };
            faces = faces
                .iter()
                .flat_map(|&[a, b, c]| {
                    let ab = midpoint(a, b, &mut vertices);
                    let bc = midpoint(b, c, &mut vertices);
                    let ca = midpoint(c, a, &mut vertices);
                    [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
                })
                .collect();
        }
        TriMesh { vertices, faces, normals: None }
    }

    /// Every triangle, nearest wins, first on ties; the same per-triangle test as the tree.
    fn brute_force(mesh: &TriMesh, origin: &Point3, dir: &Vector3, t_min: f64, t_max: f64) -> Option<Hit> {
        let ray = Ray::new(origin, dir)?;
        let test = match ray.kz {
            0 => intersect::<0>,
            1 => intersect::<1>,
            _ => intersect::<2>,
        };
        let mut best: Option<Hit> = None;
        for (f, face) in mesh.faces.iter().enumerate() {
            let tri = stored_triangle(face.map(|i| xyz(&mesh.vertices[i as usize])));
            if let Some((t, u, v)) = test(&ray, &tri, t_min, best.map_or(t_max, |h| h.t)) {
                best = Some(Hit { t, triangle: f as u32, u, v });
            }
        }
        best
    }

    /// Depth of the deepest leaf, the root at 0.
    fn max_depth(bvh: &Bvh) -> usize {
        let mut deepest = 0;
        let mut stack: Vec<(Child, usize)> = bvh.root.into_iter().map(|r| (r, 0)).collect();
        while let Some((at, depth)) = stack.pop() {
            deepest = deepest.max(depth);
            if at.count == 0 {
                stack.extend(bvh.nodes[at.index as usize].child.map(|c| (c, depth + 1)));
            }
        }
        deepest
    }

    /// Every box holds its subtree's triangles, interior nodes are depth-first with an interior left child
    /// right after its parent, and the leaves cover every triangle once.
    fn check_structure(bvh: &Bvh) {
        let mut covered = vec![false; bvh.tris.len()];
        let mut stack: Vec<(Child, Bounds)> = bvh.root.into_iter().map(|r| (r, bvh.bounds)).collect();
        let mut visited = Vec::new();
        while let Some((at, b)) = stack.pop() {
            let inside = |p: &[f64; 3]| (0..3).all(|k| b.lo[k] <= p[k] && p[k] <= b.hi[k]);
            if at.count == 0 {
                visited.push(at.index);
                let n = &bvh.nodes[at.index as usize];
                if n.child[0].count == 0 {
                    assert_eq!(n.child[0].index, at.index + 1);
                }
                for c in [1, 0] {
                    let child = Bounds { lo: [0, 1, 2].map(|k| n.lo[k][c]), hi: [0, 1, 2].map(|k| n.hi[k][c]) };
                    assert!(inside(&child.lo) && inside(&child.hi));
                    stack.push((n.child[c], child));
                }
            } else {
                let leaf = covered.iter_mut().zip(&bvh.tris).skip(at.index as usize).take(at.count as usize);
                for (seen, tri) in leaf {
                    assert!(!*seen);
                    *seen = true;
                    assert!(tri.iter().all(inside));
                }
            }
        }
        assert!(covered.iter().all(|&c| c));
        assert_eq!(visited, (0..bvh.nodes.len() as u32).collect::<Vec<_>>(), "not depth-first");
    }

    fn assert_agrees(mesh: &TriMesh, rays: usize, seed: u64) {
        let bvh = Bvh::new(mesh);
        check_structure(&bvh);
        let mut rng = Rng(seed);
        let mut hits = 0;
        for r in 0..rays {
            let origin = rng.point(2.0);
            // Not unit length, and now and then a bounded interval.
            let dir = rng.direction() * rng.range(0.1, 10.0);
            let (t_min, t_max) =
                if r % 4 == 0 { (rng.range(0.0, 0.2), rng.range(0.1, 0.5)) } else { (0.0, f64::INFINITY) };
            let got = bvh.cast(&origin, &dir, t_min, t_max);
            let want = brute_force(mesh, &origin, &dir, t_min, t_max);
            match (got, want) {
                (None, None) => {}
                (Some(g), Some(w)) => {
                    hits += 1;
                    if g.triangle == w.triangle {
                        assert_eq!(g, w, "ray {r}");
                    } else {
                        // Two triangles at the same distance (a shared edge or vertex): either is right.
                        assert!((g.t - w.t).abs() <= 1e-9, "ray {r}: {g:?} vs {w:?}");
                    }
                    let f = mesh.faces[g.triangle as usize];
                    let p = |i: usize| mesh.vertices[f[i] as usize].coords;
                    let on_triangle = p(0) * (1.0 - g.u - g.v) + p(1) * g.u + p(2) * g.v;
                    assert!((on_triangle - (origin.coords + dir * g.t)).norm() < 1e-9, "ray {r}");
                }
                _ => panic!("ray {r}: tree {got:?}, brute force {want:?}"),
            }
            assert_eq!(bvh.occluded(&origin, &dir, t_min, t_max), got.is_some(), "ray {r}");
        }
        assert!(hits > rays / 10, "only {hits} of {rays} rays hit: the test shows little");
    }

    #[test]
    fn matches_brute_force_on_a_random_soup() {
        let mesh = random_soup(2000, &mut Rng(7));
        assert_agrees(&mesh, 20_000, 11);
    }

    #[test]
    fn matches_brute_force_on_a_sphere() {
        let mut mesh = icosphere(4);
        for v in &mut mesh.vertices {
            *v = Point3::from(v.coords * 1.5);
        }
        assert_agrees(&mesh, 20_000, 13);
    }

    #[test]
    fn degenerate_triangles_are_never_hit() {
        let mesh = random_soup(2000, &mut Rng(7));
        let bvh = Bvh::new(&mesh);
        assert_eq!(bvh.len(), 2000);
        let mut rng = Rng(5);
        for _ in 0..20_000 {
            let (origin, dir) = (rng.point(2.0), rng.direction());
            if let Some(h) = bvh.cast(&origin, &dir, 0.0, f64::INFINITY) {
                assert!(h.triangle % 50 > 1, "hit degenerate triangle {}", h.triangle);
            }
        }
        // Aimed straight at a degenerate triangle's corner, the ray still reaches whatever is behind it.
        let f = mesh.faces[0];
        let target = mesh.vertices[f[0] as usize];
        let origin = Point3::new(5.0, 5.0, 5.0);
        if let Some(h) = bvh.cast(&origin, &(target - origin), 0.0, f64::INFINITY) {
            assert_ne!(h.triangle, 0);
        }
    }

    #[test]
    fn sphere_hits_lie_within_the_chord_of_the_analytic_sphere() {
        let mesh = icosphere(5);
        let bvh = Bvh::new(&mesh);
        // The polyhedron is inscribed: its surface lies between the unit sphere and the sphere through its
        // faces' nearest points, which is at least each face plane's distance from the centre.
        let inner = mesh
            .faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|i| mesh.vertices[i as usize].coords);
                (b - a).cross(&(c - a)).normalize().dot(&a).abs()
            })
            .fold(1.0, f64::min);
        assert!(inner > 0.999 && inner < 1.0, "inner radius {inner}");
        // Entry distance of a ray into the sphere of radius r about the origin.
        let enter = |o: &Point3, d: &Vector3, r: f64| {
            let (a, b, c) = (d.norm_squared(), o.coords.dot(d), o.coords.norm_squared() - r * r);
            (-b - (b * b - a * c).sqrt()) / a
        };
        let mut rng = Rng(17);
        for r in 0..20_000 {
            let origin = Point3::from(rng.direction() * rng.range(1.5, 4.0));
            // Aim inside radius 0.9 so no ray grazes, which would stretch the chord band without bound.
            let target = Point3::from(rng.direction() * rng.range(0.0, 0.9));
            let dir = (target - origin) * rng.range(0.5, 2.0);
            let hit = bvh.cast(&origin, &dir, 0.0, f64::INFINITY).unwrap_or_else(|| panic!("ray {r} missed"));
            let (outer_t, inner_t) = (enter(&origin, &dir, 1.0), enter(&origin, &dir, inner));
            assert!(
                hit.t >= outer_t - 1e-12 && hit.t <= inner_t + 1e-12,
                "ray {r}: {} not in [{outer_t}, {inner_t}]",
                hit.t
            );
            let radius = (origin + dir * hit.t).coords.norm();
            assert!(radius <= 1.0 + 1e-12 && radius >= inner - 1e-12);
            // The nearest hit enters through a face turned toward the ray.
            let [a, b, c] = mesh.faces[hit.triangle as usize].map(|i| mesh.vertices[i as usize].coords);
            assert!((b - a).cross(&(c - a)).dot(&dir) < 0.0, "ray {r} hit a back face");
        }
        // Along every axis, both ways, from outside: the icosphere reaches exactly 1 only at vertices.
        for k in 0..3 {
            for s in [-1.0, 1.0] {
                let mut dir = Vector3::zeros();
                dir[k] = s;
                let origin = Point3::from(dir * -3.0);
                let hit = bvh.cast(&origin, &dir, 0.0, f64::INFINITY).unwrap();
                assert!(hit.t >= 2.0 - 1e-12 && hit.t <= 3.0 - inner + 1e-12, "{k} {s}: {}", hit.t);
            }
        }
    }

    #[test]
    fn empty_mesh_hits_nothing() {
        let bvh = Bvh::new(&TriMesh::default());
        assert!(bvh.is_empty());
        assert_eq!(bvh.len(), 0);
        let (o, d) = (Point3::origin(), Vector3::new(1.0, 0.0, 0.0));
        assert_eq!(bvh.cast(&o, &d, 0.0, f64::INFINITY), None);
        assert!(!bvh.occluded(&o, &d, 0.0, f64::INFINITY));
        let b = bvh.bounds();
        assert!(b.min.x > b.max.x && b.min.y > b.max.y && b.min.z > b.max.z);
    }

    /// The unit cube [0, 1]³, 12 triangles.
    fn cube() -> TriMesh {
        let vertices = (0..8).map(|i| Point3::new((i & 1) as f64, (i >> 1 & 1) as f64, (i >> 2 & 1) as f64)).collect();
        let faces = vec![
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6],
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7],
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5],
        ];
        TriMesh { vertices, faces, normals: None }
    }

    #[test]
    fn axis_parallel_rays() {
        let bvh = Bvh::new(&cube());
        let b = bvh.bounds();
        assert_eq!((b.min, b.max), (Point3::origin(), Point3::new(1.0, 1.0, 1.0)));
        for k in 0..3 {
            for s in [-1.0, 1.0] {
                for zero in [0.0, -0.0] {
                    let mut dir = Vector3::from_element(zero);
                    dir[k] = s;
                    let (i, j) = ((k + 1) % 3, (k + 2) % 3);
                    // Through the interior of a face, along a face plane, along a cube edge: all enter at
                    // the face opposite the origin, at t = 1.
                    for (a, b) in [(0.5, 0.5), (0.0, 0.5), (1.0, 0.5), (0.5, 1.0), (0.0, 0.0), (1.0, 1.0), (0.25, 0.75)]
                    {
                        let mut origin = Point3::origin();
                        origin[k] = if s > 0.0 { -1.0 } else { 2.0 };
                        origin[i] = a;
                        origin[j] = b;
                        let hit = bvh.cast(&origin, &dir, 0.0, f64::INFINITY);
                        assert_eq!(hit.map(|h| h.t), Some(1.0), "axis {k} sign {s} at ({a}, {b})");
                        assert!(bvh.occluded(&origin, &dir, 0.0, f64::INFINITY));
                        assert!(!bvh.occluded(&origin, &dir, 0.0, 0.999));
                        // From inside, it leaves through the far face.
                        origin[k] = 0.5;
                        assert_eq!(bvh.cast(&origin, &dir, 0.0, f64::INFINITY).map(|h| h.t), Some(0.5));
                    }
                    // Parallel to the cube but beside it.
                    for (a, b) in [(1.5, 0.5), (-1e-9, 0.5), (0.5, 1.0 + 1e-9)] {
                        let mut origin = Point3::origin();
                        origin[k] = -s;
                        origin[i] = a;
                        origin[j] = b;
                        assert_eq!(bvh.cast(&origin, &dir, 0.0, f64::INFINITY), None);
                        assert!(!bvh.occluded(&origin, &dir, 0.0, f64::INFINITY));
                    }
                }
            }
        }
        // No direction, or not a number: nothing.
        let o = Point3::new(0.5, 0.5, -1.0);
        assert_eq!(bvh.cast(&o, &Vector3::zeros(), 0.0, f64::INFINITY), None);
        assert_eq!(bvh.cast(&o, &Vector3::new(0.0, f64::NAN, 1.0), 0.0, f64::INFINITY), None);
    }

    #[test]
    fn grid_rays_through_edges_and_vertices_never_slip_through() {
        // A 10 × 10 grid of unit squares at z = 0, each split along its diagonal: rays straight down
        // through every vertex, edge and diagonal must all hit (the watertight guarantee), at exactly t = 5.
        let mut mesh = TriMesh::default();
        for y in 0..=10 {
            for x in 0..=10 {
                mesh.vertices.push(Point3::new(x as f64, y as f64, 0.0));
            }
        }
        for y in 0..10u32 {
            for x in 0..10u32 {
                let i = y * 11 + x;
                mesh.faces.push([i, i + 1, i + 12]);
                mesh.faces.push([i, i + 12, i + 11]);
            }
        }
        let bvh = Bvh::new(&mesh);
        for y in 0..=40 {
            for x in 0..=40 {
                let target = Point3::new(x as f64 * 0.25, y as f64 * 0.25, 0.0);
                // Straight down, along the diagonals, across them, and slanted in x; all exact in binary, so
                // the rays meet the edges exactly.
                for d in [
                    Vector3::new(0.0, 0.0, -1.0),
                    Vector3::new(1.0, 1.0, -2.0),
                    Vector3::new(1.0, -1.0, -2.0),
                    Vector3::new(0.25, 0.0, -1.0),
                ] {
                    let from = target - d * 2.5;
                    let hit = bvh.cast(&from, &d, 0.0, f64::INFINITY);
                    assert_eq!(hit.map(|h| h.t), Some(2.5), "at {target} along {d}");
                }
            }
        }
        // Just past the grid's border, nothing.
        for d in [Vector3::new(0.0, 0.0, -1.0), Vector3::new(1.0, 1.0, -2.0)] {
            for target in [Point3::new(-1e-9, 5.0, 0.0), Point3::new(5.0, 10.0 + 1e-9, 0.0)] {
                assert_eq!(bvh.cast(&(target - d * 2.5), &d, 0.0, f64::INFINITY), None);
            }
        }
    }

    #[test]
    fn a_million_triangles_in_a_thin_strip_build_with_bounded_depth() {
        // Sliver triangles a micrometre wide along a 1 m line, with every tenth one a copy of the same
        // triangle (coincident centroids that no plane separates).
        let n = 1_000_000;
        let mut mesh = TriMesh::default();
        for i in 0..n {
            let x = if i % 10 == 0 { 0.5 } else { i as f64 * 1e-3 };
            let k = mesh.vertices.len() as u32;
            mesh.vertices.extend([
                Point3::new(x, 0.0, 0.0),
                Point3::new(x + 2e-3, 1e-6, 0.0),
                Point3::new(x, 0.0, 1e-9),
            ]);
            mesh.faces.push([k, k + 1, k + 2]);
        }
        let start = Instant::now();
        let bvh = Bvh::new(&mesh);
        eprintln!("thin strip: built {n} triangles in {:.0} ms, depth {}", ms(start), max_depth(&bvh));
        assert_eq!(bvh.len(), n);
        assert!(max_depth(&bvh) < MAX_DEPTH);
        check_structure(&bvh);
        let mut rng = Rng(3);
        for _ in 0..20 {
            let origin = Point3::new(rng.range(0.0, 1000.0), rng.range(-1e-6, 2e-6), 1.0);
            let dir = Vector3::new(rng.range(-1.0, 1.0), 0.0, -1.0);
            assert_eq!(
                bvh.cast(&origin, &dir, 0.0, f64::INFINITY),
                brute_force(&mesh, &origin, &dir, 0.0, f64::INFINITY)
            );
        }
    }

    #[test]
    fn depth_cap_holds_on_geometrically_spaced_triangles() {
        // Parallel unit triangles in the planes x = 1.5^k, three per plane. Binned SAH can only peel off the
        // few planes beyond 1/16 of the span per level, so uncapped the tree would be some 140 deep.
        let mut mesh = TriMesh::default();
        for i in 0..3000 {
            let x = 1.5f64.powi(i / 3 - 500);
            let k = mesh.vertices.len() as u32;
            mesh.vertices.extend([Point3::new(x, 0.0, 0.0), Point3::new(x, 1.0, 0.0), Point3::new(x, 0.0, 1.0)]);
            mesh.faces.push([k, k + 1, k + 2]);
        }
        let bvh = Bvh::new(&mesh);
        assert_eq!(max_depth(&bvh), MAX_DEPTH - 1, "the cap is what bounds this tree");
        check_structure(&bvh);
        // Along ±x only: at distances of 1e88, any slant would be lost to rounding in the triangle test. A ray
        // from the thin end passes every box and leaves some 60 subtrees pending, past the inline stack.
        let mut rng = Rng(9);
        for r in 0..2000 {
            let x = if r % 2 == 0 { rng.range(-1.0, 1.0) } else { 1.5f64.powi((rng.next() % 1000) as i32 - 500) };
            let origin = Point3::new(x, rng.range(-0.2, 0.8), rng.range(-0.2, 0.8));
            let dir = Vector3::new(if r % 4 < 2 { 1.0 } else { -1.0 }, 0.0, 0.0);
            let got = bvh.cast(&origin, &dir, 0.0, f64::INFINITY);
            let want = brute_force(&mesh, &origin, &dir, 0.0, f64::INFINITY);
            assert_eq!(got.map(|h| h.t), want.map(|h| h.t), "ray {r}");
            assert_eq!(bvh.occluded(&origin, &dir, 0.0, f64::INFINITY), want.is_some());
        }
    }

    #[test]
    fn is_send_and_sync() {
        fn shared<T: Send + Sync>() {}
        shared::<Bvh>();
    }

    fn ms(start: Instant) -> f64 {
        start.elapsed().as_secs_f64() * 1e3
    }

    #[test]
    fn timing() {
        // Icosphere level 6: 81,920 triangles, about the simulator's 100K.
        let mesh = icosphere(6);
        let start = Instant::now();
        let bvh = Bvh::new(&mesh);
        let build = ms(start);
        // Fewer rays in unoptimised builds, which only need to see it run.
        let n = if cfg!(debug_assertions) { 100_000 } else { 1_000_000 };
        let mut rng = Rng(23);
        let rays: Vec<(Point3, Vector3)> = (0..n)
            .map(|_| {
                let origin = Point3::from(rng.direction() * 3.0);
                (origin, Point3::from(rng.direction() * rng.range(0.0, 1.2)) - origin)
            })
            .collect();
        let start = Instant::now();
        let hits = rays.iter().filter(|(o, d)| bvh.cast(o, d, 0.0, f64::INFINITY).is_some()).count();
        let cast = ms(start);
        let start = Instant::now();
        let occluded = rays.iter().filter(|(o, d)| bvh.occluded(o, d, 0.0, f64::INFINITY)).count();
        let any = ms(start);
        assert_eq!(hits, occluded);
        // The simulator's case: one view's pixel rays in row order, neighbours hitting neighbouring triangles.
        let (width, height) = (1000, 600);
        let eye = Point3::new(0.2, -0.1, 3.0);
        let start = Instant::now();
        let mut view_hits = 0;
        for row in 0..height {
            for col in 0..width {
                let dir = Vector3::new((col as f64 - 500.0) / 1000.0, (row as f64 - 300.0) / 1000.0, -1.0);
                view_hits += usize::from(bvh.cast(&eye, &dir, 0.0, f64::INFINITY).is_some());
            }
        }
        let view = ms(start);
        eprintln!(
            "timing: one {width}×{height} view ({view_hits} hits) in {view:.1} ms, {:.2} Mrays/s (one thread)",
            (width * height) as f64 / view / 1e3
        );
        eprintln!(
            "timing: build {} triangles {build:.1} ms ({} nodes, depth {}); {n} random rays ({hits} hits): \
             cast {:.2} Mrays/s, occluded {:.2} Mrays/s (one thread)",
            mesh.faces.len(),
            bvh.nodes.len(),
            max_depth(&bvh),
            n as f64 / cast / 1e3,
            n as f64 / any / 1e3,
        );
    }
}
