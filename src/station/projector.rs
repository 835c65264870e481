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

/// What a window's patterns are made for: the projector's size (pixels) and response (gamma).
type MadeFor = ((u32, u32), f64);

/// The projector's window.
pub struct Window {
    output: Mutex<Box<dyn PatternOutput + Send>>,
    /// The rig's projector when the station started: its patterns' size and gamma.
    made_for: MadeFor,
    monitor: usize,
}

impl Window {
    /// Opens the window on `monitor` for `rig`'s projector.
    pub fn open(monitor: usize, rig: &rig::Rig) -> Result<Window> {
        let Some(made_for) = made_for(rig) else {
            bail!("--projector-monitor {monitor}: the station's rig has no projector to show patterns on");
        };
        let mut output = crate::scan_cmd::open_window(monitor, rig)
            .with_context(|| format!("--projector-monitor {monitor}: opening the projector's window"))?;
        // Dark until a job or the operator shows something; the window opens on its first frame, so a
        // monitor that is not there is said now, not at the first job.
        output.show(None).with_context(|| format!("--projector-monitor {monitor}: showing the projector's window"))?;
        Ok(Window { output: Mutex::new(output), made_for, monitor })
    }

    /// Shows `pattern` (None: dark) now.
    pub fn show(&self, pattern: Option<Pattern>) -> Result<(), CameraError> {
        lock(&self.output).show(pattern)
    }

    /// What the page says of it.
    pub fn describe(&self) -> String {
        let ((w, h), _) = self.made_for;
        format!("window on monitor {} ({w}×{h})", self.monitor)
    }
}

/// A job's projector: the simulator's, and the window where there is one. When the job ends, however
/// it ends (an error mid-sequence included), the window goes back to what the operator set by hand
/// (`rest`), as it was before the job.
pub struct Shown<'a> {
    sim: SimProjector,
    window: Option<&'a Window>,
    rest: &'a Mutex<Option<Pattern>>,
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

impl Drop for Shown<'_> {
    fn drop(&mut self) {
        if let Some(w) = self.window
            && let Err(e) = w.show(*lock(self.rest))
        {
            eprintln!("warning: the projector's window did not go back to its hand setting: {e}");
        }
    }
}

/// The projector for a job on `rig` with `camera` showing `program`; the simulator camera sees
/// `shown`, and the window goes back to `rest` (the hand setting) after. A program with the
/// projector's own patterns (Gray codes, phase shifts) is refused where its frames could not be
/// right: a real camera on a rig with a projector and no window to drive it, or a window made for
/// another projector than the rig's. White, black and the lasers are shot either way (a projector
/// left lit by hand still lights the board).
pub fn for_job<'a>(
    window: Option<&'a Window>,
    rig: &rig::Rig,
    camera: &CameraChoice,
    shown: &Arc<Mutex<Option<Pattern>>>,
    program: &[Pattern],
    rest: &'a Mutex<Option<Pattern>>,
) -> Result<Shown<'a>> {
    if projects(program)
        && let Err(why) = drives(window, rig, camera)
    {
        bail!(why);
    }
    Ok(Shown { sim: SimProjector(shown.clone()), window, rest })
}

/// Whether `program` holds patterns only the projector makes.
fn projects(program: &[Pattern]) -> bool {
    program.iter().any(|p| matches!(p, Pattern::Gray { .. } | Pattern::Phase { .. }))
}

/// What `rig`'s projector needs its patterns made for (None: a laser rig).
fn made_for(rig: &rig::Rig) -> Option<MadeFor> {
    rig.projector.as_ref().map(|p| ((p.lens.width, p.lens.height), p.gamma))
}

/// Whether the station drives `rig`'s projector for what `camera` films (Ok on a laser rig).
pub fn drives(window: Option<&Window>, rig: &rig::Rig, camera: &CameraChoice) -> Result<(), String> {
    drivable(camera, made_for(rig), window.map(|w| w.made_for))
}

/// Whether a job's patterns reach what `camera` films: `projector` is what the rig's projector needs
/// (None: a laser rig), `window` what the window makes (None: the station has none).
fn drivable(camera: &CameraChoice, projector: Option<MadeFor>, window: Option<MadeFor>) -> Result<(), String> {
    match (projector, window) {
        (Some(p), Some(w)) if p != w => Err(format!(
            "the projector's window was opened for {}×{} patterns at gamma {}, but the rig's projector is now {}×{} at \
             gamma {} (the rig file changed): restart the station so the window matches it",
            w.0.0, w.0.1, w.1, p.0.0, p.0.1, p.1
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
    /// a laser rig needs no projector; a window made for another projector (size or gamma) than the
    /// rig's is refused. Only Gray codes and phase shifts need it: white, black and lasers do not.
    #[test]
    fn a_projecting_job_is_refused_where_its_frames_would_be_unlit() {
        let camera = CameraChoice::Device("/dev/video0".into());
        let folder = CameraChoice::Folder("frames".into());
        let made = Some(((1024, 768), 2.2));
        let unlit = drivable(&camera, made, None).unwrap_err();
        assert!(unlit.contains("--projector-monitor N"), "{unlit}");
        assert_eq!(drivable(&camera, made, made), Ok(()));
        assert_eq!(drivable(&camera, None, None), Ok(()));
        assert_eq!(drivable(&CameraChoice::Simulator, made, None), Ok(()));
        assert_eq!(drivable(&folder, made, None), Ok(()));
        let other = drivable(&CameraChoice::Simulator, Some(((1280, 800), 2.2)), made).unwrap_err();
        assert!(other.contains("1024×768") && other.contains("1280×800") && other.contains("restart"), "{other}");
        let gamma = drivable(&CameraChoice::Simulator, Some(((1024, 768), 1.0)), made).unwrap_err();
        assert!(gamma.contains("gamma 2.2") && gamma.contains("gamma 1"), "{gamma}");
        let gray = Pattern::Gray { axis: rig::Axis::Columns, bit: 0, bits: 10, inverse: false };
        assert!(projects(&[Pattern::White, gray]));
        assert!(!projects(&[Pattern::White, Pattern::Black, Pattern::LaserOff, Pattern::Laser { index: 0 }]));
    }
}
