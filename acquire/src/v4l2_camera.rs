//! A V4L2 webcam (feature `v4l2`): format chosen and read back, exposure, gain and white balance
//! locked and read back (many webcams refuse or silently ignore a control: those are reported, not
//! assumed), and no stale frames — each capture starts a fresh stream and drops its first frames,
//! so nothing queued before the last laser or pattern change is returned.

use crate::camera::{Camera, CameraError, Shot};
use rig::image::Image8;
use v4l::buffer::Type;
use v4l::control::{Control, Value};
use v4l::io::traits::CaptureStream;
use v4l::video::Capture;
use v4l::{Device, Format, FourCC};

/// V4L2 control IDs (`linux/videodev2.h`).
mod cid {
    pub const EXPOSURE_AUTO: u32 = 0x009A_0901;
    pub const EXPOSURE_ABSOLUTE: u32 = 0x009A_0902;
    pub const AUTOGAIN: u32 = 0x0098_0912;
    pub const GAIN: u32 = 0x0098_0913;
    pub const AUTO_WHITE_BALANCE: u32 = 0x0098_090C;
    /// `V4L2_EXPOSURE_MANUAL`.
    pub const EXPOSURE_MANUAL: i64 = 1;
}

/// How to open the camera.
#[derive(Debug, Clone, PartialEq)]
pub struct V4l2Options {
    /// Frame size asked for (the driver may choose another; it is read back).
    pub width: u32,
    /// See `width`.
    pub height: u32,
    /// Manual exposure in the driver's units (100 µs for UVC), or keep the current value.
    pub exposure: Option<i64>,
    /// Gain, or keep the current value.
    pub gain: Option<i64>,
    /// Frames dropped at the start of every capture.
    pub flush: usize,
}

impl Default for V4l2Options {
    fn default() -> Self {
        V4l2Options { width: 1280, height: 960, exposure: None, gain: None, flush: 3 }
    }
}

/// An open V4L2 camera.
pub struct V4l2Camera {
    device: Device,
    path: String,
    format: Format,
    flush: usize,
    /// Controls the camera refused or did not keep, for the operator.
    pub refused: Vec<String>,
}

/// The video devices: path and the driver's name for each.
pub fn list_devices() -> Vec<(String, String)> {
    let mut out: Vec<(String, String)> = v4l::context::enum_devices()
        .into_iter()
        .map(|n| (n.path().display().to_string(), n.name().unwrap_or_default()))
        .collect();
    out.sort();
    out
}

impl V4l2Camera {
    /// Opens `path` (e.g. `/dev/video0`) and locks its exposure, gain and white balance.
    pub fn open(path: &str, opts: &V4l2Options) -> Result<V4l2Camera, CameraError> {
        let unavailable = |e: std::io::Error| CameraError::Unavailable(format!("{path}: {e}"));
        let device = Device::with_path(path).map_err(unavailable)?;
        // Grey or YUYV (its Y plane is grey) where offered, else MJPEG.
        let mut format = device.format().map_err(unavailable)?;
        for fourcc in [b"GREY", b"YUYV", b"MJPG"] {
            let want = Format::new(opts.width, opts.height, FourCC::new(fourcc));
            if let Ok(got) = device.set_format(&want)
                && got.fourcc == want.fourcc
            {
                format = got;
                break;
            }
        }
        if ![b"GREY", b"YUYV", b"MJPG"].iter().any(|f| format.fourcc == FourCC::new(f)) {
            return Err(CameraError::Unavailable(format!(
                "{path}: offers {} frames; scanrig reads GREY, YUYV or MJPG",
                format.fourcc
            )));
        }
        let mut cam = V4l2Camera { device, path: path.into(), format, flush: opts.flush, refused: Vec::new() };
        cam.lock(cid::EXPOSURE_AUTO, "manual exposure", cid::EXPOSURE_MANUAL);
        if let Some(e) = opts.exposure {
            cam.lock(cid::EXPOSURE_ABSOLUTE, "exposure", e);
        }
        cam.lock(cid::AUTOGAIN, "auto gain off", 0);
        if let Some(g) = opts.gain {
            cam.lock(cid::GAIN, "gain", g);
        }
        cam.lock(cid::AUTO_WHITE_BALANCE, "auto white balance off", 0);
        Ok(cam)
    }

    /// Sets a control and reads it back; a refusal or a different value is noted in `refused`.
    fn lock(&mut self, id: u32, what: &str, value: i64) {
        let set = self.device.set_control(Control { id, value: Value::Integer(value) });
        let back = self.device.control(id);
        match (set, back) {
            (Ok(()), Ok(Control { value: Value::Integer(v), .. })) if v == value => {}
            (Ok(()), Ok(Control { value: Value::Boolean(b), .. })) if b == (value != 0) => {}
            (Err(e), _) => self.refused.push(format!("{what}: refused ({e})")),
            (Ok(()), Ok(c)) => self.refused.push(format!("{what}: asked {value}, the camera kept {:?}", c.value)),
            (Ok(()), Err(e)) => self.refused.push(format!("{what}: set, but cannot be read back ({e})")),
        }
    }

    /// The frame as an image: grey for pattern frames; with `colour` (the texture shot), RGB from
    /// YUYV (BT.601), the JPEG's own colour from MJPG, grey from a grey stream (a mono camera has no
    /// colour to give).
    fn to_image(&self, bytes: &[u8], colour: bool) -> Result<Image8, CameraError> {
        let (w, h) = (self.format.width as usize, self.format.height as usize);
        let stride = (self.format.stride as usize).max(w);
        let frame_err = |m: String| CameraError::Frame(format!("{}: {m}", self.path));
        if self.format.fourcc == FourCC::new(b"MJPG") {
            let img = rig::image::decode_jpeg(bytes).map_err(|e| frame_err(e.to_string()))?;
            if (img.width as usize, img.height as usize) != (w, h) {
                return Err(frame_err(format!("a {}x{} JPEG frame from a {w}x{h} stream", img.width, img.height)));
            }
            return Ok(img);
        }
        let yuyv = self.format.fourcc == FourCC::new(b"YUYV");
        let row_bytes = if yuyv { stride.max(2 * w) } else { stride };
        if bytes.len() < row_bytes * h {
            return Err(frame_err(format!("a short frame: {} bytes for {w}x{h}", bytes.len())));
        }
        if colour && yuyv && w.is_multiple_of(2) {
            // Y0 U Y1 V: each pair of pixels shares its chroma.
            let data = (0..h)
                .flat_map(|r| {
                    let row = &bytes[r * row_bytes..];
                    (0..w).flat_map(move |c| {
                        let pair = 4 * (c / 2);
                        let (y, u, v) = (row[2 * c] as f32, row[pair + 1] as f32 - 128.0, row[pair + 3] as f32 - 128.0);
                        let to8 = |x: f32| x.round().clamp(0.0, 255.0) as u8;
                        [to8(y + 1.402 * v), to8(y - 0.344 * u - 0.714 * v), to8(y + 1.772 * u)]
                    })
                })
                .collect();
            return Ok(Image8 { width: w as u32, height: h as u32, channels: 3, data });
        }
        let data = (0..h)
            .flat_map(|r| {
                let row = &bytes[r * row_bytes..];
                (0..w).map(move |c| if yuyv { row[2 * c] } else { row[c] })
            })
            .collect();
        Ok(Image8::gray(w as u32, h as u32, data))
    }
}

impl Camera for V4l2Camera {
    fn size(&self) -> (u32, u32) {
        (self.format.width, self.format.height)
    }

    fn capture(&mut self, shot: &Shot) -> Result<Image8, CameraError> {
        let err = |e: std::io::Error| CameraError::Frame(format!("{}: {e}", self.path));
        // A fresh stream per capture: frames queued before the last laser or pattern change cannot
        // come back; the first few of a new stream are dropped while the sensor settles.
        let mut stream = v4l::io::mmap::Stream::with_buffers(&self.device, Type::VideoCapture, 4).map_err(err)?;
        for _ in 0..self.flush {
            stream.next().map_err(err)?;
        }
        let (buf, meta) = stream.next().map_err(err)?;
        let used = (meta.bytesused as usize).min(buf.len());
        let bytes = if used > 0 { &buf[..used] } else { buf };
        self.to_image(bytes, shot.pattern == rig::Pattern::Texture)
    }
}
