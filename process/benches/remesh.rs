//! Quad remeshing speed (issue 10's benchmark): the field solve on the armadillo subdivided once
//! (~346 K triangles) — the harmonic field of eq. 6.2 alone, and with feature-line rows (eq. 6.3) in
//! the least-squares system — and the whole remesh of the armadillo (86 K triangles) and of its
//! subdivision, each the median of 3 runs with its phases.
//!
//! `cargo bench -p process --bench remesh` — skips with a message where ../shared/data is absent.

use process::remesh::harmonic::{constrained_field, harmonic_field};
use process::remesh::{RemeshParams, remesh};
use rig::TriMesh;
use rig::math::Point3;
use std::collections::HashMap;
use std::time::Instant;

/// Each triangle split into four at its edge midpoints: the same surface, four times the faces.
fn subdivide(m: &TriMesh) -> TriMesh {
    let mut out = TriMesh { vertices: m.vertices.clone(), faces: Vec::with_capacity(4 * m.faces.len()), normals: None };
    let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
    let mut midpoint = |a: u32, b: u32, out: &mut TriMesh| {
        *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
            let (p, q) = (out.vertices[a as usize], out.vertices[b as usize]);
            out.vertices.push(Point3::from((p.coords + q.coords) / 2.0));
            out.vertices.len() as u32 - 1
        })
    };
    for &[a, b, c] in &m.faces {
        let (ab, bc, ca) = (midpoint(a, b, &mut out), midpoint(b, c, &mut out), midpoint(c, a, &mut out));
        out.faces.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
    }
    out
}

fn median<T>(mut runs: Vec<(f64, T)>) -> (f64, T) {
    runs.sort_by(|a, b| a.0.total_cmp(&b.0));
    runs.swap_remove(1)
}

fn main() {
    let Some(path) = fixtures::mesh("libigl-tutorial-data/armadillo.obj") else { return };
    let armadillo = rig::read_mesh(&path).expect("armadillo reads").triangulate();
    let fine = subdivide(&armadillo);
    println!(
        "armadillo {} triangles, subdivided {} triangles; {} rayon threads",
        armadillo.faces.len(),
        fine.faces.len(),
        rayon::current_num_threads()
    );

    // Poles at the lowest and highest vertex; the feature lines of the default remesh as rows.
    let lowest = (0..fine.vertices.len()).min_by(|&a, &b| fine.vertices[a].y.total_cmp(&fine.vertices[b].y)).unwrap();
    let highest = (0..fine.vertices.len()).max_by(|&a, &b| fine.vertices[a].y.total_cmp(&fine.vertices[b].y)).unwrap();
    let fixed = [(lowest, 0.0), (highest, 1.0)];
    let (s, _) = median(
        (0..3)
            .map(|_| {
                let t = Instant::now();
                std::hint::black_box(harmonic_field(&fine, None, &fixed).expect("solves"));
                (t.elapsed().as_secs_f64(), ())
            })
            .collect(),
    );
    println!("harmonic field (eq. 6.2), {} unknowns: {s:.2} s", fine.vertices.len() - 2);
    let lines: Vec<(usize, usize)> = process::remesh::features::feature_edges(&fine, 30.0);
    let (s, _) = median(
        (0..3)
            .map(|_| {
                let t = Instant::now();
                std::hint::black_box(constrained_field(&fine, None, &fixed, &lines, 10.0).expect("solves"));
                (t.elapsed().as_secs_f64(), ())
            })
            .collect(),
    );
    println!("with {} constraint edges as least-squares rows (eq. 6.3): {s:.2} s", lines.len());

    for (name, mesh) in [("armadillo", &armadillo), ("armadillo subdivided", &fine)] {
        let (s, r) = median(
            (0..3)
                .map(|_| {
                    let t = Instant::now();
                    let (quads, r) = remesh(mesh, &RemeshParams::default()).expect("remeshes");
                    std::hint::black_box(quads);
                    (t.elapsed().as_secs_f64(), r)
                })
                .collect(),
        );
        println!(
            "remesh {name}: {s:.2} s (field {:.2}, streamlines {:.2}, quads {:.2}, quality report {:.2}); \
             {} faces, {:.1} % quads, {} constraint lines",
            r.seconds.field,
            r.seconds.streamlines,
            r.seconds.quads,
            r.seconds.quality,
            r.quality.faces,
            100.0 * r.quality.quad_fraction,
            r.contour_constraints + r.gradient_constraints
        );
    }
}
