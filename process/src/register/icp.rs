//! Robust point-to-plane ICP (thesis ch. 2.2): registers a moving cloud to a target from a starting pose
//! (the turntable's), with the correspondence distance shrinking over the iterations, Tukey weights on
//! the point-to-plane residuals, and correspondences rejected at the target's boundary (where overlap
//! ends and nearest points lie) and where the two normals disagree (steep, or the other side).
//!
//! Each iteration solves the linearised point-to-plane problem: with `p = T·m`, target point `q` and
//! normal `n`, the residual `r = (p − q)·n` changes by `(p × n)·ω + n·t` under a small rotation ω and
//! translation t, a 6 × 6 weighted least-squares system.

use crate::kd_tree::PointTree;
use nalgebra::{Matrix6, Vector6};
use rayon::prelude::*;
use rig::math::{Isometry3, Point3, Real, Translation3, UnitQuaternion, Vector3};
use serde::Serialize;

/// Sample points per partial sum of an ICP iteration.
const SUM_CHUNK: usize = 1024;

/// The target of a registration: points, unit normals and boundary flags, with its k-d tree built once.
pub struct IcpTarget {
    points: Vec<Point3>,
    normals: Vec<Vector3>,
    boundary: Vec<bool>,
    tree: PointTree,
}

impl IcpTarget {
    /// A target; `boundary` marks points at the edge of the scan (`None`: no point is).
    pub fn new(points: Vec<Point3>, normals: Vec<Vector3>, boundary: Option<Vec<bool>>) -> Self {
        let tree = PointTree::new(&points);
        let boundary = boundary.unwrap_or_else(|| vec![false; points.len()]);
        IcpTarget { points, normals, boundary, tree }
    }

    /// Number of target points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True without points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The nearest target point to `p`: its index and squared distance.
    pub fn nearest(&self, p: &Point3) -> (usize, Real) {
        self.tree.nearest(p)
    }

    /// Target point `j`.
    pub fn point(&self, j: usize) -> Point3 {
        self.points[j]
    }

    /// Target point `j`'s unit normal.
    pub fn normal(&self, j: usize) -> Vector3 {
        self.normals[j]
    }
}

/// ICP settings. Lengths are in the data's units (the defaults suit millimetres).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct IcpParams {
    /// Most iterations.
    pub max_iterations: usize,
    /// Correspondence distance at the first iteration: about the largest expected misalignment.
    pub start_distance: Real,
    /// The floor the correspondence distance shrinks to: a few times the point spacing and noise.
    pub min_distance: Real,
    /// Factor applied to the correspondence distance after each iteration.
    pub shrink: Real,
    /// Correspondences whose normals differ by more than this are rejected (degrees).
    pub max_normal_angle_deg: Real,
    /// Moving points used (evenly strided); 0 uses all.
    pub sample: usize,
    /// Stop when an update rotates by less than this (radians) and moves by less than this times
    /// `min_distance`, once the distance has reached its floor.
    pub tolerance: Real,
}

impl Default for IcpParams {
    fn default() -> Self {
        IcpParams {
            max_iterations: 100,
            start_distance: 20.0,
            min_distance: 1.0,
            shrink: 0.85,
            max_normal_angle_deg: 45.0,
            sample: 5000,
            tolerance: 1e-4,
        }
    }
}

/// A Gaussian prior on how far the true pose lies from a known one (the turntable's): the standard
/// deviations of its rotation and translation. With it, ICP minimises the point-to-plane residuals
/// plus the prior's penalty (a MAP estimate) — which changes nothing where the surface fixes the pose,
/// and keeps a view where its turntable put it along directions the surface leaves free: a turned,
/// nearly symmetric object, or two views that overlap little, would otherwise slide to a wrong pose.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PosePrior {
    /// Standard deviation of the rotation (degrees).
    pub rotation_deg: Real,
    /// Standard deviation of the translation (data units).
    pub shift: Real,
}

/// What a registration did.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, serde::Deserialize)]
pub struct IcpReport {
    /// Iterations run.
    pub iterations: usize,
    /// Share of the sampled moving points with an accepted correspondence at the end.
    pub fitness: Real,
    /// RMS point-to-plane residual of the accepted correspondences at the end.
    pub inlier_rmse: Real,
    /// The correspondence distance at the end.
    pub final_distance: Real,
    /// Whether the updates fell below the tolerance.
    pub converged: bool,
}

/// A registration that cannot proceed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum IcpError {
    /// Too few correspondences to fix six degrees of freedom.
    #[error(
        "only {found} correspondences within {distance} of the target at iteration {iteration}; at least 6 are needed"
    )]
    TooFewCorrespondences {
        /// How many were found.
        found: usize,
        /// The correspondence distance then.
        distance: Real,
        /// The iteration.
        iteration: usize,
    },
    /// The correspondences do not constrain all six degrees of freedom (a plane, a line).
    #[error("the correspondences leave the pose undetermined (degenerate geometry)")]
    Degenerate,
    /// A point or normal that is not a finite number: no nearest neighbour or pose can come of it.
    #[error("{which} {index} is not finite (NaN or infinite): drop such points before registering")]
    NonFinite {
        /// Which input: "moving point", "moving normal", "target point", "target normal".
        which: &'static str,
        /// Its index.
        index: usize,
    },
    /// Target points and normals differ in number.
    #[error("{points} target points but {normals} normals")]
    TargetLengthMismatch {
        /// Points.
        points: usize,
        /// Normals.
        normals: usize,
    },
    /// A target without points.
    #[error("the target has no points")]
    EmptyTarget,
    /// Moving points and normals differ in number.
    #[error("{points} moving points but {normals} normals")]
    LengthMismatch {
        /// Points.
        points: usize,
        /// Normals.
        normals: usize,
    },
}

/// Registers `moving` (points with unit normals, in their own frame) to `target`, starting from
/// `initial`; returns the pose mapping moving coordinates into the target frame.
pub fn icp(
    moving: &[Point3],
    moving_normals: &[Vector3],
    target: &IcpTarget,
    initial: &Isometry3,
    params: &IcpParams,
) -> Result<(Isometry3, IcpReport), IcpError> {
    icp_near(moving, moving_normals, target, initial, None, params)
}

/// [`icp`] with a prior: `prior` is the known pose and how far the truth may be from it.
pub fn icp_near(
    moving: &[Point3],
    moving_normals: &[Vector3],
    target: &IcpTarget,
    initial: &Isometry3,
    prior: Option<(&Isometry3, PosePrior)>,
    params: &IcpParams,
) -> Result<(Isometry3, IcpReport), IcpError> {
    if moving.len() != moving_normals.len() {
        return Err(IcpError::LengthMismatch { points: moving.len(), normals: moving_normals.len() });
    }
    if target.points.is_empty() {
        return Err(IcpError::EmptyTarget);
    }
    if target.normals.len() != target.points.len() {
        return Err(IcpError::TargetLengthMismatch { points: target.points.len(), normals: target.normals.len() });
    }
    // The k-d tree's search cannot order NaN distances; such input is refused, not searched.
    let finite = |v: &Vector3| v.iter().all(|c| c.is_finite());
    let inputs: [(&'static str, Option<usize>); 4] = [
        ("moving point", moving.iter().position(|p| !finite(&p.coords))),
        ("moving normal", moving_normals.iter().position(|n| !finite(n))),
        ("target point", target.points.iter().position(|p| !finite(&p.coords))),
        ("target normal", target.normals.iter().position(|n| !finite(n))),
    ];
    if let Some((which, Some(index))) = inputs.into_iter().find(|(_, i)| i.is_some()) {
        return Err(IcpError::NonFinite { which, index });
    }
    let stride = if params.sample == 0 { 1 } else { moving.len().div_ceil(params.sample).max(1) };
    let sample: Vec<usize> = (0..moving.len()).step_by(stride).collect();
    let cos_max = params.max_normal_angle_deg.to_radians().cos();
    let mut pose = *initial;
    let mut distance = params.start_distance.max(params.min_distance);
    let mut report = IcpReport::default();
    for iteration in 0..params.max_iterations {
        // The sums over the sample, in fixed chunks on rayon's threads and added in chunk order:
        // the same pose whatever the number of threads (the k-d queries were 70 % of registering
        // the demo, on one core).
        let partial = |ks: &[usize]| {
            let (mut a, mut b) = (Matrix6::<Real>::zeros(), Vector6::<Real>::zeros());
            let (mut found, mut sq) = (0usize, 0.0);
            for &k in ks {
                let p = pose * moving[k];
                let (j, d2) = target.tree.nearest(&p);
                if d2 > distance * distance || target.boundary[j] {
                    continue;
                }
                let n = target.normals[j];
                if (pose.rotation * moving_normals[k]).dot(&n) < cos_max {
                    continue;
                }
                let r = (p - target.points[j]).dot(&n);
                // Tukey's biweight with the current distance as its scale: far residuals weigh nothing.
                let u = r / distance;
                if u.abs() >= 1.0 {
                    continue;
                }
                let w = (1.0 - u * u).powi(2);
                let jac = Vector6::from_iterator(p.coords.cross(&n).iter().chain(n.iter()).copied());
                a += jac * jac.transpose() * w;
                b -= jac * (w * r);
                found += 1;
                sq += r * r;
            }
            (a, b, found, sq)
        };
        let parts: Vec<_> = sample.par_chunks(SUM_CHUNK).map(partial).collect();
        let (mut a, mut b, found, sq) = parts.into_iter().fold(
            (Matrix6::<Real>::zeros(), Vector6::<Real>::zeros(), 0usize, 0.0),
            |(a, b, f, s), (pa, pb, pf, ps)| (a + pa, b + pb, f + pf, s + ps),
        );
        report.iterations = iteration + 1;
        report.fitness = found as Real / sample.len() as Real;
        report.inlier_rmse = if found > 0 { (sq / found as Real).sqrt() } else { 0.0 };
        report.final_distance = distance;
        if found < 6 {
            return Err(IcpError::TooFewCorrespondences { found, distance, iteration });
        }
        if let Some((known, p)) = prior {
            // The correction c = (θ, τ) from the known pose, penalised by λ|c + x|² with
            // λ = (residual scale / prior deviation)² so both terms are in squared data units; to first
            // order the step x adds to c (the step is applied on the left, in the target frame).
            let c = pose * known.inverse();
            let scale = params.min_distance * params.min_distance;
            let (l_rot, l_t) = (scale / p.rotation_deg.to_radians().powi(2), scale / (p.shift * p.shift));
            let (theta, tau) = (c.rotation.scaled_axis(), c.translation.vector);
            for i in 0..3 {
                a[(i, i)] += l_rot;
                b[i] -= l_rot * theta[i];
                a[(i + 3, i + 3)] += l_t;
                b[i + 3] -= l_t * tau[i];
            }
        }
        let x = a.cholesky().ok_or(IcpError::Degenerate)?.solve(&b);
        let (omega, t) = (Vector3::new(x[0], x[1], x[2]), Vector3::new(x[3], x[4], x[5]));
        let step = Isometry3::from_parts(Translation3::from(t), UnitQuaternion::from_scaled_axis(omega));
        pose = step * pose;
        let small = omega.norm() < params.tolerance && t.norm() < params.tolerance * params.min_distance;
        if small && distance <= params.min_distance {
            report.converged = true;
            break;
        }
        distance = (distance * params.shrink).max(params.min_distance);
    }
    Ok((pose, report))
}
