//! Watertight surfaces from oriented points (thesis ch. 5): the global FFT method of Kazhdan (2005)
//! on one N³ grid ([`global_fft`]), AdFFT's local FFT solutions over an octree blended by a partition
//! of unity (thesis 5.3, [`adfft`]), the caps a turntable scan's open base and top get first
//! ([`closing`]), and marching cubes ([`marching_cubes`]); [`mesh_distance`] is the
//! accuracy metric against a reference surface.

pub mod adfft;
pub mod base;
pub mod closing;
pub mod fft3;
pub mod fit;
pub mod global_fft;
pub mod marching_cubes;
/// The accuracy metric, kept here under its old path.
pub use crate::mesh_distance;
pub mod prune;
pub mod self_intersect;
pub mod top_cut;
pub mod trim;
