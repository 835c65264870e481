//! The simulator's configuration: a rig (the exact truth the scan is taken with) and the physics a rig
//! file does not hold — sensor noise and exposure, projector gamma and defocus, laser emitters, ambient
//! light, the platter and the scan program. Read from TOML (`configs/sim-*.toml`):
//!
//! ```toml
//! format = 1
//! [rig]            # exactly a rig.toml's content, under `rig.`
//! [sensor]         # exposure, gain, full_well_e (0 = noiseless), read_noise_e, ambient
//! [projector]      # power, gamma, black_level, defocus_px
//! [[lasers]]       # one emitter per rig laser: origin_mm (on its plane), line_width_mm (FWHM), power
//! [scene]          # platter_radius_mm, platter_albedo, object_albedo, object_size_mm, work_light,
//!                  # wall_distance_mm, floor, wall_albedo, specular, shininess (the enclosure and gloss)
//! [frames]         # colour, jpeg_quality, laser_off, blur_px, light_rgb, laser_rgb (what a real camera writes)
//! [scan]           # views, phase = [{ axis = "columns", period_px = 16.0, steps = 4 }, …]
//! ```
//! Every section but `[rig]` may be left out; the defaults are a clean, well-exposed desktop setup
//! without walls, gloss or blur, writing grey PNGs. The built-in `realistic` laser config turns the rest
//! on: what real captures look like and the simulator otherwise never shows.

use rig::error::{Error, Location, ParseError, Problem};
use rig::math::{Point3, Real};
use rig::{PhaseShift, Rig};
use serde::Deserialize;
use std::path::Path;

/// The camera sensor and exposure.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SensorConfig {
    /// Exposure scale: 1 puts a white, fully lit, facing surface at full scale.
    pub exposure: Real,
    /// Analogue gain applied after the photon count.
    pub gain: Real,
    /// Full-well capacity in electrons, setting shot noise; 0 makes a noiseless sensor (no shot or read
    /// noise).
    pub full_well_e: Real,
    /// Read noise in electrons (standard deviation).
    pub read_noise_e: Real,
    /// Ambient light on a white surface, as a fraction of full scale.
    pub ambient: Real,
}

impl Default for SensorConfig {
    fn default() -> Self {
        SensorConfig { exposure: 0.9, gain: 1.0, full_well_e: 10_000.0, read_noise_e: 5.0, ambient: 0.03 }
    }
}

/// The projector's light: power, response curve, black level and focus.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ProjectorConfig {
    /// Irradiance of a full-white pixel on a surface facing it, as a fraction of full scale.
    pub power: Real,
    /// Response exponent: light = black + (1 − black)·value^gamma.
    pub gamma: Real,
    /// Light of a black pixel, as a fraction of white.
    pub black_level: Real,
    /// Defocus blur, a Gaussian standard deviation in projector pixels (0 = sharp pixels).
    pub defocus_px: Real,
}

impl Default for ProjectorConfig {
    fn default() -> Self {
        ProjectorConfig { power: 0.85, gamma: 2.2, black_level: 0.01, defocus_px: 0.5 }
    }
}

/// One line laser's emitter.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LaserEmitter {
    /// Where the light leaves the laser (camera frame, mm); must lie on the laser's plane.
    pub origin_mm: [Real; 3],
    /// Line thickness, full width at half maximum (mm).
    #[serde(default = "default_line_width")]
    pub line_width_mm: Real,
    /// Peak irradiance on a surface facing the laser, as a fraction of full scale.
    #[serde(default = "default_laser_power")]
    pub power: Real,
}

fn default_line_width() -> Real {
    0.8
}
fn default_laser_power() -> Real {
    1.0
}

/// The platter and the object's looks.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SceneConfig {
    /// Platter radius (mm); 0 for none.
    pub platter_radius_mm: Real,
    /// Platter albedo.
    pub platter_albedo: Real,
    /// Object albedo where the mesh has no colours.
    pub object_albedo: Real,
    /// Largest extent of the object after scaling (mm).
    pub object_size_mm: Real,
    /// The work light (an LED ring, room light) for lit frames on rigs without a projector, as a fraction
    /// of full scale on a white surface.
    pub work_light: Real,
    /// A back wall behind the turntable, this far (mm) beyond the axis seen from the camera, catching
    /// the laser and projector light as a scanner's enclosure does; 0 for none.
    pub wall_distance_mm: Real,
    /// A floor (the scanner's base or the table) 10 mm below the platter top, out past the platter.
    pub floor: bool,
    /// Albedo of the wall and floor.
    pub wall_albedo: Real,
    /// Specular reflectance of the object (Blinn–Phong, 0 = matte): glossy objects' highlights.
    pub specular: Real,
    /// Specular exponent (higher: smaller, sharper highlights).
    pub shininess: Real,
    /// The object's procedural colour (bands of hue, [`crate::colour::tint`]) in texture frames; false
    /// leaves it grey.
    pub object_colour: bool,
}

impl Default for SceneConfig {
    fn default() -> Self {
        SceneConfig {
            platter_radius_mm: 100.0,
            platter_albedo: 0.3,
            object_albedo: 0.8,
            object_size_mm: 120.0,
            work_light: 0.6,
            wall_distance_mm: 0.0,
            floor: false,
            wall_albedo: 0.7,
            specular: 0.0,
            shininess: 40.0,
            object_colour: true,
        }
    }
}

/// What the camera writes: colour or grey, PNG or JPEG, focus, and the capture program's frames.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FramesConfig {
    /// RGB frames (grey when false).
    pub colour: bool,
    /// JPEG frames of this quality (1–100); 0 writes lossless PNG.
    pub jpeg_quality: u8,
    /// Whether a laser scan captures a laser-off frame per view (FabScanPi captures none).
    pub laser_off: bool,
    /// Lens blur, a Gaussian's standard deviation in camera pixels (0 = sharp): it also mixes the
    /// object and background at silhouettes.
    pub blur_px: Real,
    /// The colour of white light (ambient, work light, projector) in the camera's R, G, B.
    pub light_rgb: [Real; 3],
    /// What the camera's R, G, B record of the lasers' light (a red laser leaks a little into green
    /// and blue through the colour filters).
    pub laser_rgb: [Real; 3],
}

impl Default for FramesConfig {
    fn default() -> Self {
        FramesConfig {
            colour: false,
            jpeg_quality: 0,
            laser_off: true,
            blur_px: 0.0,
            light_rgb: [1.0, 0.95, 0.85],
            laser_rgb: [1.0, 0.08, 0.05],
        }
    }
}

/// What to capture.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ScanConfig {
    /// Turntable steps over a full turn.
    pub views: u32,
    /// Phase-shift sets after the Gray code (structured light only).
    pub phase: Vec<PhaseShift>,
    /// A colour texture frame per view (work light on, projector and lasers off): each point's colour.
    pub texture: bool,
}

impl Default for ScanConfig {
    fn default() -> Self {
        let p = |axis| PhaseShift { axis, period_px: 16.0, steps: 4 };
        ScanConfig { views: 36, phase: vec![p(rig::Axis::Columns), p(rig::Axis::Rows)], texture: true }
    }
}

/// A whole simulator configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// The rig, exact.
    pub rig: Rig,
    /// Sensor and exposure.
    pub sensor: SensorConfig,
    /// Projector light.
    pub projector: ProjectorConfig,
    /// Laser emitters, one per `rig.lasers` entry.
    pub lasers: Vec<LaserEmitter>,
    /// Platter and object looks.
    pub scene: SceneConfig,
    /// What the camera writes.
    pub frames: FramesConfig,
    /// The capture program.
    pub scan: ScanConfig,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SimToml {
    format: u32,
    rig: toml::Table,
    #[serde(default)]
    sensor: SensorConfig,
    #[serde(default)]
    projector: ProjectorConfig,
    #[serde(default)]
    lasers: Vec<LaserEmitter>,
    #[serde(default)]
    scene: SceneConfig,
    #[serde(default)]
    frames: FramesConfig,
    #[serde(default)]
    scan: ScanConfig,
}

fn invalid(field: &str, msg: impl Into<String>) -> ParseError {
    ParseError::new(Location::Field(field.into()), Problem::Invalid(msg.into()))
}

/// The built-in simulator rigs, by name: `structured-light` (1280×1024 camera, 1024×768 projector),
/// `structured-light-640` (its 640×512 readout), `laser` (Ciclop-like, two lasers at ±30°) and
/// `realistic` (the laser rig as real captures look: an enclosure whose back wall and floor catch the
/// lasers, warm ambient light, a slightly glossy object, lens blur, colour JPEG frames with a red
/// laser and no laser-off frame). The same files as `configs/sim-*.toml`, compiled in.
pub const BUILTIN: [(&str, &str); 4] = [
    ("structured-light", include_str!("../../configs/sim-structured-light.toml")),
    ("structured-light-640", include_str!("../../configs/sim-structured-light-640.toml")),
    ("laser", include_str!("../../configs/sim-laser.toml")),
    ("realistic", include_str!("../../configs/sim-realistic.toml")),
];

impl SimConfig {
    /// A built-in rig by name (see [`BUILTIN`]); `None` for another name.
    pub fn builtin(name: &str) -> Option<SimConfig> {
        let (_, text) = BUILTIN.iter().find(|(n, _)| *n == name)?;
        Some(SimConfig::from_toml_str(text).expect("the built-in configs parse (tested)"))
    }

    /// Parses a configuration from TOML text.
    pub fn from_toml_str(text: &str) -> Result<SimConfig, ParseError> {
        let t: SimToml = toml::from_str(text).map_err(|e| {
            let line = e.span().map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1).unwrap_or(1);
            ParseError::new(Location::Line(line), Problem::Syntax(e.message().trim().to_string()))
        })?;
        if t.format != 1 {
            return Err(invalid(
                "format",
                format!("simulator config format {} is not supported (this reads 1)", t.format),
            ));
        }
        let rig = Rig::from_toml_table(t.rig, "rig")?;
        if t.lasers.len() != rig.lasers.len() {
            let msg = format!(
                "{} emitters for the rig's {} lasers: give one `[[lasers]]` per laser",
                t.lasers.len(),
                rig.lasers.len()
            );
            return Err(invalid("lasers", msg));
        }
        for (i, (e, l)) in t.lasers.iter().zip(&rig.lasers).enumerate() {
            let off = l.plane.signed_distance(&Point3::from(e.origin_mm));
            if off.abs() > 1e-3 {
                return Err(invalid(
                    &format!("lasers[{i}].origin_mm"),
                    format!("lies {off:.4} mm off laser `{}`'s plane", l.name),
                ));
            }
            if !(e.line_width_mm > 0.0 && e.power >= 0.0) {
                return Err(invalid(&format!("lasers[{i}]"), "line_width_mm must be positive and power non-negative"));
            }
        }
        let s = &t.sensor;
        if !(s.exposure > 0.0 && s.gain > 0.0 && s.full_well_e >= 0.0 && s.read_noise_e >= 0.0 && s.ambient >= 0.0) {
            return Err(invalid("sensor", "exposure and gain must be positive; noise and ambient non-negative"));
        }
        let p = &t.projector;
        if !(p.power >= 0.0 && p.gamma > 0.0 && (0.0..1.0).contains(&p.black_level) && p.defocus_px >= 0.0) {
            return Err(invalid("projector", "power ≥ 0, gamma > 0, 0 ≤ black_level < 1, defocus_px ≥ 0"));
        }
        if !(1..=3600).contains(&t.scan.views) {
            return Err(invalid("scan.views", "must be 1 to 3600 (a tenth of a degree a step)"));
        }
        let sc = &t.scene;
        if !(sc.wall_distance_mm >= 0.0
            && (0.0..=1.0).contains(&sc.wall_albedo)
            && sc.specular >= 0.0
            && sc.shininess >= 1.0)
        {
            return Err(invalid("scene", "wall_distance_mm ≥ 0, 0 ≤ wall_albedo ≤ 1, specular ≥ 0, shininess ≥ 1"));
        }
        let fr = &t.frames;
        if fr.jpeg_quality > 100 {
            return Err(invalid("frames.jpeg_quality", "must be 1 to 100, or 0 for PNG frames"));
        }
        if !(0.0..=20.0).contains(&fr.blur_px) {
            return Err(invalid("frames.blur_px", "must be 0 to 20 pixels"));
        }
        if !fr.light_rgb.iter().chain(&fr.laser_rgb).all(|v| (0.0..=2.0).contains(v)) {
            return Err(invalid("frames", "light_rgb and laser_rgb take 0 to 2 per channel"));
        }
        for (i, ph) in t.scan.phase.iter().enumerate() {
            if ph.steps < 3 || ph.period_px.is_nan() || ph.period_px < 2.0 {
                return Err(invalid(&format!("scan.phase[{i}]"), "needs steps ≥ 3 and period_px ≥ 2"));
            }
        }
        Ok(SimConfig {
            rig,
            sensor: t.sensor,
            projector: t.projector,
            lasers: t.lasers,
            scene: t.scene,
            frames: t.frames,
            scan: t.scan,
        })
    }

    /// Reads a configuration file.
    pub fn read(path: &Path) -> Result<SimConfig, Error> {
        let bytes = rig::input::read_regular(path, None)?;
        SimConfig::from_toml_str(&String::from_utf8_lossy(&bytes)).map_err(|e| e.with_path(path))
    }

    /// The same rig and physics with the camera resampled to `width × height` (intrinsics scaled, the
    /// pixel-centre convention kept), e.g. the 640 × 480 variant of a 1280 × 1024 camera.
    pub fn with_camera_resolution(mut self, width: u32, height: u32) -> SimConfig {
        let c = &mut self.rig.camera;
        let (sx, sy) = (width as Real / c.width as Real, height as Real / c.height as Real);
        c.fx *= sx;
        c.fy *= sy;
        c.cx = (c.cx + 0.5) * sx - 0.5;
        c.cy = (c.cy + 0.5) * sy - 0.5;
        c.width = width;
        c.height = height;
        self
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_builtin_config_parses() {
        for (name, _) in super::BUILTIN {
            assert!(super::SimConfig::builtin(name).is_some(), "{name}");
        }
        assert!(super::SimConfig::builtin("nonesuch").is_none());
    }
}
