//! A catalogue of malformed files: each gives its typed error naming the file and the spot, never a panic.

use rig::ply::{self, WriteOptions};
use rig::{Error, Location, Point3, PolyMesh, Problem};
use std::path::Path;

type Reader = fn(&Path) -> Result<(), Error>;

fn mesh(p: &Path) -> Result<(), Error> {
    rig::read_mesh(p).map(|_| ())
}
fn cloud(p: &Path) -> Result<(), Error> {
    rig::read_cloud(p).map(|_| ())
}
fn grid(p: &Path) -> Result<(), Error> {
    ply::read_range_grid(p).map(|_| ())
}
fn rig_toml(p: &Path) -> Result<(), Error> {
    rig::Rig::read(p).map(|_| ())
}
fn yaml(p: &Path) -> Result<(), Error> {
    rig::opencv_yaml::read_camera(p).map(|_| ())
}

const ASCII_HEAD: &str =
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
const FACE_HEAD: &str = "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
const VERTS: &str = "0 0 0\n1 0 0\n0 1 0\n";

fn ascii(face_line: &str) -> Vec<u8> {
    format!("{ASCII_HEAD}{FACE_HEAD}{VERTS}{face_line}\n").into_bytes()
}

fn binary_triangle() -> Vec<u8> {
    let m = PolyMesh::from_faces(
        vec![Point3::new(0.0, 0.0, 0.0), Point3::new(1.0, 0.0, 0.0), Point3::new(0.0, 1.0, 0.0)],
        [[0u32, 1, 2], [2, 1, 0]],
    );
    ply::mesh_to_bytes(&m, &WriteOptions::default())
}

struct Case {
    name: &'static str,
    bytes: Vec<u8>,
    read: Reader,
    /// The expected `Display` text after the path.
    message: &'static str,
    is: fn(&Problem) -> bool,
}

fn catalogue() -> Vec<Case> {
    let truncated = {
        let b = binary_triangle();
        b[..b.len() - 5].to_vec()
    };
    let mut c = vec![
        Case {
            name: "truncated.ply",
            bytes: truncated,
            read: mesh,
            message: "element `face` #1: the file ends before the 3 items of list `vertex_indices` (at least 12 bytes; 7 remain)",
            is: |p| matches!(p, Problem::Truncated(_)),
        },
        Case {
            name: "count_bomb.ply",
            bytes: b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty double x\nproperty double y\nproperty double z\nend_header\n\0\0\0\0".to_vec(),
            read: mesh,
            message: "element `vertex` #0: declares 4000000000 entries of at least 24 bytes each, but only 4 bytes remain",
            is: |p| matches!(p, Problem::CountTooLarge { count: 4_000_000_000, .. }),
        },
        Case {
            name: "index_out_of_range.ply",
            bytes: ascii("3 0 1 7"),
            read: mesh,
            message: "element `face` #0: vertex index 7 is out of range (there are 3 vertices, numbered 0 to 2)",
            is: |p| matches!(p, Problem::IndexOutOfRange { index, count: 3, .. } if &**index == "7"),
        },
        Case {
            name: "float_index.ply",
            bytes: format!(
                "{ASCII_HEAD}element face 1\nproperty list uchar float vertex_indices\nend_header\n{VERTS}3 0 1.5 2\n"
            )
            .into_bytes(),
            read: mesh,
            message: "element `face` #0: face index 1.5 is not a whole number",
            is: |p| matches!(p, Problem::FractionalIndex(i) if i == "1.5"),
        },
        Case {
            name: "nan_index.ply",
            bytes: format!(
                "{ASCII_HEAD}element face 1\nproperty list uchar float vertex_indices\nend_header\n{VERTS}3 0 nan 2\n"
            )
            .into_bytes(),
            read: mesh,
            message: "element `face` #0: face index NaN is not a whole number",
            is: |p| matches!(p, Problem::FractionalIndex(_)),
        },
        Case {
            name: "negative_index.ply",
            bytes: ascii("3 0 -1 2"),
            read: mesh,
            message: "element `face` #0: vertex index -1 is out of range (there are 3 vertices, numbered 0 to 2)",
            is: |p| matches!(p, Problem::IndexOutOfRange { index, .. } if &**index == "-1"),
        },
        Case {
            name: "not_a_number.ply",
            bytes: format!("{ASCII_HEAD}{FACE_HEAD}0 0 0\n1 abc 0\n0 1 0\n3 0 1 2\n").into_bytes(),
            read: mesh,
            message: "element `vertex` #1 (line 11): `abc` is not a number",
            is: |p| matches!(p, Problem::NotANumber(t) if t == "abc"),
        },
        // Issue 19, defect 16: which `x`, which vertex set? Refused rather than one silently chosen.
        Case {
            name: "duplicate_property.ply",
            bytes: b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float x\nend_header\n1 2 3\n"
                .to_vec(),
            read: cloud,
            message: "line 6: property `x` of element `vertex` is declared twice",
            is: |p| matches!(p, Problem::Invalid(_)),
        },
        Case {
            name: "duplicate_element.ply",
            bytes: b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nelement vertex 1\nproperty float x\nend_header\n1\n2\n"
                .to_vec(),
            read: cloud,
            message: "line 5: element `vertex` is declared twice",
            is: |p| matches!(p, Problem::Invalid(_)),
        },
        Case {
            name: "unknown_header_line.ply",
            bytes: b"ply\nformat ascii 1.0\ncolour red\nend_header\n".to_vec(),
            read: mesh,
            message: "line 3: unknown header line `colour red`",
            is: |p| matches!(p, Problem::UnknownHeaderLine(_)),
        },
        Case {
            name: "no_end_header.ply",
            bytes: b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n".to_vec(),
            read: mesh,
            message: "line 4: the header has no `end_header` line",
            is: |p| matches!(p, Problem::MissingEndHeader),
        },
        Case {
            name: "nan.ply",
            bytes: format!("{ASCII_HEAD}{FACE_HEAD}0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n").into_bytes(),
            read: mesh,
            message: "element `vertex` #1: position (1, NaN, 0) is not finite",
            is: |p| matches!(p, Problem::NonFinite(_)),
        },
        Case {
            name: "infinite_cloud.ply",
            bytes: b"ply\nformat ascii 1.0\nelement vertex 1\nproperty double x\nproperty double y\nproperty double z\nend_header\n0 inf 0\n".to_vec(),
            read: cloud,
            message: "element `vertex` #0: position (0, inf, 0) is not finite",
            is: |p| matches!(p, Problem::NonFinite(_)),
        },
        Case {
            name: "bad_magic.ply",
            bytes: b"plx\nformat ascii 1.0\n".to_vec(),
            read: mesh,
            message: "line 1: not a PLY file (it starts with `plx`)",
            is: |p| matches!(p, Problem::BadMagic { .. }),
        },
        Case {
            name: "unknown_type.ply",
            bytes: b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n".to_vec(),
            read: mesh,
            message: "line 4: unknown property type `float128`",
            is: |p| matches!(p, Problem::UnknownType(_)),
        },
        Case {
            name: "property_first.ply",
            bytes: b"ply\nformat ascii 1.0\nproperty float x\nend_header\n".to_vec(),
            read: mesh,
            message: "line 3: `property` before any `element`",
            is: |p| matches!(p, Problem::Invalid(_)),
        },
        Case {
            name: "middle_endian.ply",
            bytes: b"ply\nformat binary_middle_endian 1.0\nend_header\n".to_vec(),
            read: mesh,
            message: "line 2: unsupported format `binary_middle_endian`",
            is: |p| matches!(p, Problem::UnsupportedFormat(_)),
        },
        Case {
            name: "version2.ply",
            bytes: b"ply\nformat ascii 2.0\nend_header\n".to_vec(),
            read: mesh,
            message: "line 2: unsupported format `ascii 2.0`",
            is: |p| matches!(p, Problem::UnsupportedFormat(_)),
        },
        Case {
            name: "no_format.ply",
            bytes: b"ply\nelement vertex 0\nend_header\n".to_vec(),
            read: mesh,
            message: "line 3: missing `format` line in the header",
            is: |p| matches!(p, Problem::Missing(_)),
        },
        Case {
            name: "negative_list.ply",
            bytes: b"ply\nformat ascii 1.0\nelement vertex 0\nelement face 1\nproperty list char int vertex_indices\nend_header\n-3 0 1 2\n".to_vec(),
            read: mesh,
            message: "element `face` #0 (line 7): list `vertex_indices` has negative length -3",
            is: |p| matches!(p, Problem::Invalid(_)),
        },
        Case {
            name: "list_bomb.ply",
            bytes: {
                let mut b = b"ply\nformat binary_little_endian 1.0\nelement face 1\nproperty list uint int vertex_indices\nend_header\n".to_vec();
                b.extend_from_slice(&u32::MAX.to_le_bytes());
                b
            },
            read: |p| ply::read(p).map(|_| ()),
            message: "element `face` #0: the file ends before the 4294967295 items of list `vertex_indices` (at least 17179869180 bytes; 0 remain)",
            is: |p| matches!(p, Problem::Truncated(_)),
        },
        Case {
            name: "uchar_300.ply",
            bytes: ascii("300 0 1 2"),
            read: mesh,
            message: "element `face` #0 (line 13): 300 does not fit the type `uchar`",
            is: |p| matches!(p, Problem::OutOfRange { .. }),
        },
        Case {
            name: "trailing.ply",
            bytes: ascii("3 0 1 2\n9 9 9"),
            read: mesh,
            message: "line 14: unexpected data after the last element: `9`",
            is: |p| matches!(p, Problem::TrailingData(_)),
        },
        Case {
            name: "two_corner_face.ply",
            bytes: ascii("2 0 1"),
            read: mesh,
            message: "element `face` #0: a face needs at least 3 vertices, this one has 2",
            is: |p| matches!(p, Problem::DegenerateFace(2)),
        },
        Case {
            name: "no_x.ply",
            bytes: b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float u\nend_header\n1\n".to_vec(),
            read: cloud,
            message: "file: missing scalar property `x` of element `vertex`",
            is: |p| matches!(p, Problem::Missing(_)),
        },
        Case {
            name: "grid_mismatch.ply",
            bytes: b"ply\nformat ascii 1.0\nobj_info num_cols 3\nobj_info num_rows 2\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nelement range_grid 5\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0\n0\n0\n0\n0\n".to_vec(),
            read: grid,
            message: "file: range_grid has 5 cells but obj_info says 3 × 2",
            is: |p| matches!(p, Problem::Invalid(_)),
        },
        Case {
            name: "float_count.ply",
            bytes: b"ply\nformat ascii 1.0\nelement face 0\nproperty list float int vertex_indices\nend_header\n".to_vec(),
            read: mesh,
            message: "line 4: malformed header line `property list float int vertex_indices`",
            is: |p| matches!(p, Problem::MalformedHeaderLine(_)),
        },
        Case {
            name: "zero_index.obj",
            bytes: b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n".to_vec(),
            read: mesh,
            // OBJ counts from 1: the index is reported as written.
            message: "line 4: vertex index 0 is out of range (there are 3 vertices, numbered 1 to 3)",
            is: |p| matches!(p, Problem::IndexOutOfRange { index, first: 1, .. } if &**index == "0"),
        },
        Case {
            name: "far_index.obj",
            bytes: b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4/1/1\n".to_vec(),
            read: mesh,
            message: "line 4: vertex index 4 is out of range (there are 3 vertices, numbered 1 to 3)",
            is: |p| matches!(p, Problem::IndexOutOfRange { index, count: 3, .. } if &**index == "4"),
        },
        Case {
            name: "texture_index.obj",
            bytes: b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n".to_vec(),
            read: mesh,
            message: "line 5: texture coordinate index 2 is out of range (there are 1 texture coordinates, numbered 1 to 1)",
            is: |p| matches!(p, Problem::IndexOutOfRange { what: "texture coordinate", .. }),
        },
        Case {
            name: "normal_index.obj",
            bytes: b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//1\n".to_vec(),
            read: mesh,
            message: "line 4: normal index 1 is out of range (the file has no normals before it)",
            is: |p| matches!(p, Problem::IndexOutOfRange { what: "normal", count: 0, .. }),
        },
        Case {
            name: "unknown_statement.obj",
            bytes: b"v 0 0 0\n\x7fELF\x02\x01\n".to_vec(),
            read: mesh,
            message: "line 2: unknown OBJ statement `\u{7f}ELF\u{2}\u{1}`",
            is: |p| matches!(p, Problem::Invalid(_)),
        },
        Case {
            name: "short_vertex.obj",
            bytes: b"v 1 2\n".to_vec(),
            read: mesh,
            message: "line 1: `v` needs 3 coordinates, has 2",
            is: |p| matches!(p, Problem::Invalid(_)),
        },
        Case {
            name: "nan_vertex.obj",
            bytes: b"v 1 NaN 2\n".to_vec(),
            read: mesh,
            message: "line 1: vertex position is not finite",
            is: |p| matches!(p, Problem::NonFinite(_)),
        },
        Case {
            name: "word_vertex.obj",
            bytes: b"# a comment\nv 1 one 2\n".to_vec(),
            read: mesh,
            message: "line 2: `one` is not a number",
            is: |p| matches!(p, Problem::NotANumber(_)),
        },
        Case {
            name: "bad_magic.off",
            bytes: b"PLY\n3 1 0\n".to_vec(),
            read: mesh,
            message: "line 1: not a OFF file (it starts with `PLY`)",
            is: |p| matches!(p, Problem::BadMagic { .. }),
        },
        Case {
            name: "count_bomb.off",
            bytes: b"OFF\n99999999 1 0\n0 0 0\n".to_vec(),
            read: mesh,
            message: "line 2: declares 100000000 entries of at least 6 bytes each, but only 23 bytes remain",
            is: |p| matches!(p, Problem::CountTooLarge { .. }),
        },
        Case {
            // Found by cargo fuzz: the two counts' sum overflowed while the error was built.
            name: "count_overflow.off",
            bytes: b"OFF\n18446744073709551615 400000000030000 30000\n".to_vec(),
            read: mesh,
            message: "line 2: declares 18446744073709551615 entries of at least 6 bytes each, but only 47 bytes remain",
            is: |p| matches!(p, Problem::CountTooLarge { .. }),
        },
        Case {
            name: "face_out_of_range.off",
            bytes: b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n".to_vec(),
            read: mesh,
            message: "line 6: vertex index 3 is out of range (there are 3 vertices, numbered 0 to 2)",
            is: |p| matches!(p, Problem::IndexOutOfRange { index, count: 3, .. } if &**index == "3"),
        },
        Case {
            name: "truncated.off",
            bytes: b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n".to_vec(),
            read: mesh,
            message: "line 2: the file ends before face 0 of 1",
            is: |p| matches!(p, Problem::Truncated(_)),
        },
        Case {
            name: "typo.toml",
            bytes: b"format = 1\n[camera]\nwidth_px = 640\nheight_px = 480\nfx_pix = 500.0\nfy_px = 500.0\ncx_px = 320.0\ncy_px = 240.0\n".to_vec(),
            read: rig_toml,
            message: "line 5: unknown field `fx_pix`, expected one of `width_px`, `height_px`, `fx_px`, `fy_px`, `cx_px`, `cy_px`, `distortion`",
            is: |p| matches!(p, Problem::Syntax(_)),
        },
        Case {
            name: "negative_focal.toml",
            bytes: b"format = 1\n[camera]\nwidth_px = 640\nheight_px = 480\nfx_px = -500.0\nfy_px = 500.0\ncx_px = 320.0\ncy_px = 240.0\n".to_vec(),
            read: rig_toml,
            message: "field `camera`: focal lengths (-500, 500) must be positive and finite",
            is: |p| matches!(p, Problem::Invalid(_)),
        },
        Case {
            name: "not_a_rotation.toml",
            bytes: b"format = 1\n[camera]\nwidth_px = 640\nheight_px = 480\nfx_px = 500.0\nfy_px = 500.0\ncx_px = 320.0\ncy_px = 240.0\n[projector]\nrotation = [[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1.0]]\ntranslation_mm = [100.0, 0.0, 0.0]\n[projector.lens]\nwidth_px = 1024\nheight_px = 768\nfx_px = 1000.0\nfy_px = 1000.0\ncx_px = 512.0\ncy_px = 384.0\n".to_vec(),
            read: rig_toml,
            message: "field `projector.rotation`: must be a rotation matrix (orthonormal, determinant +1)",
            is: |p| matches!(p, Problem::Invalid(_)),
        },
        Case {
            name: "rational.yml",
            bytes: include_bytes!("../fixtures/opencv_camera_k8.yml").to_vec(),
            read: yaml,
            message: "line 10: `distortion_coefficients` uses OpenCV's rational, thin-prism or tilt terms (beyond k3), which scanrig's five-term model cannot represent; recalibrate with the default flags",
            is: |p| matches!(p, Problem::Invalid(_)),
        },
        Case {
            name: "skew.yml",
            bytes: b"%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 500., 3., 320., 0., 500., 240., 0., 0., 1. ]\n".to_vec(),
            read: yaml,
            message: "line 5: `camera_matrix` must be [fx 0 cx; 0 fy cy; 0 0 1] (scanrig's model has no skew)",
            is: |p| matches!(p, Problem::Invalid(_)),
        },
    ];
    c.sort_by_key(|c| c.name);
    c
}

fn temp_dir() -> fixtures::TempDir {
    fixtures::temp_dir("rig-malformed")
}

#[test]
fn every_malformed_file_gives_its_typed_error() {
    let dir = temp_dir();
    let cases = catalogue();
    assert!(cases.len() >= 20, "the catalogue holds {} files", cases.len());
    for case in &cases {
        let path = dir.join(case.name);
        std::fs::write(&path, &case.bytes).unwrap();
        let err = (case.read)(&path).expect_err(case.name);
        let shown = err.to_string();
        assert_eq!(shown, format!("{}: {}", path.display(), case.message), "{}", case.name);
        let problem = err.problem().unwrap_or_else(|| panic!("{}: not a parse error: {err}", case.name));
        assert!((case.is)(problem), "{}: unexpected problem {problem:?}", case.name);
    }
    eprintln!("{} malformed files, each with its typed error", cases.len());
}

#[test]
fn a_missing_file_names_its_path() {
    let err = rig::read_mesh(Path::new("/nonexistent/dir/x.ply")).unwrap_err();
    assert!(matches!(err, Error::Io { .. }));
    assert!(err.to_string().starts_with("/nonexistent/dir/x.ply: "), "{err}");
}

#[test]
fn an_unknown_extension_says_what_would_be_understood() {
    let err = rig::read_mesh(Path::new("scan.3ds")).unwrap_err();
    assert_eq!(err.to_string(), "scan.3ds: unrecognised file type; expected .ply, .obj, .off, .stl or .glb");
    let err = rig::read_mesh(Path::new("scan.e57")).unwrap_err().to_string();
    assert!(err.contains("an E57 file holds point clouds"), "{err}");
}

#[test]
fn locations_display_as_users_read_them() {
    let at = Location::Element { name: "face".into(), index: 12, line: None };
    assert_eq!(at.to_string(), "element `face` #12");
}

/// A JPEG cut short (a copy that stopped) is refused, not decoded with its missing rows grey; the
/// whole file still reads. On a real FabScanPi capture.
#[test]
fn a_truncated_jpeg_is_refused() {
    let Some(path) = fixtures::data_file("fabscanpi-calibration/calibration_8x10/calibration_003.jpg") else { return };
    let bytes = std::fs::read(&path).unwrap();
    let whole = rig::image::decode_jpeg(&bytes).unwrap();
    assert!(whole.width > 0 && whole.height > 0);
    for keep in [0.6, 0.95, 0.999] {
        let cut = &bytes[..(bytes.len() as f64 * keep) as usize];
        let e = rig::image::decode_jpeg(cut).unwrap_err().to_string();
        assert!(e.contains("truncated") || e.contains("corrupt"), "{keep}: {e}");
    }
}
