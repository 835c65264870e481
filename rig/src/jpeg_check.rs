//! A check of a baseline JPEG's entropy-coded data, as libjpeg makes it while decoding (OpenCV's
//! "Corrupt JPEG data: N extraneous bytes before marker", "premature end of data segment"): every scan's
//! Huffman codes are walked, block by block, and must be valid codes, describe exactly the blocks the
//! frame header promises, and end where the scan's data end. The decoder used (`zune-jpeg`) renders a
//! damaged image without a word; this says it is damaged.
//!
//! Only sequential Huffman JPEGs (SOF0, SOF1) are walked: what cameras stream. Progressive and other
//! frames are left to the decoder.

/// A canonical Huffman table: the codes of each length and the symbols they stand for.
#[derive(Clone, Default)]
struct Huffman {
    /// For each length 1–16: the first code, the number of codes, the index of its first symbol.
    first: [(u32, u32, usize); 17],
    symbols: Vec<u8>,
}

impl Huffman {
    fn new(counts: &[u8; 16], symbols: Vec<u8>) -> Huffman {
        let mut first = [(0u32, 0u32, 0usize); 17];
        let (mut code, mut index) = (0u32, 0usize);
        for len in 1..=16 {
            let n = counts[len - 1] as u32;
            first[len] = (code, n, index);
            code = (code + n) << 1;
            index += n as usize;
        }
        Huffman { first, symbols }
    }
}

/// The entropy-coded bytes of one scan, read bit by bit (stuffed zeros removed, restart markers
/// stopping the bits until [`Bits::restart`]).
struct Bits<'a> {
    data: &'a [u8],
    pos: usize,
    byte: u8,
    left: u8,
    /// A marker (other than a stuffed zero) was reached: no more bits in this interval.
    at_marker: bool,
}

impl Bits<'_> {
    fn bit(&mut self) -> Result<u32, String> {
        if self.left == 0 {
            if self.at_marker || self.pos >= self.data.len() {
                return Err("its data end before the blocks the frame promises (premature end of data)".into());
            }
            let b = self.data[self.pos];
            if b == 0xFF {
                match self.data.get(self.pos + 1) {
                    Some(0x00) => self.pos += 2,
                    _ => {
                        self.at_marker = true;
                        return Err("its data end before the blocks the frame promises (premature end of data)".into());
                    }
                }
            } else {
                self.pos += 1;
            }
            self.byte = b;
            self.left = 8;
        }
        self.left -= 1;
        Ok(((self.byte >> self.left) & 1) as u32)
    }

    fn skip(&mut self, n: u32) -> Result<(), String> {
        for _ in 0..n {
            self.bit()?;
        }
        Ok(())
    }

    fn decode(&mut self, h: &Huffman) -> Result<u8, String> {
        let mut code = 0u32;
        for len in 1..=16 {
            code = (code << 1) | self.bit()?;
            let (first, n, index) = h.first[len];
            if code >= first && code < first + n {
                return h
                    .symbols
                    .get(index + (code - first) as usize)
                    .copied()
                    .ok_or_else(|| "a bad Huffman table".into());
            }
        }
        Err(format!("an invalid Huffman code at byte {}", self.pos))
    }

    /// Whole bytes left before the next marker: an encoder pads only the last byte's bits.
    fn extraneous(&self) -> usize {
        let mut n = 0;
        let mut p = self.pos;
        while p < self.data.len() {
            if self.data[p] == 0xFF {
                match self.data.get(p + 1) {
                    Some(0x00) => p += 2,
                    // Fill bytes before a marker are allowed.
                    Some(0xFF) => {
                        p += 1;
                        continue;
                    }
                    _ => break,
                }
            } else {
                p += 1;
            }
            n += 1;
        }
        n
    }

    /// Past the restart marker that must come next, with the bits reset.
    fn restart(&mut self) -> Result<(), String> {
        let n = self.extraneous();
        if n > 0 {
            return Err(format!("{n} extraneous bytes before a restart marker"));
        }
        while self.data.get(self.pos) == Some(&0xFF) && self.data.get(self.pos + 1) == Some(&0xFF) {
            self.pos += 1;
        }
        match (self.data.get(self.pos), self.data.get(self.pos + 1)) {
            (Some(0xFF), Some(0xD0..=0xD7)) => self.pos += 2,
            _ => return Err(format!("a restart marker missing at byte {}", self.pos)),
        }
        self.left = 0;
        self.at_marker = false;
        Ok(())
    }
}

struct Component {
    id: u8,
    h: u32,
    v: u32,
}

/// Checks a JPEG's entropy-coded data (see the module doc); `Err` says what is wrong. Files that are
/// not sequential Huffman JPEGs, or whose headers the walk does not follow, pass: the decoder judges them.
pub(crate) fn check(bytes: &[u8]) -> Result<(), String> {
    let mut dc: [Option<Huffman>; 4] = Default::default();
    let mut ac: [Option<Huffman>; 4] = Default::default();
    let mut frame: Option<(u32, u32, Vec<Component>)> = None;
    let mut restart_interval = 0u32;
    let mut pos = 2usize;
    let mut scan_no = 0;
    if bytes.get(..2) != Some(&[0xFF, 0xD8]) {
        return Ok(());
    }
    while pos + 4 <= bytes.len() {
        if bytes[pos] != 0xFF {
            return Ok(());
        }
        let marker = bytes[pos + 1];
        if marker == 0xFF {
            pos += 1;
            continue;
        }
        if marker == 0xD9 {
            return Ok(());
        }
        let len = u16::from_be_bytes([bytes[pos + 2], bytes[pos + 3]]) as usize;
        let Some(seg) = bytes.get(pos + 4..pos + 2 + len) else { return Ok(()) };
        pos += 2 + len;
        match marker {
            0xC0 | 0xC1 => {
                if seg.len() < 6 {
                    return Ok(());
                }
                let h = u16::from_be_bytes([seg[1], seg[2]]) as u32;
                let w = u16::from_be_bytes([seg[3], seg[4]]) as u32;
                let n = seg[5] as usize;
                let comps: Option<Vec<Component>> = (0..n)
                    .map(|i| {
                        let c = seg.get(6 + 3 * i..9 + 3 * i)?;
                        Some(Component { id: c[0], h: (c[1] >> 4).max(1) as u32, v: (c[1] & 15).max(1) as u32 })
                    })
                    .collect();
                match comps {
                    Some(c) if w > 0 && h > 0 => frame = Some((w, h, c)),
                    _ => return Ok(()),
                }
            }
            // Progressive, lossless, arithmetic-coded frames: left to the decoder.
            0xC2 | 0xC3 | 0xC5..=0xC7 | 0xC9..=0xCB | 0xCD..=0xCF => return Ok(()),
            0xC4 => {
                let mut s = seg;
                while s.len() >= 17 {
                    let (class, slot) = (s[0] >> 4, (s[0] & 15) as usize);
                    let counts: [u8; 16] = s[1..17].try_into().unwrap_or([0; 16]);
                    let total: usize = counts.iter().map(|&c| c as usize).sum();
                    let Some(symbols) = s.get(17..17 + total) else { return Ok(()) };
                    if slot > 3 {
                        return Ok(());
                    }
                    let table = Some(Huffman::new(&counts, symbols.to_vec()));
                    if class == 0 {
                        dc[slot] = table
                    } else {
                        ac[slot] = table
                    }
                    s = &s[17 + total..];
                }
            }
            0xDD if seg.len() >= 2 => restart_interval = u16::from_be_bytes([seg[0], seg[1]]) as u32,
            0xDA => {
                scan_no += 1;
                let Some((w, h, comps)) = &frame else { return Ok(()) };
                let n = *seg.first().unwrap_or(&0) as usize;
                let mut scan: Vec<(&Component, &Huffman, &Huffman)> = Vec::new();
                for i in 0..n {
                    let Some(s) = seg.get(1 + 2 * i..3 + 2 * i) else { return Ok(()) };
                    let Some(c) = comps.iter().find(|c| c.id == s[0]) else { return Ok(()) };
                    let (Some(Some(d)), Some(Some(a))) = (dc.get((s[1] >> 4) as usize), ac.get((s[1] & 15) as usize))
                    else {
                        return Ok(());
                    };
                    scan.push((c, d, a));
                }
                // The entropy-coded data run to the next marker that is not a stuffed zero or a restart.
                let start = pos;
                let mut end = start;
                while end + 1 < bytes.len() {
                    if bytes[end] == 0xFF && !matches!(bytes[end + 1], 0x00 | 0xD0..=0xD7 | 0xFF) {
                        break;
                    }
                    end += 1;
                }
                let end = if end + 1 >= bytes.len() { bytes.len() } else { end };
                let hmax = comps.iter().map(|c| c.h).max().unwrap_or(1);
                let vmax = comps.iter().map(|c| c.v).max().unwrap_or(1);
                // Blocks per MCU of each scan component, and the MCUs.
                let (units, mcus): (Vec<u32>, u64) = if scan.len() == 1 {
                    let c = scan[0].0;
                    let bw = (*w * c.h).div_ceil(8 * hmax);
                    let bh = (*h * c.v).div_ceil(8 * vmax);
                    (vec![1], bw as u64 * bh as u64)
                } else {
                    let mw = w.div_ceil(8 * hmax);
                    let mh = h.div_ceil(8 * vmax);
                    (scan.iter().map(|(c, _, _)| c.h * c.v).collect(), mw as u64 * mh as u64)
                };
                let mut bits = Bits { data: &bytes[start..end], pos: 0, byte: 0, left: 0, at_marker: false };
                let what = |e: String| format!("scan {scan_no}: {e}");
                for m in 0..mcus {
                    if restart_interval > 0 && m > 0 && m % restart_interval as u64 == 0 {
                        bits.restart().map_err(what)?;
                    }
                    for ((_, d, a), &u) in scan.iter().zip(&units) {
                        for _ in 0..u {
                            let s = bits.decode(d).map_err(what)?;
                            if s > 11 {
                                return Err(what(format!("a DC difference of {s} bits")));
                            }
                            bits.skip(s as u32).map_err(what)?;
                            let mut k = 1;
                            while k < 64 {
                                let rs = bits.decode(a).map_err(what)?;
                                let (r, s) = ((rs >> 4) as usize, (rs & 15) as u32);
                                if s == 0 {
                                    if r == 15 {
                                        k += 16;
                                        continue;
                                    }
                                    break;
                                }
                                k += r;
                                bits.skip(s).map_err(what)?;
                                k += 1;
                            }
                            if k > 64 {
                                return Err(what("a block with more than 64 coefficients".into()));
                            }
                        }
                    }
                }
                let extra = bits.extraneous();
                if extra > 0 {
                    return Err(what(format!("{extra} extraneous bytes after the last block, before the next marker")));
                }
                pos = end;
            }
            _ => {}
        }
    }
    Ok(())
}
