//! `tracker_proc`: the plant + tracker process of the closed loop (see `ipc::tracker_proc`).
//! Prints one JSON summary line on stdout when it stops; exit 2 on setup errors, 1 otherwise.

use std::process::ExitCode;

use clap::Parser;

#[derive(Parser, Debug)]
#[command(
    name = "tracker_proc",
    about = "Simulates the car and tracks plans received over iceoryx2"
)]
struct Cli {
    #[command(flatten)]
    args: ipc::tracker_proc::TrackerArgs,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match ipc::tracker_proc::run(&cli.args) {
        Ok(summary) => match ipc::out::print_line(&summary) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                ipc::elog!("tracker_proc: cannot write the summary: {e}");
                ExitCode::from(1)
            }
        },
        Err(e) => {
            ipc::elog!("tracker_proc: error: {e}");
            match e {
                ipc::tracker_proc::TrackerProcError::Setup(_) => ExitCode::from(2),
                _ => ExitCode::from(1),
            }
        }
    }
}
