//! SVG charts for the pages: drawn here from numbers, so a page needs no charting script and a
//! test can read the numbers back from the markup.

use crate::escape::esc;
use process::preview::turbo;
use std::fmt::Write as _;

const W: f64 = 560.0;
const H: f64 = 220.0;
const LEFT: f64 = 56.0;
const RIGHT: f64 = 12.0;
const TOP: f64 = 12.0;
const BOTTOM: f64 = 36.0;
/// Series colours (colour-blind safe, Okabe–Ito).
pub const COLOURS: [&str; 6] = ["#0072b2", "#d55e00", "#009e73", "#cc79a7", "#e69f00", "#56b4e9"];

/// About `n` round tick values covering `lo..hi`.
pub fn ticks(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if !(lo.is_finite() && hi.is_finite()) || hi <= lo {
        return vec![lo];
    }
    let raw = (hi - lo) / n.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0].iter().map(|m| m * mag).find(|s| *s >= raw).unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|k| k as f64 * step).collect()
}

/// A number for an axis label: few digits, no trailing zeros.
pub fn num(v: f64) -> String {
    let a = v.abs();
    let s = if a == 0.0 || (1e-3..1e5).contains(&a) {
        let digits = if a >= 100.0 {
            0
        } else if a >= 1.0 {
            2
        } else {
            4
        };
        format!("{v:.digits$}")
    } else {
        format!("{v:.2e}")
    };
    if s.contains('.') && !s.contains('e') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s }
}

fn figure(svg: String, caption: &str) -> String {
    format!("<figure>{svg}<figcaption>{}</figcaption></figure>", esc(caption))
}

/// The opening markup of a plot: its frame, y ticks over `lo..hi` and the axis labels.
fn frame(lo: f64, hi: f64, ylabel: &str, xlabel: &str) -> String {
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{W}\" height=\"{H}\" viewBox=\"0 0 {W} {H}\" role=\"img\">\
         <rect x=\"{LEFT}\" y=\"{TOP}\" width=\"{}\" height=\"{}\" fill=\"#fafbfc\" stroke=\"#d8dbe0\"/>",
        W - LEFT - RIGHT,
        H - TOP - BOTTOM
    );
    for t in ticks(lo, hi, 4) {
        let y = ymap(t, lo, hi);
        let _ = write!(
            s,
            "<line x1=\"{LEFT}\" x2=\"{}\" y1=\"{y:.1}\" y2=\"{y:.1}\" stroke=\"#e3e5e8\"/>\
             <text x=\"{}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>",
            W - RIGHT,
            LEFT - 4.0,
            y + 4.0,
            num(t)
        );
    }
    let _ = write!(
        s,
        "<text x=\"12\" y=\"{}\" transform=\"rotate(-90 12 {})\" text-anchor=\"middle\">{}</text>\
         <text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>",
        TOP + (H - TOP - BOTTOM) / 2.0,
        TOP + (H - TOP - BOTTOM) / 2.0,
        esc(ylabel),
        LEFT + (W - LEFT - RIGHT) / 2.0,
        H - 4.0,
        esc(xlabel)
    );
    s
}

fn ymap(v: f64, lo: f64, hi: f64) -> f64 {
    let t = if hi > lo { (v - lo) / (hi - lo) } else { 0.5 };
    H - BOTTOM - t.clamp(0.0, 1.0) * (H - TOP - BOTTOM)
}

fn range(values: impl Iterator<Item = f64>, from_zero: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (if from_zero { 0.0 } else { f64::INFINITY }, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !hi.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-12 {
        hi = lo + if lo.abs() > 0.0 { lo.abs() * 0.1 } else { 1.0 };
    }
    (lo, hi + 0.05 * (hi - lo))
}

/// A bar per label (flagged bars in orange), with the values in each bar's tooltip.
pub fn bars(caption: &str, labels: &[String], values: &[f64], flagged: &[bool], ylabel: &str, xlabel: &str) -> String {
    let (lo, hi) = range(values.iter().copied(), true);
    let mut s = frame(lo, hi, ylabel, xlabel);
    let n = values.len().max(1) as f64;
    let slot = (W - LEFT - RIGHT) / n;
    // A missing figure (null in a report) draws no bar rather than a bar at NaN.
    for (i, v) in values.iter().enumerate().filter(|(_, v)| v.is_finite()) {
        let x = LEFT + slot * i as f64 + 0.15 * slot;
        let y = ymap(*v, lo, hi);
        let colour = if flagged.get(i).copied().unwrap_or(false) { COLOURS[1] } else { COLOURS[0] };
        let label = labels.get(i).map(String::as_str).unwrap_or("");
        let _ = write!(
            s,
            "<rect x=\"{x:.1}\" y=\"{y:.1}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"{colour}\"><title>{}: {}</title></rect>",
            0.7 * slot,
            (H - BOTTOM - y).max(0.0),
            esc(label),
            num(*v)
        );
    }
    label_x(&mut s, labels);
    s.push_str("</svg>");
    figure(s, caption)
}

/// Up to ~12 category labels under the x axis (every k-th when there are more).
fn label_x(s: &mut String, labels: &[String]) {
    let n = labels.len().max(1);
    let slot = (W - LEFT - RIGHT) / n as f64;
    let every = n.div_ceil(12);
    for (i, l) in labels.iter().enumerate().filter(|(i, _)| i % every == 0) {
        let _ = write!(
            s,
            "<text x=\"{:.1}\" y=\"{}\" text-anchor=\"middle\">{}</text>",
            LEFT + slot * (i as f64 + 0.5),
            H - BOTTOM + 14.0,
            esc(l)
        );
    }
}

/// Lines across views: one series per (name, values), x = the labels' positions.
pub fn series(caption: &str, labels: &[String], series: &[(&str, Vec<f64>)], ylabel: &str, xlabel: &str) -> String {
    let (lo, hi) = range(series.iter().flat_map(|(_, v)| v.iter().copied()), true);
    let mut s = frame(lo, hi, ylabel, xlabel);
    let n = labels.len().max(1);
    let slot = (W - LEFT - RIGHT) / n as f64;
    for (k, (name, values)) in series.iter().enumerate() {
        let colour = COLOURS[k % COLOURS.len()];
        let pts: Vec<String> = values
            .iter()
            .enumerate()
            .filter(|(_, v)| v.is_finite())
            .map(|(i, v)| format!("{:.1},{:.1}", LEFT + slot * (i as f64 + 0.5), ymap(*v, lo, hi)))
            .collect();
        let _ = write!(
            s,
            "<polyline fill=\"none\" stroke=\"{colour}\" stroke-width=\"1.6\" points=\"{}\"/>",
            pts.join(" ")
        );
        for (i, v) in values.iter().enumerate().filter(|(_, v)| v.is_finite()) {
            let _ = write!(
                s,
                "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"2.5\" fill=\"{colour}\"><title>{} {}: {}</title></circle>",
                LEFT + slot * (i as f64 + 0.5),
                ymap(*v, lo, hi),
                esc(name),
                esc(labels.get(i).map(String::as_str).unwrap_or("")),
                num(*v)
            );
        }
        if series.len() > 1 {
            let _ = write!(
                s,
                "<rect x=\"{}\" y=\"{}\" width=\"10\" height=\"10\" fill=\"{colour}\"/><text x=\"{}\" y=\"{}\">{}</text>",
                LEFT + 8.0 + 150.0 * k as f64,
                TOP + 6.0,
                LEFT + 22.0 + 150.0 * k as f64,
                TOP + 15.0,
                esc(name)
            );
        }
    }
    label_x(&mut s, labels);
    s.push_str("</svg>");
    figure(s, caption)
}

/// A histogram of `values` over `lo..hi` in `bins` bins (values outside counted in the end bins),
/// each bar coloured by the turbo scale over the same range, so it doubles as the mesh's legend.
pub fn histogram(caption: &str, values: &[f64], lo: f64, hi: f64, bins: usize, xlabel: &str) -> String {
    let bins = bins.max(1);
    let mut counts = vec![0usize; bins];
    for v in values.iter().filter(|v| v.is_finite()) {
        let t = ((v - lo) / (hi - lo).max(1e-12) * bins as f64).floor();
        counts[(t.max(0.0) as usize).min(bins - 1)] += 1;
    }
    let (_, top) = range(counts.iter().map(|&c| c as f64), true);
    let mut s = frame(0.0, top, "points", xlabel);
    let slot = (W - LEFT - RIGHT) / bins as f64;
    for (i, c) in counts.iter().enumerate() {
        let y = ymap(*c as f64, 0.0, top);
        let [r, g, b] = turbo((i as f64 + 0.5) / bins as f64);
        let _ = write!(
            s,
            "<rect x=\"{:.1}\" y=\"{y:.1}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"rgb({r},{g},{b})\"><title>{}–{}: {c}</title></rect>",
            LEFT + slot * i as f64,
            slot.max(1.0) - 0.5,
            (H - BOTTOM - y).max(0.0),
            num(lo + (hi - lo) * i as f64 / bins as f64),
            num(lo + (hi - lo) * (i + 1) as f64 / bins as f64)
        );
    }
    for t in ticks(lo, hi, 6) {
        let x = LEFT + (t - lo) / (hi - lo).max(1e-12) * (W - LEFT - RIGHT);
        let _ = write!(s, "<text x=\"{x:.1}\" y=\"{}\" text-anchor=\"middle\">{}</text>", H - BOTTOM + 14.0, num(t));
    }
    s.push_str("</svg>");
    figure(s, caption)
}

/// A horizontal colour bar of the turbo scale from `lo` (t = 0) to `hi` (t = 1), with ticks.
pub fn colour_bar(lo: f64, hi: f64, label: &str) -> String {
    let (w, h) = (360.0, 46.0);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\" role=\"img\">\
         <defs><linearGradient id=\"turbo\">"
    );
    for k in 0..=16 {
        let [r, g, b] = turbo(k as f64 / 16.0);
        let _ = write!(s, "<stop offset=\"{:.4}\" stop-color=\"rgb({r},{g},{b})\"/>", k as f64 / 16.0);
    }
    let _ = write!(
        s,
        // Every bar's gradient is the same turbo scale, so one id serves however many a page holds.
        "</linearGradient></defs><rect x=\"10\" y=\"4\" width=\"{}\" height=\"12\" fill=\"url(#turbo)\"/>",
        w - 20.0
    );
    for t in ticks(lo, hi, 5) {
        let x = 10.0 + (t - lo) / (hi - lo).max(1e-12) * (w - 20.0);
        let _ = write!(
            s,
            "<line x1=\"{x:.1}\" x2=\"{x:.1}\" y1=\"16\" y2=\"20\" stroke=\"#555\"/><text x=\"{x:.1}\" y=\"30\" text-anchor=\"middle\">{}</text>",
            num(t)
        );
    }
    let _ = write!(s, "<text x=\"{}\" y=\"43\" text-anchor=\"middle\">{}</text></svg>", w / 2.0, esc(label));
    s
}

/// Arrows from each point by its vector × `scale`, over an image of `width` × `height` pixels
/// (drawn at `draw_width` px wide); `points` are (x, y, dx, dy) in image pixels.
pub fn vectors(caption: &str, width: u32, height: u32, draw_width: f64, points: &[[f64; 4]], scale: f64) -> String {
    let k = draw_width / width.max(1) as f64;
    let (w, h) = (draw_width, height as f64 * k);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w:.0}\" height=\"{h:.0}\" viewBox=\"0 0 {w:.1} {h:.1}\" role=\"img\">\
         <rect width=\"{w:.1}\" height=\"{h:.1}\" fill=\"#fafbfc\" stroke=\"#d8dbe0\"/>"
    );
    for p in points.iter().filter(|p| p.iter().all(|v| v.is_finite())) {
        let (x, y) = (p[0] * k, p[1] * k);
        let _ = write!(
            s,
            "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"1.2\" fill=\"#5c6370\"/><line x1=\"{x:.1}\" y1=\"{y:.1}\" x2=\"{:.1}\" y2=\"{:.1}\" stroke=\"{}\" stroke-width=\"1.2\"/>",
            x + p[2] * scale * k,
            y + p[3] * scale * k,
            COLOURS[1]
        );
    }
    s.push_str("</svg>");
    figure(s, caption)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_cover_the_range() {
        assert_eq!(ticks(0.0, 1.0, 4), vec![0.0, 0.25, 0.5, 0.75, 1.0]);
        let t = ticks(0.013, 0.087, 4);
        assert!(t.first().unwrap() >= &0.013 && t.last().unwrap() <= &0.087 && t.len() >= 3, "{t:?}");
        assert_eq!(ticks(f64::NAN, 1.0, 4).len(), 1);
        assert_eq!(num(0.25), "0.25");
        assert_eq!(num(120.0), "120");
    }

    #[test]
    fn histogram_counts_every_value_once() {
        let values: Vec<f64> = (0..1000).map(|i| i as f64 / 1000.0).chain([f64::NAN, -5.0, 9.0]).collect();
        let svg = histogram("h", &values, 0.0, 1.0, 10, "mm");
        // Bin counts are in each bar's tooltip: "lo–hi: count".
        let total: usize = svg.split("</title>").filter_map(|t| t.rsplit(": ").next()?.parse::<usize>().ok()).sum();
        assert_eq!(total, 1002, "finite values, those outside in the end bins");
    }

    #[test]
    fn charts_survive_empty_and_flat_data() {
        for svg in [
            bars("b", &[], &[], &[], "y", "x"),
            bars("b", &["0".into(), "1".into()], &[f64::NAN, 2.0], &[], "y", "x"),
            series("s", &["0".into()], &[("a", vec![f64::NAN])], "y", "x"),
            histogram("h", &[], 0.0, 0.0, 0, "x"),
            colour_bar(3.0, 3.0, "z"),
            vectors("v", 0, 0, 100.0, &[[f64::NAN; 4]], 1.0),
        ] {
            assert!(svg.contains("</svg>") && !svg.contains("NaN") && !svg.contains("inf"), "{svg}");
        }
    }
}
