//! Other turntable laser scanners' calibration files, to and from a [`Rig`]: Horus' `settings.json`
//! (`calibration_settings`) and FabScanPi's `config.json` (`calibration`, `camera`, `laser`,
//! `turntable`). See PROTOCOLS.md, "FabScanPi scans and configuration" and "Horus 0.2 profiles".
//!
//! # Conventions
//! Both scanners turn each frame first (transpose, then mirror) and calibrate on the turned image:
//! the rig's camera is the turned image's, its [`ImageTransform`] says how to turn. Laser planes are
//! `n·X = d` in the camera frame (mm), as ours. The platform pose is `X_platform = Rᵀ (X_cam − t)`:
//! `t` is the platter centre and R's third column the turntable axis (up) in the camera frame; the rig
//! keeps R whole so that an export gives back the file's numbers. Horus' laser 0 is `left`, 1 `right`.
//! Neither scanner undistorts by default (`use_distortion`, `undistort` false); scanrig models the
//! lens with the coefficients given, and exports write the flags false.
//!
//! A round trip keeps every number bit for bit: values are copied, never renormalised (a normal
//! within 1e-9 of unit length is taken as written).

use crate::camera::{Distortion, PinholeCamera};
use crate::error::{Location, ParseError, Problem};
use crate::image::ImageTransform;
use crate::laser::{LaserColour, LaserPlane};
use crate::math::{Matrix3, Point3, UnitVector3, Vector3};
use crate::rig_file::{Laser, Rig};
use crate::turntable::TurntableAxis;
use serde_json::{Value, json};

/// The numbers both scanners keep.
#[derive(Debug, Clone, PartialEq)]
struct Numbers {
    /// Frames as captured.
    raw_size: (u32, u32),
    image: ImageTransform,
    camera_matrix: [[f64; 3]; 3],
    distortion: [f64; 5],
    /// Normal and distance (mm) per laser.
    planes: Vec<([f64; 3], f64)>,
    platform_rotation: [[f64; 3]; 3],
    platform_translation: [f64; 3],
    radius_mm: Option<f64>,
    height_mm: Option<f64>,
    colour: LaserColour,
}

fn err(field: &str, msg: impl Into<String>) -> ParseError {
    ParseError::new(Location::Field(field.into()), Problem::Invalid(msg.into()))
}

fn get<'a>(v: &'a Value, path: &str) -> Result<&'a Value, ParseError> {
    path.split('.').try_fold(v, |v, key| v.get(key)).ok_or_else(|| err(path, "is missing"))
}

fn number(v: &Value, field: &str) -> Result<f64, ParseError> {
    v.as_f64().filter(|x| x.is_finite()).ok_or_else(|| err(field, format!("must be a finite number, got {v}")))
}

fn numbers<const N: usize>(v: &Value, field: &str) -> Result<[f64; N], ParseError> {
    let a =
        v.as_array().filter(|a| a.len() == N).ok_or_else(|| err(field, format!("must be a list of {N} numbers")))?;
    let mut out = [0.0; N];
    for (i, x) in a.iter().enumerate() {
        out[i] = number(x, &format!("{field}[{i}]"))?;
    }
    Ok(out)
}

fn matrix(v: &Value, field: &str) -> Result<[[f64; 3]; 3], ParseError> {
    let rows = v.as_array().filter(|a| a.len() == 3).ok_or_else(|| err(field, "must be 3 rows of 3 numbers"))?;
    let mut m = [[0.0; 3]; 3];
    for (r, row) in rows.iter().enumerate() {
        m[r] = numbers::<3>(row, &format!("{field}[{r}]"))?;
    }
    Ok(m)
}

fn size(v: &Value, field: &str) -> Result<u32, ParseError> {
    v.as_u64()
        .filter(|&x| x > 0 && x <= 1 << 16)
        .map(|x| x as u32)
        .ok_or_else(|| err(field, format!("must be a whole number of pixels, 1 to 65536, got {v}")))
}

/// FabScanPi writes booleans as the strings "True" and "False"; real booleans are taken too.
fn flag(v: &Value, field: &str) -> Result<bool, ParseError> {
    match v {
        Value::Bool(b) => Ok(*b),
        Value::String(s) if s.eq_ignore_ascii_case("true") => Ok(true),
        Value::String(s) if s.eq_ignore_ascii_case("false") => Ok(false),
        _ => Err(err(field, format!("must be \"True\" or \"False\", got {v}"))),
    }
}

fn parse_json(text: &str) -> Result<Value, ParseError> {
    serde_json::from_str(text).map_err(|e| ParseError::new(Location::Line(e.line()), Problem::Syntax(e.to_string())))
}

impl Numbers {
    /// The rig these numbers describe; `field(name)` gives a number's place in the source file for
    /// messages (`camera_matrix` → `calibration.camera_matrix`).
    fn to_rig(&self, name: &str, field: impl Fn(&str) -> String) -> Result<Rig, ParseError> {
        let m = &self.camera_matrix;
        if m[0][1] != 0.0 || m[1][0] != 0.0 || m[2] != [0.0, 0.0, 1.0] {
            return Err(err(&field("camera_matrix"), "must be [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (no skew)"));
        }
        let (width, height) = self.image.size(self.raw_size.0, self.raw_size.1);
        let camera = PinholeCamera {
            width,
            height,
            fx: m[0][0],
            fy: m[1][1],
            cx: m[0][2],
            cy: m[1][2],
            distortion: Distortion::from_opencv(self.distortion),
        };
        camera.distortion.validate().map_err(|e| err(&field("distortion_vector"), e))?;
        camera.validate().map_err(|e| err(&field("camera_matrix"), e))?;
        // A principal point outside the turned image: the size (or the turn) does not belong to it.
        if !(0.0..width as f64).contains(&camera.cx) || !(0.0..height as f64).contains(&camera.cy) {
            return Err(err(
                &field("camera_matrix"),
                format!(
                    "its principal point ({}, {}) lies outside the {width}×{height} image the frames become{}: the \
                     image size or its rotate/flip settings do not belong to this calibration",
                    camera.cx,
                    camera.cy,
                    if self.image.transpose { " once turned" } else { "" }
                ),
            ));
        }
        // A principal point far off this image's centre that would sit near the centre of the image
        // turned the other way: the rotate setting does not belong to this calibration.
        let off = |w: u32, h: u32| {
            ((camera.cx - (w as f64 - 1.0) / 2.0).abs() / w as f64)
                .max((camera.cy - (h as f64 - 1.0) / 2.0).abs() / h as f64)
        };
        let (here, turned) = (off(width, height), off(height, width));
        if here > 0.1 && turned < here / 3.0 {
            return Err(err(
                &field("camera_matrix"),
                format!(
                    "its principal point ({}, {}) is {:.0} % of the image off the centre of the {width}×{height} image the \
                     frames become, but fits a {height}×{width} one: the rotate setting does not belong to this \
                     calibration",
                    camera.cx,
                    camera.cy,
                    100.0 * here
                ),
            ));
        }
        let mut lasers = Vec::new();
        for (k, &(n, d)) in self.planes.iter().enumerate() {
            let plane = LaserPlane::as_written(Vector3::from(n), d).ok_or_else(|| {
                err(&field(&format!("laser {k} normal")), "must be a non-zero direction (is the laser calibrated?)")
            })?;
            let name = match (self.planes.len(), k) {
                (2, 0) => "left".to_string(),
                (2, 1) => "right".to_string(),
                _ => format!("laser {k}"),
            };
            lasers.push(Laser { name, plane, colour: self.colour });
        }
        let r = Matrix3::from_row_slice(self.platform_rotation.as_flattened());
        if !((r.transpose() * r - Matrix3::identity()).norm() < 1e-6 && r.determinant() > 0.0) {
            return Err(err(&field("platform_rotation"), "must be a rotation matrix (orthonormal, determinant +1)"));
        }
        let axis = TurntableAxis {
            point: Point3::from(self.platform_translation),
            // Normalised: rotations are built from it (the file's numbers stay in platform_rotation).
            direction: UnitVector3::new_normalize(r.column(2).into_owned()),
        };
        let rig = Rig {
            name: name.into(),
            camera,
            projector: None,
            lasers,
            turntable: Some(axis),
            platter_radius_mm: self.radius_mm,
            working_height_mm: self.height_mm,
            image: self.image,
            platform_rotation: Some(r),
        };
        // Whatever the checks above leave (planes behind the camera, the platter behind it): named in
        // the source file's own terms.
        rig.validate().map_err(|p| {
            let source = match p.field.as_str() {
                "camera.distortion" => field("distortion_vector"),
                "turntable" | "turntable.axis_point_mm" => field("platform_translation"),
                "turntable.platter_radius_mm" => "turntable.radius".into(),
                "turntable.working_height_mm" => "turntable.height".into(),
                f if f.starts_with("lasers[") => {
                    let k = f.trim_start_matches("lasers[").trim_end_matches(']');
                    field(&format!("laser {k} normal"))
                }
                _ => field("camera_matrix"),
            };
            err(&source, p.message)
        })?;
        Ok(rig)
    }

    /// The numbers of a laser rig with a turntable; `None` with the reason otherwise.
    fn from_rig(rig: &Rig) -> Result<Numbers, String> {
        let axis = rig.turntable.ok_or("the rig has no [turntable]: both scanners need the platform's pose")?;
        if rig.lasers.is_empty() {
            return Err("the rig has no [[lasers]]".into());
        }
        let c = &rig.camera;
        let raw_size = rig.image.size(c.width, c.height);
        let r = rig.platform_rotation.unwrap_or_else(|| {
            // The object frame at θ = 0 is the platform's: its axes are R's columns.
            let [x, y, z] = axis.axes_at_zero();
            Matrix3::from_columns(&[x, y, z])
        });
        Ok(Numbers {
            raw_size,
            image: rig.image,
            camera_matrix: [[c.fx, 0.0, c.cx], [0.0, c.fy, c.cy], [0.0, 0.0, 1.0]],
            distortion: c.distortion.to_opencv(),
            planes: rig.lasers.iter().map(|l| (l.plane.normal.into_inner().into(), l.plane.distance)).collect(),
            platform_rotation: [0, 1, 2].map(|i| [r[(i, 0)], r[(i, 1)], r[(i, 2)]]),
            platform_translation: axis.point.coords.into(),
            radius_mm: rig.platter_radius_mm,
            height_mm: rig.working_height_mm,
            colour: rig.lasers[0].colour,
        })
    }
}

/// FabScanPi's laser colour names.
fn fabscan_colour(s: &str) -> Option<LaserColour> {
    match s.split_whitespace().next()? {
        "R" => Some(LaserColour::Red),
        "G" => Some(LaserColour::Green),
        "B" => Some(LaserColour::Blue),
        _ => None,
    }
}

/// A rig from FabScanPi's `config.json` text (its `calibration`, `camera`, `laser` and `turntable`
/// blocks); errors name the field.
pub fn rig_from_fabscan(text: &str) -> Result<Rig, ParseError> {
    let v = parse_json(text)?;
    let cal = get(&v, "calibration")?;
    let planes = get(cal, "laser_planes")
        .map_err(|_| err("calibration.laser_planes", "is missing"))?
        .as_array()
        .ok_or_else(|| err("calibration.laser_planes", "must be a list of {normal, distance}"))?
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let f = format!("calibration.laser_planes[{k}]");
            let n = numbers::<3>(
                get(p, "normal").map_err(|_| err(&format!("{f}.normal"), "is missing"))?,
                &format!("{f}.normal"),
            )?;
            let d = number(
                get(p, "distance").map_err(|_| err(&format!("{f}.distance"), "is missing"))?,
                &format!("{f}.distance"),
            )?;
            Ok((n, d))
        })
        .collect::<Result<Vec<_>, ParseError>>()?;
    let lasers = get(&v, "laser.numbers")?.as_u64().ok_or_else(|| err("laser.numbers", "must be a whole number"))?;
    if lasers as usize != planes.len() {
        return Err(err(
            "laser.numbers",
            format!("says {lasers} laser(s) but calibration.laser_planes holds {} plane(s)", planes.len()),
        ));
    }
    let colour_text = get(&v, "laser.color").ok().and_then(Value::as_str).unwrap_or("R (RGB)");
    let colour = fabscan_colour(colour_text)
        .ok_or_else(|| err("laser.color", format!("`{colour_text}` is not a colour scanrig knows (R, G or B)")))?;
    let optional = |path: &str| -> Result<Option<f64>, ParseError> {
        match get(&v, path) {
            Ok(x) => {
                let r = number(x, path)?;
                if r > 0.0 { Ok(Some(r)) } else { Err(err(path, format!("must be positive (millimetres), got {r}"))) }
            }
            Err(_) => Ok(None),
        }
    };
    let cal_field =
        |f: &str| if f.starts_with("laser ") { "calibration.laser_planes".into() } else { format!("calibration.{f}") };
    let n = Numbers {
        raw_size: (
            size(get(&v, "camera.resolution.width")?, "camera.resolution.width")?,
            size(get(&v, "camera.resolution.height")?, "camera.resolution.height")?,
        ),
        image: ImageTransform {
            transpose: flag(get(&v, "camera.rotate")?, "camera.rotate")?,
            hflip: flag(get(&v, "camera.hflip")?, "camera.hflip")?,
            vflip: flag(get(&v, "camera.vflip")?, "camera.vflip")?,
        },
        camera_matrix: matrix(get(&v, "calibration.camera_matrix")?, "calibration.camera_matrix")?,
        distortion: numbers::<5>(get(&v, "calibration.distortion_vector")?, "calibration.distortion_vector")?,
        planes,
        platform_rotation: matrix(get(&v, "calibration.platform_rotation")?, "calibration.platform_rotation")?,
        platform_translation: numbers::<3>(
            get(&v, "calibration.platform_translation")?,
            "calibration.platform_translation",
        )?,
        radius_mm: optional("turntable.radius")?,
        height_mm: optional("turntable.height")?,
        colour,
    };
    n.to_rig("FabScanPi", cal_field)
}

/// The rig as FabScanPi's `config.json` (the blocks [`rig_from_fabscan`] reads); the reason where the
/// rig cannot be one (no turntable, no laser).
pub fn rig_to_fabscan(rig: &Rig) -> Result<String, String> {
    let n = Numbers::from_rig(rig)?;
    let colour = match n.colour {
        LaserColour::Green => "G (RGB)",
        LaserColour::Blue => "B (RGB)",
        _ => "R (RGB)",
    };
    let b = |x: bool| if x { "True" } else { "False" };
    let mut turntable = json!({});
    if let Some(r) = n.radius_mm {
        turntable["radius"] = json!(r);
    }
    if let Some(h) = n.height_mm {
        turntable["height"] = json!(h);
    }
    let v = json!({
        "scanner_type": "laserscanner",
        "laser": { "numbers": n.planes.len(), "color": colour, "interleaved": "False" },
        "camera": {
            "resolution": { "width": n.raw_size.0, "height": n.raw_size.1 },
            "rotate": b(n.image.transpose), "hflip": b(n.image.hflip), "vflip": b(n.image.vflip),
            "undistort": "False",
        },
        "turntable": turntable,
        "calibration": {
            "camera_matrix": n.camera_matrix,
            "distortion_vector": n.distortion,
            "laser_planes": n.planes.iter().map(|(n, d)| json!({ "normal": n, "distance": d })).collect::<Vec<_>>(),
            "platform_rotation": n.platform_rotation,
            "platform_translation": n.platform_translation,
        },
    });
    Ok(serde_json::to_string_pretty(&v).expect("plain numbers and strings serialise"))
}

/// Which scanner's file [`merge_into`] lays an export over.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scanner {
    /// FabScanPi's `config.json`.
    Fabscan,
    /// Horus' `settings.json`.
    Horus,
}

impl Scanner {
    /// Settings the export speaks for whether or not it writes them: removed from the scanner's file
    /// first, so a one-laser rig laid over a two-laser Horus file leaves no stale right-hand plane.
    fn owned(self) -> &'static [&'static str] {
        match self {
            Scanner::Fabscan => &["calibration.laser_planes"],
            Scanner::Horus => &[
                "calibration_settings.normal_left",
                "calibration_settings.distance_left",
                "calibration_settings.normal_right",
                "calibration_settings.distance_right",
            ],
        }
    }

    /// Settings of the scanner's own that are not calibration (how it captures), kept as it has them.
    fn kept(self) -> &'static [&'static str] {
        match self {
            Scanner::Fabscan => &["laser.interleaved"],
            Scanner::Horus => &[],
        }
    }
}

/// `ours` (an export of [`rig_to_fabscan`] or [`rig_to_horus`]) laid over the scanner's own file
/// `existing`: objects are merged key by key, every other value of ours replaces the file's, and what
/// a rig does not hold (FabScanPi's `turntable.steps`, `calibration.pattern`, `folders`, `connector`;
/// Horus' other categories) stays as the scanner had it. The scanner reads its whole configuration
/// from that one file, so an export alone would leave those out. The laser planes are the rig's
/// alone (the file's are removed first), and how the scanner captures (`laser.interleaved`) stays.
pub fn merge_into(existing: &str, ours: &str, scanner: Scanner) -> Result<String, ParseError> {
    fn lay(base: &mut Value, top: Value) {
        match (base, top) {
            (Value::Object(b), Value::Object(t)) => {
                for (k, v) in t {
                    match b.get_mut(&k) {
                        Some(slot) => lay(slot, v),
                        None => {
                            b.insert(k, v);
                        }
                    }
                }
            }
            (slot, v) => *slot = v,
        }
    }
    /// Removes the value at a dotted `path` from `v`, returning it.
    fn take(v: &mut Value, path: &str) -> Option<Value> {
        let (parent, key) = path.rsplit_once('.').map_or((None, path), |(p, k)| (Some(p), k));
        let holder = match parent {
            Some(p) => p.split('.').try_fold(&mut *v, |v, k| v.get_mut(k))?,
            None => v,
        };
        holder.as_object_mut()?.remove(key)
    }
    let mut base = parse_json(existing)?;
    let mut ours = parse_json(ours)?;
    let (Some(b), Some(o)) = (base.as_object(), ours.as_object()) else {
        return Err(err("(top level)", "must be an object of settings"));
    };
    // Another scanner's file (a Horus settings.json given for FabScanPi) shares none of the blocks.
    if !o.keys().any(|k| b.contains_key(k)) {
        let keys: Vec<&str> = o.keys().map(String::as_str).collect();
        return Err(err("(top level)", format!("holds none of {}: not this scanner's file", keys.join(", "))));
    }
    for path in scanner.owned() {
        take(&mut base, path);
    }
    for path in scanner.kept() {
        if get(&base, path).is_ok() {
            take(&mut ours, path);
        }
    }
    lay(&mut base, ours);
    Ok(serde_json::to_string_pretty(&base).expect("parsed JSON serialises"))
}

/// A Horus setting's value: `calibration_settings.NAME.value`.
fn horus<'a>(v: &'a Value, name: &str) -> Result<&'a Value, ParseError> {
    let field = format!("calibration_settings.{name}");
    get(v, &format!("{field}.value"))
        .map_err(|_| err(&field, "is missing (Horus keeps each setting as {\"value\": …})"))
}

/// A rig from Horus' `settings.json` text (its `calibration_settings`); errors name the field.
pub fn rig_from_horus(text: &str) -> Result<Rig, ParseError> {
    let v = parse_json(text)?;
    if !v.get("calibration_settings").is_some_and(Value::is_object) {
        return Err(err("calibration_settings", "is missing: this is not a Horus settings.json"));
    }
    let f = |name: &str| format!("calibration_settings.{name}");
    let mut planes = Vec::new();
    for side in ["left", "right"] {
        let (n, d) = (format!("normal_{side}"), format!("distance_{side}"));
        match (horus(&v, &n), horus(&v, &d)) {
            (Ok(nv), Ok(dv)) => planes.push((numbers::<3>(nv, &f(&n))?, number(dv, &f(&d))?)),
            (Err(_), Err(_)) if side == "right" => {}
            (Err(e), _) | (_, Err(e)) => return Err(e),
        }
    }
    let transform = |name: &str| flag(horus(&v, name)?, &f(name));
    let n = Numbers {
        raw_size: (
            size(horus(&v, "camera_width")?, &f("camera_width"))?,
            size(horus(&v, "camera_height")?, &f("camera_height"))?,
        ),
        image: ImageTransform {
            transpose: transform("camera_rotate")?,
            hflip: transform("camera_hflip")?,
            vflip: transform("camera_vflip")?,
        },
        camera_matrix: matrix(horus(&v, "camera_matrix")?, &f("camera_matrix"))?,
        distortion: numbers::<5>(horus(&v, "distortion_vector")?, &f("distortion_vector"))?,
        planes,
        platform_rotation: matrix(horus(&v, "rotation_matrix")?, &f("rotation_matrix"))?,
        platform_translation: numbers::<3>(horus(&v, "translation_vector")?, &f("translation_vector"))?,
        radius_mm: None,
        height_mm: None,
        colour: LaserColour::Red,
    };
    n.to_rig("Horus", |name| match name {
        "platform_rotation" => f("rotation_matrix"),
        "laser 0 normal" => f("normal_left"),
        "laser 1 normal" => f("normal_right"),
        other => f(other),
    })
}

/// The rig as Horus' `settings.json` (its `calibration_settings`); the reason where the rig cannot be
/// one (no turntable, no laser, more than two lasers).
pub fn rig_to_horus(rig: &Rig) -> Result<String, String> {
    let n = Numbers::from_rig(rig)?;
    if n.planes.len() > 2 {
        return Err(format!("Horus knows two lasers (left, right); the rig has {}", n.planes.len()));
    }
    let mut s = serde_json::Map::new();
    let mut put = |name: &str, value: Value| {
        s.insert(name.into(), json!({ "value": value }));
    };
    put("camera_width", json!(n.raw_size.0));
    put("camera_height", json!(n.raw_size.1));
    put("camera_rotate", json!(n.image.transpose));
    put("camera_hflip", json!(n.image.hflip));
    put("camera_vflip", json!(n.image.vflip));
    put("camera_matrix", json!(n.camera_matrix));
    put("distortion_vector", json!(n.distortion));
    put("use_distortion", json!(false));
    for ((normal, distance), side) in n.planes.iter().zip(["left", "right"]) {
        put(&format!("normal_{side}"), json!(normal));
        put(&format!("distance_{side}"), json!(distance));
    }
    put("rotation_matrix", json!(n.platform_rotation));
    put("translation_vector", json!(n.platform_translation));
    let v = json!({ "calibration_settings": Value::Object(s) });
    Ok(serde_json::to_string_pretty(&v).expect("plain numbers serialise"))
}
