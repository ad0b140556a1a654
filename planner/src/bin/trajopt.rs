//! `trajopt`: command-line front end of the planner.
fn main() {}
