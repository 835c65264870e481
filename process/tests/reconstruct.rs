//! Issue 9: global FFT reconstruction against analytic shapes, fertility and the real bunny.

use process::normals::{PointTree, pca_normals};
use process::reconstruct::global_fft::{FftParams, reconstruct_fft};
use rig::math::{Point3, Real, Vector3};
use rig::topology::topology;
use rig::{PointCloud, TriMesh};

#[path = "support/surface.rs"]
mod surface;

/// Area-weighted samples of a mesh with the face normals (seeded).
fn sample_mesh(m: &TriMesh, count: usize, seed: u64) -> PointCloud {
    let mut rng = fixtures::Rng::new(seed);
    let areas: Vec<Real> = m
        .faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|i| m.vertices[i as usize]);
            (b - a).cross(&(c - a)).norm() / 2.0
        })
        .collect();
    let total: Real = areas.iter().sum();
    let mut cdf = Vec::with_capacity(areas.len());
    let mut acc = 0.0;
    for a in &areas {
        acc += a / total;
        cdf.push(acc);
    }
    let mut cloud = PointCloud { normals: Some(Vec::new()), ..Default::default() };
    for _ in 0..count {
        let u = rng.uniform();
        let f = m.faces[cdf.partition_point(|&c| c < u).min(m.faces.len() - 1)];
        let [a, b, c] = f.map(|i| m.vertices[i as usize]);
        let (mut s, mut t) = (rng.uniform(), rng.uniform());
        if s + t > 1.0 {
            (s, t) = (1.0 - s, 1.0 - t);
        }
        cloud.positions.push(a + (b - a) * s + (c - a) * t);
        cloud.normals.as_mut().unwrap().push((b - a).cross(&(c - a)).normalize());
    }
    cloud
}

/// Hausdorff distance between a mesh and the truth, both ways, sampled.
fn hausdorff(mesh: &TriMesh, truth: &TriMesh, cell: Real) -> Real {
    let to_truth = surface::SurfaceDistance::new(truth, 2.0 * cell);
    let to_mesh = surface::SurfaceDistance::new(mesh, 2.0 * cell);
    let a = mesh.vertices.iter().map(|p| to_truth.distance(p)).fold(0.0, Real::max);
    let b = sample_mesh(truth, 20_000, 9).positions.iter().map(|p| to_mesh.distance(p)).fold(0.0, Real::max);
    a.max(b)
}

fn torus_mesh(big: Real, small: Real, u: usize, v: usize) -> TriMesh {
    let mut m = TriMesh::default();
    for i in 0..u {
        for j in 0..v {
            let (a, b) = (std::f64::consts::TAU * i as Real / u as Real, std::f64::consts::TAU * j as Real / v as Real);
            let r = big + small * b.cos();
            m.vertices.push(Point3::new(r * a.cos(), r * a.sin(), small * b.sin()));
        }
    }
    let id = |i: usize, j: usize| ((i % u) * v + j % v) as u32;
    for i in 0..u {
        for j in 0..v {
            m.faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            m.faces.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    m
}

fn check_shape(name: &str, truth: &TriMesh, points: usize, depth: u32, genus: i64) {
    let cloud = sample_mesh(truth, points, 3);
    let (mesh, report) = reconstruct_fft(&cloud, &FftParams { depth, ..Default::default() }).unwrap();
    let t = topology(&mesh);
    let h = hausdorff(&mesh, truth, report.cell);
    eprintln!(
        "{name}: {}³ grid, cell {:.3}: {} triangles, genus {:?}, {} components, Hausdorff {h:.3} = {:.2} cells",
        report.n,
        report.cell,
        mesh.faces.len(),
        t.genus(),
        t.components,
        h / report.cell
    );
    assert!(t.is_closed_oriented_manifold(), "{name}: {t:?}");
    assert_eq!((t.genus(), t.components), (Some(genus), 1), "{name}");
    assert!(h <= report.cell, "{name}: Hausdorff {h} > cell {}", report.cell);
}

#[test]
fn torus_and_fertility_come_back_with_their_genus_within_a_cell() {
    check_shape("torus", &torus_mesh(30.0, 10.0, 200, 80), 60_000, 7, 1);
    let Some(path) = fixtures::mesh("libigl-tutorial-data/fertility.off") else { return };
    let fertility = rig::read_mesh(&path).unwrap().triangulate();
    check_shape("fertility", &fertility, 200_000, 8, 4);
}

#[test]
fn bunny_scans_reconstruct_close_to_the_zipper_mesh() {
    // Sensor-oriented: each scan looks down its own −z, so normals face +z in its frame.
    let (Some(cloud), Some(zipper)) = (
        fixtures::bunny_aligned_mm(|p| pca_normals(p, &PointTree::new(p), 10, |_| Vector3::z())),
        fixtures::data_file("stanford-bunny/reconstruction/bun_zipper.ply"),
    ) else {
        return;
    };
    let zipper = surface::zipper_mm(&zipper);
    let start = std::time::Instant::now();
    let mut params = FftParams { depth: 8, ..Default::default() };
    if let Ok(v) = std::env::var("RF_PAD") {
        params.padding = v.parse().unwrap();
    }
    if let Ok(v) = std::env::var("RF_SMOOTH") {
        params.smoothing_cells = v.parse().unwrap();
    }
    if let Ok(v) = std::env::var("RF_AREA") {
        params.area_k = v.parse().unwrap();
    }
    let (mesh, report) = reconstruct_fft(&cloud, &params).unwrap();
    let seconds = start.elapsed().as_secs_f64();
    let t = topology(&mesh);
    // Accuracy: reconstruction → reference, only where the reconstruction is within 2 mm of an input
    // point (filled holes do not count); completeness: reference → reconstruction.
    let input = PointTree::new(&cloud.positions);
    let to_ref = surface::SurfaceDistance::new(&zipper, 1.0);
    let mut acc: Vec<Real> = sample_mesh(&mesh, 100_000, 5)
        .positions
        .iter()
        .filter(|p| input.nearest(p).1 <= 4.0)
        .map(|p| to_ref.distance(p))
        .collect();
    let to_rec = surface::SurfaceDistance::new(&mesh, 1.0);
    let mut comp: Vec<Real> = sample_mesh(&zipper, 100_000, 6).positions.iter().map(|p| to_rec.distance(p)).collect();
    let stats = |v: &mut Vec<Real>| {
        v.sort_by(Real::total_cmp);
        (v.iter().sum::<Real>() / v.len() as Real, v[v.len() * 95 / 100])
    };
    let ((am, a95), (cm, c95)) = (stats(&mut acc), stats(&mut comp));
    eprintln!(
        "bunny, global FFT {}³ (cell {:.3} mm): {} triangles, {:?}; accuracy mean {am:.4} p95 {a95:.4} mm, completeness mean {cm:.4} p95 {c95:.4} mm, their mean {:.4} mm; {seconds:.2} s (splat {:.2}, fft {:.2}, extract {:.2})",
        report.n,
        report.cell,
        mesh.faces.len(),
        t,
        (am + cm) / 2.0,
        report.seconds_splat,
        report.seconds_fft,
        report.seconds_extract
    );
    assert!(t.is_closed_oriented_manifold() && t.components == 1, "{t:?}");
    // Measured 0.066 mm (accuracy 0.072, completeness 0.059); screened Poisson at the same depth
    // reaches 0.054 mm. The bound leaves room for platform differences, not for a regression.
    assert!((am + cm) / 2.0 < 0.075, "mean of accuracy and completeness {}", (am + cm) / 2.0);
}
