//! Quad remeshing from constrained harmonic and quasi-harmonic fields (thesis ch. 6), in the order
//! the work flows: constraint lines ([`features`], [`half_split`]), the field ([`harmonic`], with the
//! singularity index of eq. 6.5 in [`singularities`]), streamlines of its gradient and co-gradient
//! ([`surface`], [`streamline`], [`seeding`]), the quads their crossings bound ([`quad_graph`], [`polygon_split`]) and
//! how good they are ([`quality`]); [`quad_remesh::remesh`] runs them all.

pub mod edge_faces;
pub mod features;
pub mod half_split;
pub mod harmonic;
pub mod polygon_split;
pub mod quad_graph;
pub mod quad_remesh;
pub mod quality;
pub mod seeding;
pub mod singularities;
pub mod streamline;
pub mod surface;

pub use quad_remesh::{RemeshError, RemeshParams, RemeshReport, remesh, snap_lines};
