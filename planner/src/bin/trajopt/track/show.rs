//! `trajopt track show NAME`: `out/<name>_track.png` and the corner list.

use std::path::PathBuf;

use planner::config::load_track_index;
use planner::plot_track::{plot_track, TrackFigure};
use planner::track::map::{corners, TrackMap};
use planner::track::Profile;

use super::DataRoot;
use crate::out::outln;
use crate::paths::resolve;

#[derive(clap::Args, Debug)]
pub struct ShowArgs {
    /// Track name (an entry of tracks/tracks.toml).
    name: String,
    /// Folder for the PNG.
    #[arg(long, default_value = "out")]
    out_dir: PathBuf,
    /// Print exactly one JSON object on stdout.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    root: DataRoot,
}

/// Draws the track and prints its corners.
pub fn run(args: ShowArgs) -> Result<(), String> {
    let index = resolve(&args.root.data_root).join("tracks/tracks.toml");
    let tracks = load_track_index(&index).map_err(|e| e.to_string())?;
    let Some(t) = tracks.iter().find(|t| t.name == args.name) else {
        let names: Vec<&str> = tracks.iter().map(|t| t.name.as_str()).collect();
        return Err(format!(
            "{}: no track named `{}` (have: {})",
            index.display(),
            args.name,
            names.join(", ")
        ));
    };
    let profile = Profile::load(&t.profile_csv, t.lap_length).map_err(|e| e.to_string())?;
    let map = TrackMap::new(&profile, t.start_pose);
    let list = corners(&profile);
    std::fs::create_dir_all(&args.out_dir)
        .map_err(|e| format!("{}: cannot create: {e}", args.out_dir.display()))?;
    let png = args.out_dir.join(format!("{}_track.png", t.name));
    let fig = TrackFigure {
        name: &t.name,
        profile: &profile,
        map: &map,
        corners: &list,
        plan: None,
    };
    plot_track(&fig, &png).map_err(|e| format!("track figure: {e}"))?;
    if args.json {
        let cs: Vec<serde_json::Value> = list
            .iter()
            .map(|c| {
                serde_json::json!({
                    "corner": c.number, "s_m": c.s_peak, "s_start_m": c.s_start, "s_end_m": c.s_end,
                    "kappa_peak_1pm": c.kappa_peak, "radius_m": 1.0 / c.kappa_peak.abs(),
                    "direction": c.direction(), "turn_deg": c.turn.to_degrees(),
                })
            })
            .collect();
        outln!(
            "{}",
            serde_json::json!({
                "track": t.name, "lap_length_m": profile.lap_length(), "corners": cs,
                "files": [png.display().to_string()],
            })
        );
        return Ok(());
    }
    outln!(
        "{}: lap {:.1} m, {} corners (|kappa| > 1/200 m, turning 15 deg or more)",
        t.name,
        profile.lap_length(),
        list.len()
    );
    outln!("corner   s [m]   peak kappa [1/m]   R [m]  direction  turn [deg]");
    for c in &list {
        outln!(
            "{:>6} {:>7.0} {:>18.4} {:>7.1}  {:<9} {:>10.0}",
            c.number,
            c.s_peak,
            c.kappa_peak,
            1.0 / c.kappa_peak.abs(),
            c.direction(),
            c.turn.to_degrees()
        );
    }
    outln!("  wrote {}", png.display());
    Ok(())
}
