//! What reading back a file scanrig writes gives, without writing and parsing it: the pipeline hands
//! each stage exactly what the previous stage's file holds (so a resumed run and a fresh one agree),
//! and parsing a 3 M-point cloud back costs as much as the stage that made it. Binary bodies only —
//! the values are then the written scalars bit for bit; where only a parse can tell (ASCII, a value
//! the file's type cannot hold), `None` says to parse. The tests check each against the parse.

use super::{Encoding, Precision, WriteOptions};
use crate::math::{Point3, Real, UnitVector3, Vector3};
use crate::range_grid::Sensor;
use crate::{PointCloud, RangeGrid};

/// `x` as the file's coordinate type holds it.
fn stored(x: Real, precision: Precision) -> Real {
    match precision {
        Precision::F32 => x as f32 as Real,
        Precision::F64 => x,
    }
}

fn point(p: &Point3, precision: Precision) -> Point3 {
    p.map(|c| stored(c, precision))
}

fn vector(v: &Vector3, precision: Precision) -> Vector3 {
    v.map(|c| stored(c, precision))
}

fn binary(opts: &WriteOptions) -> bool {
    opts.encoding != Encoding::Ascii
}

/// [`cloud_from_ply`](super::cloud_from_ply) of [`cloud_to_bytes`](super::cloud_to_bytes).
pub fn cloud_as_written(cloud: &PointCloud, opts: &WriteOptions) -> Option<PointCloud> {
    let precision = opts.holding(&cloud.positions).precision;
    // The reader refuses a position the file holds as infinite or NaN: only its error says so.
    let positions: Vec<Point3> = cloud.positions.iter().map(|p| point(p, precision)).collect();
    if !binary(opts) || !positions.iter().all(|p| p.iter().all(|c| c.is_finite())) {
        return None;
    }
    // Ids beyond i32 are written as uint, which reads back the same; the cast is exact either way.
    Some(PointCloud {
        positions,
        normals: cloud.normals.as_ref().map(|n| n.iter().map(|v| vector(v, precision)).collect()),
        colors: cloud.colors.clone(),
        confidence: cloud.confidence.clone(),
        view_id: cloud.view_id.clone(),
    })
}

/// [`range_grid_from_ply`](super::range_grid_from_ply) of
/// [`range_grid_to_bytes`](super::range_grid_to_bytes): valid cells as stored, the rest empty as the
/// reader leaves them, and the sensor as its header comment reads back.
pub fn range_grid_as_written(grid: &RangeGrid, opts: &WriteOptions) -> Option<RangeGrid> {
    let precision = opts.holding(super::write::valid_points(grid)).precision;
    if !binary(opts) || grid.width.checked_mul(grid.height) != Some(grid.valid.len()) {
        return None;
    }
    let sensor = match &grid.sensor {
        Sensor::Center(c) => Sensor::Center(*c),
        // Printed in full and parsed back exactly, then normalised again by the reader.
        Sensor::Direction(d) => Sensor::Direction(UnitVector3::try_new(d.into_inner(), 1e-12)?),
        // Not written: the reader's default.
        Sensor::PerCell(_) => Sensor::Direction(UnitVector3::new_unchecked(Vector3::z())),
    };
    let mut out = RangeGrid::empty(grid.width, grid.height, sensor);
    let cells = grid.valid.len();
    out.normals = grid.normals.as_ref().map(|_| vec![Vector3::zeros(); cells]);
    out.confidence = grid.confidence.as_ref().map(|_| vec![0.0; cells]);
    out.colors = grid.colors.as_ref().map(|_| vec![[0; 3]; cells]);
    for i in (0..cells).filter(|&i| grid.valid[i]) {
        let p = point(&grid.points[i], precision);
        if !p.iter().all(|c| c.is_finite()) {
            return None;
        }
        out.points[i] = p;
        out.valid[i] = true;
        if let (Some(dst), Some(src)) = (out.normals.as_mut(), grid.normals.as_ref()) {
            dst[i] = vector(&src[i], precision);
        }
        if let (Some(dst), Some(src)) = (out.confidence.as_mut(), grid.confidence.as_ref()) {
            dst[i] = src[i];
        }
        if let (Some(dst), Some(src)) = (out.colors.as_mut(), grid.colors.as_ref()) {
            dst[i] = src[i];
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ply::{cloud_from_ply, cloud_to_bytes, parse, range_grid_from_ply, range_grid_to_bytes};
    use proptest::prelude::*;

    fn bits(p: &[Real]) -> Vec<u64> {
        p.iter().map(|x| x.to_bits()).collect()
    }

    fn same_cloud(a: &PointCloud, b: &PointCloud) -> bool {
        let flat = |v: &[Point3]| bits(&v.iter().flat_map(|p| [p.x, p.y, p.z]).collect::<Vec<_>>());
        let flatn = |v: &Option<Vec<Vector3>>| {
            v.as_ref().map(|v| bits(&v.iter().flat_map(|p| [p.x, p.y, p.z]).collect::<Vec<_>>()))
        };
        flat(&a.positions) == flat(&b.positions)
            && flatn(&a.normals) == flatn(&b.normals)
            && a.colors == b.colors
            && a.confidence.as_ref().map(|c| c.iter().map(|x| x.to_bits()).collect::<Vec<_>>())
                == b.confidence.as_ref().map(|c| c.iter().map(|x| x.to_bits()).collect::<Vec<_>>())
            && a.view_id == b.view_id
    }

    fn coordinate() -> impl Strategy<Value = Real> {
        prop_oneof![-1e4..1e4f64, Just(0.0), Just(-0.0), Just(1e-40), Just(123.456_789_012_345)]
    }

    fn precision() -> impl Strategy<Value = Precision> {
        prop_oneof![Just(Precision::F32), Just(Precision::F64)]
    }

    /// A cloud's body is written in runs of points on several threads: across run boundaries, in
    /// every encoding, parsing its bytes gives every point back in order.
    #[test]
    fn a_cloud_of_several_runs_reads_back_point_for_point() {
        let n = 150_001;
        let cloud = PointCloud {
            positions: (0..n).map(|i| Point3::new(i as Real * 0.5, -(i as Real), 1.0 / (i as Real + 1.0))).collect(),
            normals: Some((0..n).map(|i| Vector3::new(0.0, (i % 3) as Real, 1.0)).collect()),
            colors: Some((0..n).map(|i| [i as u8, (i >> 8) as u8, 7]).collect()),
            confidence: Some((0..n).map(|i| i as f32).collect()),
            view_id: Some((0..n).map(|i| (i / 1000) as u32).collect()),
        };
        for encoding in [Encoding::Ascii, Encoding::BinaryLittleEndian, Encoding::BinaryBigEndian] {
            let opts = WriteOptions { encoding, precision: Precision::F64, ..Default::default() };
            let parsed = cloud_from_ply(&parse(&cloud_to_bytes(&cloud, &opts)).unwrap()).unwrap();
            assert!(same_cloud(&cloud, &parsed), "{encoding:?}");
        }
    }

    proptest! {
        #[test]
        fn a_cloud_as_written_is_what_parsing_its_bytes_gives(
            xyz in prop::collection::vec((coordinate(), coordinate(), coordinate()), 0..40),
            with in (any::<bool>(), any::<bool>(), any::<bool>(), any::<bool>()),
            big_id in any::<bool>(),
            precision in precision(),
        ) {
            let n = xyz.len();
            let cloud = PointCloud {
                positions: xyz.iter().map(|&(x, y, z)| Point3::new(x, y, z)).collect(),
                normals: with.0.then(|| xyz.iter().map(|&(x, y, z)| Vector3::new(z, x, y) / 1e4).collect()),
                colors: with.1.then(|| (0..n).map(|i| [i as u8, (i * 7) as u8, 255]).collect()),
                confidence: with.2.then(|| (0..n).map(|i| i as f32 / 3.0).collect()),
                view_id: with.3.then(|| (0..n).map(|i| if big_id { u32::MAX - i as u32 } else { i as u32 }).collect()),
            };
            let opts = WriteOptions { precision, ..Default::default() };
            let parsed = cloud_from_ply(&parse(&cloud_to_bytes(&cloud, &opts)).unwrap()).unwrap();
            let fast = cloud_as_written(&cloud, &opts).expect("binary, finite");
            prop_assert!(same_cloud(&fast, &parsed), "{fast:?}\nvs\n{parsed:?}");
        }

        #[test]
        fn a_range_grid_as_written_is_what_parsing_its_bytes_gives(
            w in 1usize..7, h in 1usize..7,
            seed in any::<u64>(),
            with in (any::<bool>(), any::<bool>(), any::<bool>()),
            sensor in 0u8..3,
            precision in precision(),
        ) {
            let cells = w * h;
            let r = |i: usize, k: u64| {
                let x = seed.wrapping_mul(6364136223846793005).wrapping_add((i as u64).wrapping_mul(1442695040888963407)).wrapping_add(k);
                (x >> 11) as f64 / (1u64 << 53) as f64
            };
            let mut grid = RangeGrid::empty(w, h, match sensor {
                0 => Sensor::Center(Point3::new(r(0, 1) * 100.0, -r(0, 2), 0.3)),
                1 => Sensor::Direction(UnitVector3::new_normalize(Vector3::new(r(0, 3), 0.2, 1.0))),
                _ => Sensor::PerCell(vec![UnitVector3::new_unchecked(Vector3::x()); cells]),
            });
            for i in 0..cells {
                grid.valid[i] = r(i, 4) < 0.7;
                if grid.valid[i] {
                    grid.points[i] = Point3::new(r(i, 5) * 300.0 - 150.0, r(i, 6) * 1e-3, 412.123_456_789 + r(i, 7));
                }
            }
            grid.normals = with.0.then(|| (0..cells).map(|i| Vector3::new(r(i, 8), r(i, 9), 1.0).normalize()).collect());
            grid.confidence = with.1.then(|| (0..cells).map(|i| r(i, 10) as f32).collect());
            grid.colors = with.2.then(|| (0..cells).map(|i| [i as u8, 3, 200]).collect());
            let opts = WriteOptions { precision, ..Default::default() };
            let parsed = range_grid_from_ply(&parse(&range_grid_to_bytes(&grid, &opts)).unwrap()).unwrap();
            let fast = range_grid_as_written(&grid, &opts).expect("binary, finite");
            let as_cloud = |g: &RangeGrid| PointCloud {
                positions: g.points.clone(),
                normals: g.normals.clone(),
                colors: g.colors.clone(),
                confidence: g.confidence.clone(),
                view_id: None,
            };
            prop_assert_eq!((fast.width, fast.height), (parsed.width, parsed.height));
            prop_assert_eq!(&fast.valid, &parsed.valid);
            prop_assert!(same_cloud(&as_cloud(&fast), &as_cloud(&parsed)));
            let sensor_bits = |s: &Sensor| match s {
                Sensor::Center(c) => bits(&[0.0, c.x, c.y, c.z]),
                Sensor::Direction(d) => bits(&[1.0, d.x, d.y, d.z]),
                Sensor::PerCell(_) => vec![2],
            };
            prop_assert_eq!(sensor_bits(&fast.sensor), sensor_bits(&parsed.sensor));
        }
    }

    #[test]
    fn what_only_a_parse_can_tell_is_left_to_it() {
        let cloud = PointCloud::from_positions(vec![Point3::new(1e300, 0.0, 0.0)]);
        // 1e300 is infinite as a float: the writer takes double for it (as for any coordinate single
        // precision would not hold), and the value comes back as it was.
        let written = cloud_as_written(&cloud, &WriteOptions::default()).unwrap();
        assert_eq!(written.positions[0].x, 1e300);
        let parsed = cloud_from_ply(&parse(&cloud_to_bytes(&cloud, &WriteOptions::default())).unwrap()).unwrap();
        assert_eq!(parsed.positions, written.positions);
        assert!(cloud_as_written(&PointCloud::default(), &WriteOptions::ascii()).is_none());
    }
}
