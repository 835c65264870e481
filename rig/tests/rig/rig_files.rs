//! Rig TOML and OpenCV YAML: the files read what OpenCV writes, and write what they read.

use crate::common;
use rig::opencv_yaml;

use common::strong;
use rig::{Isometry3, LaserPlane, PinholeCamera, Point3, Projector, Rig, TurntableAxis, UnitVector3, Vector3};

#[test]
fn reads_the_yaml_opencv_writes() {
    // Written by cv2.FileStorage: OpenCV 5 (`%YAML 1.2`), OpenCV 4 (`%YAML:1.0`), and a 5×1 distortion.
    for bytes in [
        &include_bytes!("../fixtures/opencv_camera.yml")[..],
        &include_bytes!("../fixtures/opencv4_camera.yml")[..],
        &include_bytes!("../fixtures/opencv_camera_distortion_col.yml")[..],
    ] {
        assert_eq!(opencv_yaml::camera_from_bytes(bytes).unwrap(), strong());
    }
}

#[test]
fn yaml_export_reads_back_exactly() {
    let mut cam = strong();
    cam.fx = 1319.597123456789;
    cam.cy = 808.36;
    let text = opencv_yaml::camera_to_string(&cam);
    assert!(text.starts_with("%YAML:1.0\n---\n"));
    assert!(text.contains("camera_matrix: !!opencv-matrix"));
    assert_eq!(opencv_yaml::camera_from_bytes(text.as_bytes()).unwrap(), cam);
}

fn full_rig() -> Rig {
    let from_camera = Isometry3::new(Vector3::new(-152.5, 3.25, 20.0), Vector3::new(0.01, -0.35, 0.02));
    Rig {
        name: "test rig".into(),
        camera: strong(),
        projector: Some(Projector { lens: PinholeCamera::ideal(1024, 768, 1500.0), from_camera, gamma: 2.2 }),
        lasers: vec![
            rig::Laser {
                name: "left".into(),
                plane: LaserPlane::new(Vector3::new(0.866, 0.0, 0.5), 150.0).unwrap(),
                colour: rig::LaserColour::Red,
            },
            rig::Laser {
                name: "right".into(),
                plane: LaserPlane::new(Vector3::new(-0.866, 0.0, 0.5), 150.0).unwrap(),
                colour: rig::LaserColour::Green,
            },
        ],
        turntable: Some(TurntableAxis {
            point: Point3::new(0.5, 60.0, 400.0),
            direction: UnitVector3::new_normalize(Vector3::new(0.0, -1.0, -0.1)),
        }),
        platter_radius_mm: Some(90.0),
        working_height_mm: Some(140.0),
        image: rig::image::ImageTransform { transpose: true, hflip: true, vflip: false },
        platform_rotation: None,
    }
}

#[test]
fn rig_toml_round_trips() {
    let rig = full_rig();
    let text = rig.to_toml_string();
    let back = Rig::from_toml_str(&text).unwrap();
    assert_eq!(back.camera, rig.camera);
    assert_eq!(back.lasers, rig.lasers);
    assert_eq!(back.turntable, rig.turntable);
    assert_eq!(back.platter_radius_mm, Some(90.0));
    let (p, q) = (back.projector.unwrap(), rig.projector.unwrap());
    assert_eq!(p.lens, q.lens);
    // The rotation goes through a matrix in the file: equal to rounding.
    let x = Point3::new(10.0, -20.0, 400.0);
    assert!((p.from_camera * x - q.from_camera * x).norm() < 1e-9);
    // Units are in the field names, conventions in the comment block.
    for key in ["fx_px", "translation_mm", "distance_mm", "axis_point_mm", "X_projector = rotation"] {
        assert!(text.contains(key), "{key} missing from\n{text}");
    }
}

#[test]
fn laser_normals_are_normalised_with_their_distance() {
    let text = "format = 1\n[camera]\nwidth_px = 640\nheight_px = 480\nfx_px = 500.0\nfy_px = 500.0\ncx_px = 320.0\n\
cy_px = 240.0\n[[lasers]]\nname = \"a\"\nnormal = [0.0, 0.0, 2.0]\ndistance_mm = 800.0\n";
    let rig = Rig::from_toml_str(text).unwrap();
    let plane = rig.lasers[0].plane;
    assert_eq!((plane.normal.into_inner(), plane.distance), (Vector3::z(), 400.0));
}

#[test]
fn projector_centre_is_minus_r_transpose_t() {
    let rig = full_rig();
    let p = rig.projector.unwrap();
    let c = p.center_in_camera();
    // The centre maps to the projector origin.
    assert!((p.from_camera * c).coords.norm() < 1e-12);
    // A point in front of the projector projects, and the projector's ray through that pixel passes it.
    let x = Point3::new(30.0, -10.0, 420.0);
    let px = p.project(&x).unwrap();
    let (o, d) = p.ray_in_camera(px).unwrap();
    let along = (x - o).dot(&d);
    assert!(((o + d.into_inner() * along) - x).norm() < 1e-9);
}
