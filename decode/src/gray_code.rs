//! Gray-code decoding with inverse patterns: each bit is whether the pattern frame is brighter than its
//! inverse at that pixel — robust to albedo, ambient light and projector response, since both frames
//! of a pair see the same surface.

use rig::patterns::gray_inverse;

/// Decodes one pixel of one axis from its (pattern, inverse) grey levels, most significant bit first:
/// the projector index (column or row) and the weakest bit's |pattern − inverse|, which says how close
/// to undecidable the pixel was.
///
/// ```
/// // Column 5 = Gray 0b111 on 3 bits: every pattern frame brighter than its inverse.
/// let (index, weakest) = decode::gray_code::decode_pixel([(200, 20), (180, 30), (90, 60)].into_iter());
/// assert_eq!((index, weakest), (5, 30));
/// ```
pub fn decode_pixel(pairs: impl Iterator<Item = (u8, u8)>) -> (u32, u8) {
    let mut code = 0u32;
    let mut weakest = u8::MAX;
    for (a, b) in pairs {
        code = (code << 1) | u32::from(a > b);
        weakest = weakest.min(a.abs_diff(b));
    }
    (gray_inverse(code), weakest)
}
