//! The command-line grammar (clap derive). Each subcommand's arguments are a plain struct its module
//! turns into library calls.

use clap::{Parser, Subcommand};
use std::path::PathBuf;

/// scanrig: drive, calibrate and simulate 3D scanners; turn their captures into point clouds and meshes.
#[derive(Parser, Debug)]
#[command(name = "scanrig", version, about, long_about = None)]
pub struct Args {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Describe a PLY, OBJ or OFF file, a rig (.toml) or an OpenCV camera (.yml): counts, properties, bounds.
    Info(InfoArgs),
    /// Convert a mesh or point cloud between PLY (binary or ASCII) and OBJ.
    Convert(ConvertArgs),
}

#[derive(clap::Args, Debug)]
pub struct InfoArgs {
    /// The file to describe.
    pub file: PathBuf,
    /// Print a JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::Args, Debug)]
pub struct ConvertArgs {
    /// Input mesh or cloud (.ply, .obj, .off).
    pub input: PathBuf,
    /// Output file (.ply or .obj); written atomically.
    pub output: PathBuf,
    /// Write ASCII PLY instead of binary little-endian.
    #[arg(long)]
    pub ascii: bool,
    /// Write coordinates as `double` instead of `float` (PLY).
    #[arg(long)]
    pub double: bool,
}
