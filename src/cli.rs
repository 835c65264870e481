//! The command-line grammar (clap derive). Each subcommand's arguments are a plain struct its module
//! turns into library calls.

use crate::stage_args::{CropOpts, DecodeOpts, DenoiseOpts, FuseOpts, ReconstructOpts, RegisterOpts, RemeshOpts};
use clap::{Parser, Subcommand};
use std::path::PathBuf;

/// scanrig: drive, calibrate and simulate 3D scanners; turn their captures into point clouds and meshes.
///
/// Conventions: millimetres and degrees; camera frame x right, y down, z forward. A turntable angle
/// is counter-clockwise seen from above (the platter turns that way as the angle grows); importers
/// convert other scanners' angles to it (FabScanPi's position k of N is -k*360/N).
#[derive(Parser, Debug)]
#[command(name = "scanrig", version, about)]
pub struct Args {
    /// No progress on stderr (errors and warnings still go there).
    #[arg(long, short, global = true)]
    pub quiet: bool,
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

    #[test]
    fn sizes_boards_and_sweeps_are_bounded() {
        use super::{parse_board, parse_size, parse_sweep};
        assert_eq!(parse_size("640x512"), Ok((640, 512)));
        for bad in ["4294967295x4294967295", "32769x10", "0x5", "x", "-1x5", "1.5x2"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
        assert_eq!(parse_board("9x6").map(|b| (b.cols, b.rows, b.charuco.is_none())), Ok((9, 6, true)));
        let charuco = parse_board("charuco:11x9:square=10:marker=7:dict=4x4_50").unwrap();
        assert_eq!((charuco.cols, charuco.rows, charuco.charuco.map(|c| c.0)), (10, 8, Some(10.0)));
        for bad in ["100000x100000", "1x6", "201x3", "charuco:11x9:square=10:marker=7:dict=4x4_5"] {
            assert!(parse_board(bad).is_err(), "{bad}");
        }
        assert_eq!(parse_sweep("-60:60:10").unwrap().0.len(), 13);
        for bad in ["0:1e9:1e-9", "0:inf:1", "0:10:0", "NaN:1:1"] {
            assert!(parse_sweep(bad).is_err(), "{bad}");
        }
    }
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Describe a PLY, OBJ or OFF file, a rig (.toml) or an OpenCV camera (.yml): counts, properties, bounds.
    Info(InfoArgs),
    /// Convert a mesh or point cloud between PLY (binary or ASCII) and OBJ.
    Convert(ConvertArgs),
    /// Process a scan folder: decode, triangulate, denoise, merge, register, fuse, reconstruct, remesh
    /// (reuses every output whose inputs and settings are unchanged).
    Process(ProcessArgs),
    /// Denoise range grids (PLY range grids) by the non-local filter, or the bilateral baseline.
    Denoise(DenoiseArgs),
    /// Register a processed scan's views by multi-view ICP from the turntable poses, and merge them again.
    Register(RegisterArgs),
    /// Align cloud A onto cloud B from any pose (another pass of the object, another tool's scan) by their
    /// local shape; refuses an ambiguous match unless --force.
    Align(AlignArgs),
    /// Fuse a registered point cloud by mean shift: smooth it, cluster it, remove outliers (thesis ch. 3).
    Fuse(FuseArgs),
    /// Reconstruct a watertight mesh from an oriented point cloud (thesis ch. 5).
    Reconstruct(ReconstructArgs),
    /// Remesh a triangle mesh into quads along the streamlines of a designed harmonic field (thesis ch. 6).
    Remesh(RemeshArgs),
    /// Calibrate a rig (camera, projector, lasers, turntable) from chessboard captures into a rig file.
    Calibrate(CalibrateArgs),
    /// Rebuild a processed scan's report page (processed/report.html): views, plots, a 3D viewer, files.
    Report(ReportArgs),
    /// Look at clouds and meshes (PLY, OBJ, OFF, STL, GLB, E57) in a 3D viewer page: written beside the
    /// first file, or served on 127.0.0.1 with --serve.
    View(ViewArgs),
    /// Decode a folder of structured-light images made by other tools into a projector correspondence map.
    Decode(DecodeArgs),
    /// The operator's station in the browser: devices and check, live view, calibration, scan with
    /// the object appearing view by view, processing and the projects under --data (127.0.0.1 only,
    /// unless --bind names another address; then a token printed at start is needed).
    Serve(ServeArgs),
    /// Simulate a 36-view scan of the built-in object and process it: the whole pipeline on a virtual rig.
    Demo(DemoArgs),
    /// Simulate a scan on a virtual rig: structured-light or laser frames of a mesh on a turntable, with truth.
    Sim(SimArgs),
    /// Capture a scan on a rig: a Horus turntable (or the virtual one) and a camera, resumable.
    Scan(ScanArgs),
    /// Drive a Horus turntable by hand: check it, turn it, switch a laser or the motor.
    Turntable(TurntableArgs),
    /// Run a virtual Horus 0.2 turntable on a pseudo-terminal and print its port (for testing hosts).
    VirtualTurntable(VirtualTurntableArgs),
    /// Bring in another scanner's calibration as a rig: Horus' settings.json, FabScanPi's config.json.
    Import {
        /// Which scanner's file.
        #[command(subcommand)]
        command: ImportCommand,
    },
    /// Write a rig as another scanner's calibration file: Horus' settings.json, FabScanPi's config.json.
    Export {
        /// Which scanner's file.
        #[command(subcommand)]
        command: ExportCommand,
    },
    /// Cameras: list the video devices.
    Camera {
        /// What to do.
        #[command(subcommand)]
        command: CameraCommand,
    },
    /// The projector: show a pattern fullscreen (feature `projector-window`).
    Projector {
        /// What to do.
        #[command(subcommand)]
        command: ProjectorCommand,
    },
}

#[derive(Subcommand, Debug)]
pub enum ImportCommand {
    /// Horus' settings.json (its calibration_settings: camera, distortion, both laser planes, platform
    /// pose, image rotate/flip) into a rig file.
    Horus {
        /// The settings.json.
        settings: PathBuf,
        /// The rig file to write.
        #[arg(long, short)]
        out: PathBuf,
    },
    /// FabScanPi's config.json (camera, image rotate/flip, laser planes and colour, platform pose,
    /// turntable radius and height as the working volume) into a rig file; or a FabScanPi scan folder
    /// (its raw_laser_raw or laser_raw frames, kept with keep_raw_images, or `<id>_NNN.jpg` frames
    /// directly in the folder, counted from 000) and its config into a scan folder whose frames are
    /// those files, unaltered, each at its turntable angle (--step-deg).
    Fabscan {
        /// A config.json (writes a rig), or a scan folder `<id>/` (writes a scan folder).
        input: PathBuf,
        /// The scanner's config.json, for a scan folder (default: config.json in it or beside it).
        #[arg(long)]
        config: Option<PathBuf>,
        /// For a scan folder: the turntable step between its positions, degrees (FabScanPi's config does
        /// not record the scan's resolution; 3.6 for 100 positions a turn). Required, never guessed:
        /// frame k stands at k times this.
        #[arg(long, value_name = "DEG")]
        step_deg: Option<f64>,
        /// The rig file or scan folder to write (a scan folder must not exist yet).
        #[arg(long, short)]
        out: PathBuf,
        /// A further pass of the same object (turned over and scanned again): its frames and views
        /// are added to the scan folder OUT, which holds the passes before it; `process` aligns them.
        #[arg(long, default_value_t = 1)]
        pass: u32,
    },
}

#[derive(Subcommand, Debug)]
pub enum ExportCommand {
    /// A rig as Horus' settings.json (its calibration_settings; with --into, laid over Horus' own
    /// file so its other settings stay).
    Horus {
        /// The rig file.
        rig: PathBuf,
        /// The settings file to write.
        #[arg(long, short)]
        out: PathBuf,
        /// Horus' own settings.json: the output is it with the rig's calibration in place (it is read,
        /// never written).
        #[arg(long)]
        into: Option<PathBuf>,
    },
    /// A rig as FabScanPi's config.json (its calibration, camera, laser and turntable blocks; with
    /// --into, laid over the scanner's own config so turntable.steps, calibration.pattern, folders
    /// and connector stay as they were).
    Fabscan {
        /// The rig file.
        rig: PathBuf,
        /// The config file to write.
        #[arg(long, short)]
        out: PathBuf,
        /// The scanner's own config.json: the output is it with the rig's numbers in place (it is read,
        /// never written).
        #[arg(long)]
        into: Option<PathBuf>,
    },
}

#[derive(Subcommand, Debug)]
pub enum ProjectorCommand {
    /// Show one pattern of the structured-light program fullscreen, e.g. `white`, `gray_col_00`,
    /// `gray_row_03_inv`, `phase_col_p16_1of4`.
    Show {
        /// The pattern's name (as frame files are named).
        pattern: String,
        /// The projector's resolution.
        #[arg(long, value_parser = parse_size, default_value = "1024x768")]
        size: (u32, u32),
        /// Monitor index (default: the primary one).
        #[arg(long)]
        monitor: Option<usize>,
        /// Keep it shown this long, seconds.
        #[arg(long, default_value_t = 10.0)]
        seconds: f64,
        /// The projector's response exponent (light = drive^gamma).
        #[arg(long, default_value_t = 1.0)]
        gamma: f64,
    },
}

#[derive(clap::Args, Debug)]
pub struct ScanArgs {
    /// A further pass of the same object into the same folder, after turning it over (2 on its side,
    /// and so on; the simulated rig turns it as `sim --passes` does): its views are appended, and
    /// `process` aligns it with the first by its shape.
    #[arg(long, default_value_t = 1)]
    pub pass: u32,
    /// The scan folder to write (frames, scan.json, rig.toml).
    #[arg(long, short)]
    pub out: PathBuf,
    /// Continue the scan in --out from its first incomplete view. A Horus board cannot tell where
    /// the platter is after a reset or an unplug: turn it back to the mark it started from (0°).
    #[arg(long)]
    pub resume: bool,
    /// The rig file recorded with the scan (default: the simulator config's rig).
    #[arg(long)]
    pub rig: Option<PathBuf>,
    /// The turntable's serial port (a Horus 0.2 board at 115200 baud); default: the virtual turntable.
    #[arg(long)]
    pub port: Option<String>,
    /// The camera: `sim` (the simulator, watching the virtual turntable; the default), a V4L2 device
    /// such as `/dev/video0` (feature `v4l2`), or a folder of recorded frames to replay in the order
    /// of their numbers (img1, img2, …, img10; a duplicate, gap or extra image is refused).
    #[arg(long)]
    pub camera: Option<PathBuf>,
    /// Show the patterns in a fullscreen window on this monitor (feature `projector-window`); without
    /// it, the simulator's projector (with the simulated camera) or none.
    #[arg(long)]
    pub projector_monitor: Option<usize>,
    /// The simulated rig and object (for `--camera sim`, and the capture program).
    #[command(flatten)]
    pub world: SimWorld,
    /// Pause after each move before the first frame, ms.
    #[arg(long, default_value_t = 200)]
    pub settle_ms: u64,
    /// Testing: the virtual turntable goes silent after this many commands (an unplugged cable).
    #[arg(long, hide = true)]
    pub virtual_unplug_after: Option<usize>,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::Args, Debug)]
pub struct TurntableArgs {
    /// The serial port (default: a virtual turntable, for trying the commands).
    #[arg(long)]
    pub port: Option<String>,
    /// What to do.
    #[command(subcommand)]
    pub command: TurntableCommand,
}

#[derive(Subcommand, Debug)]
pub enum TurntableCommand {
    /// Greet the board and check it runs Horus 0.2.
    Check,
    /// Turn to an absolute angle (degrees, from where the board was switched on).
    Move {
        /// The angle, degrees.
        #[arg(allow_hyphen_values = true)]
        degrees: f64,
        /// Speed, degrees per second.
        #[arg(long, default_value_t = 50.0)]
        speed: f64,
    },
    /// Switch laser INDEX (0-based) on or off.
    Laser {
        /// The laser, 0-based.
        index: usize,
        /// on or off.
        state: OnOff,
    },
    /// Energise or release the stepper.
    Motor {
        /// on or off.
        state: OnOff,
    },
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum OnOff {
    /// On.
    On,
    /// Off.
    Off,
}

impl OnOff {
    pub fn on(self) -> bool {
        self == OnOff::On
    }
}

#[derive(clap::Args, Debug)]
pub struct VirtualTurntableArgs {
    /// Stop after this many seconds (default: run until Ctrl-C).
    #[arg(long)]
    pub seconds: Option<u64>,
    /// Greet with this line instead of Horus 0.2's (imitates other firmware or a wrong baud rate).
    #[arg(long)]
    pub greeting: Option<String>,
    /// Go silent after this many commands (an unplugged cable).
    #[arg(long)]
    pub unplug_after: Option<usize>,
    /// Never answer these commands (1-based numbers, comma-separated).
    #[arg(long, value_delimiter = ',')]
    pub drop_reply: Vec<usize>,
    /// Answer these commands with a garbled line.
    #[arg(long, value_delimiter = ',')]
    pub garble: Vec<usize>,
    /// Wait this long before every reply, ms.
    #[arg(long, default_value_t = 0)]
    pub slow_ms: u64,
    /// Moves complete at once instead of at the feed rate.
    #[arg(long)]
    pub instant: bool,
}

#[derive(Subcommand, Debug)]
pub enum CameraCommand {
    /// List the video devices (V4L2) on this machine.
    List,
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
    /// Input mesh or cloud (.ply, .obj, .off, .stl, .glb, .e57).
    pub input: PathBuf,
    /// Output file: a mesh as .ply, .obj, .stl (to print) or .glb (glTF, for web viewers); a cloud as
    /// .ply, .obj, .glb or .e57 (for surveying tools). Written atomically.
    pub output: PathBuf,
    /// Write ASCII instead of binary (PLY: instead of little-endian; STL: instead of binary STL).
    #[arg(long)]
    pub ascii: bool,
    /// Write coordinates as `double` instead of `float` (PLY). Without it `float` is written unless
    /// single precision would round the data by over 10⁻⁵ of their size (an object far from the
    /// origin, a survey's coordinates), which takes `double` on its own.
    #[arg(long)]
    pub double: bool,
    /// Print what was written as JSON.
    #[arg(long)]
    pub json: bool,
}

/// The simulated rig and the object on its platter.
#[derive(clap::Args, Debug, Clone)]
pub struct SimWorld {
    /// Simulator config: a TOML file, or a built-in rig: `structured-light`, `structured-light-640`, `laser`, or
    /// `realistic` (the laser rig in an enclosure, colour JPEG frames, no laser-off frame).
    #[arg(long, default_value = "structured-light")]
    pub config: String,
    /// The object: a PLY, OBJ or OFF mesh (default: the built-in fluted vase).
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// Largest extent of the object on the platter, mm (default: the config's object_size_mm).
    #[arg(long)]
    pub size: Option<f64>,
    /// Which axis of the mesh file points up.
    #[arg(long, value_enum, default_value = "y")]
    pub up: Up,
    /// Turntable views over a full turn (default: the config's).
    #[arg(long)]
    pub views: Option<u32>,
    /// Camera resolution WxH, intrinsics scaled from the config's camera (e.g. 640x480).
    #[arg(long, value_parser = parse_size)]
    pub resolution: Option<(u32, u32)>,
    /// Noise seed: the same seed gives byte-identical frames.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

#[derive(clap::Args, Debug)]
pub struct SimArgs {
    /// The rig and the object.
    #[command(flatten)]
    pub world: SimWorld,
    /// Move the object on the platter by X,Y,Z mm (object frame: z up the turntable axis).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub offset: Option<[f64; 3]>,
    /// Capture program (default: structured light when the rig has a projector, else laser).
    #[arg(long, value_enum)]
    pub method: Option<SimMethod>,
    /// Scan the object in this many passes, turned over between them as an operator would: pass 2
    /// on its side, 3 upside down, 4 on its other side (up to 6); each pass the whole turntable
    /// program, the truth of each pass's pose in truth/passes.json.
    #[arg(long, default_value_t = 1)]
    pub passes: u32,
    /// Output scan folder; a half-finished scan of the same settings there is resumed.
    #[arg(long, short, default_value = "scan-sim")]
    pub out: PathBuf,
    /// Calibration captures of a chessboard with COLSxROWS inner corners instead of a scan, or of
    /// a ChArUco board: charuco:SQUARESxSQUARES:square=MM:marker=MM:dict=4x4_50.
    #[arg(long, value_parser = parse_board)]
    pub board: Option<BoardArg>,
    /// The chessboard's square size, mm.
    #[arg(long, default_value_t = 15.0)]
    pub square: f64,
    /// Board poses held in front of the camera (with --board; default 15, none with --sweep alone).
    #[arg(long)]
    pub poses: Option<usize>,
    /// Stand the board on the turntable and sweep it START:END:STEP degrees (with --board; after
    /// the held poses when --poses is given too).
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
    /// Also write the scan in another tool's layout, for trying importers: `fabscan` (a laser scan as
    /// FabScanPi keeps it, OUT/fabscan/config.json and OUT/fabscan/sim/raw_laser_raw/sim_NNN.png,
    /// frames as its side-mounted camera captures them); `opencv` (a structured-light --board capture
    /// as pose folders OUT/opencv/pose_NN/graycode_MM.png in OpenCV's Gray-code order).
    #[arg(long, value_enum)]
    pub layout: Option<SimLayout>,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum LensModelArg {
    /// The terms the views support.
    Auto,
    /// Every term not held fixed.
    Full,
}

impl From<LensModelArg> for calib::LensModel {
    fn from(m: LensModelArg) -> Self {
        match m {
            LensModelArg::Auto => calib::LensModel::Auto,
            LensModelArg::Full => calib::LensModel::Full,
        }
    }
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SimLayout {
    /// FabScanPi's scan folder and config.json.
    Fabscan,
    /// One folder per board pose of Gray codes in OpenCV order.
    Opencv,
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

/// An image size WIDTHxHEIGHT, each side 1 to the largest camera or projector side.
fn parse_size(s: &str) -> Result<(u32, u32), String> {
    parse_pair(s, 1, rig::camera::MAX_SIDE_PX, "pixels")
}

/// A chessboard's inner corners COLSxROWS: at least 2×2 to fix a pose, at most 200 a side (a board
/// finer than that spans fewer than 20 pixels a square on any camera's image).
/// A board on the command line: a chessboard's inner corners, or a ChArUco board's description.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoardArg {
    /// Inner corners across.
    pub cols: u32,
    /// Inner corners down.
    pub rows: u32,
    /// A ChArUco board's square (mm) and markers.
    pub charuco: Option<(f64, calib::charuco::CharucoMarkers)>,
}

fn parse_board(s: &str) -> Result<BoardArg, String> {
    if s.trim_start().starts_with("charuco") {
        let (cols, rows, square, markers) = calib::charuco::parse(s)?;
        return Ok(BoardArg { cols, rows, charuco: Some((square, markers)) });
    }
    let (cols, rows) = parse_pair(s, 2, calib::workflow::limits::MAX_BOARD_CORNERS as u32, "inner corners")?;
    Ok(BoardArg { cols, rows, charuco: None })
}

fn parse_pair(s: &str, min: u32, max: u32, unit: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("expected WIDTHxHEIGHT, got `{s}`"))?;
    let parse = |t: &str| {
        let v = t.trim().parse::<u32>().map_err(|_| format!("`{t}` is not a whole number"))?;
        if (min..=max).contains(&v) { Ok(v) } else { Err(format!("{v} must be {min} to {max} {unit}")) }
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
    let n = ((b - a) / step + 1e-9).floor() + 1.0;
    // More board poses than a turntable has tenth-degree steps is a typo, and each pose is a capture.
    if n.is_nan() || n > 3600.0 {
        return Err(format!("the sweep gives {n} poses; at most 3600"));
    }
    let n = n as usize;
    Ok(Sweep((0..n).map(|k| a + k as f64 * step).collect()))
}

/// A stage by name, for `--until`.
fn parse_stage(name: &str) -> Result<process::Stage, String> {
    process::Stage::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = process::Stage::ALL.iter().map(|s| s.name()).collect();
        format!("`{name}` is not a stage; the stages are {}", names.join(", "))
    })
}

#[derive(clap::Args, Debug)]
pub struct ProcessArgs {
    /// The scan folder (with scan.json).
    pub scan: PathBuf,
    /// Output folder (default: SCAN/processed).
    #[arg(long, short)]
    pub out: Option<PathBuf>,
    /// Stop after this stage: decode, triangulate, denoise, merge, register, fuse, reconstruct or remesh.
    #[arg(long, value_parser = parse_stage, default_value = "remesh")]
    pub until: process::Stage,
    /// Redo stages whose outputs are already current.
    #[arg(long)]
    pub redo: bool,
    /// Skip the denoising stage.
    #[arg(long)]
    pub no_denoise: bool,
    /// Reconstruct the fused cloud as it is, without flat caps over its open base (on the platter)
    /// and top (at the data's highest level).
    #[arg(long)]
    pub no_close: bool,
    /// Decoding (as `scanrig decode`).
    #[command(flatten, next_help_heading = "Decoding")]
    pub decode: DecodeOpts,
    /// Denoising (as `scanrig denoise`).
    #[command(flatten, next_help_heading = "Denoising")]
    pub denoise: DenoiseOpts,
    /// The object cylinder.
    #[command(flatten, next_help_heading = "Merging")]
    pub crop: CropOpts,
    /// Registration (as `scanrig register`).
    #[command(flatten, next_help_heading = "Registration")]
    pub register: RegisterOpts,
    /// Fusion (as `scanrig fuse`).
    #[command(flatten, next_help_heading = "Fusion")]
    pub fuse: FuseOpts,
    /// Reconstruction (as `scanrig reconstruct`).
    #[command(flatten, next_help_heading = "Reconstruction")]
    pub reconstruct: ReconstructOpts,
    /// Remeshing (as `scanrig remesh`).
    #[command(flatten, next_help_heading = "Remeshing")]
    pub remesh: RemeshOpts,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameOrder {
    /// OpenCV GrayCodePattern: column bits (pattern, inverse; MSB first), row bits, then white, black.
    Opencv,
}

#[derive(clap::Args, Debug)]
pub struct DecodeArgs {
    /// Folder of 8-bit images (PNG or JPEG, grey or colour), taken in the order of their numbers
    /// (img1, img2, …, img10), never as text; a duplicate, gap or extra image is refused.
    pub dir: PathBuf,
    /// Projector resolution WxH (default: the rig's projector, with --rig).
    #[arg(long, value_parser = parse_size)]
    pub projector: Option<(u32, u32)>,
    /// A calibrated rig (camera and projector): the map is triangulated, and `-o cloud.ply` writes the
    /// points as a range grid (a cloud with each point's `grid_col grid_row`) other tools open as a cloud. Frames are
    /// turned as its `[image]` says.
    #[arg(long)]
    pub rig: Option<PathBuf>,
    /// The order the images were captured in.
    #[arg(long, value_enum, default_value = "opencv")]
    pub order: FrameOrder,
    /// The decoder's thresholds.
    #[command(flatten)]
    pub decode: DecodeOpts,
    /// Write the map even where the frames contradict themselves (a pattern and its inverse not
    /// complementary, white and black swapped, a dark frame, a mirrored or discontinuous code), with
    /// a warning, instead of failing.
    #[arg(long)]
    pub force: bool,
    /// Output: `.npy`, a NumPy (H, W, 3) array of projector u, v and confidence (a PNG preview is
    /// written beside it as NAME.preview.png); `.ply` (with --rig), the triangulated points,
    /// millimetres, camera frame. Never inside DIR.
    #[arg(long, short, default_value = "correspondence.npy")]
    pub out: PathBuf,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::Args, Debug)]
pub struct ReportArgs {
    /// The scan folder.
    pub scan: PathBuf,
    /// Its processed folder (default: SCAN/processed).
    #[arg(long, short)]
    pub out: Option<PathBuf>,
}

#[derive(clap::Args, Debug)]
pub struct ViewArgs {
    /// Clouds and meshes to show, one layer each.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// The page to write (default: FIRST_FILE.view.html beside the first file).
    #[arg(long, short, conflicts_with = "serve")]
    pub out: Option<PathBuf>,
    /// Serve the page on 127.0.0.1 (nothing is written) until interrupted, and print its address.
    #[arg(long)]
    pub serve: bool,
    /// The port to serve on (0: any free one).
    #[arg(long, default_value_t = 0, requires = "serve")]
    pub port: u16,
}

#[derive(clap::Args, Debug)]
pub struct ServeArgs {
    /// The port to listen on (0: any free one; the address is printed).
    #[arg(long, default_value_t = 8720)]
    pub port: u16,
    /// The address to listen on. Anything but a loopback address needs the token printed at start
    /// (or given with --token) in every request.
    #[arg(long, default_value = "127.0.0.1")]
    pub bind: std::net::IpAddr,
    /// The token for a non-loopback --bind (default: a random one, printed).
    #[arg(long)]
    pub token: Option<String>,
    /// The rig file: scans use it, calibration writes it (default: the simulated rig's, kept in
    /// DATA/rig.toml once calibrated).
    #[arg(long)]
    pub rig: Option<PathBuf>,
    /// The folder of projects: each scan folder in it is a project.
    #[arg(long, default_value = "scans")]
    pub data: PathBuf,
    /// The calibration board: COLSxROWS inner corners.
    #[arg(long, default_value = "9x6", value_parser = parse_board)]
    pub board: BoardArg,
    /// The board's square size, mm.
    #[arg(long, default_value_t = 11.0)]
    pub square: f64,
    /// Serve for this many seconds, then stop (default: until interrupted; 0 checks the options,
    /// binds, prints the address and stops — for scripts).
    #[arg(long)]
    pub seconds: Option<u64>,
    /// Seconds a page that controls the rig may go unheard (its laptop asleep, its network gone)
    /// before another page may take control (3 to 3600). The page answers the station every few
    /// seconds while it is open; a closed page lets go after 10 s.
    #[arg(long, default_value_t = 30)]
    pub control_timeout: u64,
    /// Show the projector's patterns in a fullscreen window on this monitor (feature
    /// `projector-window`): a real structured-light rig's check, live view, calibration and scans
    /// need it; the simulator's projector is driven either way.
    #[arg(long)]
    pub projector_monitor: Option<usize>,
    /// The virtual rig (the simulator's camera and projector and the virtual turntable, offered as
    /// devices beside real ones).
    #[command(flatten)]
    pub world: SimWorld,
}

#[derive(clap::Args, Debug)]
pub struct DemoArgs {
    /// Where the simulated scan and its processed outputs go.
    #[arg(long, short, default_value = "scanrig-demo")]
    pub out: PathBuf,
    /// Simulate the full 1280x1024 camera instead of the quick 640x480 readout.
    #[arg(long)]
    pub full_resolution: bool,
    /// Noise seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Turntable views (36 makes the demo; fewer for a quick look).
    #[arg(long, default_value_t = 36)]
    pub views: u32,
    /// Process the simulated captures with this rig (say, one `scanrig calibrate all` estimated from
    /// simulated calibration captures) instead of the simulator's own; the simulator's goes to
    /// `scan/truth/rig.toml` and accuracy is still measured against the truth.
    #[arg(long)]
    pub rig: Option<PathBuf>,
    /// Stop the processing after this stage: triangulate, denoise, merge, register, fuse, reconstruct
    /// or remesh (the accuracy is measured on the range grids, so triangulate at the earliest).
    #[arg(long, value_parser = parse_stage, default_value = "remesh")]
    pub until: process::Stage,
    /// Print the simulation's and the processing's reports and the accuracy as one JSON object.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::Args, Debug)]
pub struct DenoiseArgs {
    /// Range grids: PLY files with grid cells (scanrig's views, Stanford scans' range_grid). Several files
    /// with --temporal form a sequence, in the order given.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Output file (one input) or folder (several); written atomically.
    #[arg(long, short)]
    pub out: PathBuf,
    /// The filter's settings.
    #[command(flatten)]
    pub filter: DenoiseOpts,
    /// Sequences: use this many frames before and after each frame (eq. 4.6).
    #[arg(long, default_value_t = 0)]
    pub temporal: usize,
    /// Print the reports as JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::Args, Debug)]
pub struct ReconstructArgs {
    /// The oriented cloud (.ply or .obj with normals; `scanrig fuse` writes one).
    pub input: PathBuf,
    /// The mesh to write: .ply (with vertex normals), .obj, .stl (binary, to print) or .glb (glTF).
    #[arg(long, short)]
    pub out: PathBuf,
    /// The method and its settings.
    #[command(flatten)]
    pub reconstruct: ReconstructOpts,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
    /// Write the mesh even when its cloud does not support it — far from it, inside out, facing
    /// against its normals, leaving samples out, or coarsened by a few points far from the rest (it
    /// is still warned about).
    #[arg(long)]
    pub force: bool,
    /// Cap the cloud's open base and top flat first, as `process` does: for a cloud in a turntable
    /// scan's object frame (z up, the platter at z = 0), such as `process` writes.
    #[arg(long)]
    pub close: bool,
}

#[derive(clap::Args, Debug)]
pub struct RemeshArgs {
    /// The triangle mesh (.ply, .obj, .off, .stl or .glb; polygons are split into triangles).
    pub input: PathBuf,
    /// The quad mesh to write: .obj or .ply (polygons), or .stl / .glb (triangulated).
    #[arg(long, short)]
    pub out: PathBuf,
    /// The remesher's settings.
    #[command(flatten)]
    pub remesh: RemeshOpts,
    /// Constraint lines to follow: one per line, vertex indices, or `p` and x y z points snapped to the
    /// surface; `#` comments.
    #[arg(long)]
    pub constraints: Option<PathBuf>,
    /// Per-face conductivity (eq. 6.4): one non-negative number per face; low values repel contours,
    /// high values attract them.
    #[arg(long)]
    pub conductivity: Option<PathBuf>,
    /// Also write the streamlines as OBJ polylines to this file.
    #[arg(long)]
    pub lines: Option<PathBuf>,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
    /// Write the quad mesh even when it cannot be right: edges of three faces or holes its input lacks,
    /// or surface far from it; and remesh an input with a few vertices far from the rest (it is still
    /// warned about).
    #[arg(long)]
    pub force: bool,
}

#[derive(clap::Args, Debug)]
pub struct CalibrateArgs {
    /// What to calibrate.
    #[arg(value_enum)]
    pub target: CalibrateTarget,
    /// A capture folder (`scanrig sim --board` writes one), a folder of PNG or JPEG images, or a
    /// `'dir/*.png'` pattern; for `import`, an OpenCV YAML camera file. In an image folder a frame
    /// much darker than the lit frame before it is that position's laser frame (laser 0, then 1).
    #[arg(required_unless_present = "images")]
    pub captures: Option<PathBuf>,
    /// Images made by other tools, as a folder or a `'dir/*.png'` pattern (the same as giving them
    /// in place of CAPTURES).
    #[arg(long, conflicts_with = "captures")]
    pub images: Option<PathBuf>,
    /// The rig file to write; an existing one keeps everything but what is calibrated.
    #[arg(long, short)]
    pub out: PathBuf,
    /// Inner corners of the chessboard, COLSxROWS; or a ChArUco board,
    /// charuco:SQUARESxSQUARES:square=MM:marker=MM:dict=4x4_50 (OpenCV's layout; its square= is
    /// the square size, --square is not used).
    #[arg(long, value_parser = parse_board, default_value = "9x6")]
    pub board: BoardArg,
    /// Square size, mm.
    #[arg(long, default_value_t = 15.0)]
    pub square: f64,
    /// Transpose each image first (a camera mounted on its side).
    #[arg(long)]
    pub transpose: bool,
    /// Mirror each image left to right (after transposing).
    #[arg(long)]
    pub flip: bool,
    /// Keep fy/fx at Zhang's estimate.
    #[arg(long)]
    pub fix_aspect_ratio: bool,
    /// Keep the principal point at the image centre.
    #[arg(long)]
    pub fix_principal_point: bool,
    /// No tangential distortion.
    #[arg(long)]
    pub zero_tangential: bool,
    /// No k3 term.
    #[arg(long)]
    pub fix_k3: bool,
    /// The camera's distortion terms: `auto` estimates those the board views support (k3 only when
    /// eight views or more reach the image's corners, p1 p2 from six views over half the image, the
    /// report says which and why); `full` estimates every term not held by a --fix flag.
    #[arg(long, value_enum, default_value = "auto")]
    pub lens_model: LensModelArg,
    /// Also export the camera in OpenCV's YAML layout.
    #[arg(long)]
    pub yaml: Option<PathBuf>,
    /// The rig to start from: its camera serves the projector, laser or turntable steps when the
    /// camera is not calibrated too, and what is not calibrated is kept (default: the output rig if
    /// it exists, else the capture folder's).
    #[arg(long)]
    pub rig: Option<PathBuf>,
    /// How high the board's lowest inner corners stand above the platter, mm (Horus' and FabScan's
    /// "origin distance"; default two squares, the simulator's stand).
    #[arg(long)]
    pub corner_height: Option<f64>,
    /// The projector's resolution, WIDTHxHEIGHT (default: the rig's projector).
    #[arg(long, value_parser = parse_size)]
    pub projector: Option<(u32, u32)>,
    /// Print the report as JSON (it is also written beside the rig, as NAME.report.json).
    #[arg(long)]
    pub json: bool,
    /// Write the rig even when its figures cannot be right (a reprojection error over 2 px, a
    /// principal point far off centre, runaway distortion); they are still warned about.
    #[arg(long)]
    pub force: bool,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum CalibrateTarget {
    /// Camera intrinsics and distortion from views of a chessboard.
    Camera,
    /// The projector's lens and pose from the board under the structured-light program.
    Projector,
    /// Laser planes from the laser frames of the board's positions.
    Laser,
    /// The turntable axis from the board standing on the platter, turned.
    Turntable,
    /// Every step the captures allow, the camera first.
    All,
    /// A camera from an OpenCV YAML file (camera_matrix, distortion_coefficients) into the rig.
    Import,
}

#[derive(clap::Args, Debug)]
pub struct AlignArgs {
    /// Cloud A, the one to move (.ply, .obj, .off, .stl, .glb, .e57; a mesh's vertices).
    pub moving: PathBuf,
    /// Cloud B, the one A is moved onto.
    pub fixed: PathBuf,
    /// Write A moved into B's frame here (normals turned with it).
    #[arg(long, short)]
    pub out: Option<PathBuf>,
    /// Write the motion and its confidence here as JSON (as --json prints).
    #[arg(long)]
    pub pose: Option<PathBuf>,
    /// The spacing both clouds are thinned to for matching, in their units (default: 1/100 of B's
    /// bounding-box diagonal).
    #[arg(long)]
    pub voxel: Option<f64>,
    /// The seed of the random search: the same clouds and seed give the same answer.
    #[arg(long, default_value_t = process::register::global::GlobalParams::default().seed)]
    pub seed: u64,
    /// Write the best guess even when it is not trusted (ambiguous, too little overlap).
    #[arg(long)]
    pub force: bool,
    /// Print the result as JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::Args, Debug)]
pub struct FuseArgs {
    /// The registered cloud (.ply with optional normals and confidence, .obj, .off vertices).
    pub input: PathBuf,
    /// The fused cloud (.ply or .obj), with normals.
    #[arg(long, short)]
    pub out: PathBuf,
    /// Fusion's settings.
    #[command(flatten)]
    pub fuse: FuseOpts,
    /// Also write the points removed as outliers here.
    #[arg(long)]
    pub outliers: Option<PathBuf>,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::Args, Debug)]
pub struct RegisterArgs {
    /// The scan folder (with scan.json), already through `scanrig process`.
    pub scan: PathBuf,
    /// The processed folder (default: SCAN/processed).
    #[arg(long)]
    pub processed: Option<PathBuf>,
    /// The registered, merged cloud (default: PROCESSED/registered.ply); poses go beside it as JSON.
    #[arg(long, short)]
    pub out: Option<PathBuf>,
    /// The object cylinder.
    #[command(flatten)]
    pub crop: CropOpts,
    /// The corrections accepted.
    #[command(flatten)]
    pub register: RegisterOpts,
    /// Print the poses as JSON.
    #[arg(long)]
    pub json: bool,
}
