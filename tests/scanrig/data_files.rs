//! Every real file in `../shared/data` reads with the counts its README states. Skips with a message
//! where the data folder is absent.

use fixtures::{BUNNY_SCANS, require};
use std::collections::HashMap;

fn info_json(path: &std::path::Path) -> serde_json::Value {
    let out = crate::run::scanrig(&[&"info", &path, &"--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn scanrig_info_reports_each_bunny_scan_and_its_range_grid() {
    // Vertex counts from stanford-bunny/README.md.
    let counts = [40256, 40097, 30379, 40251, 31701, 35336, 37738, 32193, 38298, 36023];
    let mut total = 0;
    for (name, count) in BUNNY_SCANS.iter().zip(counts) {
        let path = require!(fixtures::bunny_scan(name));
        let info = info_json(&path);
        assert_eq!(info["vertices"], count, "{name}");
        assert_eq!(info["range_grid"]["width"], 512, "{name}");
        assert_eq!(info["range_grid"]["height"], 400, "{name}");
        assert_eq!(info["range_grid"]["valid"], count, "{name}: valid cells equal the vertex count");
        assert_eq!(info["units"], "m", "{name}: Cyberware data is in metres");
        total += count;
    }
    assert_eq!(total, 362_272);
}

#[test]
fn bunny_zipper_has_its_vertex_and_triangle_counts() {
    let path = require!(fixtures::data_file("stanford-bunny/reconstruction/bun_zipper.ply"));
    let info = info_json(&path);
    assert_eq!(info["vertices"], 35_947);
    assert_eq!(info["faces"]["triangles"], 69_451);
    assert_eq!(info["faces"]["total"], 69_451);
}

#[test]
fn bunny_range_grid_cells_hold_their_vertices() {
    let path = require!(fixtures::bunny_scan("bun000"));
    let grid = rig::ply::read_range_grid(&path).unwrap();
    let cloud = rig::ply::read_cloud(&path).unwrap();
    assert_eq!(grid.valid_count(), cloud.len());
    // Each valid cell holds a distinct vertex of the file, and together they are all of them.
    let mut seen: Vec<[u64; 3]> =
        grid.to_point_cloud().positions.iter().map(|p| p.coords.map(f64::to_bits).into()).collect();
    let mut all: Vec<[u64; 3]> = cloud.positions.iter().map(|p| p.coords.map(f64::to_bits).into()).collect();
    seen.sort();
    all.sort();
    assert_eq!(seen, all);
}

/// (path under ../shared/data, vertices, faces, triangles, quads) from the two models READMEs.
const MESHES: &[(&str, usize, usize, usize, usize)] = &[
    ("common-3d-test-models/fandisk.obj", 6475, 12946, 12946, 0),
    ("common-3d-test-models/spot/spot_triangulated.obj", 2930, 5856, 5856, 0),
    ("common-3d-test-models/spot/spot_quadrangulated.obj", 2930, 2928, 0, 2928),
    ("common-3d-test-models/spot/spot_control_mesh.obj", 188, 180, 4, 160),
    ("common-3d-test-models/horse.ply", 48485, 96966, 96966, 0),
    ("common-3d-test-models/rocker-arm.off", 10044, 20088, 20088, 0),
    ("common-3d-test-models/beetle.obj", 1148, 2053, 2053, 0),
    ("common-3d-test-models/suzanne.obj", 507, 500, 32, 468),
    ("common-3d-test-models/teapot.obj", 3644, 6320, 6320, 0),
    ("libigl-tutorial-data/armadillo.obj", 43243, 86482, 86482, 0),
    ("libigl-tutorial-data/fertility.off", 4494, 9000, 9000, 0),
    ("libigl-tutorial-data/fandisk.off", 7229, 14454, 14454, 0),
    ("libigl-tutorial-data/camelhead.off", 11381, 22704, 22704, 0),
    ("libigl-tutorial-data/horse_quad.obj", 2400, 2398, 0, 2398),
    ("libigl-tutorial-data/lilium.obj", 3389, 6590, 6590, 0),
    ("libigl-tutorial-data/bumpy-cube.obj", 19970, 39936, 39936, 0),
    ("libigl-tutorial-data/bunny.off", 3485, 6966, 6966, 0),
    ("libigl-tutorial-data/cheburashka.off", 6669, 13334, 13334, 0),
    ("libigl-tutorial-data/decimated-knight.off", 502, 1000, 1000, 0),
    ("libigl-tutorial-data/lion.off", 8356, 16674, 16674, 0),
    ("libigl-tutorial-data/screwdriver.off", 3395, 6786, 6786, 0),
];

#[test]
fn every_model_reads_with_its_readme_counts() {
    for &(rel, v, f, tris, quads) in MESHES {
        let path = require!(fixtures::mesh(rel));
        let mesh = rig::read_mesh(&path).unwrap_or_else(|e| panic!("{e}"));
        let sizes = mesh.face_sizes();
        assert_eq!((mesh.vertices.len(), mesh.face_count()), (v, f), "{rel}");
        assert_eq!((sizes.triangles, sizes.quads), (tris, quads), "{rel}");
    }
}

/// Euler characteristic and orientation of a triangle mesh: (V − E + F, whether every edge has exactly
/// two faces that traverse it in opposite directions).
fn euler_and_orientation(m: &rig::PolyMesh) -> (i64, bool) {
    let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
    for f in m.faces() {
        for k in 0..f.len() {
            *directed.entry((f[k], f[(k + 1) % f.len()])).or_default() += 1;
        }
    }
    let closed_oriented = directed.iter().all(|(&(a, b), &n)| n == 1 && directed.get(&(b, a)) == Some(&1));
    let edges = directed.keys().filter(|(a, b)| a < b || !directed.contains_key(&(*b, *a))).count();
    (m.vertices.len() as i64 - edges as i64 + m.face_count() as i64, closed_oriented)
}

#[test]
fn tristrip_meshes_become_consistently_oriented_triangles() {
    // igea: 134,345 vertices in one strip; a closed genus-0 scan, so its triangles must form a closed,
    // consistently oriented surface with Euler characteristic 2 — which fails if strip parity is wrong.
    let igea = require!(fixtures::mesh("common-3d-test-models/igea.ply"));
    let m = rig::read_mesh(&igea).unwrap();
    assert_eq!(m.vertices.len(), 134_345);
    assert_eq!(m.face_count(), 2 * 134_345 - 4);
    assert_eq!(euler_and_orientation(&m), (2, true));

    let cow = require!(fixtures::mesh("common-3d-test-models/cow.ply"));
    let m = rig::read_mesh(&cow).unwrap();
    assert_eq!(m.vertices.len(), 2903);
    assert_eq!(m.face_sizes().triangles, m.face_count());
    assert!(m.face_count() > 5000, "{} triangles", m.face_count());
    // The cow is open, but every interior edge must still be traversed once each way.
    let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
    for f in m.faces() {
        for k in 0..3 {
            *directed.entry((f[k], f[(k + 1) % 3])).or_default() += 1;
        }
    }
    assert!(directed.values().all(|&n| n == 1), "an edge is traversed twice in the same direction");
}
