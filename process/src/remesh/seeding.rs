//! Evenly spaced streamlines of both families over the surface (thesis §6: "we sample the line
//! constraints regularly and choose the selected points as seeds for the gradient streamlines … we
//! also place seed points on both sides of the streamline while it is traced according to a
//! user-defined distance"). This is Jobard and Lefer's seeding: every line offers seeds at `spacing`
//! on both sides, a seed closer than that to a line of its family is refused, and a line stops where it
//! comes within half the spacing of another. Distances are Euclidean between samples whose normals
//! are not opposed, so the two sides of a thin part do not stop each other's lines.

use super::streamline::{Stop, Trace, Walls, stop_after, trace_contour, trace_field};
use super::surface::{Surface, SurfacePoint};
use rig::math::{Point3, Real, Vector3};
use std::collections::{HashMap, VecDeque};

/// The two families of lines whose crossings make the quads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Family {
    /// Streamlines of the gradient ∇u.
    Gradient = 0,
    /// Streamlines of the co-gradient n × ∇u: the contours of u.
    Contour = 1,
}

impl Family {
    /// The other family.
    pub fn other(self) -> Family {
        match self {
            Family::Gradient => Family::Contour,
            Family::Contour => Family::Gradient,
        }
    }
}

/// A polyline on the surface.
#[derive(Debug, Clone)]
pub struct Line {
    /// Which family it belongs to (a constraint line: the family it is aligned with).
    pub family: Family,
    /// Its points; a closed line repeats its first point at the end.
    pub points: Vec<Point3>,
    /// The face of each segment. Segments of lines that run along mesh edges name one of the two faces.
    pub faces: Vec<u32>,
    /// Whether it is a closed loop.
    pub closed: bool,
    /// Whether it runs along mesh edges (a constraint line) rather than through faces.
    pub on_edges: bool,
    /// The mesh vertices its two ends lie on, if they do.
    pub end_vertices: [Option<u32>; 2],
}

/// Spacing of the lines.
#[derive(Debug, Clone, Copy)]
pub struct Spacing {
    /// Distance between neighbouring lines of one family: the quad size.
    pub spacing: Real,
    /// A line stops within this fraction of the spacing of another line of its family.
    pub stop_ratio: Real,
    /// A seed is refused within this fraction of the spacing of a line of its family.
    pub seed_ratio: Real,
}

impl Spacing {
    /// Jobard and Lefer's ratios for a given spacing.
    pub fn new(spacing: Real) -> Self {
        Spacing { spacing, stop_ratio: 0.5, seed_ratio: 0.9 }
    }
}

/// Points along the lines of one family, hashed into cubes of one spacing.
struct SampleGrid {
    cell: Real,
    cells: HashMap<[i32; 3], Vec<u32>>,
    samples: Vec<(Point3, Vector3)>,
}

impl SampleGrid {
    fn new(cell: Real) -> Self {
        SampleGrid { cell, cells: HashMap::new(), samples: Vec::new() }
    }

    fn key(&self, p: &Point3) -> [i32; 3] {
        [p.x, p.y, p.z].map(|c| (c / self.cell).floor() as i32)
    }

    fn insert(&mut self, p: Point3, n: Vector3) {
        let k = self.key(&p);
        self.cells.entry(k).or_default().push(self.samples.len() as u32);
        self.samples.push((p, n));
    }

    /// Whether a sample lies within `r` (≤ one cell) of `p` with a normal not opposed to `n`.
    fn near(&self, p: &Point3, n: &Vector3, r: Real) -> bool {
        let k = self.key(p);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(ids) = self.cells.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) {
                        for &i in ids {
                            let (q, m) = &self.samples[i as usize];
                            if (q - p).norm_squared() < r * r && m.dot(n) > 0.5 {
                                return true;
                            }
                        }
                    }
                }
            }
        }
        false
    }

    /// Adds samples every `step` along a line. A line along mesh edges (a crease) is sampled with
    /// the normals of the faces on both sides, so lines on either side keep their distance.
    fn insert_line(&mut self, s: &Surface, line: &Line, step: Real) {
        for (w, &f) in line.points.windows(2).zip(&line.faces) {
            let mut normals = vec![s.normal[f as usize]];
            if line.on_edges
                && let Some(g) = s.face_across_segment(f, &w[0], &w[1])
            {
                normals.push(s.normal[g as usize]);
            }
            let len = (w[1] - w[0]).norm();
            let pieces = (len / step).ceil().max(1.0) as usize;
            for i in 0..pieces {
                for n in &normals {
                    self.insert(w[0] + (w[1] - w[0]) * (i as Real / pieces as Real), *n);
                }
            }
        }
        if let (Some(p), Some(&f)) = (line.points.last(), line.faces.last()) {
            self.insert(*p, s.normal[f as usize]);
        }
    }
}

/// The field the lines follow: `u` per vertex and its gradient per face (eq. 6.1).
pub struct Field<'a> {
    /// The surface.
    pub surface: &'a Surface<'a>,
    /// The scalar field per vertex.
    pub u: &'a [Real],
    /// Its gradient per face.
    pub grad: &'a [Vector3],
    /// Mesh edges streamlines must not slide along (the constraint lines').
    pub walls: &'a Walls,
}

impl Field<'_> {
    fn trace(
        &self,
        family: Family,
        sign: Real,
        start: SurfacePoint,
        stop: impl FnMut(&Point3, &Point3, u32) -> Option<Real>,
    ) -> Trace {
        let steps = 4 * self.surface.mesh.faces.len() + 1000;
        match family {
            Family::Gradient => trace_field(self.surface, self.grad, sign, start, steps, self.walls, stop),
            Family::Contour => trace_contour(self.surface, self.u, self.grad, sign, start, steps, stop),
        }
    }
}

/// Every line of both families: the constraint lines first, then the traced ones.
pub fn place_lines(field: &Field, constraints: Vec<Line>, spacing: Spacing) -> Vec<Line> {
    let s = field.surface;
    let d = spacing.spacing;
    let mut grids = [SampleGrid::new(d), SampleGrid::new(d)];
    let mut lines = constraints;
    let mut queue: VecDeque<usize> = VecDeque::new();
    for (i, line) in lines.iter().enumerate() {
        grids[line.family as usize].insert_line(s, line, d / 4.0);
        queue.push_back(i);
    }
    // Seeds on the constraints for the lines that cross them.
    let mut crossing_seeds: Vec<(Family, SurfacePoint)> = Vec::new();
    for line in &lines {
        // Half a spacing in from the ends: a line's end is often a corner of the constraints, and a
        // streamline started on a mesh vertex would pass exactly through it.
        for (p, f) in samples_from(line, d / 2.0, d) {
            crossing_seeds.push((line.family.other(), s.locate_in(f, &p)));
        }
    }
    let try_seed = |lines: &mut Vec<Line>,
                    grids: &mut [SampleGrid; 2],
                    queue: &mut VecDeque<usize>,
                    family: Family,
                    seed: SurfacePoint| {
        let p = s.position(&seed);
        let n = s.normal[seed.face as usize];
        if grids[family as usize].near(&p, &n, spacing.seed_ratio * d) {
            return;
        }
        let line = trace_line(field, family, seed, &grids[family as usize], spacing);
        if line.points.len() < 2 {
            return;
        }
        grids[family as usize].insert_line(s, &line, d / 4.0);
        lines.push(line);
        queue.push_back(lines.len() - 1);
    };
    for (family, seed) in crossing_seeds {
        try_seed(&mut lines, &mut grids, &mut queue, family, seed);
    }
    if lines.is_empty() {
        let seed = middle_seed(field);
        try_seed(&mut lines, &mut grids, &mut queue, Family::Gradient, seed);
        try_seed(&mut lines, &mut grids, &mut queue, Family::Contour, seed);
    }
    let mut next_face = 0usize;
    loop {
        while let Some(i) = queue.pop_front() {
            let family = lines[i].family;
            let samples = samples_along(&lines[i], d / 2.0);
            for (p, f) in samples {
                let at = s.locate_in(f, &p);
                for sign in [1.0, -1.0] {
                    // A step of one spacing across the line, along the other family.
                    let walk = field.trace(family.other(), sign, at, stop_after(d));
                    if walk.stop == Stop::Asked {
                        try_seed(&mut lines, &mut grids, &mut queue, family, walk.end);
                    }
                }
            }
        }
        // Parts the propagation did not reach (other components, behind singularities): seed anew.
        let mut seeded = false;
        while next_face < s.mesh.faces.len() && !seeded {
            let f = next_face as u32;
            next_face += 1;
            if s.area2[f as usize] <= 0.0 || field.grad[f as usize].norm_squared() == 0.0 {
                continue;
            }
            let c = SurfacePoint { face: f, bary: [1.0 / 3.0; 3] };
            let (p, n) = (s.position(&c), s.normal[f as usize]);
            for family in [Family::Gradient, Family::Contour] {
                if !grids[family as usize].near(&p, &n, 1.5 * d) {
                    let before = lines.len();
                    try_seed(&mut lines, &mut grids, &mut queue, family, c);
                    seeded |= lines.len() > before;
                }
            }
        }
        if !seeded {
            break;
        }
    }
    lines
}

/// Points every `step` of arc length along a line, with the face each lies in.
fn samples_along(line: &Line, step: Real) -> Vec<(Point3, u32)> {
    samples_from(line, 0.0, step)
}

/// Points every `step` of arc length along a line from arc length `first` on.
fn samples_from(line: &Line, first: Real, step: Real) -> Vec<(Point3, u32)> {
    let mut out = Vec::new();
    let mut next = first;
    let mut run = 0.0;
    for (w, &f) in line.points.windows(2).zip(&line.faces) {
        let len = (w[1] - w[0]).norm();
        while next <= run + len {
            let t = if len > 0.0 { (next - run) / len } else { 0.0 };
            out.push((w[0] + (w[1] - w[0]) * t, f));
            next += step;
        }
        run += len;
    }
    out
}

/// A start for a mesh without constraints: the centre of the face whose value is the median.
fn middle_seed(field: &Field) -> SurfacePoint {
    let s = field.surface;
    let centre = |f: usize| s.mesh.faces[f].iter().map(|&v| field.u[v as usize]).sum::<Real>() / 3.0;
    let mut usable: Vec<usize> =
        (0..s.mesh.faces.len()).filter(|&f| s.area2[f] > 0.0 && field.grad[f].norm_squared() > 0.0).collect();
    usable.sort_by(|&a, &b| centre(a).total_cmp(&centre(b)));
    let f = usable.get(usable.len() / 2).copied().unwrap_or(0) as u32;
    SurfacePoint { face: f, bary: [1.0 / 3.0; 3] }
}

/// Traces one line of `family` both ways from `seed`, stopping near lines already in `grid`.
fn trace_line(field: &Field, family: Family, seed: SurfacePoint, grid: &SampleGrid, spacing: Spacing) -> Line {
    let s = field.surface;
    let d = spacing.spacing;
    let limit = spacing.stop_ratio * d;
    let step = d / 4.0;
    let stop = |a: &Point3, b: &Point3, f: u32| -> Option<Real> {
        let n = s.normal[f as usize];
        let len = (b - a).norm();
        let pieces = (len / step).ceil().max(1.0) as usize;
        (1..=pieces).map(|i| i as Real / pieces as Real).find(|&t| grid.near(&(a + (b - a) * t), &n, limit))
    };
    let forward = field.trace(family, 1.0, seed, stop);
    if forward.stop == Stop::Closed {
        return Line {
            family,
            points: forward.points,
            faces: forward.faces,
            closed: true,
            on_edges: false,
            end_vertices: [None, None],
        };
    }
    let backward = field.trace(family, -1.0, seed, stop);
    let mut points: Vec<Point3> = backward.points.iter().rev().copied().collect();
    let mut faces: Vec<u32> = backward.faces.iter().rev().copied().collect();
    points.extend_from_slice(&forward.points[1..]);
    faces.extend_from_slice(&forward.faces);
    Line {
        family,
        points,
        faces,
        closed: false,
        on_edges: false,
        end_vertices: [backward.end_vertex, forward.end_vertex],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::remesh::harmonic::face_gradients;

    #[test]
    fn a_linear_field_on_a_plate_gets_a_regular_grid_of_lines() {
        let m = fixtures::plate(30, 20, false);
        let s = Surface::new(&m);
        let u: Vec<Real> = m.vertices.iter().map(|p| p.x).collect();
        let g = face_gradients(&m, &u);
        let lines =
            place_lines(&Field { surface: &s, u: &u, grad: &g, walls: &Walls::new() }, Vec::new(), Spacing::new(2.0));
        // Gradient lines run along x, one every 2 units of y; contours along y, every 2 units of x.
        let count = |fam| lines.iter().filter(|l| l.family == fam && l.points.len() > 1).count();
        let (ng, nc) = (count(Family::Gradient), count(Family::Contour));
        assert!((9..=12).contains(&ng), "{ng} gradient lines");
        assert!((14..=17).contains(&nc), "{nc} contours");
        for l in lines.iter().filter(|l| l.family == Family::Gradient) {
            let y0 = l.points[0].y;
            assert!(l.points.iter().all(|p| (p.y - y0).abs() < 1e-6));
        }
    }
}
