//! What the station's jobs show their patterns on: the simulator's projector (what the virtual
//! camera sees) and, with `--projector-monitor`, a fullscreen window on the monitor a real projector
//! is plugged into. The window is opened once, when the station starts (winit allows one event loop
//! a process), and every job, the live view and the projector buttons show through it.
//!
//! A real camera filming a projector that nothing drives records unlit frames, which decode to
//! nothing: a job that projects is refused instead, saying to start the station with the window.

use super::devices::CameraChoice;
use super::lock;
use crate::virtual_rig::SimProjector;
use acquire::camera::{CameraError, PatternOutput};
use anyhow::{Context, Result, bail};
use rig::Pattern;
use std::sync::{Arc, Mutex};

/// The projector's window.
pub struct Window {
    output: Mutex<Box<dyn PatternOutput + Send>>,
    /// The patterns' size, pixels: the rig's projector when the station started.
    size: (u32, u32),
    monitor: usize,
}

impl Window {
    /// Opens the window on `monitor` at the size of `rig`'s projector.
    pub fn open(monitor: usize, rig: &rig::Rig) -> Result<Window> {
        let Some(p) = rig.projector.as_ref() else {
            bail!("--projector-monitor {monitor}: the station's rig has no projector to show patterns on");
        };
        let mut output = crate::scan_cmd::open_window(monitor, rig)
            .with_context(|| format!("--projector-monitor {monitor}: opening the projector's window"))?;
        // Dark until a job or the operator shows something; the window opens on its first frame, so a
        // monitor that is not there is said now, not at the first job.
        output.show(None).with_context(|| format!("--projector-monitor {monitor}: showing the projector's window"))?;
        Ok(Window { output: Mutex::new(output), size: (p.lens.width, p.lens.height), monitor })
    }

    /// Shows `pattern` (None: dark) now.
    pub fn show(&self, pattern: Option<Pattern>) -> Result<(), CameraError> {
        lock(&self.output).show(pattern)
    }

    /// What the page says of it.
    pub fn describe(&self) -> String {
        format!("window on monitor {} ({}×{})", self.monitor, self.size.0, self.size.1)
    }
}

/// A job's projector: the simulator's, and the window where there is one.
pub struct Shown<'a> {
    sim: SimProjector,
    window: Option<&'a Window>,
}

impl PatternOutput for Shown<'_> {
    fn show(&mut self, pattern: Option<Pattern>) -> Result<(), CameraError> {
        self.sim.show(pattern)?;
        match self.window {
            Some(w) => w.show(pattern),
            None => Ok(()),
        }
    }
}

/// The projector for a job on `rig` with `camera` showing `program`; the simulator camera sees
/// `shown`. A program with the projector's own patterns (Gray codes, phase shifts) is refused where
/// its frames could not be right: a real camera on a rig with a projector and no window to drive
/// it, or a window made for another projector than the rig's. White, black and the lasers are shot
/// either way (a projector left lit by hand still lights the board).
pub fn for_job<'a>(
    window: Option<&'a Window>,
    rig: &rig::Rig,
    camera: &CameraChoice,
    shown: &Arc<Mutex<Option<Pattern>>>,
    program: &[Pattern],
) -> Result<Shown<'a>> {
    let projects = program.iter().any(|p| matches!(p, Pattern::Gray { .. } | Pattern::Phase { .. }));
    if projects && let Err(why) = drives(window, rig, camera) {
        bail!(why);
    }
    Ok(Shown { sim: SimProjector(shown.clone()), window })
}

/// Whether the station drives `rig`'s projector for what `camera` films (Ok on a laser rig).
pub fn drives(window: Option<&Window>, rig: &rig::Rig, camera: &CameraChoice) -> Result<(), String> {
    drivable(camera, rig.projector.as_ref().map(|p| (p.lens.width, p.lens.height)), window.map(|w| w.size))
}

/// Whether a job's patterns reach what `camera` films: `projector` is the rig's projector's size
/// (None: a laser rig), `window` the window's (None: the station has none).
fn drivable(camera: &CameraChoice, projector: Option<(u32, u32)>, window: Option<(u32, u32)>) -> Result<(), String> {
    match (projector, window) {
        (Some(p), Some(w)) if p != w => Err(format!(
            "the projector's window was opened for {}×{} patterns, but the rig's projector is now {}×{} (the rig \
             file changed): restart the station so the window matches it",
            w.0, w.1, p.0, p.1
        )),
        (Some(_), None) if matches!(camera, CameraChoice::Device(_)) => {
            Err("the rig has a projector, and the station shows patterns on it only in its own window: start it with \
             `scanrig serve --projector-monitor N` (N: the monitor the projector is plugged into; `scanrig projector \
             show white --monitor N` finds it)"
                .into())
        }
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A real camera needs the window on a projector rig; the simulator and recorded frames do not;
    /// a laser rig needs no projector; a window of another size than the rig's projector is refused.
    #[test]
    fn a_projecting_job_is_refused_where_its_frames_would_be_unlit() {
        let camera = CameraChoice::Device("/dev/video0".into());
        let folder = CameraChoice::Folder("frames".into());
        let size = Some((1024, 768));
        let unlit = drivable(&camera, size, None).unwrap_err();
        assert!(unlit.contains("--projector-monitor N"), "{unlit}");
        assert_eq!(drivable(&camera, size, size), Ok(()));
        assert_eq!(drivable(&camera, None, None), Ok(()));
        assert_eq!(drivable(&CameraChoice::Simulator, size, None), Ok(()));
        assert_eq!(drivable(&folder, size, None), Ok(()));
        let other = drivable(&CameraChoice::Simulator, Some((1280, 800)), size).unwrap_err();
        assert!(other.contains("1024×768") && other.contains("1280×800") && other.contains("restart"), "{other}");
    }
}
