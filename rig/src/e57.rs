//! E57 (ASTM E2807), the point-cloud format surveying and heritage tools exchange: read and written with
//! the `e57` crate (see the README's list of crates).
//!
//! E57's coordinates are metres; scanrig's are millimetres: writing divides by 1000 and reading
//! multiplies back. Colours are stored as 8-bit integers. Every point cloud of a file is read, placed by
//! its pose, into one cloud; points without valid Cartesian coordinates (a scanner's "no return") are
//! left out. Normals, confidence and view ids have no standard E57 field and are not written.

use crate::error::{Error, Location, ParseError, Problem, read_bytes, write_atomic};
use crate::math::Point3;
use crate::point_cloud::PointCloud;
use e57::{CartesianCoordinate, E57Reader, E57Writer, Record, RecordValue};
use std::io::Cursor;
use std::path::Path;

/// A fixed GUID per written cloud is allowed (GUIDs identify data sets, they need not be random) and
/// keeps the bytes reproducible; the file's own is derived from the cloud's size.
const GUID_PREFIX: &str = "scanrig-e57";

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
        let mut pc = w.add_pointcloud(&format!("{GUID_PREFIX}-cloud"), proto).map_err(err)?;
        pc.set_name(Some("scanrig point cloud".into()));
        for (i, p) in cloud.positions.iter().enumerate() {
            let mut values: Vec<RecordValue> = p.coords.iter().map(|&c| RecordValue::Double(c / 1000.0)).collect();
            if let Some(c) = &cloud.colors {
                values.extend(c[i].map(|v| RecordValue::Integer(v as i64)));
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

/// Parses E57 bytes into one cloud (millimetres), with colours where every point cloud has them.
pub fn parse(bytes: &[u8]) -> Result<PointCloud, ParseError> {
    let invalid = |what: &str, e: e57::Error| ParseError::new(Location::File, Problem::Invalid(format!("{what}: {e}")));
    let mut reader = E57Reader::new(Cursor::new(bytes)).map_err(|e| invalid("not a readable E57 file", e))?;
    let clouds = reader.pointclouds();
    let all_coloured = !clouds.is_empty() && clouds.iter().all(|c| c.has_color());
    let mut out = PointCloud::default();
    let mut colors = Vec::new();
    for (k, pc) in clouds.iter().enumerate() {
        let mut points = reader.pointcloud_simple(pc).map_err(|e| invalid(&format!("point cloud {k}"), e))?;
        points.apply_pose(true);
        for p in points {
            let p = p.map_err(|e| invalid(&format!("point cloud {k}"), e))?;
            let CartesianCoordinate::Valid { x, y, z } = p.cartesian else { continue };
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
    }
    if all_coloured {
        out.colors = Some(colors);
    }
    Ok(out)
}

/// Reads an E57 file (see [`parse`]).
pub fn read(path: &Path) -> Result<PointCloud, Error> {
    parse(&read_bytes(path)?).map_err(|e| e.with_path(path))
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
        assert_eq!((bare.len(), bare.colors), (1, None));
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
