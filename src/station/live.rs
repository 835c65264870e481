//! The live view: one frame of the camera now, with what the operator needs to see drawn over it —
//! the raw frame, the laser's signal and the line found in it, the projector's decoded map with its
//! shadow mask, or the board's corners — and how much of it is saturated.

use super::devices::{CameraChoice, Link};
use super::{Station, lock};
use crate::virtual_rig::SimCamera;
use acquire::Turntable;
use acquire::camera::{Camera, Shot};
use anyhow::{Result, bail};
use rig::Pattern;
use rig::image::Image8;
use serde_json::json;
use std::sync::{Arc, Mutex};
use tiny_http::ResponseBox;

/// A pixel this bright or brighter is saturated (the sensor clipped it).
pub const SATURATED: u8 = 250;
/// A laser row counts as lit where the laser frame exceeds the dark one by this much.
const LINE_CONTRAST: i16 = 30;

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

/// What the projector shows by hand, from `{pattern}`: white, black or off.
pub fn set_projector(st: &Station, b: &serde_json::Value) -> Result<serde_json::Value, String> {
    let p = match b["pattern"].as_str() {
        Some("white") => Some(Pattern::White),
        Some("black") => Some(Pattern::Black),
        Some("off") => None,
        _ => return Err(format!("pattern: white, black or off, got {}", b["pattern"])),
    };
    *lock(&st.projector) = p;
    st.bus.send("state", st.state_json());
    Ok(json!({ "projector": b["pattern"] }))
}

/// The simulator as the camera for `scene` with `cfg`'s sensor ([`Station::camera_config`]),
/// watching `link`'s virtual board and `shown`'s pattern.
pub fn sim_camera<'a>(
    st: &Station,
    cfg: &'a sim::SimConfig,
    scene: &'a sim::Scene,
    program: &[Pattern],
    link: &Link,
    shown: &Arc<Mutex<Option<Pattern>>>,
) -> Result<SimCamera<'a>> {
    let Some(board) = &link.board else { bail!("the simulator camera watches the virtual turntable only") };
    Ok(SimCamera {
        cfg,
        scene,
        rays: sim::pixel_rays(&cfg.rig.camera),
        lights: sim::scan::lights_for(cfg, program),
        program: program.to_vec(),
        seed: st.world.seed,
        board: board.state.clone(),
        shown: shown.clone(),
        geometry: None,
    })
}

/// What the rig can show: the projector's white and black, the lasers off and each on.
pub fn check_program(rig: &rig::Rig) -> Vec<Pattern> {
    let mut p = Vec::new();
    if rig.projector.is_some() {
        p.extend([Pattern::White, Pattern::Black]);
    }
    p.push(Pattern::LaserOff);
    p.extend((0..rig.lasers.len()).map(|index| Pattern::Laser { index }));
    p
}

/// Takes one frame showing `pattern`: the projector shows it, or the lasers are switched to it.
pub fn shoot(
    camera: &mut dyn Camera,
    turntable: &mut dyn Turntable,
    shown: &Mutex<Option<Pattern>>,
    lasers: usize,
    pattern: Pattern,
) -> Result<Image8> {
    let projected = matches!(pattern, Pattern::White | Pattern::Black | Pattern::Gray { .. } | Pattern::Phase { .. });
    *lock(shown) = projected.then_some(pattern);
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
    if lock(&st.job).is_some() {
        return super::error(409, "a job uses the camera now; the live view comes back when it ends");
    }
    match take(st, show) {
        Ok(v) => super::json_response(200, &v),
        Err(e) => super::error(400, &format!("{e:#}")),
    }
}

fn take(st: &Station, show: &str) -> Result<serde_json::Value> {
    if st.devices.camera() != CameraChoice::Simulator {
        bail!("the live view needs a camera that takes frames now; a folder of recorded frames does not");
    }
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
        let mut camera = sim_camera(st, &cfg, scene, &program, &link, &shown)?;
        let lasers = rig.lasers.len();
        // The raw frame shows what the projector was set to by hand (lit, dark or off).
        let manual = if rig.projector.is_some() { *lock(&st.projector) } else { None };
        let lit = match show {
            "colour" => Pattern::Texture,
            "raw" => manual.unwrap_or(Pattern::LaserOff),
            _ if rig.projector.is_some() => Pattern::White,
            _ => Pattern::LaserOff,
        };
        let t = &mut link.turntable;
        let raw = shoot(&mut camera, t, &shown, lasers, lit)?;
        let sat = saturated(&raw);
        let mut note = String::new();
        let picture = match show {
            "raw" | "colour" => web::picture::to_rgb(&raw),
            "laser" => {
                if lasers == 0 {
                    bail!("the rig has no lasers");
                }
                *lock(&shown) = None;
                let off = shoot(&mut camera, t, &shown, lasers, Pattern::LaserOff)?;
                let on = shoot(&mut camera, t, &shown, lasers, Pattern::Laser { index: 0 })?;
                t.laser(0, false)?;
                let (img, found, clipped) = laser_overlay(&off, &on);
                note = format!("laser 0: a line in {found} rows; {clipped} rows rejected as saturated (orange)");
                img
            }
            "decode" => {
                let p = rig.projector.as_ref().expect("checked above");
                let frames: Vec<(Pattern, Image8)> = program
                    .iter()
                    .map(|&pat| shoot(&mut camera, t, &shown, 0, pat).map(|i| (pat, i)))
                    .collect::<Result<_>>()?;
                let refs: Vec<(Pattern, &Image8)> = frames.iter().map(|(p, i)| (*p, i)).collect();
                let (map, report) =
                    process::decode_view(&refs, p.lens.width, p.lens.height, &process::DecodeParams::default())?;
                *lock(&shown) = None;
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
        *lock(&shown) = None;
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

/// The laser frame over the dark one: the signal in red, the line's peak per row in green, rows
/// whose peak is clipped in orange (a saturated line has no sub-pixel centre); counts of each.
pub fn laser_overlay(off: &Image8, on: &Image8) -> (Image8, usize, usize) {
    let (g_off, g_on) = (off.to_gray(), on.to_gray());
    let (w, h) = (g_on.width as usize, g_on.height as usize);
    let mut img = web::picture::to_rgb(off);
    let (mut found, mut clipped) = (0, 0);
    for y in 0..h {
        let mut best = (0i16, 0usize);
        for x in 0..w {
            let d = g_on.data[y * w + x] as i16 - g_off.data[y * w + x] as i16;
            if d > 0 {
                let px = &mut img.data[(y * w + x) * 3..(y * w + x) * 3 + 3];
                px[0] = px[0].saturating_add((d.min(255) as u8) / 2 + 60);
            }
            if d > best.0 {
                best = (d, x);
            }
        }
        if best.0 >= LINE_CONTRAST {
            let x = best.1;
            let colour = if g_on.data[y * w + x] >= SATURATED {
                clipped += 1;
                [255, 150, 0]
            } else {
                found += 1;
                [0, 255, 0]
            };
            img.data[(y * w + x) * 3..(y * w + x) * 3 + 3].copy_from_slice(&colour);
        }
    }
    (img, found, clipped)
}
