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

#[cfg(test)]
mod tests {
    #[test]
    fn the_grammar_is_consistent() {
        use clap::CommandFactory;
        super::Args::command().debug_assert();
    }
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Describe a PLY, OBJ or OFF file, a rig (.toml) or an OpenCV camera (.yml): counts, properties, bounds.
    Info(InfoArgs),
    /// Convert a mesh or point cloud between PLY (binary or ASCII) and OBJ.
    Convert(ConvertArgs),
    /// Simulate a scan on a virtual rig: structured-light or laser frames of a mesh on a turntable, with truth.
    Sim(SimArgs),
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

#[derive(clap::Args, Debug)]
pub struct SimArgs {
    /// Simulator config: a TOML file, or the built-in `structured-light` or `laser` rig.
    #[arg(long, default_value = "structured-light")]
    pub config: String,
    /// The object: a PLY, OBJ or OFF mesh (default: the built-in fluted vase).
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// Largest extent of the object on the platter, mm (default: the config's object_size_mm).
    #[arg(long)]
    pub size: Option<f64>,
    /// Move the object on the platter by X,Y,Z mm (object frame: z up the turntable axis).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub offset: Option<[f64; 3]>,
    /// Which axis of the mesh file points up.
    #[arg(long, value_enum, default_value = "y")]
    pub up: Up,
    /// Capture program (default: structured light when the rig has a projector, else laser).
    #[arg(long, value_enum)]
    pub method: Option<SimMethod>,
    /// Turntable views over a full turn (default: the config's).
    #[arg(long)]
    pub views: Option<u32>,
    /// Camera resolution WxH, intrinsics scaled from the config's camera (e.g. 640x480).
    #[arg(long, value_parser = parse_size)]
    pub resolution: Option<(u32, u32)>,
    /// Noise seed: the same seed gives byte-identical frames.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output scan folder; a half-finished scan of the same settings there is resumed.
    #[arg(long, short, default_value = "scan-sim")]
    pub out: PathBuf,
    /// Calibration captures of a chessboard with COLSxROWS inner corners instead of a scan.
    #[arg(long, value_parser = parse_size)]
    pub board: Option<(u32, u32)>,
    /// The chessboard's square size, mm.
    #[arg(long, default_value_t = 15.0)]
    pub square: f64,
    /// Board poses in front of the camera (with --board).
    #[arg(long, default_value_t = 15)]
    pub poses: usize,
    /// Stand the board on the turntable and sweep it START:END:STEP degrees instead (with --board).
    #[arg(long, value_parser = parse_sweep, allow_hyphen_values = true)]
    pub sweep: Option<Sweep>,
    /// A noiseless sensor (no shot or read noise), for reference captures.
    #[arg(long)]
    pub noiseless: bool,
    /// Skip writing the ground truth (truth/).
    #[arg(long)]
    pub no_truth: bool,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Up {
    Y,
    Z,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SimMethod {
    StructuredLight,
    Laser,
}

fn parse_vec3(s: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> =
        s.split(',').map(|t| t.trim().parse::<f64>()).collect::<Result<_, _>>().map_err(|e| e.to_string())?;
    <[f64; 3]>::try_from(v).map_err(|v| format!("expected X,Y,Z, got {} values", v.len()))
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("expected WIDTHxHEIGHT, got `{s}`"))?;
    let parse = |t: &str| {
        t.trim().parse::<u32>().ok().filter(|&v| v > 0).ok_or_else(|| format!("`{t}` is not a positive size"))
    };
    Ok((parse(w)?, parse(h)?))
}

/// Turntable angles of a board sweep, degrees.
#[derive(Clone, Debug, PartialEq)]
pub struct Sweep(pub Vec<f64>);

fn parse_sweep(s: &str) -> Result<Sweep, String> {
    let v: Vec<f64> =
        s.split(':').map(|t| t.trim().parse::<f64>()).collect::<Result<_, _>>().map_err(|e| e.to_string())?;
    let [a, b, step] = v[..] else { return Err(format!("expected START:END:STEP, got `{s}`")) };
    if step.is_nan() || step <= 0.0 || b < a {
        return Err("the sweep needs END ≥ START and a positive STEP".into());
    }
    let n = ((b - a) / step + 1e-9).floor() as usize + 1;
    Ok(Sweep((0..n).map(|k| a + k as f64 * step).collect()))
}
