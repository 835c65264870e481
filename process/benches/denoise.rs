//! Non-local denoising throughput: 640 × 480 range grids with N 7 × 7 and Sim 5 × 5, single frames and
//! the ±1-frame temporal variant, against the bilateral filter in the same run; then the non-local
//! filter with patches from 3 × 3 to 21 × 21, whose cost should not depend on the patch size.
//!
//! `cargo bench -p process --bench denoise` — medians of 11 runs (5 for the patch sizes).

use process::denoise::{DenoiseParams, Similarity, denoise, denoise_sequence};
use rig::math::{Isometry3, Point3, Vector3};
use rig::{RangeGrid, Sensor};
use sim::{Albedo, Mount, Part, PartKind, Scene, SimConfig};
use std::time::Instant;

fn median_s(runs: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..runs)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[runs / 2]
}

fn main() {
    let cfg = SimConfig::builtin("structured-light").unwrap().with_camera_resolution(640, 480);
    let vase = sim::fluted_vase(120.0);
    let rays = sim::pixel_rays(&cfg.rig.camera);
    // A wall behind the vase fills the frame, so most of the 307 K cells are valid.
    let grids: Vec<RangeGrid> = (0..3)
        .map(|k| {
            let pose = Isometry3::new(Vector3::new(0.0, 60.0, 380.0), Vector3::new(-1.9, 0.01 * k as f64, 0.0));
            let scene = Scene {
                parts: vec![
                    Part {
                        kind: PartKind::Object,
                        surface: Box::new(sim::MeshSurface::new(&vase)),
                        pose,
                        mount: Mount::Fixed,
                        albedo: Albedo::Constant(0.8),
                    },
                    Part {
                        kind: PartKind::Other,
                        surface: Box::new(sim::Rectangle { half_width: 400.0, half_height: 400.0 }),
                        pose: Isometry3::translation(0.0, 0.0, 470.0),
                        mount: Mount::Fixed,
                        albedo: Albedo::Constant(0.8),
                    },
                ],
            };
            let g = sim::view_geometry(&scene, &cfg, &rays, &Isometry3::identity());
            let mut grid = RangeGrid::empty(g.width, g.height, Sensor::Center(Point3::origin()));
            let mut rng = fixtures::Lcg::new(7 + k);
            for i in 0..g.kind.len() {
                if g.kind[i] != 0 {
                    let u = rng.uniform() - 0.5;
                    grid.points[i] = g.point[i] + g.normal[i] * (0.6 * u);
                    grid.valid[i] = true;
                }
            }
            grid
        })
        .collect();
    // The thesis's fixed setting, so the figures compare with earlier runs; the default (sizes from the
    // grid's noise) is timed after.
    let p = DenoiseParams::thesis();
    let valid = grids[1].valid_count();
    println!("640x480 grid, {valid} valid cells; {} rayon threads", rayon::current_num_threads());
    let nl = median_s(11, || {
        std::hint::black_box(denoise(&grids[1], &p).unwrap());
    });
    let bl = median_s(11, || {
        std::hint::black_box(denoise(&grids[1], &DenoiseParams { similarity: Similarity::Bilateral, ..p }).unwrap());
    });
    let tv = median_s(11, || {
        std::hint::black_box(denoise_sequence(&grids, 1, 1, &p).unwrap());
    });
    let (_, r) = denoise(&grids[1], &p).unwrap();
    println!(
        "  one run: directions {:.3} s, bandwidths {:.3} s, weighted average {:.3} s",
        r.seconds_directions, r.seconds_bandwidth, r.seconds_filter
    );
    println!("non-local N7 O5: {:.3} s/grid = {:.1} grids/s", nl, 1.0 / nl);
    println!("bilateral N7:    {:.3} s/grid = {:.1} grids/s", bl, 1.0 / bl);
    println!("non-local ±1 frame: {:.3} s/grid = {:.1} grids/s", tv, 1.0 / tv);
    let auto = median_s(11, || {
        std::hint::black_box(denoise(&grids[1], &DenoiseParams::default()).unwrap());
    });
    let (_, r) = denoise(&grids[1], &DenoiseParams::default()).unwrap();
    println!(
        "default (sized from the noise: σ {:.3} mm, spacing {:.3} mm -> N{} O{} x{}): {:.3} s/grid = {:.1} grids/s",
        r.noise.map_or(0.0, |n| n.sigma),
        r.noise.map_or(0.0, |n| n.spacing),
        2 * r.window + 1,
        2 * r.patch + 1,
        r.iterations,
        auto,
        1.0 / auto
    );
    // The patch similarity's cost should not grow with the patch (section 4.3.2's speed argument).
    for half in [1usize, 2, 5, 10] {
        let t = median_s(5, || {
            let p = DenoiseParams { similarity: Similarity::NonLocal { half }, ..p };
            std::hint::black_box(denoise(&grids[1], &p).unwrap());
        });
        println!("non-local N7 O{}: {:.3} s/grid", 2 * half + 1, t);
    }
}
