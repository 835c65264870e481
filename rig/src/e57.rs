//! E57 (ASTM E2807), the point-cloud format surveying and heritage tools exchange: read and written with
//! the `e57` crate (see the README's list of crates).
//!
//! E57's coordinates are metres; scanrig's are millimetres: writing divides by 1000 and reading
//! multiplies back (data in another unit, a PLY's `comment units m`, are brought to millimetres
//! first by [`crate::mesh_io::write_cloud`]). Colours are stored as 8-bit integers. Every point
//! cloud of a file is read, placed by its pose, into one cloud; points without valid Cartesian
//! coordinates (a scanner's "no return") are left out. Normals are written and read as the
//! surface-normals extension libE57Format and CloudCompare use (`nor:normalX` …, [`NORMALS_URL`]);
//! confidence and view ids have no E57 field and are not written.

use crate::error::{Error, Location, ParseError, Problem};
use crate::math::Point3;
use crate::point_cloud::PointCloud;
use crate::run_files::{read_bytes, write_atomic};
use e57::{CartesianCoordinate, E57Reader, E57Writer, Extension, Record, RecordDataType, RecordName, RecordValue};
use std::io::Cursor;
use std::path::Path;

/// A fixed GUID per written cloud is allowed (GUIDs identify data sets, they need not be random) and
/// keeps the bytes reproducible; the file's own is derived from the cloud's size.
const GUID_PREFIX: &str = "scanrig-e57";

/// The surface-normals extension's namespace and its definition's address (E57_EXT_surface_normals).
pub const NORMALS_URL: (&str, &str) = ("nor", "http://www.libe57.org/E57_EXT_surface_normals.txt");

/// The extension's field for one component of a normal (`X`, `Y` or `Z`).
fn normal_name(axis: &str) -> RecordName {
    RecordName::Unknown { namespace: NORMALS_URL.0.into(), name: format!("normal{axis}") }
}

/// A point cloud as E57 bytes.
pub fn cloud_to_bytes(cloud: &PointCloud) -> Result<Vec<u8>, String> {
    let err = |e: e57::Error| e.to_string();
    let mut out = Cursor::new(Vec::new());
    {
        let mut w = E57Writer::new(&mut out, &format!("{GUID_PREFIX}-file-{}", cloud.len())).map_err(err)?;
        let mut proto = vec![Record::CARTESIAN_X_F64, Record::CARTESIAN_Y_F64, Record::CARTESIAN_Z_F64];
        if cloud.colors.is_some() {
            proto.extend([Record::COLOR_RED_U8, Record::COLOR_GREEN_U8, Record::COLOR_BLUE_U8]);
        }
        if cloud.normals.is_some() {
            w.register_extension(Extension::new(NORMALS_URL.0, NORMALS_URL.1)).map_err(err)?;
            let unit = RecordDataType::Single { min: Some(-1.0), max: Some(1.0) };
            proto.extend(["X", "Y", "Z"].map(|a| Record { name: normal_name(a), data_type: unit.clone() }));
        }
        let mut pc = w.add_pointcloud(&format!("{GUID_PREFIX}-cloud"), proto).map_err(err)?;
        pc.set_name(Some("scanrig point cloud".into()));
        for (i, p) in cloud.positions.iter().enumerate() {
            let mut values: Vec<RecordValue> = p.coords.iter().map(|&c| RecordValue::Double(c / 1000.0)).collect();
            if let Some(c) = &cloud.colors {
                values.extend(c[i].map(|v| RecordValue::Integer(v as i64)));
            }
            if let Some(n) = &cloud.normals {
                // Within the field's [-1, 1]; a normal that is none (zero, or not finite) is written as zero.
                let unit = n[i].try_normalize(1e-12).filter(|u| u.iter().all(|c| c.is_finite()));
                let u = unit.unwrap_or_else(crate::math::Vector3::zeros);
                values.extend(u.iter().map(|&c| RecordValue::Single((c as f32).clamp(-1.0, 1.0))));
            }
            pc.add_point(values).map_err(err)?;
        }
        pc.finalize().map_err(err)?;
        w.finalize().map_err(err)?;
    }
    Ok(out.into_inner())
}

/// Writes a point cloud as E57, atomically.
pub fn write_cloud(path: &Path, cloud: &PointCloud) -> Result<(), Error> {
    let bytes = cloud_to_bytes(cloud)
        .map_err(|e| Error::io(path, std::io::Error::other(format!("the E57 writer refused the cloud: {e}"))))?;
    write_atomic(path, &bytes)
}

/// How far from unit length a pose quaternion may be and still be taken as a rotation (normalised):
/// files written in single precision, or rounded to six decimals, are within 10⁻⁶; a quaternion further
/// off (2, 0, 0, 0) would scale the cloud by its squared length, and is refused.
pub const QUATERNION_TOLERANCE: f64 = 1e-3;

/// A point cloud's pose made a rigid motion: its quaternion normalised where it is within
/// [`QUATERNION_TOLERANCE`] of unit length, refused (naming the pose) where it is not, or not finite.
fn checked_pose(pc: &e57::PointCloud, k: usize) -> Result<e57::PointCloud, ParseError> {
    let mut pc = pc.clone();
    if let Some(t) = pc.transform.as_mut() {
        let at = Location::Field(format!("data3D[{k}].pose"));
        let q = &mut t.rotation;
        let tr = &t.translation;
        let shown = format!("({}, {}, {}, {})", q.w, q.x, q.y, q.z);
        if ![q.w, q.x, q.y, q.z, tr.x, tr.y, tr.z].iter().all(|v| v.is_finite()) {
            return Err(ParseError::new(at, Problem::NonFinite(format!("the pose (rotation {shown})"))));
        }
        let norm = (q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z).sqrt();
        if (norm - 1.0).abs() > QUATERNION_TOLERANCE {
            let msg = format!(
                "the pose's rotation quaternion (w, x, y, z) = {shown} has length {norm}, not 1: it is not a \
                 rotation (it would scale the cloud by {:.3})",
                norm * norm
            );
            return Err(ParseError::new(at, Problem::Invalid(msg)));
        }
        (q.w, q.x, q.y, q.z) = (q.w / norm, q.x / norm, q.y / norm, q.z / norm);
    }
    Ok(pc)
}

/// Parses E57 bytes into one cloud (millimetres), with colours where every point cloud has them.
pub fn parse(bytes: &[u8]) -> Result<PointCloud, ParseError> {
    parse_reported(bytes).map(|(cloud, _)| cloud)
}

/// [`parse`], with what it left out named, one sentence each: points without valid coordinates (a
/// scanner's "no return"), colours that only some point clouds have. A pose whose quaternion is not a
/// rotation is refused (see [`QUATERNION_TOLERANCE`]).
pub fn parse_reported(bytes: &[u8]) -> Result<(PointCloud, Vec<String>), ParseError> {
    let invalid = |what: &str, e: e57::Error| ParseError::new(Location::File, Problem::Invalid(format!("{what}: {e}")));
    let mut reader = E57Reader::new(Cursor::new(bytes)).map_err(|e| invalid("not a readable E57 file", e))?;
    let clouds = reader.pointclouds();
    let all_coloured = !clouds.is_empty() && clouds.iter().all(|c| c.has_color());
    let mut warnings = Vec::new();
    let coloured = clouds.iter().filter(|c| c.has_color()).count();
    if coloured > 0 && !all_coloured {
        warnings.push(format!("its colours are not kept: {coloured} of {} point clouds have them", clouds.len()));
    }
    // Normals where every point cloud has the extension's three fields (their places in its records).
    let normal_fields = |pc: &e57::PointCloud| -> Option<[usize; 3]> {
        let at = |a: &str| {
            let name = format!("normal{a}");
            pc.prototype.iter().position(|r| matches!(&r.name, RecordName::Unknown { name: n, .. } if *n == name))
        };
        Some([at("X")?, at("Y")?, at("Z")?])
    };
    let with_normals = clouds.iter().filter(|c| normal_fields(c).is_some()).count();
    let all_normals = !clouds.is_empty() && with_normals == clouds.len();
    if with_normals > 0 && !all_normals {
        warnings.push(format!("its normals are not kept: {with_normals} of {} point clouds have them", clouds.len()));
    }
    let mut out = PointCloud::default();
    let mut colors = Vec::new();
    let mut normals = Vec::new();
    let mut no_return = 0usize;
    for (k, pc) in clouds.iter().enumerate() {
        let pc = checked_pose(pc, k)?;
        let mut points = reader.pointcloud_simple(&pc).map_err(|e| invalid(&format!("point cloud {k}"), e))?;
        points.apply_pose(true);
        // Which points came in (the normals, read after, are those of the same points).
        let mut kept = Vec::new();
        for p in points {
            let p = p.map_err(|e| invalid(&format!("point cloud {k}"), e))?;
            kept.push(matches!(p.cartesian, CartesianCoordinate::Valid { .. }));
            let CartesianCoordinate::Valid { x, y, z } = p.cartesian else {
                no_return += 1;
                continue;
            };
            let q = Point3::new(x * 1000.0, y * 1000.0, z * 1000.0);
            if !q.coords.iter().all(|c| c.is_finite()) {
                let at = Location::Field(format!("data3D[{k}]"));
                return Err(ParseError::new(at, Problem::NonFinite("a coordinate".into())));
            }
            out.positions.push(q);
            if all_coloured {
                let c = p.color.map_or([0.0; 3], |c| [c.red, c.green, c.blue]);
                colors.push(c.map(|v| (v * 255.0).round().clamp(0.0, 255.0) as u8));
            }
        }
        if all_normals {
            normals.extend(cloud_normals(&mut reader, &pc, k, &kept, normal_fields(&pc).expect("checked"))?);
        }
    }
    if all_normals {
        out.normals = Some(normals);
    }
    if all_coloured {
        out.colors = Some(colors);
    }
    if no_return > 0 {
        warnings.push(format!("{no_return} points without valid coordinates (no return) are left out"));
    }
    Ok((out, warnings))
}

/// The normals of point cloud `k` (at `fields` of its records) for the points `kept`, turned by its
/// pose as the points are.
fn cloud_normals(
    reader: &mut E57Reader<Cursor<&[u8]>>,
    pc: &e57::PointCloud,
    k: usize,
    kept: &[bool],
    fields: [usize; 3],
) -> Result<Vec<crate::math::Vector3>, ParseError> {
    let at = || Location::Field(format!("data3D[{k}] normals"));
    let bad = |e: e57::Error| ParseError::new(at(), Problem::Invalid(e.to_string()));
    let turn = pc.transform.as_ref().map_or(crate::math::UnitQuaternion::identity(), |t| {
        let q = &t.rotation;
        crate::math::UnitQuaternion::new_normalize(nalgebra::Quaternion::new(q.w, q.x, q.y, q.z))
    });
    let mut out = Vec::new();
    for (values, &keep) in reader.pointcloud_raw(pc).map_err(bad)?.zip(kept) {
        let values = values.map_err(bad)?;
        if !keep {
            continue;
        }
        let c = |f: usize| values[f].to_f64(&pc.prototype[f].data_type).map_err(bad);
        let n = crate::math::Vector3::new(c(fields[0])?, c(fields[1])?, c(fields[2])?);
        if !n.iter().all(|v| v.is_finite()) {
            return Err(ParseError::new(at(), Problem::NonFinite("a normal".into())));
        }
        out.push(turn * n);
    }
    if out.len() != kept.iter().filter(|&&k| k).count() {
        return Err(ParseError::new(at(), Problem::Invalid("fewer normals than points".into())));
    }
    Ok(out)
}

/// Reads an E57 file (see [`parse`]).
pub fn read(path: &Path) -> Result<PointCloud, Error> {
    parse(&read_bytes(path)?).map_err(|e| e.with_path(path))
}

/// Reads an E57 file with what was left out named (see [`parse_reported`]).
pub fn read_reported(path: &Path) -> Result<(PointCloud, Vec<String>), Error> {
    parse_reported(&read_bytes(path)?).map_err(|e| e.with_path(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_coloured_cloud_round_trips_in_millimetres() {
        let positions: Vec<Point3> = (0..500).map(|i| Point3::new(i as f64 * 0.37, -12.5 + i as f64, 80.0)).collect();
        let colors: Vec<[u8; 3]> = (0..500).map(|i| [(i % 256) as u8, 7, 255 - (i % 256) as u8]).collect();
        let cloud = PointCloud { colors: Some(colors), ..PointCloud::from_positions(positions) };
        let back = parse(&cloud_to_bytes(&cloud).unwrap()).unwrap();
        assert_eq!(back.len(), 500);
        assert_eq!(back.colors, cloud.colors);
        for (a, b) in back.positions.iter().zip(&cloud.positions) {
            assert!((a - b).norm() < 1e-9, "{a} vs {b}");
        }
        let bare = parse(&cloud_to_bytes(&PointCloud::from_positions(vec![Point3::origin()])).unwrap()).unwrap();
        assert_eq!((bare.len(), bare.colors, bare.normals), (1, None, None));
    }

    /// Normals go out as the surface-normals extension and come back (they had been dropped without
    /// a word, found by a hostile user's probe on 2026-12-07), in single precision.
    #[test]
    fn normals_round_trip_as_the_extension() {
        let positions: Vec<Point3> = (0..300).map(|i| Point3::new(i as f64, 2.0 * i as f64, 5.0)).collect();
        let normals: Vec<crate::math::Vector3> = (0..300)
            .map(|i| crate::math::Vector3::new((i as f64 * 0.1).cos(), (i as f64 * 0.1).sin(), 0.5).normalize())
            .collect();
        let cloud = PointCloud { normals: Some(normals.clone()), ..PointCloud::from_positions(positions) };
        let bytes = cloud_to_bytes(&cloud).unwrap();
        assert!(bytes.windows(NORMALS_URL.1.len()).any(|w| w == NORMALS_URL.1.as_bytes()), "the extension is named");
        let (back, warnings) = parse_reported(&bytes).unwrap();
        assert!(warnings.is_empty(), "{warnings:?}");
        let back = back.normals.expect("normals read back");
        assert_eq!(back.len(), 300);
        for (a, b) in back.iter().zip(&normals) {
            assert!((a - b).norm() < 1e-6, "{a} vs {b}");
        }
    }

    fn posed(rotation: e57::Quaternion) -> Vec<u8> {
        let mut out = Cursor::new(Vec::new());
        {
            let mut w = E57Writer::new(&mut out, "posed-file").unwrap();
            let proto = vec![Record::CARTESIAN_X_F64, Record::CARTESIAN_Y_F64, Record::CARTESIAN_Z_F64];
            let mut pc = w.add_pointcloud("posed-cloud", proto).unwrap();
            pc.set_transform(Some(e57::Transform {
                rotation,
                translation: e57::Translation { x: 0.0, y: 0.0, z: 0.0 },
            }));
            pc.add_point(vec![RecordValue::Double(0.1), RecordValue::Double(0.0), RecordValue::Double(0.0)]).unwrap();
            pc.finalize().unwrap();
            w.finalize().unwrap();
        }
        out.into_inner()
    }

    /// A cloud's normals are turned by its pose as its points are: a quarter turn about z takes the
    /// normal +x to +y.
    #[test]
    fn normals_are_turned_by_the_clouds_pose() {
        let mut out = Cursor::new(Vec::new());
        {
            let mut w = E57Writer::new(&mut out, "posed-normals").unwrap();
            w.register_extension(Extension::new(NORMALS_URL.0, NORMALS_URL.1)).unwrap();
            let mut proto = vec![Record::CARTESIAN_X_F64, Record::CARTESIAN_Y_F64, Record::CARTESIAN_Z_F64];
            let unit = RecordDataType::Single { min: Some(-1.0), max: Some(1.0) };
            proto.extend(["X", "Y", "Z"].map(|a| Record { name: normal_name(a), data_type: unit.clone() }));
            let mut pc = w.add_pointcloud("posed-cloud", proto).unwrap();
            let h = 0.5f64.sqrt();
            pc.set_transform(Some(e57::Transform {
                rotation: e57::Quaternion { w: h, x: 0.0, y: 0.0, z: h },
                translation: e57::Translation { x: 0.0, y: 0.0, z: 0.0 },
            }));
            let v = [RecordValue::Double(0.1), RecordValue::Double(0.0), RecordValue::Double(0.0)];
            let n = [RecordValue::Single(1.0), RecordValue::Single(0.0), RecordValue::Single(0.0)];
            pc.add_point(v.into_iter().chain(n).collect()).unwrap();
            pc.finalize().unwrap();
            w.finalize().unwrap();
        }
        let back = parse(&out.into_inner()).unwrap();
        assert!((back.positions[0] - Point3::new(0.0, 100.0, 0.0)).norm() < 1e-9, "{}", back.positions[0]);
        let n = back.normals.unwrap()[0];
        assert!((n - crate::math::Vector3::y()).norm() < 1e-6, "{n}");
    }

    /// A pose quaternion (2, 0, 0, 0) scaled the cloud ×4 (issue 37): a near-unit one is normalised, one
    /// far from unit or zero is refused naming the pose.
    #[test]
    fn pose_quaternions_are_normalised_or_refused() {
        let q = |w, x, y, z| e57::Quaternion { w, x, y, z };
        for bad in [q(2.0, 0.0, 0.0, 0.0), q(0.0, 0.0, 0.0, 0.0), q(0.5, 0.0, 0.0, 0.0)] {
            let e = parse(&posed(bad.clone())).unwrap_err().to_string();
            assert!(e.contains("data3D[0].pose") && e.contains("not a rotation"), "{bad:?}: {e}");
        }
        let near = parse(&posed(q(1.0 + 1e-5, 0.0, 0.0, 0.0))).unwrap();
        assert!((near.positions[0] - Point3::new(100.0, 0.0, 0.0)).norm() < 1e-9, "{}", near.positions[0]);
        // A quarter turn about z, written as an unnormalised (w, z) = (0.7071, 0.7071) at four decimals.
        let h = (0.5f64.sqrt() * 1e4).round() / 1e4;
        let turned = parse(&posed(q(h, 0.0, 0.0, h))).unwrap();
        assert!((turned.positions[0] - Point3::new(0.0, 100.0, 0.0)).norm() < 1e-9, "{}", turned.positions[0]);
    }

    #[test]
    fn damaged_files_are_refused() {
        let b = cloud_to_bytes(&PointCloud::from_positions(vec![Point3::origin(); 10])).unwrap();
        assert!(parse(&b[..b.len() / 2]).is_err());
        assert!(parse(b"not an e57 file at all, not even close to one").unwrap_err().to_string().contains("E57"));
        let mut flipped = b.clone();
        let mid = flipped.len() / 2;
        flipped[mid] ^= 0xff;
        assert!(parse(&flipped).is_err(), "the page checksums catch a changed byte");
    }
}
