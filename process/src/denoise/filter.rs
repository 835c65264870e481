//! The weighted averages of eq. 4.3 (one frame) and eq. 4.6 (a sequence).

use super::bandwidth::estimate;
use super::directions::{direction_at, directions};
use super::noise::measure;
use super::patch::PatchSums;
use super::planes::{Directions, Planes, valid_mean};
use super::weights::{Bandwidths, Cells, Centre, accumulate_row};
use super::{DenoiseError, DenoiseParams, DenoiseReport, Similarity};
use rayon::prelude::*;
use rig::RangeGrid;
use rig::math::{Point3, Real, Vector3};
use std::time::Instant;

/// Random samples for the automatic bandwidths.
const BANDWIDTH_SAMPLES: usize = 2000;

/// One frame's part in a filtering pass: the grid, its bandwidths and its weight Ψ_dk·Ψ_sk.
struct FrameTerm<'a> {
    grid: &'a RangeGrid,
    /// Whether this is the frame being filtered.
    current: bool,
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
            let window = |rad: usize| {
                let (c0, r0) = (c.saturating_sub(rad), r.saturating_sub(rad));
                let (c1, r1) = ((c + rad + 1).min(w), (r + rad + 1).min(h));
                sat[r1 * stride + c1] + sat[r0 * stride + c0] - sat[r0 * stride + c1] - sat[r1 * stride + c0]
            };
            // Most cells: the whole largest window is valid.
            if window(max) as usize == (2 * max + 1) * (2 * max + 1) {
                return max;
            }
            let mut best = (0.0, max);
            for rad in (1..=max).rev() {
                let share = window(rad) as Real / ((2 * rad + 1) * (2 * rad + 1)) as Real;
                if share > best.0 + 1e-12 {
                    best = (share, rad);
                }
            }
            best.1
        })
        .collect()
}

/// A job of a pass: the pairs (x in the current frame, x + (dc, dr) in frame `frame`); with `back`, the
/// pairs the other way round too (single frame, the opposite offset).
struct Job {
    frame: usize,
    dc: isize,
    dr: isize,
    back: bool,
}

/// Rows per band. A pass works band by band, every job on one band before the next, so the band's rows
/// of the planes and sums stay in cache across the jobs; bands run in parallel.
const BAND: usize = 32;

/// One band's sums: Σ w·h and Σ w of the centres, then of the centres taken the other way round, for
/// grid rows `lo..hi` (the band and the rows its pairs reach).
struct BandSums {
    lo: usize,
    hi: usize,
    sums: [Vec<f32>; 4],
}

/// One pass of eq. 4.6 (eq. 4.3 when `frames` holds only the current one): the new positions of the
/// current grid's cells.
fn filter_pass(current: &RangeGrid, frames: &[FrameTerm<'_>], dirs: &[Vector3], params: &DenoiseParams) -> Vec<Point3> {
    let (w, h) = (current.width, current.height);
    let n = w * h;
    let radius = if params.adaptive { adaptive_radius(current, params.window) } else { vec![params.window; n] };
    let origin = valid_mean(current);
    let planes: Vec<Planes> = frames.par_iter().map(|f| Planes::new(f.grid, &origin)).collect();
    let directions = Directions::new(current, dirs, &radius);
    let r = params.window as isize;
    let mut jobs = Vec::new();
    for (k, f) in frames.iter().enumerate() {
        for dr in -r..=r {
            for dc in -r..=r {
                // On the current frame the pair at −δ is the pair at δ the other way round, and δ = 0
                // pairs each point with itself (weight Ψ, height 0): added below.
                let skip = f.current && (dr < 0 || (dr == 0 && dc <= 0));
                if !skip {
                    jobs.push(Job { frame: k, dc, dr, back: f.current });
                }
            }
        }
    }
    let half = match params.similarity {
        Similarity::NonLocal { half } => Some(half),
        Similarity::Bilateral => None,
    };
    let cur = frames.iter().position(|f| f.current).expect("the current frame is among the terms");
    let bands: Vec<BandSums> = (0..h)
        .step_by(BAND)
        .collect::<Vec<_>>()
        .into_par_iter()
        .map(|r0| {
            let r1 = (r0 + BAND).min(h);
            let (lo, hi) = (r0.saturating_sub(params.window), (r1 + params.window).min(h));
            let mut band = BandSums { lo, hi, sums: std::array::from_fn(|_| vec![0.0; (hi - lo) * w]) };
            let mut sums = half.map(|half| PatchSums::new(w, h, half));
            for job in &jobs {
                let f = &frames[job.frame];
                let bw = Bandwidths {
                    inv_d2: (1.0 / (f.d * f.d)) as f32,
                    inv_s2: (1.0 / (f.s * f.s)) as f32,
                    psi: f.psi as f32,
                    reach: job.dc.unsigned_abs().max(job.dr.unsigned_abs()) as f32,
                };
                let (cur, other) = (&planes[cur], &planes[job.frame]);
                run_job(job, cur, other, &directions, sums.as_mut(), bw, r0..r1, &mut band);
            }
            band
        })
        .collect();
    // Bands are added in order, so the result does not depend on the number of threads.
    let (mut num, mut den) = (vec![0.0f32; n], vec![0.0f32; n]);
    for b in &bands {
        let rows = b.lo * w..b.hi * w;
        let [fnum, fden, bnum, bden] = &b.sums;
        num[rows.clone()].iter_mut().zip(fnum).zip(bnum).for_each(|((t, a), c)| *t += a + c);
        den[rows].iter_mut().zip(fden).zip(bden).for_each(|((t, a), c)| *t += a + c);
    }
    let psi_current = frames[cur].psi;
    (0..n)
        .into_par_iter()
        .map(|i| {
            if !current.valid[i] || directions.reach[i] < 0.0 {
                return current.points[i];
            }
            current.points[i] - dirs[i] * (f64::from(num[i]) / (psi_current + f64::from(den[i])))
        })
        .collect()
}

/// Adds one job's pairs with centres in rows `rows` to `band`.
#[allow(clippy::too_many_arguments)]
fn run_job(
    job: &Job,
    cur: &Planes,
    other: &Planes,
    dirs: &Directions,
    sums: Option<&mut PatchSums>,
    bw: Bandwidths,
    rows: std::ops::Range<usize>,
    band: &mut BandSums,
) {
    let (w, h) = (cur.w, cur.h);
    let (dc, dr) = (job.dc, job.dr);
    let (c0, c1) = ((-dc).max(0) as usize, (w as isize - dc).min(w as isize).max(0) as usize);
    if c0 >= c1 {
        return;
    }
    let (j0, j1) = ((c0 as isize + dc) as usize, (c1 as isize + dc) as usize);
    let lo = band.lo;
    let [num, den, bnum, bden] = &mut band.sums;
    fn cells(p: &Planes, r: usize, a: usize, b: usize) -> Cells<'_> {
        let [x, y, z, m] = p.row(r, a, b);
        Cells { x, y, z, m }
    }
    let mut row = |r: usize, patch: Option<&[f32]>| {
        let jr = r as isize + dr;
        if !(0..h as isize).contains(&jr) {
            return;
        }
        let jr = jr as usize;
        let (ri, rj) = ((r - lo) * w, (jr - lo) * w);
        let [dx, dy, dz, reach] = dirs.row(w, r, c0, c1);
        let centre = Centre { dx, dy, dz, reach, num: &mut num[ri + c0..ri + c1], den: &mut den[ri + c0..ri + c1] };
        let back = job.back.then(|| {
            let [dx, dy, dz, reach] = dirs.row(w, jr, j0, j1);
            Centre { dx, dy, dz, reach, num: &mut bnum[rj + j0..rj + j1], den: &mut bden[rj + j0..rj + j1] }
        });
        let patch = patch.map(|b| std::array::from_fn(|k| &b[k * w + c0..k * w + c1]));
        accumulate_row(centre, cells(cur, r, c0, c1), cells(other, jr, j0, j1), patch, back, bw);
    };
    match sums {
        Some(sums) => sums.for_each_row(cur, other, (dc, dr), rows, |r, b| row(r, Some(b))),
        None => rows.for_each(|r| row(r, None)),
    }
}

/// The valid cells without a valid 8-neighbour.
fn lone_cells(grid: &RangeGrid) -> Vec<usize> {
    let (w, h) = (grid.width, grid.height);
    (0..w * h)
        .into_par_iter()
        .filter(|&i| grid.valid[i])
        .filter(|&i| {
            let (c, r) = (i % w, i / w);
            !(r.saturating_sub(1)..=(r + 1).min(h - 1))
                .flat_map(|rr| (c.saturating_sub(1)..=(c + 1).min(w - 1)).map(move |cc| rr * w + cc))
                .any(|j| j != i && grid.valid[j])
        })
        .collect()
}

/// Marks invalid the valid cells without a valid 8-neighbour; returns how many.
fn drop_isolated(grid: &mut RangeGrid) -> usize {
    let lone = lone_cells(grid);
    invalidate(grid, &lone);
    lone.len()
}

/// Marks `cells` invalid (NaN positions, as `RangeGrid::empty` has them).
fn invalidate(grid: &mut RangeGrid, cells: &[usize]) {
    for &i in cells {
        grid.valid[i] = false;
        grid.points[i] = Point3::new(Real::NAN, Real::NAN, Real::NAN);
    }
}

fn check(grid: &RangeGrid) -> Result<(), DenoiseError> {
    let v = grid.valid_count();
    if v < 16 { Err(DenoiseError::TooFewPoints(v)) } else { Ok(()) }
}

/// A hand bandwidth below this fraction of section 4.3.2's automatic one over 3 × 3 cells (d about
/// 1.06 cell spacings on a surface facing the sensor, s the noise of a cell against its plane) weighs
/// the nearest neighbours next to nothing (d: about e^-14 there): the filter would return the grid
/// all but unchanged, which a bandwidth in the wrong unit (metres on a grid in mm) gives.
const LEAST_BANDWIDTH_SHARE: Real = 0.25;

/// Refuses bandwidths given by hand that would move next to nothing on `grid`, measured against
/// section 4.3.2's automatic ones over the nearest cells (3 × 3, whatever the neighbourhood: a wider
/// one would raise d with its reach, not with the spacing). s only for the non-local similarity:
/// the bilateral filter's still weighs neighbours at the point's own height fully. A grid too sparse
/// to measure is not judged.
fn check_bandwidth(grid: &RangeGrid, params: &DenoiseParams) -> Result<(), DenoiseError> {
    let Some((d, s)) = params.bandwidth else { return Ok(()) };
    let dir = |i| direction_at(grid, params.direction, params.normal_window, i);
    let Some((own_d, own_s)) = super::bandwidth::measured(grid, dir, 1, BANDWIDTH_SAMPLES, params.seed) else {
        return Ok(());
    };
    let non_local = matches!(params.similarity, Similarity::NonLocal { .. });
    let checked = [("d", d, own_d)].into_iter().chain(non_local.then_some(("s", s, own_s)));
    for (which, given, own) in checked {
        let least = LEAST_BANDWIDTH_SHARE * own;
        if given < least {
            return Err(DenoiseError::BandwidthTooSmall { which, given, own, least });
        }
    }
    Ok(())
}

/// Denoises one range grid (eq. 4.3). Returns the filtered grid (normals re-estimated if the input had
/// them) and what was done.
pub fn denoise(grid: &RangeGrid, params: &DenoiseParams) -> Result<(RangeGrid, DenoiseReport), DenoiseError> {
    denoise_sequence(std::slice::from_ref(grid), 0, 0, params)
}

/// Refuses frames whose grid is not the current frame's size (another sensor).
fn check_sizes(frames: &[RangeGrid], cur: &RangeGrid) -> Result<(), DenoiseError> {
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
    Ok(())
}

/// `out` with each valid cell at the mean of that cell over `grids` (where two or more have it).
fn frame_mean(out: &RangeGrid, grids: &[&RangeGrid]) -> RangeGrid {
    let mut mean = out.clone();
    mean.points.par_iter_mut().enumerate().for_each(|(i, p)| {
        if !out.valid[i] {
            return;
        }
        let (sum, count) = grids
            .iter()
            .filter(|g| g.valid[i])
            .fold((Vector3::zeros(), 0usize), |(s, n), g| (s + g.points[i].coords, n + 1));
        if count > 1 {
            *p = Point3::from(sum / count as Real);
        }
    });
    mean
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
    check_sizes(frames, cur)?;
    let span: Vec<usize> = (current.saturating_sub(temporal)..=(current + temporal).min(frames.len() - 1)).collect();
    let wide = params.direction_frames.max(temporal);
    let dir_span = current.saturating_sub(wide)..=(current + wide).min(frames.len() - 1);
    // The other frames read, without their lone cells too: a flying pixel in a neighbouring frame
    // would otherwise spoil the frame mean the directions come from, and serve as a neighbour.
    let others: Vec<Option<RangeGrid>> = (0..frames.len())
        .map(|k| {
            // Copied only where there is something to drop.
            let wanted = k != current && params.drop_isolated && dir_span.contains(&k);
            let lone = if wanted { lone_cells(&frames[k]) } else { Vec::new() };
            (!lone.is_empty()).then(|| {
                let mut g = frames[k].clone();
                invalidate(&mut g, &lone);
                g
            })
        })
        .collect();
    let frame = |k: usize| others[k].as_ref().unwrap_or(&frames[k]);
    let mut out = cur.clone();
    let isolated_dropped = if params.drop_isolated { drop_isolated(&mut out) } else { 0 };
    // Counted again without the lone cells: a grid of specks has nothing left to filter.
    check(&out)?;
    // Sizes from the noise (a grid too small to measure keeps the fixed ones). Sequences keep the
    // thesis's setting: sized from the noise, two passes over ±1 frames left the test sequence's RMS
    // error at 0.0562 mm against the thesis's 0.0532 (its flicker lower, 0.026 against 0.035 mm), and
    // one pass flickered more than filtering each frame alone.
    let level = (params.from_noise && span.len() == 1).then(|| measure(&out)).flatten();
    let sized = level.map(|level| params.sized_for(&level));
    let s_from_noise = sized.and_then(|(_, s)| s);
    let params = &sized.map_or(*params, |(p, _)| p);
    check_bandwidth(&out, params)?;
    let mut report = DenoiseReport {
        points: out.valid_count(),
        isolated_dropped,
        noise: level,
        window: params.window,
        patch: match params.similarity {
            Similarity::NonLocal { half } => half,
            Similarity::Bilateral => 0,
        },
        iterations: params.iterations.max(1),
        ..Default::default()
    };
    // Bandwidths of the other frames do not change between passes: only the current frame moves.
    let other_bw: Vec<Option<(Real, Real)>> = span
        .iter()
        .map(|&k| {
            (k != current).then(|| {
                params.bandwidth.unwrap_or_else(|| {
                    let g = frame(k);
                    let dir = |i| direction_at(g, params.direction, params.normal_window, i);
                    estimate(g, dir, params.window, BANDWIDTH_SAMPLES, params.seed ^ k as u64)
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
        let dirs = if span.len() > 1 {
            let grids: Vec<&RangeGrid> = dir_span.clone().map(|k| if k == current { &out } else { frame(k) }).collect();
            directions(&frame_mean(&out, &grids), params.direction, params.normal_window)
        } else {
            directions(&out, params.direction, params.normal_window)
        };
        report.seconds_directions += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let own = params.bandwidth.unwrap_or_else(|| {
            let (d, s) = estimate(&out, |i| dirs[i], params.window, BANDWIDTH_SAMPLES, params.seed ^ pass as u64);
            (d, s_from_noise.unwrap_or(s))
        });
        report.seconds_bandwidth += t.elapsed().as_secs_f64();
        let bw: Vec<(Real, Real)> = other_bw.iter().map(|b| b.unwrap_or(own)).collect();
        let s_max = bw.iter().map(|b| b.1).fold(0.0, Real::max);
        let terms: Vec<FrameTerm<'_>> = span
            .iter()
            .zip(&bw)
            .map(|(&k, &(d, s))| FrameTerm {
                grid: if k == current { &out } else { frame(k) },
                current: k == current,
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
        report.d.push(own.0);
        report.s.push(own.1);
        report.rms_displacement.push((sq / report.points as Real).sqrt());
    }
    if out.normals.is_some() {
        out.normals = Some(super::directions::least_squares_normals(&out, params.normal_window));
    }
    report.seconds = start.elapsed().as_secs_f64();
    Ok((out, report))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::denoise::directions::least_squares_normals;
    use rig::Sensor;

    #[test]
    fn lone_cells_are_dropped_and_counted() {
        let mut g = RangeGrid::empty(6, 5, Sensor::Center(Point3::origin()));
        for i in [0usize, 7, 8, 14, 29, 11] {
            g.valid[i] = true;
            g.points[i] = Point3::new(i as Real, 0.0, 100.0);
        }
        // 0 touches 7 diagonally and 7, 8, 14 touch each other; 11 and 29 (a corner) are alone.
        assert_eq!(drop_isolated(&mut g), 2);
        assert_eq!((0..30).filter(|&i| g.valid[i]).collect::<Vec<_>>(), vec![0, 7, 8, 14]);
        assert!(g.points[11].x.is_nan() && g.points[29].x.is_nan());
    }

    /// A wavy, noisy grid with holes (spacing 0.5, noise ±0.1), shifted a little per frame.
    fn frame(seed: u64, shift: f64) -> RangeGrid {
        frame_with(seed, shift, 0.5, 0.2, 2.0)
    }

    fn frame_with(seed: u64, shift: f64, spacing: f64, noise_amplitude: f64, wave: f64) -> RangeGrid {
        let (w, h) = (41usize, 37usize);
        let mut g = RangeGrid::empty(w, h, Sensor::Center(Point3::origin()));
        let mut rng = fixtures::Lcg::new(seed);
        for i in 0..w * h {
            let noise = (rng.uniform() - 0.5) * noise_amplitude;
            let (c, r) = ((i % w) as f64 * spacing, (i / w) as f64 * spacing);
            g.points[i] = Point3::new(
                c - 10.0,
                r - 9.0,
                300.0 + shift + wave * (c * 0.4).sin() * (r * 0.3).cos() + 0.3 * c + noise,
            );
            g.valid[i] = i % 23 != 7 && !(10..14).contains(&(i % w)) || i / w > 30;
        }
        g
    }

    /// Eqs. 4.3–4.6 summed directly in double precision, pair by pair.
    fn reference(frames: &[FrameTerm<'_>], dirs: &[Vector3], params: &DenoiseParams) -> Vec<Point3> {
        let cur = frames.iter().find(|f| f.current).unwrap().grid;
        let (w, h) = (cur.width as isize, cur.height as isize);
        let radius =
            if params.adaptive { adaptive_radius(cur, params.window) } else { vec![params.window; cur.points.len()] };
        let at = |c: isize, r: isize| ((0..w).contains(&c) && (0..h).contains(&r)).then(|| (r * w + c) as usize);
        (0..cur.points.len())
            .map(|i| {
                let (d, p) = (dirs[i], cur.points[i]);
                if !cur.valid[i] || d.norm_squared() == 0.0 {
                    return p;
                }
                let (c, r) = (i as isize % w, i as isize / w);
                let reach = radius[i] as isize;
                let (mut num, mut den) = (0.0, 0.0);
                for f in frames {
                    for dr in -reach..=reach {
                        for dc in -reach..=reach {
                            let Some(j) = at(c + dc, r + dr).filter(|&j| f.grid.valid[j]) else { continue };
                            let diff = p - f.grid.points[j];
                            let height = diff.dot(&d);
                            let sim = match params.similarity {
                                Similarity::Bilateral => height * height,
                                Similarity::NonLocal { half } => {
                                    let (hf, mut sum, mut n) = (half as isize, 0.0, 0.0);
                                    for or in -hf..=hf {
                                        for oc in -hf..=hf {
                                            let a = at(c + oc, r + or).filter(|&a| cur.valid[a]);
                                            let b = at(c + dc + oc, r + dr + or).filter(|&b| f.grid.valid[b]);
                                            if let (Some(a), Some(b)) = (a, b) {
                                                sum += ((cur.points[a] - f.grid.points[b]).dot(&d)).powi(2);
                                                n += 1.0;
                                            }
                                        }
                                    }
                                    sum / n
                                }
                            };
                            let wgt = f.psi * (-(diff.norm_squared() / (f.d * f.d) + sim / (f.s * f.s))).exp();
                            num += wgt * height;
                            den += wgt;
                        }
                    }
                }
                p - d * (num / den)
            })
            .collect()
    }

    /// The banded, symmetric, single-precision pass against the direct sums, for the non-local and the
    /// bilateral filter, one frame and three.
    #[test]
    fn the_fast_pass_equals_the_direct_sums() {
        let grids = [frame(1, -0.05), frame(2, 0.0), frame(3, 0.04)];
        let dirs = least_squares_normals(&grids[1], 1);
        for similarity in [Similarity::NonLocal { half: 2 }, Similarity::NonLocal { half: 1 }, Similarity::Bilateral] {
            for (first, last) in [(1usize, 1usize), (0, 2)] {
                let params = DenoiseParams { similarity, window: 3, ..DenoiseParams::thesis() };
                let terms: Vec<FrameTerm<'_>> = (first..=last)
                    .map(|k| FrameTerm {
                        grid: &grids[k],
                        current: k == 1,
                        d: 1.4 + 0.1 * k as Real,
                        s: 0.12 + 0.02 * k as Real,
                        psi: 0.5f64.powi((k as i32 - 1).abs()),
                    })
                    .collect();
                let fast = filter_pass(&grids[1], &terms, &dirs, &params);
                let slow = reference(&terms, &dirs, &params);
                let (mut worst, mut moved): (Real, Real) = (0.0, 0.0);
                for i in (0..fast.len()).filter(|&i| grids[1].valid[i]) {
                    worst = worst.max((fast[i] - slow[i]).norm());
                    moved = moved.max((slow[i] - grids[1].points[i]).norm());
                }
                assert!(moved > 0.05, "{similarity:?}, frames {first}..={last}: the filter moves points ({moved})");
                assert!(worst < 1e-5, "{similarity:?}, frames {first}..={last}: off by {worst} mm");
            }
        }
    }

    /// Single precision where it is weakest: a tilted plane with noise 1000 times below the grid spacing,
    /// so the patch similarity is a small difference of large sums of squared offsets (cancellation
    /// ~10⁶).
    #[test]
    fn the_fast_pass_holds_at_low_noise() {
        let grid = frame_with(5, 0.0, 1.0, 0.004, 0.0);
        let dirs = least_squares_normals(&grid, 1);
        let params = DenoiseParams::default();
        let terms = [FrameTerm { grid: &grid, current: true, d: 3.0, s: 0.002, psi: 1.0 }];
        let fast = filter_pass(&grid, &terms, &dirs, &params);
        let slow = reference(&terms, &dirs, &params);
        let (mut worst, mut moved): (Real, Real) = (0.0, 0.0);
        for i in (0..fast.len()).filter(|&i| grid.valid[i]) {
            worst = worst.max((fast[i] - slow[i]).norm());
            moved = moved.max((slow[i] - grid.points[i]).norm());
        }
        eprintln!("low noise: moved up to {moved:.2e}, fast vs direct {worst:.2e}");
        assert!(moved > 5e-4, "the filter moves points ({moved})");
        assert!(worst < 0.02 * moved, "off by {worst} where points move {moved}");
    }

    /// A bandwidth in the wrong unit (metres on a grid in mm) would weigh no neighbour and return the
    /// grid unchanged: refused, naming which bandwidth and the least that moves anything.
    #[test]
    fn bandwidths_that_would_move_nothing_are_refused() {
        let grid = frame(4, 0.0);
        let by_hand = |d, s| DenoiseParams { bandwidth: Some((d, s)), ..DenoiseParams::thesis() };
        for (d, s, which) in [(1e-9, 1e-9, "d"), (0.1, 0.1, "d"), (1.4, 1e-4, "s")] {
            match denoise(&grid, &by_hand(d, s)) {
                Err(DenoiseError::BandwidthTooSmall { which: w, own, least, .. }) => {
                    assert_eq!(w, which, "({d}, {s})");
                    assert!((least - 0.25 * own).abs() < 1e-12 && own > 0.0, "{own} {least}");
                }
                other => panic!("({d}, {s}): expected a refusal of {which}, got {other:?}"),
            }
        }
        // The grid's own bandwidths, d under one cell's spacing (0.5) with the 7 × 7 window, and far
        // larger ones (the similarity switched off) still filter.
        let (_, own) = denoise(&grid, &DenoiseParams::thesis()).unwrap();
        for (d, s) in [(own.d[0], own.s[0]), (0.4, own.s[0]), (1e3, 1e3)] {
            let (_, report) = denoise(&grid, &by_hand(d, s)).unwrap();
            assert!(report.rms_displacement[0] > 0.01, "({d}, {s}) moves points: {:?}", report.rms_displacement);
        }
        // The bilateral filter's similarity still weighs neighbours at the point's height: its s is
        // not judged.
        let bilateral = DenoiseParams { similarity: Similarity::Bilateral, ..by_hand(own.d[0], 1e-9) };
        assert!(denoise(&grid, &bilateral).is_ok());
    }
}
