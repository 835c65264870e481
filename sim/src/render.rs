//! Image formation: from a view's geometry and one pattern to the 8-bit frame a camera records.
//!
//! Lambertian reflection of ambient light plus the projector's pattern (or the lasers' Gaussian line
//! profile), scaled by exposure; shot noise (Poisson, as a Gaussian of variance equal to the electron
//! count) and read noise; gain; 8-bit quantisation with saturation. Noise comes from a counter-based
//! hash of (seed, view, frame, pixel), so frames are identical for a seed whatever the thread count.

use crate::config::SimConfig;
use crate::geometry::ViewGeometry;
use crate::light::PatternLight;
use rayon::prelude::*;
use rig::Pattern;
use rig::image::Image8;
use rig::math::Real;

/// SplitMix64's finaliser: a cheap, well-mixed hash of a 64-bit counter.
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A standard normal sample for a counter (Box–Muller on two 32-bit halves of the hash).
fn normal(counter: u64) -> Real {
    let h = mix(counter);
    let u1 = ((h >> 32) as Real + 0.5) / 4_294_967_296.0;
    let u2 = ((h & 0xffff_ffff) as Real + 0.5) / 4_294_967_296.0;
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// The key that makes a frame's noise its own: seed, view and frame index.
pub fn frame_key(seed: u64, view: usize, frame: usize) -> u64 {
    mix(mix(seed ^ 0x5ca9_0000_0000_0000) ^ ((view as u64) << 24) ^ frame as u64)
}

/// Relative scene radiance at a pixel (1 = a white surface fully lit by a white pixel at exposure 1).
fn radiance(g: &ViewGeometry, cfg: &SimConfig, light: &PatternLight, i: usize) -> Real {
    if g.kind[i] == 0 {
        return 0.0;
    }
    let albedo = g.albedo[i] as Real;
    let mut e = cfg.sensor.ambient;
    match light.pattern() {
        Pattern::LaserOff => {}
        // A lit frame on a rig without a projector: the work light is on.
        Pattern::White if cfg.rig.projector.is_none() => e += cfg.scene.work_light,
        Pattern::Laser { index } => {
            let em = &cfg.lasers[index];
            let sigma = em.line_width_mm / (8.0 * std::f64::consts::LN_2).sqrt();
            let d = g.laser_distance[index][i] as Real;
            e += em.power * (-0.5 * (d / sigma).powi(2)).exp() * g.laser_cos[index][i] as Real;
        }
        _ => {
            let cos = g.projector_cos[i] as Real;
            if cos > 0.0 {
                let uv = g.projector[i];
                e += cfg.projector.power * light.at(uv.x, uv.y) * cos;
            }
        }
    }
    albedo * e
}

/// Renders one frame. `key` is [`frame_key`] for the frame (it decides the noise).
pub fn render_frame(g: &ViewGeometry, cfg: &SimConfig, light: &PatternLight, key: u64) -> Image8 {
    let s = &cfg.sensor;
    let data: Vec<u8> = (0..g.width * g.height)
        .into_par_iter()
        .map(|i| {
            let signal = radiance(g, cfg, light, i) * s.exposure;
            let dn = if s.full_well_e > 0.0 {
                let electrons = signal * s.full_well_e;
                let sd = (electrons.max(0.0) + s.read_noise_e * s.read_noise_e).sqrt();
                (electrons + sd * normal(key ^ mix(i as u64))) / s.full_well_e * s.gain * 255.0
            } else {
                signal * s.gain * 255.0
            };
            dn.round().clamp(0.0, 255.0) as u8
        })
        .collect();
    Image8::gray(g.width as u32, g.height as u32, data)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_samples_have_unit_variance() {
        let n = 200_000;
        let (mut s, mut s2) = (0.0, 0.0);
        for i in 0..n {
            let x = normal(mix(i));
            s += x;
            s2 += x * x;
        }
        let mean = s / n as Real;
        assert!(mean.abs() < 0.01 && (s2 / n as Real - mean * mean - 1.0).abs() < 0.01);
    }
}
