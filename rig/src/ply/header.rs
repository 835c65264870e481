//! The PLY header: format, comments, `obj_info`, and element and property definitions.

use crate::error::{Location, ParseError, Problem};

/// How the body is encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// Whitespace-separated text.
    Ascii,
    /// Binary, least significant byte first.
    BinaryLittleEndian,
    /// Binary, most significant byte first.
    BinaryBigEndian,
}

impl Encoding {
    /// The name used on the `format` line.
    pub fn name(self) -> &'static str {
        match self {
            Encoding::Ascii => "ascii",
            Encoding::BinaryLittleEndian => "binary_little_endian",
            Encoding::BinaryBigEndian => "binary_big_endian",
        }
    }
}

/// A PLY scalar type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScalarType {
    /// `char` / `int8`.
    I8,
    /// `uchar` / `uint8`.
    U8,
    /// `short` / `int16`.
    I16,
    /// `ushort` / `uint16`.
    U16,
    /// `int` / `int32`.
    I32,
    /// `uint` / `uint32`.
    U32,
    /// `float` / `float32`.
    F32,
    /// `double` / `float64`.
    F64,
}

impl ScalarType {
    /// Parses a type name, either spelling.
    pub fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "char" | "int8" => ScalarType::I8,
            "uchar" | "uint8" => ScalarType::U8,
            "short" | "int16" => ScalarType::I16,
            "ushort" | "uint16" => ScalarType::U16,
            "int" | "int32" => ScalarType::I32,
            "uint" | "uint32" => ScalarType::U32,
            "float" | "float32" => ScalarType::F32,
            "double" | "float64" => ScalarType::F64,
            _ => return None,
        })
    }

    /// The classic name, as written by the writer.
    pub fn name(self) -> &'static str {
        match self {
            ScalarType::I8 => "char",
            ScalarType::U8 => "uchar",
            ScalarType::I16 => "short",
            ScalarType::U16 => "ushort",
            ScalarType::I32 => "int",
            ScalarType::U32 => "uint",
            ScalarType::F32 => "float",
            ScalarType::F64 => "double",
        }
    }

    /// Size in bytes.
    pub fn size(self) -> usize {
        match self {
            ScalarType::I8 | ScalarType::U8 => 1,
            ScalarType::I16 | ScalarType::U16 => 2,
            ScalarType::I32 | ScalarType::U32 | ScalarType::F32 => 4,
            ScalarType::F64 => 8,
        }
    }

    /// True for the integer types.
    pub fn is_integer(self) -> bool {
        !matches!(self, ScalarType::F32 | ScalarType::F64)
    }

    /// The range of an integer type.
    pub(crate) fn int_range(self) -> (f64, f64) {
        match self {
            ScalarType::I8 => (i8::MIN as f64, i8::MAX as f64),
            ScalarType::U8 => (0.0, u8::MAX as f64),
            ScalarType::I16 => (i16::MIN as f64, i16::MAX as f64),
            ScalarType::U16 => (0.0, u16::MAX as f64),
            ScalarType::I32 => (i32::MIN as f64, i32::MAX as f64),
            ScalarType::U32 => (0.0, u32::MAX as f64),
            ScalarType::F32 | ScalarType::F64 => (f64::NEG_INFINITY, f64::INFINITY),
        }
    }
}

/// A property: a scalar, or a list with a count type and an item type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PropertyKind {
    /// One value.
    Scalar(ScalarType),
    /// A count, then that many items.
    List {
        /// The count's type (an integer type).
        count: ScalarType,
        /// The items' type.
        item: ScalarType,
    },
}

/// A named property of an element.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PropertyDef {
    /// The property's name.
    pub name: String,
    /// Its type.
    pub kind: PropertyKind,
}

/// An element's name, count and properties.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ElementDef {
    /// The element's name (`vertex`, `face`, …).
    pub name: String,
    /// How many entries the header declares.
    pub count: u64,
    /// Its properties in order.
    pub properties: Vec<PropertyDef>,
}

/// A parsed PLY header.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Header {
    /// The body encoding.
    pub encoding: Encoding,
    /// Element definitions in file order.
    pub elements: Vec<ElementDef>,
    /// `comment` lines, without the keyword.
    pub comments: Vec<String>,
    /// `obj_info` lines, without the keyword.
    pub obj_info: Vec<String>,
    /// The 1-based line number where the body starts (for ASCII error messages).
    pub body_line: usize,
}

impl Header {
    /// The value of an `obj_info KEY VALUE` line.
    pub fn obj_info_value(&self, key: &str) -> Option<&str> {
        self.obj_info.iter().find_map(|l| {
            let mut it = l.split_whitespace();
            (it.next() == Some(key)).then(|| it.next()).flatten()
        })
    }

    /// The length unit, where the file says: a `comment units X` line (as scanrig writes), else metres
    /// for Cyberware data (`obj_info is_cyberware_data 1`, the Stanford scans).
    pub fn units(&self) -> Option<String> {
        let from_comment = self.comments.iter().find_map(|c| {
            let mut it = c.split_whitespace();
            (it.next() == Some("units")).then(|| it.next().map(str::to_string)).flatten()
        });
        from_comment.or_else(|| (self.obj_info_value("is_cyberware_data") == Some("1")).then(|| "m".to_string()))
    }
}

/// The longest header we read: real headers are a few kB; this stops a file of garbage without newlines
/// from being scanned as one giant header line.
pub(crate) const MAX_HEADER_BYTES: usize = 1 << 20;

/// Parses the header; returns it and the byte offset where the body starts.
pub(crate) fn parse_header(bytes: &[u8]) -> Result<(Header, usize), ParseError> {
    let err = |line: usize, p: Problem| ParseError::new(Location::Line(line), p);
    let mut pos = 0usize;
    let mut line_no = 0usize;
    let next_line = |pos: &mut usize| -> Option<String> {
        if *pos >= bytes.len() || *pos >= MAX_HEADER_BYTES {
            return None;
        }
        let rest = &bytes[*pos..];
        let end = rest.iter().position(|&b| b == b'\n' || b == b'\r').unwrap_or(rest.len());
        let line = String::from_utf8_lossy(&rest[..end]).into_owned();
        let mut skip = end;
        // A line ends at \n, \r\n or a lone \r.
        if rest.get(skip) == Some(&b'\r') {
            skip += 1;
        }
        if rest.get(skip) == Some(&b'\n') {
            skip += 1;
        }
        *pos += skip;
        Some(line)
    };

    let first = next_line(&mut pos).unwrap_or_default();
    line_no += 1;
    if first.trim_end() != "ply" {
        let found: String = first.chars().take(40).collect();
        return Err(err(1, Problem::BadMagic { format: "PLY", found }));
    }
    let mut encoding = None;
    let mut elements: Vec<ElementDef> = Vec::new();
    let mut comments = Vec::new();
    let mut obj_info = Vec::new();
    loop {
        let Some(line) = next_line(&mut pos) else {
            return Err(err(line_no, Problem::MissingEndHeader));
        };
        line_no += 1;
        let words: Vec<&str> = line.split_whitespace().collect();
        let malformed = || err(line_no, Problem::MalformedHeaderLine(line.clone()));
        match words.first().copied() {
            None => continue,
            Some("end_header") => break,
            Some("comment") => comments.push(rest_after_keyword(&line)),
            Some("obj_info") => obj_info.push(rest_after_keyword(&line)),
            Some("format") => {
                let [_, enc, version] = words[..] else { return Err(malformed()) };
                if version != "1.0" {
                    return Err(err(line_no, Problem::UnsupportedFormat(format!("{enc} {version}"))));
                }
                encoding = Some(match enc {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::BinaryLittleEndian,
                    "binary_big_endian" => Encoding::BinaryBigEndian,
                    _ => return Err(err(line_no, Problem::UnsupportedFormat(enc.to_string()))),
                });
            }
            Some("element") => {
                let [_, name, count] = words[..] else { return Err(malformed()) };
                let count = count.parse::<u64>().map_err(|_| malformed())?;
                // A second `vertex` element would leave readers to pick one of two point sets.
                if elements.iter().any(|e| e.name == name) {
                    return Err(err(line_no, Problem::Invalid(format!("element `{name}` is declared twice"))));
                }
                elements.push(ElementDef { name: name.to_string(), count, properties: Vec::new() });
            }
            Some("property") => {
                let ty = |s: &str| ScalarType::parse(s).ok_or_else(|| err(line_no, Problem::UnknownType(s.into())));
                let (kind, name) = match words[..] {
                    [_, "list", count, item, name] => {
                        let count = ty(count)?;
                        if !count.is_integer() {
                            return Err(malformed());
                        }
                        (PropertyKind::List { count, item: ty(item)? }, name)
                    }
                    [_, t, name] if t != "list" => (PropertyKind::Scalar(ty(t)?), name),
                    _ => return Err(malformed()),
                };
                let Some(el) = elements.last_mut() else {
                    return Err(err(line_no, Problem::Invalid("`property` before any `element`".into())));
                };
                if el.properties.iter().any(|p| p.name == name) {
                    let msg = format!("property `{name}` of element `{}` is declared twice", el.name);
                    return Err(err(line_no, Problem::Invalid(msg)));
                }
                el.properties.push(PropertyDef { name: name.to_string(), kind });
            }
            Some(_) => {
                let shown: String = line.chars().take(60).collect();
                return Err(err(line_no, Problem::UnknownHeaderLine(shown)));
            }
        }
    }
    let Some(encoding) = encoding else {
        return Err(err(line_no, Problem::Missing("`format` line in the header".into())));
    };
    Ok((Header { encoding, elements, comments, obj_info, body_line: line_no + 1 }, pos))
}

fn rest_after_keyword(line: &str) -> String {
    let t = line.trim_start();
    t.split_once(char::is_whitespace).map(|(_, r)| r.trim().to_string()).unwrap_or_default()
}
