//! Frame files in the order they were captured: by their number, never as text.
//!
//! Other tools number their frames without padding (`img1.png … img42.png`, `graycode_0 …
//! graycode_41`), and sorted as text those come out `1, 10, 11, …, 19, 2, 20, …`: every frame after the
//! ninth is taken for the wrong pattern. Here a name's runs of digits compare as numbers (natural
//! order), and a folder's images are checked to be one numbered series: two files with the same number
//! (`img1.png` and `img01.png`), a number missing between the first and the last, an image without a
//! number or of another series (a preview written into the folder) are each named. Every place that
//! lists frames from a folder goes through [`list_images`] (or [`order`] for a list it already has).
//!
//! ```
//! use rig::frame_order::order;
//! use std::path::PathBuf;
//! let files: Vec<PathBuf> = ["img10.png", "img2.png", "img1.png"].iter().map(PathBuf::from).collect();
//! let sorted = order(files);
//! assert_eq!(sorted.files, ["img1.png", "img2.png", "img10.png"].map(PathBuf::from));
//! assert_eq!(sorted.problems.len(), 1);
//! assert!(sorted.describe().contains("frame numbers 3 to 9 are missing (after img2.png)"));
//! ```

use crate::error::{Error, Location, ParseError, Problem};
use std::cmp::Ordering;
use std::fmt;
use std::path::{Path, PathBuf};

/// Compares two names in natural order: runs of ASCII digits compare as the numbers they write (of any
/// length, without overflow), everything else as text. Names equal that way (`img1` and `img01`) are
/// then ordered by their text, so the order is total and the same whatever the input order.
pub fn natural_cmp(a: &str, b: &str) -> Ordering {
    let (mut x, mut y) = (a.as_bytes(), b.as_bytes());
    loop {
        match (x.first(), y.first()) {
            (None, None) => return a.cmp(b),
            (None, Some(_)) => return Ordering::Less,
            (Some(_), None) => return Ordering::Greater,
            (Some(c), Some(d)) if c.is_ascii_digit() && d.is_ascii_digit() => {
                let (da, ra) = split_digits(x);
                let (db, rb) = split_digits(y);
                let (na, nb) = (strip_zeros(da), strip_zeros(db));
                let by_value = na.len().cmp(&nb.len()).then_with(|| na.cmp(nb));
                if by_value != Ordering::Equal {
                    return by_value;
                }
                (x, y) = (ra, rb);
            }
            (Some(c), Some(d)) => {
                if c != d {
                    return c.cmp(d);
                }
                (x, y) = (&x[1..], &y[1..]);
            }
        }
    }
}

fn split_digits(s: &[u8]) -> (&[u8], &[u8]) {
    let n = s.iter().take_while(|c| c.is_ascii_digit()).count();
    s.split_at(n)
}

fn strip_zeros(s: &[u8]) -> &[u8] {
    let n = s.iter().take_while(|&&c| c == b'0').count();
    &s[n..]
}

/// A file name taken apart: the text before its last run of digits, the number, and the text after
/// (the extension left out, compared without case).
#[derive(Debug, Clone, PartialEq, Eq)]
struct Numbered {
    series: (String, String),
    number: Option<u128>,
}

fn numbered(path: &Path) -> Numbered {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let bytes = stem.as_bytes();
    let Some(end) = bytes.iter().rposition(u8::is_ascii_digit).map(|i| i + 1) else {
        return Numbered { series: (stem, String::new()), number: None };
    };
    let start = bytes[..end].iter().rposition(|c| !c.is_ascii_digit()).map_or(0, |i| i + 1);
    Numbered {
        series: (stem[..start].to_string(), stem[end..].to_string()),
        // 38 digits fit; a longer run is no frame number.
        number: stem[start..end].parse().ok(),
    }
}

/// What is wrong with a folder's numbering.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SequenceProblem {
    /// Two or more files with the same number (`img1.png` and `img01.png`, or a PNG and a JPEG).
    Duplicate {
        /// The number.
        number: u128,
        /// The files that carry it.
        files: Vec<PathBuf>,
    },
    /// Numbers missing between two present ones: frames lost, or not one capture.
    Gap {
        /// The last file before the gap.
        after: PathBuf,
        /// The first and last missing numbers.
        missing: (u128, u128),
    },
    /// Images without a number, or of another series than the folder's frames.
    Extra {
        /// The files.
        files: Vec<PathBuf>,
    },
}

fn name(p: &Path) -> String {
    p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| p.display().to_string())
}

impl fmt::Display for SequenceProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SequenceProblem::Duplicate { number, files } => {
                let names: Vec<String> = files.iter().map(|p| name(p)).collect();
                write!(f, "{} carry the same frame number, {number}", names.join(" and "))
            }
            SequenceProblem::Gap { after, missing: (a, b) } if a == b => {
                write!(f, "frame number {a} is missing (after {})", name(after))
            }
            SequenceProblem::Gap { after, missing: (a, b) } => {
                write!(f, "frame numbers {a} to {b} are missing (after {})", name(after))
            }
            SequenceProblem::Extra { files } => {
                let names: Vec<String> = files.iter().take(5).map(|p| name(p)).collect();
                let more = if files.len() > 5 { format!(" and {} more", files.len() - 5) } else { String::new() };
                write!(f, "{}{more} {} not numbered like the other frames", names.join(", "), plural(files.len()))
            }
        }
    }
}

fn plural(n: usize) -> &'static str {
    if n == 1 { "is" } else { "are" }
}

/// Files in frame order, and what is wrong with their numbering.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Ordered {
    /// Every file given, in natural order of its name.
    pub files: Vec<PathBuf>,
    /// Duplicates, gaps and extra images, in the order found; empty for one clean series.
    pub problems: Vec<SequenceProblem>,
}

impl Ordered {
    /// The files, or an error naming every problem (against `dir`, the folder they came from).
    pub fn complete(self, dir: &Path) -> Result<Vec<PathBuf>, Error> {
        if self.problems.is_empty() {
            return Ok(self.files);
        }
        Err(ParseError::new(Location::File, Problem::Invalid(self.describe())).with_path(dir))
    }

    /// The problems in one sentence (empty when there are none).
    pub fn describe(&self) -> String {
        let parts: Vec<String> = self.problems.iter().map(ToString::to_string).collect();
        if parts.is_empty() {
            return String::new();
        }
        format!(
            "the frames are not one numbered series: {} (frames are taken in the order of their numbers; \
             rename or remove the files named)",
            parts.join("; ")
        )
    }
}

/// Orders `files` by their names in natural order ([`natural_cmp`]) and checks that they form one
/// numbered series: the most common series (the text around each name's last number) is the
/// folder's; images outside it are extra, equal numbers duplicates, and missing numbers between the
/// first and last a gap.
pub fn order(mut files: Vec<PathBuf>) -> Ordered {
    let key = |p: &PathBuf| p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    files.sort_by(|a, b| natural_cmp(&key(a), &key(b)).then_with(|| a.cmp(b)));
    let names: Vec<Numbered> = files.iter().map(|p| numbered(p)).collect();
    // The folder's series: the one most files belong to (ties: the first in order).
    let mut counts: Vec<(&(String, String), usize)> = Vec::new();
    for n in names.iter().filter(|n| n.number.is_some()) {
        match counts.iter_mut().find(|c| *c.0 == n.series) {
            Some(c) => c.1 += 1,
            None => counts.push((&n.series, 1)),
        }
    }
    let main = counts.iter().fold(None::<(&(String, String), usize)>, |best, &(s, c)| match best {
        Some((_, b)) if b >= c => best,
        _ => Some((s, c)),
    });
    let mut problems = Vec::new();
    let in_series = |n: &Numbered| main.is_some_and(|(s, _)| *s == n.series) && n.number.is_some();
    let extra: Vec<PathBuf> = files.iter().zip(&names).filter(|(_, n)| !in_series(n)).map(|(p, _)| p.clone()).collect();
    if !extra.is_empty() {
        problems.push(SequenceProblem::Extra { files: extra });
    }
    let series: Vec<(u128, &PathBuf)> =
        files.iter().zip(&names).filter(|(_, n)| in_series(n)).filter_map(|(p, n)| Some((n.number?, p))).collect();
    let mut k = 0;
    while k < series.len() {
        let number = series[k].0;
        let same: Vec<PathBuf> = series[k..].iter().take_while(|s| s.0 == number).map(|s| s.1.clone()).collect();
        let run = same.len();
        if run > 1 {
            problems.push(SequenceProblem::Duplicate { number, files: same });
        }
        if let Some(&(next, _)) = series.get(k + run)
            && next > number + 1
        {
            let last = series[k + run - 1].1;
            problems.push(SequenceProblem::Gap { after: last.clone(), missing: (number + 1, next - 1) });
        }
        k += run;
    }
    Ordered { files, problems }
}

/// The PNG and JPEG images of `dir`, in frame order, with what is wrong with their numbering.
pub fn list_images(dir: &Path) -> Result<Ordered, Error> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
        let path = entry.map_err(|e| Error::io(dir, e))?.path();
        if crate::image::is_image_file(&path) && !path.is_dir() {
            files.push(path);
        }
    }
    Ok(order(files))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn paths(names: &[&str]) -> Vec<PathBuf> {
        names.iter().map(PathBuf::from).collect()
    }

    /// Issue 37: `graycode_0 … graycode_41` and `img1 … img42` sorted as text put frame 10 second.
    #[test]
    fn unpadded_numbers_sort_by_value_not_as_text() {
        for prefix in ["graycode_", "img", ""] {
            let names: Vec<String> = (0..42).rev().map(|k| format!("{prefix}{k}.png")).collect();
            let o = order(names.iter().map(PathBuf::from).collect());
            let want: Vec<PathBuf> = (0..42).map(|k| PathBuf::from(format!("{prefix}{k}.png"))).collect();
            assert_eq!(o.files, want);
            assert!(o.problems.is_empty(), "{:?}", o.problems);
        }
    }

    #[test]
    fn duplicates_gaps_and_extras_are_named() {
        let o = order(paths(&["img1.png", "img01.png", "img2.png", "img5.png", "map.png", "shot_3.png"]));
        let text = o.describe();
        assert!(text.contains("img01.png and img1.png carry the same frame number, 1"), "{text}");
        assert!(text.contains("frame numbers 3 to 4 are missing (after img2.png)"), "{text}");
        assert!(text.contains("map.png, shot_3.png are not numbered like the other frames"), "{text}");
        let e = o.complete(Path::new("/captures")).unwrap_err().to_string();
        assert!(e.starts_with("/captures"), "{e}");
        let o = order(paths(&["a_0.png", "a_1.jpg", "a_1.png"]));
        assert_eq!(o.problems, vec![SequenceProblem::Duplicate { number: 1, files: paths(&["a_1.jpg", "a_1.png"]) }]);
    }

    /// Frames listed in a scan folder's manifest: a file listed twice, by one view or two, or two files
    /// for one pattern, is refused by name (one of them would be decoded as a frame it is not).
    #[test]
    fn a_manifest_listing_a_frame_twice_is_refused() {
        let patterns = [crate::Pattern::White, crate::Pattern::Black];
        let m = crate::Manifest::fresh(crate::Method::StructuredLight, "test", None, &[0.0], &patterns);
        assert!(crate::Manifest::from_json(&serde_json::to_vec(&m).unwrap()).is_ok());
        let mut twice = m.clone();
        twice.views[0].frames[1].file = twice.views[0].frames[0].file.clone();
        let e = crate::Manifest::from_json(&serde_json::to_vec(&twice).unwrap()).unwrap_err().to_string();
        assert!(e.contains("views[0].frames") && e.contains("frames/view_000/00_white.png` is listed twice"), "{e}");
        let mut again = m.clone();
        again.views[0].frames[1].pattern = crate::Pattern::White;
        let e = crate::Manifest::from_json(&serde_json::to_vec(&again).unwrap()).unwrap_err().to_string();
        assert!(e.contains("both show white"), "{e}");
        // A view listed twice (a hostile user's probe, 2026-12-07: registration failed with "the
        // target has no points"): its files are another view's.
        let two = crate::Manifest::fresh(crate::Method::StructuredLight, "test", None, &[0.0, 30.0], &patterns);
        let mut copied = two.clone();
        copied.views[1].frames = copied.views[0].frames.clone();
        let e = crate::Manifest::from_json(&serde_json::to_vec(&copied).unwrap()).unwrap_err().to_string();
        assert!(e.contains("views[1].frames") && e.contains("is view 0's too"), "{e}");
        assert!(crate::Manifest::from_json(&serde_json::to_vec(&two).unwrap()).is_ok());
    }

    #[test]
    fn natural_order_compares_long_runs_without_overflow() {
        let big = "9".repeat(60);
        assert_eq!(natural_cmp(&format!("x{big}"), &format!("x1{big}")), Ordering::Less);
        assert_eq!(natural_cmp("a2b10", "a2b9"), Ordering::Greater);
        assert_eq!(natural_cmp("a", "a0"), Ordering::Less);
        assert_eq!(natural_cmp("img01", "img1"), Ordering::Less);
    }

    proptest! {
        /// Any set of distinct numbers, padded or not, in any order, comes back sorted by number with
        /// no problem when the numbers run without gaps.
        #[test]
        fn a_shuffled_series_comes_back_in_number_order(
            start in 0u32..1000,
            len in 1usize..60,
            pads in proptest::collection::vec(0usize..5, 60),
            seed in any::<u64>(),
            prefix in "[a-z_]{0,6}",
        ) {
            let names: Vec<String> =
                (0..len).map(|k| format!("{prefix}{:0width$}.png", start as usize + k, width = pads[k])).collect();
            let mut shuffled = names.clone();
            let mut s = seed | 1;
            for i in (1..shuffled.len()).rev() {
                s ^= s << 13; s ^= s >> 7; s ^= s << 17;
                shuffled.swap(i, (s % (i as u64 + 1)) as usize);
            }
            let o = order(shuffled.iter().map(PathBuf::from).collect());
            prop_assert_eq!(o.files, names.iter().map(PathBuf::from).collect::<Vec<_>>());
            prop_assert!(o.problems.is_empty(), "{:?}", o.problems);
        }

        /// Removing an inner frame is a gap naming its number; adding a differently padded twin is a
        /// duplicate naming both files; a stray unnumbered image is extra.
        #[test]
        fn gaps_duplicates_and_extras_are_found(len in 3usize..50, cut in 1usize..49, twin in 0usize..50) {
            let (cut, twin) = (cut % (len - 2) + 1, twin % len);
            let names: Vec<String> = (0..len).filter(|&k| k != cut).map(|k| format!("f{k}.png")).collect();
            let o = order(names.iter().map(PathBuf::from).collect());
            prop_assert_eq!(
                o.problems,
                vec![SequenceProblem::Gap { after: PathBuf::from(format!("f{}.png", cut - 1)), missing: (cut as u128, cut as u128) }]
            );
            let mut names: Vec<String> = (0..len).map(|k| format!("f{k}.png")).collect();
            names.push(format!("f00{twin}.png"));
            names.push("preview.png".into());
            let o = order(names.iter().map(PathBuf::from).collect());
            prop_assert_eq!(o.files.len(), len + 2);
            prop_assert_eq!(o.problems.len(), 2);
            let extra = SequenceProblem::Extra { files: vec![PathBuf::from("preview.png")] };
            prop_assert_eq!(&o.problems[0], &extra);
            let SequenceProblem::Duplicate { number, files } = &o.problems[1] else { panic!("{:?}", o.problems) };
            prop_assert_eq!(*number, twin as u128);
            let mut files = files.clone();
            files.sort();
            let mut want = vec![PathBuf::from(format!("f00{twin}.png")), PathBuf::from(format!("f{twin}.png"))];
            want.sort();
            prop_assert_eq!(files, want);
        }

        /// The comparison is a total order: antisymmetric, and sorting is the same from any start.
        #[test]
        fn natural_cmp_is_a_total_order(a in "[a0-9]{0,8}", b in "[a0-9]{0,8}", c in "[a0-9]{0,8}") {
            prop_assert_eq!(natural_cmp(&a, &b), natural_cmp(&b, &a).reverse());
            prop_assert_eq!(natural_cmp(&a, &b) == Ordering::Equal, a == b);
            if natural_cmp(&a, &b) != Ordering::Greater && natural_cmp(&b, &c) != Ordering::Greater {
                prop_assert_ne!(natural_cmp(&a, &c), Ordering::Greater);
            }
        }
    }
}
