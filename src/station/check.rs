//! The one-button check, as Horus' auto-check: the turntable answers; the board standing on the
//! platter is seen; the exposure is not saturated; the platter turns the right way and by the
//! angle asked (the board's pose before and after a turn, about the rig's axis); each laser and the
//! projector light the scene. Each verdict says what to do when it fails.

use super::Station;
use super::devices::CameraChoice;
use super::live::{Shooting, check_program, live_camera, saturated, shoot};
use acquire::Turntable;
use anyhow::Result;
use rig::Pattern;
use rig::image::Image8;
use serde_json::json;
use std::sync::{Arc, Mutex};

/// The turn the check asks for, degrees.
pub const TURN_DEG: f64 = 30.0;
/// How far the measured turn may be from it, degrees.
pub const TURN_TOLERANCE_DEG: f64 = 1.0;
/// The most of a frame that may be saturated.
pub const MAX_SATURATED: f64 = 0.005;

/// One verdict: `ok` true, false, or null (not checked, and why).
fn say(st: &Station, name: &str, ok: Option<bool>, detail: String, todo: &str) {
    st.bus.send(
        "check",
        json!({"name": name, "ok": ok, "detail": detail, "todo": if ok == Some(true) { "" } else { todo }}),
    );
}

/// Runs the check.
pub fn run(st: &Arc<Station>) -> Result<()> {
    st.bus.send("check", json!({"name": "start"}));
    let rig = st.rig()?;
    let mut link = match st.devices.take() {
        Ok(l) => {
            say(st, "turntable", Some(true), format!("{} answers as Horus 0.2 firmware", l.port), "");
            l
        }
        Err(e) => {
            say(
                st,
                "turntable",
                Some(false),
                format!("{e:#}"),
                "check the cable, the port chosen and that the board runs Horus firmware",
            );
            st.bus.send("check", json!({"name": "end"}));
            return Ok(());
        }
    };
    if matches!(st.devices.camera(), CameraChoice::Folder(_)) {
        say(
            st,
            "camera",
            None,
            "a folder of recorded frames cannot be checked".into(),
            "choose a live camera to check the rig",
        );
        st.devices.give_back(link);
        st.bus.send("check", json!({"name": "end"}));
        return Ok(());
    }
    let result = checks(st, &rig, &mut link);
    st.devices.give_back(link);
    st.bus.send("check", json!({"name": "end"}));
    result
}

fn checks(st: &Station, rig: &rig::Rig, link: &mut super::devices::Link) -> Result<()> {
    let board = sim::Board::chessboard(st.board.cols, st.board.rows, st.square);
    let scene = sim::board::board_scene(&st.cfg, &board, None);
    let program = check_program(rig);
    let shown = Arc::new(Mutex::new(None));
    let cfg = st.camera_config();
    let what = Shooting { cfg: &cfg, scene: &scene, program: &program, seed: st.world.seed };
    let mut camera = live_camera(st, what, link, &shown)?;
    let camera = camera.as_mut();
    let mut projector = st.projector_for(rig, &shown, &program)?;
    let t = &mut link.turntable;
    t.motor(true)?;
    t.set_speed(200.0)?;
    t.set_acceleration(200.0)?;
    t.move_to(0.0)?;
    let lasers = rig.lasers.len();
    let lit = Pattern::White;
    let first = shoot(camera, t, &mut projector, lasers, lit)?;
    let (cols, rows) = (st.board.cols as usize, st.board.rows as usize);
    let corners = |img: &Image8| calib::find_corners(&calib::Gray::from_image(img), cols, rows).ok();
    let seen = corners(&first);
    match &seen {
        Some(c) => say(st, "board", Some(true), format!("the {cols}x{rows} board is seen: {} corners", c.len()), ""),
        None => say(
            st,
            "board",
            Some(false),
            format!("no {cols}x{rows} board found in the frame"),
            "stand the board on the platter facing the camera, in focus and evenly lit; check --board",
        ),
    }
    let sat = saturated(&first);
    say(
        st,
        "exposure",
        Some(sat <= MAX_SATURATED),
        format!("{:.2} % of the lit frame saturated", sat * 100.0),
        "lower the exposure or the projector's brightness until no part of the board clips",
    );
    // The turn: the board's pose at 0° and at TURN_DEG, the rotation between them about the axis.
    match (&seen, rig.turntable) {
        (None, _) => say(st, "turn", None, "not checked: the board is not seen".into(), "make the board seen first"),
        (_, None) => {
            say(st, "turn", None, "not checked: the rig has no turntable axis yet".into(), "calibrate the turntable")
        }
        (Some(c0), Some(axis)) => {
            t.move_to(TURN_DEG)?;
            let after = shoot(camera, t, &mut projector, lasers, lit)?;
            t.move_to(0.0)?;
            let object: Vec<rig::Point3> = (0..rows)
                .flat_map(|j| (0..cols).map(move |i| rig::Point3::new(i as f64 * st.square, j as f64 * st.square, 0.0)))
                .collect();
            let turned = corners(&after)
                .and_then(|c1| calib::turntable_axis::measured_turn(&rig.camera, &axis, &object, c0, &c1));
            match turned {
                Some(turn) => {
                    let ok = (turn - TURN_DEG).abs() <= TURN_TOLERANCE_DEG;
                    let todo = if turn * TURN_DEG < 0.0 {
                        "the platter turns the wrong way: swap the motor's coil wires or the rig's axis direction"
                    } else {
                        "the platter turns by another angle than asked: check the firmware's steps per degree and microstepping"
                    };
                    say(
                        st,
                        "turn",
                        Some(ok),
                        format!("asked {TURN_DEG}°, the board turned {turn:+.2}° about the axis"),
                        todo,
                    );
                }
                _ => say(
                    st,
                    "turn",
                    Some(false),
                    "the board was lost after the turn".into(),
                    "stand the board nearer the axis, facing the camera",
                ),
            }
        }
    }
    // Each laser, then the projector: do they light the scene where the camera sees?
    let dark = shoot(camera, t, &mut projector, lasers, Pattern::LaserOff)?;
    for k in 0..lasers {
        let on = shoot(camera, t, &mut projector, lasers, Pattern::Laser { index: k })?;
        let (_, line) = super::live::laser_overlay(&dark, &on, rig.lasers[k].colour);
        let h = on.height as usize;
        say(
            st,
            &format!("laser {k}"),
            Some(line.found >= h / 20),
            format!("a line in {} of {h} rows ({} saturated, {} too wide)", line.found, line.saturated, line.too_wide),
            "switch the laser on, aim it across the platter's centre, and check its plane in the rig",
        );
    }
    for k in 0..lasers {
        t.laser(k, false)?;
    }
    let driven = st.drives_projector(rig);
    if let (Some(_), Err(why)) = (&rig.projector, &driven) {
        // A real camera would film whatever the projector's monitor shows: no verdict on its light.
        say(st, "projector", Some(false), "the station does not drive the projector".into(), why);
    } else if rig.projector.is_some() {
        let white = shoot(camera, t, &mut projector, 0, Pattern::White)?.to_gray();
        let black = shoot(camera, t, &mut projector, 0, Pattern::Black)?.to_gray();
        let lit = white.data.iter().zip(&black.data).filter(|(w, b)| **w as i16 - **b as i16 > 20).count();
        let share = lit as f64 / white.data.len().max(1) as f64;
        say(
            st,
            "projector",
            Some(share > 0.05),
            format!("the projector lights {:.0} % of the frame", share * 100.0),
            "switch the projector on, show its output on the right monitor, aim and focus it on the platter",
        );
    }
    // The window goes back to the hand setting as `projector` is dropped.
    Ok(())
}
