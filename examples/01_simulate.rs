//! 01 — Simulate one structured-light view of the built-in vase on the virtual rig, in memory, and look
//! at what the camera recorded and what the truth says.
//!
//! `cargo run --release --example 01_simulate`

use rig::Method;
use sim::{Albedo, Scene, SimConfig};

fn main() {
    // The built-in desktop rig at its 640 × 480 readout, and the vase standing on the platter.
    let cfg = SimConfig::builtin("structured-light").expect("a built-in config").with_camera_resolution(640, 480);
    let vase = sim::fluted_vase(120.0);
    let scene = Scene::on_turntable(&cfg, &vase, Albedo::Constant(0.8));

    // One view's geometry (every pixel's ray, projector shadow rays), then every frame of the program.
    let view = sim::scan::simulate_view(&cfg, &scene, Method::StructuredLight, 30.0, 1, 0).unwrap();
    let (geometry, patterns, frames) = (&view.geometry, &view.patterns, &view.frames);

    let on_object = geometry.kind.iter().filter(|&&k| k == sim::PartKind::Object as u8).count();
    let lit = geometry.projector_cos.iter().filter(|&&c| c > 0.0).count();
    let white = &frames[0];
    let mean = white.data.iter().map(|&v| v as f64).sum::<f64>() / white.data.len() as f64;
    println!(
        "{} frames of {}×{}: {:?} … {:?}",
        frames.len(),
        white.width,
        white.height,
        patterns[0],
        patterns[patterns.len() - 1]
    );
    println!(
        "{on_object} pixels see the vase, {lit} are lit by the projector; the white frame's mean grey is {mean:.1}"
    );
    assert!(on_object > 10_000 && lit > on_object / 2);
}
