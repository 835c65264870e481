//! The calibration wizard: the board held in a spread of poses (the page shows where to hold it
//! next, drawn over a map of where corners have been seen), then standing on the platter while it
//! turns through a sweep; each capture taken by the capture session into a folder of its own, its
//! corners found and shown, and accepted or rejected by the operator. Calibrating gathers the
//! accepted captures into one capture folder and runs `scanrig calibrate all` on it, word for word:
//! the rig is written only when its plausibility checks pass, and the report page is linked.

use super::devices::{CameraChoice, Link};
use super::{Station, lock};
use crate::cli::{Args, Command};
use anyhow::{Context, Result, bail};
use clap::Parser;
use rig::Pattern;
use rig::scan_folder::{Manifest, Method, ScanLayout};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// Held poses the wizard asks for.
pub const HELD_POSES: usize = 12;
/// The turntable sweep, degrees: the board standing on the platter at each.
pub const SWEEP_DEG: [f64; 7] = [-45.0, -30.0, -15.0, 0.0, 15.0, 30.0, 45.0];
/// The coverage map's cells across and down.
const COVERAGE: (usize, usize) = (8, 6);

/// One capture.
struct Capture {
    /// A held pose's index, or the sweep's angle.
    held: Option<usize>,
    angle_deg: f64,
    dir: PathBuf,
    corners: Option<Vec<[f64; 2]>>,
    accepted: Option<bool>,
}

/// The captures so far.
#[derive(Default)]
pub struct Wizard {
    captures: Vec<Capture>,
    /// Captures taken since the station started: each one's folder is new (a reset forgets the
    /// list, never a folder an accepted capture may still name).
    taken: usize,
}

fn root(st: &Station) -> PathBuf {
    st.data.join("calibration")
}

/// The next held pose, for the page: its outline in the image and words for the operator.
fn next_pose(st: &Station, w: &Wizard) -> Value {
    let held = w.captures.iter().filter(|c| c.held.is_some()).count();
    if held >= HELD_POSES {
        return json!({"done": true, "say": "every held pose is taken: now sweep the turntable"});
    }
    let board = sim::Board::chessboard(st.board.cols, st.board.rows, st.square);
    let distance = st.cfg.rig.turntable.map(|t| t.point.coords.norm()).unwrap_or(400.0);
    let pose = sim::board::default_fixed_poses(&board, distance, HELD_POSES)[held];
    let (c, r) = (st.board.cols as f64 + 1.0, st.board.rows as f64 + 1.0);
    let s = st.square;
    let outline: Vec<[f64; 2]> = [(-1.0, -1.0), (c - 1.0, -1.0), (c - 1.0, r - 1.0), (-1.0, r - 1.0)]
        .iter()
        .filter_map(|&(x, y)| st.cfg.rig.camera.project(&(pose * rig::Point3::new(x * s, y * s, 0.0))))
        .map(|p| [p.x, p.y])
        .collect();
    let (roll, pitch, yaw) = pose.rotation.euler_angles();
    json!({
        "done": false,
        "index": held,
        "outline": outline,
        "say": format!(
            "pose {} of {HELD_POSES}: hold the board inside the outline, tilted {:.0}° about the image's x axis and {:.0}° about its y axis, turned {:.0}° in its plane",
            held + 1, (roll.to_degrees().abs() - 180.0).abs(), pitch.to_degrees(), yaw.to_degrees()
        ),
    })
}

/// The wizard's state for the page: captures, coverage, the next pose.
pub fn describe(st: &Station) -> Value {
    let w = lock(&st.calibration);
    let (cw, ch) = (st.cfg.rig.camera.width as f64, st.cfg.rig.camera.height as f64);
    let mut cells = vec![0usize; COVERAGE.0 * COVERAGE.1];
    for c in w.captures.iter().filter(|c| c.accepted == Some(true)) {
        for p in c.corners.iter().flatten() {
            let i = ((p[0] / cw * COVERAGE.0 as f64) as usize).min(COVERAGE.0 - 1);
            let j = ((p[1] / ch * COVERAGE.1 as f64) as usize).min(COVERAGE.1 - 1);
            cells[j * COVERAGE.0 + i] += 1;
        }
    }
    let captures: Vec<Value> = w
        .captures
        .iter()
        .enumerate()
        .map(|(i, c)| {
            json!({
                "index": i,
                "kind": if c.held.is_some() { "held" } else { "sweep" },
                "angle_deg": c.angle_deg,
                "corners": c.corners.as_ref().map_or(0, Vec::len),
                "found": c.corners.is_some(),
                "accepted": c.accepted,
                "picture": format!("/api/calibrate/capture/{i}.png"),
            })
        })
        .collect();
    json!({
        "captures": captures,
        "coverage": {"cols": COVERAGE.0, "rows": COVERAGE.1, "cells": cells, "width": cw, "height": ch},
        "next": next_pose(st, &w),
        "sweep": SWEEP_DEG,
    })
}

/// Takes the next held pose (`kind` "held") or the whole sweep ("sweep").
pub fn capture(st: &Arc<Station>, kind: &str) -> Result<()> {
    if matches!(st.devices.camera(), CameraChoice::Folder(_)) {
        bail!("the wizard captures with a live camera; a folder of frames is calibrated with `scanrig calibrate all`");
    }
    let rig = st.rig()?;
    let board = sim::Board::chessboard(st.board.cols, st.board.rows, st.square);
    let program = sim::scan::program(&st.cfg, Method::Board)?;
    let lit = if program.contains(&Pattern::White) { Pattern::White } else { Pattern::LaserOff };
    let todo: Vec<(Option<usize>, f64)> = match kind {
        "held" => {
            let w = lock(&st.calibration);
            let held = w.captures.iter().filter(|c| c.held.is_some()).count();
            if held >= HELD_POSES {
                bail!("every held pose is taken ({HELD_POSES}); sweep the turntable or calibrate");
            }
            vec![(Some(held), 0.0)]
        }
        "sweep" => SWEEP_DEG.iter().map(|&a| (None, a)).collect(),
        other => bail!("kind: {other:?} is neither held nor sweep"),
    };
    rig::run_files::workspace(&root(st))?;
    let mut link = st.devices.take()?;
    let result = (|| -> Result<()> {
        for (held, angle) in todo {
            let index = {
                let mut w = lock(&st.calibration);
                w.taken += 1;
                w.taken
            };
            let dir = root(st).join("captures").join(format!("capture_{index:03}"));
            if dir.exists() {
                std::fs::remove_dir_all(&dir).with_context(|| format!("clearing {}", dir.display()))?;
            }
            let distance = st.cfg.rig.turntable.map(|t| t.point.coords.norm()).unwrap_or(400.0);
            let pose = held.map(|k| sim::board::default_fixed_poses(&board, distance, HELD_POSES)[k]);
            let scene = sim::board::board_scene(&st.cfg, &board, pose);
            take_one(st, &rig, &scene, &program, &mut link, &dir, angle, held.is_some(), index)?;
            let m = Manifest::read(&dir)?;
            let frame = m.views[0].frames.iter().find(|f| f.pattern == lit).context("the capture's lit frame")?;
            let img = rig::image::read_image(&Manifest::frame_path(&dir, frame))?;
            // A board cut by the image's edge counts for what is seen, as `calibrate` uses it.
            let corners =
                calib::find_board(&calib::Gray::from_image(&img), st.board.cols as usize, st.board.rows as usize)
                    .ok()
                    .map(|c| c.pixels.iter().map(|p| [p.x, p.y]).collect::<Vec<_>>());
            lock(&st.calibration).captures.push(Capture { held, angle_deg: angle, dir, corners, accepted: None });
            st.bus.send("calibration", describe(st));
        }
        Ok(())
    })();
    st.devices.give_back(link);
    result
}

/// One capture through the capture session (one view of the board's program), the platter back
/// at its mark after it.
#[allow(clippy::too_many_arguments)]
fn take_one(
    st: &Station,
    rig: &rig::Rig,
    scene: &sim::Scene,
    program: &[Pattern],
    link: &mut Link,
    dir: &Path,
    angle: f64,
    held: bool,
    index: usize,
) -> Result<()> {
    let shown = Arc::new(Mutex::new(None));
    let cfg = st.camera_config();
    // The simulated capture: each its own noise, as separate exposures have.
    let seed = st.world.seed.wrapping_add(index as u64 + 1);
    let simulated = st.devices.camera() == CameraChoice::Simulator;
    let what = super::live::Shooting { cfg: &cfg, scene, program, seed };
    let mut camera = super::live::live_camera(st, what, link, &shown)?;
    let mut projector = st.projector_for(rig, &shown, program)?;
    let mut plan = acquire::Plan::full_turn(Method::Board, program.to_vec(), 1);
    plan.angles = vec![angle];
    plan.settle = if link.board.is_some() { Duration::ZERO } else { Duration::from_millis(200) };
    plan.seed = simulated.then_some(seed);
    let devices =
        acquire::Devices { turntable: &mut link.turntable, camera: camera.as_mut(), projector: &mut projector };
    acquire::session::clear_stop();
    acquire::session::run(dir, rig, &plan, false, devices, |_, _, _| {})?;
    acquire::Turntable::move_to(&mut link.turntable, 0.0)?;
    if held {
        let mut m = Manifest::read(dir)?;
        m.views[0].held = true;
        m.write(dir)?;
    }
    Ok(())
}

/// `{index, accept}`: keeps or drops a capture.
pub fn review(st: &Station, b: &Value) -> Result<Value, String> {
    let Some(i) = b["index"].as_u64() else { return Err(format!("index: a capture's number, got {}", b["index"])) };
    let Some(accept) = b["accept"].as_bool() else { return Err(format!("accept: true or false, got {}", b["accept"])) };
    {
        let mut w = lock(&st.calibration);
        let c = w.captures.get_mut(i as usize).ok_or_else(|| format!("index: no capture {i}"))?;
        if accept && c.corners.is_none() {
            return Err(format!("capture {i}: the board was not found in it; take it again"));
        }
        c.accepted = Some(accept);
    }
    let d = describe(st);
    st.bus.send("calibration", d.clone());
    Ok(d)
}

/// Starts over: the captures are forgotten (their folders stay until overwritten).
pub fn reset(st: &Station) -> Result<Value, String> {
    lock(&st.calibration).captures.clear();
    let d = describe(st);
    st.bus.send("calibration", d.clone());
    Ok(d)
}

/// A capture's lit frame with its corners, as PNG.
pub fn picture(st: &Station, path: &str) -> tiny_http::ResponseBox {
    let i: Option<usize> = path.rsplit('/').next().and_then(|n| n.strip_suffix(".png")).and_then(|n| n.parse().ok());
    let w = lock(&st.calibration);
    let Some(c) = i.and_then(|i| w.captures.get(i)) else { return super::error(404, "no such capture") };
    let img = Manifest::read(&c.dir).ok().and_then(|m| {
        let f = m.views[0].frames.iter().find(|f| matches!(f.pattern, Pattern::White | Pattern::LaserOff))?.clone();
        rig::image::read_image(&Manifest::frame_path(&c.dir, &f)).ok()
    });
    let Some(img) = img else { return super::error(404, "the capture's frame is gone") };
    let mut rgb = web::picture::to_rgb(&img);
    if let Some(corners) = &c.corners {
        web::picture::mark(&mut rgb, corners, 2, [0, 220, 0]);
    }
    tiny_http::Response::from_data(rig::image::png_bytes(&rgb, true))
        .with_header(super::header("Content-Type", "image/png"))
        .boxed()
}

/// Gathers the accepted captures into `calibration/board` and runs `scanrig calibrate all` on it.
pub fn run(st: &Arc<Station>) -> Result<()> {
    let accepted: Vec<(PathBuf, bool)> = lock(&st.calibration)
        .captures
        .iter()
        .filter(|c| c.accepted == Some(true))
        .map(|c| (c.dir.clone(), c.held.is_some()))
        .collect();
    if accepted.is_empty() {
        bail!("no capture accepted yet: take the held poses and the sweep, and accept the good ones");
    }
    let folder = root(st).join("board");
    rig::run_files::workspace(&root(st))?;
    gather(&accepted, &folder)?;
    let words: Vec<std::ffi::OsString> = vec![
        "scanrig".into(),
        "calibrate".into(),
        "all".into(),
        folder.clone().into(),
        "-o".into(),
        st.rig_path.clone().into(),
        "--board".into(),
        format!("{}x{}", st.board.cols, st.board.rows).into(),
        "--square".into(),
        st.square.to_string().into(),
    ];
    let Command::Calibrate(args) = Args::try_parse_from(words)?.command else { bail!("not a calibrate command") };
    let report_path = st.rig_path.with_file_name(format!(
        "{}.report.json",
        st.rig_path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "rig".into())
    ));
    let result = crate::calibrate::calibrate_into_files(&args, &folder);
    let report: Option<Value> = std::fs::read(&report_path).ok().and_then(|b| serde_json::from_slice(&b).ok());
    let page = report_path.with_extension("html");
    let link = page.strip_prefix(&st.data).ok().map(|p| format!("/files/{}", p.display()));
    st.bus.send(
        "calibrated",
        json!({
            "ok": result.is_ok(),
            "message": result.as_ref().err().map(|e| format!("{e:#}")),
            "warnings": report.as_ref().map(|r| r["warnings"].clone()),
            "rms_px": report.as_ref().map(|r| r["camera"]["rms_px"].clone()),
            "report": link,
            "rig": st.rig_path.display().to_string(),
            "captures": folder.display().to_string(),
        }),
    );
    st.bus.send("state", st.state_json());
    result.map(|_| ())
}

/// One capture folder from the accepted ones: each one's view, its frames renumbered, in order.
fn gather(captures: &[(PathBuf, bool)], folder: &Path) -> Result<()> {
    if folder.exists() {
        std::fs::remove_dir_all(folder).with_context(|| format!("clearing {}", folder.display()))?;
    }
    std::fs::create_dir_all(folder)?;
    let first = Manifest::read(&captures[0].0)?;
    let mut manifest = Manifest { views: Vec::new(), ..first };
    for (v, (dir, held)) in captures.iter().enumerate() {
        let m = Manifest::read(dir)?;
        let mut view = m.views[0].clone();
        for (f, frame) in view.frames.iter_mut().enumerate() {
            let from = Manifest::frame_path(dir, frame);
            frame.file = ScanLayout::frame(v, f, &frame.pattern);
            let to = Manifest::frame_path(folder, frame);
            std::fs::create_dir_all(to.parent().expect("a frame's folder"))?;
            std::fs::copy(&from, &to).with_context(|| format!("copying {}", from.display()))?;
        }
        view.held = *held;
        manifest.views.push(view);
    }
    std::fs::copy(captures[0].0.join("rig.toml"), folder.join("rig.toml"))?;
    manifest.write(folder)?;
    Ok(())
}
