//! Calibration against simulated and real captures, in one binary.

mod fabscanpi;
mod laser_sim;
mod partial_boards;
mod structured_light_sim;
mod turntable_sim;
