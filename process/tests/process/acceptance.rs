//! Decoding, triangulation and placement against simulator truth (issue 4's acceptance).

use process::{ProcessParams, process_scan};
use rig::math::{Isometry3, Point2, Point3, Real, Vector3};
use rig::scan_folder::Manifest;
use rig::{Method, PinholeCamera, PointCloud, TriMesh};
use sim::{Albedo, Mount, Part, PartKind, Rectangle, ScanOptions, Scene, SimConfig, Sphere, simulate_scan};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

fn config(name: &str, w: u32, h: u32, views: u32, noiseless: bool) -> SimConfig {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs").join(name);
    let mut c = SimConfig::read(&path).unwrap().with_camera_resolution(w, h);
    c.scan.views = views;
    if noiseless {
        c.sensor.full_well_e = 0.0;
    }
    c
}

/// A temporary folder, removed when the test ends (pass or fail).
fn tmp(name: &str) -> fixtures::TempDir {
    fixtures::temp_dir(&format!("process-accept-{name}"))
}

fn npy(path: &Path) -> Vec<Real> {
    rig::npy::read(path).unwrap().to_f64()
}

/// Simulates and processes; returns (scan folder, removed when dropped; processed folder inside it).
fn scan_and_process(
    cfg: &SimConfig,
    scene: &Scene,
    object: Option<&TriMesh>,
    method: Method,
    name: &str,
) -> (fixtures::TempDir, PathBuf) {
    let scan = tmp(name);
    simulate_scan(cfg, scene, object, ScanOptions { method, seed: 11, truth: true }, &scan, |_, _| {}).unwrap();
    let out = scan.join("processed");
    // Registration and fusion have their own test (register_fuse.rs); these check what precedes them.
    let params = ProcessParams { until: process::Stage::Merge, ..Default::default() };
    process_scan(&scan, &out, &params, |_, _, _| {}).unwrap();
    (scan, out)
}

/// The truth point of every pixel (camera frame), from the truth depth and the pixel's ray.
fn truth_points(cam: &PinholeCamera, depth: &[Real]) -> Vec<Option<Point3>> {
    let w = cam.width as usize;
    depth
        .iter()
        .enumerate()
        .map(|(i, &z)| {
            let d = cam.unproject(Point2::new((i % w) as Real, (i / w) as Real))?.into_inner();
            z.is_finite().then(|| Point3::from(d * (z / d.z)))
        })
        .collect()
}

fn percentile(v: &mut [Real], q: Real) -> Real {
    v.sort_by(Real::total_cmp);
    v[((v.len() - 1) as Real * q).round() as usize]
}

fn fixed(surface: impl sim::Surface + 'static, pose: Isometry3) -> Part {
    Part {
        kind: PartKind::Object,
        surface: Box::new(surface),
        pose,
        mount: Mount::Fixed,
        albedo: Albedo::Constant(0.8),
    }
}

#[test]
fn noiseless_sphere_and_plane_depth_is_within_a_ten_thousandth_of_the_distance() {
    let cfg = config("sim-structured-light.toml", 640, 512, 1, true);
    let plane = Isometry3::new(Vector3::new(0.0, 0.0, 440.0), Vector3::new(0.0, 0.3, 0.1));
    for (name, part) in [
        ("sphere", fixed(Sphere { center: Point3::new(0.0, 10.0, 440.0), radius: 60.0 }, Isometry3::identity())),
        ("plane", fixed(Rectangle { half_width: 300.0, half_height: 300.0 }, plane)),
    ] {
        let (scan, out) = scan_and_process(&cfg, &Scene { parts: vec![part] }, None, Method::StructuredLight, name);
        let grid = rig::ply::read_range_grid(&out.join("views/view_000.ply")).unwrap();
        let depth = npy(&scan.join("truth/view_000/depth.npy"));
        let mut rel: Vec<Real> = (0..depth.len())
            .filter(|&i| grid.valid[i] && depth[i].is_finite())
            .map(|i| (grid.points[i].z - depth[i]).abs() / depth[i])
            .collect();
        let n = rel.len();
        let (median, p95) = (percentile(&mut rel, 0.5), percentile(&mut rel, 0.95));
        eprintln!("{name}: {n} points, |Δz|/z median {:.2e}, p95 {:.2e}", median, p95);
        assert!(n > 50_000 && median <= 1e-4 && p95 <= 5e-4, "{name}: median {median:.2e} p95 {p95:.2e}");
    }
}

/// Point-to-surface distance of a triangulated point from the truth point on the same camera ray:
/// the along-ray offset projected on the truth normal (the distance to the tangent plane).
fn surface_distance(p: &Point3, truth: &Point3, normal: &Vector3) -> Real {
    ((p - truth).dot(normal)).abs()
}

#[test]
fn spot_with_noise_decodes_nearly_every_lit_pixel_onto_the_surface() {
    let Some(path) = fixtures::mesh("common-3d-test-models/spot/spot_triangulated.obj") else { return };
    let cfg = config("sim-structured-light.toml", 640, 512, 4, false);
    let spot = sim::place_on_platter(&rig::read_mesh(&path).unwrap(), 120.0, sim::UpAxis::Y, Vector3::zeros());
    let diag = spot.bounding_box().unwrap().diagonal();
    let scene = Scene::on_turntable(&cfg, &spot, Albedo::Constant(0.8));
    let (scan, out) = scan_and_process(&cfg, &scene, Some(&spot), Method::StructuredLight, "spot");
    let mut acc = sim::truth::ViewAccuracy::default();
    for v in 0..4 {
        let grid = rig::ply::read_range_grid(&out.join(format!("views/view_{v:03}.ply"))).unwrap();
        let truth = scan.join(format!("truth/view_{v:03}"));
        acc.add(sim::truth::view_accuracy(&truth, &cfg.rig.camera, &grid, 0.01 * diag).unwrap());
    }
    let (mut dist, visible_lit, decoded_of_those, decoded, far) =
        (acc.distances, acc.visible_lit, acc.decoded_of_visible_lit, acc.decoded, acc.far);
    let median = percentile(&mut dist, 0.5);
    let frac = decoded_of_those as Real / visible_lit as Real;
    let outliers = far as Real / decoded as Real;
    eprintln!(
        "spot: median distance {median:.4} mm = {:.4} % of the {diag:.1} mm diagonal; {:.2} % of visible lit pixels decoded; {:.4} % outliers",
        100.0 * median / diag,
        100.0 * frac,
        100.0 * outliers
    );
    assert!(median <= 2e-4 * diag, "median {median}");
    assert!(frac >= 0.97, "decoded {frac}");
    assert!(outliers < 1e-3, "outliers {outliers}");
}

/// Points in a uniform grid of cells, for nearest-neighbour questions in the tests.
struct Cells {
    size: Real,
    cells: HashMap<[i64; 3], Vec<Point3>>,
}

impl Cells {
    fn new(points: &[Point3], size: Real) -> Self {
        let mut cells: HashMap<[i64; 3], Vec<Point3>> = HashMap::new();
        for p in points {
            cells.entry(Self::key(p, size)).or_default().push(*p);
        }
        Cells { size, cells }
    }
    fn key(p: &Point3, size: Real) -> [i64; 3] {
        [(p.x / size).floor() as i64, (p.y / size).floor() as i64, (p.z / size).floor() as i64]
    }
    /// The points within one cell size of `p`, nearest first.
    fn near(&self, p: &Point3) -> Vec<(Real, Point3)> {
        let k = Self::key(p, self.size);
        let mut out = Vec::new();
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    for q in self.cells.get(&[k[0] + dx, k[1] + dy, k[2] + dz]).into_iter().flatten() {
                        out.push(((q - p).norm(), *q));
                    }
                }
            }
        }
        out.sort_by(|a, b| a.0.total_cmp(&b.0));
        out
    }
}

#[test]
fn laser_rig_finds_the_line_in_nearly_every_row_and_both_lasers_agree() {
    let cfg = config("sim-laser.toml", 1280, 960, 12, false);
    let vase = sim::fluted_vase(120.0);
    let diag = vase.bounding_box().unwrap().diagonal();
    let scene = Scene::on_turntable(&cfg, &vase, Albedo::Constant(0.8));
    let (scan, out) = scan_and_process(&cfg, &scene, Some(&vase), Method::Laser, "laser");
    let m = Manifest::read(&scan).unwrap();
    let rig = rig::Rig::read(&scan.join("rig.toml")).unwrap();
    let (w, h) = (1280usize, 960usize);
    let (mut rows, mut found, mut errors) = (0, 0, Vec::new());
    let mut clouds: [Vec<Point3>; 2] = [Vec::new(), Vec::new()];
    for (v, view) in m.views.iter().enumerate() {
        let t = |f: &str| npy(&scan.join(format!("truth/view_{v:03}/{f}")));
        let (depth, normal) = (t("depth.npy"), t("normal.npy"));
        let truth = truth_points(&cfg.rig.camera, &depth);
        let pose = rig.turntable.unwrap().object_from_camera(view.angle_deg);
        for (k, cloud) in clouds.iter_mut().enumerate() {
            let centres = t(&format!("laser{k}_centres.npy"));
            let grid = rig::ply::read_sparse_view(&out.join(format!("views/view_{v:03}_laser{k}.ply")))
                .unwrap()
                .to_range_grid();
            for r in 0..h {
                let truth_cols: Vec<Real> =
                    centres[r * 4..r * 4 + 4].iter().copied().filter(|c| c.is_finite()).collect();
                let cells: Vec<usize> = (0..w).filter(|&c| grid.valid[r * w + c]).collect();
                if truth_cols.is_empty() {
                    continue;
                }
                rows += 1;
                let Some(&c) = cells.first() else { continue };
                found += 1;
                let p = grid.points[r * w + c];
                // The truth surface around the detected column: the nearer truth pixel's tangent plane.
                let i = r * w + c;
                if let Some(tp) = truth[i] {
                    let n = Vector3::new(normal[3 * i], normal[3 * i + 1], normal[3 * i + 2]);
                    errors.push(surface_distance(&p, &tp, &n));
                }
                if (pose * p).z > 1.0 {
                    cloud.push(pose * p);
                }
            }
        }
    }
    let frac = found as Real / rows as Real;
    let median = percentile(&mut errors, 0.5);
    // Laser 0 at view v lights the meridian laser 1 lights at view v ± 2 (60° apart, 30° steps):
    // each laser-0 point's distance to the polyline of its nearest laser-1 points.
    let other = Cells::new(&clouds[1], 2.0);
    let mut gaps: Vec<Real> = clouds[0]
        .iter()
        .filter_map(|p| {
            let near = other.near(p);
            let (a, b) = (near.first()?.1, near.get(1)?.1);
            let ab = b - a;
            let t = ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
            Some((p - (a + ab * t)).norm())
        })
        .collect();
    let agree = percentile(&mut gaps, 0.5);
    eprintln!(
        "laser: a point in {:.2} % of {rows} rows; median error {median:.4} mm = {:.4} % of diag; lasers agree to {agree:.4} mm = {:.4} %",
        100.0 * frac,
        100.0 * median / diag,
        100.0 * agree / diag
    );
    assert!(frac >= 0.95, "rows {frac}");
    assert!(median <= 3e-4 * diag, "median error {median}");
    assert!(agree <= 5e-4 * diag, "lasers disagree by {agree}");
}

/// Area-weighted random samples of a mesh's surface above `min_z` (seeded).
fn surface_samples(m: &TriMesh, n: usize, min_z: Real) -> Vec<Point3> {
    let tris: Vec<[Point3; 3]> = m
        .faces
        .iter()
        .map(|f| f.map(|i| m.vertices[i as usize]))
        .filter(|t| t.iter().map(|p| p.z).sum::<Real>() / 3.0 > min_z)
        .collect();
    let areas: Vec<Real> = tris.iter().map(|t| (t[1] - t[0]).cross(&(t[2] - t[0])).norm() / 2.0).collect();
    let total: Real = areas.iter().sum();
    let mut rng = fixtures::Lcg::new(42);
    let mut uniform = move || rng.uniform();
    let mut cdf = Vec::with_capacity(areas.len());
    let mut acc = 0.0;
    for a in &areas {
        acc += a / total;
        cdf.push(acc);
    }
    (0..n)
        .map(|_| {
            let k = cdf.partition_point(|&c| c < uniform()).min(tris.len() - 1);
            let (mut a, mut b) = (uniform(), uniform());
            if a + b > 1.0 {
                (a, b) = (1.0 - a, 1.0 - b);
            }
            let t = tris[k];
            t[0] + (t[1] - t[0]) * a + (t[2] - t[0]) * b
        })
        .collect()
}

#[test]
fn merged_36_view_cloud_covers_the_visible_surface() {
    // Coverage is the views' doing, not the pixels': at 320×256 the merged cloud still covers 100.00 %
    // of the surface within the 0.5 % radius (768,851 points), in 10.5 s against 53.5 s at 640×512.
    let cfg = config("sim-structured-light.toml", 320, 256, 36, false);
    let vase = sim::fluted_vase(120.0);
    let diag = vase.bounding_box().unwrap().diagonal();
    let scene = Scene::on_turntable(&cfg, &vase, Albedo::Constant(0.8));
    let (_scan, out) = scan_and_process(&cfg, &scene, Some(&vase), Method::StructuredLight, "coverage");
    let merged: PointCloud = rig::ply::read_cloud(&out.join("merged.ply")).unwrap();
    let radius = 0.005 * diag;
    let cells = Cells::new(&merged.positions, radius);
    // The base stands on the platter and can never be seen: the surface above the crop height counts.
    let samples = surface_samples(&vase, 20_000, ProcessParams::default().crop.min_height_mm);
    let covered = samples.iter().filter(|p| cells.near(p).first().is_some_and(|(d, _)| *d <= radius)).count();
    let frac = covered as Real / samples.len() as Real;
    eprintln!("coverage: {:.2} % of the surface within {radius:.3} mm of {} merged points", 100.0 * frac, merged.len());
    assert!(frac >= 0.95, "coverage {frac}");
}
