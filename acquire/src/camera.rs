//! Cameras a session captures from: the trait, and the image-folder replay backend (frames another
//! tool recorded, taken in the order of their numbers). The V4L2 backend sits behind the `v4l2` feature; the
//! simulator's camera lives with the command line, which wires the simulator in.

use rig::Pattern;
use rig::image::Image8;
use std::path::{Path, PathBuf};

/// What the session expects a frame to show: which view and frame of the program (a simulated
/// camera keys its noise by these, as the simulator does) and the pattern or laser state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shot {
    /// View index.
    pub view: usize,
    /// Frame index within the view.
    pub frame: usize,
    /// What the frame shows.
    pub pattern: Pattern,
}

/// Why a frame could not be captured.
#[derive(Debug, thiserror::Error)]
pub enum CameraError {
    /// No camera, or it could not be opened.
    #[error("{0}")]
    Unavailable(String),
    /// A frame could not be read.
    #[error("{0}")]
    Frame(String),
    /// A replayed or delivered image is unusable.
    #[error(transparent)]
    File(#[from] rig::Error),
}

/// A camera.
pub trait Camera {
    /// Frame size (width, height).
    fn size(&self) -> (u32, u32);
    /// A fresh frame (never one queued before the last laser or pattern change).
    fn capture(&mut self, shot: &Shot) -> Result<Image8, CameraError>;
}

/// Replays the PNG or JPEG images of a folder in the order of their numbers (`img1, img2, …, img10`, not
/// as text: [`rig::frame_order`]), one per capture.
pub struct FolderCamera {
    files: Vec<PathBuf>,
    next: usize,
    size: (u32, u32),
}

impl FolderCamera {
    /// The images of `dir`; refused when they are not one numbered series (a duplicate number, a
    /// gap, an image of another series), each named: replayed, every frame after it would be
    /// recorded under the wrong pattern.
    pub fn open(dir: &Path) -> Result<FolderCamera, CameraError> {
        let listed = rig::frame_order::list_images(dir)
            .map_err(|e| CameraError::Unavailable(format!("{}: {e}", dir.display())))?;
        let files = listed.complete(dir)?;
        let first = files
            .first()
            .ok_or_else(|| CameraError::Unavailable(format!("{}: no PNG or JPEG images", dir.display())))?;
        let img = rig::image::read_image(first)?;
        Ok(FolderCamera { size: (img.width, img.height), files, next: 0 })
    }

    /// Skips the first `n` images (a resumed session replays from where it stopped).
    pub fn skip(&mut self, n: usize) {
        self.next += n;
    }
}

impl Camera for FolderCamera {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn capture(&mut self, shot: &Shot) -> Result<Image8, CameraError> {
        let path = self.files.get(self.next).ok_or_else(|| {
            CameraError::Frame(format!("the replay folder ran out of images after {}", self.files.len()))
        })?;
        self.next += 1;
        // Pattern frames are decoded as grey; the texture shot is the view's colour.
        let img = rig::image::read_image(path)?;
        let img = if shot.pattern == rig::Pattern::Texture { img } else { img.to_gray() };
        if (img.width, img.height) != self.size {
            return Err(CameraError::Frame(format!(
                "{} is {}x{}, the replay's first image {}x{}",
                path.display(),
                img.width,
                img.height,
                self.size.0,
                self.size.1
            )));
        }
        Ok(img)
    }
}

/// A projector's output: shows one pattern at a time, or nothing.
pub trait PatternOutput {
    /// Shows `pattern` (None: dark) and returns once it is on screen.
    fn show(&mut self, pattern: Option<Pattern>) -> Result<(), CameraError>;
}

/// No projector (a laser rig, or one driven by another program).
pub struct NoProjector;

impl PatternOutput for NoProjector {
    fn show(&mut self, _pattern: Option<Pattern>) -> Result<(), CameraError> {
        Ok(())
    }
}
