//! The object's colour: a procedural albedo tint, so colour has a truth.
//!
//! Grey frames see the object's scalar albedo; the texture frame (`Pattern::Texture`) sees it tinted by
//! smooth bands of hue that change with height and around the axis, in the object frame (they turn with
//! the object). The tint is a function of position, so any point the pipeline places can be checked
//! against it: [`texture_rgb`] is what a noiseless texture frame records of a surface point there.

use crate::config::SimConfig;
use rig::math::{Point3, Real};

/// The tint, each channel in [0.35, 1], at a point of the object frame (mm): bands 40 mm tall in red,
/// green turning twice around the axis, blue mixing both, so neighbouring millimetres differ little
/// and the whole object spans the range.
pub fn tint(p: &Point3) -> [Real; 3] {
    use std::f64::consts::TAU;
    let around = p.y.atan2(p.x);
    let up = TAU * p.z / 40.0;
    let band = |x: Real| 0.675 + 0.325 * x;
    [band(up.sin()), band((2.0 * around).cos()), band((0.5 * up + around).sin())]
}

/// The light on the object in a texture frame, as a fraction of full scale on a white surface: the
/// ambient light and the work light, both diffuse (no projector, no laser), the same from every view.
pub fn texture_light(cfg: &SimConfig) -> Real {
    cfg.sensor.ambient + cfg.scene.work_light
}

/// The 8-bit R, G, B a noiseless texture frame records of an object point with albedo `albedo` at
/// `p` (object frame): exposure, gain, the light's colour, clipped at full scale; unrounded.
pub fn texture_rgb(cfg: &SimConfig, albedo: Real, p: &Point3) -> [Real; 3] {
    let t = tint(p);
    let s = &cfg.sensor;
    std::array::from_fn(|c| {
        let signal = albedo * t[c] * cfg.frames.light_rgb[c] * texture_light(cfg) * s.exposure;
        (signal * s.gain * 255.0).clamp(0.0, 255.0)
    })
}
