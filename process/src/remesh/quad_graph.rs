//! Quads from crossing streamlines (thesis §6: "we first determine the intersection points of gradient
//! and co-gradient streamlines … we associate the line segments of all streamlines with the triangles
//! they are integrated on and compute the intersections on all triangles. This way, we obtain a graph
//! of streamlines … we traverse the graph to create the quadrangular faces").
//!
//! The graph's nodes are the crossings; its edges the pieces of line between consecutive crossings.
//! A line's tail beyond its last crossing is dropped, so a line that stopped near another ends at a
//! T-junction. Faces are the cycles of the embedding: at every node the edges are ordered by angle in
//! the surface's tangent plane (unfolding the faces around a node that sits on a mesh edge or vertex,
//! so the order survives sharp creases), and each face continues, at every node, with the edge just
//! clockwise of the one it came in on. On an open mesh the boundary is a line too, and the faces
//! outside it are dropped.

use super::seeding::Line;
use super::surface::Surface;
use rig::PolyMesh;
use rig::math::{Point3, Real, Vector3};
use rig::union_find::UnionFind;
use std::collections::HashMap;
use std::f64::consts::TAU;

/// Counts from building the quad mesh.
#[derive(Debug, Clone, Copy, Default, serde::Serialize, serde::Deserialize)]
pub struct GraphStats {
    /// Crossings found (after merging coincident ones).
    pub crossings: usize,
    /// Nodes kept in the mesh.
    pub nodes: usize,
    /// Nodes where a line ends on another (three edges).
    pub t_junctions: usize,
    /// Faces dropped: outside the boundary, or degenerate (fewer than three corners).
    pub dropped_faces: usize,
    /// Edges removed because the same face lay on both sides, or hung from a single node.
    pub bridges: usize,
}

/// Where a node sits relative to the mesh, for ordering the edges around it.
#[derive(Debug, Clone, Copy)]
enum Seat {
    /// Inside a face.
    Face(u32),
    /// On an edge of a face.
    Edge(u32),
    /// On a mesh vertex.
    Vertex(u32),
}

/// One occurrence of a node on a line: the position along it (segment index + fraction).
#[derive(Debug, Clone, Copy)]
struct Visit {
    param: Real,
    node: u32,
}

/// An edge of the graph: a piece of `line` from `from` (at `p0`) to `to` (at `p1`).
#[derive(Debug, Clone, Copy)]
struct GraphEdge {
    from: u32,
    to: u32,
    line: u32,
    p0: Real,
    p1: Real,
}

/// Builds the polygon mesh of the lines' crossings. `boundary_lines` marks lines that run along the
/// mesh boundary in its orientation (interior on their left); faces on their other side are dropped.
/// Nodes closer than `merge` along a line become one.
pub fn quads_from_lines(s: &Surface, lines: &[Line], boundary_lines: &[bool], merge: Real) -> (PolyMesh, GraphStats) {
    let mut stats = GraphStats::default();
    let diag = s.mesh.bounding_box().map_or(1.0, |b| (b.max - b.min).norm()).max(Real::MIN_POSITIVE);
    let eps = 1e-7 * diag;
    let parts = Parts::of(s);
    let (index, visits) = crossings(s, &parts, lines, eps);
    let (nodes, node_part) = (index.nodes, index.part);
    stats.crossings = nodes.len();
    let mut edges = line_edges(lines, visits);
    if merge > 0.0 {
        collapse_short_edges(&nodes, &mut edges, merge);
    }
    drop_doubled_edges(lines, &nodes, &mut edges);
    let (alive, around, faces) = proper_faces(s, &node_part, lines, &nodes, &edges, &mut stats);
    let is_corner = corners(&nodes, &edges, &alive, &around);
    let tail = |h: u32| -> u32 {
        let e = edges[(h / 2) as usize];
        if h.is_multiple_of(2) { e.from } else { e.to }
    };
    let outside = |h: u32| -> bool {
        let e = edges[(h / 2) as usize];
        boundary_lines.get(e.line as usize).copied().unwrap_or(false) && h % 2 == 1
    };
    let mut index = vec![u32::MAX; nodes.len()];
    let mut mesh = PolyMesh::default();
    for cycle in &faces {
        let out = cycle.iter().any(|&h| outside(h));
        let mut corners: Vec<u32> = cycle.iter().map(|&h| tail(h)).filter(|&n| is_corner[n as usize]).collect();
        corners.dedup();
        if corners.len() > 1 && corners[0] == corners[corners.len() - 1] {
            corners.pop();
        }
        if out || corners.len() < 3 {
            stats.dropped_faces += 1;
            continue;
        }
        let face: Vec<u32> = corners
            .iter()
            .map(|&n| {
                if index[n as usize] == u32::MAX {
                    index[n as usize] = mesh.vertices.len() as u32;
                    mesh.vertices.push(nodes[n as usize].0);
                }
                index[n as usize]
            })
            .collect();
        mesh.push_face(&face);
    }
    stats.nodes = mesh.vertices.len();
    stats.t_junctions = (0..nodes.len()).filter(|&n| index[n] != u32::MAX && around[n].len() == 3).count();
    (mesh, stats)
}

/// Which part of the mesh each face lies on: faces joined across edges that two faces share, as the
/// streamlines cross them ([`Surface::across`]). Parts that share only a vertex (the Newell teapot's
/// patches meet at their corners) or an edge of three or more faces (the coarse Stanford bunny's
/// pieces) are apart: no line passes from one to the other, and the edges around a node there would
/// be ordered in two surfaces at once.
struct Parts(Vec<u32>);

impl Parts {
    fn of(s: &Surface) -> Self {
        let mut joined = UnionFind::new(s.mesh.faces.len());
        for f in 0..s.mesh.faces.len() {
            for k in 0..3 {
                if let Some((g, _)) = s.across(f as u32, k) {
                    joined.union(f, g as usize);
                }
            }
        }
        Parts((0..s.mesh.faces.len()).map(|f| joined.find(f) as u32).collect())
    }
}

/// The graph's nodes, found by position: crossings closer than twice `eps` on the same part of the
/// mesh ([`Parts`]) are one node, and each node's part. Parts that touch only by position or by a
/// vertex (the Newell teapot's handle and its lid's patches) keep their own nodes: one shared node
/// joined the handle's graph to the body's, whose largest component then won the handle's part too,
/// so the handle got no quads at any spacing.
struct NodeIndex {
    nodes: Vec<(Point3, Seat)>,
    part: Vec<u32>,
    at: HashMap<[i64; 3], Vec<u32>>,
    eps: Real,
}

impl NodeIndex {
    fn find_or_add(&mut self, p: Point3, seat: Seat, part: u32) -> u32 {
        let eps = self.eps;
        let key = [p.x, p.y, p.z].map(|c| (c / (4.0 * eps)).floor() as i64);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(ids) = self.at.get(&[key[0] + dx, key[1] + dy, key[2] + dz]) {
                        for &id in ids {
                            if (self.nodes[id as usize].0 - p).norm() < 2.0 * eps && self.part[id as usize] == part {
                                return id;
                            }
                        }
                    }
                }
            }
        }
        self.nodes.push((p, seat));
        self.part.push(part);
        let id = self.nodes.len() as u32 - 1;
        self.at.entry(key).or_default().push(id);
        id
    }
}

/// The lines' crossings, merged by position into nodes, and each line's visits to them in order of
/// finding; lines ending on a mesh vertex (at a pole of the field) meet there.
fn crossings(s: &Surface, parts: &Parts, lines: &[Line], eps: Real) -> (NodeIndex, Vec<Vec<Visit>>) {
    // Segments per face. Lines along mesh edges are filed under both faces of each edge.
    let mut by_face: HashMap<u32, Vec<(u32, u32)>> = HashMap::new();
    for (i, line) in lines.iter().enumerate() {
        for (j, &f) in line.faces.iter().enumerate() {
            by_face.entry(f).or_default().push((i as u32, j as u32));
            if line.on_edges
                && let Some(g) = s.face_across_segment(f, &line.points[j], &line.points[j + 1])
            {
                by_face.entry(g).or_default().push((i as u32, j as u32));
            }
        }
    }
    let mut index = NodeIndex { nodes: Vec::new(), part: Vec::new(), at: HashMap::new(), eps };
    let mut visits: Vec<Vec<Visit>> = vec![Vec::new(); lines.len()];
    let mut faces_sorted: Vec<u32> = by_face.keys().copied().collect();
    faces_sorted.sort_unstable();
    for f in faces_sorted {
        let segs = &by_face[&f];
        if segs.len() < 2 {
            continue;
        }
        let frame = face_frame(s, f);
        for a in 0..segs.len() {
            for b in a + 1..segs.len() {
                let ((la, ja), (lb, jb)) = (segs[a], segs[b]);
                if la == lb {
                    continue;
                }
                let (la_, lb_) = (&lines[la as usize], &lines[lb as usize]);
                let Some((sa, sb)) = intersect(
                    &frame,
                    &la_.points[ja as usize],
                    &la_.points[ja as usize + 1],
                    &lb_.points[jb as usize],
                    &lb_.points[jb as usize + 1],
                ) else {
                    continue;
                };
                let p = la_.points[ja as usize] + (la_.points[ja as usize + 1] - la_.points[ja as usize]) * sa;
                let seat = seat_of(s, f, &p, 10.0 * eps);
                let id = index.find_or_add(p, seat, parts.0[f as usize]);
                visits[la as usize].push(Visit { param: ja as Real + sa, node: id });
                visits[lb as usize].push(Visit { param: jb as Real + sb, node: id });
            }
        }
    }
    for (i, line) in lines.iter().enumerate() {
        for (end, v) in line.end_vertices.iter().enumerate() {
            if let Some(v) = v {
                let p = s.mesh.vertices[*v as usize];
                // The line's own part: a vertex may be shared by parts that meet only there.
                let face = if end == 0 { line.faces.first() } else { line.faces.last() };
                let Some(&face) = face else { continue };
                let id = index.find_or_add(p, Seat::Vertex(*v), parts.0[face as usize]);
                index.nodes[id as usize] = (p, Seat::Vertex(*v));
                let param = if end == 0 { 0.0 } else { line.faces.len() as Real };
                visits[i].push(Visit { param, node: id });
            }
        }
    }
    (index, visits)
}

/// Edges between consecutive nodes along each line (a closed line's last back to its first).
fn line_edges(lines: &[Line], mut visits: Vec<Vec<Visit>>) -> Vec<GraphEdge> {
    let mut edges: Vec<GraphEdge> = Vec::new();
    for (i, v) in visits.iter_mut().enumerate() {
        v.sort_by(|a, b| a.param.total_cmp(&b.param));
        v.dedup_by(|b, a| a.node == b.node);
        let closed = lines[i].closed;
        if closed && v.len() > 1 && v[0].node == v[v.len() - 1].node {
            v.pop();
        }
        if closed && v.len() < 2 {
            continue; // a loop crossing at most one line bounds nothing
        }
        for w in v.windows(2) {
            edges.push(GraphEdge { from: w[0].node, to: w[1].node, line: i as u32, p0: w[0].param, p1: w[1].param });
        }
        if closed {
            let (last, first) = (v[v.len() - 1], v[0]);
            let n = lines[i].faces.len() as Real;
            edges.push(GraphEdge {
                from: last.node,
                to: first.node,
                line: i as u32,
                p0: last.param,
                p1: first.param + n,
            });
        }
    }
    edges.retain(|e| e.from != e.to);
    edges
}

/// Collapses edges shorter than `merge`: lines crossing at a glancing angle (a streamline beside a
/// constraint near a corner) leave near-coincident nodes and slivers between them. A mesh vertex (a
/// corner of the constraints) wins as the merged node.
fn collapse_short_edges(nodes: &[(Point3, Seat)], edges: &mut Vec<GraphEdge>, merge: Real) {
    let mut groups = UnionFind::new(nodes.len());
    for e in edges.iter() {
        if (nodes[e.from as usize].0 - nodes[e.to as usize].0).norm() < merge {
            groups.union(e.from as usize, e.to as usize);
        }
    }
    let mut rep = vec![u32::MAX; nodes.len()];
    for n in 0..nodes.len() {
        let root = groups.find(n);
        let better = rep[root] == u32::MAX
            || (matches!(nodes[n].1, Seat::Vertex(_)) && !matches!(nodes[rep[root] as usize].1, Seat::Vertex(_)));
        if better {
            rep[root] = n as u32;
        }
    }
    for e in edges.iter_mut() {
        e.from = rep[groups.find(e.from as usize)];
        e.to = rep[groups.find(e.to as usize)];
    }
    edges.retain(|e| e.from != e.to);
}

/// Two lines along the same stretch (a streamline that slid onto a constraint edge) give two edges
/// between the same nodes leaving in the same direction: keeps the first (constraints come first),
/// or the rotation order between them would be a coin toss.
fn drop_doubled_edges(lines: &[Line], nodes: &[(Point3, Seat)], edges: &mut Vec<GraphEdge>) {
    let mut by_ends: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
    for (k, e) in edges.iter().enumerate() {
        by_ends.entry((e.from.min(e.to), e.from.max(e.to))).or_default().push(k);
    }
    let mut dead = vec![false; edges.len()];
    let leave = |k: usize, at: u32| -> Option<Vector3> {
        let e = edges[k];
        let (param, forward) = if e.from == at { (e.p0, true) } else { (e.p1, false) };
        step_from(&lines[e.line as usize], param, forward, &nodes[at as usize].0).map(|(d, _)| d.normalize())
    };
    for ks in by_ends.values().filter(|ks| ks.len() > 1) {
        for (i, &a) in ks.iter().enumerate() {
            for &b in &ks[i + 1..] {
                if dead[a] || dead[b] {
                    continue;
                }
                let same = [edges[a].from, edges[a].to].iter().all(|&n| match (leave(a, n), leave(b, n)) {
                    (Some(x), Some(y)) => x.dot(&y) > 1.0 - 1e-6,
                    _ => false,
                });
                if same {
                    dead[if edges[a].line <= edges[b].line { b } else { a }] = true;
                }
            }
        }
    }
    let mut k = 0;
    edges.retain(|_| {
        k += 1;
        !dead[k - 1]
    });
}

/// The edges still alive, each node's edges in rotation order, and the faces they bound (half-edge
/// cycles). Drops dangling edges, stray islands and bridges (an edge with the same face on both
/// sides: a cluster hanging by one path) until the embedding's faces are all proper.
#[allow(clippy::type_complexity)]
fn proper_faces(
    s: &Surface,
    node_part: &[u32],
    lines: &[Line],
    nodes: &[(Point3, Seat)],
    edges: &[GraphEdge],
    stats: &mut GraphStats,
) -> (Vec<bool>, Vec<Vec<(Real, u32)>>, Vec<Vec<u32>>) {
    let mut alive = vec![true; edges.len()];
    loop {
        prune_dangling(edges, &mut alive, nodes.len());
        keep_main_components(node_part, nodes.len(), edges, &mut alive);
        let around = rotations(s, lines, nodes, edges, &alive);
        let faces = trace_faces(edges, &alive, &around);
        let mut face_of = vec![u32::MAX; 2 * edges.len()];
        for (i, f) in faces.iter().enumerate() {
            for &h in f {
                face_of[h as usize] = i as u32;
            }
        }
        let mut bridges = 0;
        for k in 0..edges.len() {
            if alive[k] && face_of[2 * k] == face_of[2 * k + 1] {
                alive[k] = false;
                bridges += 1;
            }
        }
        for f in &faces {
            bridges += cut_hanging_cluster(f, edges, &mut alive);
        }
        stats.bridges += bridges;
        if bridges == 0 {
            return (alive, around, faces);
        }
    }
}

/// A face that passes a node twice has a cluster hanging by that node: cuts the smaller side (its
/// edges no longer alive); returns how many edges it cut.
fn cut_hanging_cluster(f: &[u32], edges: &[GraphEdge], alive: &mut [bool]) -> usize {
    let mut cut = 0;
    let mut at: HashMap<u32, usize> = HashMap::new();
    for (i, &h) in f.iter().enumerate() {
        let e = edges[(h / 2) as usize];
        let node = if h.is_multiple_of(2) { e.from } else { e.to };
        if let Some(&j) = at.get(&node) {
            let inner = i - j;
            let piece: Vec<u32> =
                if 2 * inner <= f.len() { f[j..i].to_vec() } else { f[i..].iter().chain(&f[..j]).copied().collect() };
            for h in piece {
                if alive[(h / 2) as usize] {
                    alive[(h / 2) as usize] = false;
                    cut += 1;
                }
            }
            break;
        }
        at.insert(node, i);
    }
    cut
}

/// Which nodes are corners of the faces: a node where a line passes straight through with nothing
/// crossing is not, unless dropping it would join two nodes that are already neighbours (a doubled
/// edge).
fn corners(nodes: &[(Point3, Seat)], edges: &[GraphEdge], alive: &[bool], around: &[Vec<(Real, u32)>]) -> Vec<bool> {
    let mut adjacent: Vec<Vec<u32>> = vec![Vec::new(); nodes.len()];
    for (k, e) in edges.iter().enumerate() {
        if alive[k] {
            adjacent[e.from as usize].push(e.to);
            adjacent[e.to as usize].push(e.from);
        }
    }
    let mut is_corner: Vec<bool> = around.iter().map(|list| list.len() > 2).collect();
    for n in 0..nodes.len() {
        let list = &around[n];
        if list.len() != 2 {
            continue;
        }
        let turn = ((list[1].0 - list[0].0).rem_euclid(TAU) - TAU / 2.0).abs();
        let (a, b) = (adjacent[n][0], adjacent[n][1]);
        let n32 = n as u32;
        if turn > 30f64.to_radians() || a == b || a == n32 || b == n32 || adjacent[a as usize].contains(&b) {
            is_corner[n] = true;
            continue;
        }
        for (x, y) in [(a, b), (b, a)] {
            if let Some(slot) = adjacent[x as usize].iter_mut().find(|m| **m == n32) {
                *slot = y;
            }
        }
        adjacent[n].clear();
    }
    is_corner
}

/// Removes edges hanging from nodes with a single edge, repeatedly.
fn prune_dangling(edges: &[GraphEdge], alive: &mut [bool], nodes: usize) {
    let mut degree = vec![0u32; nodes];
    let mut incident: Vec<Vec<u32>> = vec![Vec::new(); nodes];
    for (k, e) in edges.iter().enumerate() {
        if alive[k] {
            degree[e.from as usize] += 1;
            degree[e.to as usize] += 1;
            incident[e.from as usize].push(k as u32);
            incident[e.to as usize].push(k as u32);
        }
    }
    let mut stack: Vec<u32> = (0..nodes as u32).filter(|&n| degree[n as usize] == 1).collect();
    while let Some(n) = stack.pop() {
        if degree[n as usize] != 1 {
            continue;
        }
        let Some(&k) = incident[n as usize].iter().find(|&&k| alive[k as usize]) else { continue };
        alive[k as usize] = false;
        let e = edges[k as usize];
        for m in [e.from, e.to] {
            degree[m as usize] -= 1;
            if degree[m as usize] == 1 {
                stack.push(m);
            }
        }
    }
}

/// Keeps, on each connected part of the mesh, only the edges of the connected part of the graph
/// with the most edges there: a smaller one would sit inside one of its faces, a face with a hole
/// that no polygon can be. Edges belong to the part their first node lies on, so a component that a
/// line joins to another part's (a feature line through a vertex where two parts meet, as the
/// Newell teapot's spout and body do) is judged on each part by what it has there.
fn keep_main_components(node_part: &[u32], nodes: usize, edges: &[GraphEdge], alive: &mut [bool]) {
    let mut graph = UnionFind::new(nodes);
    for (k, e) in edges.iter().enumerate() {
        if alive[k] {
            graph.union(e.from as usize, e.to as usize);
        }
    }
    // Edges per graph component and surface part, and the biggest component per part.
    let mut size: HashMap<(u32, usize), usize> = HashMap::new();
    for (k, e) in edges.iter().enumerate() {
        if alive[k] {
            *size.entry((node_part[e.from as usize], graph.find(e.from as usize))).or_default() += 1;
        }
    }
    let mut best: HashMap<u32, (usize, usize)> = HashMap::new();
    for (&(part, root), &n) in &size {
        let entry = best.entry(part).or_insert((root, n));
        if n > entry.1 || (n == entry.1 && root < entry.0) {
            *entry = (root, n);
        }
    }
    for (k, e) in edges.iter().enumerate() {
        if alive[k] && best.get(&node_part[e.from as usize]).map(|&(root, _)| root) != Some(graph.find(e.from as usize))
        {
            alive[k] = false;
        }
    }
}

/// Each node's outgoing half-edges sorted by angle: half-edge `2k` runs along edge `k` from its
/// `from` node, `2k + 1` back from its `to` node.
fn rotations(
    s: &Surface,
    lines: &[Line],
    nodes: &[(Point3, Seat)],
    edges: &[GraphEdge],
    alive: &[bool],
) -> Vec<Vec<(Real, u32)>> {
    let mut around: Vec<Vec<(Real, u32)>> = vec![Vec::new(); nodes.len()];
    for (k, e) in edges.iter().enumerate() {
        if !alive[k] {
            continue;
        }
        let line = &lines[e.line as usize];
        for (half, node, param, forward) in [(2 * k, e.from, e.p0, true), (2 * k + 1, e.to, e.p1, false)] {
            let (pos, seat) = nodes[node as usize];
            let angle = step_from(line, param, forward, &pos).map_or(0.0, |(d, f)| polar_angle(s, seat, &d, f));
            around[node as usize].push((angle, half as u32));
        }
    }
    for list in &mut around {
        list.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    around
}

/// The faces of the embedding as cycles of half-edges: the face on the left of a half-edge continues,
/// at its head, with the half-edge just clockwise of its twin.
fn trace_faces(edges: &[GraphEdge], alive: &[bool], around: &[Vec<(Real, u32)>]) -> Vec<Vec<u32>> {
    let mut slot = vec![(0u32, 0u32); 2 * edges.len()];
    for (n, list) in around.iter().enumerate() {
        for (i, &(_, h)) in list.iter().enumerate() {
            slot[h as usize] = (n as u32, i as u32);
        }
    }
    let next = |h: u32| -> u32 {
        let (n, i) = slot[(h ^ 1) as usize];
        let list = &around[n as usize];
        list[(i as usize + list.len() - 1) % list.len()].1
    };
    let mut seen = vec![false; 2 * edges.len()];
    let mut faces = Vec::new();
    for start in 0..2 * edges.len() as u32 {
        if seen[start as usize] || !alive[(start / 2) as usize] {
            continue;
        }
        let mut cycle = Vec::new();
        let mut h = start;
        loop {
            seen[h as usize] = true;
            cycle.push(h);
            h = next(h);
            if h == start || seen[h as usize] || cycle.len() > 2 * edges.len() {
                break;
            }
        }
        faces.push(cycle);
    }
    faces
}

/// An orthonormal frame in face `f`'s plane: origin, first axis, second axis (normal × first).
fn face_frame(s: &Surface, f: u32) -> (Point3, Vector3, Vector3) {
    let face = s.mesh.faces[f as usize];
    let p0 = s.mesh.vertices[face[0] as usize];
    let e1 = (s.mesh.vertices[face[1] as usize] - p0).normalize();
    let n = s.normal[f as usize];
    (p0, e1, n.cross(&e1))
}

/// The parameters `(s, t)` where segments `a0 a1` and `b0 b1` cross in the frame's plane, endpoints
/// included (a line that ends on another crosses it); `None` if they miss or are parallel.
fn intersect(
    frame: &(Point3, Vector3, Vector3),
    a0: &Point3,
    a1: &Point3,
    b0: &Point3,
    b1: &Point3,
) -> Option<(Real, Real)> {
    let (o, x, y) = frame;
    let to2 = |p: &Point3| {
        let d = p - o;
        (d.dot(x), d.dot(y))
    };
    let (a0, a1, b0, b1) = (to2(a0), to2(a1), to2(b0), to2(b1));
    let da = (a1.0 - a0.0, a1.1 - a0.1);
    let db = (b1.0 - b0.0, b1.1 - b0.1);
    let denom = da.0 * db.1 - da.1 * db.0;
    let (la, lb) = ((da.0 * da.0 + da.1 * da.1).sqrt(), (db.0 * db.0 + db.1 * db.1).sqrt());
    if la == 0.0 || lb == 0.0 || denom.abs() <= 1e-9 * la * lb {
        return None;
    }
    let w = (b0.0 - a0.0, b0.1 - a0.1);
    let sa = (w.0 * db.1 - w.1 * db.0) / denom;
    let sb = (w.0 * da.1 - w.1 * da.0) / denom;
    let (ta, tb) = (1e-7 * (1.0 + 1.0 / la).min(1e3), 1e-7 * (1.0 + 1.0 / lb).min(1e3));
    ((-ta..=1.0 + ta).contains(&sa) && (-tb..=1.0 + tb).contains(&sb)).then(|| (sa.clamp(0.0, 1.0), sb.clamp(0.0, 1.0)))
}

/// Where point `p` (in face `f`) sits: on a vertex or an edge if within `eps` of it, else inside.
fn seat_of(s: &Surface, f: u32, p: &Point3, eps: Real) -> Seat {
    let face = s.mesh.faces[f as usize];
    let corner = face.map(|v| s.mesh.vertices[v as usize]);
    if let Some(c) = (0..3).find(|&c| (corner[c] - p).norm() < eps) {
        return Seat::Vertex(face[c]);
    }
    for k in 0..3 {
        let (a, b) = (corner[(k + 1) % 3], corner[(k + 2) % 3]);
        let ab = b - a;
        let t = ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
        if (a + ab * t - p).norm() < eps {
            return Seat::Edge(f);
        }
    }
    Seat::Face(f)
}

/// The direction a line leaves position `param` in (forward or backward) and the face it leaves into.
fn step_from(line: &Line, param: Real, forward: bool, at: &Point3) -> Option<(Vector3, u32)> {
    let n = line.faces.len();
    if n == 0 {
        return None;
    }
    let len = 1e-9 * (line.points[0] - line.points[n]).norm().max(1.0);
    let wrap = |j: isize| -> Option<usize> {
        if line.closed {
            Some(j.rem_euclid(n as isize) as usize)
        } else {
            (0..n as isize).contains(&j).then_some(j as usize)
        }
    };
    let param = if line.closed { param.rem_euclid(n as Real) } else { param };
    let mut j = if forward { param.floor() as isize } else { param.ceil() as isize - 1 };
    for _ in 0..n {
        let seg = wrap(j)?;
        let target = if forward { line.points[seg + 1] } else { line.points[seg] };
        let d = target - at;
        if d.norm() > len {
            return Some((d, line.faces[seg]));
        }
        j += if forward { 1 } else { -1 };
    }
    None
}

/// The angle of direction `d` (lying in face `f`) around a node seated at `seat`, counter-clockwise
/// about the outward normal, in a chart that unfolds the faces around the node into one plane.
fn polar_angle(s: &Surface, seat: Seat, d: &Vector3, f: u32) -> Real {
    let in_frame = |g: u32, v: &Vector3| {
        let (_, x, y) = face_frame(s, g);
        v.dot(&y).atan2(v.dot(&x))
    };
    match seat {
        Seat::Face(g) | Seat::Edge(g) => in_frame(g, &unfold_into(s, g, f, d)),
        Seat::Vertex(v) => {
            let Some((fan, _)) = s.fan(v) else {
                let (g, _) = s.corners_of(v)[0];
                return in_frame(g, d);
            };
            let pv = s.mesh.vertices[v as usize];
            // The corner whose sector holds d (in its plane), preferring d's own face: a line
            // through the vertex may name a face beside the one its direction enters.
            let mut total = 0.0;
            let mut before = None;
            let mut best_fit = Real::INFINITY;
            for &(g, m) in &fan {
                let face = s.mesh.faces[g as usize];
                let ea = s.mesh.vertices[face[(m as usize + 1) % 3] as usize] - pv;
                let eb = s.mesh.vertices[face[(m as usize + 2) % 3] as usize] - pv;
                let n = s.normal[g as usize];
                let corner = ea.angle(&eb);
                let a = ea.cross(d).dot(&n).atan2(ea.dot(d));
                let off = d.dot(&n).abs() / d.norm();
                let outside = if a < 0.0 { -a } else { (a - corner).max(0.0) };
                let fit = off + outside - if g == f { 1e-6 } else { 0.0 };
                if fit < best_fit {
                    best_fit = fit;
                    before = Some(total + a.clamp(0.0, corner));
                }
                total += corner;
            }
            match before {
                Some(a) if total > 0.0 => a / total * TAU,
                _ => 0.0,
            }
        }
    }
}

/// A direction `d` in face `f` carried into face `g`'s plane: as is in `g`; rotated about the shared
/// edge for a neighbour; rotated edge by edge around the shared vertex (counter-clockwise from `g`)
/// for a face that shares only a vertex; projected otherwise.
fn unfold_into(s: &Surface, g: u32, f: u32, d: &Vector3) -> Vector3 {
    if f == g {
        return *d;
    }
    if let Some(k) = shared_edge(s, g, f) {
        return unfold(s, g, k, d);
    }
    let gf = s.mesh.faces[g as usize];
    let ff = s.mesh.faces[f as usize];
    if let Some(&v) = gf.iter().find(|v| ff.contains(v))
        && let Some((fan, _)) = s.fan(v)
        && let (Some(ig), Some(i_f)) = (fan.iter().position(|c| c.0 == g), fan.iter().position(|c| c.0 == f))
    {
        // Faces from g to f going counter-clockwise; unfold from f back towards g.
        let n = fan.len();
        let mut path = Vec::new();
        let mut i = ig;
        while i != i_f {
            path.push(fan[i].0);
            i = (i + 1) % n;
        }
        path.push(f);
        let mut v3 = *d;
        for w in path.windows(2).rev() {
            match shared_edge(s, w[0], w[1]) {
                Some(k) => v3 = unfold(s, w[0], k, &v3),
                None => return *d,
            }
        }
        return v3;
    }
    *d
}

/// The edge index (in face `g`) that faces `g` and `f` share, if any.
fn shared_edge(s: &Surface, g: u32, f: u32) -> Option<usize> {
    (0..3).find(|&k| s.across(g, k).is_some_and(|(h, _)| h == f))
}

/// A direction in the face across edge `k` of `g`, rotated about that edge into `g`'s plane: the part
/// along the edge is kept, the part pointing into the other face points out of `g`.
fn unfold(s: &Surface, g: u32, k: usize, d: &Vector3) -> Vector3 {
    let face = s.mesh.faces[g as usize];
    let e = (s.mesh.vertices[face[(k + 2) % 3] as usize] - s.mesh.vertices[face[(k + 1) % 3] as usize]).normalize();
    let inward_g = s.normal[g as usize].cross(&e);
    let Some((h, _)) = s.across(g, k) else { return *d };
    let inward_h = s.normal[h as usize].cross(&-e);
    e * d.dot(&e) - inward_g * d.dot(&inward_h)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig::TriMesh;

    /// Faces are on one part only across an edge that two faces share: three fins on one edge, and
    /// a face touching another by a corner, are each apart.
    #[test]
    fn parts_join_across_edges_of_two_faces_only() {
        let p = |x: f64, y: f64, z: f64| Point3::new(x, y, z);
        let mesh = TriMesh {
            vertices: vec![
                p(0.0, 0.0, 0.0),
                p(1.0, 0.0, 0.0),
                p(0.5, 1.0, 0.0),
                p(0.5, -1.0, 0.0),
                p(0.5, 0.0, 1.0),
                p(1.5, 1.0, 0.0),
                p(2.0, -1.0, 0.0),
                p(3.0, -1.0, 0.0),
            ],
            // Fins 0, 1 and 2 share the edge 0–1; face 3 shares the edge 1–2 with fin 0 alone;
            // face 4 touches the others at vertex 1 only.
            faces: vec![[0, 1, 2], [1, 0, 3], [0, 1, 4], [1, 5, 2], [1, 6, 7]],
            normals: None,
        };
        let s = Surface::new(&mesh);
        let Parts(part) = Parts::of(&s);
        assert_eq!(part[0], part[3], "fin 0 and the face across its edge of two faces");
        let distinct: std::collections::HashSet<u32> = part.iter().copied().collect();
        assert_eq!(distinct.len(), 4, "{part:?}");
        assert!(part[1] != part[0] && part[2] != part[0] && part[1] != part[2] && part[4] != part[1], "{part:?}");
    }
}
