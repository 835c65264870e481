//! Issue 9: global FFT reconstruction against analytic shapes, fertility and the real bunny.

use process::kd_tree::PointTree;
use process::normals::pca_normals;
use process::reconstruct::adfft::{AdFftParams, reconstruct_adfft};
use process::reconstruct::global_fft::{FftParams, ReconstructError, reconstruct_fft};
use rig::math::{Point3, Real, Vector3};
use rig::topology::topology;
use rig::{PointCloud, TriMesh};

use crate::surface;

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

/// Accuracy (reconstruction → reference, only where the reconstruction lies within 2 mm of an input
/// point, so filled holes do not count) and completeness (reference → reconstruction): (mean, p95) each.
fn accuracy_completeness(mesh: &TriMesh, input: &PointTree, reference: &TriMesh) -> ((Real, Real), (Real, Real)) {
    let to_ref = surface::SurfaceDistance::new(reference, 1.0);
    let mut acc: Vec<Real> = sample_mesh(mesh, 100_000, 5)
        .positions
        .iter()
        .filter(|p| input.nearest(p).1 <= 4.0)
        .map(|p| to_ref.distance(p))
        .collect();
    let to_rec = surface::SurfaceDistance::new(mesh, 1.0);
    let mut comp: Vec<Real> = sample_mesh(reference, 100_000, 6).positions.iter().map(|p| to_rec.distance(p)).collect();
    let stats = |v: &mut Vec<Real>| {
        v.sort_by(Real::total_cmp);
        (v.iter().sum::<Real>() / v.len() as Real, v[v.len() * 95 / 100])
    };
    (stats(&mut acc), stats(&mut comp))
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
    // The input's premise: sensor-oriented normals agree with the reference surface's side (the
    // nearest zipper triangle's normal) for 99.98 % of points.
    let reference = surface::SurfaceDistance::new(&zipper, 1.0);
    let normals = cloud.normals.as_ref().unwrap();
    let agree = (0..cloud.len())
        .step_by(7)
        .filter(|&i| {
            reference
                .nearest(&cloud.positions[i])
                .is_some_and(|(_, t)| reference.triangle_normal(t).dot(&normals[i]) > 0.0)
        })
        .count();
    let tested = cloud.len().div_ceil(7);
    eprintln!("input normals agreeing with the reference: {:.3} % of {tested}", 100.0 * agree as Real / tested as Real);
    assert!(agree as Real >= 0.999 * tested as Real, "{agree}/{tested}");
    let input = PointTree::new(&cloud.positions);
    let mut means = Vec::new();
    // AdFFT's 512³ is asked for as depth 10: the samples (0.41 mm apart) carry no finer detail than
    // depth 9's 0.38 mm cells, and the grid stops there, as Poisson's octree does (issue 42).
    for (method, asked, depth) in [("global FFT", 8, 8), ("AdFFT", 8, 8), ("AdFFT", 10, 9)] {
        let start = std::time::Instant::now();
        let (mesh, cell, detail) = if method == "AdFFT" {
            let p = AdFftParams { depth: asked, ..Default::default() };
            let (m, r) = reconstruct_adfft(&cloud, &p).unwrap();
            assert_eq!((r.depth_asked, r.depth, r.n), (asked, depth, 1 << depth), "{r:?}");
            // 0.56 samples per surface cell at depth 9 (four times that at 8); 0.14 at depth 10.
            assert!((0.5..0.6).contains(&(r.samples_per_cell / 4f64.powi(9 - depth as i32))), "{r:?}");
            // The up-front estimate of the mesh, which sizes the memory estimate (issue 42).
            let ratio = r.estimated_triangles as Real / m.faces.len() as Real;
            assert!(
                (0.95..=1.05).contains(&ratio),
                "estimated {} triangles, made {}",
                r.estimated_triangles,
                m.faces.len()
            );
            let detail = format!(
                "{} patches by depth {:?}, {} tests, ≤ {} in memory; self-intersections {:?}",
                r.leaves(),
                r.leaves_by_depth,
                r.tests,
                r.peak_active_leaves,
                r.self_intersections
            );
            (m, r.cell, detail)
        } else {
            let (m, r) = reconstruct_fft(&cloud, &FftParams { depth, ..Default::default() }).unwrap();
            (m, r.cell, String::new())
        };
        let seconds = start.elapsed().as_secs_f64();
        // Issue 19, defect 17: Open3D found 10 intersecting pairs in AdFFT 256³ of this cloud.
        let crossing = process::reconstruct::self_intersect::intersecting_pairs(&mesh);
        assert!(
            crossing.is_empty(),
            "{method} {}³ intersects itself: {:?}",
            1 << depth,
            &crossing[..crossing.len().min(5)]
        );
        let t = topology(&mesh);
        let ((am, a95), (cm, c95)) = accuracy_completeness(&mesh, &input, &zipper);
        eprintln!(
            "bunny, {method} {}³ (cell {cell:.3} mm): {} triangles, {} component(s), genus {:?}; accuracy mean {am:.4} p95 {a95:.4} mm, completeness mean {cm:.4} p95 {c95:.4} mm, their mean {:.4} mm; {seconds:.2} s {detail}",
            1 << depth,
            mesh.faces.len(),
            t.components,
            t.genus(),
            (am + cm) / 2.0
        );
        means.push(((am + cm) / 2.0, t));
    }
    // Measured: global 256³ 0.0617 mm, AdFFT 256³ 0.0520, AdFFT 512³ 0.0538 (screened Poisson at 256³:
    // 0.054). The bound on global leaves room for platform differences, not for a regression; AdFFT
    // at 512³ must beat global at 256³, and AdFFT at 256³ match screened Poisson (issue 9, acceptance 2).
    // The global method is taken with its defaults: with AdFFT's area weights (16 neighbours, 0.25-cell
    // low-pass) it reads 0.0533 at 256³, which AdFFT at 512³ does not beat (BENCHMARKS.md).
    for (_, t) in &means {
        assert!(t.is_closed_oriented_manifold() && t.components == 1, "{t:?}");
    }
    assert!(means[0].0 < 0.075, "global FFT 256³: {}", means[0].0);
    assert!(means[2].0 < means[0].0, "AdFFT 512³ {} vs global 256³ {}", means[2].0, means[0].0);
    assert!(means[1].0 <= 0.054, "AdFFT 256³ {} vs screened Poisson's 0.054", means[1].0);

    // Issue 42: depth 11 ran for hours, also under `--memory-budget 1`, because the estimate left out
    // the mesh (≈ 23 M triangles here). Forced to the full depth, it is now refused up front, after the
    // octree alone, with the estimate (5.45 GB measured) and a hint that does not send AdFFT to itself.
    let p = AdFftParams { depth: 11, memory_budget: 1_000_000_000, samples_per_cell: 0.0, ..Default::default() };
    match reconstruct_adfft(&cloud, &p) {
        Err(e @ ReconstructError::TooLarge { n: 2048, need, .. }) => {
            let said = e.to_string();
            assert!((4.0..8.0).contains(&need), "{said}");
            assert!(said.contains("lower --depth") && !said.contains("--method adfft"), "{said}");
        }
        other => panic!("depth 11 under a 1 GB budget: {:?}", other.map(|(_, r)| r.estimated_bytes)),
    }
}

#[test]
fn outliers_leave_no_spurious_surface() {
    // Issue 9, acceptance 3: the bunny plus 25,000 points uniform in its bounding box with random
    // normals. Spurious surface = mesh area farther than 2 mm from both the reference and every scan
    // sample; the clean input's own such area (hole fills) is subtracted.
    let (Some(clean), Some(zipper)) = (
        fixtures::bunny_aligned_mm(|p| pca_normals(p, &PointTree::new(p), 10, |_| Vector3::z())),
        fixtures::data_file("stanford-bunny/reconstruction/bun_zipper.ply"),
    ) else {
        return;
    };
    let zipper = surface::zipper_mm(&zipper);
    let mut noisy = clean.clone();
    let mut rng = fixtures::Rng::new(77);
    let (lo, hi) =
        clean.positions.iter().fold((clean.positions[0], clean.positions[0]), |(lo, hi), p| (lo.inf(p), hi.sup(p)));
    for _ in 0..25_000 {
        let t = Vector3::new(rng.uniform(), rng.uniform(), rng.uniform());
        noisy.positions.push(lo + (hi - lo).component_mul(&t));
        noisy.normals.as_mut().unwrap().push(rng.direction());
    }
    let scans = PointTree::new(&clean.positions);
    let to_ref = surface::SurfaceDistance::new(&zipper, 1.0);
    let spurious = |mesh: &TriMesh| {
        let (mut far, mut total) = (0.0, 0.0);
        for f in &mesh.faces {
            let [a, b, c] = f.map(|i| mesh.vertices[i as usize]);
            let area = (b - a).cross(&(c - a)).norm() / 2.0;
            let centre = Point3::from((a.coords + b.coords + c.coords) / 3.0);
            total += area;
            if scans.nearest(&centre).1 > 4.0 && to_ref.distance_up_to(&centre, 2.0) > 2.0 {
                far += area;
            }
        }
        far / total
    };
    for method in ["global FFT", "AdFFT"] {
        let run = |cloud: &PointCloud| -> TriMesh {
            if method == "AdFFT" {
                reconstruct_adfft(cloud, &AdFftParams { depth: 8, ..Default::default() }).unwrap().0
            } else {
                reconstruct_fft(cloud, &FftParams { depth: 8, ..Default::default() }).unwrap().0
            }
        };
        let (base, with) = (run(&clean), run(&noisy));
        let t = topology(&with);
        let (s0, s1) = (spurious(&base), spurious(&with));
        eprintln!(
            "{method} 256³ with 25 K outliers: {} component(s), genus {:?}; area away from data and reference {:.3} % (clean input {:.3} %)",
            t.components,
            t.genus(),
            100.0 * s1,
            100.0 * s0
        );
        assert!(t.is_closed_oriented_manifold(), "{method}: {t:?}");
        assert!(s1 - s0 <= 0.01, "{method}: spurious area {s1} vs clean {s0}");
    }
}
