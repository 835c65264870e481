//! Image formation: from a view's geometry and one pattern to the 8-bit frame a camera records.
//!
//! Lambertian reflection of ambient light plus the projector's pattern (or the lasers' Gaussian line
//! profile, with a Blinn–Phong highlight on glossy objects), lens blur, colour (white light and the
//! laser in their own colours) where the config asks, scaled by exposure; shot noise (Poisson, as a Gaussian of variance equal to the electron
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

/// The two uniforms in (0, 1) of a counter's hash, from its two 32-bit halves.
fn uniforms(counter: u64) -> (Real, Real) {
    let h = mix(counter);
    (((h >> 32) as Real + 0.5) / 4_294_967_296.0, ((h & 0xffff_ffff) as Real + 0.5) / 4_294_967_296.0)
}

/// A standard normal sample for a counter (Box–Muller on two 32-bit halves of the hash).
fn normal(counter: u64) -> Real {
    let (u1, u2) = uniforms(counter);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Where nothing is lit (half of most frames: nothing hit), a pixel's value is its read noise alone,
/// `sd · normal(counter)` in digital numbers, and rounds to 0 unless that reaches half a number.
/// Box–Muller's sample is at most `√(−2 ln u1)` in size, so every `u1` above this threshold gives 0
/// without the logarithm and cosine ([`normal`]'s cost, most of a frame's); the rest are computed.
/// `sd_dn` is the read noise's standard deviation in digital numbers.
fn dark_threshold(sd_dn: Real) -> Real {
    // A millionth inside the bound: rounding in ln, sqrt and the products stays far below it.
    let radius = 0.5 / sd_dn * (1.0 - 1e-6);
    (-0.5 * radius * radius).exp()
}

/// `dn.round().clamp(0.0, 255.0) as u8` (halves away from zero, NaN to 0) without `round`, which
/// the baseline x86-64 target calls in libm: it was 7 % of a structured-light simulation. Below 256
/// a value's integer part is exact and so is the fraction left, so the result is the same bits.
fn quantise(dn: Real) -> u8 {
    // NaN and everything not above zero (NaN compares false).
    if dn.is_nan() || dn <= 0.0 {
        return 0;
    }
    if dn >= 255.0 {
        return 255;
    }
    let whole = dn as u8;
    whole + u8::from(dn - Real::from(whole) >= 0.5)
}

/// The key that makes a frame's noise its own: seed, view and frame index.
pub fn frame_key(seed: u64, view: usize, frame: usize) -> u64 {
    mix(mix(seed ^ 0x5ca9_0000_0000_0000) ^ ((view as u64) << 24) ^ frame as u64)
}

/// Relative scene radiance at a pixel (1 = a white surface fully lit by a white pixel at exposure 1),
/// as its white-light part (ambient, work light, projector) and its laser part: colour frames give
/// them different colours.
fn radiance(g: &ViewGeometry, cfg: &SimConfig, light: &PatternLight, i: usize) -> (Real, Real) {
    if g.kind[i] == 0 {
        return (0.0, 0.0);
    }
    let albedo = g.albedo[i] as Real;
    let mut e = cfg.sensor.ambient;
    let mut laser = 0.0;
    match light.pattern() {
        Pattern::LaserOff => {}
        // The same diffuse light from every view: the colour of a point does not depend on the view.
        Pattern::Texture => e += cfg.scene.work_light,
        // A lit frame on a rig without a projector: the work light is on.
        Pattern::White if cfg.rig.projector.is_none() => e += cfg.scene.work_light,
        Pattern::Laser { index } => {
            let em = &cfg.lasers[index];
            let sigma = em.line_width_mm / (8.0 * std::f64::consts::LN_2).sqrt();
            let d = g.laser_distance[index][i] as Real;
            let cos = g.laser_cos[index][i] as Real;
            let profile = em.power * (-0.5 * (d / sigma).powi(2)).exp();
            laser = albedo * profile * cos;
            if cfg.scene.specular > 0.0 && cos > 0.0 && g.kind[i] == crate::scene::PartKind::Object as u8 {
                laser += profile * specular(g, cfg, i, &rig::math::Point3::from(em.origin_mm));
            }
        }
        _ => {
            let cos = g.projector_cos[i] as Real;
            if cos > 0.0 {
                let uv = g.projector[i];
                e += cfg.projector.power * light.at(uv.x, uv.y) * cos;
            }
        }
    }
    (albedo * e, laser)
}

/// Blinn–Phong highlight of a light at `source` seen by the camera at the origin.
fn specular(g: &ViewGeometry, cfg: &SimConfig, i: usize, source: &rig::math::Point3) -> Real {
    let p = g.point[i];
    let n = g.normal[i];
    let to_light = (source - p).normalize();
    let to_camera = (-p.coords).normalize();
    let half = (to_light + to_camera).normalize();
    cfg.scene.specular * n.dot(&half).max(0.0).powf(cfg.scene.shininess)
}

/// A separable Gaussian blur of a single-channel image (lens blur), edges clamped
/// ([`rig::convolve::convolve_clamped`], which gives the bits of the per-pixel definition).
fn blur(values: &[f32], w: usize, h: usize, sigma: Real) -> Vec<f32> {
    let r = (3.0 * sigma).ceil() as isize;
    let kernel: Vec<f32> = (-r..=r).map(|k| (-0.5 * (k as Real / sigma).powi(2)).exp() as f32).collect();
    let total: f32 = kernel.iter().sum();
    let kernel: Vec<f32> = kernel.iter().map(|k| k / total).collect();
    rig::convolve::convolve_clamped(values, w, h, &kernel)
}

/// Renders one frame. `key` is [`frame_key`] for the frame (it decides the noise). Grey unless the
/// config's `[frames] colour` asks for RGB.
pub fn render_frame(g: &ViewGeometry, cfg: &SimConfig, light: &PatternLight, key: u64) -> Image8 {
    let s = &cfg.sensor;
    let fr = &cfg.frames;
    let n = g.width * g.height;
    // The sensor: photon count, shot and read noise, gain, 8-bit quantisation.
    let dark = dark_threshold(s.read_noise_e / s.full_well_e * s.gain * 255.0);
    let expose = |signal: Real, counter: u64| -> u8 {
        let signal = signal * s.exposure;
        let dn = if s.full_well_e > 0.0 {
            let electrons = signal * s.full_well_e;
            if electrons == 0.0 && uniforms(key ^ mix(counter)).0 > dark {
                return 0;
            }
            let sd = (electrons.max(0.0) + s.read_noise_e * s.read_noise_e).sqrt();
            (electrons + sd * normal(key ^ mix(counter))) / s.full_well_e * s.gain * 255.0
        } else {
            signal * s.gain * 255.0
        };
        quantise(dn)
    };
    let texture = light.pattern() == Pattern::Texture;
    if !fr.colour && fr.blur_px == 0.0 && !texture {
        // The clean default, pixel by pixel as it always was (its figures depend on it).
        let data: Vec<u8> = (0..n)
            .into_par_iter()
            .map(|i| {
                let (white, laser) = radiance(g, cfg, light, i);
                expose(white + laser, i as u64)
            })
            .collect();
        return Image8::gray(g.width as u32, g.height as u32, data);
    }
    let parts: Vec<(Real, Real)> = (0..n).into_par_iter().map(|i| radiance(g, cfg, light, i)).collect();
    let channels: Vec<Vec<f32>> = if texture {
        // Always colour, with the object's tint: the view's texture.
        (0..3)
            .map(|c| parts.iter().zip(&g.tint).map(|(&(wt, _), t)| (wt * fr.light_rgb[c]) as f32 * t[c]).collect())
            .collect()
    } else if fr.colour {
        (0..3)
            .map(|c| parts.iter().map(|&(wt, l)| (wt * fr.light_rgb[c] + l * fr.laser_rgb[c]) as f32).collect())
            .collect()
    } else {
        vec![parts.iter().map(|&(wt, l)| (wt + l) as f32).collect()]
    };
    let nc = channels.len();
    let channels: Vec<Vec<f32>> = channels
        .into_iter()
        .map(|ch| if fr.blur_px > 0.0 { blur(&ch, g.width, g.height, fr.blur_px) } else { ch })
        .collect();
    // Blocks of pixels, each pixel's channels side by side (no division per sample to find them).
    const BLOCK: usize = 4096;
    let mut data = vec![0u8; n * nc];
    data.par_chunks_mut(BLOCK * nc).enumerate().for_each(|(b, block)| {
        for (j, px) in block.chunks_mut(nc).enumerate() {
            let i = b * BLOCK + j;
            for (c, o) in px.iter_mut().enumerate() {
                // Grey keeps the pixel's own noise counter; colour gives each channel its own.
                let counter = if nc == 1 { i as u64 } else { (i as u64) * 3 + c as u64 + (1 << 40) };
                *o = expose(channels[c][i] as Real, counter);
            }
        }
    });
    Image8 { width: g.width as u32, height: g.height as u32, channels: nc as u8, data }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The dark shortcut gives what the full computation gives, for read noise from a trace to
    /// several digital numbers (where the threshold is crossed often), over many counters.
    #[test]
    fn dark_pixels_round_as_their_noise_does() {
        let mut shortcut = 0usize;
        for sd_dn in [0.0, 1e-3, 0.05, 0.1275, 0.2, 0.5, 1.0, 3.0] {
            let dark = dark_threshold(sd_dn);
            for counter in 0..200_000u64 {
                let c = mix(counter ^ 0x1234);
                let full = quantise(sd_dn * normal(c));
                if uniforms(c).0 > dark {
                    assert_eq!(full, 0, "sd {sd_dn} DN, counter {counter}");
                    shortcut += 1;
                }
            }
        }
        assert!(shortcut > 1_000_000, "the shortcut was taken {shortcut} times");
    }

    /// The blur as defined: each pixel's taps in kernel order, each read through the clamp.
    fn blur_by_definition(values: &mut [f32], w: usize, h: usize, sigma: Real) {
        let r = (3.0 * sigma).ceil() as isize;
        let kernel: Vec<f32> = (-r..=r).map(|k| (-0.5 * (k as Real / sigma).powi(2)).exp() as f32).collect();
        let total: f32 = kernel.iter().sum();
        let kernel: Vec<f32> = kernel.iter().map(|k| k / total).collect();
        let pass = |src: &[f32], along_rows: bool| -> Vec<f32> {
            (0..w * h)
                .map(|i| {
                    let (x, y) = (i % w, i / w);
                    let mut acc = 0.0;
                    for (j, k) in kernel.iter().enumerate() {
                        let d = j as isize - r;
                        let (xx, yy) = if along_rows {
                            ((x as isize + d).clamp(0, w as isize - 1) as usize, y)
                        } else {
                            (x, (y as isize + d).clamp(0, h as isize - 1) as usize)
                        };
                        acc += k * src[yy * w + xx];
                    }
                    acc
                })
                .collect()
        };
        let tmp = pass(values, true);
        values.copy_from_slice(&pass(&tmp, false));
    }

    #[test]
    fn the_row_at_a_time_blur_gives_the_definitions_bits() {
        // Sizes narrower and shorter than the kernel included: every tap then reads a clamped end.
        for (w, h, sigma) in [(37, 23, 0.8), (64, 48, 2.5), (1, 5, 1.0), (5, 1, 1.0), (2, 3, 3.0), (3, 2, 0.3)] {
            let image: Vec<f32> = (0..w * h).map(|i| (normal(mix(i as u64)) * 40.0 + 100.0) as f32).collect();
            let fast = blur(&image, w, h, sigma);
            let mut slow = image;
            blur_by_definition(&mut slow, w, h, sigma);
            let same = fast.iter().zip(&slow).all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same, "{w} x {h}, sigma {sigma}");
        }
    }

    #[test]
    fn quantise_rounds_as_round_then_clamp_does() {
        let by_definition = |dn: Real| dn.round().clamp(0.0, 255.0) as u8;
        let mut values = vec![Real::NAN, -0.0, 0.0, -0.5, 0.5, 0.49999999999999994, 254.5, 254.49999999999997];
        values.extend([255.0, 255.4, 255.5, 1e300, Real::INFINITY, -Real::INFINITY, 1.5, 2.5, 127.5]);
        values.extend((0..200_000).map(|i| normal(mix(i)) * 90.0 + 128.0));
        values.extend((0..2_600).map(|i| i as Real * 0.1 - 2.0));
        for dn in values {
            assert_eq!(quantise(dn), by_definition(dn), "{dn:e}");
        }
    }

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
