//! The projector as a borderless fullscreen window on one monitor (feature `projector-window`):
//! `show` draws the pattern (through the projector's response, so the emitted light is what the
//! pattern asks for) and returns once it is presented. winit and softbuffer load X11 or Wayland at
//! run time, so the build needs no system library.
//!
//! winit allows one event loop per process; it runs on its own thread here.

use crate::camera::{CameraError, PatternOutput};
use rig::Pattern;
use std::num::NonZeroU32;
use std::rc::Rc;
use std::sync::mpsc::{Receiver, Sender, channel};
use std::time::Duration;
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop, EventLoopProxy};
use winit::platform::x11::EventLoopBuilderExtX11;
use winit::window::{Fullscreen, Window, WindowId};

enum Msg {
    /// An XRGB frame of the projector's size.
    Show(Vec<u32>),
    Exit,
}

/// A fullscreen window showing patterns.
pub struct WindowProjector {
    proxy: EventLoopProxy<Msg>,
    presented: Receiver<Result<(), String>>,
    size: (u32, u32),
    gamma: f64,
    thread: Option<std::thread::JoinHandle<()>>,
}

struct App {
    monitor: Option<usize>,
    size: (u32, u32),
    window: Option<Rc<Window>>,
    surface: Option<softbuffer::Surface<Rc<Window>, Rc<Window>>>,
    frame: Vec<u32>,
    presented: Sender<Result<(), String>>,
    pending: bool,
}

impl App {
    fn open(&mut self, el: &ActiveEventLoop) -> Result<(), String> {
        let monitor = match self.monitor {
            Some(i) => Some(el.available_monitors().nth(i).ok_or_else(|| format!("there is no monitor {i}"))?),
            None => el.primary_monitor().or_else(|| el.available_monitors().next()),
        };
        let mut attrs = Window::default_attributes()
            .with_title("scanrig projector")
            .with_decorations(false)
            .with_inner_size(winit::dpi::PhysicalSize::new(self.size.0, self.size.1));
        if let Some(m) = monitor {
            // Fullscreen needs a window manager; without one the position and size still place it.
            attrs = attrs.with_position(m.position()).with_fullscreen(Some(Fullscreen::Borderless(Some(m))));
        }
        let window = Rc::new(el.create_window(attrs).map_err(|e| e.to_string())?);
        window.set_cursor_visible(false);
        let context = softbuffer::Context::new(window.clone()).map_err(|e| e.to_string())?;
        let surface = softbuffer::Surface::new(&context, window.clone()).map_err(|e| e.to_string())?;
        self.window = Some(window);
        self.surface = Some(surface);
        Ok(())
    }

    fn draw(&mut self) -> Result<(), String> {
        let (Some(window), Some(surface)) = (&self.window, &mut self.surface) else { return Ok(()) };
        let sz = window.inner_size();
        let (w, h) = (sz.width.max(1), sz.height.max(1));
        surface
            .resize(NonZeroU32::new(w).expect("non-zero"), NonZeroU32::new(h).expect("non-zero"))
            .map_err(|e| e.to_string())?;
        let mut buf = surface.buffer_mut().map_err(|e| e.to_string())?;
        let (pw, ph) = (self.size.0 as usize, self.size.1 as usize);
        // The window is normally the projector's size; otherwise the pattern is sampled to fit.
        for y in 0..h as usize {
            let sy = y * ph / h as usize;
            for x in 0..w as usize {
                let sx = x * pw / w as usize;
                buf[y * w as usize + x] = self.frame.get(sy * pw + sx).copied().unwrap_or(0);
            }
        }
        buf.present().map_err(|e| e.to_string())
    }
}

impl ApplicationHandler<Msg> for App {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.window.is_none()
            && let Err(e) = self.open(el)
        {
            let _ = self.presented.send(Err(e));
            el.exit();
        }
    }

    fn window_event(&mut self, el: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => el.exit(),
            WindowEvent::RedrawRequested => {
                let r = self.draw();
                if self.pending {
                    self.pending = false;
                    let _ = self.presented.send(r);
                }
            }
            _ => {}
        }
    }

    fn user_event(&mut self, el: &ActiveEventLoop, msg: Msg) {
        match msg {
            Msg::Show(frame) => {
                self.frame = frame;
                self.pending = true;
                match &self.window {
                    Some(w) => w.request_redraw(),
                    None => {
                        self.pending = false;
                        let _ = self.presented.send(Err("the projector window is not open".into()));
                    }
                }
            }
            Msg::Exit => el.exit(),
        }
    }
}

impl WindowProjector {
    /// Opens a `width × height` window on monitor `monitor` (default: the primary one) for a
    /// projector whose response is `light = drive^gamma`.
    pub fn open(monitor: Option<usize>, width: u32, height: u32, gamma: f64) -> Result<WindowProjector, CameraError> {
        let (ready_tx, ready_rx) = channel();
        let (presented_tx, presented) = channel();
        let thread = std::thread::spawn(move || {
            let el = match EventLoop::<Msg>::with_user_event().with_any_thread(true).build() {
                Ok(el) => el,
                Err(e) => {
                    let _ = ready_tx.send(Err(format!("no display for the projector window: {e}")));
                    return;
                }
            };
            el.set_control_flow(ControlFlow::Wait);
            let _ = ready_tx.send(Ok(el.create_proxy()));
            let mut app = App {
                monitor,
                size: (width, height),
                window: None,
                surface: None,
                frame: Vec::new(),
                presented: presented_tx,
                pending: false,
            };
            let _ = el.run_app(&mut app);
        });
        let proxy = ready_rx
            .recv_timeout(Duration::from_secs(10))
            .map_err(|_| CameraError::Unavailable("the projector window did not start".into()))?
            .map_err(CameraError::Unavailable)?;
        Ok(WindowProjector { proxy, presented, size: (width, height), gamma, thread: Some(thread) })
    }
}

impl PatternOutput for WindowProjector {
    fn show(&mut self, pattern: Option<Pattern>) -> Result<(), CameraError> {
        let (w, h) = self.size;
        let gamma = self.gamma.max(1e-3);
        let frame: Vec<u32> = (0..h)
            .flat_map(|r| (0..w).map(move |c| (r, c)))
            .map(|(r, c)| {
                let light = pattern.map_or(0.0, |p| p.pixel_value(c, r));
                let g = (light.clamp(0.0, 1.0).powf(1.0 / gamma) * 255.0).round() as u32;
                g * 0x0001_0101
            })
            .collect();
        // A confirmation that came after an earlier show timed out belongs to that pattern; a window
        // that could not open (a monitor not there) said why before its loop ended.
        let mut why = None;
        while let Ok(r) = self.presented.try_recv() {
            why = r.err().or(why);
        }
        let closed =
            || CameraError::Unavailable(why.clone().unwrap_or_else(|| "the projector window has closed".into()));
        self.proxy.send_event(Msg::Show(frame)).map_err(|_| closed())?;
        match self.presented.recv_timeout(Duration::from_secs(5)) {
            Ok(r) => r.map_err(CameraError::Unavailable),
            // The loop ended after the pattern was sent (having said why, or its window closed).
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => Err(closed()),
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                Err(CameraError::Unavailable("the projector window did not present the pattern".into()))
            }
        }
    }
}

impl Drop for WindowProjector {
    fn drop(&mut self) {
        let _ = self.proxy.send_event(Msg::Exit);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
