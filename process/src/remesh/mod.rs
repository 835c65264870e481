//! Quad remeshing from constrained harmonic and quasi-harmonic fields (thesis ch. 6). So far: the
//! field solver with line constraints ([`harmonic`]) and feature lines to constrain it ([`features`]);
//! streamline tracing and quad extraction are still to come.

pub mod features;
pub mod harmonic;
