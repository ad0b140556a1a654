//! `trajopt track`: bring a raw centerline in as a named track (`import`), and draw a
//! track with its corners (`show`).

mod import;
mod show;

use std::path::PathBuf;

/// The `track` subcommands.
#[derive(clap::Subcommand, Debug)]
pub enum TrackCommand {
    /// Smooth a raw centerline CSV (x_m, y_m, w_tr_right_m, w_tr_left_m) into a profile and
    /// add it to the track index.
    Import(import::ImportArgs),
    /// Draw a track (map with s marks and numbered corners; curvature and widths against s)
    /// and list its corners.
    Show(show::ShowArgs),
}

/// The data root option the track commands share.
#[derive(clap::Args, Debug)]
pub struct DataRoot {
    /// Data root: the folder holding tracks/ (tracks.toml and the profiles).
    #[arg(long, default_value = "config")]
    pub data_root: PathBuf,
}

/// Runs a `track` subcommand.
pub fn run(command: TrackCommand) -> Result<(), String> {
    match command {
        TrackCommand::Import(args) => import::run(args),
        TrackCommand::Show(args) => show::run(args),
    }
}

/// `trajopt solve --track NAME --start-s S`: a stretch of a track with the defaults of
/// `config/scenarios/segments.toml`, no scenario file needed.
#[derive(clap::Args, Debug)]
#[allow(rustdoc::broken_intra_doc_links)] // clap prints these docs as --help: unit brackets stay unescaped
pub struct StretchArgs {
    /// Solve a stretch of this track (an entry of DATA_ROOT/tracks/tracks.toml) instead of
    /// a scenario file.
    #[arg(long, requires = "start_s", conflicts_with_all = ["scenario", "segment"])]
    track: Option<String>,
    /// Track arc length [m] where the stretch starts (with --track).
    #[arg(long, requires = "track", allow_negative_numbers = true)]
    start_s: Option<f64>,
    /// Length of the stretch [m] (with --track; node spacing length / N at most 5 m).
    #[arg(long, default_value_t = 250.0, requires = "track")]
    length_m: f64,
    /// Distance kept from each track edge [m] (with --track).
    #[arg(long, default_value_t = 1.0, requires = "track")]
    edge_margin_m: f64,
    /// Data root of --track: the folder holding tracks/.
    #[arg(long = "track-data-root", default_value = "config", requires = "track")]
    data_root: PathBuf,
}

impl StretchArgs {
    /// The stretch's spec and layout, or `None` without `--track`.
    pub fn load(
        &self,
        vehicle: planner::model::VehicleParams,
    ) -> Result<Option<(planner::ocp::OcpSpec, planner::config::Layout)>, String> {
        let (Some(track), Some(start_s)) = (&self.track, self.start_s) else {
            return Ok(None);
        };
        planner::config::stretch_layout(
            &crate::paths::resolve(&self.data_root),
            track,
            start_s,
            self.length_m,
            self.edge_margin_m,
            vehicle,
        )
        .map(Some)
        .map_err(|e| e.to_string())
    }
}

/// Draws a plan on the map of its track: `<out_dir>/<plan name>_track.png`.
pub fn draw_plan(
    track: &planner::config::TrackInfo,
    traj: &planner::trajectory::Trajectory,
    out_dir: &std::path::Path,
) -> Result<PathBuf, String> {
    use planner::track::map::{corners, TrackMap};
    let profile = planner::track::Profile::load(&track.profile_csv, track.lap_length)
        .map_err(|e| e.to_string())?;
    let map = TrackMap::new(&profile, track.start_pose);
    let list = corners(&profile);
    let png = out_dir.join(format!("{}_track.png", traj.name));
    let fig = planner::plot_track::TrackFigure {
        name: &track.name,
        profile: &profile,
        map: &map,
        corners: &list,
        plan: Some(traj),
    };
    planner::plot_track::plot_track(&fig, &png).map_err(|e| format!("track figure: {e}"))?;
    Ok(png)
}
