//! Harmonic and quasi-harmonic scalar fields on a triangle mesh (thesis eqs. 6.2 and 6.4).
//!
//! `div(c ∇u) = 0` with `u` prescribed at some vertices, discretised with linear finite elements: the
//! cotangent Laplacian, each face's contribution scaled by its conductivity `c_f` (eq. 6.4; `c ≡ 1` is
//! the harmonic field of eq. 6.2). Prescribed vertices are eliminated and the remaining symmetric
//! positive definite system is solved by faer's sparse Cholesky. Boundaries without prescribed values
//! get the natural (Neumann, no-flux) condition.

use faer::Side;
use faer::prelude::*;
use faer::sparse::{SparseColMat, Triplet};
use rig::TriMesh;
use rig::math::{Real, Vector3};

/// Why a field could not be solved.
#[derive(Debug, thiserror::Error)]
pub enum FieldError {
    /// Nothing is prescribed: the field is only defined up to a constant.
    #[error("no vertex has a prescribed value; at least one is needed")]
    NoConstraints,
    /// A prescribed vertex index is out of range.
    #[error("prescribed vertex {0} is not in the mesh ({1} vertices)")]
    BadVertex(usize, usize),
    /// The conductivity list does not have one value per face, or has a negative or non-finite one.
    #[error("conductivity: {0}")]
    Conductivity(String),
    /// A part of the mesh has no prescribed vertex, or the system is otherwise singular.
    #[error("the system is singular: every connected part of the mesh needs a prescribed vertex ({0})")]
    Singular(String),
}

/// A conductivity this small relative to the largest stands in for 0 (an insulator), which would
/// leave the vertices inside the region without an equation.
const INSULATOR: Real = 1e-9;

/// Solves `div(c ∇u) = 0` with `u[v] = value` for every `(v, value)` in `fixed`; `conductivity` is one
/// non-negative value per face (`None`: all 1). Returns one value per vertex.
pub fn harmonic_field(
    mesh: &TriMesh,
    conductivity: Option<&[Real]>,
    fixed: &[(usize, Real)],
) -> Result<Vec<Real>, FieldError> {
    constrained_field(mesh, conductivity, fixed, &[], 0.0)
}

/// [`harmonic_field`] with line constraints (eq. 6.3): for each mesh edge `(a, b)` of a constraint
/// line, `⟨∇u, b − a⟩ = 0` — which, as u is linear along the edge, is `u_a = u_b`, so a contour runs
/// along the line. The constraint rows, scaled by `weight`, join the Laplace rows in one least-squares
/// system solved through its normal equations; where constraints and prescribed values disagree, the
/// weight sets the compromise.
pub fn constrained_field(
    mesh: &TriMesh,
    conductivity: Option<&[Real]>,
    fixed: &[(usize, Real)],
    lines: &[(usize, usize)],
    weight: Real,
) -> Result<Vec<Real>, FieldError> {
    let rows: Vec<Vec<(usize, Real)>> = lines.iter().map(|&(a, b)| vec![(a, 1.0), (b, -1.0)]).collect();
    field_with_rows(mesh, conductivity, fixed, &rows, weight)
}

/// The general form of [`constrained_field`]: each row `Σ c_v u_v = 0` (a list of `(v, c_v)`) is one
/// extra least-squares equation, scaled by `weight`. Gradient constraints other than contours — the
/// gradient along a line, `⟨∇u, n × t⟩ = 0` in the faces beside it — are rows of this kind.
pub fn field_with_rows(
    mesh: &TriMesh,
    conductivity: Option<&[Real]>,
    fixed: &[(usize, Real)],
    lines: &[Vec<(usize, Real)>],
    weight: Real,
) -> Result<Vec<Real>, FieldError> {
    let system = LaplaceSystem::new(mesh, conductivity, fixed)?;
    if lines.is_empty() { system.solve() } else { system.solve_with_rows(lines, weight, None) }
}

/// The Laplace equations of a mesh with prescribed values (eqs. 6.2, 6.4), over its free vertices:
/// assembled once, solved alone ([`LaplaceSystem::solve`]) or with extra rows in least squares
/// ([`LaplaceSystem::solve_with_rows`]). The remesher solves both on the same system, the second
/// prepared while the first is solved ([`LaplaceSystem::normal_plan`]).
pub struct LaplaceSystem {
    /// The matrix over the free vertices (symmetric); `None` when every vertex is prescribed.
    matrix: Option<SparseColMat<usize, Real>>,
    rhs: Vec<Real>,
    /// Each vertex's unknown, `usize::MAX` when prescribed.
    unknown: Vec<usize>,
    /// Prescribed values (0 elsewhere).
    value: Vec<Real>,
}

/// The part of the normal equations' solve that does not depend on the extra rows: `A·A` and the
/// symbolic Cholesky factorisation of its pattern (the fill-reducing ordering is most of it). The
/// rows' `CᵀC` couples vertices of one face, which `A·A` already couples, so the normal matrix
/// `A·A + CᵀC` has `A·A`'s pattern and the symbolic factorisation holds for it.
pub struct NormalPlan {
    aa: SparseColMat<usize, Real>,
    symbolic: faer::sparse::linalg::solvers::SymbolicLlt<usize>,
}

impl LaplaceSystem {
    /// Checks the input and assembles the equations (see [`harmonic_field`]).
    pub fn new(mesh: &TriMesh, conductivity: Option<&[Real]>, fixed: &[(usize, Real)]) -> Result<Self, FieldError> {
        let n = mesh.vertices.len();
        if fixed.is_empty() {
            return Err(FieldError::NoConstraints);
        }
        if let Some(&(v, _)) = fixed.iter().find(|(v, _)| *v >= n) {
            return Err(FieldError::BadVertex(v, n));
        }
        if let Some(c) = conductivity {
            if c.len() != mesh.faces.len() {
                return Err(FieldError::Conductivity(format!("{} values for {} faces", c.len(), mesh.faces.len())));
            }
            if let Some((f, x)) = c.iter().enumerate().find(|(_, x)| !(x.is_finite() && **x >= 0.0)) {
                return Err(FieldError::Conductivity(format!("face {f} has {x}")));
            }
        }
        let c_max = conductivity.map_or(1.0, |c| c.iter().copied().fold(0.0, Real::max)).max(Real::MIN_POSITIVE);
        let mut value = vec![0.0; n];
        let mut is_fixed = vec![false; n];
        for &(v, x) in fixed {
            value[v] = x;
            is_fixed[v] = true;
        }
        // Vertices on no face with an area are not part of the surface (left over by pruning, or only
        // on slivers): no equation involves them, so they are held at 0 rather than left singular.
        let mut on_surface = vec![false; n];
        for face in &mesh.faces {
            let p = face.map(|i| mesh.vertices[i as usize]);
            if (p[1] - p[0]).cross(&(p[2] - p[0])).norm() > 0.0 {
                face.iter().for_each(|&v| on_surface[v as usize] = true);
            }
        }
        for v in 0..n {
            if !on_surface[v] {
                is_fixed[v] = true;
            }
        }
        // Unknowns: the free vertices, numbered in order.
        let mut unknown = vec![usize::MAX; n];
        let mut free = 0;
        for v in 0..n {
            if !is_fixed[v] {
                unknown[v] = free;
                free += 1;
            }
        }
        if free == 0 {
            return Ok(LaplaceSystem { matrix: None, rhs: Vec::new(), unknown, value });
        }
        let mut triplets = Vec::with_capacity(mesh.faces.len() * 9);
        let mut rhs = vec![0.0; free];
        for (f, face) in mesh.faces.iter().enumerate() {
            let c = conductivity.map_or(1.0, |c| c[f]).max(INSULATOR * c_max);
            let p = face.map(|i| mesh.vertices[i as usize]);
            for k in 0..3 {
                // The edge (a, b) opposite corner k: weight c·cot(angle at k)/2.
                let (a, b) = (face[(k + 1) % 3] as usize, face[(k + 2) % 3] as usize);
                let (ea, eb) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
                let cross = ea.cross(&eb).norm();
                if cross <= 0.0 {
                    continue; // a degenerate face carries no flux
                }
                let w = c * ea.dot(&eb) / cross / 2.0;
                for (i, j) in [(a, b), (b, a)] {
                    if is_fixed[i] {
                        continue;
                    }
                    let row = unknown[i];
                    triplets.push(Triplet::new(row, row, w));
                    if is_fixed[j] {
                        rhs[row] += w * value[j];
                    } else {
                        triplets.push(Triplet::new(row, unknown[j], -w));
                    }
                }
            }
        }
        let matrix = SparseColMat::<usize, Real>::try_new_from_triplets(free, free, &triplets)
            .map_err(|e| FieldError::Singular(format!("{e:?}")))?;
        Ok(LaplaceSystem { matrix: Some(matrix), rhs, unknown, value })
    }

    /// The field with the Laplace equations alone.
    pub fn solve(&self) -> Result<Vec<Real>, FieldError> {
        match &self.matrix {
            None => Ok(self.value.clone()),
            Some(m) => self.solved(m, &self.rhs, None),
        }
    }

    /// Prepares [`LaplaceSystem::solve_with_rows`] (see [`NormalPlan`]); `None` when every vertex
    /// is prescribed.
    pub fn normal_plan(&self) -> Result<Option<NormalPlan>, FieldError> {
        let Some(a) = &self.matrix else { return Ok(None) };
        let singular = |e: &dyn std::fmt::Debug| FieldError::Singular(format!("{e:?}"));
        let par = faer::get_global_parallelism();
        let aa = faer::sparse::linalg::matmul::sparse_sparse_matmul(a.as_ref(), a.as_ref(), 1.0, par)
            .map_err(|e| singular(&e))?;
        let symbolic = faer::sparse::linalg::solvers::SymbolicLlt::try_new(aa.symbolic(), Side::Lower)
            .map_err(|e| singular(&e))?;
        Ok(Some(NormalPlan { aa, symbolic }))
    }

    /// The field with each row `Σ c_v u_v = 0` of `lines`, scaled by `weight`, added to the Laplace
    /// equations in least squares (see [`field_with_rows`]); `plan` from
    /// [`LaplaceSystem::normal_plan`] on this system, or `None` to make it here.
    pub fn solve_with_rows(
        &self,
        lines: &[Vec<(usize, Real)>],
        weight: Real,
        plan: Option<NormalPlan>,
    ) -> Result<Vec<Real>, FieldError> {
        let n = self.unknown.len();
        if let Some(&(v, _)) = lines.iter().flatten().find(|(v, _)| *v >= n) {
            return Err(FieldError::BadVertex(v, n));
        }
        let plan = match plan {
            Some(p) => Some(p),
            None => self.normal_plan()?,
        };
        let (Some(a), Some(plan)) = (&self.matrix, plan) else { return Ok(self.value.clone()) };
        let (matrix, rhs) = normal_equations(a, &plan.aa, &self.rhs, lines, weight, &self.unknown, &self.value)?;
        // The plan's symbolic factorisation holds when the sum kept A·A's pattern (always, for rows
        // within faces); otherwise it is made anew.
        let same = matrix.symbolic().col_ptr() == plan.aa.symbolic().col_ptr()
            && matrix.symbolic().row_idx() == plan.aa.symbolic().row_idx();
        self.solved(&matrix, &rhs, same.then_some(plan.symbolic))
    }

    /// Solves `m x = rhs` by sparse Cholesky (with `symbolic` when given), LU where rounding leaves a
    /// pivot ≤ 0, and spreads `x` over the free vertices.
    fn solved(
        &self,
        m: &SparseColMat<usize, Real>,
        rhs: &[Real],
        symbolic: Option<faer::sparse::linalg::solvers::SymbolicLlt<usize>>,
    ) -> Result<Vec<Real>, FieldError> {
        let mut b = Mat::<Real>::from_fn(rhs.len(), 1, |i, _| rhs[i]);
        let llt = match symbolic {
            Some(s) => faer::sparse::linalg::solvers::Llt::try_new_with_symbolic(s, m.as_ref(), Side::Lower),
            None => m.sp_cholesky(Side::Lower),
        };
        match llt {
            Ok(llt) => llt.solve_in_place(b.as_mut()),
            // The system is symmetric positive definite in exact arithmetic, but the cotangent weights
            // of near-degenerate triangles (slivers marching cubes leaves) reach 1e10 and rounding can
            // leave a pivot ≤ 0: LU with pivoting solves what is still regular.
            Err(chol) => {
                let lu = m.sp_lu().map_err(|e| FieldError::Singular(format!("{chol:?}; LU: {e:?}")))?;
                lu.solve_in_place(b.as_mut());
            }
        }
        let mut value = self.value.clone();
        for (v, &u) in self.unknown.iter().enumerate() {
            if u != usize::MAX {
                value[v] = b[(u, 0)];
                if !value[v].is_finite() {
                    return Err(FieldError::Singular(format!("vertex {v} got {}", value[v])));
                }
            }
        }
        Ok(value)
    }
}

/// The normal equations `AᵀA x = Aᵀb` of the stacked system: the Laplace rows (`a`, symmetric, and
/// `rhs`) and one row `w·Σ c_v u_v = 0` per constraint, with prescribed values moved to the right.
/// `AᵀA = A²` is a sparse product and the constraints' `CᵀC` is merged into it column by column
/// (summing the products of every row's entry pairs as triplets made 11 M of them on the demo's
/// mesh, and sorting them was a third of the remesher's field time).
fn normal_equations(
    a: &SparseColMat<usize, Real>,
    aa: &SparseColMat<usize, Real>,
    rhs: &[Real],
    lines: &[Vec<(usize, Real)>],
    weight: Real,
    unknown: &[usize],
    value: &[Real],
) -> Result<(SparseColMat<usize, Real>, Vec<Real>), FieldError> {
    let free = rhs.len();
    let singular = |e: &dyn std::fmt::Debug| FieldError::Singular(format!("{e:?}"));
    // Cᵀ: one column per constraint row, over the unknowns; c: the row's right-hand side.
    let mut ct = Vec::new();
    let mut c = Vec::with_capacity(lines.len());
    for (r, line) in lines.iter().enumerate() {
        let mut b = 0.0;
        for &(v, coeff) in line {
            if unknown[v] == usize::MAX {
                b -= weight * coeff * value[v];
            } else {
                ct.push(Triplet::new(unknown[v], r, weight * coeff));
            }
        }
        c.push(b);
    }
    let ct = SparseColMat::<usize, Real>::try_new_from_triplets(free, lines.len(), &ct).map_err(|e| singular(&e))?;
    let par = faer::get_global_parallelism();
    let cc = faer::sparse::linalg::matmul::sparse_sparse_matmul(
        ct.as_ref(),
        ct.transpose().to_col_major().map_err(|e| singular(&e))?.as_ref(),
        1.0,
        par,
    )
    .map_err(|e| singular(&e))?;
    // Right-hand side Aᵀ rhs + Cᵀ c, A symmetric.
    let mut rhs_n = vec![0.0; free];
    for (m, x) in [(a, rhs), (&ct, c.as_slice())] {
        let (ptr, idx, val) = (m.col_ptr(), m.row_idx(), m.val());
        for j in 0..x.len() {
            for k in ptr[j]..ptr[j + 1] {
                rhs_n[idx[k]] += val[k] * x[j];
            }
        }
    }
    Ok((add_sorted(aa, &cc), rhs_n))
}

/// `p + q` for two matrices of the same shape whose columns hold sorted row indices.
fn add_sorted(p: &SparseColMat<usize, Real>, q: &SparseColMat<usize, Real>) -> SparseColMat<usize, Real> {
    let n = p.ncols();
    let mut ptr = Vec::with_capacity(n + 1);
    let mut idx = Vec::with_capacity(p.val().len() + q.val().len());
    let mut val = Vec::with_capacity(idx.capacity());
    ptr.push(0);
    for j in 0..n {
        let (pr, pv) = (p.row_idx_of_col_raw(j), p.val_of_col(j));
        let (qr, qv) = (q.row_idx_of_col_raw(j), q.val_of_col(j));
        let (mut x, mut y) = (0, 0);
        while x < pr.len() || y < qr.len() {
            if y == qr.len() || (x < pr.len() && pr[x] < qr[y]) {
                idx.push(pr[x]);
                val.push(pv[x]);
                x += 1;
            } else if x == pr.len() || qr[y] < pr[x] {
                idx.push(qr[y]);
                val.push(qv[y]);
                y += 1;
            } else {
                idx.push(pr[x]);
                val.push(pv[x] + qv[y]);
                x += 1;
                y += 1;
            }
        }
        ptr.push(idx.len());
    }
    let symbolic = faer::sparse::SymbolicSparseColMat::new_checked(p.nrows(), n, ptr, None, idx);
    SparseColMat::new(symbolic, val)
}

/// The gradient of a per-vertex field on each face (eq. 6.1), constant over the face.
pub fn face_gradients(mesh: &TriMesh, u: &[Real]) -> Vec<Vector3> {
    mesh.faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|i| mesh.vertices[i as usize]);
            let [ua, ub, uc] = f.map(|i| u[i as usize]);
            let n = (b - a).cross(&(c - a));
            let area2 = n.norm_squared();
            if area2 <= 0.0 {
                return Vector3::zeros();
            }
            // ∇u = Σ u_i (n × e_i) / (2A)·… with e_i the edge opposite vertex i.
            (n.cross(&(c - b)) * ua + n.cross(&(a - c)) * ub + n.cross(&(b - a)) * uc) / area2
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plate(w: usize, h: usize, cell: Real) -> TriMesh {
        let mut m = fixtures::plate(w, h, false);
        m.vertices.iter_mut().for_each(|p| *p *= cell);
        m
    }

    #[test]
    fn a_plate_between_two_potentials_is_linear_and_its_gradient_uniform() {
        let m = plate(20, 10, 1.0);
        let fixed: Vec<(usize, Real)> = (0..=20).flat_map(|i| [(i, 0.0), (10 * 21 + i, 1.0)]).collect();
        let u = harmonic_field(&m, None, &fixed).unwrap();
        for (v, p) in m.vertices.iter().enumerate() {
            assert!((u[v] - p.y / 10.0).abs() < 1e-9, "vertex {v}: {} vs {}", u[v], p.y / 10.0);
        }
        for g in face_gradients(&m, &u) {
            assert!((g - Vector3::new(0.0, 0.1, 0.0)).norm() < 1e-9);
        }
    }

    #[test]
    fn a_line_constraint_bends_the_contours_along_it() {
        // Plate 0 at the bottom, 1 at the top; a constraint line of mesh edges that runs flat, climbs a
        // diagonal and runs flat again. Unconstrained, u varies along it by 0.2; constrained, it is one
        // contour (to the least-squares compromise the weight sets), and the field stays in its bounds.
        let (w, h) = (60usize, 40usize);
        let m = plate(w, h, 1.0);
        let id = |i: usize, j: usize| j * (w + 1) + i;
        let fixed: Vec<(usize, Real)> = (0..=w).flat_map(|i| [(id(i, 0), 0.0), (id(i, h), 1.0)]).collect();
        let mut path = vec![id(5, 15)];
        for i in 6..=20 {
            path.push(id(i, 15));
        }
        for k in 1..=8 {
            path.push(id(20 + k, 15 + k));
        }
        for i in 29..=55 {
            path.push(id(i, 23));
        }
        let lines: Vec<(usize, usize)> = path.windows(2).map(|e| (e[0], e[1])).collect();
        let spread = |u: &[Real]| {
            let vals: Vec<Real> = path.iter().map(|&v| u[v]).collect();
            vals.iter().copied().fold(Real::MIN, Real::max) - vals.iter().copied().fold(Real::MAX, Real::min)
        };
        let free = harmonic_field(&m, None, &fixed).unwrap();
        let bent = constrained_field(&m, None, &fixed, &lines, 10.0).unwrap();
        assert!(spread(&free) > 0.19, "{}", spread(&free));
        // Measured: 0.2 free, 0.0015 at weight 10, and tighter with weight.
        assert!(spread(&bent) < 0.01 * spread(&free), "constrained spread {}", spread(&bent));
        let tighter = constrained_field(&m, None, &fixed, &lines, 100.0).unwrap();
        assert!(spread(&tighter) < 0.5 * spread(&bent), "weight 100: {}", spread(&tighter));
        assert!(bent.iter().all(|&u| (-1e-6..=1.0 + 1e-6).contains(&u)));
    }

    #[test]
    fn bad_problems_are_refused() {
        let m = plate(2, 2, 1.0);
        assert!(matches!(harmonic_field(&m, None, &[]), Err(FieldError::NoConstraints)));
        assert!(matches!(harmonic_field(&m, None, &[(99, 1.0)]), Err(FieldError::BadVertex(99, 9))));
        assert!(matches!(harmonic_field(&m, Some(&[1.0; 3]), &[(0, 1.0)]), Err(FieldError::Conductivity(_))));
        assert!(matches!(harmonic_field(&m, Some(&[-1.0; 8]), &[(0, 1.0)]), Err(FieldError::Conductivity(_))));
    }
}
