//! Watertight surfaces from oriented points (thesis ch. 5): the global FFT method of Kazhdan (2005)
//! and marching cubes.

pub mod adfft;
pub mod fft3;
pub mod global_fft;
pub mod marching_cubes;
pub mod mesh_distance;
pub mod prune;
