//! The integration tests of the `scanrig` command line, in one test binary (one link of the workspace
//! instead of one per file): each module is one former test file.

mod bad_input;
mod bases;
mod cli;
mod data_files;
mod fabscan_scan;
mod frame_sequences;
mod hostile;
mod independent_readers;
mod pages;
mod passes;
mod python_bindings;
mod run;
mod scanner_files;
mod shared_demo;
mod stages;
mod station;
mod trusted_inputs;
mod user_files;
