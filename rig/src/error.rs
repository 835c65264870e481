//! Errors of the vocabulary crate. Every error names the file and the spot in it: a line, an element
//! entry or a field, so a user can open the file and see what is wrong.

use std::fmt;
use std::path::{Path, PathBuf};

/// "there are 3 vertices, numbered 1 to 3" (or that there are none).
fn numbering(count: &usize, first: &u8, what: &str) -> String {
    let (count, first) = (*count, *first as i64);
    let plural = match what {
        "vertex" => "vertices".to_string(),
        w => format!("{w}s"),
    };
    if count == 0 {
        format!("the file has no {plural} before it")
    } else {
        format!("there are {count} {plural}, numbered {first} to {}", first + count as i64 - 1)
    }
}

/// Where in a file a problem was found.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum Location {
    /// A line of a text file or of a PLY header (1-based).
    Line(usize),
    /// One entry (0-based) of a PLY element; `line` is set for ASCII bodies.
    Element {
        /// The element's name, e.g. `vertex`.
        name: String,
        /// The entry's index within the element.
        index: u64,
        /// The 1-based line of an ASCII body.
        line: Option<usize>,
    },
    /// A field of a structured file, as a dotted key path (`camera.fx_px`).
    Field(String),
    /// The file as a whole.
    File,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line(n) => write!(f, "line {n}"),
            Location::Element { name, index, line: Some(l) } => {
                write!(f, "element `{name}` #{index} (line {l})")
            }
            Location::Element { name, index, line: None } => write!(f, "element `{name}` #{index}"),
            Location::Field(k) => write!(f, "field `{k}`"),
            Location::File => write!(f, "file"),
        }
    }
}

/// What is wrong at a [`Location`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Problem {
    /// The data stops before something the header or format promised.
    #[error("the file ends before {0}")]
    Truncated(String),
    /// The first line does not identify the format.
    #[error("not a {format} file (it starts with `{found}`)")]
    BadMagic {
        /// The format that was expected.
        format: &'static str,
        /// What the file starts with instead (shortened).
        found: String,
    },
    /// A header line with an unknown keyword.
    #[error("unknown header line `{0}`")]
    UnknownHeaderLine(String),
    /// A header line with the right keyword but the wrong shape.
    #[error("malformed header line `{0}`")]
    MalformedHeaderLine(String),
    /// The PLY header never ends.
    #[error("the header has no `end_header` line")]
    MissingEndHeader,
    /// An encoding or version this reader does not know.
    #[error("unsupported format `{0}`")]
    UnsupportedFormat(String),
    /// A scalar type name this reader does not know.
    #[error("unknown property type `{0}`")]
    UnknownType(String),
    /// A count the rest of the file cannot hold: refused before anything is allocated.
    #[error("declares {count} entries of at least {min_bytes} bytes each, but only {available} bytes remain")]
    CountTooLarge {
        /// The declared count.
        count: u64,
        /// The fewest bytes one entry can take.
        min_bytes: u64,
        /// The bytes left in the file.
        available: u64,
    },
    /// A token that should be a number.
    #[error("`{0}` is not a number")]
    NotANumber(String),
    /// A number that does not fit its declared type.
    #[error("{value} does not fit the type `{ty}`")]
    OutOfRange {
        /// The value as read.
        value: String,
        /// The declared type.
        ty: &'static str,
    },
    /// A face refers to a vertex (or texture coordinate, or normal) that does not exist.
    #[error("{what} index {index} is out of range ({})", numbering(.count, .first, .what))]
    IndexOutOfRange {
        /// The index as written in the file.
        index: Box<str>,
        /// What it indexes: `vertex`, `texture coordinate`, `normal`.
        what: &'static str,
        /// How many of them exist.
        count: usize,
        /// The format's first index: 1 for OBJ, 0 for PLY and OFF.
        first: u8,
    },
    /// A face index that is not a whole number (a float list type holding 1.5, NaN).
    #[error("face index {0} is not a whole number")]
    FractionalIndex(String),
    /// A face with fewer than three corners.
    #[error("a face needs at least 3 vertices, this one has {0}")]
    DegenerateFace(usize),
    /// A NaN or infinite value where geometry must be finite.
    #[error("{0} is not finite")]
    NonFinite(String),
    /// An element or property the data needs is absent.
    #[error("missing {0}")]
    Missing(String),
    /// Data after the last declared element.
    #[error("unexpected data after the last element: `{0}`")]
    TrailingData(String),
    /// A value that parses but makes no sense (a negative focal length, a non-rotation matrix).
    #[error("{0}")]
    Invalid(String),
    /// A syntax error reported by a structured-text parser (TOML).
    #[error("{0}")]
    Syntax(String),
}

/// A problem found while parsing bytes, before the file's path is known.
#[derive(Debug, Clone, PartialEq)]
pub struct ParseError {
    /// Where.
    pub at: Location,
    /// What.
    pub problem: Problem,
}

impl ParseError {
    /// A problem at a location.
    pub fn new(at: Location, problem: Problem) -> Self {
        ParseError { at, problem }
    }

    /// Attaches the file's path, giving the crate's [`Error`].
    pub fn with_path(self, path: &Path) -> Error {
        Error::Parse { path: path.to_path_buf(), at: self.at, problem: self.problem }
    }
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.at, self.problem)
    }
}

impl std::error::Error for ParseError {}

/// The error of every file operation in this crate.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The file was read but its contents are wrong.
    #[error("{}: {at}: {problem}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// Where in it.
        at: Location,
        /// What is wrong.
        problem: Problem,
    },
    /// Writing the file would replace something of the user's (see [`crate::run_files`]).
    #[error("{}: not written: {why}", path.display())]
    Refused {
        /// The file that would have been written.
        path: PathBuf,
        /// Why not.
        why: String,
    },
    /// The file's name does not say what it holds.
    #[error("{}: unrecognised file type; expected {expected}", path.display())]
    UnknownFileType {
        /// The file.
        path: PathBuf,
        /// The extensions that would have been understood.
        expected: &'static str,
    },
}

impl Error {
    /// Wraps an I/O error with its path.
    pub fn io(path: &Path, source: std::io::Error) -> Self {
        Error::Io { path: path.to_path_buf(), source }
    }

    /// The problem, for a parse error.
    pub fn problem(&self) -> Option<&Problem> {
        match self {
            Error::Parse { problem, .. } => Some(problem),
            _ => None,
        }
    }
}
