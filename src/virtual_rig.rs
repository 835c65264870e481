//! The virtual rig's parts that `scan` and `serve` share: the simulator as a camera watching the
//! virtual turntable, the simulated projector, the rig and capture program a world implies, and the
//! serial port a turntable is opened on.

use acquire::camera::{Camera, CameraError, PatternOutput, Shot};
use acquire::virtual_horus::BoardState;
use anyhow::{Context, Result, bail};
use rig::image::Image8;
use rig::{Method, Pattern};
use sim::{Scene, SimConfig, ViewGeometry};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// The simulator as a camera: it renders what the virtual board's platter and lasers and the
/// simulated projector show at the moment of capture, with the simulator's noise for that view and
/// frame, so a session on the virtual rig records exactly what `scanrig sim` writes.
pub struct SimCamera<'a> {
    pub cfg: &'a SimConfig,
    pub scene: &'a Scene,
    pub rays: Vec<rig::Vector3>,
    pub program: Vec<Pattern>,
    pub lights: Vec<sim::light::PatternLight>,
    pub seed: u64,
    pub board: Arc<Mutex<BoardState>>,
    pub shown: Arc<Mutex<Option<Pattern>>>,
    pub geometry: Option<(f64, ViewGeometry)>,
}

impl<'a> SimCamera<'a> {
    /// The simulator showing `scene` with `cfg`'s sensor, its lights made for `program`, watching
    /// the virtual `board` and the simulated projector's `shown` pattern.
    pub fn new(
        cfg: &'a SimConfig,
        scene: &'a Scene,
        program: &[Pattern],
        seed: u64,
        board: Arc<Mutex<BoardState>>,
        shown: Arc<Mutex<Option<Pattern>>>,
    ) -> Self {
        SimCamera {
            cfg,
            scene,
            rays: sim::pixel_rays(&cfg.rig.camera),
            lights: sim::scan::lights_for(cfg, program),
            program: program.to_vec(),
            seed,
            board,
            shown,
            geometry: None,
        }
    }
}

impl Camera for SimCamera<'_> {
    fn size(&self) -> (u32, u32) {
        (self.cfg.rig.camera.width, self.cfg.rig.camera.height)
    }

    fn capture(&mut self, shot: &Shot) -> Result<Image8, CameraError> {
        let board = self.board.lock().expect("board state").clone();
        // What is lit now: the projected pattern, else the lasers that are on.
        let showing = match *self.shown.lock().expect("projector state") {
            Some(p) => p,
            None => match board.lasers.iter().position(|&on| on) {
                Some(index) => Pattern::Laser { index },
                None => Pattern::LaserOff,
            },
        };
        // Dark, with the work light on: the texture shot (the work light is not under the session's
        // control, so the shot says it).
        let showing =
            if shot.pattern == Pattern::Texture && showing == Pattern::LaserOff { Pattern::Texture } else { showing };
        let k = self.program.iter().position(|&p| p == showing).ok_or_else(|| {
            CameraError::Frame(format!("the simulated rig cannot show {showing:?} (not in its capture program)"))
        })?;
        let angle = board.angle_deg;
        if self.geometry.as_ref().is_none_or(|(a, _)| *a != angle) {
            let pose = sim::scan::view_pose(self.cfg, angle);
            self.geometry = Some((angle, sim::view_geometry(self.scene, self.cfg, &self.rays, &pose)));
        }
        let g = &self.geometry.as_ref().expect("just computed").1;
        Ok(sim::render_frame(g, self.cfg, &self.lights[k], sim::render::frame_key(self.seed, shot.view, shot.frame)))
    }
}

/// The simulated projector: what it shows, the simulator camera sees.
pub struct SimProjector(pub Arc<Mutex<Option<Pattern>>>);

impl PatternOutput for SimProjector {
    fn show(&mut self, pattern: Option<Pattern>) -> Result<(), CameraError> {
        *self.0.lock().expect("projector state") = pattern;
        Ok(())
    }
}

pub fn open_port(port: &str) -> Result<Box<dyn serialport::SerialPort>> {
    serialport::new(port, 115_200)
        .timeout(Duration::from_millis(100))
        .open()
        .with_context(|| format!("opening the turntable's serial port {port}"))
}

/// The rig a simulated world scans with: the config's, its platter radius as the working volume.
pub fn default_rig(cfg: &SimConfig) -> rig::Rig {
    let mut r = cfg.rig.clone();
    if cfg.rig.turntable.is_some() && cfg.scene.platter_radius_mm > 0.0 {
        r.platter_radius_mm = Some(cfg.scene.platter_radius_mm);
    }
    r
}

/// The capture program is the rig's: its projector's patterns (with the config's phase sets), else
/// one frame per laser — the frames then decode against the rig recorded beside them — and a
/// texture frame under the work light where the config asks for colour.
pub fn capture_program(rig: &rig::Rig, cfg: &SimConfig) -> Result<(Method, Vec<Pattern>)> {
    let (method, program) = match &rig.projector {
        Some(p) => (
            Method::StructuredLight,
            rig::patterns::structured_light_sequence(p.lens.width, p.lens.height, &cfg.scan.phase),
        ),
        None if !rig.lasers.is_empty() => (Method::Laser, rig::patterns::laser_sequence(rig.lasers.len())),
        None => bail!("the rig has neither a projector nor lasers: nothing to scan with"),
    };
    Ok((method, program.into_iter().chain(cfg.scan.texture.then_some(Pattern::Texture)).collect()))
}
