//! Decode + triangulate one 1280 × 1024 structured-light view from frames already in memory (white,
//! black, 10 + 10 Gray bits with inverses, 2 × 4 phase frames), against a pass that only reads the same
//! bytes, timed in the same run; PNG loading of the same frames reported separately.
//!
//! `cargo bench -p process --bench decode` — medians of 15 runs (3 for PNG loading).

use process::triangulate::{TriangulateParams, Triangulator};
use process::{DecodeParams, decode_view};
use rayon::prelude::*;
use rig::Pattern;
use rig::image::Image8;
use sim::{Albedo, Scene, SimConfig};
use std::time::Instant;

fn median_ms(runs: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..runs)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[runs / 2]
}

fn main() {
    let cfg = SimConfig::builtin("structured-light").unwrap();
    let vase = sim::fluted_vase(120.0);
    let scene = Scene::on_turntable(&cfg, &vase, Albedo::Constant(0.8));
    let projector = cfg.rig.projector.unwrap();
    let view = sim::scan::simulate_view(&cfg, &scene, rig::Method::StructuredLight, 0.0, 1, 0).unwrap();
    let (patterns, frames) = (view.patterns, view.frames);
    let refs: Vec<(Pattern, &Image8)> = patterns.iter().copied().zip(frames.iter()).collect();
    let bytes: usize = frames.iter().map(|f| f.data.len()).sum();
    println!(
        "{} frames of {}x{} ({:.1} MB); {} rayon threads",
        frames.len(),
        cfg.rig.camera.width,
        cfg.rig.camera.height,
        bytes as f64 / 1e6,
        rayon::current_num_threads()
    );

    let params = DecodeParams::default();
    let tri = Triangulator::new(&cfg.rig.camera, &projector);
    // For profilers: `SCANRIG_PROFILE=1` repeats only decode + triangulate.
    if std::env::var_os("SCANRIG_PROFILE").is_some() {
        for _ in 0..60 {
            let (map, _) = decode_view(&refs, projector.lens.width, projector.lens.height, &params).unwrap();
            std::hint::black_box(tri.triangulate(&map, &TriangulateParams::default()));
        }
        return;
    }
    let (map, report) = decode_view(&refs, projector.lens.width, projector.lens.height, &params).unwrap();
    let decode = median_ms(15, || {
        std::hint::black_box(decode_view(&refs, projector.lens.width, projector.lens.height, &params).unwrap());
    });
    let triangulate = median_ms(15, || {
        std::hint::black_box(tri.triangulate(&map, &TriangulateParams::default()));
    });
    // The floor: touch every byte once, in parallel, and do nothing with it.
    // (Nothing lit contradicts the frames: forced, so the floor is measured rather than refused.)
    let dark = DecodeParams { shadow_threshold: 255.0, force: true, ..params };
    let accumulate = median_ms(15, || {
        std::hint::black_box(decode_view(&refs, projector.lens.width, projector.lens.height, &dark).unwrap());
    });
    let empty = median_ms(15, || {
        std::hint::black_box(rig::RangeGrid::empty(1280, 1024, rig::Sensor::Center(rig::Point3::origin())));
    });
    println!("(allocating an empty 1280x1024 range grid: {empty:.1} ms)");
    println!("(decode with every pixel in shadow: {accumulate:.1} ms — the accumulation passes alone)");
    let read = median_ms(15, || {
        let s: u64 = frames
            .par_iter()
            .map(|f| f.data.par_chunks(1 << 16).map(|c| c.iter().map(|&b| b as u64).sum::<u64>()).sum::<u64>())
            .sum();
        std::hint::black_box(s);
    });
    let pngs: Vec<Vec<u8>> = frames.iter().map(|f| rig::image::png_bytes(f, true)).collect();
    let load = median_ms(3, || {
        let imgs: Vec<Image8> = pngs.par_iter().map(|p| rig::image::decode_png(p).unwrap()).collect();
        std::hint::black_box(imgs);
    });
    println!("decoded {} of {} pixels ({} lit)", report.decoded, report.pixels, report.lit);
    println!("decode {decode:.1} ms + triangulate {triangulate:.1} ms = {:.1} ms", decode + triangulate);
    println!(
        "read-only pass over the same bytes {read:.1} ms: decode + triangulate = {:.1}x of it",
        (decode + triangulate) / read
    );
    println!("PNG loading of the {} frames (reported separately) {load:.1} ms", frames.len());
}
