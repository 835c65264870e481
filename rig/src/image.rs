//! 8-bit images and PNG files: what cameras capture and the simulator writes.
//!
//! Frames are grey (1 channel) or RGB (3 channels), row-major, row 0 at the top. Reading accepts any
//! PNG (grey, grey+alpha, RGB, RGBA, palette, 1–16 bits) and converts it; `to_gray` gives luminance.

use crate::error::{Error, Location, ParseError, Problem};
use crate::run_files::{read_bytes, write_atomic};
use std::path::Path;

/// How a camera's frames are turned before its calibration applies, in this order: transposed (a
/// camera mounted on its side), mirrored left–right, mirrored top–bottom. FabScanPi's `rotate`,
/// `hflip`, `vflip` and Horus' `camera_rotate`, `camera_hflip`, `camera_vflip` mean exactly this.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImageTransform {
    /// Rows become columns.
    #[serde(default)]
    pub transpose: bool,
    /// Then mirrored left–right.
    #[serde(default)]
    pub hflip: bool,
    /// Then mirrored top–bottom.
    #[serde(default)]
    pub vflip: bool,
}

impl ImageTransform {
    /// True when frames are used as captured.
    pub fn is_identity(&self) -> bool {
        *self == ImageTransform::default()
    }

    /// The size of a `width × height` frame after the transform.
    pub fn size(&self, width: u32, height: u32) -> (u32, u32) {
        if self.transpose { (height, width) } else { (width, height) }
    }
}

/// An 8-bit image.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Image8 {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// 1 (grey) or 3 (RGB).
    pub channels: u8,
    /// `width · height · channels` bytes, row-major, channels interleaved.
    pub data: Vec<u8>,
}

impl Image8 {
    /// A grey image from its bytes.
    pub fn gray(width: u32, height: u32, data: Vec<u8>) -> Self {
        debug_assert_eq!(data.len(), width as usize * height as usize);
        Image8 { width, height, channels: 1, data }
    }

    /// The image transposed (row r, column c → row c, column r): a camera mounted on its side.
    // Compiled in its callers at their opt-level (see `convolve_clamped`).
    #[inline]
    pub fn transposed(&self) -> Image8 {
        let (w, h, ch) = (self.width as usize, self.height as usize, self.channels as usize);
        let mut data = vec![0u8; self.data.len()];
        for y in 0..h {
            for x in 0..w {
                let (src, dst) = ((y * w + x) * ch, (x * h + y) * ch);
                data[dst..dst + ch].copy_from_slice(&self.data[src..src + ch]);
            }
        }
        Image8 { width: self.height, height: self.width, channels: self.channels, data }
    }

    /// The image mirrored left to right.
    // Compiled in its callers at their opt-level (see `convolve_clamped`).
    #[inline]
    pub fn mirrored(&self) -> Image8 {
        let mut out = self.clone();
        out.mirror_rows();
        out
    }

    /// Mirrors the image left to right where it lies (`transformed` turns its own copy): each row
    /// reversed, then each pixel's channels put back in order. A swap per byte had been 6 % of
    /// calibrating FabScanPi's mirrored sweep.
    #[inline]
    fn mirror_rows(&mut self) {
        let (w, ch) = (self.width as usize, self.channels as usize);
        if w == 0 || ch == 0 {
            return;
        }
        for row in self.data.chunks_exact_mut(w * ch) {
            row.reverse();
            if ch > 1 {
                row.chunks_exact_mut(ch).for_each(|px| px.reverse());
            }
        }
    }

    /// The image mirrored top to bottom.
    // Compiled in its callers at their opt-level (see `convolve_clamped`).
    #[inline]
    pub fn flipped(&self) -> Image8 {
        let row = self.width as usize * self.channels as usize;
        let data = self.data.chunks_exact(row.max(1)).rev().flatten().copied().collect();
        Image8 { width: self.width, height: self.height, channels: self.channels, data }
    }

    /// The image as `t` turns it: transposed first, then mirrored left–right, then top–bottom.
    // Compiled in its callers at their opt-level (see `convolve_clamped`).
    #[inline]
    pub fn transformed(&self, t: &ImageTransform) -> Image8 {
        let mut out = if t.transpose { self.transposed() } else { self.clone() };
        if t.hflip {
            out.mirror_rows();
        }
        if t.vflip {
            out = out.flipped();
        }
        out
    }

    /// The frame a camera mounted as `t` says captured, given the turned one: `t` undone, in reverse order.
    // Compiled in its callers at their opt-level (see `convolve_clamped`).
    #[inline]
    pub fn untransformed(&self, t: &ImageTransform) -> Image8 {
        let mut out = if t.vflip { self.flipped() } else { self.clone() };
        if t.hflip {
            out.mirror_rows();
        }
        if t.transpose { out.transposed() } else { out }
    }

    /// Grey by Rec. 601 luma (what OpenCV's `cvtColor(…, COLOR_RGB2GRAY)` computes).
    pub fn to_gray(&self) -> Image8 {
        if self.channels == 1 {
            return self.clone();
        }
        let data = self
            .data
            .chunks_exact(self.channels as usize)
            .map(|p| (0.299 * p[0] as f64 + 0.587 * p[1] as f64 + 0.114 * p[2] as f64).round() as u8)
            .collect();
        Image8 { width: self.width, height: self.height, channels: 1, data }
    }

    /// The value at (col, row), channel 0.
    pub fn at(&self, col: u32, row: u32) -> u8 {
        self.data[(row as usize * self.width as usize + col as usize) * self.channels as usize]
    }
}

/// PNG bytes of an image. `fast` trades file size for speed (the simulator writes thousands of frames).
pub fn png_bytes(img: &Image8, fast: bool) -> Vec<u8> {
    let mut out = Vec::with_capacity(img.data.len() / 2 + 1024);
    {
        let mut enc = png::Encoder::new(&mut out, img.width, img.height);
        enc.set_color(if img.channels == 3 { png::ColorType::Rgb } else { png::ColorType::Grayscale });
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(if fast { png::Compression::Fast } else { png::Compression::Balanced });
        let mut w = enc.write_header().expect("writing to memory cannot fail");
        w.write_image_data(&img.data).expect("the buffer matches the header");
    }
    out
}

/// Writes a PNG atomically.
pub fn write_png(path: &Path, img: &Image8, fast: bool) -> Result<(), Error> {
    write_atomic(path, &png_bytes(img, fast))
}

/// Decodes PNG bytes to 8 bits per channel; alpha is dropped, palettes expanded, 16-bit scaled.
pub fn decode_png(bytes: &[u8]) -> Result<Image8, ParseError> {
    let bad = |m: String| ParseError::new(Location::File, Problem::Invalid(m));
    let mut dec = png::Decoder::new(std::io::Cursor::new(bytes));
    dec.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut reader = dec.read_info().map_err(|e| bad(format!("not a readable PNG: {e}")))?;
    let (w, h) = (reader.info().width, reader.info().height);
    // A header may claim any size: refuse what cannot be real before allocating for it.
    if (w as u64) * (h as u64) > 1 << 28 {
        return Err(bad(format!("a {w}×{h} image is larger than any camera frame")));
    }
    let size = reader.output_buffer_size().ok_or_else(|| bad("the image size overflows".into()))?;
    let mut buf = vec![0u8; size];
    let info = reader.next_frame(&mut buf).map_err(|e| bad(format!("corrupt PNG data: {e}")))?;
    buf.truncate(info.buffer_size());
    let (channels, keep): (u8, usize) = match info.color_type {
        png::ColorType::Grayscale => (1, 1),
        png::ColorType::GrayscaleAlpha => (1, 2),
        png::ColorType::Rgb => (3, 3),
        png::ColorType::Rgba => (3, 4),
        png::ColorType::Indexed => return Err(bad("palette PNG was not expanded".into())),
    };
    let data = if keep == channels as usize {
        buf
    } else {
        buf.chunks_exact(keep).flat_map(|p| p[..channels as usize].to_vec()).collect()
    };
    Ok(Image8 { width: w, height: h, channels, data })
}

/// Reads a PNG file.
pub fn read_png(path: &Path) -> Result<Image8, Error> {
    decode_png(&read_bytes(path)?).map_err(|e| e.with_path(path))
}

/// Decodes baseline or progressive JPEG bytes: RGB for colour JPEGs (the camera streams of Raspberry
/// Pi and webcam scanners; a red laser is told from white light by its colour), grey for grey ones.
pub fn decode_jpeg(bytes: &[u8]) -> Result<Image8, ParseError> {
    use zune_core::bytestream::ZCursor;
    use zune_core::colorspace::ColorSpace;
    use zune_core::options::DecoderOptions;
    let bad = |m: String| ParseError::new(Location::File, Problem::Invalid(m));
    // A file cut short (a copy that stopped, a camera that lost power) decodes "successfully" with its
    // missing rows grey: the image must end with an end-of-image marker after its last scan. (An EXIF
    // thumbnail brings its own markers, but before the main image's scan.) Entropy-coded data never
    // holds FF D9, so the search cannot be fooled by the pixels.
    let last_scan = bytes.windows(2).rposition(|w| w == [0xFF, 0xDA]);
    let end = bytes.windows(2).rposition(|w| w == [0xFF, 0xD9]);
    if let Some(scan) = last_scan
        && end.is_none_or(|e| e <= scan)
    {
        return Err(bad("the JPEG is truncated: its data stops before the end-of-image marker".into()));
    }
    let options = DecoderOptions::default().set_strict_mode(true);
    let mut dec = zune_jpeg::JpegDecoder::new_with_options(ZCursor::new(bytes), options);
    dec.decode_headers().map_err(|e| bad(format!("not a readable JPEG: {e:?}")))?;
    let info = dec.info().ok_or_else(|| bad("a JPEG without a frame header".into()))?;
    let (w, h) = (info.width as u32, info.height as u32);
    let grey = info.components == 1;
    let (out, channels) = if grey { (ColorSpace::Luma, 1u8) } else { (ColorSpace::RGB, 3u8) };
    dec.set_options(options.jpeg_set_out_colorspace(out));
    let data = dec.decode().map_err(|e| bad(format!("corrupt JPEG data: {e:?}")))?;
    if data.len() != (w as usize) * (h as usize) * channels as usize {
        return Err(bad(format!("{} values for a {w}×{h} image of {channels} channels", data.len())));
    }
    // The decoder renders damaged data without a word; a walk of the codes, as libjpeg's, says so.
    crate::jpeg_check::check(bytes).map_err(|e| bad(format!("corrupt JPEG data: {e}")))?;
    Ok(Image8 { width: w, height: h, channels, data })
}

/// JPEG bytes of an image at `quality` (1–100): what a webcam or Raspberry Pi camera streams, for the
/// simulator's realistic frames.
pub fn jpeg_bytes(img: &Image8, quality: u8) -> Vec<u8> {
    let mut out = Vec::with_capacity(img.data.len() / 8 + 1024);
    let colour = if img.channels == 3 { jpeg_encoder::ColorType::Rgb } else { jpeg_encoder::ColorType::Luma };
    let enc = jpeg_encoder::Encoder::new(&mut out, quality.clamp(1, 100));
    // The sizes are a camera's (checked far below 65535) and the buffer matches them: encoding into
    // memory cannot fail otherwise.
    enc.encode(&img.data, img.width as u16, img.height as u16, colour).expect("an image of a camera's size encodes");
    out
}

/// Whether [`read_image`] reads `path` by its extension (PNG or JPEG, any case).
pub fn is_image_file(path: &Path) -> bool {
    path.extension().is_some_and(|e| ["png", "jpg", "jpeg"].iter().any(|x| e.eq_ignore_ascii_case(x)))
}

/// Reads a camera frame by its extension: PNG or JPEG (`.jpg`, `.jpeg`), colour kept.
pub fn read_image(path: &Path) -> Result<Image8, Error> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    match ext.as_str() {
        "jpg" | "jpeg" => decode_jpeg(&read_bytes(path)?).map_err(|e| e.with_path(path)),
        _ => read_png(path),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transposing_and_mirroring_move_pixels_where_they_should() {
        let g = Image8::gray(3, 2, vec![1, 2, 3, 4, 5, 6]);
        assert_eq!(g.transposed(), Image8::gray(2, 3, vec![1, 4, 2, 5, 3, 6]));
        assert_eq!(g.mirrored(), Image8::gray(3, 2, vec![3, 2, 1, 6, 5, 4]));
        assert_eq!(g.transposed().transposed(), g);
        // Colour: whole pixels move, their channels in order.
        let rgb = Image8 { width: 3, height: 1, channels: 3, data: vec![1, 2, 3, 4, 5, 6, 7, 8, 9] };
        assert_eq!(rgb.mirrored().data, vec![7, 8, 9, 4, 5, 6, 1, 2, 3]);
        assert_eq!(rgb.mirrored().mirrored(), rgb);
    }

    #[test]
    fn png_round_trip_grey_and_rgb() {
        let g = Image8::gray(7, 3, (0..21).map(|i| (i * 12) as u8).collect());
        assert_eq!(decode_png(&png_bytes(&g, true)).unwrap(), g);
        let rgb = Image8 { width: 2, height: 2, channels: 3, data: (0..12).map(|i| (i * 20) as u8).collect() };
        assert_eq!(decode_png(&png_bytes(&rgb, false)).unwrap(), rgb);
        assert_eq!(rgb.to_gray().data.len(), 4);
    }

    /// A JPEG with bytes flipped in its entropy-coded data is refused, naming the corruption (OpenCV's
    /// "Corrupt JPEG data"), for every seed tried.
    #[test]
    fn a_jpeg_with_flipped_bytes_is_refused() {
        let (w, h) = (320u32, 240u32);
        let data = (0..w * h).flat_map(|i| {
            let (x, y) = (i % w, i / w);
            [(x * 255 / w) as u8, (y * 255 / h) as u8, ((x ^ y) & 0xff) as u8]
        });
        let img = Image8 { width: w, height: h, channels: 3, data: data.collect() };
        let good = jpeg_bytes(&img, 90);
        assert!(decode_jpeg(&good).is_ok());
        let scan = good.windows(2).rposition(|x| x == [0xFF, 0xDA]).unwrap() + 20;
        let end = good.len() - 2;
        let mut silent = 0;
        for seed in 0..40u64 {
            let mut bad = good.clone();
            let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            for _ in 0..30 {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                let at = scan + (state >> 33) as usize % (end - scan);
                bad[at] ^= 0xFF;
            }
            if decode_jpeg(&bad).is_ok() {
                silent += 1;
            }
        }
        assert_eq!(silent, 0, "corrupt JPEGs decoded without a word");
    }

    #[test]
    fn jpeg_keeps_colour_and_grey_close() {
        let rgb = Image8 {
            width: 16,
            height: 8,
            channels: 3,
            data: (0..16 * 8).flat_map(|i| [200u8, (i % 16 * 4) as u8, 30]).collect(),
        };
        let back = decode_jpeg(&jpeg_bytes(&rgb, 95)).unwrap();
        assert_eq!((back.width, back.height, back.channels), (16, 8, 3));
        let worst = rgb.data.iter().zip(&back.data).map(|(a, b)| a.abs_diff(*b)).max().unwrap();
        assert!(worst <= 12, "{worst}");
        let grey = rgb.to_gray();
        assert_eq!(decode_jpeg(&jpeg_bytes(&grey, 95)).unwrap().channels, 1);
    }
}
