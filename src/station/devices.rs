//! The devices the station drives: a Horus turntable on a serial port or the virtual board, and the
//! simulator's camera or a folder of recorded frames. The turntable's link is opened when a job
//! first needs it and kept between jobs; a link that failed (an unplugged cable) is dropped and
//! opened again by the next job.

use super::{Station, lock};
use crate::virtual_rig::open_port;
use acquire::virtual_horus::{Faults, VirtualBoard};
use acquire::{HorusOptions, HorusTurntable, Turntable};
use anyhow::{Context, Result};
use serde_json::{Value, json};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// The virtual turntable's name among the ports.
pub const VIRTUAL: &str = "virtual";
/// The simulator's name among the cameras.
pub const SIMULATOR: &str = "simulator";

/// An open turntable.
pub struct Link {
    /// Its port.
    pub port: String,
    /// The driver.
    pub turntable: HorusTurntable<Box<dyn serialport::SerialPort>>,
    /// The virtual board behind it, where it is one.
    pub board: Option<Arc<VirtualBoard>>,
}

/// What a camera is.
#[derive(Clone, Debug, PartialEq)]
pub enum CameraChoice {
    /// The simulator, watching the virtual turntable.
    Simulator,
    /// Frames recorded earlier, replayed in order.
    Folder(PathBuf),
    /// A V4L2 camera (`/dev/videoN`; feature `v4l2`).
    Device(String),
}

struct Inner {
    turntable: String,
    camera: CameraChoice,
    link: Option<Link>,
    /// The virtual board of the link, also while a job holds the link (to unplug it by hand).
    board: Option<Arc<VirtualBoard>>,
}

/// The devices chosen and the link.
pub struct Devices(Mutex<Inner>);

impl Default for Devices {
    fn default() -> Self {
        Devices(Mutex::new(Inner {
            turntable: VIRTUAL.into(),
            camera: CameraChoice::Simulator,
            link: None,
            board: None,
        }))
    }
}

impl Devices {
    /// The choice and what else is offered, for the page.
    pub fn describe(&self) -> Value {
        let i = lock(&self.0);
        let mut ports = vec![VIRTUAL.to_string()];
        ports.extend(serialport::available_ports().unwrap_or_default().into_iter().map(|p| p.port_name));
        json!({
            "turntable": i.turntable,
            "camera": match &i.camera {
                CameraChoice::Simulator => SIMULATOR.to_string(),
                CameraChoice::Folder(d) => d.display().to_string(),
                CameraChoice::Device(p) => p.clone(),
            },
            "connected": i.link.is_some() || i.board.as_ref().is_some_and(|b| !b.unplugged()),
            "unplugged": i.board.as_ref().is_some_and(|b| b.unplugged()),
            "ports": ports,
        })
    }

    /// Chooses the devices from `{turntable, camera}`: the virtual turntable or a serial port that
    /// exists, the simulator or a folder of frames.
    pub fn choose(&self, b: &Value) -> Result<(), String> {
        let turntable = b["turntable"].as_str().unwrap_or(VIRTUAL).trim().to_string();
        if turntable != VIRTUAL && !std::path::Path::new(&turntable).exists() {
            return Err(format!(
                "turntable: no serial port {turntable:?} on this machine (plugged in? `scanrig turntable --port` to try it)"
            ));
        }
        let camera = match b["camera"].as_str().unwrap_or(SIMULATOR).trim() {
            SIMULATOR => CameraChoice::Simulator,
            dev if dev.starts_with("/dev/video") && std::path::Path::new(dev).exists() => {
                CameraChoice::Device(dev.to_string())
            }
            dir if std::path::Path::new(dir).is_dir() => CameraChoice::Folder(PathBuf::from(dir)),
            other => {
                return Err(format!(
                    "camera: {other:?} is neither the simulator, a /dev/video device here nor a folder of frames"
                ));
            }
        };
        if camera == CameraChoice::Simulator && turntable != VIRTUAL {
            return Err(
                "camera: the simulator watches the virtual turntable only; choose a folder of frames for a real port"
                    .into(),
            );
        }
        let mut i = lock(&self.0);
        *i = Inner { turntable, camera, link: None, board: None };
        Ok(())
    }

    /// The camera chosen.
    pub fn camera(&self) -> CameraChoice {
        lock(&self.0).camera.clone()
    }

    /// The turntable's link for a job (opened now if none is open), to give back with
    /// [`Devices::give_back`].
    pub fn take(&self) -> Result<Link> {
        let mut i = lock(&self.0);
        if let Some(l) = i.link.take().filter(|l| l.board.as_ref().is_none_or(|b| !b.unplugged())) {
            return Ok(l);
        }
        let (port, board) = if i.turntable == VIRTUAL {
            let b = Arc::new(VirtualBoard::start(Faults::default()).context("starting the virtual turntable")?);
            (b.port.clone(), Some(b))
        } else {
            (i.turntable.clone(), None)
        };
        let opts = HorusOptions {
            motor_settle: if board.is_some() { Duration::ZERO } else { Duration::from_secs(1) },
            ..HorusOptions::default()
        };
        let turntable = HorusTurntable::connect(open_port(&port)?, &port, opts)
            .with_context(|| format!("the turntable on {port} did not answer as Horus firmware"))?;
        i.board = board.clone();
        Ok(Link { port, turntable, board })
    }

    /// A link back after a job; one whose board was unplugged is dropped.
    pub fn give_back(&self, link: Link) {
        let mut i = lock(&self.0);
        if link.board.as_ref().is_none_or(|b| !b.unplugged()) {
            i.link = Some(link);
        }
    }

    /// Pulls the virtual turntable's cable (a fault injected by hand: the scan then stops, keeping
    /// every view, and resumes on a new board).
    pub fn unplug(&self) -> Result<(), String> {
        let i = lock(&self.0);
        match &i.board {
            Some(b) => {
                b.unplug();
                Ok(())
            }
            None => Err("only the virtual turntable can be unplugged from here, and it is not connected".into()),
        }
    }
}

/// A manual move or laser switch: `{angle}` or `{laser, on}` or `{motor}`.
pub fn manual(st: &Station, b: &Value) -> Result<Value, String> {
    let mut link = st.devices.take().map_err(|e| format!("{e:#}"))?;
    let t: &mut dyn Turntable = &mut link.turntable;
    let r = if let Some(a) = b["angle"].as_f64() {
        t.move_to(a).map(|_| format!("turned to {a}°"))
    } else if let Some(k) = b["laser"].as_u64() {
        let on = b["on"].as_bool().unwrap_or(false);
        t.laser(k as usize, on).map(|_| format!("laser {k} {}", if on { "on" } else { "off" }))
    } else if let Some(on) = b["motor"].as_bool() {
        t.motor(on).map(|_| format!("motor {}", if on { "on" } else { "off" }))
    } else {
        st.devices.give_back(link);
        return Err("say {angle}, {laser, on} or {motor}".into());
    };
    st.devices.give_back(link);
    r.map(|m| json!({ "done": m })).map_err(|e| e.to_string())
}
