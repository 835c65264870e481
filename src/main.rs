//! `scanrig`: the command line. Arguments are parsed here ([`cli`]), turned into calls of the library
//! crates, and results printed; no algorithm lives in the binary.

mod align_cmd;
mod calibrate;
mod cli;
mod convert;
mod decode_cmd;
mod demo;
mod denoise_cmd;
mod fuse_cmd;
mod info;
mod inputs;
mod json_outputs;
mod outputs;
mod pages;
mod process_cmd;
mod progress;
mod reconstruct_cmd;
mod register_cmd;
mod remesh_cmd;
mod scan_cmd;
mod scanner_files;
mod sim_cmd;
mod stage_args;
mod station;
mod virtual_rig;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    process::pipeline::memory::limit_arenas();
    // A panic is a bug in scanrig, never the user's doing: say so in one line, with where it happened,
    // instead of Rust's panic text and backtrace.
    std::panic::set_hook(Box::new(|info| {
        let what = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_default();
        let at = info.location().map(|l| format!(" ({}:{})", l.file(), l.line())).unwrap_or_default();
        eprintln!("error: internal error in scanrig{at}: {what}. This is a bug; please report it with the command.");
    }));
    let args = cli::Args::parse_from(negative_values_attached(std::env::args_os()));
    progress::set_quiet(args.quiet);
    // Every command is one run: what it reads is never replaced by what it writes (rig::run_files).
    let _run = rig::run_files::Run::open();
    let result = match args.command {
        cli::Command::Info(a) => info::run(&a),
        cli::Command::Convert(a) => convert::run(&a),
        cli::Command::Sim(a) => sim_cmd::run(&a),
        cli::Command::Process(a) => process_cmd::run(&a),
        cli::Command::Decode(a) => decode_cmd::run(&a),
        cli::Command::Serve(a) => station::run(&a),
        cli::Command::Denoise(a) => denoise_cmd::run(&a),
        cli::Command::Align(a) => align_cmd::run(&a),
        cli::Command::Fuse(a) => fuse_cmd::run(&a),
        cli::Command::Reconstruct(a) => reconstruct_cmd::run(&a),
        cli::Command::Register(a) => register_cmd::run(&a),
        cli::Command::Remesh(a) => remesh_cmd::run(&a),
        cli::Command::Demo(a) => demo::run(&a),
        cli::Command::Calibrate(a) => calibrate::run(&a),
        cli::Command::Report(a) => pages::report(&a),
        cli::Command::View(a) => pages::view(&a),
        cli::Command::Scan(a) => scan_cmd::scan(&a),
        cli::Command::Turntable(a) => scan_cmd::turntable(&a),
        cli::Command::VirtualTurntable(a) => scan_cmd::virtual_turntable(&a),
        cli::Command::Import { command } => scanner_files::import(&command),
        cli::Command::Export { command } => scanner_files::export(&command),
        cli::Command::Camera { command } => scan_cmd::camera(&command),
        cli::Command::Projector { command } => scan_cmd::projector(&command),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // A closed pipe (`scanrig info x.ply | head`) is the reader's choice, not a failure.
        Err(e) if is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", message(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes on one line: a cause whose text the message already holds (errors that
/// print their source as part of themselves) is not repeated, and control characters from file
/// contents are shown escaped rather than sent to the terminal.
fn message(e: &anyhow::Error) -> String {
    let mut text = e.to_string();
    for cause in e.chain().skip(1) {
        let c = cause.to_string();
        if !text.contains(&c) {
            text.push_str(": ");
            text.push_str(&c);
        }
    }
    text.chars()
        .flat_map(|c| {
            let escaped: Vec<char> = if c.is_control() { c.escape_default().collect() } else { vec![c] };
            escaped
        })
        .collect()
}

/// `--k -1` as `--k=-1`: clap takes a lone `-1` or `-inf` for an unknown flag and says "unexpected
/// argument '-1'", naming no option; attached, the value reaches the option's parser or the library's
/// limits, whose refusal names the option (`--k -1: must be from 6 …`). A value after a flag that
/// takes none is then refused naming that flag.
fn negative_values_attached(args: impl IntoIterator<Item = std::ffi::OsString>) -> Vec<std::ffi::OsString> {
    let mut out: Vec<std::ffi::OsString> = Vec::new();
    for a in args {
        // A value that starts like a negative number: `-1`, `-.5`, `-inf`, `-NaN`, `-1x768`, `-5,0,0`.
        let numeric = a.to_str().and_then(|t| t.strip_prefix('-')).is_some_and(|rest| {
            let lower = rest.to_ascii_lowercase();
            rest.starts_with(|c: char| c.is_ascii_digit() || c == '.')
                || lower.starts_with("inf")
                || lower.starts_with("nan")
        });
        let after_option =
            out.last().and_then(|p| p.to_str()).is_some_and(|p| p.starts_with("--") && p.len() > 2 && !p.contains('='));
        match out.last_mut() {
            Some(prev) if numeric && after_option => {
                prev.push("=");
                prev.push(&a);
            }
            _ => out.push(a),
        }
    }
    out
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| c.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe))
}

#[cfg(test)]
mod tests {
    #[test]
    fn negative_numbers_are_attached_to_the_option_before_them() {
        let args = |v: &[&str]| v.iter().map(std::ffi::OsString::from).collect::<Vec<_>>();
        let got = super::negative_values_attached(args(&["scanrig", "x", "--k", "-1", "--x", "-inf", "--p", "-1x768"]));
        assert_eq!(got, args(&["scanrig", "x", "--k=-1", "--x=-inf", "--p=-1x768"]));
        // Short options, attached values and plain arguments stay as they are.
        let same = args(&["scanrig", "fuse", "-o", "-1", "--k=-2", "--out", "x", "-"]);
        assert_eq!(super::negative_values_attached(same.clone()), same);
    }

    #[test]
    fn messages_say_each_cause_once_and_escape_control_characters() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file or directory (os error 2)");
        let e = anyhow::Error::new(rig::Error::io(std::path::Path::new("a.ply"), io)).context("reading a.ply");
        let m = super::message(&e);
        assert_eq!(m.matches("No such file or directory").count(), 1, "{m}");
        let e = anyhow::anyhow!("bad name \u{1b}[31mred\u{7}");
        assert_eq!(super::message(&e), "bad name \\u{1b}[31mred\\u{7}");
    }
}
