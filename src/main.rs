//! `scanrig`: the command line. Arguments are parsed here ([`cli`]), turned into calls of the library
//! crates, and results printed; no algorithm lives in the binary.

mod cli;
mod convert;
mod info;
mod sim_cmd;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args = cli::Args::parse();
    let result = match args.command {
        cli::Command::Info(a) => info::run(&a),
        cli::Command::Convert(a) => convert::run(&a),
        cli::Command::Sim(a) => sim_cmd::run(&a),
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
