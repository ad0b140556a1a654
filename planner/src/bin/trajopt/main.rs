//! `trajopt`: command-line front end of the planner.
//!
//! `trajopt solve` solves one scenario (the oval by default) from the equilibrium or zero
//! guess, prints a summary (stderr with `--json`, whose single JSON object goes to stdout),
//! and writes the trajectory as CSV and a PNG figure; `--record FILE.mcap` records every
//! solve's input and output for `replay`. Exit code 0 when the solve ran, whatever its
//! status; 2 on bad input.
//!
//! This file parses the command line and dispatches; each subcommand lives in its own
//! module ([`solve`], [`guess`], [`closed_loop`], [`study`]), the option types they share
//! in [`args`] and the path helpers in [`paths`].

mod args;
mod closed_loop;
mod guess;
mod out;
mod paths;
mod solve;
mod study;
mod track;

use std::process::ExitCode;

use crate::out::errln;
use clap::{Parser, Subcommand};

#[derive(Parser, Debug)]
#[command(
    name = "trajopt",
    version,
    about = "Reference-free minimum-time trajectory optimizer"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

// Parsed once per run: the size of its largest variant costs nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand, Debug)]
enum Command {
    /// Solve one scenario (default: the oval) and write CSV + PNG.
    Solve(solve::SolveArgs),
    /// Compute and print the equilibrium initial guess of a vehicle (paper eq. 8).
    Guess(guess::GuessArgs),
    /// Run the planner and tracker processes (ipc crate) in closed loop and summarise.
    ClosedLoop(closed_loop::ClosedLoopArgs),
    /// Reproduce a study of the paper (tables + PNG; `--json` for one JSON object).
    #[command(subcommand)]
    Study(study::StudyCommand),
    /// Import a track from a raw centerline, or draw one with its corners.
    #[command(subcommand)]
    Track(track::TrackCommand),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // A progress bar on stderr for the long commands, only on a terminal and never with --json.
    planner::progress::install_terminal(std::env::args().any(|a| a == "--json"));
    // No subcommand: solve the built-in default scenario (the oval).
    let command = match cli.command {
        Some(c) => c,
        None => match Cli::parse_from(["trajopt", "solve"]).command {
            Some(c) => c,
            None => return ExitCode::from(2),
        },
    };
    let result = match command {
        Command::Solve(args) => solve::run(args),
        Command::Guess(args) => guess::run(args),
        Command::ClosedLoop(args) => closed_loop::run(args),
        Command::Study(command) => study::run(command),
        Command::Track(command) => track::run(command),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(msg) => {
            errln!("trajopt: error: {msg}");
            ExitCode::from(2)
        }
    }
}
