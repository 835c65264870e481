//! Quad remeshing from constrained harmonic and quasi-harmonic fields (thesis ch. 6). So far: the
//! field solver.

pub mod harmonic;
