//! Fuzzing the readers: PLY (header, body and conversions), OBJ, OFF, STL, GLB, E57, OpenCV YAML, rig TOML, NumPy
//! arrays, PNG frames and the scan manifest must
//! return `Ok` or a typed error for any bytes — never panic, never allocate past what the input holds.
//!
//! Two harnesses: proptest over arbitrary bytes, and a seeded mutational fuzzer that starts from valid
//! files of every format and flips, deletes, duplicates, splices and renumbers their bytes, which
//! reaches far deeper into the parsers than random bytes do. By default it runs a fixed number of
//! inputs (quick, for CI);
//! `SCANRIG_FUZZ_SECS=600 cargo test --release -p rig --test rig fuzz_readers:: -- --nocapture` runs it for ten minutes and prints how many inputs it tried. A crashing input is
//! written to the temp folder and its seed printed, so it can be replayed.

use proptest::prelude::*;
use rig::ply::{self, Encoding, Precision, WriteOptions};
use rig::{Point3, PointCloud, PolyMesh, Vector3};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::time::{Duration, Instant};

/// Runs every reader over the bytes; the results are irrelevant, only that they return.
fn read_everything(bytes: &[u8]) {
    if let Ok(p) = ply::parse(bytes) {
        let _ = ply::cloud_from_ply(&p);
        let _ = ply::mesh_from_ply(&p);
        let _ = ply::range_grid_from_ply(&p);
        let _ = ply::sparse_view_from_ply(&p);
        let _ = p.header.units();
    }
    let _ = rig::obj::parse(bytes);
    let _ = rig::off::parse_reported(bytes);
    let _ = rig::stl::parse(bytes);
    let _ = rig::glb::parse_reported(bytes);
    let _ = rig::e57::parse_reported(bytes);
    let _ = rig::opencv_yaml::camera_from_bytes(bytes);
    let _ = rig::Rig::from_toml_str(&String::from_utf8_lossy(bytes));
    let _ = rig::npy::parse(bytes);
    let _ = rig::image::decode_png(bytes);
    let _ = rig::image::decode_jpeg(bytes);
    let _ = rig::Manifest::from_json(bytes);
    let _ = rig::scan_folder::parse_progress(bytes, 8);
    let _ = rig::remesh_inputs::parse_constraints(bytes);
    let _ = rig::remesh_inputs::parse_face_values(bytes, 3);
    let text = String::from_utf8_lossy(bytes);
    let _ = rig::scanner_calibration::rig_from_fabscan(&text);
    let _ = rig::scanner_calibration::rig_from_horus(&text);
}

/// A 2 × 2 range grid with three cells measured.
fn cloud_grid() -> rig::RangeGrid {
    let mut g = rig::RangeGrid::empty(2, 2, rig::Sensor::Center(Point3::origin()));
    for i in 0..3 {
        g.points[i] = Point3::new(i as f64, 0.0, 100.0);
        g.valid[i] = true;
    }
    g
}

fn seeds() -> Vec<Vec<u8>> {
    let verts = vec![
        Point3::new(0.0, 0.0, 0.0),
        Point3::new(1.0, 0.0, 0.0),
        Point3::new(1.0, 1.0, 0.0),
        Point3::new(0.0, 1.0, 0.5),
    ];
    let mut mesh = PolyMesh::from_faces(verts.clone(), [vec![0u32, 1, 2], vec![0, 1, 2, 3]]);
    mesh.normals = Some(vec![Vector3::z(); 4]);
    let cloud = PointCloud {
        positions: verts,
        normals: Some(vec![Vector3::x(); 4]),
        colors: Some(vec![[1, 2, 3]; 4]),
        confidence: Some(vec![0.5; 4]),
        view_id: Some(vec![7; 4]),
    };
    let mut out = Vec::new();
    for encoding in [Encoding::Ascii, Encoding::BinaryLittleEndian, Encoding::BinaryBigEndian] {
        for precision in [Precision::F32, Precision::F64] {
            let opts = WriteOptions { encoding, precision, comments: vec!["units mm".into()] };
            out.push(ply::mesh_to_bytes(&mesh, &opts));
            out.push(ply::cloud_to_bytes(&cloud, &opts));
        }
    }
    out.push(
        b"ply\nformat ascii 1.0\nobj_info num_cols 2\nobj_info num_rows 2\nelement vertex 2\nproperty float x\n\
property float y\nproperty float z\nelement range_grid 4\nproperty list uchar int vertex_indices\nend_header\n\
0 0 0\n1 1 1\n1 0\n0\n1 1\n0\n"
            .to_vec(),
    );
    out.push(
        b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
element tristrips 1\nproperty list int int vertex_indices\nend_header\n"
            .iter()
            .copied()
            .chain((0..9).flat_map(|i: i32| (i as f32).to_le_bytes()))
            .chain([4i32, 0, 1, 2, -1].iter().flat_map(|v| v.to_le_bytes()))
            .collect(),
    );
    let mut coloured = mesh.clone();
    coloured.colors = Some(vec![[9, 8, 7]; 4]);
    out.push(rig::stl::mesh_to_binary(&mesh));
    out.push(rig::stl::mesh_to_ascii(&mesh, "fuzz"));
    // Two solids in one ASCII file (both are kept).
    out.push([rig::stl::mesh_to_ascii(&mesh, "a"), rig::stl::mesh_to_ascii(&mesh, "b")].concat());
    // A baseline JPEG: its entropy-coded data are walked (rig's jpeg_check) after decoding.
    let rgb = rig::image::Image8 {
        width: 24,
        height: 16,
        channels: 3,
        data: (0..24 * 16 * 3).map(|i| (i * 7 % 251) as u8).collect(),
    };
    out.push(rig::image::jpeg_bytes(&rgb, 80));
    out.push(rig::image::jpeg_bytes(&rgb.to_gray(), 60));
    out.push(rig::glb::mesh_to_bytes(&coloured));
    out.push(rig::glb::cloud_to_bytes(&cloud));
    out.push(rig::e57::cloud_to_bytes(&cloud).expect("the seed cloud writes"));
    let grid = rig::RangeGrid { colors: Some(vec![[1, 2, 3]; 4]), ..cloud_grid() };
    out.push(ply::range_grid_to_bytes(&grid, &WriteOptions::default()));
    out.push(rig::obj::mesh_to_bytes(&mesh, Some("m")));
    out.push(rig::obj::cloud_to_bytes(&cloud, None));
    out.push(b"# obj\no thing\nv 0 0 0\nv 1 0 0\nv 0 1 0 0.5 0.5 0.5\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1\nf -3//1 -2//1 -1//1\nusemtl x\n".to_vec());
    out.push(b"OFF\n# c\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n4 0 1 2 3 255 0 0\n".to_vec());
    out.push(b"COFF 3 1 0\n0 0 0 1 1 1 1\n1 0 0 1 1 1 1\n0 1 0 1 1 1 1\n3 0 1 2\n".to_vec());
    out.push(include_bytes!("../fixtures/opencv_camera.yml").to_vec());
    out.push(include_bytes!("../fixtures/fabscan_config.json").to_vec());
    out.push(include_bytes!("../fixtures/horus_settings.json").to_vec());
    out.push(include_bytes!("../fixtures/opencv_camera_distortion_col.yml").to_vec());
    out.push(
        b"format = 1\nname = \"r\"\n[camera]\nwidth_px = 640\nheight_px = 480\nfx_px = 500.0\nfy_px = 500.0\ncx_px = 320.0\n\
cy_px = 240.0\ndistortion = [0.1, 0.0, 0.0, 0.0, 0.0]\n[[lasers]]\nname = \"l\"\nnormal = [1.0, 0.0, 1.0]\ndistance_mm = 100.0\n\
[turntable]\naxis_point_mm = [0.0, 50.0, 400.0]\naxis_direction = [0.0, -1.0, 0.0]\n"
            .to_vec(),
    );
    let npy = |data| rig::npy::to_bytes(&rig::npy::NpyArray { shape: vec![2, 2], data });
    out.push(npy(rig::npy::NpyData::F64(vec![1.0, 2.0, 3.0, 4.0])));
    out.push(npy(rig::npy::NpyData::U8(vec![1, 2, 3, 4])));
    out.push(rig::image::png_bytes(&rig::image::Image8::gray(4, 3, (0..12).collect()), true));
    let manifest = rig::Manifest {
        format: rig::scan_folder::SCAN_FORMAT,
        method: rig::Method::StructuredLight,
        rig: "rig.toml".into(),
        source: "fuzz".into(),
        seed: Some(1),
        views: vec![rig::scan_folder::View {
            angle_deg: 10.0,
            frames: rig::patterns::structured_light_sequence(4, 2, &[])
                .into_iter()
                .map(|pattern| rig::scan_folder::Frame { file: format!("f/{}.png", pattern.name()), pattern })
                .collect(),
            complete: true,
            held: false,
            pass: 1,
        }],
    };
    out.push(serde_json::to_vec_pretty(&manifest).unwrap());
    out.push(b"# remesh constraints\n12 45 78 90\np 0.0 1.0 2.0  0.5 1.2 2.1\n".to_vec());
    out.push(b"1.0 0.5\n# insulator\n0\n".to_vec());
    out.push(b"0\n3\n7\n2".to_vec());
    out
}

/// xorshift64*: a small, seeded, dependency-free generator, so a failing input replays from its seed.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        if n == 0 { 0 } else { (self.next() % n as u64) as usize }
    }
}

const TOKENS: &[&[u8]] = &[
    b"0",
    b"-1",
    b"255",
    b"256",
    b"4294967295",
    b"4294967296",
    b"-2147483649",
    b"1e308",
    b"nan",
    b"inf",
    b"-0",
    b"3.5",
    b"\n",
    b" ",
    b"end_header\n",
    b"element face 3\n",
    b"property list uchar int vertex_indices\n",
    b"property list uint uint a\n",
    b"format binary_big_endian 1.0\n",
    b"obj_info num_cols 9\n",
    b"f 1 2 3\n",
    b"v 1 2 3\n",
    b"data: [ 1., 2. ]\n",
    b"!!opencv-matrix\n",
    b"rows: 3\n",
    b"]",
    b"[",
    b"//",
    b"/",
    b"#",
    b"=",
    b"\"",
    b"\xff\xff\xff\xff",
    b"\0\0\0\0",
    b"\x7f\xff\xff\xff",
];

fn mutate(rng: &mut Rng, input: &mut Vec<u8>) {
    let rounds = 1 + rng.below(4);
    for _ in 0..rounds {
        let len = input.len();
        match rng.below(8) {
            0 if len > 0 => {
                let i = rng.below(len);
                input[i] ^= 1 << rng.below(8);
            }
            1 if len > 0 => {
                let i = rng.below(len);
                input[i] = [0u8, 0xff, b'\n', b' ', b'-', b'9', b'.', 0x7f][rng.below(8)];
            }
            2 if len > 0 => {
                let i = rng.below(len);
                let n = 1 + rng.below((len - i).min(64));
                input.drain(i..i + n);
            }
            3 if len > 0 => {
                let i = rng.below(len);
                let n = 1 + rng.below((len - i).min(64));
                let chunk = input[i..i + n].to_vec();
                let at = rng.below(len);
                input.splice(at..at, chunk);
            }
            4 => {
                let tok = TOKENS[rng.below(TOKENS.len())];
                let at = rng.below(len + 1);
                input.splice(at..at, tok.iter().copied());
            }
            5 if len > 0 => {
                // Replace a run of digits (a count, an index, a coordinate) with an interesting number.
                let start = rng.below(len);
                if let Some(off) = input[start..].iter().position(u8::is_ascii_digit) {
                    let s = start + off;
                    let e = s + input[s..].iter().take_while(|b| b.is_ascii_digit()).count();
                    let tok = TOKENS[rng.below(12)];
                    input.splice(s..e, tok.iter().copied());
                }
            }
            6 if len > 0 => input.truncate(rng.below(len)),
            _ => {
                let n = rng.below(16);
                let at = rng.below(len + 1);
                let bytes: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
                input.splice(at..at, bytes);
            }
        }
    }
}

#[test]
fn mutated_files_never_panic() {
    let secs: u64 = std::env::var("SCANRIG_FUZZ_SECS").ok().and_then(|s| s.parse().ok()).unwrap_or(0);
    let min_cases: u64 = std::env::var("SCANRIG_FUZZ_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(20_000);
    let seed: u64 = std::env::var("SCANRIG_FUZZ_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(0x05ca_9419);
    let deadline = Instant::now() + Duration::from_secs(secs);
    let seeds = seeds();
    // The seeds themselves must be valid: otherwise the fuzzer explores only error paths.
    for (i, s) in seeds.iter().enumerate() {
        let ok = ply::parse(s).is_ok()
            || rig::obj::parse(s).is_ok_and(|o| !o.mesh.vertices.is_empty())
            || rig::off::parse(s).is_ok()
            || rig::stl::parse(s).is_ok()
            || rig::glb::parse(s).is_ok()
            || rig::e57::parse(s).is_ok()
            || rig::opencv_yaml::camera_from_bytes(s).is_ok()
            || rig::Rig::from_toml_str(&String::from_utf8_lossy(s)).is_ok()
            || rig::npy::parse(s).is_ok()
            || rig::image::decode_png(s).is_ok()
            || rig::image::decode_jpeg(s).is_ok()
            || rig::Manifest::from_json(s).is_ok()
            || rig::remesh_inputs::parse_constraints(s).is_ok_and(|c| !c.is_empty())
            || rig::remesh_inputs::parse_face_values(s, 3).is_ok()
            || rig::scan_folder::parse_progress(s, 8).is_ok_and(|d| !d.is_empty())
            || rig::scanner_calibration::rig_from_fabscan(&String::from_utf8_lossy(s)).is_ok()
            || rig::scanner_calibration::rig_from_horus(&String::from_utf8_lossy(s)).is_ok();
        assert!(ok, "seed {i} does not parse");
    }
    let mut tried = 0u64;
    let mut case = 0u64;
    while case < min_cases || Instant::now() < deadline {
        let case_seed = seed ^ case.wrapping_mul(0x9e37_79b9_7f4a_7c15);
        let mut rng = Rng(case_seed | 1);
        let mut input = seeds[rng.below(seeds.len())].clone();
        // Stack mutations: a few rounds on the same input before starting from a seed again.
        for _ in 0..1 + rng.below(6) {
            mutate(&mut rng, &mut input);
            if catch_unwind(AssertUnwindSafe(|| read_everything(&input))).is_err() {
                let path = std::env::temp_dir().join(format!("scanrig-fuzz-crash-{case_seed:x}.bin"));
                let _ = std::fs::write(&path, &input);
                panic!("a reader panicked on input {} (case seed {case_seed:#x})", path.display());
            }
            tried += 1;
        }
        case += 1;
    }
    eprintln!("fuzzed the readers with {tried} inputs from {} seeds in {secs} s budget", seeds.len());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..512)) {
        read_everything(&bytes);
    }

    #[test]
    fn a_valid_header_over_arbitrary_bodies_never_panics(
        enc in prop_oneof![Just("ascii"), Just("binary_little_endian"), Just("binary_big_endian")],
        body in prop::collection::vec(any::<u8>(), 0..512),
    ) {
        let mut bytes = format!(
            "ply\nformat {enc} 1.0\nelement vertex 3\nproperty float x\nproperty double y\nproperty short z\n\
element face 2\nproperty list uchar int vertex_indices\nelement tristrips 1\nproperty list ushort int vertex_indices\nend_header\n"
        ).into_bytes();
        bytes.extend(body);
        read_everything(&bytes);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]

    /// `Rig::validate` never panics, and a rig it accepts is accepted again through its TOML file; one it
    /// refuses is refused when read, naming the same field.
    #[test]
    fn rigs_are_validated_wherever_they_are_read(
        d in prop::array::uniform5(prop_oneof![-2.0f64..2.0, Just(1e30), Just(-5e3), Just(f64::NAN)]),
        cx in -2000.0f64..3000.0, cy in -2000.0f64..3000.0,
        n in prop::array::uniform3(-1.0f64..1.0), dist in prop_oneof![-300.0f64..300.0, Just(0.0)],
        z in -400.0f64..400.0, radius in prop_oneof![Just(None), Just(Some(0.0)), Just(Some(-1.0)), (1.0f64..200.0).prop_map(Some)],
    ) {
        prop_assume!(Vector3::from(n).norm() > 0.1);
        let r = rig::Rig {
            name: "p".into(),
            camera: rig::PinholeCamera { width: 1280, height: 960, fx: 1000.0, fy: 1000.0, cx, cy, distortion: rig::Distortion::from_opencv(d) },
            projector: None,
            lasers: vec![rig::Laser { name: "l".into(), plane: rig::LaserPlane::new(Vector3::from(n), dist).unwrap(), colour: rig::LaserColour::Red }],
            turntable: Some(rig::TurntableAxis { point: Point3::new(0.0, 50.0, z), direction: rig::UnitVector3::new_normalize(-Vector3::y()) }),
            platter_radius_mm: radius,
            working_height_mm: None,
            image: Default::default(),
            platform_rotation: None,
        };
        let verdict = r.validate();
        let text = r.to_toml_string();
        // NaN cannot be written to TOML as a number that reads back as the same rig: only compare fields.
        match (verdict, rig::Rig::from_toml_str(&text)) {
            (Ok(()), Ok(back)) => prop_assert!(back.validate().is_ok()),
            (Ok(()), Err(e)) => prop_assert!(false, "accepted, then refused on reading: {}", e),
            (Err(p), Err(e)) => prop_assert!(e.to_string().contains(&p.field) || e.to_string().contains("camera"), "{} vs {}", p, e),
            (Err(p), Ok(_)) => prop_assert!(false, "refused ({}), then accepted on reading", p),
        }
    }

    /// 16-bit PLY colours scale to 8 bits (v · 255 / 65535, rounded), never clamp.
    #[test]
    fn sixteen_bit_colours_scale(v in prop::array::uniform3(0u16..=u16::MAX)) {
        let text = format!(
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n\
             property ushort red\nproperty ushort green\nproperty ushort blue\nend_header\n0 0 0 {} {} {}\n",
            v[0], v[1], v[2]
        );
        let c = ply::cloud_from_ply(&ply::parse(text.as_bytes()).unwrap()).unwrap().colors.unwrap()[0];
        prop_assert_eq!(c, v.map(|x| (x as f64 * 255.0 / 65535.0).round() as u8));
    }

    /// Written constraint lines read back as they were.
    #[test]
    fn constraint_files_round_trip(
        paths in prop::collection::vec(prop::collection::vec(0usize..100_000, 2..12), 0..8),
        sketches in prop::collection::vec(prop::collection::vec(-1e3f64..1e3, 2..6), 0..4),
    ) {
        use rig::remesh_inputs::{ConstraintLine, parse_constraints};
        let mut text = String::from("# generated\n");
        let mut expect = Vec::new();
        for p in &paths {
            text += &p.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(" ");
            text += "\n\n";
            expect.push(ConstraintLine::Vertices(p.clone()));
        }
        for s in &sketches {
            let points: Vec<Point3> = s.iter().map(|&x| Point3::new(x, -x, 0.5 * x)).collect();
            text += "p";
            for q in &points {
                text += &format!(" {} {} {}", q.x, q.y, q.z);
            }
            text += " # sketch\n";
            expect.push(ConstraintLine::Points(points));
        }
        prop_assert_eq!(parse_constraints(text.as_bytes()).unwrap(), expect);
    }

    /// A scan's progress journal reads back the views appended to it, whatever bytes a crash left
    /// after the last newline; an index outside the scan is refused with its line.
    #[test]
    fn progress_journals_round_trip(done in prop::collection::vec(0usize..50, 0..40), torn in "[0-9]{0,3}") {
        let mut text: String = done.iter().map(|v| format!("{v}\n")).collect();
        text += &torn;
        prop_assert_eq!(rig::scan_folder::parse_progress(text.as_bytes(), 50).unwrap(), done.clone());
        if let Some(&v) = done.first() {
            let e = rig::scan_folder::parse_progress(text.as_bytes(), v).unwrap_err().to_string();
            prop_assert!(e.contains("line 1") && e.contains("not in the scan"), "{}", e);
        }
    }
}

/// Completing views journals them without rewriting scan.json; reading the folder sees them, and
/// writing the manifest folds the journal in.
#[test]
fn completed_views_are_journalled_and_folded_into_the_manifest() {
    let dir = fixtures::temp_dir("progress-journal");
    let patterns = rig::patterns::structured_light_sequence(4, 2, &[]);
    let mut m = rig::Manifest::fresh(rig::Method::StructuredLight, "test", None, &[0.0, 10.0, 20.0], &patterns);
    m.write(dir.path()).unwrap();
    let written = std::fs::read(dir.path().join("scan.json")).unwrap();
    m.complete_view(dir.path(), 0).unwrap();
    m.complete_view(dir.path(), 2).unwrap();
    assert_eq!(std::fs::read(dir.path().join("scan.json")).unwrap(), written, "scan.json is not rewritten per view");
    assert_eq!(std::fs::read_to_string(dir.path().join("scan.progress")).unwrap(), "0\n2\n");
    let read = rig::Manifest::read(dir.path()).unwrap();
    assert_eq!(read.views.iter().map(|v| v.complete).collect::<Vec<_>>(), [true, false, true]);
    assert_eq!(read.first_incomplete(), Some(1));
    read.write(dir.path()).unwrap();
    assert!(!dir.path().join("scan.progress").exists());
    assert_eq!(rig::Manifest::read(dir.path()).unwrap(), read);
    // A journal naming a view the scan does not have is refused, naming the file.
    std::fs::write(dir.path().join("scan.progress"), "9\n").unwrap();
    let e = rig::Manifest::read(dir.path()).unwrap_err().to_string();
    assert!(e.contains("scan.progress") && e.contains("view 9 is not in the scan (3 views)"), "{e}");
}
