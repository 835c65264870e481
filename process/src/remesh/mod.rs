//! Quad remeshing from constrained harmonic and quasi-harmonic fields (thesis ch. 6). So far: the
//! field solver with line constraints ([`harmonic`]), feature lines to constrain it ([`features`]) and
//! the singularity index of eq. 6.5 ([`singularities`]); streamline tracing and quad extraction are
//! still to come.

pub mod features;
pub mod harmonic;
pub mod singularities;
