//! Streamlines on a triangle mesh, traced edge to edge (thesis §6, "streamline tracing"): a
//! piecewise-linear curve whose vertices lie on mesh edges and which follows, inside each face, that
//! face's constant vector. Two tracers:
//!
//! - [`trace_field`] follows a per-face vector field (the gradient of eq. 6.1). Where the vectors on
//!   both sides of an edge point into it (a discrete ridge), the line slides along the edge to the
//!   vertex the shared tangential part points at and leaves it into the face whose vector points out of
//!   that corner; a vertex no face leaves (a sink, such as a prescribed extremum) ends the line there.
//! - [`trace_contour`] follows the co-gradient `n × ∇u` of a piecewise-linear field `u`. Its
//!   streamlines are exactly the level sets of `u`, so it walks the level set face to face, computing
//!   each edge crossing from the edge's two vertex values in a fixed order so both faces agree on it
//!   bit for bit, and it recognises a closed loop when it comes back to its first face.
//!
//! Both ask a `stop` callback after every segment whether the line should end part-way along it
//! (another line is too close, or a length is reached).

use super::surface::{Surface, SurfacePoint};
use rig::math::{Point3, Real, Vector3};

/// Why a trace ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stop {
    /// The `stop` callback asked for it.
    Asked,
    /// It reached a mesh boundary.
    Boundary,
    /// It reached a point the field does not leave: a sink vertex or a face with no vector.
    Sink,
    /// A contour came back to where it started.
    Closed,
    /// The step limit: a safety net against numerical cycles.
    Steps,
}

/// A traced line: its points, the face each segment lies in, and how it ended.
#[derive(Debug, Clone)]
pub struct Trace {
    /// Points; the first is the start.
    pub points: Vec<Point3>,
    /// The face of segment `i` (from `points[i]` to `points[i + 1]`).
    pub faces: Vec<u32>,
    /// Where the line ended on the surface.
    pub end: SurfacePoint,
    /// The mesh vertex the line ended on, if it ended on one.
    pub end_vertex: Option<u32>,
    /// Why it ended.
    pub stop: Stop,
}

impl Trace {
    fn new(s: &Surface, start: SurfacePoint) -> Self {
        Trace { points: vec![s.position(&start)], faces: Vec::new(), end: start, end_vertex: None, stop: Stop::Steps }
    }

    /// Appends the segment to `q` in face `f` unless `stop` cuts it; returns whether the line goes on.
    fn push(
        &mut self,
        s: &Surface,
        from: &SurfacePoint,
        q: SurfacePoint,
        stop: &mut impl FnMut(&Point3, &Point3, u32) -> Option<Real>,
    ) -> bool {
        let a = *self.points.last().expect("a trace has a start");
        let b = s.position(&q);
        if let Some(alpha) = stop(&a, &b, q.face) {
            let alpha = alpha.clamp(0.0, 1.0);
            let bary: [Real; 3] = std::array::from_fn(|i| from.bary[i] + alpha * (q.bary[i] - from.bary[i]));
            self.end = SurfacePoint { face: q.face, bary };
            self.points.push(a + (b - a) * alpha);
            self.faces.push(q.face);
            self.stop = Stop::Asked;
            return false;
        }
        self.points.push(b);
        self.faces.push(q.face);
        self.end = q;
        true
    }

    /// Total length.
    pub fn length(&self) -> Real {
        self.points.windows(2).map(|w| (w[1] - w[0]).norm()).sum()
    }
}

/// Moves a point a hair inside its face so that a start on an edge or a vertex has a definite face.
fn nudge(p: SurfacePoint) -> SurfacePoint {
    let b = p.bary.map(|x| x.max(1e-9));
    let sum: Real = b.iter().sum();
    SurfacePoint { face: p.face, bary: b.map(|x| x / sum) }
}

/// Mesh edges `(a, b)`, `a < b`, that a line must not slide along: constraint lines, which are
/// lines of their own.
pub type Walls = std::collections::HashSet<(u32, u32)>;

/// Follows `sign · field[f]` from `start` (see the module notes); `max_steps` bounds the faces crossed.
/// Where it would slide along an edge in `walls`, it ends instead.
pub fn trace_field(
    s: &Surface,
    field: &[Vector3],
    sign: Real,
    start: SurfacePoint,
    max_steps: usize,
    walls: &Walls,
    mut stop: impl FnMut(&Point3, &Point3, u32) -> Option<Real>,
) -> Trace {
    let wall = |a: u32, b: u32| walls.contains(&(a.min(b), a.max(b)));
    let mut p = nudge(start);
    let mut trace = Trace::new(s, p);
    let dir = |f: u32| field[f as usize] * sign;
    for _ in 0..max_steps {
        let f = p.face;
        let vel = s.velocity(f, &dir(f));
        let scale = vel.iter().fold(0.0, |m: Real, v| m.max(v.abs()));
        if scale.is_nan() || scale <= 0.0 {
            trace.stop = Stop::Sink;
            return trace;
        }
        let tiny = 1e-9 * scale;
        // The coordinate that reaches 0 first names the exit edge.
        let mut exit: Option<(usize, Real)> = None;
        for (i, &v) in vel.iter().enumerate() {
            if v < -tiny {
                let t = p.bary[i] / -v;
                if exit.is_none_or(|(_, best)| t < best) {
                    exit = Some((i, t));
                }
            }
        }
        let Some((k, t)) = exit else {
            trace.stop = Stop::Sink;
            return trace;
        };
        let mut q: [Real; 3] = std::array::from_fn(|i| (p.bary[i] + t * vel[i]).max(0.0));
        q[k] = 0.0;
        let sum: Real = q.iter().sum();
        let q = SurfacePoint { face: f, bary: q.map(|x| x / sum) };
        if !trace.push(s, &p, q, &mut stop) {
            return trace;
        }
        let Some(next) = s.hand_over(&q, k) else {
            trace.stop = Stop::Boundary;
            return trace;
        };
        let (_, l) = s.across(f, k).expect("hand_over found it");
        let vg = s.velocity(next.face, &dir(next.face));
        let g_scale = vg.iter().fold(0.0, |m: Real, v| m.max(v.abs()));
        if vg[l] > 1e-9 * g_scale {
            p = next;
            continue;
        }
        // Both sides point into the edge: slide along it to the vertex its tangent points at —
        // unless the field hardly runs along the edge (a contour valley: the line has arrived).
        let face = s.mesh.faces[f as usize];
        let (ca, cb) = ((k + 1) % 3, (k + 2) % 3);
        let along = s.mesh.vertices[face[ca] as usize] - s.mesh.vertices[face[cb] as usize];
        let tangential = dir(f).dot(&along) / along.norm();
        if tangential.abs() < 0.2 * dir(f).norm() || wall(face[ca], face[cb]) {
            trace.stop = Stop::Sink;
            return trace;
        }
        let target = if tangential >= 0.0 { ca } else { cb };
        let mut at = [0.0; 3];
        at[target] = 1.0;
        let corner = SurfacePoint { face: f, bary: at };
        if !trace.push(s, &q, corner, &mut stop) {
            return trace;
        }
        let mut v = face[target];
        let mut at_vertex = corner;
        loop {
            match leave_vertex(s, field, sign, v, walls) {
                Leave::Face(next) => {
                    p = next;
                    break;
                }
                Leave::Edge(h, w) => {
                    // Down a valley edge to its other end, and try again from there.
                    let hf = s.mesh.faces[h as usize];
                    let from = SurfacePoint { face: h, bary: hf.map(|x| if x == v { 1.0 } else { 0.0 }) };
                    let to = SurfacePoint { face: h, bary: hf.map(|x| if x == w { 1.0 } else { 0.0 }) };
                    if trace.points.len() > max_steps || !trace.push(s, &from, to, &mut stop) {
                        return trace;
                    }
                    v = w;
                    at_vertex = to;
                }
                Leave::Stuck => {
                    trace.end = at_vertex;
                    trace.end_vertex = Some(v);
                    trace.stop = Stop::Sink;
                    return trace;
                }
            }
        }
    }
    trace
}

/// How a line leaves a vertex.
enum Leave {
    /// Into a face, from its corner at the vertex.
    Face(SurfacePoint),
    /// Along a mesh edge (of the given face) to the given vertex: the field runs along the edge.
    Edge(u32, u32),
    /// Not at all: the vertex is a sink of the field.
    Stuck,
}

/// How the line leaves vertex `v`: into the face whose vector points out of its corner at `v` (most
/// squarely, if several do); failing that, along the edge from `v` that the vectors of the faces
/// beside it follow most closely (within 25°); failing that, not at all.
fn leave_vertex(s: &Surface, field: &[Vector3], sign: Real, v: u32, walls: &Walls) -> Leave {
    let mut best: Option<(Real, SurfacePoint)> = None;
    let mut best_edge: Option<(Real, u32, u32)> = None;
    let pv = s.mesh.vertices[v as usize];
    for &(h, m) in s.corners_of(v) {
        let m = m as usize;
        let d = field[h as usize] * sign;
        let vel = s.velocity(h, &d);
        let scale = vel.iter().fold(0.0, |a: Real, x| a.max(x.abs()));
        if scale.is_nan() || scale <= 0.0 {
            continue;
        }
        let face = s.mesh.faces[h as usize];
        for c in [(m + 1) % 3, (m + 2) % 3] {
            let e = s.mesh.vertices[face[c] as usize] - pv;
            let cos = e.dot(&d) / (e.norm() * d.norm());
            let w = face[c];
            if cos > 0.9 && !walls.contains(&(v.min(w), v.max(w))) && best_edge.is_none_or(|(b, _, _)| cos > b) {
                best_edge = Some((cos, h, face[c]));
            }
        }
        if vel[m] >= -1e-9 * scale {
            continue;
        }
        let inside = vel[(m + 1) % 3].min(vel[(m + 2) % 3]) / scale;
        if inside < -1e-9 {
            continue;
        }
        if best.is_none_or(|(b, _)| inside > b) {
            let mut bary = [0.0; 3];
            bary[m] = 1.0;
            best = Some((inside, SurfacePoint { face: h, bary }));
        }
    }
    match (best, best_edge) {
        (Some((_, p)), _) => Leave::Face(p),
        (None, Some((_, h, w))) => Leave::Edge(h, w),
        (None, None) => Leave::Stuck,
    }
}

/// Where the level set `u = c` crosses edge `k` of face `f`, computed from the edge's two vertex
/// values in ascending vertex order so that both faces of the edge get the same point.
fn level_crossing(s: &Surface, u: &[Real], f: u32, k: usize, c: Real) -> SurfacePoint {
    let face = s.mesh.faces[f as usize];
    let (ca, cb) = ((k + 1) % 3, (k + 2) % 3);
    let (lo, hi) = if face[ca] < face[cb] { (ca, cb) } else { (cb, ca) };
    let (ul, uh) = (u[face[lo] as usize], u[face[hi] as usize]);
    let t = if uh != ul { ((c - ul) / (uh - ul)).clamp(0.0, 1.0) } else { 0.5 };
    let mut bary = [0.0; 3];
    bary[lo] = 1.0 - t;
    bary[hi] = t;
    SurfacePoint { face: f, bary }
}

/// The edges of face `f` the level set `u = c` crosses (a vertex exactly at `c` counts as above).
fn crossed_edges(s: &Surface, u: &[Real], f: u32, c: Real) -> Vec<usize> {
    let face = s.mesh.faces[f as usize];
    let above = face.map(|v| u[v as usize] >= c);
    (0..3).filter(|&k| above[(k + 1) % 3] != above[(k + 2) % 3]).collect()
}

/// Follows the level set of `u` through `start` in the direction `sign · n × ∇u` (`grad` is ∇u per
/// face, eq. 6.1), until it closes, hits a boundary or `stop` asks.
pub fn trace_contour(
    s: &Surface,
    u: &[Real],
    grad: &[Vector3],
    sign: Real,
    start: SurfacePoint,
    max_steps: usize,
    mut stop: impl FnMut(&Point3, &Point3, u32) -> Option<Real>,
) -> Trace {
    let p0 = nudge(start);
    let mut trace = Trace::new(s, p0);
    let face = s.mesh.faces[p0.face as usize];
    let c: Real = (0..3).map(|i| p0.bary[i] * u[face[i] as usize]).sum();
    let edges = crossed_edges(s, u, p0.face, c);
    if edges.len() != 2 {
        trace.stop = Stop::Sink;
        return trace;
    }
    let forward = s.normal[p0.face as usize].cross(&grad[p0.face as usize]) * sign;
    let (q1, q2) = (level_crossing(s, u, p0.face, edges[0], c), level_crossing(s, u, p0.face, edges[1], c));
    let (mut k, q) =
        if (s.position(&q2) - s.position(&q1)).dot(&forward) > 0.0 { (edges[1], q2) } else { (edges[0], q1) };
    if !trace.push(s, &p0, q, &mut stop) {
        return trace;
    }
    let mut at = q;
    for _ in 0..max_steps {
        let Some((g, l)) = s.across(at.face, k) else {
            trace.stop = Stop::Boundary;
            return trace;
        };
        let entry = level_crossing(s, u, g, l, c);
        if g == p0.face {
            trace.push(s, &entry, p0, &mut stop);
            trace.stop = Stop::Closed;
            return trace;
        }
        let edges = crossed_edges(s, u, g, c);
        let Some(&m) = edges.iter().find(|&&m| m != l) else {
            trace.stop = Stop::Sink;
            return trace;
        };
        if edges.len() != 2 {
            trace.stop = Stop::Sink;
            return trace;
        }
        let q = level_crossing(s, u, g, m, c);
        if !trace.push(s, &entry, q, &mut stop) {
            return trace;
        }
        at = q;
        k = m;
    }
    trace
}

/// A stop callback that ends a line once it has run `length`.
pub fn stop_after(length: Real) -> impl FnMut(&Point3, &Point3, u32) -> Option<Real> {
    let mut run = 0.0;
    move |a, b, _| {
        let step = (b - a).norm();
        if run + step >= length {
            Some(if step > 0.0 { (length - run) / step } else { 0.0 })
        } else {
            run += step;
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::remesh::harmonic::face_gradients;
    use rig::TriMesh;

    fn plate(w: usize, h: usize) -> TriMesh {
        fixtures::plate(w, h, true)
    }

    #[test]
    fn a_gradient_line_runs_straight_up_a_linear_field() {
        let m = plate(10, 10);
        let s = Surface::new(&m);
        let u: Vec<Real> = m.vertices.iter().map(|p| 0.3 * p.y + 0.1 * p.x).collect();
        let g = face_gradients(&m, &u);
        let start = s.locate_in(0, &Point3::new(0.7, 0.2, 0.0));
        let t = trace_field(&s, &g, 1.0, start, 1000, &Walls::new(), |_, _, _| None);
        assert_eq!(t.stop, Stop::Boundary);
        // The line keeps the gradient's direction (1, 3)/√10 throughout.
        let d = Vector3::new(0.1, 0.3, 0.0).normalize();
        for p in &t.points {
            let off = (p - t.points[0]) - d * (p - t.points[0]).dot(&d);
            assert!(off.norm() < 1e-9, "{p:?} is off the line");
        }
        assert!((t.points.last().unwrap().y - 10.0).abs() < 1e-9);
    }

    #[test]
    fn a_contour_around_a_bump_closes_on_itself() {
        // A radial field on a plate: its level sets are (polygonal) circles.
        let m = plate(20, 20);
        let s = Surface::new(&m);
        let u: Vec<Real> = m.vertices.iter().map(|p| ((p.x - 10.0).powi(2) + (p.y - 10.0).powi(2)).sqrt()).collect();
        let g = face_gradients(&m, &u);
        let f = (0..m.faces.len() as u32)
            .find(|&f| {
                (s.position(&SurfacePoint { face: f, bary: [1.0 / 3.0; 3] }) - Point3::new(15.5, 10.2, 0.0)).norm()
                    < 0.6
            })
            .unwrap();
        let start = s.locate_in(f, &Point3::new(15.5, 10.2, 0.0));
        let t = trace_contour(&s, &u, &g, 1.0, start, 10_000, |_, _, _| None);
        assert_eq!(t.stop, Stop::Closed);
        assert!((t.points[0] - t.points.last().unwrap()).norm() < 1e-12);
        let r0 = (t.points[0] - Point3::new(10.0, 10.0, 0.0)).norm();
        assert!((t.length() - std::f64::consts::TAU * r0).abs() < 0.05 * t.length(), "{} vs {r0}", t.length());
        // Counter-clockwise about +z for sign +1: the signed area is positive.
        let area: Real = t.points.windows(2).map(|w| w[0].x * w[1].y - w[1].x * w[0].y).sum();
        assert!(area > 0.0);
    }

    #[test]
    fn a_gradient_line_ends_on_a_sink_vertex() {
        // u = distance to the centre vertex, followed downhill: every line ends on it.
        let m = plate(10, 10);
        let s = Surface::new(&m);
        let centre = Point3::new(5.0, 5.0, 0.0);
        let u: Vec<Real> = m.vertices.iter().map(|p| (p - centre).norm()).collect();
        let g = face_gradients(&m, &u);
        let v = m.vertices.iter().position(|p| *p == centre).unwrap() as u32;
        for f in [0u32, 37, 120, 199] {
            let start = SurfacePoint { face: f, bary: [0.2, 0.3, 0.5] };
            let t = trace_field(&s, &g, -1.0, start, 1000, &Walls::new(), |_, _, _| None);
            assert_eq!(t.end_vertex, Some(v), "from face {f}: {:?}", t.stop);
        }
    }

    #[test]
    fn stop_after_cuts_at_the_length() {
        let m = plate(10, 2);
        let s = Surface::new(&m);
        let u: Vec<Real> = m.vertices.iter().map(|p| p.x).collect();
        let g = face_gradients(&m, &u);
        let start = s.locate_in(0, &Point3::new(0.5, 0.5, 0.0));
        let t = trace_field(&s, &g, 1.0, start, 1000, &Walls::new(), stop_after(3.25));
        assert_eq!(t.stop, Stop::Asked);
        assert!((t.length() - 3.25).abs() < 1e-9);
        assert!((s.position(&t.end) - Point3::new(3.75, 0.5, 0.0)).norm() < 1e-6);
    }
}
