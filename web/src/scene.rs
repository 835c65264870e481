//! The viewer's scene: layers of points, triangles and line segments, decimated for display and
//! packed into the page as gzip-compressed binary blocks (see `assets/viewer.js` for the reading side).
//!
//! Positions are quantised to 16 bits per axis over the scene's bounds: a 300 mm object reads back
//! to within 0.003 mm, far below any scanner's noise, at half the bytes of `f32`. Large inputs are
//! decimated so the page stays light and the browser fast: clouds by an even stride (views stay
//! evenly represented, since clouds are stored view by view), meshes by vertex clustering.

use crate::escape::{esc, json_text};
use base64::Engine as _;
use rayon::prelude::*;
use rig::math::{Point3, Real};
use serde_json::{Value, json};
use std::collections::HashMap;
use std::fmt::Write as _;

/// The canvas' clear colour (the browser test counts pixels that differ from it).
pub const BACKGROUND: &str = "#1e1f24";

/// Display limits: a page of the demo (3.1 M points, 400 K triangles) stays under 25 MB.
#[derive(Debug, Clone, Copy)]
pub struct Limits {
    /// Points drawn per cloud layer at most.
    pub points: usize,
    /// Triangles drawn per mesh at most.
    pub triangles: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits { points: 600_000, triangles: 700_000 }
    }
}

enum Block {
    Positions(Vec<[f32; 3]>),
    Bytes(Vec<u8>),
}

/// A mesh's geometry already in the scene, for another layer to colour differently.
#[derive(Debug, Clone, Copy)]
pub struct MeshGeometry {
    position: usize,
    index: usize,
    triangles: usize,
    /// Vertices drawn (after decimation).
    pub vertices: usize,
}

/// A mesh's vertices and triangles after display decimation, and which input vertex each drawn
/// vertex stands for (so per-vertex values can follow).
pub struct DisplayMesh {
    /// Drawn vertices.
    pub vertices: Vec<Point3>,
    /// Drawn triangles.
    pub faces: Vec<[u32; 3]>,
    /// For each drawn vertex, the input vertices it merges (one each when not decimated).
    pub members: Vec<Vec<u32>>,
}

/// The layers of one viewer.
#[derive(Default)]
pub struct Scene {
    blocks: Vec<Block>,
    layers: Vec<Value>,
    notes: Vec<String>,
    /// The display limits.
    pub limits: Limits,
    camera_frame: bool,
}

impl std::fmt::Debug for Scene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Scene({} layers, {} blocks)", self.layers.len(), self.blocks.len())
    }
}

fn rgb_bytes(c: &[[u8; 3]]) -> Vec<u8> {
    c.iter().flatten().copied().collect()
}

fn index_bytes(idx: impl Iterator<Item = u32>) -> Vec<u8> {
    idx.flat_map(u32::to_le_bytes).collect()
}

fn f32s(p: &[Point3]) -> Vec<[f32; 3]> {
    p.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect()
}

/// Thousands separated by thin spaces, for notes.
pub fn count(n: usize) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push('\u{2009}');
        }
        out.push(c);
    }
    out
}

impl Scene {
    /// An empty scene with the default limits.
    pub fn new() -> Self {
        Scene::default()
    }

    fn block(&mut self, b: Block) -> usize {
        self.blocks.push(b);
        self.blocks.len() - 1
    }

    /// The scene is in a camera's frame (x right, y down, z forward) rather than the turntable's
    /// (z up): the view is oriented to match.
    pub fn set_camera_frame(&mut self) {
        self.camera_frame = true;
    }

    /// A note shown under the viewer (plain text).
    pub fn note(&mut self, text: String) {
        self.notes.push(text);
    }

    /// Layers so far.
    pub fn layer_count(&self) -> usize {
        self.layers.len()
    }

    /// Adds a cloud, every `n / limit`-th point when it has more than the limit (said in a note).
    /// Layers of one `group` show one at a time. Returns the points drawn.
    pub fn add_points(
        &mut self,
        name: &str,
        points: &[Point3],
        colours: Option<&[[u8; 3]]>,
        visible: bool,
        group: Option<&str>,
    ) -> usize {
        let n = points.len();
        let keep: Vec<usize> = if n > self.limits.points {
            (0..self.limits.points).map(|k| k * n / self.limits.points).collect()
        } else {
            (0..n).collect()
        };
        if keep.len() < n {
            self.note(format!(
                "{name}: {} of its {} points drawn (an even sample, for display); the file has them all.",
                count(keep.len()),
                count(n)
            ));
        }
        let pos: Vec<Point3> = keep.iter().map(|&i| points[i]).collect();
        let position = self.block(Block::Positions(f32s(&pos)));
        let colour = colours
            .filter(|c| c.len() == n)
            .map(|c| self.block(Block::Bytes(keep.iter().flat_map(|&i| c[i]).collect())));
        self.push_layer(name, "points", position, None, colour, keep.len(), visible, None, group);
        keep.len()
    }

    /// Adds a mesh, decimated to the triangle limit by vertex clustering (said in a note), coloured
    /// per input vertex when `colours` are given. Returns its geometry for other colourings, and for
    /// each drawn vertex the input vertices it stands for.
    pub fn add_mesh(
        &mut self,
        name: &str,
        input: &rig::TriMesh,
        colours: Option<&[[u8; 3]]>,
        visible: bool,
        group: Option<&str>,
    ) -> (MeshGeometry, Vec<Vec<u32>>) {
        let mesh = display_mesh(&input.vertices, &input.faces, self.limits.triangles);
        if mesh.faces.len() < input.faces.len() {
            self.note(format!(
                "{name}: {} of its {} triangles drawn (vertices clustered, for display); the file has them all.",
                count(mesh.faces.len()),
                count(input.faces.len())
            ));
        }
        let position = self.block(Block::Positions(f32s(&mesh.vertices)));
        let index = self.block(Block::Bytes(index_bytes(mesh.faces.iter().flatten().copied())));
        let geometry = MeshGeometry { position, index, triangles: mesh.faces.len(), vertices: mesh.vertices.len() };
        let colour = colours.map(|c| self.block(Block::Bytes(rgb_bytes(&average_colours(&mesh, c)))));
        self.push_layer(name, "mesh", position, Some(index), colour, mesh.faces.len(), visible, None, group);
        (geometry, mesh.members)
    }

    /// Adds another colouring of a mesh already added (`colours` per drawn vertex), with a legend
    /// (trusted SVG/HTML) shown while the layer is.
    pub fn add_mesh_colouring(
        &mut self,
        name: &str,
        geometry: MeshGeometry,
        colours: &[[u8; 3]],
        legend: String,
        visible: bool,
        group: Option<&str>,
    ) {
        assert_eq!(colours.len(), geometry.vertices, "one colour per drawn vertex");
        let colour = self.block(Block::Bytes(rgb_bytes(colours)));
        self.push_layer(
            name,
            "mesh",
            geometry.position,
            Some(geometry.index),
            Some(colour),
            geometry.triangles,
            visible,
            Some(legend),
            group,
        );
    }

    /// Adds line segments, each with its colour.
    pub fn add_lines(&mut self, name: &str, segments: &[(Point3, Point3, [u8; 3])], visible: bool) {
        let pos: Vec<Point3> = segments.iter().flat_map(|s| [s.0, s.1]).collect();
        let colours: Vec<[u8; 3]> = segments.iter().flat_map(|s| [s.2, s.2]).collect();
        let position = self.block(Block::Positions(f32s(&pos)));
        let index = self.block(Block::Bytes(index_bytes(0..pos.len() as u32)));
        let colour = self.block(Block::Bytes(rgb_bytes(&colours)));
        self.push_layer(name, "lines", position, Some(index), Some(colour), segments.len(), visible, None, None);
    }

    #[allow(clippy::too_many_arguments)]
    fn push_layer(
        &mut self,
        name: &str,
        kind: &str,
        position: usize,
        index: Option<usize>,
        colour: Option<usize>,
        count: usize,
        visible: bool,
        legend: Option<String>,
        group: Option<&str>,
    ) {
        let id = |b: usize| format!("block-{b}");
        self.layers.push(json!({
            "name": name, "kind": kind, "position": id(position), "index": index.map(id),
            "colour": colour.map(id), "count": count, "visible": visible, "legend": legend, "group": group,
        }));
    }

    /// The bounds of every position in the scene (the quantisation box).
    fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for b in &self.blocks {
            if let Block::Positions(p) = b {
                for q in p.iter().filter(|q| q.iter().all(|c| c.is_finite())) {
                    for k in 0..3 {
                        lo[k] = lo[k].min(q[k]);
                        hi[k] = hi[k].max(q[k]);
                    }
                }
            }
        }
        if lo[0] > hi[0] {
            return ([0.0; 3], [1.0; 3]);
        }
        for k in 0..3 {
            // A flat scene (a board, a plane) still needs a non-zero box to quantise over.
            hi[k] = hi[k].max(lo[k] + 1e-3);
        }
        (lo, hi)
    }

    /// The notes under the viewer, as HTML.
    pub fn notes_html(&self) -> String {
        let (lo, hi) = self.bounds();
        let step = (0..3).map(|k| (hi[k] - lo[k]) / 65535.0).fold(0.0f32, f32::max);
        let mut h = String::new();
        for n in &self.notes {
            let _ = write!(h, "<p class=\"note\">{}</p>", esc(n));
        }
        let _ = write!(
            h,
            "<p class=\"note\">Coordinates shown are rounded to {:.4} mm for display (the files keep full precision).</p>",
            step / 2.0
        );
        h
    }

    /// The scene description and its blocks, as the `<script>` elements the viewer reads.
    pub fn data_html(&self) -> String {
        let (lo, hi) = self.bounds();
        let spec = json!({
            "background": BACKGROUND, "units": "mm",
            "bounds": {"min": lo, "max": hi}, "layers": self.layers,
            // Up on screen, and where the first view looks from (relative to the centre).
            "up": if self.camera_frame { [0.0, -1.0, 0.0] } else { [0.0, 0.0, 1.0] },
            "home": if self.camera_frame { [0.9, -0.8, -1.6] } else { [1.0, -1.4, 0.9] },
        });
        let mut h = format!(
            "<script type=\"application/json\" id=\"scene\">{}</script>",
            json_text(&serde_json::to_string(&spec).unwrap_or_default())
        );
        let b64 = base64::engine::general_purpose::STANDARD;
        // Compressed side by side: deflating a 3 M-point scene's blocks one after another was a
        // third of the page's time.
        let encoded: Vec<String> = self
            .blocks
            .par_iter()
            .map(|b| match b {
                Block::Bytes(v) => b64.encode(gzip(v)),
                Block::Positions(p) => b64.encode(gzip(&quantise(p, lo, hi))),
            })
            .collect();
        for (i, bytes) in encoded.iter().enumerate() {
            let _ = write!(h, "<script type=\"application/octet-stream\" id=\"block-{i}\">{bytes}</script>");
        }
        h
    }
}

/// A block gzip-compressed: triangle indices and quantised positions shrink to about half, and the
/// browser inflates them natively (`DecompressionStream`).
fn gzip(bytes: &[u8]) -> Vec<u8> {
    use std::io::Write as _;
    let mut e = flate2::write::GzEncoder::new(Vec::with_capacity(bytes.len() / 2), flate2::Compression::fast());
    // Writing to a Vec cannot fail.
    let _ = e.write_all(bytes);
    e.finish().unwrap_or_default()
}

/// Positions as little-endian u16 triples over `lo..hi` (non-finite values go to the box's corner).
fn quantise(p: &[[f32; 3]], lo: [f32; 3], hi: [f32; 3]) -> Vec<u8> {
    let mut out = Vec::with_capacity(p.len() * 6);
    for q in p {
        for k in 0..3 {
            let t = ((q[k] - lo[k]) / (hi[k] - lo[k])).clamp(0.0, 1.0);
            let t = if t.is_finite() { t } else { 0.0 };
            out.extend(((t * 65535.0).round() as u16).to_le_bytes());
        }
    }
    out
}

/// The mean colour of each drawn vertex's members.
fn average_colours(mesh: &DisplayMesh, colours: &[[u8; 3]]) -> Vec<[u8; 3]> {
    mesh.members
        .iter()
        .map(|m| {
            let mut s = [0u32; 3];
            let mut n = 0;
            for &v in m {
                if let Some(c) = colours.get(v as usize) {
                    (0..3).for_each(|k| s[k] += c[k] as u32);
                    n += 1;
                }
            }
            let n = n.max(1);
            [(s[0] / n) as u8, (s[1] / n) as u8, (s[2] / n) as u8]
        })
        .collect()
}

/// A mesh for display: itself when it has at most `max_triangles`, else clustered on a grid
/// coarse enough to bring it under (each cluster's vertices merged at their mean; triangles that
/// collapse dropped).
pub fn display_mesh(vertices: &[Point3], faces: &[[u32; 3]], max_triangles: usize) -> DisplayMesh {
    if faces.len() <= max_triangles {
        return DisplayMesh {
            vertices: vertices.to_vec(),
            faces: faces.to_vec(),
            members: (0..vertices.len() as u32).map(|v| vec![v]).collect(),
        };
    }
    let (mut lo, mut hi) = (Point3::from([Real::INFINITY; 3]), Point3::from([Real::NEG_INFINITY; 3]));
    for v in vertices {
        lo = lo.inf(v);
        hi = hi.sup(v);
    }
    let diag = (hi - lo).norm().max(1e-9);
    // A surface of n triangles at spacing s has about diag²/s² of them: start at the cell that would
    // give the limit, and coarsen until it does.
    let mut cell = diag / (max_triangles as Real).sqrt();
    loop {
        let m = cluster(vertices, faces, lo, cell);
        if m.faces.len() <= max_triangles {
            return m;
        }
        cell *= 1.25;
    }
}

fn cluster(vertices: &[Point3], faces: &[[u32; 3]], lo: Point3, cell: Real) -> DisplayMesh {
    let mut ids: HashMap<[i64; 3], u32> = HashMap::new();
    let mut members: Vec<Vec<u32>> = Vec::new();
    let of: Vec<u32> = vertices
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let key = [0, 1, 2].map(|k| ((v[k] - lo[k]) / cell).floor() as i64);
            let id = *ids.entry(key).or_insert_with(|| {
                members.push(Vec::new());
                (members.len() - 1) as u32
            });
            members[id as usize].push(i as u32);
            id
        })
        .collect();
    let centres: Vec<Point3> = members
        .iter()
        .map(|m| {
            Point3::from(m.iter().map(|&i| vertices[i as usize].coords).sum::<rig::math::Vector3>() / m.len() as Real)
        })
        .collect();
    let mut seen = std::collections::HashSet::new();
    let mut out = Vec::new();
    for f in faces {
        let t = f.map(|v| of[v as usize]);
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            continue;
        }
        let mut key = t;
        key.sort_unstable();
        if seen.insert(key) {
            out.push(t);
        }
    }
    DisplayMesh { vertices: centres, faces: out, members }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere(n: usize) -> (Vec<Point3>, Vec<[u32; 3]>) {
        // A UV sphere of radius 50: n rings of 2n vertices.
        let mut v = Vec::new();
        for i in 0..=n {
            let th = std::f64::consts::PI * i as f64 / n as f64;
            for j in 0..2 * n {
                let ph = std::f64::consts::PI * j as f64 / n as f64;
                v.push(Point3::new(50.0 * th.sin() * ph.cos(), 50.0 * th.sin() * ph.sin(), 50.0 * th.cos()));
            }
        }
        let mut f = Vec::new();
        let id = |i: usize, j: usize| (i * 2 * n + j % (2 * n)) as u32;
        for i in 0..n {
            for j in 0..2 * n {
                f.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                f.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        (v, f)
    }

    #[test]
    fn decimated_mesh_stays_on_the_surface_and_under_the_limit() {
        let (v, f) = sphere(200);
        let m = display_mesh(&v, &f, 20_000);
        assert!(m.faces.len() <= 20_000 && m.faces.len() > 5_000, "{} triangles", m.faces.len());
        // Cluster means lie just inside a convex surface, never far from it.
        let worst = m.vertices.iter().map(|p| (50.0 - p.coords.norm()).abs()).fold(0.0, f64::max);
        assert!(worst < 1.5, "a drawn vertex {worst} mm off the sphere");
        assert_eq!(m.members.iter().map(Vec::len).sum::<usize>(), v.len(), "every vertex in one cluster");
        let small = display_mesh(&v[..10], &f[..2], 20_000);
        assert_eq!(small.faces.len(), 2, "a small mesh is drawn as it is");
    }

    #[test]
    fn quantised_positions_read_back_within_half_a_step() {
        let p = vec![[0.0f32, -10.0, 5.0], [300.0, 10.0, 5.0005], [123.456, 0.0, 5.0]];
        let (lo, hi) = ([0.0, -10.0, 5.0], [300.0, 10.0, 5.0005]);
        let q = quantise(&p, lo, hi);
        for (i, pt) in p.iter().enumerate() {
            for k in 0..3 {
                let u = u16::from_le_bytes([q[6 * i + 2 * k], q[6 * i + 2 * k + 1]]) as f32;
                let back = lo[k] + u / 65535.0 * (hi[k] - lo[k]);
                assert!((back - pt[k]).abs() <= 0.5 * (hi[k] - lo[k]) / 65535.0 + 1e-4, "{back} vs {}", pt[k]);
            }
        }
    }

    #[test]
    fn large_clouds_are_sampled_and_said_to_be() {
        let pts: Vec<Point3> = (0..1000).map(|i| Point3::new(i as f64, 0.0, 0.0)).collect();
        let mut s = Scene::new();
        s.limits.points = 100;
        assert_eq!(s.add_points("cloud", &pts, None, true, None), 100);
        assert!(s.notes_html().contains("100 of its 1\u{2009}000 points"));
        let data = s.data_html();
        assert!(data.contains("id=\"scene\"") && data.contains("id=\"block-0\""));
    }
}
