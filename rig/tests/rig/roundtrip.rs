//! Write → read is the identity: point clouds (normals, colours, confidence, view ids) and triangle and
//! quad meshes, through binary and ASCII PLY (float and double) and OBJ. Property tests over random data.

use proptest::prelude::*;
use rig::ply::{self, Encoding, Precision, WriteOptions};
use rig::{Point3, PointCloud, PolyMesh, Vector3, obj};

fn coord() -> impl Strategy<Value = f64> {
    prop_oneof![-1e4..1e4f64, -1.0..1.0f64, Just(0.0), Just(-0.0), (-1e-30..1e-30f64)]
}

fn point() -> impl Strategy<Value = Point3> {
    (coord(), coord(), coord()).prop_map(|(x, y, z)| Point3::new(x, y, z))
}

fn vector() -> impl Strategy<Value = Vector3> {
    (coord(), coord(), coord()).prop_map(|(x, y, z)| Vector3::new(x, y, z))
}

fn cloud() -> impl Strategy<Value = PointCloud> {
    (0usize..40).prop_flat_map(|n| {
        (
            prop::collection::vec(point(), n),
            prop::option::of(prop::collection::vec(vector(), n)),
            prop::option::of(prop::collection::vec(any::<[u8; 3]>(), n)),
            prop::option::of(prop::collection::vec(-1e6f32..1e6f32, n)),
            prop::option::of(prop::collection::vec(any::<u32>(), n)),
        )
            .prop_map(|(positions, normals, colors, confidence, view_id)| PointCloud {
                positions,
                normals,
                colors,
                confidence,
                view_id,
            })
    })
}

/// A mesh of `sizes` faces (3 = triangles, 4 = quads, or mixed up to hexagons).
fn mesh(sizes: std::ops::RangeInclusive<usize>) -> impl Strategy<Value = PolyMesh> {
    (1usize..30).prop_flat_map(move |nv| {
        let face = sizes.clone().prop_flat_map(move |k| prop::collection::vec(0..nv as u32, k));
        (
            prop::collection::vec(point(), nv),
            prop::collection::vec(face, 0..40),
            prop::bool::ANY,
            prop::collection::vec(vector(), nv),
        )
            .prop_map(|(v, faces, with_normals, n)| {
                let mut m = PolyMesh::from_faces(v, faces);
                m.normals = with_normals.then_some(n);
                m
            })
    })
}

fn to_f32(p: &Point3) -> Point3 {
    p.map(|c| c as f32 as f64)
}

fn round_cloud(c: &PointCloud, precision: Precision) -> PointCloud {
    let mut c = c.clone();
    if precision == Precision::F32 {
        c.positions.iter_mut().for_each(|p| *p = to_f32(p));
        c.normals.iter_mut().flatten().for_each(|n| *n = n.map(|c| c as f32 as f64));
    }
    c
}

const ENCODINGS: [Encoding; 3] = [Encoding::BinaryLittleEndian, Encoding::BinaryBigEndian, Encoding::Ascii];

proptest! {
    #[test]
    fn ply_cloud_round_trip(c in cloud()) {
        for encoding in ENCODINGS {
            for precision in [Precision::F32, Precision::F64] {
                let opts = WriteOptions { encoding, precision, comments: vec!["units mm".into()] };
                let bytes = ply::cloud_to_bytes(&c, &opts);
                let parsed = ply::parse(&bytes).unwrap();
                prop_assert_eq!(parsed.header.units(), Some("mm".to_string()));
                let back = ply::cloud_from_ply(&parsed).unwrap();
                // `float` where single precision holds the points, else `double` whatever was asked.
                let stored = opts.holding(&c.positions).precision;
                prop_assert_eq!(&back, &round_cloud(&c, stored), "{:?} {:?}", encoding, precision);
            }
        }
    }

    #[test]
    fn ply_mesh_round_trip(m in mesh(3..=6)) {
        for encoding in ENCODINGS {
            for precision in [Precision::F32, Precision::F64] {
                let opts = WriteOptions { encoding, precision, comments: vec![] };
                let back = ply::mesh_from_ply(&ply::parse(&ply::mesh_to_bytes(&m, &opts)).unwrap()).unwrap();
                let mut expect = m.clone();
                if opts.holding(&m.vertices).precision == Precision::F32 {
                    expect.vertices.iter_mut().for_each(|p| *p = to_f32(p));
                    expect.normals.iter_mut().flatten().for_each(|n| *n = n.map(|c| c as f32 as f64));
                }
                prop_assert_eq!(&back, &expect, "{:?} {:?}", encoding, precision);
            }
        }
    }

    #[test]
    fn obj_mesh_round_trip_triangles(m in mesh(3..=3)) {
        let back = obj::parse(&obj::mesh_to_bytes(&m, None)).unwrap();
        prop_assert_eq!(back.mesh, m);
    }

    #[test]
    fn obj_mesh_round_trip_quads(m in mesh(4..=4)) {
        let back = obj::parse(&obj::mesh_to_bytes(&m, None)).unwrap();
        prop_assert_eq!(back.mesh, m);
    }

    #[test]
    fn obj_cloud_round_trip(c in cloud()) {
        // OBJ holds positions, colours and normals; confidence and view ids need PLY.
        let c = PointCloud { confidence: None, view_id: None, ..c };
        let back = obj::parse(&obj::cloud_to_bytes(&c, None)).unwrap();
        prop_assert_eq!(&back.mesh.vertices, &c.positions);
        prop_assert_eq!(back.colors, c.colors.filter(|v| !v.is_empty()));
        prop_assert_eq!(back.mesh.normals, c.normals.filter(|v| !v.is_empty()));
    }
}

#[test]
fn files_on_disk_round_trip_through_the_extension_dispatch() {
    let dir = fixtures::temp_dir("rig-roundtrip");
    let quads = PolyMesh::from_faces(
        vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(1.0, 1.0, 0.5),
            Point3::new(0.0, 1.0, 0.25),
        ],
        [[0u32, 1, 2, 3]],
    );
    for name in ["q.ply", "q.obj"] {
        let path = dir.join(name);
        rig::write_mesh(&path, &quads, &WriteOptions::default()).unwrap();
        assert_eq!(rig::read_mesh(&path).unwrap(), quads, "{name}");
    }
}

fn range_grid() -> impl Strategy<Value = rig::RangeGrid> {
    (1usize..12, 1usize..9).prop_flat_map(|(w, h)| {
        (
            prop::collection::vec(prop::option::of(point()), w * h),
            prop::collection::vec(vector(), w * h),
            prop::collection::vec(0f32..1.0, w * h),
            prop::bool::ANY,
            point(),
        )
            .prop_map(move |(cells, normals, confidence, center, sensor)| {
                let sensor = if center {
                    rig::Sensor::Center(sensor)
                } else {
                    rig::Sensor::Direction(rig::UnitVector3::new_normalize(Vector3::new(0.3, -0.2, 1.0)))
                };
                let mut g = rig::RangeGrid::empty(w, h, sensor);
                for (i, c) in cells.into_iter().enumerate() {
                    if let Some(p) = c {
                        g.points[i] = p;
                        g.valid[i] = true;
                    }
                }
                // Only valid cells are stored: invalid cells read back with zero normal and confidence.
                g.normals =
                    Some(normals.iter().zip(&g.valid).map(|(n, &v)| if v { *n } else { Vector3::zeros() }).collect());
                g.confidence = Some(confidence.iter().zip(&g.valid).map(|(c, &v)| if v { *c } else { 0.0 }).collect());
                g
            })
    })
}

proptest! {
    #[test]
    fn ply_range_grid_round_trip(g in range_grid()) {
        for encoding in ENCODINGS {
            let opts = WriteOptions { encoding, precision: Precision::F64, comments: vec![] };
            let back = ply::range_grid_from_ply(&ply::parse(&ply::range_grid_to_bytes(&g, &opts)).unwrap()).unwrap();
            prop_assert_eq!((back.width, back.height), (g.width, g.height));
            prop_assert_eq!(&back.valid, &g.valid);
            prop_assert_eq!(&back.sensor, &g.sensor);
            for i in 0..g.valid.len() {
                if g.valid[i] {
                    prop_assert_eq!(back.points[i], g.points[i]);
                }
            }
            prop_assert_eq!(&back.normals, &g.normals);
            prop_assert_eq!(&back.confidence, &g.confidence);
        }
    }
}

fn sparse_view() -> impl Strategy<Value = rig::SparseView> {
    (1usize..2000, 1usize..2000).prop_flat_map(|(w, h)| {
        let pixel = (-0.5f32..w as f32 - 0.5, -0.5f32..h as f32 - 0.5);
        (prop::collection::vec((point(), pixel, 0f32..1.0), 0..40), point()).prop_map(move |(pts, c)| {
            let mut v = rig::SparseView::empty(w, h, rig::Sensor::Center(c));
            for (p, (col, row), k) in pts {
                v.push(p, [col, row], k);
            }
            v
        })
    })
}

proptest! {
    #[test]
    fn ply_sparse_view_round_trip(v in sparse_view()) {
        for encoding in ENCODINGS {
            let opts = WriteOptions { encoding, precision: Precision::F64, comments: vec![] };
            let bytes = ply::sparse_view_to_bytes(&v, &opts);
            let back = ply::sparse_view_from_ply(&ply::parse(&bytes).unwrap()).unwrap();
            prop_assert_eq!(&back, &v);
            // And it is a plain cloud to every other reader.
            let cloud = ply::cloud_from_ply(&ply::parse(&bytes).unwrap()).unwrap();
            prop_assert_eq!(cloud.positions, v.points.clone());
        }
    }
}

/// A sparse view's pixel outside its image is refused, naming the vertex.
#[test]
fn a_sparse_view_pixel_outside_the_image_is_refused() {
    let mut v = rig::SparseView::empty(64, 48, rig::Sensor::Center(Point3::origin()));
    v.push(Point3::new(1.0, 2.0, 300.0), [10.0, 5.0], 0.5);
    v.push(Point3::new(1.0, 2.0, 300.0), [10.0, 48.0], 0.5);
    let bytes = ply::sparse_view_to_bytes(&v, &WriteOptions::ascii());
    let err = ply::sparse_view_from_ply(&ply::parse(&bytes).unwrap()).unwrap_err().to_string();
    assert!(err.contains("vertex") && err.contains("outside the 64 × 48 image"), "{err}");
    // An image no camera has (a grid of it could not be allocated) is refused too.
    let huge = String::from_utf8(bytes).unwrap().replace("num_cols 64", "num_cols 4000000000");
    let err = ply::sparse_view_from_ply(&ply::parse(huge.as_bytes()).unwrap()).unwrap_err().to_string();
    assert!(err.contains("4000000000 × 48 image, which no camera has"), "{err}");
}

/// A polygon with more corners than a `uchar` count holds is written whole, with a wider count, in
/// every encoding: one face of 300 corners reads back as that face.
#[test]
fn a_polygon_of_300_corners_survives_ply() {
    let n = 300;
    let vertices: Vec<Point3> = (0..n)
        .map(|k| {
            let a = k as f64 / n as f64 * std::f64::consts::TAU;
            Point3::new(a.cos(), a.sin(), 0.0)
        })
        .collect();
    let m = PolyMesh::from_faces(vertices, [(0..n as u32).collect::<Vec<_>>(), vec![0, 1, 2]]);
    for encoding in [ply::Encoding::Ascii, ply::Encoding::BinaryLittleEndian, ply::Encoding::BinaryBigEndian] {
        let opts = WriteOptions { encoding, precision: Precision::F64, comments: Vec::new() };
        let bytes = ply::mesh_to_bytes(&m, &opts);
        assert!(String::from_utf8_lossy(&bytes[..400]).contains("list ushort int vertex_indices"));
        let back = ply::mesh_from_ply(&ply::parse(&bytes).unwrap()).unwrap();
        assert_eq!(back.face_count(), 2);
        assert_eq!(back.faces().next().unwrap().len(), n);
        assert_eq!(back, m);
    }
}
