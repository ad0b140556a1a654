//! `trajopt track import FILE.csv [--name NAME]`: the profile, a copy of the raw file and
//! the index entry, written into the data root.

use std::path::PathBuf;

use planner::track::import::import_track;
use planner::track::map::corners;

use super::DataRoot;
use crate::out::outln;
use crate::paths::resolve;

#[derive(clap::Args, Debug)]
pub struct ImportArgs {
    /// Raw centerline CSV in the TUMFTM racetrack-database columns
    /// (x_m, y_m, w_tr_right_m, w_tr_left_m; the last point joins the first).
    file: PathBuf,
    /// Track name (letters, digits, `_`, `-`); default: the file name without `.csv`.
    #[arg(long)]
    name: Option<String>,
    /// Replace a track of the same name.
    #[arg(long)]
    force: bool,
    /// The centerline crosses itself on purpose (a figure-eight track).
    #[arg(long)]
    figure_eight: bool,
    #[command(flatten)]
    root: DataRoot,
}

/// Imports the track and prints what was written.
pub fn run(args: ImportArgs) -> Result<(), String> {
    let name = match &args.name {
        Some(n) => n.clone(),
        None => args
            .file
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
    };
    let root = resolve(&args.root.data_root);
    let t = import_track(&args.file, &root, &name, args.force, args.figure_eight)
        .map_err(|e| e.to_string())?;
    let st = &t.smoothed.stats;
    outln!(
        "{}: lap {:.3} m, {}, {} corners, max |kappa| {:.4} 1/m (R {:.1} m), min widths {:.2} / {:.2} m (left / right), smoothing moved the centerline by at most {:.2} m",
        t.name,
        t.smoothed.profile.lap_length(),
        t.direction,
        corners(&t.smoothed.profile).len(),
        st.max_abs_kappa,
        1.0 / st.max_abs_kappa,
        st.min_w_left,
        st.min_w_right,
        st.max_centerline_shift
    );
    for f in &t.files {
        outln!("  wrote {}", f.display());
    }
    outln!("  next: trajopt track show {name}; trajopt solve --track {name} --start-s S");
    Ok(())
}
