//! The live view: one frame of the camera now, with what the operator needs to see drawn over it —
//! the raw frame, the laser's signal and the line found in it, the projector's decoded map with its
//! shadow mask, or the board's corners — and how much of it is saturated.

use super::devices::{CameraChoice, Link};
use super::{Station, lock};
use crate::virtual_rig::SimCamera;
use acquire::Turntable;
use acquire::camera::{Camera, PatternOutput, Shot};
use anyhow::{Result, bail};
use process::triangulate::laser_line::LineReport;
use rig::Pattern;
use rig::image::Image8;
use serde_json::json;
use std::sync::{Arc, Mutex};
use tiny_http::ResponseBox;

/// A pixel this bright or brighter is saturated (the sensor clipped it).
pub const SATURATED: u8 = 250;

/// The virtual camera's exposure, from `{exposure}`: the simulator's sensor exposure, 0.01 to 10.
pub fn set_exposure(st: &Station, b: &serde_json::Value) -> Result<serde_json::Value, String> {
    match b["exposure"].as_f64() {
        Some(e) if (0.01..=10.0).contains(&e) => {
            *lock(&st.exposure) = e;
            st.bus.send("state", st.state_json());
            Ok(json!({ "exposure": e }))
        }
        _ => Err(format!("exposure: a number from 0.01 to 10, got {}", b["exposure"])),
    }
}

/// What the projector shows by hand, from `{pattern}`: white, black or off. The projector's window,
/// where the station has one, shows it now, or when the job driving the projector ends.
pub fn set_projector(st: &Station, b: &serde_json::Value) -> Result<serde_json::Value, (u16, String)> {
    let p = match b["pattern"].as_str() {
        Some("white") => Some(Pattern::White),
        Some("black") => Some(Pattern::Black),
        Some("off") => None,
        _ => return Err((400, format!("pattern: white, black or off, got {}", b["pattern"]))),
    };
    *lock(&st.projector) = p;
    // Shown now where no job drives the projector; a job (a scan, a live frame) puts the hand
    // setting back on the window when it ends.
    if let Some(w) = &st.window {
        match st.exclusive("projector", || w.show(p).map_err(|e| format!("the projector's window: {e}"))) {
            Ok(()) | Err((409, _)) => {}
            Err(e) => return Err(e),
        }
    }
    st.bus.send("state", st.state_json());
    Ok(json!({ "projector": b["pattern"] }))
}

/// What a frame taken now is of: the simulator's world (`cfg`'s sensor, [`Station::camera_config`],
/// and `scene`) and the program its lights are made for.
pub struct Shooting<'a> {
    /// The virtual camera's config.
    pub cfg: &'a sim::SimConfig,
    /// What stands in front of it.
    pub scene: &'a sim::Scene,
    /// Every pattern it may be asked to show.
    pub program: &'a [Pattern],
    /// Its noise seed (the world's, unless a capture needs its own).
    pub seed: u64,
}

/// The camera chosen, for a job that takes frames now: the simulator showing `what`, watching
/// `link`'s virtual board and `shown`'s pattern, or a V4L2 camera (which shows whatever is in front
/// of it). A folder of recorded frames takes no frame now.
pub fn live_camera<'a>(
    st: &Station,
    what: Shooting<'a>,
    link: &Link,
    shown: &Arc<Mutex<Option<Pattern>>>,
) -> Result<Box<dyn Camera + 'a>> {
    match st.devices.camera() {
        CameraChoice::Simulator => {
            let Some(board) = &link.board else { bail!("the simulator camera watches the virtual turntable only") };
            Ok(Box::new(SimCamera::new(
                what.cfg,
                what.scene,
                what.program,
                what.seed,
                board.state.clone(),
                shown.clone(),
            )))
        }
        CameraChoice::Device(path) => crate::scan_cmd::open_v4l2(&path, &st.rig()?),
        CameraChoice::Folder(_) => {
            bail!(
                "a folder of recorded frames takes no frame now: choose the simulator or a camera to check, look or calibrate"
            )
        }
    }
}

/// What the rig can show: the projector's white and black, the lasers off and each on.
pub fn check_program(rig: &rig::Rig) -> Vec<Pattern> {
    // White: the projector full on, or on a laser rig the work light (as its calibration captures
    // the board, `sim::scan::program`).
    let mut p = vec![Pattern::White];
    if rig.projector.is_some() {
        p.push(Pattern::Black);
    }
    p.push(Pattern::LaserOff);
    p.extend((0..rig.lasers.len()).map(|index| Pattern::Laser { index }));
    p
}

/// Takes one frame showing `pattern`: the projector shows it, or the lasers are switched to it.
pub fn shoot(
    camera: &mut dyn Camera,
    turntable: &mut dyn Turntable,
    projector: &mut dyn PatternOutput,
    lasers: usize,
    pattern: Pattern,
) -> Result<Image8> {
    let projected = matches!(pattern, Pattern::White | Pattern::Black | Pattern::Gray { .. } | Pattern::Phase { .. });
    projector.show(projected.then_some(pattern))?;
    for k in 0..lasers {
        turntable.laser(k, pattern == Pattern::Laser { index: k })?;
    }
    Ok(camera.capture(&Shot { view: 0, frame: 0, pattern })?)
}

/// Share of pixels at or above [`SATURATED`] in any channel.
pub fn saturated(img: &Image8) -> f64 {
    let c = img.channels as usize;
    let n = img.data.chunks(c).filter(|p| p.iter().any(|&v| v >= SATURATED)).count();
    n as f64 / (img.data.len() / c).max(1) as f64
}

/// `GET /api/live?show=raw|colour|laser|decode|corners`: the frame as a PNG data URL, with notes.
pub fn frame(st: &Station, show: &str) -> ResponseBox {
    // Under the job slot: no job may start while the frame is taken, nor the frame while one runs.
    match st.exclusive("live", || take(st, show).map_err(|e| format!("{e:#}"))) {
        Ok(v) => super::json_response(200, &v),
        Err((409, m)) => super::error(409, &format!("{m}; the live view comes back when it ends")),
        Err((s, m)) => super::error(s, &m),
    }
}

fn take(st: &Station, show: &str) -> Result<serde_json::Value> {
    let rig = st.rig()?;
    let mut link = st.devices.take()?;
    let result = (|| {
        let board = sim::Board::chessboard(st.board.cols, st.board.rows, st.square);
        let object_scene;
        let scene = if show == "corners" {
            object_scene = sim::board::board_scene(&st.cfg, &board, None);
            &object_scene
        } else {
            let size = st.world.size.unwrap_or(st.cfg.scene.object_size_mm);
            let (object, albedo) = crate::sim_cmd::object_on_platter(
                &st.cfg,
                st.world.mesh.as_deref(),
                size,
                st.world.up,
                rig::Vector3::zeros(),
            )?;
            object_scene = sim::Scene::on_turntable(&st.cfg, &object, albedo);
            &object_scene
        };
        let shown = Arc::new(Mutex::new(None));
        let mut program = check_program(&rig);
        if show == "decode" {
            let p = rig.projector.as_ref().ok_or_else(|| anyhow::anyhow!("the rig has no projector to decode"))?;
            program = rig::patterns::structured_light_sequence(p.lens.width, p.lens.height, &st.cfg.scan.phase);
        }
        if show == "colour" {
            program.push(Pattern::Texture);
        }
        let cfg = st.camera_config();
        let what = Shooting { cfg: &cfg, scene, program: &program, seed: st.world.seed };
        let mut camera = live_camera(st, what, &link, &shown)?;
        let camera = camera.as_mut();
        let mut projector = st.projector_for(&rig, &shown, &program)?;
        let lasers = rig.lasers.len();
        // The raw frame shows what the projector was set to by hand (lit, dark or off); a laser
        // rig's, the work light.
        let lit = match show {
            "colour" => Pattern::Texture,
            "raw" if rig.projector.is_some() => lock(&st.projector).unwrap_or(Pattern::LaserOff),
            _ => Pattern::White,
        };
        let t = &mut link.turntable;
        let raw = shoot(camera, t, &mut projector, lasers, lit)?;
        let sat = saturated(&raw);
        let mut note = String::new();
        let picture = match show {
            "raw" | "colour" => web::picture::to_rgb(&raw),
            "laser" => {
                if lasers == 0 {
                    bail!("the rig has no lasers");
                }
                projector.show(None)?;
                let off = shoot(camera, t, &mut projector, lasers, Pattern::LaserOff)?;
                let on = shoot(camera, t, &mut projector, lasers, Pattern::Laser { index: 0 })?;
                t.laser(0, false)?;
                let (img, report) = laser_overlay(&off, &on, rig.lasers[0].colour);
                note = format!("laser 0: {}", laser_legend(&report));
                img
            }
            "decode" => {
                let p = rig.projector.as_ref().expect("checked above");
                let frames: Vec<(Pattern, Image8)> = program
                    .iter()
                    .map(|&pat| shoot(camera, t, &mut projector, 0, pat).map(|i| (pat, i)))
                    .collect::<Result<_>>()?;
                let refs: Vec<(Pattern, &Image8)> = frames.iter().map(|(p, i)| (*p, i)).collect();
                let (map, report) =
                    process::decode_view(&refs, p.lens.width, p.lens.height, &process::DecodeParams::default())?;
                note = format!(
                    "decoded {} of {} lit pixels; black: shadow (the projector does not reach it) or not lit",
                    report.decoded, report.lit
                );
                map.preview(p.lens.width, p.lens.height)
            }
            "corners" => {
                let mut img = web::picture::to_rgb(&raw);
                match calib::find_corners(
                    &calib::Gray::from_image(&raw),
                    st.board.cols as usize,
                    st.board.rows as usize,
                ) {
                    Ok(c) => {
                        let px: Vec<[f64; 2]> = c.iter().map(|p| [p.x, p.y]).collect();
                        web::picture::mark(&mut img, &px, 2, [0, 220, 0]);
                        note = format!("board seen: {} corners", c.len());
                    }
                    Err(e) => note = format!("board not found: {e}"),
                }
                img
            }
            other => bail!("show: {other:?} is none of raw, colour, laser, decode, corners"),
        };
        // The window goes back to the hand setting as `projector` is dropped.
        drop(projector);
        Ok(json!({
            "image": web::picture::png_url(&picture),
            "saturated": sat,
            "warning": (sat > 0.005).then(|| format!("{:.1} % of the frame is saturated: lower the exposure or the projector's brightness", sat * 100.0)),
            "note": note,
        }))
    })();
    st.devices.give_back(link);
    result
}

/// The laser frame with the line the pipeline finds in it (its own extraction, with its default
/// settings, against the dark frame): each row's peak in green, and a mark at the left edge of each
/// row the extraction rejected, in the colour of its reason (rows with nothing at all are left
/// unmarked). The report counts each reason.
pub fn laser_overlay(off: &Image8, on: &Image8, colour: rig::LaserColour) -> (Image8, LineReport) {
    use process::triangulate::laser_line::{Background, RowOutcome, extract_line_explained};
    let params = process::ProcessParams::default().laser;
    let (peaks, report, outcomes) =
        extract_line_explained(on, Background::Frame(off), colour, None, &params, |_, _| true);
    let mut img = web::picture::to_rgb(on);
    let w = img.width as usize;
    for (row, why) in outcomes.iter().enumerate() {
        let mark = match why {
            RowOutcome::Saturated => [255, 150, 0],
            RowOutcome::TooWide => [230, 0, 230],
            RowOutcome::Doubled => [255, 235, 0],
            RowOutcome::Outside => [0, 200, 230],
            RowOutcome::Found | RowOutcome::Faint | RowOutcome::Unsearched => continue,
        };
        for x in 0..w.min(8) {
            img.data[(row * w + x) * 3..(row * w + x) * 3 + 3].copy_from_slice(&mark);
        }
    }
    let px: Vec<[f64; 2]> = peaks.iter().map(|p| [p.col, p.row as f64]).collect();
    web::picture::mark(&mut img, &px, 0, [0, 255, 0]);
    (img, report)
}

/// What [`laser_overlay`]'s marks mean, with the counts.
pub fn laser_legend(r: &LineReport) -> String {
    format!(
        "a line in {} rows (green); rejected: {} saturated (orange), {} too wide (magenta), {} doubled (yellow), \
         {} outside the working volume (cyan); {} rows without a line",
        r.found, r.saturated, r.too_wide, r.doubled, r.outside, r.faint
    )
}
