//! `scanrig`: the command line. Arguments are parsed here ([`cli`]), turned into calls of the library
//! crates, and results printed; no algorithm lives in the binary.

mod calibrate;
mod cli;
mod convert;
mod decode_cmd;
mod demo;
mod denoise_cmd;
mod fuse_cmd;
mod info;
mod process_cmd;
mod reconstruct_cmd;
mod register_cmd;
mod remesh_cmd;
mod scan_cmd;
mod sim_cmd;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args = cli::Args::parse();
    let result = match args.command {
        cli::Command::Info(a) => info::run(&a),
        cli::Command::Convert(a) => convert::run(&a),
        cli::Command::Sim(a) => sim_cmd::run(&a),
        cli::Command::Process(a) => process_cmd::run(&a),
        cli::Command::Decode(a) => decode_cmd::run(&a),
        cli::Command::Denoise(a) => denoise_cmd::run(&a),
        cli::Command::Fuse(a) => fuse_cmd::run(&a),
        cli::Command::Reconstruct(a) => reconstruct_cmd::run(&a),
        cli::Command::Register(a) => register_cmd::run(&a),
        cli::Command::Remesh(a) => remesh_cmd::run(&a),
        cli::Command::Demo(a) => demo::run(&a),
        cli::Command::Calibrate(a) => calibrate::run(&a),
        cli::Command::Scan(a) => scan_cmd::scan(&a),
        cli::Command::Turntable(a) => scan_cmd::turntable(&a),
        cli::Command::VirtualTurntable(a) => scan_cmd::virtual_turntable(&a),
        cli::Command::Camera { command } => scan_cmd::camera(&command),
        cli::Command::Projector { command } => scan_cmd::projector(&command),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // A closed pipe (`scanrig info x.ply | head`) is the reader's choice, not a failure.
        Err(e) if is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| c.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe))
}
