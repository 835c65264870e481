//! A small dense Levenberg–Marquardt with a forward-difference Jacobian, for the problems here with
//! a handful of unknowns (a board pose, a turntable sweep). The camera's own calibration, with six
//! unknowns per view, keeps its block-structured solver in [`crate::camera_calib`].

use nalgebra::{DMatrix, DVector};
use rig::math::Real;

/// What [`minimize`] reached.
#[derive(Debug, Clone, PartialEq)]
pub struct Minimum {
    /// The parameters.
    pub x: DVector<Real>,
    /// The residuals there.
    pub residuals: Vec<Real>,
    /// Iterations taken.
    pub iterations: usize,
}

/// Minimises the sum of squared `residuals(x)` from `x0` (Marquardt's diagonal damping, at most
/// `max_iterations` steps, stopping when a step gains less than 1e-12 of the cost).
pub fn minimize(x0: DVector<Real>, max_iterations: usize, residuals: impl Fn(&DVector<Real>) -> Vec<Real>) -> Minimum {
    let n = x0.len();
    let mut x = x0;
    let mut r = residuals(&x);
    let mut cost: Real = r.iter().map(|v| v * v).sum();
    let mut mu = 1e-3;
    let mut iterations = 0;
    while iterations < max_iterations {
        iterations += 1;
        let mut jac = DMatrix::zeros(r.len(), n);
        for k in 0..n {
            let h = 1e-7 * x[k].abs().max(1.0);
            let mut xp = x.clone();
            xp[k] += h;
            for (i, (a, b)) in residuals(&xp).iter().zip(&r).enumerate() {
                jac[(i, k)] = (a - b) / h;
            }
        }
        let jtj = jac.transpose() * &jac;
        let jtr = jac.transpose() * DVector::from_column_slice(&r);
        let mut improved = false;
        for _ in 0..10 {
            let mut a = jtj.clone();
            for k in 0..n {
                a[(k, k)] += mu * jtj[(k, k)].max(1e-12);
            }
            let Some(step) = a.cholesky().map(|c| c.solve(&(-&jtr))) else {
                mu *= 10.0;
                continue;
            };
            let xn = &x + step;
            let rn = residuals(&xn);
            let cn: Real = rn.iter().map(|v| v * v).sum();
            if cn < cost {
                let done = cost - cn < 1e-12 * cost;
                (x, r, cost, mu) = (xn, rn, cn, mu / 3.0);
                improved = !done;
                break;
            }
            mu *= 4.0;
        }
        if !improved {
            break;
        }
    }
    Minimum { x, residuals: r, iterations }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fits_an_exponential() {
        // y = a·exp(b·t), a = 2, b = −0.3, from a poor start.
        let t: Vec<Real> = (0..20).map(|k| k as Real * 0.5).collect();
        let y: Vec<Real> = t.iter().map(|t| 2.0 * (-0.3 * t).exp()).collect();
        let m = minimize(DVector::from_vec(vec![1.0, 0.0]), 100, |x| {
            t.iter().zip(&y).map(|(t, y)| x[0] * (x[1] * t).exp() - y).collect()
        });
        assert!((m.x[0] - 2.0).abs() < 1e-6 && (m.x[1] + 0.3).abs() < 1e-6, "{:?}", m.x);
    }
}
