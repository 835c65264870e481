//! The simulator against geometry computed independently in the test: analytic depth, Gray codes a plain
//! decoder reads back, shadows, determinism, laser line centres.

use rig::math::{Isometry3, Point2, Point3, Real, Vector3};
use rig::npy;
use rig::scan_folder::Manifest;
use rig::{Method, Pattern};
use sim::{Albedo, Mount, Part, PartKind, Rectangle, ScanOptions, Scene, SimConfig, Sphere, simulate_scan};
use std::path::Path;

fn config(name: &str) -> SimConfig {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs").join(name);
    SimConfig::read(&path).unwrap()
}

/// A noiseless sensor, one view, at a small resolution for speed.
fn noiseless(name: &str, w: u32, h: u32) -> SimConfig {
    let mut c = config(name).with_camera_resolution(w, h);
    c.sensor.full_well_e = 0.0;
    c.scan.views = 1;
    c
}

/// A temporary folder, removed when the test ends (pass or fail).
fn tmp(name: &str) -> fixtures::TempDir {
    fixtures::temp_dir(&format!("sim-accept-{name}"))
}

fn fixed(kind: PartKind, surface: impl sim::Surface + 'static, pose: Isometry3) -> Part {
    Part { kind, surface: Box::new(surface), pose, mount: Mount::Fixed, albedo: Albedo::Constant(0.8) }
}

/// A plane facing the camera, tilted 25° about y, 430 mm ahead: its pose and its normal.
fn tilted_plane() -> (Isometry3, Vector3) {
    let pose = Isometry3::new(Vector3::new(0.0, 0.0, 430.0), Vector3::new(0.0, 25f64.to_radians(), 0.0));
    (pose, pose * Vector3::z())
}

fn scan(cfg: &SimConfig, scene: &Scene, method: Method, seed: u64, out: &Path) -> Manifest {
    simulate_scan(cfg, scene, None, ScanOptions { method, seed, truth: true }, out, |_, _| {}).unwrap();
    Manifest::read(out).unwrap()
}

fn load(path: &Path) -> Vec<Real> {
    npy::read(path).unwrap().to_f64()
}

#[test]
fn truth_depth_of_a_sphere_and_a_plane_is_analytic() {
    let cfg = noiseless("sim-structured-light.toml", 320, 256);
    let cam = cfg.rig.camera;
    let sphere = Sphere { center: Point3::new(15.0, -10.0, 400.0), radius: 50.0 };
    let (plane_pose, n) = tilted_plane();
    let size = 100.0; // the sphere's diameter: the tolerance is 1e-6 of it
    for (name, part) in [
        ("sphere", fixed(PartKind::Object, sphere, Isometry3::identity())),
        ("plane", fixed(PartKind::Object, Rectangle { half_width: 400.0, half_height: 400.0 }, plane_pose)),
    ] {
        let out = tmp(name);
        scan(&cfg, &Scene { parts: vec![part] }, Method::StructuredLight, 1, &out);
        let depth = load(&out.join("truth/view_000/depth.npy"));
        let (mut covered, mut missed) = (0, 0);
        for (i, z) in depth.iter().enumerate() {
            let px = Point2::new((i % cam.width as usize) as Real, (i / cam.width as usize) as Real);
            let d = cam.unproject(px).unwrap().into_inner();
            // Independent analytic intersections of the pixel ray from the camera centre.
            let expect = if name == "sphere" {
                let oc = -sphere.center.coords;
                let (b, c) = (oc.dot(&d), oc.norm_squared() - sphere.radius.powi(2));
                let disc = b * b - c;
                (disc >= 0.0).then(|| (-b - disc.sqrt()) * d.z)
            } else {
                let t = n.dot(&plane_pose.translation.vector) / n.dot(&d);
                Some(t * d.z)
            };
            match expect {
                Some(e) if z.is_finite() => {
                    assert!((z - e).abs() <= 1e-6 * size, "{name} pixel {px:?}: {z} vs {e}");
                    covered += 1;
                }
                Some(_) => missed += 1,
                None => assert!(!z.is_finite(), "{name} {px:?} hit nothing analytically"),
            }
        }
        // Only a grazing ray at the sphere's rim may fall on the other side of a root rounding.
        assert!(covered > 5000 && missed <= 2, "{name}: {covered} pixels covered, {missed} missed");
        eprintln!("{name}: {covered} covered pixels within 1e-6 of the size");
    }
}

/// Reads the Gray-coded column and row of every pixel the plain way: bit = pattern > inverse.
fn reference_decode(out: &Path, m: &Manifest, w: usize, h: usize) -> (Vec<u32>, Vec<u32>) {
    let mut col = vec![0u32; w * h];
    let mut row = vec![0u32; w * h];
    let frames = &m.views[0].frames;
    for (k, f) in frames.iter().enumerate() {
        if let Pattern::Gray { axis, inverse: false, .. } = f.pattern {
            let a = rig::image::read_png(&out.join(&f.file)).unwrap();
            let b = rig::image::read_png(&out.join(&frames[k + 1].file)).unwrap();
            let target = if axis == rig::Axis::Columns { &mut col } else { &mut row };
            for ((t, pa), pb) in target.iter_mut().zip(&a.data).zip(&b.data) {
                *t = (*t << 1) | u32::from(pa > pb);
            }
        }
    }
    (
        col.into_iter().map(rig::patterns::gray_inverse).collect(),
        row.into_iter().map(rig::patterns::gray_inverse).collect(),
    )
}

#[test]
fn gray_code_frames_of_a_plane_decode_to_the_projector_pixel_geometry_predicts() {
    let cfg = noiseless("sim-structured-light.toml", 640, 512);
    let (pose, _) = tilted_plane();
    let scene =
        Scene { parts: vec![fixed(PartKind::Object, Rectangle { half_width: 400.0, half_height: 400.0 }, pose)] };
    let out = tmp("gray");
    let m = scan(&cfg, &scene, Method::StructuredLight, 3, &out);
    let (w, h) = (640, 512);
    let (col, row) = reference_decode(&out, &m, w, h);
    let proj = load(&out.join("truth/view_000/projector.npy"));
    let (mut lit, mut exact) = (0, 0);
    for i in 0..w * h {
        let (u, v) = (proj[2 * i], proj[2 * i + 1]);
        if u.is_finite() {
            lit += 1;
            exact += usize::from(col[i] == (u + 0.5).floor() as u32 && row[i] == (v + 0.5).floor() as u32);
        }
    }
    let frac = exact as Real / lit as Real;
    eprintln!("{exact} of {lit} lit pixels decode exactly ({:.3} %)", 100.0 * frac);
    assert!(lit > 100_000 && frac >= 0.99, "{frac}");
}

/// A closed box mesh of half-size `s` at `c`.
fn box_mesh(c: Point3, s: Vector3) -> rig::TriMesh {
    fixtures::box_mesh(c, s)
}

/// Whether the segment p→q passes through the axis-aligned box (slab test, in the test itself).
fn segment_hits_box(p: Point3, q: Point3, c: Point3, s: Vector3) -> bool {
    let d = q - p;
    let (mut t0, mut t1) = (1e-6, 1.0 - 1e-6);
    for a in 0..3 {
        let (lo, hi) = (c[a] - s[a], c[a] + s[a]);
        if d[a].abs() < 1e-15 {
            if p[a] < lo || p[a] > hi {
                return false;
            }
        } else {
            let (mut ta, mut tb) = ((lo - p[a]) / d[a], (hi - p[a]) / d[a]);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            t0 = Real::max(t0, ta);
            t1 = Real::min(t1, tb);
        }
    }
    t0 <= t1
}

#[test]
fn shadows_of_a_box_are_dark_in_every_pattern_frame() {
    for (name, method) in [("sim-structured-light.toml", Method::StructuredLight), ("sim-laser.toml", Method::Laser)] {
        let cfg = noiseless(name, 320, 256);
        // A wall 480 mm ahead facing the camera, a box floating between it and the emitters.
        let (bc, bs) = (Point3::new(10.0, -5.0, 400.0), Vector3::new(15.0, 25.0, 15.0));
        let wall = Isometry3::translation(0.0, 0.0, 480.0);
        let scene = Scene {
            parts: vec![
                fixed(PartKind::Other, Rectangle { half_width: 500.0, half_height: 500.0 }, wall),
                fixed(PartKind::Object, sim::MeshSurface::new(&box_mesh(bc, bs)), Isometry3::identity()),
            ],
        };
        let out = tmp(&format!("shadow-{method:?}"));
        let m = scan(&cfg, &scene, method, 5, &out);
        let depth = load(&out.join("truth/view_000/depth.npy"));
        let part = load(&out.join("truth/view_000/part.npy"));
        let cam = cfg.rig.camera;
        let (w, h) = (cam.width as usize, cam.height as usize);
        let sources: Vec<Point3> = match method {
            Method::StructuredLight => vec![cfg.rig.projector.unwrap().center_in_camera()],
            _ => cfg.lasers.iter().map(|e| Point3::from(e.origin_mm)).collect(),
        };
        let frames: Vec<rig::image::Image8> =
            m.views[0].frames.iter().map(|f| rig::image::read_png(&out.join(&f.file)).unwrap()).collect();
        let dark = if method == Method::StructuredLight { &frames[1] } else { &frames[0] }; // black / laser off
        let mut shadowed = 0;
        for i in 0..w * h {
            if part[i] != PartKind::Other as u8 as Real {
                continue;
            }
            let px = Point2::new((i % w) as Real, (i / w) as Real);
            let p = Point3::from(cam.unproject(px).unwrap().into_inner() * (depth[i] / cam.unproject(px).unwrap().z));
            for (k, src) in sources.iter().enumerate() {
                if !segment_hits_box(p, *src, bc, bs) {
                    continue;
                }
                shadowed += 1;
                // In the emitter's shadow, every frame of that emitter shows only ambient light.
                for (f, img) in frames.iter().enumerate() {
                    let mine = match m.views[0].frames[f].pattern {
                        Pattern::Laser { index } => index == k,
                        Pattern::LaserOff | Pattern::Texture => false,
                        _ => method == Method::StructuredLight,
                    };
                    if mine {
                        assert_eq!(img.data[i], dark.data[i], "{name}: pixel {px:?} lit in frame {f} through the box");
                    }
                }
            }
        }
        eprintln!("{name}: {shadowed} shadowed wall pixels checked");
        assert!(shadowed > 500, "{name}: the box casts no shadow ({shadowed})");
    }
}

#[test]
fn same_seed_gives_identical_frames_another_seed_other_noise_same_truth() {
    let mut cfg = config("sim-structured-light.toml").with_camera_resolution(160, 128);
    cfg.scan.views = 2;
    let vase = sim::fluted_vase(120.0);
    let scene = Scene::on_turntable(&cfg, &vase, Albedo::Constant(0.8));
    let run = |seed: u64, tag: &str| {
        let out = tmp(tag);
        simulate_scan(
            &cfg,
            &scene,
            Some(&vase),
            ScanOptions { method: Method::StructuredLight, seed, truth: true },
            &out,
            |_, _| {},
        )
        .unwrap();
        out
    };
    let (a, b, c) = (run(7, "seed-a"), run(7, "seed-b"), run(8, "seed-c"));
    let m = Manifest::read(&a).unwrap();
    let mut differing = 0;
    for v in &m.views {
        for f in &v.frames {
            let (fa, fb, fc) = (
                std::fs::read(a.join(&f.file)).unwrap(),
                std::fs::read(b.join(&f.file)).unwrap(),
                std::fs::read(c.join(&f.file)).unwrap(),
            );
            assert_eq!(fa, fb, "{} differs between runs with the same seed", f.file);
            differing += usize::from(fa != fc);
        }
    }
    assert_eq!(differing, m.views.len() * m.views[0].frames.len(), "every frame's noise depends on the seed");
    for t in ["depth.npy", "projector.npy", "normal.npy", "lit.npy"] {
        let p = format!("truth/view_001/{t}");
        assert_eq!(std::fs::read(a.join(&p)).unwrap(), std::fs::read(c.join(&p)).unwrap(), "{t}");
    }
}

#[test]
fn brightest_pixel_of_each_row_sits_on_the_truth_laser_line() {
    let mut cfg = noiseless("sim-laser.toml", 1280, 960);
    cfg.scan.views = 3;
    let vase = sim::fluted_vase(120.0);
    let scene = Scene::on_turntable(&cfg, &vase, Albedo::Constant(0.8));
    let out = tmp("laser");
    simulate_scan(
        &cfg,
        &scene,
        Some(&vase),
        ScanOptions { method: Method::Laser, seed: 2, truth: true },
        &out,
        |_, _| {},
    )
    .unwrap();
    let m = Manifest::read(&out).unwrap();
    // A laser rig has no projector: no projector map (it would be NaN throughout), the rest is there.
    let truth = out.join("truth/view_000");
    assert!(!truth.join("projector.npy").exists(), "a projector map for a rig without a projector");
    for t in ["depth.npy", "part.npy", "normal.npy", "lit.npy", "pose.npy", "laser0_centres.npy"] {
        assert!(truth.join(t).is_file(), "{t} missing");
    }
    let (w, h) = (1280usize, 960usize);
    let (mut rows, mut good) = (0, 0);
    for (v, view) in m.views.iter().enumerate() {
        for (k, _) in cfg.rig.lasers.iter().enumerate() {
            let frame = view.frames.iter().find(|f| f.pattern == Pattern::Laser { index: k }).unwrap();
            let img = rig::image::read_png(&out.join(&frame.file)).unwrap();
            let centres = load(&out.join(format!("truth/view_{v:03}/laser{k}_centres.npy")));
            for r in 0..h {
                let truth: Vec<Real> = centres[r * 4..r * 4 + 4].iter().copied().filter(|c| c.is_finite()).collect();
                if truth.is_empty() {
                    continue;
                }
                let line = &img.data[r * w..(r + 1) * w];
                // The brightest pixel; where 8-bit rounding ties neighbours, the middle of the tied run.
                let top = *line.iter().max().unwrap();
                let first = line.iter().position(|&x| x == top).unwrap();
                let run = line[first..].iter().take_while(|&&x| x == top).count();
                let brightest = first as Real + (run - 1) as Real / 2.0;
                rows += 1;
                good += usize::from(truth.iter().any(|t| (t - brightest).abs() <= 0.5));
            }
        }
    }
    let frac = good as Real / rows as Real;
    eprintln!("{good} of {rows} rows: brightest pixel within 0.5 px of the truth line ({:.2} %)", 100.0 * frac);
    assert!(rows > 1000 && frac >= 0.99, "{frac}");
}

#[test]
fn board_truth_corners_sit_where_the_lit_frame_changes_colour() {
    let mut cfg = noiseless("sim-laser.toml", 640, 480);
    cfg.scene.platter_radius_mm = 0.0;
    let board = sim::Board { cols: 9, rows: 6, square_mm: 15.0, markers: None };
    let poses = sim::board::default_fixed_poses(&board, 320.0, 5);
    let out = tmp("board");
    let opts = ScanOptions { method: Method::Board, seed: 4, truth: true };
    sim::simulate_board(&cfg, &board, &sim::BoardPoses::held(poses), opts, &out, |_, _| {}).unwrap();
    let m = Manifest::read(&out).unwrap();
    let mut checked = 0;
    for v in 0..m.views.len() {
        let lit = rig::image::read_png(&out.join(&m.views[v].frames[0].file)).unwrap();
        assert_eq!(m.views[v].frames[0].pattern, Pattern::White);
        let corners = load(&out.join(format!("truth/view_{v:03}/corners.npy")));
        for c in corners.chunks(2) {
            let (x, y) = (c[0].round() as i64, c[1].round() as i64);
            if x < 4 || y < 4 || x > 635 || y > 475 {
                continue;
            }
            // Diagonal neighbours 3 px away lie in the four squares around the corner: the two on one
            // diagonal share a colour, and it differs from the other diagonal's.
            let at = |dx: i64, dy: i64| lit.at((x + dx) as u32, (y + dy) as u32) as i32;
            let (d1, d2) = (at(-3, -3).min(at(3, 3)), at(3, -3).max(at(-3, 3)));
            let (e1, e2) = (at(-3, -3).max(at(3, 3)), at(3, -3).min(at(-3, 3)));
            assert!(d1 > d2 + 40 || e2 > e1 + 40, "view {v}: no colour change at corner ({}, {})", c[0], c[1]);
            checked += 1;
        }
    }
    assert!(checked > 200, "{checked} corners checked");
}
