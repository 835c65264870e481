//! 07 — Quad remeshing (thesis ch. 6) of a box: a harmonic field and its streamlines in two families,
//! the quads they bound, measured for squareness and distance from the box.
//!
//! `cargo run --release --example 07_remesh`

use process::pipeline::stages::remesh;
use process::remesh::RemeshParams;
use rig::math::{Point3, Vector3};

fn main() {
    let box_mesh = fixtures::box_mesh(Point3::origin(), Vector3::new(30.0, 20.0, 10.0));
    let (quads, report) = remesh(&box_mesh, &RemeshParams::default()).unwrap();
    let q = &report.quality;
    println!(
        "{} triangles → {} faces, {:.1} % quads, corners {:.1}° from square on average, within {:.3} of the diagonal of the box",
        box_mesh.faces.len(),
        quads.face_count(),
        100.0 * q.quad_fraction,
        q.mean_angle_error_deg,
        q.hausdorff_relative
    );
    assert!(q.quad_fraction > 0.9 && q.hausdorff_relative < 0.02, "{q:?}");
}
