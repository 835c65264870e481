//! Calibration against simulated and real captures, in one binary.

mod charuco;
mod fabscanpi;
mod laser_sim;
mod partial_boards;
mod structured_light_sim;
mod turntable_sim;

/// The camera calibrated from the capture folder `dir` as `scanrig calibrate camera` would, with the
/// lens model the views support: the rig and its report.
fn calibrate_camera_from(dir: &std::path::Path, board: calib::BoardSpec) -> (rig::Rig, calib::CalibReport) {
    use calib::workflow::{Orientation, Step, Target, load};
    let params = calib::RigCalibParams {
        target: Target::Only(Step::Camera),
        board,
        orientation: Orientation::default(),
        lens: Default::default(),
        lens_model: calib::LensModel::Auto,
        corner_height_mm: None,
        projector_size: None,
    };
    let positions = load(dir, Orientation::default(), None, |_, _| {}).unwrap();
    calib::calibrate_rig(&positions, None, &params, |_, _, _| {}).unwrap()
}
