//! The PLY body: ASCII tokens or binary values, into one [`Column`] per property.

use super::header::{ElementDef, Encoding, Header, PropertyKind, ScalarType};
use super::{Column, Element};
use crate::error::{Location, ParseError, Problem};

/// Reads every element the header declares.
pub(crate) fn parse_body(header: &Header, body: &[u8], first_line: usize) -> Result<Vec<Element>, ParseError> {
    let mut src = Source { bytes: body, pos: 0, line: first_line, encoding: header.encoding };
    let mut elements = Vec::with_capacity(header.elements.len());
    for def in &header.elements {
        elements.push(read_element(&mut src, def)?);
    }
    if header.encoding == Encoding::Ascii
        && let Some(tok) = src.next_token()
    {
        let at = Location::Line(src.line);
        return Err(ParseError::new(
            at,
            Problem::TrailingData(String::from_utf8_lossy(tok).chars().take(40).collect()),
        ));
    }
    Ok(elements)
}

struct Source<'a> {
    bytes: &'a [u8],
    pos: usize,
    line: usize,
    encoding: Encoding,
}

impl<'a> Source<'a> {
    fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    /// The fewest bytes a value of this type takes: its size in binary; a digit and a separator in ASCII.
    fn min_bytes(&self, t: ScalarType) -> u64 {
        match self.encoding {
            Encoding::Ascii => 2,
            _ => t.size() as u64,
        }
    }

    fn next_token(&mut self) -> Option<&'a [u8]> {
        while let Some(&b) = self.bytes.get(self.pos) {
            if !b.is_ascii_whitespace() {
                break;
            }
            if b == b'\n' {
                self.line += 1;
            }
            self.pos += 1;
        }
        let start = self.pos;
        while self.bytes.get(self.pos).is_some_and(|b| !b.is_ascii_whitespace()) {
            self.pos += 1;
        }
        (self.pos > start).then(|| &self.bytes[start..self.pos])
    }

    /// Reads one value of type `t`; `Err(problem)` for the caller to locate.
    fn value(&mut self, t: ScalarType) -> Result<f64, Problem> {
        match self.encoding {
            Encoding::Ascii => {
                let tok = self.next_token().ok_or_else(|| Problem::Truncated("this value".into()))?;
                let s = std::str::from_utf8(tok).map_err(|_| Problem::NotANumber(lossy(tok)))?;
                let v: f64 = if t.is_integer() {
                    // Integers must be whole numbers in range; a few writers put `3.0` for a count.
                    match s.parse::<i64>() {
                        Ok(i) => i as f64,
                        Err(_) => s
                            .parse::<f64>()
                            .ok()
                            .filter(|f| f.fract() == 0.0)
                            .ok_or_else(|| Problem::NotANumber(lossy(tok)))?,
                    }
                } else if t == ScalarType::F32 {
                    // Parse as f32 so the value is the one a binary file of this type would hold.
                    s.parse::<f32>().map_err(|_| Problem::NotANumber(lossy(tok)))? as f64
                } else {
                    s.parse::<f64>().map_err(|_| Problem::NotANumber(lossy(tok)))?
                };
                let (lo, hi) = t.int_range();
                if t.is_integer() && !(lo..=hi).contains(&v) {
                    return Err(Problem::OutOfRange { value: s.to_string(), ty: t.name() });
                }
                Ok(v)
            }
            enc => {
                let n = t.size();
                let b =
                    self.bytes.get(self.pos..self.pos + n).ok_or_else(|| Problem::Truncated("this value".into()))?;
                self.pos += n;
                let mut buf = [0u8; 8];
                buf[..n].copy_from_slice(b);
                if enc == Encoding::BinaryBigEndian {
                    buf[..n].reverse();
                }
                Ok(match t {
                    ScalarType::I8 => buf[0] as i8 as f64,
                    ScalarType::U8 => buf[0] as f64,
                    ScalarType::I16 => i16::from_le_bytes([buf[0], buf[1]]) as f64,
                    ScalarType::U16 => u16::from_le_bytes([buf[0], buf[1]]) as f64,
                    ScalarType::I32 => i32::from_le_bytes(buf[..4].try_into().unwrap()) as f64,
                    ScalarType::U32 => u32::from_le_bytes(buf[..4].try_into().unwrap()) as f64,
                    ScalarType::F32 => f32::from_le_bytes(buf[..4].try_into().unwrap()) as f64,
                    ScalarType::F64 => f64::from_le_bytes(buf),
                })
            }
        }
    }
}

fn lossy(tok: &[u8]) -> String {
    String::from_utf8_lossy(tok).chars().take(40).collect()
}

fn read_element(src: &mut Source<'_>, def: &ElementDef) -> Result<Element, ParseError> {
    let at = |index: u64, line: Option<usize>| Location::Element { name: def.name.clone(), index, line };
    // Refuse counts the rest of the file cannot hold before allocating for them.
    let min_entry: u64 = def
        .properties
        .iter()
        .map(|p| match p.kind {
            PropertyKind::Scalar(t) => src.min_bytes(t),
            PropertyKind::List { count, .. } => src.min_bytes(count),
        })
        .sum();
    let available = src.remaining() as u64;
    // The last ASCII entry may end the file without a separator.
    let slack = u64::from(src.encoding == Encoding::Ascii);
    if min_entry > 0 && def.count.checked_mul(min_entry).is_none_or(|need| need > available + slack) {
        let problem = Problem::CountTooLarge { count: def.count, min_bytes: min_entry, available };
        return Err(ParseError::new(at(0, None), problem));
    }
    let count = if min_entry == 0 { 0 } else { def.count as usize };
    let mut columns: Vec<Column> = def
        .properties
        .iter()
        .map(|p| match p.kind {
            PropertyKind::Scalar(_) => Column::Scalar(Vec::with_capacity(count)),
            PropertyKind::List { .. } => {
                let mut offsets = Vec::with_capacity(count + 1);
                offsets.push(0);
                Column::List { offsets, values: Vec::new() }
            }
        })
        .collect();
    let ascii = src.encoding == Encoding::Ascii;
    for index in 0..count as u64 {
        let line = ascii.then_some(src.line);
        for (prop, col) in def.properties.iter().zip(columns.iter_mut()) {
            let locate = |p: Problem, src: &Source<'_>| {
                let line = if ascii { Some(src.line) } else { line };
                ParseError::new(at(index, line), p)
            };
            match (prop.kind, col) {
                (PropertyKind::Scalar(t), Column::Scalar(v)) => v.push(src.value(t).map_err(|p| locate(p, src))?),
                (PropertyKind::List { count: ct, item }, Column::List { offsets, values }) => {
                    let n = src.value(ct).map_err(|p| locate(p, src))?;
                    if n < 0.0 {
                        return Err(locate(
                            Problem::Invalid(format!("list `{}` has negative length {n}", prop.name)),
                            src,
                        ));
                    }
                    let n = n as u64;
                    let need = n.saturating_mul(src.min_bytes(item));
                    if need > src.remaining() as u64 + slack {
                        let what = format!(
                            "the {n} items of list `{}` (at least {need} bytes; {} remain)",
                            prop.name,
                            src.remaining()
                        );
                        return Err(locate(Problem::Truncated(what), src));
                    }
                    for _ in 0..n {
                        values.push(src.value(item).map_err(|p| locate(p, src))?);
                    }
                    offsets.push(values.len());
                }
                _ => unreachable!("columns are built from the same property kinds"),
            }
        }
    }
    Ok(Element { def: def.clone(), columns })
}
