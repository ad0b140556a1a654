//! `planner_proc`: the planner process of the closed loop (see `ipc::planner_proc`).
//! Prints one JSON summary line on stdout when it stops; exit 2 on setup errors, 1 on IPC errors.

use std::process::ExitCode;

use clap::Parser;

#[derive(Parser, Debug)]
#[command(
    name = "planner_proc",
    about = "Replans over iceoryx2 from the latest vehicle state"
)]
struct Cli {
    #[command(flatten)]
    args: ipc::planner_proc::PlannerArgs,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match ipc::planner_proc::run(&cli.args) {
        Ok(summary) => match ipc::out::print_line(&summary) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                ipc::elog!("planner_proc: cannot write the summary: {e}");
                ExitCode::from(1)
            }
        },
        Err(e) => {
            ipc::elog!("planner_proc: error: {e}");
            match e {
                ipc::planner_proc::PlannerProcError::Setup(_) => ExitCode::from(2),
                ipc::planner_proc::PlannerProcError::Ipc(_) => ExitCode::from(1),
            }
        }
    }
}
