//! The whole quad remesh (thesis §6, fig. 6.4): constraint lines (given, or feature lines), the
//! half-split where a line turns inside a triangle (fig. 6.5), a harmonic or quasi-harmonic field
//! between two far-apart poles that follows the lines (eqs. 6.2–6.4), evenly spaced streamlines of its
//! gradient and co-gradient, and the quads their crossings bound, with a quality report.
//!
//! A constraint line can only be followed by one family of streamlines: those nearly across the
//! unconstrained field's gradient become contours (eq. 6.3, `⟨∇u, t⟩ = 0`), the others gradient lines
//! (`⟨∇u, n × t⟩ = 0` in the faces beside them). Both kinds are rows of the same least-squares system.

use super::edge_faces::EdgeFaces;
use super::features::{chain, feature_edges};
use super::half_split::split_doubly_constrained;
use super::harmonic::{FieldError, LaplaceSystem, face_gradients};
use super::polygon_split::{SplitStats, split_polygons};
use super::quad_graph::{GraphStats, quads_from_lines};
use super::quality::{Quality, measure};
use super::seeding::{Family, Field, Line, Spacing, place_lines};
use super::singularities::vertex_indices;
use super::streamline::Walls;
use super::surface::Surface;
use rig::math::{Point3, Real};
use rig::remesh_inputs::ConstraintLine;
use rig::union_find::UnionFind;
use rig::{PolyMesh, TriMesh};
use serde::Serialize;
use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashSet};
use std::time::Instant;

/// The default streamline spacing as a fraction of the bounding-box diagonal: about 10 000 quads on
/// a compact shape, fine enough to stay within 0.5 % of the input on a machined part like fandisk.
pub const DEFAULT_SPACING: Real = 0.01;

/// How many times finer than the default (1 % of the diagonal) a remeshing spacing may be: quads grow
/// with the square, so 10× finer is already 100× the default remesh's faces.
pub const MAX_SPACING_RATIO: Real = 10.0;

/// Settings of [`remesh`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RemeshParams {
    /// Distance between neighbouring streamlines (the quad size); `None`: [`DEFAULT_SPACING`] of the
    /// bounding-box diagonal.
    pub spacing: Option<Real>,
    /// Edges folding by more than this many degrees become feature lines; `None`: no feature lines.
    pub feature_angle: Option<Real>,
    /// Weight of the constraint rows against the Laplace rows.
    pub weight: Real,
    /// Per-face conductivity (eq. 6.4); `None`: 1 everywhere (harmonic, eq. 6.2).
    pub conductivity: Option<Vec<Real>>,
    /// Constraint lines as vertex paths; consecutive vertices that are not neighbours are joined by
    /// the shortest edge path.
    pub lines: Vec<Vec<usize>>,
    /// Split the n-gons left at T-junctions and singularities into quads and a triangle at most.
    pub split_polygons: bool,
    /// Feature lines shorter than this many spacings are ignored.
    pub min_feature_length: Real,
}

impl Default for RemeshParams {
    fn default() -> Self {
        RemeshParams {
            spacing: None,
            feature_angle: Some(30.0),
            weight: 10.0,
            conductivity: None,
            lines: Vec::new(),
            split_polygons: true,
            min_feature_length: 3.0,
        }
    }
}

/// Why a remesh failed.
#[derive(Debug, thiserror::Error)]
pub enum RemeshError {
    /// The mesh has no faces.
    #[error("the mesh has no faces")]
    Empty,
    /// A vertex position is NaN or infinite.
    #[error("vertex {0} is not a finite point")]
    NonFinite(usize),
    /// A constraint line is unusable.
    #[error("constraint line {0}: {1}")]
    BadLine(usize, String),
    /// The field could not be solved.
    #[error(transparent)]
    Field(#[from] FieldError),
}

/// Seconds per phase.
#[derive(Debug, Clone, Copy, Default, Serialize, serde::Deserialize)]
pub struct Timings {
    /// Constraints, half-split and the field solves.
    pub field: f64,
    /// Streamline placement.
    pub streamlines: f64,
    /// Crossings and faces.
    pub quads: f64,
    /// The quality report.
    pub quality: f64,
}

/// What [`remesh`] did and how good the result is.
#[derive(Debug, Clone, Default, Serialize, serde::Deserialize)]
pub struct RemeshReport {
    /// Triangles in.
    pub input_faces: usize,
    /// The input's edges with one face (its holes' rims), what the quads' are checked against.
    #[serde(default)]
    pub input_boundary_edges: usize,
    /// The input's edges with three or more faces.
    #[serde(default)]
    pub input_non_manifold_edges: usize,
    /// Edges split by the half-split of fig. 6.5.
    pub split_edges: usize,
    /// Constraint lines followed by contours.
    pub contour_constraints: usize,
    /// Constraint lines followed by gradient lines.
    pub gradient_constraints: usize,
    /// The streamline spacing used.
    pub spacing: Real,
    /// Streamlines traced (constraints included).
    pub streamlines: usize,
    /// Counts from the crossing graph.
    pub graph: GraphStats,
    /// Polygons split into quads and triangles.
    pub split: SplitStats,
    /// The quality report.
    pub quality: Quality,
    /// Seconds per phase.
    pub seconds: Timings,
}

/// The designed field and its streamlines: everything before the quads.
pub struct Streamlines {
    /// The input after the half-split: the mesh the field and lines live on.
    pub mesh: TriMesh,
    /// The field per vertex of `mesh`.
    pub u: Vec<Real>,
    /// Its gradient per face.
    pub grad: Vec<rig::math::Vector3>,
    /// Constraint lines first, then the traced streamlines, then the boundary.
    pub lines: Vec<Line>,
    /// Which of `lines` run along the mesh boundary.
    pub on_boundary: Vec<bool>,
    /// How many of `lines` are constraints (they come first).
    pub constraints: usize,
}

/// Remeshes `mesh` into quads (see the module notes).
pub fn remesh(mesh: &TriMesh, params: &RemeshParams) -> Result<(PolyMesh, RemeshReport), RemeshError> {
    remesh_counting(mesh, params, &std::sync::atomic::AtomicUsize::new(0))
}

/// The phases [`remesh_counting`] counts: the fields and their streamlines, the quads between them,
/// the quality measured against the input.
pub const REMESH_PHASES: usize = 3;

/// [`remesh`], adding one to `phases` as each of its [`REMESH_PHASES`] ends, for a progress display.
pub fn remesh_counting(
    mesh: &TriMesh,
    params: &RemeshParams,
    phases: &std::sync::atomic::AtomicUsize,
) -> Result<(PolyMesh, RemeshReport), RemeshError> {
    let next = || phases.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let mut report = RemeshReport::default();
    let traced = streamlines(mesh, params, &mut report)?;
    next();
    let s = Surface::new(&traced.mesh);
    let t2 = Instant::now();
    let (mut out, graph) = quads_from_lines(&s, &traced.lines, &traced.on_boundary, 0.15 * report.spacing);
    report.graph = graph;
    if params.split_polygons {
        (out, report.split) = split_polygons(&out);
    }
    report.seconds.quads = t2.elapsed().as_secs_f64();
    next();

    let t3 = Instant::now();
    let diag = mesh.bounding_box().map_or(0.0, |b| (b.max - b.min).norm());
    let constraint_points: Vec<Vec<Point3>> =
        traced.lines[..traced.constraints].iter().map(|l| l.points.clone()).collect();
    report.quality = measure(mesh, &out, &constraint_points, 0.002 * diag);
    let before = rig::topology::topology(mesh);
    (report.input_boundary_edges, report.input_non_manifold_edges) = (before.boundary_edges, before.non_manifold_edges);
    report.quality.singularities =
        vertex_indices(&traced.mesh, &traced.grad).iter().filter(|i| i.is_some_and(|i| i.abs() > 0.5)).count();
    report.seconds.quality = t3.elapsed().as_secs_f64();
    next();
    Ok((out, report))
}

/// The first half of [`remesh`]: constraints, field and streamlines, with their part of the report.
pub fn streamlines(
    mesh: &TriMesh,
    params: &RemeshParams,
    report: &mut RemeshReport,
) -> Result<Streamlines, RemeshError> {
    if mesh.faces.is_empty() {
        return Err(RemeshError::Empty);
    }
    if let Some(v) = mesh.vertices.iter().position(|p| !p.coords.iter().all(|c| c.is_finite())) {
        return Err(RemeshError::NonFinite(v));
    }
    let t0 = Instant::now();
    report.input_faces = mesh.faces.len();
    let neighbours = mesh.vertex_neighbours();

    // Constraint paths: the user's, joined up along edges, then the feature lines.
    let mut paths: Vec<Vec<usize>> = Vec::new();
    for (i, line) in params.lines.iter().enumerate() {
        paths.push(join_path(mesh, &neighbours, line).map_err(|e| RemeshError::BadLine(i, e))?);
    }
    let diag = mesh.bounding_box().map_or(1.0, |b| (b.max - b.min).norm());
    let spacing = params.spacing.unwrap_or(DEFAULT_SPACING * diag);
    if let Some(angle) = params.feature_angle {
        // Short, soft creases are noise on scanned surfaces, not features to follow; short sharp
        // ones (a machined step) are kept.
        let faces_of = EdgeFaces::new(mesh);
        let length =
            |p: &Vec<usize>| p.windows(2).map(|w| (mesh.vertices[w[1]] - mesh.vertices[w[0]]).norm()).sum::<Real>();
        let sharp = (1.5 * angle).max(60.0);
        paths.extend(chain(&feature_edges(mesh, angle)).into_iter().filter(|p| {
            length(p) >= params.min_feature_length * spacing || mean_dihedral(mesh, &faces_of, p) >= sharp
        }));
    }
    // A path that turns a corner cannot be one contour or one gradient line: split it there.
    let paths: Vec<Vec<usize>> = paths.iter().flat_map(|p| split_at_turns(mesh, p, 50.0)).collect();
    let constrained: HashSet<(u32, u32)> =
        paths.iter().flat_map(|p| p.windows(2).map(|w| (w[0].min(w[1]) as u32, w[0].max(w[1]) as u32))).collect();
    let (work, splits, parent) = split_doubly_constrained(mesh, &constrained);
    report.split_edges = splits;
    let conductivity: Option<Vec<Real>> = params.conductivity.as_ref().map(|c| parent.iter().map(|&f| c[f]).collect());
    if let Some(c) = &params.conductivity
        && c.len() != mesh.faces.len()
    {
        return Err(FieldError::Conductivity(format!("{} values for {} faces", c.len(), mesh.faces.len())).into());
    }
    let s = Surface::new(&work);

    // Poles, then the unconstrained field to decide each line's family, then the constrained one.
    let on_lines: Vec<usize> = paths.iter().flatten().copied().collect();
    let fixed = poles(&work, &on_lines, 3.0 * spacing);
    let system = LaplaceSystem::new(&work, conductivity.as_deref(), &fixed)?;
    // The constrained solve's ordering and symbolic factorisation depend only on the mesh (see
    // `NormalPlan`), so they run beside the free solve, whose result picks the constraints.
    let (free, plan) = rayon::join(|| system.solve(), || (!paths.is_empty()).then(|| system.normal_plan()));
    let free = free?;
    let free_grad = face_gradients(&work, &free);
    let faces_of_edge = EdgeFaces::new(&work);
    let mut families = Vec::with_capacity(paths.len());
    let mut rows: Vec<Vec<(usize, Real)>> = Vec::new();
    for path in &paths {
        let family = path_family(&work, &faces_of_edge, &free_grad, path);
        for w in path.windows(2) {
            let (a, b) = (w[0], w[1]);
            match family {
                Family::Contour => rows.push(vec![(a, 1.0), (b, -1.0)]),
                Family::Gradient => {
                    let t = work.vertices[b] - work.vertices[a];
                    for &f in faces_of_edge.get(a, b) {
                        let across = s.normal[f as usize].cross(&t);
                        let face = work.faces[f as usize];
                        rows.push(
                            (0..3).map(|k| (face[k] as usize, s.grad_bary[f as usize][k].dot(&across))).collect(),
                        );
                    }
                }
            }
        }
        families.push(family);
    }
    report.contour_constraints = families.iter().filter(|&&f| f == Family::Contour).count();
    report.gradient_constraints = families.len() - report.contour_constraints;
    let u = if rows.is_empty() {
        free
    } else {
        system.solve_with_rows(&rows, params.weight, plan.transpose()?.flatten())?
    };
    let grad = face_gradients(&work, &u);
    report.seconds.field = t0.elapsed().as_secs_f64();

    // Streamlines: the constraints first, then both families evenly spaced.
    let t1 = Instant::now();
    report.spacing = spacing;
    let constraint_lines: Vec<Line> = paths
        .iter()
        .zip(&families)
        .filter_map(|(path, &family)| path_line(&work, &faces_of_edge, path, family))
        .collect();
    let constraints = constraint_lines.len();
    let walls: Walls =
        paths.iter().flat_map(|p| p.windows(2).map(|w| (w[0].min(w[1]) as u32, w[0].max(w[1]) as u32))).collect();
    let field = Field { surface: &s, u: &u, grad: &grad, walls: &walls };
    let mut lines = place_lines(&field, constraint_lines, Spacing::new(spacing));
    let mut on_boundary = vec![false; lines.len()];
    for line in boundary_lines(&s) {
        lines.push(line);
        on_boundary.push(true);
    }
    report.streamlines = lines.len();
    report.seconds.streamlines = t1.elapsed().as_secs_f64();
    Ok(Streamlines { mesh: work, u, grad, lines, on_boundary, constraints })
}

/// Constraint lines as read from a file, as vertex paths of `mesh`: indices are checked, and points
/// snapped to their nearest vertex (consecutive duplicates dropped), a point farther from it than
/// the longest edge and [`MAX_SNAP`] of the mesh's size refused. [`remesh`] joins the vertices of
/// each path along edges.
pub fn snap_lines(mesh: &TriMesh, lines: &[ConstraintLine]) -> Result<Vec<Vec<usize>>, RemeshError> {
    let n = mesh.vertices.len();
    // How far a point on the surface can be from its nearest vertex is up to an edge (a coarse
    // mesh's face centre), past it a share of the mesh's size.
    let size = mesh.bounding_box().map_or(0.0, |b| b.diagonal());
    let longest = (mesh.faces.iter())
        .flat_map(|f| (0..3).map(move |k| (f[k], f[(k + 1) % 3])))
        .map(|(a, b)| (mesh.vertices[a as usize] - mesh.vertices[b as usize]).norm())
        .fold(0.0, Real::max);
    let reach = MAX_SNAP * size + longest;
    let mut out = Vec::with_capacity(lines.len());
    for (i, line) in lines.iter().enumerate() {
        let mut path: Vec<usize> = match line {
            ConstraintLine::Vertices(v) => {
                if let Some(&bad) = v.iter().find(|&&v| v >= n) {
                    return Err(RemeshError::BadLine(i, format!("vertex {bad} is not in the mesh ({n} vertices)")));
                }
                v.clone()
            }
            ConstraintLine::Points(points) => points
                .iter()
                .map(|p| {
                    let near = (0..n)
                        .min_by(|&a, &b| {
                            (mesh.vertices[a] - p).norm_squared().total_cmp(&(mesh.vertices[b] - p).norm_squared())
                        })
                        .ok_or(RemeshError::Empty)?;
                    // A point far off the surface is in another unit or frame, not a point on it.
                    let off = (mesh.vertices[near] - p).norm();
                    if off > reach {
                        return Err(RemeshError::BadLine(
                            i,
                            format!(
                                "its point ({}, {}, {}) lies {off:.4} from the mesh's nearest vertex, over its longest \
                                 edge and {:.0} % of its size ({size:.4}) more: points must lie on the mesh, in its \
                                 units and frame",
                                p.x,
                                p.y,
                                p.z,
                                100.0 * MAX_SNAP
                            ),
                        ));
                    }
                    Ok(near)
                })
                .collect::<Result<_, _>>()?,
        };
        path.dedup();
        if path.len() < 2 {
            return Err(RemeshError::BadLine(i, "its points all snap to one vertex".into()));
        }
        out.push(path);
    }
    Ok(out)
}

/// How much farther than the mesh's longest edge a constraint point may lie from its nearest vertex,
/// as a share of the mesh's bounding-box diagonal: a point picked on the surface in another tool lies
/// within an edge of a vertex.
pub const MAX_SNAP: Real = 0.05;

/// Dijkstra distances along edges from `start`, with each vertex's predecessor.
fn edge_distances(mesh: &TriMesh, neighbours: &[Vec<u32>], start: usize) -> (Vec<Real>, Vec<u32>) {
    edge_distances_from(mesh, neighbours, &[start])
}

/// Dijkstra distances along edges from the nearest of `starts` (infinite everywhere without any).
fn edge_distances_from(mesh: &TriMesh, neighbours: &[Vec<u32>], starts: &[usize]) -> (Vec<Real>, Vec<u32>) {
    let mut dist = vec![Real::INFINITY; mesh.vertices.len()];
    let mut prev = vec![u32::MAX; mesh.vertices.len()];
    let mut heap = BinaryHeap::new();
    for &start in starts {
        dist[start] = 0.0;
        heap.push(Reverse((OrdReal(0.0), start as u32)));
    }
    while let Some(Reverse((OrdReal(d), v))) = heap.pop() {
        if d > dist[v as usize] {
            continue;
        }
        for &w in &neighbours[v as usize] {
            let nd = d + (mesh.vertices[w as usize] - mesh.vertices[v as usize]).norm();
            if nd < dist[w as usize] {
                dist[w as usize] = nd;
                prev[w as usize] = v;
                heap.push(Reverse((OrdReal(nd), w)));
            }
        }
    }
    (dist, prev)
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct OrdReal(Real);
impl Eq for OrdReal {}
impl PartialOrd for OrdReal {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for OrdReal {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&o.0)
    }
}

/// A vertex path with every step along an edge: gaps are filled with shortest edge paths.
fn join_path(mesh: &TriMesh, neighbours: &[Vec<u32>], line: &[usize]) -> Result<Vec<usize>, String> {
    if line.len() < 2 {
        return Err("needs at least two vertices".into());
    }
    if let Some(&v) = line.iter().find(|&&v| v >= mesh.vertices.len()) {
        return Err(format!("vertex {v} is not in the mesh ({} vertices)", mesh.vertices.len()));
    }
    let mut path = vec![line[0]];
    for w in line.windows(2) {
        let (a, b) = (w[0], w[1]);
        if a == b {
            continue;
        }
        if neighbours[a].binary_search(&(b as u32)).is_ok() {
            path.push(b);
            continue;
        }
        let (dist, prev) = edge_distances(mesh, neighbours, a);
        if !dist[b].is_finite() {
            return Err(format!("vertices {a} and {b} are not connected"));
        }
        let mut back = vec![b];
        while *back.last().expect("non-empty") != a {
            back.push(prev[*back.last().expect("non-empty")] as usize);
        }
        path.extend(back.iter().rev().skip(1));
    }
    Ok(path)
}

/// Splits a vertex path where it turns by more than `max_turn_deg`, or has turned by more than that
/// in total since its last split (a closed path also at its start, which then is a corner).
fn split_at_turns(mesh: &TriMesh, path: &[usize], max_turn_deg: Real) -> Vec<Vec<usize>> {
    let limit = max_turn_deg.to_radians();
    let dir = |a: usize, b: usize| (mesh.vertices[b] - mesh.vertices[a]).normalize();
    let mut out = Vec::new();
    let mut piece = vec![path[0]];
    let mut start_dir: Option<rig::math::Vector3> = None;
    for i in 1..path.len() {
        piece.push(path[i]);
        let d = dir(path[i - 1], path[i]);
        let start = *start_dir.get_or_insert(d);
        if i + 1 < path.len() {
            let next = dir(path[i], path[i + 1]);
            if d.angle(&next) > limit || start.angle(&next) > limit {
                out.push(std::mem::replace(&mut piece, vec![path[i]]));
                start_dir = None;
            }
        }
    }
    if piece.len() > 1 {
        out.push(piece);
    }
    out
}

/// Two far-apart vertices per connected part, valued 0 and 1: the field's source and sink. The pair
/// comes from a double sweep (the farthest vertex from any start, then the farthest from that), over
/// the vertices at least `clearance` from every constrained vertex where there are such: a pole is a
/// singularity, and on a crease its fan of lines would cut the crease's corner.
fn poles(mesh: &TriMesh, constrained: &[usize], clearance: Real) -> Vec<(usize, Real)> {
    let neighbours = mesh.vertex_neighbours();
    // Parts as the field's equations see them: a face without area carries no flux, so two pieces
    // joined only through such faces are two parts, and each needs its own poles (else the system is
    // singular there).
    let mut parts = UnionFind::new(mesh.vertices.len());
    for f in &mesh.faces {
        let p = f.map(|i| mesh.vertices[i as usize]);
        if (p[1] - p[0]).cross(&(p[2] - p[0])).norm() > 0.0 {
            parts.union(f[0] as usize, f[1] as usize);
            parts.union(f[1] as usize, f[2] as usize);
        }
    }
    let (to_line, _) = edge_distances_from(mesh, &neighbours, constrained);
    let mut done: HashSet<usize> = HashSet::new();
    let mut fixed = Vec::new();
    for f in &mesh.faces {
        let root = parts.find(f[0] as usize);
        if !done.insert(root) {
            continue;
        }
        let (mut members, mut clear) = (Vec::new(), Vec::new());
        for (v, &d) in to_line.iter().enumerate() {
            if parts.find(v) == root {
                members.push(v);
                if d >= clearance {
                    clear.push(v);
                }
            }
        }
        // Without a clear vertex, the clearest ones.
        if clear.is_empty() {
            let best = members.iter().map(|&v| to_line[v]).fold(0.0, Real::max);
            clear = members.iter().copied().filter(|&v| to_line[v] >= 0.5 * best).collect();
        }
        let far = |from: usize| {
            let (d, _) = edge_distances(mesh, &neighbours, from);
            clear.iter().copied().filter(|&v| d[v].is_finite()).max_by(|&a, &b| d[a].total_cmp(&d[b])).unwrap_or(from)
        };
        let a = far(clear[0]);
        let b = far(a);
        fixed.push((a, 0.0));
        if b != a {
            fixed.push((b, 1.0));
        }
    }
    fixed
}

/// Which family can follow a path: contours if the field mostly crosses it (length-weighted mean
/// |cos| between path and gradient below cos 45°), gradient lines otherwise.
fn path_family(mesh: &TriMesh, faces_of_edge: &EdgeFaces, grad: &[rig::math::Vector3], path: &[usize]) -> Family {
    let (mut along, mut total) = (0.0, 0.0);
    for w in path.windows(2) {
        let t = mesh.vertices[w[1]] - mesh.vertices[w[0]];
        for &f in faces_of_edge.get(w[0], w[1]) {
            let g = grad[f as usize];
            if g.norm() > 0.0 {
                along += (g.dot(&t) / g.norm()).abs();
                total += t.norm();
            }
        }
    }
    if total > 0.0 && along / total > std::f64::consts::FRAC_1_SQRT_2 { Family::Gradient } else { Family::Contour }
}

/// A constraint path as a line along mesh edges.
fn path_line(mesh: &TriMesh, faces_of_edge: &EdgeFaces, path: &[usize], family: Family) -> Option<Line> {
    let faces = path.windows(2).map(|w| faces_of_edge.get(w[0], w[1]).first().copied()).collect::<Option<_>>()?;
    Some(edge_line(mesh, path, faces, family))
}

/// A line along the mesh edges `path`, each edge filed under the face given for it.
fn edge_line(mesh: &TriMesh, path: &[usize], faces: Vec<u32>, family: Family) -> Line {
    let closed = path.len() > 2 && path[0] == path[path.len() - 1];
    Line {
        family,
        points: path.iter().map(|&v| mesh.vertices[v]).collect(),
        faces,
        closed,
        on_edges: true,
        end_vertices: if closed { [None, None] } else { [Some(path[0] as u32), Some(path[path.len() - 1] as u32)] },
    }
}

/// The mesh boundary as lines along its edges, each oriented with the surface on its left, split
/// where the boundary turns a corner so the corner is a node of the quad graph.
fn boundary_lines(s: &Surface) -> Vec<Line> {
    let mesh = s.mesh;
    // A boundary half-edge: edge k of face f (from corner k+1 to corner k+2), nothing across it.
    let open = |f: u32, k: usize| s.across(f, k).is_none();
    // The boundary half-edge that follows (f, k): around its head through the faces of its own fan,
    // so a vertex where two parts' boundaries meet (the Newell teapot's patches at their corners)
    // passes each loop on in its own part, and no boundary edge is left out.
    let next = |f: u32, k: usize| -> Option<(u32, usize)> {
        let head = mesh.faces[f as usize][(k + 2) % 3];
        let (mut g, mut c) = (f, (k + 2) % 3);
        for _ in 0..=s.corners_of(head).len() {
            // The edge leaving the head in g: from corner c to corner c+1, edge c+2.
            let m = (c + 2) % 3;
            if open(g, m) {
                return Some((g, m));
            }
            let (h, _) = s.across(g, m)?;
            g = h;
            c = (0..3).find(|&j| mesh.faces[g as usize][j] == head)?;
        }
        None
    };
    let mut used: HashSet<(u32, usize)> = HashSet::new();
    let mut lines = Vec::new();
    for (f, k) in (0..mesh.faces.len() as u32).flat_map(|f| (0..3).map(move |k| (f, k))) {
        if !open(f, k) || used.contains(&(f, k)) {
            continue;
        }
        let mut path = vec![mesh.faces[f as usize][(k + 1) % 3] as usize];
        // Each edge's own face: along an edge of three or more faces each fin has its own
        // boundary, which its own streamlines must meet (the first face of the edge is one fin's).
        let mut faces = Vec::new();
        let mut h = Some((f, k));
        while let Some((g, m)) = h {
            if !used.insert((g, m)) {
                break;
            }
            path.push(mesh.faces[g as usize][(m + 2) % 3] as usize);
            faces.push(g);
            h = next(g, m);
        }
        // The pieces follow one another, each starting where the last ended.
        let mut first = 0;
        for piece in split_at_turns(mesh, &path, 50.0) {
            let edges = piece.len() - 1;
            lines.push(edge_line(mesh, &piece, faces[first..first + edges].to_vec(), Family::Contour));
            first += edges;
        }
    }
    lines
}

/// The mean angle, in degrees, between the normals of the two faces along a path's edges.
fn mean_dihedral(mesh: &TriMesh, faces_of: &EdgeFaces, path: &[usize]) -> Real {
    let normal = |f: u32| {
        let [a, b, c] = mesh.faces[f as usize].map(|i| mesh.vertices[i as usize]);
        (b - a).cross(&(c - a))
    };
    let (mut sum, mut n) = (0.0, 0);
    for w in path.windows(2) {
        if let [f, g] = faces_of.get(w[0], w[1]) {
            sum += normal(*f).angle(&normal(*g)).to_degrees();
            n += 1;
        }
    }
    if n > 0 { sum / n as Real } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::remesh::seeding::place_lines;

    fn plate(w: usize, h: usize) -> TriMesh {
        fixtures::plate(w, h, false)
    }

    /// Three pages of a book share their spine (edges of three faces): each page's boundary runs
    /// along the spine too, filed under that page's own faces, so its own streamlines end on it.
    #[test]
    fn each_fin_of_an_edge_of_three_faces_has_its_own_boundary_along_it() {
        let (n, mut mesh) = (3usize, TriMesh::default());
        for z in 0..=n {
            mesh.vertices.push(Point3::new(0.0, 0.0, z as Real));
        }
        for page in 0..3 {
            let a = page as Real * std::f64::consts::TAU / 3.0;
            let first = mesh.vertices.len() as u32;
            for i in 1..=n {
                for z in 0..=n {
                    mesh.vertices.push(Point3::new(i as Real * a.cos(), i as Real * a.sin(), z as Real));
                }
            }
            let v = |i: usize, z: usize| if i == 0 { z as u32 } else { first + ((i - 1) * (n + 1) + z) as u32 };
            for i in 0..n {
                for z in 0..n {
                    mesh.faces.push([v(i, z), v(i + 1, z), v(i + 1, z + 1)]);
                    mesh.faces.push([v(i, z), v(i + 1, z + 1), v(i, z + 1)]);
                }
            }
        }
        let s = Surface::new(&mesh);
        let lines = boundary_lines(&s);
        let page_of = |f: u32| f as usize / (2 * n * n);
        let mut spine_pages = HashSet::new();
        for line in &lines {
            for (i, &f) in line.faces.iter().enumerate() {
                let face = mesh.faces[f as usize].map(|v| mesh.vertices[v as usize]);
                for p in [line.points[i], line.points[i + 1]] {
                    assert!(face.contains(&p), "segment {i} filed under face {f}, which lacks its end {p}");
                }
                if line.points[i].x == 0.0 && line.points[i].y == 0.0 && line.points[i + 1].x == 0.0 {
                    spine_pages.insert(page_of(f));
                }
            }
        }
        assert_eq!(spine_pages.len(), 3, "pages with a boundary along the spine: {spine_pages:?}");
    }

    #[test]
    fn a_linear_field_on_a_plate_gives_a_grid_of_quads_inside_its_boundary() {
        let m = plate(30, 20);
        let s = Surface::new(&m);
        let u: Vec<Real> = m.vertices.iter().map(|p| p.x).collect();
        let grad = face_gradients(&m, &u);
        let walls = Walls::new();
        let field = Field { surface: &s, u: &u, grad: &grad, walls: &walls };
        let mut lines = place_lines(&field, Vec::new(), Spacing::new(2.0));
        let mut on_boundary = vec![false; lines.len()];
        for l in boundary_lines(&s) {
            lines.push(l);
            on_boundary.push(true);
        }
        let (out, stats) = quads_from_lines(&s, &lines, &on_boundary, 0.3);
        let sizes = out.face_sizes();
        assert_eq!(sizes.quads, out.face_count(), "{sizes:?}");
        // The quads tile the plate: their areas add up to it, and every corner is square.
        let area: Real = out
            .triangulate()
            .faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|i| out.vertices[i as usize]);
                (b - a).cross(&(c - a)).z / 2.0
            })
            .sum();
        assert!((area - 600.0).abs() < 1e-6, "area {area}");
        let q = measure(&m, &out, &[], 0.01);
        assert!(q.mean_angle_error_deg < 1e-6, "{}", q.mean_angle_error_deg);
        assert_eq!(q.non_manifold_edges, 0);
        // Only the plate's outline is open: 2·(w + h) / spacing edges, give or take the cut corners.
        let outline = 2.0 * (30.0 + 20.0) / 2.0;
        assert!((q.boundary_edges as Real - outline).abs() <= 4.0, "{} boundary edges", q.boundary_edges);
        assert_eq!(stats.bridges, 0);
    }

    #[test]
    fn constraint_paths_are_joined_split_at_corners_and_checked() {
        let m = plate(6, 6);
        let nb = m.vertex_neighbours();
        let id = |i: usize, j: usize| j * 7 + i;
        // Two far vertices on one row get the row's edges between them.
        let p = join_path(&m, &nb, &[id(0, 3), id(4, 3)]).unwrap();
        assert_eq!(p, (0..=4).map(|i| id(i, 3)).collect::<Vec<_>>());
        assert!(join_path(&m, &nb, &[id(0, 0)]).is_err());
        assert!(join_path(&m, &nb, &[0, 999]).unwrap_err().contains("999"));
        // An L-shaped path splits at its corner.
        let l: Vec<usize> = (0..=3).map(|i| id(i, 1)).chain((2..=4).map(|j| id(3, j))).collect();
        let pieces = split_at_turns(&m, &l, 50.0);
        assert_eq!(pieces.len(), 2);
        assert_eq!(pieces[0].last(), pieces[1].first());
    }
}
