//! Point-to-mesh distance queries (`process::mesh_distance`) near and far from the mesh: the simulator's
//! fluted vase (120 mm, 43,200 triangles) indexed with 2 mm cells, as the report page and the
//! accuracy tests index a truth mesh, and 20,000 queries at each distance from its surface (points
//! of the surface moved along their normals, half outward, half inward).
//!
//! `cargo bench -p process --bench mesh_distance`

use process::mesh_distance::MeshDistance;
use rig::math::Point3;
use std::time::Instant;

fn main() {
    let vase = sim::object::fluted_vase(120.0);
    let t0 = Instant::now();
    let index = MeshDistance::new(&vase, 2.0);
    let built = t0.elapsed().as_secs_f64() * 1e3;
    println!("vase: {} triangles, index built in {built:.1} ms", vase.faces.len());
    let surface = fixtures::surface_points(&vase, 20_000, 7);
    let normals: Vec<rig::math::Vector3> =
        surface.iter().map(|p| index.triangle_normal(index.nearest(p).unwrap().1)).collect();
    for offset in [0.5, 5.0, 20.0, 60.0] {
        let queries: Vec<Point3> = surface
            .iter()
            .zip(&normals)
            .enumerate()
            .map(|(i, (p, n))| p + n * if i % 2 == 0 { offset } else { -offset })
            .collect();
        // Medians of 5 passes over the queries, one thread (the callers run queries in parallel).
        let mut times: Vec<f64> = (0..5)
            .map(|_| {
                let s = Instant::now();
                let sum: f64 = queries.iter().map(|q| index.distance(q)).sum();
                std::hint::black_box(sum);
                s.elapsed().as_secs_f64() * 1e6 / queries.len() as f64
            })
            .collect();
        times.sort_by(f64::total_cmp);
        println!(
            "{offset:>5} mm off the surface: {:.2} µs per query (median of 5 passes of {})",
            times[2],
            queries.len()
        );
    }
}
