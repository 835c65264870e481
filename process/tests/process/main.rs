//! The geometry pipeline's integration tests, in one binary: each module is one area.

mod acceptance;
mod colour;
mod denoise;
mod global;
mod icp;
mod laser_real;
mod mean_shift;
mod parts;
mod reconstruct;
mod register_fuse;
mod remesh_fields;
mod remesh_quads;
mod surface;
mod turned_frames;
mod views_at_once;
