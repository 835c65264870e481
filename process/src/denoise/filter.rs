//! The weighted averages of eq. 4.3 (one frame) and eq. 4.6 (a sequence).

use super::bandwidth::estimate;
use super::directions::directions;
use super::patch::{PairTable, similarity};
use super::{DenoiseError, DenoiseParams, DenoiseReport, Similarity};
use rayon::prelude::*;
use rig::RangeGrid;
use rig::math::{Real, Vector3};
use std::time::Instant;

/// Random samples for the automatic bandwidths.
const BANDWIDTH_SAMPLES: usize = 2000;

/// One frame's part in a filtering pass: the grid, its bandwidths and its weight Ψ_dk·Ψ_sk.
struct FrameTerm<'a> {
    grid: &'a RangeGrid,
    d: Real,
    s: Real,
    psi: Real,
}

/// Per cell, the largest neighbourhood half-size ≤ `max` whose window has the highest share of valid
/// cells (section 4.3.2's adaptive neighbourhoods: near holes and borders the window shrinks).
fn adaptive_radius(grid: &RangeGrid, max: usize) -> Vec<usize> {
    let (w, h) = (grid.width, grid.height);
    let stride = w + 1;
    let mut sat = vec![0u32; stride * (h + 1)];
    for r in 0..h {
        let mut row = 0;
        for c in 0..w {
            row += u32::from(grid.valid[r * w + c]);
            sat[(r + 1) * stride + c + 1] = sat[r * stride + c + 1] + row;
        }
    }
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (c, r) = (i % w, i / w);
            let mut best = (0.0, max);
            for rad in (1..=max).rev() {
                let (c0, r0) = (c.saturating_sub(rad), r.saturating_sub(rad));
                let (c1, r1) = ((c + rad + 1).min(w), (r + rad + 1).min(h));
                let valid =
                    sat[r1 * stride + c1] + sat[r0 * stride + c0] - sat[r0 * stride + c1] - sat[r1 * stride + c0];
                let share = valid as Real / ((2 * rad + 1) * (2 * rad + 1)) as Real;
                if share > best.0 + 1e-12 {
                    best = (share, rad);
                }
            }
            best.1
        })
        .collect()
}

/// One pass of eq. 4.6 (eq. 4.3 when `frames` holds only the current one): the new positions of the
/// current grid's cells.
fn filter_pass(
    current: &RangeGrid,
    frames: &[FrameTerm<'_>],
    dirs: &[Vector3],
    params: &DenoiseParams,
) -> Vec<rig::math::Point3> {
    let (w, h) = (current.width, current.height);
    let n = w * h;
    let radius = if params.adaptive { adaptive_radius(current, params.window) } else { vec![params.window; n] };
    let r = params.window as isize;
    let jobs: Vec<(usize, isize, isize)> =
        (0..frames.len()).flat_map(|k| (-r..=r).flat_map(move |dr| (-r..=r).map(move |dc| (k, dc, dr)))).collect();
    // Parallel over (frame, offset): each job adds its pairs' weights into per-thread sums.
    let (num, den, _) = jobs
        .par_iter()
        .fold(
            || (vec![0.0; n], vec![0.0; n], PairTable::default()),
            |(mut num, mut den, mut table), &(k, dc, dr)| {
                let f = &frames[k];
                let non_local = matches!(params.similarity, Similarity::NonLocal { .. });
                if non_local {
                    table.fill(current, f.grid, dc, dr);
                }
                let reach = dc.unsigned_abs().max(dr.unsigned_abs());
                let (inv_d2, inv_s2) = (1.0 / (f.d * f.d), 1.0 / (f.s * f.s));
                for row in 0..h {
                    let jr = row as isize + dr;
                    if !(0..h as isize).contains(&jr) {
                        continue;
                    }
                    for col in 0..w {
                        let i = row * w + col;
                        let jc = col as isize + dc;
                        if !current.valid[i] || radius[i] < reach || !(0..w as isize).contains(&jc) {
                            continue;
                        }
                        let j = jr as usize * w + jc as usize;
                        let d = dirs[i];
                        if !f.grid.valid[j] || d.norm_squared() == 0.0 {
                            continue;
                        }
                        let diff = current.points[i] - f.grid.points[j];
                        let height = diff.dot(&d);
                        // Eq. 4.4 writes Φ_s = exp(−Sim²/s²) with eq. 4.5's Sim a mean of squared heights;
                        // as in NL-means (eq. 4.2) that is exp(−Sim/s²), the squared patch distance over s².
                        let sim = match params.similarity {
                            Similarity::NonLocal { half } => match similarity(&table.patch(col, row, half), &d) {
                                Some(s) => s,
                                None => continue,
                            },
                            Similarity::Bilateral => height * height,
                        };
                        // Φ_d·Φ_s as one exponential.
                        let wgt = f.psi * (-(diff.norm_squared() * inv_d2 + sim * inv_s2)).exp();
                        num[i] += wgt * height;
                        den[i] += wgt;
                    }
                }
                (num, den, table)
            },
        )
        .reduce(
            || (vec![0.0; n], vec![0.0; n], PairTable::default()),
            |(mut a, mut b, t), (c, d, _)| {
                a.iter_mut().zip(&c).for_each(|(x, y)| *x += y);
                b.iter_mut().zip(&d).for_each(|(x, y)| *x += y);
                (a, b, t)
            },
        );
    (0..n)
        .map(|i| {
            if current.valid[i] && den[i] > 0.0 {
                current.points[i] - dirs[i] * (num[i] / den[i])
            } else {
                current.points[i]
            }
        })
        .collect()
}

fn check(grid: &RangeGrid) -> Result<(), DenoiseError> {
    let v = grid.valid_count();
    if v < 16 { Err(DenoiseError::TooFewPoints(v)) } else { Ok(()) }
}

/// Denoises one range grid (eq. 4.3). Returns the filtered grid (normals re-estimated if the input had
/// them) and what was done.
pub fn denoise(grid: &RangeGrid, params: &DenoiseParams) -> Result<(RangeGrid, DenoiseReport), DenoiseError> {
    denoise_sequence(std::slice::from_ref(grid), 0, 0, params)
}

/// Denoises frame `current` of a sequence using the frames within `temporal` of it (eq. 4.6): Ψ_dk =
/// (1/2)^|k−c| and Ψ_sk = exp(−s_k²/max s²), with bandwidths estimated per frame. Frames must share the
/// current frame's grid size (the same sensor); the other frames are read, not filtered.
pub fn denoise_sequence(
    frames: &[RangeGrid],
    current: usize,
    temporal: usize,
    params: &DenoiseParams,
) -> Result<(RangeGrid, DenoiseReport), DenoiseError> {
    let start = Instant::now();
    let cur = frames.get(current).ok_or(DenoiseError::NoSuchFrame(current))?;
    check(cur)?;
    for (k, f) in frames.iter().enumerate() {
        if (f.width, f.height) != (cur.width, cur.height) {
            return Err(DenoiseError::SizeMismatch {
                frame: k,
                w: f.width,
                h: f.height,
                cw: cur.width,
                ch: cur.height,
            });
        }
    }
    let span: Vec<usize> = (current.saturating_sub(temporal)..=(current + temporal).min(frames.len() - 1)).collect();
    let mut out = cur.clone();
    let mut report = DenoiseReport { points: cur.valid_count(), ..Default::default() };
    // Bandwidths of the other frames do not change between passes: only the current frame moves.
    let other_bw: Vec<Option<(Real, Real)>> = span
        .iter()
        .map(|&k| {
            (k != current).then(|| {
                params.bandwidth.unwrap_or_else(|| {
                    let dirs = directions(&frames[k], params.direction, params.normal_window);
                    estimate(&frames[k], &dirs, params.window, BANDWIDTH_SAMPLES, params.seed ^ k as u64)
                })
            })
        })
        .collect();
    for pass in 0..params.iterations.max(1) {
        let t = Instant::now();
        // Normals from one noisy frame tilt from frame to frame, and displacing along a tilted normal
        // moves the point sideways: on a static wall that sideways motion was most of what flickered
        // (total flicker ratio 0.82 where the along-normal part alone was 0.56). Directions from the
        // mean of nearby frames (`direction_frames`) steady it.
        let wide = params.direction_frames.max(temporal);
        let dir_span = current.saturating_sub(wide)..=(current + wide).min(frames.len() - 1);
        let dirs = if span.len() > 1 {
            let mut mean = out.clone();
            for i in 0..mean.points.len() {
                let valid: Vec<&RangeGrid> = dir_span
                    .clone()
                    .map(|k| if k == current { &out } else { &frames[k] })
                    .filter(|g| g.valid[i])
                    .collect();
                if mean.valid[i] && valid.len() > 1 {
                    let sum = valid.iter().fold(rig::math::Vector3::zeros(), |a, g| a + g.points[i].coords);
                    mean.points[i] = rig::math::Point3::from(sum / valid.len() as Real);
                }
            }
            directions(&mean, params.direction, params.normal_window)
        } else {
            directions(&out, params.direction, params.normal_window)
        };
        report.seconds_directions += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let own = params
            .bandwidth
            .unwrap_or_else(|| estimate(&out, &dirs, params.window, BANDWIDTH_SAMPLES, params.seed ^ pass as u64));
        report.seconds_bandwidth += t.elapsed().as_secs_f64();
        let bw: Vec<(Real, Real)> = other_bw.iter().map(|b| b.unwrap_or(own)).collect();
        let s_max = bw.iter().map(|b| b.1).fold(0.0, Real::max);
        let terms: Vec<FrameTerm<'_>> = span
            .iter()
            .zip(&bw)
            .map(|(&k, &(d, s))| FrameTerm {
                grid: if k == current { &out } else { &frames[k] },
                d,
                s,
                psi: 0.5f64.powi((k as i32 - current as i32).abs()) * (-(s * s) / (s_max * s_max)).exp(),
            })
            .collect();
        let t = Instant::now();
        let moved = filter_pass(&out, &terms, &dirs, params);
        report.seconds_filter += t.elapsed().as_secs_f64();
        let sq: Real = moved
            .iter()
            .zip(&out.points)
            .zip(&out.valid)
            .filter(|(_, v)| **v)
            .map(|((m, p), _)| (m - p).norm_squared())
            .sum();
        out.points = moved;
        report.d_mm.push(own.0);
        report.s_mm.push(own.1);
        report.rms_displacement_mm.push((sq / report.points as Real).sqrt());
    }
    if out.normals.is_some() {
        out.normals = Some(super::directions::least_squares_normals(&out, params.normal_window));
    }
    report.seconds = start.elapsed().as_secs_f64();
    Ok((out, report))
}
