//! 06 — A watertight mesh of an oriented point cloud (a sphere's samples), by the mesh stage
//! `scanrig process` runs: FFT reconstruction (thesis ch. 5, eqs. 5.16–5.17), finish, support check,
//! and the mesh measured against the sphere.
//!
//! `cargo run --release --example 06_reconstruct`

use process::pipeline::stages::{MeshParams, mesh};
use rig::PointCloud;
use rig::math::Point3;
use rig::topology::topology;

fn main() {
    let radius = 40.0;
    let mut rng = fixtures::Rng::new(6);
    let normals: Vec<_> = (0..40_000).map(|_| rng.direction()).collect();
    let positions = normals.iter().map(|n| Point3::from(n * radius)).collect();
    let cloud = PointCloud { normals: Some(normals), ..PointCloud::from_positions(positions) };
    let params = MeshParams {
        reconstruct: Default::default(),
        finish: Default::default(),
        platter_z: None,
        top_z: None,
        force: false,
    };
    let made = mesh(&cloud, &params).unwrap();
    let t = topology(&made.mesh);
    let worst = made.mesh.vertices.iter().map(|v| (v.coords.norm() - radius).abs()).fold(0.0, f64::max);
    println!(
        "{} triangles on a {}³ grid (cell {:.3} mm): farthest vertex {worst:.3} mm from the sphere; genus {:?}",
        made.mesh.faces.len(),
        made.report.reconstruct.n(),
        made.report.reconstruct.cell(),
        t.genus()
    );
    assert_eq!(t.genus(), Some(0), "the sphere's mesh is one closed surface without handles");
    assert!(worst < made.report.reconstruct.cell(), "a vertex strays more than a cell from the sphere");
}
