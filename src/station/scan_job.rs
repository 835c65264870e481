//! A scan from the station: the capture session `scanrig scan` runs, into a project under `--data`,
//! and each view decoded and triangulated as it lands (the `process` pipeline's own view stages,
//! on that view alone) and sent to the page's 3D view with its quality badge. A stop, a fault or a
//! cancel keeps every complete view; starting the scan again resumes it.

use super::devices::CameraChoice;
use super::events::now_ms;
use super::live::{Shooting, live_camera};
use super::{Station, projects};
use crate::virtual_rig::capture_program;
use acquire::camera::{Camera, PatternOutput};
use anyhow::{Context, Result, bail};
use process::pipeline::layout::Layout;
use process::{ProcessParams, Stage};
use serde_json::{Value, json};
use std::collections::VecDeque;
use std::path::Path;
use std::sync::mpsc::{Receiver, TryRecvError, channel};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// Points a view sends to the page's 3D view at most (the page shows the whole cloud after
/// processing; live, a thinned view is enough to see coverage grow).
const LIVE_POINTS: usize = 4000;

/// The project and view count of a scan request `{project, views}`.
pub fn request(st: &Station, b: &Value) -> Result<(String, usize), String> {
    let project = projects::name(b)?;
    let views = match &b["views"] {
        Value::Null => st.cfg.scan.views as usize,
        v => match v.as_u64() {
            Some(n @ 1..=3600) => n as usize,
            _ => return Err(format!("views: a whole number from 1 to 3600, got {v}")),
        },
    };
    Ok((project, views))
}

/// Runs (or resumes) the scan of `project` with `views` views.
pub fn run(st: &Arc<Station>, project: &str, views: usize) -> Result<()> {
    let dir = st.data.join(project);
    let rig = st.rig()?;
    let (method, program) = capture_program(&rig, &st.cfg)?;
    // The project folder is the job's own: it reads and rewrites its manifest, and writes
    // processed/ inside it.
    rig::run_files::workspace(&dir)?;
    let resume = dir.join("scan.json").is_file();
    if resume {
        let m = rig::Manifest::read(&dir)?;
        if m.views.len() != views || m.views.first().is_some_and(|v| v.frames.len() != program.len()) {
            bail!(
                "{project} holds a scan of {} views with other frames; resume it with {} views or choose another project name",
                m.views.len(),
                m.views.len()
            );
        }
    }
    // A stop asked of an earlier scan is not this one's.
    acquire::session::clear_stop();
    let mut plan = acquire::Plan::full_turn(method, program.clone(), views);
    plan.seed = Some(st.world.seed);
    // The projector first: a scan whose frames would be unlit is refused before the rig moves.
    let shown = Arc::new(Mutex::new(None));
    let mut projector = st.projector_for(&rig, &shown, &program)?;
    let mut link = st.devices.take()?;
    let virtual_board = link.board.is_some();
    plan.settle = if virtual_board { Duration::ZERO } else { Duration::from_millis(200) };
    st.bus.send("scan", json!({"project": project, "state": "running", "views": views, "resumed": resume}));

    // The object as the virtual rig shows it.
    let size = st.world.size.unwrap_or(st.cfg.scene.object_size_mm);
    let (object, albedo) =
        crate::sim_cmd::object_on_platter(&st.cfg, st.world.mesh.as_deref(), size, st.world.up, rig::Vector3::zeros())?;
    let scene = sim::Scene::on_turntable(&st.cfg, &object, albedo);
    let cfg = st.camera_config();
    let mut camera: Box<dyn Camera> = match st.devices.camera() {
        CameraChoice::Folder(d) => {
            let mut replay = acquire::FolderCamera::open(&d)?;
            if let Ok(m) = rig::Manifest::read(&dir) {
                replay.skip(m.views.iter().filter(|v| v.complete).count() * program.len());
            }
            Box::new(replay)
        }
        // The simulator or a V4L2 camera, as the live view and the check take them.
        _ => live_camera(
            st,
            Shooting { cfg: &cfg, scene: &scene, program: &program, seed: st.world.seed },
            &link,
            &shown,
        )?,
    };

    // Each view, once on disk, goes to the live worker: decoded, triangulated and sent while the
    // next one is captured. A resumed scan's views so far are shown again too (no capture time:
    // they are not live), but only while no new view waits: each is hashed and read again, and a
    // view captured behind six of them would reach the page seconds late.
    let replay: Vec<usize> = match resume.then(|| rig::Manifest::read(&dir)) {
        Some(Ok(m)) => (0..m.views.len()).filter(|&v| m.views[v].complete).collect(),
        _ => Vec::new(),
    };
    let (views_tx, views_rx) = channel::<(usize, f64)>();
    let live = {
        let (st, dir, rig) = (st.clone(), dir.clone(), rig.clone());
        std::thread::spawn(move || {
            for (view, captured) in live_first(views_rx, replay) {
                if let Err(e) = show_view(&st, &dir, &rig, view, captured) {
                    st.bus.send("view-failed", json!({"view": view, "message": format!("{e:#}")}));
                }
            }
        })
    };
    let started_at = std::time::Instant::now();
    let bus = &st.bus;
    let result = {
        let devices = acquire::Devices {
            turntable: &mut link.turntable,
            camera: camera.as_mut(),
            projector: &mut projector as &mut dyn PatternOutput,
        };
        acquire::session::run(&dir, &rig, &plan, resume, devices, |done, total, eta| {
            let t = now_ms();
            bus.send(
                "captured",
                json!({"view": done - 1, "done": done, "total": total, "at_ms": t,
                       "eta_s": eta.map(|d| d.as_secs_f64()), "elapsed_s": started_at.elapsed().as_secs_f64()}),
            );
            let _ = views_tx.send((done - 1, t));
        })
    };
    drop(views_tx);
    let _ = live.join();
    st.devices.give_back(link);
    match result {
        Ok(r) => {
            st.bus.send(
                "scan",
                json!({"project": project, "state": "complete", "complete": r.complete, "total": r.total}),
            );
            Ok(())
        }
        Err(acquire::session::SessionError::Stopped { complete, total, .. }) => {
            st.bus.send(
                "scan",
                json!({"project": project, "state": "stopped", "complete": complete, "total": total,
                "message": format!("stopped: {complete} of {total} views are kept; Start continues the scan")}),
            );
            Ok(())
        }
        Err(e) => {
            let m = rig::Manifest::read(&dir).ok();
            let complete = m.as_ref().map_or(0, |m| m.views.iter().filter(|v| v.complete).count());
            st.bus.send(
                "scan",
                json!({"project": project, "state": "failed", "complete": complete, "total": views,
                "message": format!("{e}")}),
            );
            Err(anyhow::Error::new(e)
                .context(format!("scanning {project} (every complete view is kept; Start resumes)")))
        }
    }
}

/// The views to show in turn: each newly captured one (with its capture time) as soon as it is
/// sent, and the `replay` views (capture time NaN) only while none waits; ends when the sender is
/// dropped and the replays are done.
fn live_first(live: Receiver<(usize, f64)>, replay: Vec<usize>) -> impl Iterator<Item = (usize, f64)> {
    let mut replay = VecDeque::from(replay);
    std::iter::from_fn(move || match live.try_recv() {
        Ok(next) => Some(next),
        Err(TryRecvError::Empty) => replay.pop_front().map(|v| (v, f64::NAN)).or_else(|| live.recv().ok()),
        Err(TryRecvError::Disconnected) => replay.pop_front().map(|v| (v, f64::NAN)),
    })
}

/// Decodes and triangulates `view` of the scan in `dir` (the pipeline's view stages, that view
/// only, into `dir/processed` where `process` reuses them) and sends its points, in the object's
/// frame, with its badge.
fn show_view(st: &Station, dir: &Path, rig: &rig::Rig, view: usize, captured_ms: f64) -> Result<()> {
    let out = dir.join("processed");
    let params = ProcessParams { until: Stage::Triangulate, views: Some(vec![view]), ..ProcessParams::default() };
    let report = process::process_scan(dir, &out, &params, |_, _, _| {}).context("decoding the view")?;
    let m = rig::Manifest::read(dir)?;
    let angle = m.views.get(view).map_or(0.0, |v| v.angle_deg);
    let v = report.views.iter().find(|r| r.view == view);
    let object_from_camera = rig.turntable.map(|t| t.object_from_camera(angle));
    let mut points = Vec::new();
    let grid_path = Layout::new(&out).path(&Layout::grid(view));
    if grid_path.is_file() {
        let cloud = rig::ply::read_range_grid(&grid_path)?.to_point_cloud();
        let step = cloud.positions.len().div_ceil(LIVE_POINTS).max(1);
        for p in cloud.positions.iter().step_by(step) {
            let q = object_from_camera.map_or(*p, |t| t * p);
            points.extend([q.x, q.y, q.z].map(|c| (c * 10.0).round() / 10.0));
        }
    } else {
        for k in 0..rig.lasers.len() {
            let path = Layout::new(&out).path(&Layout::laser_grid(view, k));
            if let Ok(s) = rig::ply::read_cloud(&path) {
                let step = s.positions.len().div_ceil(LIVE_POINTS).max(1);
                for p in s.positions.iter().step_by(step) {
                    let q = object_from_camera.map_or(*p, |t| t * p);
                    points.extend([q.x, q.y, q.z].map(|c| (c * 10.0).round() / 10.0));
                }
            }
        }
    }
    let (decoded, lit) = v.and_then(|v| v.decode.as_ref()).map_or((0, 0), |d| (d.report.decoded, d.report.lit));
    let warnings: Vec<&String> = report.warnings.iter().collect();
    st.bus.send(
        "view",
        json!({
            "view": view,
            "angle_deg": angle,
            "captured_ms": captured_ms.is_finite().then_some(captured_ms),
            "points": points,
            "badge": {
                "points": v.map_or(0, |v| v.points),
                "coverage": if lit > 0 { decoded as f64 / lit as f64 } else { 0.0 },
                "warnings": warnings,
            },
        }),
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_captured_view_is_shown_before_the_resumed_ones_left_to_show_again() {
        let (tx, rx) = channel();
        tx.send((6, 1.0)).unwrap();
        let mut order = live_first(rx, vec![0, 1, 2]);
        assert_eq!(order.next(), Some((6, 1.0)), "the view waiting goes first");
        assert_eq!(order.next().map(|(v, t)| (v, t.is_nan())), Some((0, true)));
        tx.send((7, 2.0)).unwrap();
        assert_eq!(order.next(), Some((7, 2.0)), "a view captured during the replay jumps it");
        drop(tx);
        let rest: Vec<usize> = order.map(|(v, _)| v).collect();
        assert_eq!(rest, [1, 2], "the replay finishes after the last capture");
    }
}
