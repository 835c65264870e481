//! 02 — Decode a simulated view and triangulate it, then measure the points against the simulator's
//! truth: the accuracy a user of the pipeline gets, in a few calls.
//!
//! `cargo run --release --example 02_decode_triangulate`

use process::triangulate::{TriangulateParams, Triangulator};
use process::{DecodeParams, decode_view};
use rig::{Method, Pattern};
use sim::{Albedo, Scene, SimConfig};

fn main() {
    let cfg = SimConfig::builtin("structured-light").expect("a built-in config").with_camera_resolution(640, 480);
    let vase = sim::fluted_vase(120.0);
    let scene = Scene::on_turntable(&cfg, &vase, Albedo::Constant(0.8));
    let view = sim::scan::simulate_view(&cfg, &scene, Method::StructuredLight, 0.0, 7, 0).unwrap();
    let (geometry, patterns, frames) = (&view.geometry, &view.patterns, &view.frames);
    let projector = cfg.rig.projector.unwrap();

    // Decode Gray code + phase shift into projector coordinates, then intersect camera and projector rays.
    let labelled: Vec<(Pattern, &rig::image::Image8)> = patterns.iter().copied().zip(frames.iter()).collect();
    let (map, report) =
        decode_view(&labelled, projector.lens.width, projector.lens.height, &DecodeParams::default()).unwrap();
    let grid = Triangulator::new(&cfg.rig.camera, &projector).triangulate(&map, &TriangulateParams::default());

    // Depth error against the truth on the same pixels.
    let mut errors: Vec<f64> = (0..grid.points.len())
        .filter(|&i| grid.valid[i] && geometry.point[i].z.is_finite())
        .map(|i| (grid.points[i].z - geometry.point[i].z).abs())
        .collect();
    errors.sort_by(f64::total_cmp);
    let median = errors[errors.len() / 2];
    println!(
        "decoded {} of {} lit pixels; {} points; median |Δz| {median:.4} mm",
        report.decoded,
        report.lit,
        grid.valid_count()
    );
    assert!(median < 0.1, "median depth error {median} mm");
}
