//! The rig description: camera, optional projector, line lasers and turntable, read from and written to
//! a human-editable TOML file with units in the field names.
//!
//! ```toml
//! format = 1
//! name = "desk scanner"
//!
//! [camera]                       # pinhole + OpenCV distortion, pixels
//! width_px = 1280
//! height_px = 1024
//! fx_px = 1400.0
//! fy_px = 1400.0
//! cx_px = 639.5
//! cy_px = 511.5
//! distortion = [0.0, 0.0, 0.0, 0.0, 0.0]   # k1 k2 p1 p2 k3 (OpenCV order)
//!
//! [projector]                    # X_p = rotation · X_c + translation_mm
//! rotation = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
//! translation_mm = [-150.0, 0.0, 0.0]
//! gamma = 2.2                    # response exponent, 1 = linear (phase patterns are pre-compensated)
//! [projector.lens]               # same fields as [camera]
//! width_px = 1024
//! # …
//!
//! [[lasers]]                     # plane n·X = distance_mm in the camera frame
//! name = "left"
//! normal = [0.866, 0.0, 0.5]
//! distance_mm = 150.0
//! colour = "red"                 # red (default), green, blue or white: picks the line out of colour frames
//!
//! [turntable]                    # camera frame; direction points up out of the platter
//! axis_point_mm = [0.0, 60.0, 400.0]
//! axis_direction = [0.0, -1.0, 0.0]
//! platter_radius_mm = 100.0      # optional: the working volume is the cylinder of this radius
//! working_height_mm = 150.0      # optional: … and this height above the platter
//! # platform_rotation = [[…], […], […]]  # optional: another scanner's platform pose, kept for export
//!
//! [image]                        # optional: frames turned before the camera applies (in this order)
//! transpose = true               # rows become columns (a camera on its side)
//! hflip = true                   # then mirrored left–right
//! vflip = false                  # then mirrored top–bottom
//! ```
//!
//! Reading checks every value against the bounds of [`crate::limits`] ([`Rig::validate`]): a value no
//! scanner has is refused naming the file and the field.

use crate::camera::{Distortion, PinholeCamera};
use crate::error::{Error, Location, ParseError, Problem};
use crate::laser::{LaserColour, LaserPlane};
use crate::math::{Isometry3, Matrix3, Point3, Real, Rotation3, Translation3, UnitQuaternion, UnitVector3, Vector3};
use crate::projector::Projector;
use crate::run_files::{read_bytes, write_atomic};
use crate::turntable::TurntableAxis;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The rig-file format this code reads and writes.
pub const RIG_FORMAT: u32 = 1;

/// A named line laser.
#[derive(Debug, Clone, PartialEq)]
pub struct Laser {
    /// A name for messages and file names (`left`, `right`).
    pub name: String,
    /// Its light plane.
    pub plane: LaserPlane,
    /// Its colour, which picks its line out of colour frames.
    pub colour: LaserColour,
}

/// A whole scanner: everything triangulation and placement need.
#[derive(Debug, Clone, PartialEq)]
pub struct Rig {
    /// A free-form name.
    pub name: String,
    /// The camera.
    pub camera: PinholeCamera,
    /// The projector of a structured-light rig.
    pub projector: Option<Projector>,
    /// The line lasers of a laser rig.
    pub lasers: Vec<Laser>,
    /// The turntable axis, where there is a turntable.
    pub turntable: Option<TurntableAxis>,
    /// The platter's radius (mm), where known: processing crops the turntable out by it.
    pub platter_radius_mm: Option<Real>,
    /// How high above the platter an object can reach (mm), where known: with the platter's radius it
    /// bounds the working volume, the only place a laser line can be (a reflection on the scanner's
    /// wall lies outside).
    pub working_height_mm: Option<Real>,
    /// How the camera's frames are turned before [`Rig::camera`] applies (the camera's width and
    /// height are the turned frame's); the identity for frames used as captured.
    pub image: crate::image::ImageTransform,
    /// The platform's full pose rotation as another scanner's calibration gave it (columns: the
    /// platform's x, y, z axes in the camera frame; z is the turntable axis), kept so that exporting
    /// the rig back gives the same numbers. scanrig itself uses only the axis.
    pub platform_rotation: Option<Matrix3>,
}

/// What [`Rig::validate`] found wrong: the field as rig.toml names it (`camera.distortion`,
/// `lasers[1]`, `turntable.platter_radius_mm`) and the problem.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RigProblem {
    /// The field, as rig.toml names it.
    pub field: String,
    /// What is wrong with it.
    pub message: String,
}

impl std::fmt::Display for RigProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "field `{}`: {}", self.field, self.message)
    }
}

impl Rig {
    /// Sets a newly calibrated turntable axis, keeping another scanner's platform pose (kept for
    /// export) consistent with it: the pose is turned by the smallest rotation that takes its z (the
    /// old axis) to the new axis, as the rig file requires.
    pub fn set_turntable(&mut self, axis: TurntableAxis) {
        if let Some(r) = self.platform_rotation {
            let z = crate::math::Vector3::from(r.column(2));
            let turn = crate::math::Rotation3::rotation_between(&z, &axis.direction.into_inner())
                .unwrap_or_else(crate::math::Rotation3::identity);
            self.platform_rotation = Some(turn.matrix() * r);
        }
        self.turntable = Some(axis);
    }
    /// Checks the rig is one a scanner can have, against the bounds of [`crate::limits`]: the camera
    /// (finite, distortion within real lenses' range and invertible over the image, principal point
    /// inside the image), the projector's lens and pose, every laser plane in front of the camera (some
    /// ray through the image meets it at positive depth), the platter in front of the camera, and a
    /// positive, finite platter radius and working height. Whatever reads or imports a rig calls it.
    pub fn validate(&self) -> Result<(), RigProblem> {
        let problem = |field: &str, message: String| RigProblem { field: field.into(), message };
        let cam = &self.camera;
        cam.distortion.validate().map_err(|m| problem("camera.distortion", m))?;
        cam.validate_camera().map_err(|m| problem("camera", m))?;
        if let Some(p) = &self.projector {
            p.lens.distortion.validate().map_err(|m| problem("projector.lens.distortion", m))?;
            p.lens.validate().map_err(|m| problem("projector.lens", m))?;
            let t = p.from_camera.translation.vector;
            if !(t.iter().all(|x| x.is_finite()) && p.from_camera.rotation.coords.iter().all(|x| x.is_finite())) {
                return Err(problem("projector", "its pose must be finite".into()));
            }
            if !(p.gamma.is_finite() && p.gamma > 0.0) {
                return Err(problem("projector.gamma", format!("{} must be positive and finite", p.gamma)));
            }
        }
        // The image's corner rays span the camera's view: a plane meets some ray in front of the camera
        // exactly when some corner ray has n·r of the sign of d (n·r is linear over the cone they span).
        let corners: Vec<Vector3> = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
            .iter()
            .map(|&(a, b)| {
                let (u, v) = (a * cam.width as Real - 0.5, b * cam.height as Real - 0.5);
                Vector3::new((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0)
            })
            .collect();
        for (i, l) in self.lasers.iter().enumerate() {
            let field = format!("lasers[{i}]");
            let (n, d) = (l.plane.normal.into_inner(), l.plane.distance);
            if !(n.iter().all(|x| x.is_finite()) && d.is_finite()) {
                return Err(problem(&field, "its plane must be finite".into()));
            }
            if d == 0.0 {
                return Err(problem(
                    &field,
                    "its plane passes through the camera's centre (distance_mm 0): it cannot triangulate".into(),
                ));
            }
            if !corners.iter().any(|r| n.dot(r) * d.signum() > 0.0) {
                return Err(problem(
                    &field,
                    format!(
                        "its plane n·X = {d} with n = ({}, {}, {}) lies behind the camera: no ray through the image meets it",
                        n.x, n.y, n.z
                    ),
                ));
            }
        }
        if let Some(t) = &self.turntable {
            if !(t.point.iter().all(|x| x.is_finite()) && t.direction.iter().all(|x| x.is_finite())) {
                return Err(problem("turntable", "its axis must be finite".into()));
            }
            if t.point.z <= 0.0 {
                return Err(problem(
                    "turntable.axis_point_mm",
                    format!("the platter centre at depth z = {} mm is not in front of the camera", t.point.z),
                ));
            }
        }
        if let Some(r) = self.platter_radius_mm
            && !(r.is_finite() && r > 0.0)
        {
            return Err(problem("turntable.platter_radius_mm", format!("{r} must be positive and finite")));
        }
        if let Some(h) = self.working_height_mm
            && !(h.is_finite() && h > 0.0)
        {
            return Err(problem("turntable.working_height_mm", format!("{h} must be positive and finite")));
        }
        Ok(())
    }

    /// The working volume — the cylinder above the platter objects stand in — where the rig knows it:
    /// a turntable and a platter radius (the height is open where the rig does not give it).
    pub fn working_volume(&self) -> Option<crate::turntable::WorkingVolume> {
        Some(crate::turntable::WorkingVolume {
            axis: self.turntable?,
            radius_mm: self.platter_radius_mm?,
            height_mm: self.working_height_mm.unwrap_or(Real::INFINITY),
        })
    }
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RigToml {
    format: u32,
    #[serde(default)]
    name: String,
    camera: LensToml,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    projector: Option<ProjectorToml>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    lasers: Vec<LaserToml>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    turntable: Option<TurntableToml>,
    #[serde(default, skip_serializing_if = "crate::image::ImageTransform::is_identity")]
    image: crate::image::ImageTransform,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct LensToml {
    width_px: u32,
    height_px: u32,
    fx_px: f64,
    fy_px: f64,
    cx_px: f64,
    cy_px: f64,
    /// k1 k2 p1 p2 k3 (OpenCV order); read as a list so that more terms are refused, not cut.
    #[serde(default)]
    distortion: Vec<f64>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ProjectorToml {
    rotation: [[f64; 3]; 3],
    translation_mm: [f64; 3],
    #[serde(default = "linear")]
    gamma: f64,
    lens: LensToml,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct LaserToml {
    name: String,
    normal: [f64; 3],
    distance_mm: f64,
    #[serde(default, skip_serializing_if = "is_red")]
    colour: LaserColour,
}

fn is_red(c: &LaserColour) -> bool {
    *c == LaserColour::Red
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct TurntableToml {
    axis_point_mm: [f64; 3],
    axis_direction: [f64; 3],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    platter_radius_mm: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    working_height_mm: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    platform_rotation: Option<[[f64; 3]; 3]>,
}

fn linear() -> f64 {
    1.0
}

fn invalid(field: &str, msg: impl Into<String>) -> ParseError {
    ParseError::new(Location::Field(field.to_string()), Problem::Invalid(msg.into()))
}

fn lens_from(t: &LensToml, field: &str) -> Result<PinholeCamera, ParseError> {
    let d = &t.distortion;
    let distortion: [f64; 5] = match d.len() {
        0 => [0.0; 5],
        4 => [d[0], d[1], d[2], d[3], 0.0],
        5 => [d[0], d[1], d[2], d[3], d[4]],
        n => {
            return Err(invalid(
                &format!("{field}.distortion"),
                format!(
                    "has {n} terms; the camera model takes k1, k2, p1, p2 and optionally k3 (4 or 5): higher-order \
                     terms (k4, k5, k6, s1…) are not supported and would be lost"
                ),
            ));
        }
    };
    let cam = PinholeCamera {
        width: t.width_px,
        height: t.height_px,
        fx: t.fx_px,
        fy: t.fy_px,
        cx: t.cx_px,
        cy: t.cy_px,
        distortion: Distortion::from_opencv(distortion),
    };
    cam.distortion.validate().map_err(|m| invalid(&format!("{field}.distortion"), m))?;
    cam.validate().map_err(|m| invalid(field, m))?;
    Ok(cam)
}

fn lens_to(c: &PinholeCamera) -> LensToml {
    LensToml {
        width_px: c.width,
        height_px: c.height,
        fx_px: c.fx,
        fy_px: c.fy,
        cx_px: c.cx,
        cy_px: c.cy,
        distortion: c.distortion.to_opencv().to_vec(),
    }
}

fn unit(v: [f64; 3], field: &str) -> Result<UnitVector3, ParseError> {
    let v = Vector3::from(v);
    let n = v.norm();
    if !(n > 0.0 && n.is_finite()) {
        return Err(invalid(field, "must be a non-zero, finite direction"));
    }
    // Normalised always: rotations are built from it, and they must be exact rotations.
    Ok(UnitVector3::new_normalize(v))
}

fn finite(v: &[f64], field: &str) -> Result<(), ParseError> {
    if v.iter().all(|x| x.is_finite()) { Ok(()) } else { Err(invalid(field, "must be finite")) }
}

impl Rig {
    /// Parses a rig from TOML text.
    pub fn from_toml_str(text: &str) -> Result<Rig, ParseError> {
        let t: RigToml = toml::from_str(text).map_err(|e| {
            let line = e.span().map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1).unwrap_or(1);
            ParseError::new(Location::Line(line), Problem::Syntax(e.message().trim().to_string()))
        })?;
        Rig::from_parsed(t)
    }

    /// Parses a rig from a TOML table embedded in another file (a simulator config's `[rig]`); errors
    /// name the fields under `prefix`.
    pub fn from_toml_table(table: toml::Table, prefix: &str) -> Result<Rig, ParseError> {
        use serde::Deserialize;
        let t = RigToml::deserialize(toml::Value::Table(table)).map_err(|e| {
            ParseError::new(Location::Field(prefix.into()), Problem::Syntax(e.message().trim().to_string()))
        })?;
        Rig::from_parsed(t).map_err(|e| match e.at {
            Location::Field(f) => ParseError::new(Location::Field(format!("{prefix}.{f}")), e.problem),
            at => ParseError::new(at, e.problem),
        })
    }

    fn from_parsed(t: RigToml) -> Result<Rig, ParseError> {
        if t.format != RIG_FORMAT {
            return Err(invalid(
                "format",
                format!("rig format {} is not supported (this scanrig reads {RIG_FORMAT})", t.format),
            ));
        }
        let camera = lens_from(&t.camera, "camera")?;
        let projector = t
            .projector
            .as_ref()
            .map(|p| -> Result<Projector, ParseError> {
                let lens = lens_from(&p.lens, "projector.lens")?;
                let m = Matrix3::from_row_slice(p.rotation.as_flattened());
                finite(m.as_slice(), "projector.rotation")?;
                let orthonormal = (m.transpose() * m - Matrix3::identity()).norm() < 1e-6 && m.determinant() > 0.0;
                if !orthonormal {
                    return Err(invalid(
                        "projector.rotation",
                        "must be a rotation matrix (orthonormal, determinant +1)",
                    ));
                }
                finite(&p.translation_mm, "projector.translation_mm")?;
                let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(&m));
                let from_camera = Isometry3::from_parts(Translation3::from(Vector3::from(p.translation_mm)), rot);
                if !(p.gamma.is_finite() && p.gamma > 0.0) {
                    return Err(invalid("projector.gamma", "must be positive (1 for a linear projector)"));
                }
                Ok(Projector { lens, from_camera, gamma: p.gamma })
            })
            .transpose()?;
        let mut lasers = Vec::new();
        for (i, l) in t.lasers.iter().enumerate() {
            let field = format!("lasers[{i}]");
            finite(&[l.distance_mm], &field)?;
            // The file's plane is n·X = d for the n as written: normalising n scales d with it.
            let plane = LaserPlane::as_written(Vector3::from(l.normal), l.distance_mm)
                .ok_or_else(|| invalid(&format!("{field}.normal"), "must be a non-zero, finite direction"))?;
            lasers.push(Laser { name: l.name.clone(), plane, colour: l.colour });
        }
        let turntable = t
            .turntable
            .as_ref()
            .map(|tt| -> Result<TurntableAxis, ParseError> {
                finite(&tt.axis_point_mm, "turntable.axis_point_mm")?;
                Ok(TurntableAxis {
                    point: Point3::from(tt.axis_point_mm),
                    direction: unit(tt.axis_direction, "turntable.axis_direction")?,
                })
            })
            .transpose()?;
        // The platter's radius and working height are checked by `Rig::validate` below, not here: a
        // rig read from a file and one built in code are refused naming the same field first.
        let platter_radius_mm = t.turntable.as_ref().and_then(|tt| tt.platter_radius_mm);
        let working_height_mm = t.turntable.as_ref().and_then(|tt| tt.working_height_mm);
        let platform_rotation = match t.turntable.as_ref().and_then(|tt| tt.platform_rotation) {
            None => None,
            Some(r) => {
                let field = "turntable.platform_rotation";
                let m = Matrix3::from_row_slice(r.as_flattened());
                finite(m.as_slice(), field)?;
                if !((m.transpose() * m - Matrix3::identity()).norm() < 1e-6 && m.determinant() > 0.0) {
                    return Err(invalid(field, "must be a rotation matrix (orthonormal, determinant +1)"));
                }
                let axis = turntable.expect("platform_rotation comes with the turntable").direction;
                if m.column(2).normalize().dot(&axis) < (0.01f64).to_radians().cos() {
                    return Err(invalid(field, "its third column (the platform's z) must be axis_direction"));
                }
                Some(m)
            }
        };
        let rig = Rig {
            name: t.name,
            camera,
            projector,
            lasers,
            turntable,
            platter_radius_mm,
            working_height_mm,
            image: t.image,
            platform_rotation,
        };
        rig.validate().map_err(|p| invalid(&p.field, p.message))?;
        Ok(rig)
    }

    /// The rig as TOML text, with a comment block stating the conventions.
    pub fn to_toml_string(&self) -> String {
        let t = RigToml {
            format: RIG_FORMAT,
            name: self.name.clone(),
            camera: lens_to(&self.camera),
            projector: self.projector.as_ref().map(|p| {
                let r = p.from_camera.rotation.to_rotation_matrix();
                let m = r.matrix();
                ProjectorToml {
                    rotation: [0, 1, 2].map(|i| [m[(i, 0)], m[(i, 1)], m[(i, 2)]]),
                    translation_mm: p.from_camera.translation.vector.into(),
                    gamma: p.gamma,
                    lens: lens_to(&p.lens),
                }
            }),
            lasers: self
                .lasers
                .iter()
                .map(|l| LaserToml {
                    name: l.name.clone(),
                    normal: l.plane.normal.into_inner().into(),
                    distance_mm: l.plane.distance,
                    colour: l.colour,
                })
                .collect(),
            turntable: self.turntable.map(|a| TurntableToml {
                axis_point_mm: a.point.coords.into(),
                axis_direction: a.direction.into_inner().into(),
                platter_radius_mm: self.platter_radius_mm,
                working_height_mm: self.working_height_mm,
                platform_rotation: self.platform_rotation.map(|m| [0, 1, 2].map(|i| [m[(i, 0)], m[(i, 1)], m[(i, 2)]])),
            }),
            image: self.image,
        };
        let body = toml::to_string(&t).expect("a rig always serialises: plain numbers, strings and arrays");
        format!(
            "# scanrig rig description. Frames follow OpenCV: camera x right, y down, z forward; millimetres.\n\
             # camera/lens: intrinsics in px, distortion = [k1, k2, p1, p2, k3].\n\
             # projector: X_projector = rotation · X_camera + translation_mm; gamma: light ∝ drive^gamma.\n\
             # lasers: plane normal · X = distance_mm in the camera frame.\n\
             # turntable: platter centre and up axis in the camera frame.\n\
             # image: frames are transposed, then mirrored (hflip, vflip) before the camera applies.\n\n{body}"
        )
    }

    /// Reads a rig file.
    pub fn read(path: &Path) -> Result<Rig, Error> {
        let bytes = read_bytes(path)?;
        let text = std::str::from_utf8(&bytes).map_err(|e| {
            ParseError::new(Location::File, Problem::Invalid(format!("not UTF-8 text: {e}"))).with_path(path)
        })?;
        Rig::from_toml_str(text).map_err(|e| e.with_path(path))
    }

    /// Writes a rig file atomically.
    pub fn write(&self, path: &Path) -> Result<(), Error> {
        write_atomic(path, self.to_toml_string().as_bytes())
    }
}
