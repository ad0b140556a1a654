//! Importing raw centerlines as tracks: the shipped profiles reproduced to the printed
//! digits, the index entry, the files of an import, and bad centerlines refused with
//! their row.

use planner::config::load_track_index;
use planner::track::import::{import_track, index_entry, profile_csv_text, smooth_checked};
use planner::track::map::{corners, TrackMap};
use planner::track::Profile;
use std::path::{Path, PathBuf};

fn data_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../config")
}

fn temp_root(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("planner-import-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("tracks")).unwrap();
    dir
}

/// A raw centerline CSV in `dir`: an ellipse of `n` points (counter-clockwise) with
/// widths 5 m, edited by `edit` (row index, line text) before writing.
fn ellipse_csv(
    dir: &Path,
    file: &str,
    n: usize,
    edit: impl Fn(usize, String) -> String,
) -> PathBuf {
    let mut text = String::from("# x_m,y_m,w_tr_right_m,w_tr_left_m\n");
    for i in 0..n {
        let a = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
        let line = format!("{:.4},{:.4},5.0,5.0", 300.0 * a.cos(), 150.0 * a.sin());
        text.push_str(&edit(i, line));
        text.push('\n');
    }
    let path = dir.join(file);
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn reimporting_a_shipped_raw_centerline_reproduces_its_profile_to_the_printed_digits() {
    for t in load_track_index(&data_root().join("tracks/tracks.toml")).unwrap() {
        let smoothed = smooth_checked(t.raw_csv.as_ref().unwrap(), false).unwrap();
        let ours = profile_csv_text(&smoothed.profile);
        let shipped = std::fs::read_to_string(&t.profile_csv).unwrap();
        assert_eq!(ours.lines().count(), shipped.lines().count(), "{}", t.name);
        let first_diff = ours.lines().zip(shipped.lines()).position(|(a, b)| a != b);
        assert_eq!(first_diff, None, "{}: first differing line", t.name);
    }
}

/// The `[[tracks]]` block of `name` in an index text.
fn block_of(text: &str, name: &str) -> String {
    text.split("[[tracks]]")
        .find(|b| b.contains(&format!("name = \"{name}\"")))
        .map(|b| format!("[[tracks]]{}", b.trim_end()))
        .unwrap_or_default()
}

#[test]
fn the_index_entry_of_a_reimported_track_matches_the_shipped_one() {
    let index = std::fs::read_to_string(data_root().join("tracks/tracks.toml")).unwrap();
    for t in load_track_index(&data_root().join("tracks/tracks.toml")).unwrap() {
        let smoothed = smooth_checked(t.raw_csv.as_ref().unwrap(), false).unwrap();
        let ours = index_entry(&t.name, &smoothed);
        assert_eq!(ours.trim_end(), block_of(&index, &t.name), "{}", t.name);
    }
}

#[test]
fn an_import_writes_the_profile_and_index_and_refuses_an_existing_name_without_force() {
    let root = temp_root("files");
    let raw = data_root().join("tracks/Budapest.csv");
    let t = import_track(&raw, &root, "Hungaroring", false, false).unwrap();
    assert_eq!(t.direction, "cw");
    let idx = load_track_index(&root.join("tracks/tracks.toml")).unwrap();
    assert_eq!(idx.len(), 1);
    assert_eq!(idx[0].name, "Hungaroring");
    let shipped = std::fs::read_to_string(data_root().join("tracks/Budapest_profile.csv")).unwrap();
    let ours = std::fs::read_to_string(root.join("tracks/Hungaroring_profile.csv")).unwrap();
    assert!(ours == shipped, "profile differs from the shipped one");
    assert_eq!(
        std::fs::read(root.join("tracks/Hungaroring.csv")).unwrap(),
        std::fs::read(&raw).unwrap()
    );
    let msg = import_track(&raw, &root, "Hungaroring", false, false)
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("a track named `Hungaroring` exists already"),
        "{msg}"
    );
    // A second track is appended; --force replaces an entry in place.
    import_track(
        &data_root().join("tracks/Spa.csv"),
        &root,
        "Spa",
        false,
        false,
    )
    .unwrap();
    import_track(&raw, &root, "Hungaroring", true, false).unwrap();
    let names: Vec<String> = load_track_index(&root.join("tracks/tracks.toml"))
        .unwrap()
        .into_iter()
        .map(|t| t.name)
        .collect();
    assert_eq!(names, ["Hungaroring", "Spa"]);
    let msg = import_track(&raw, &root, "no spaces", false, false)
        .unwrap_err()
        .to_string();
    assert!(msg.contains("track name `no spaces`"), "{msg}");
    let _ = std::fs::remove_dir_all(&root);
}

/// The error of importing the ellipse edited by `edit`.
fn import_error(tag: &str, n: usize, edit: impl Fn(usize, String) -> String) -> String {
    let root = temp_root(tag);
    let raw = ellipse_csv(&root, "raw.csv", n, edit);
    let msg = import_track(&raw, &root, "T", false, false)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        msg.is_empty() || !root.join("tracks/tracks.toml").exists(),
        "{tag}: a failed import wrote the index"
    );
    let _ = std::fs::remove_dir_all(&root);
    msg
}

#[test]
fn a_clean_synthetic_ellipse_imports() {
    assert_eq!(import_error("clean", 300, |_, l| l), "");
}

#[test]
fn bad_centerlines_are_refused_with_their_row() {
    // Line numbers: line 1 is the comment, row i is on line i + 2.
    let too_few = import_error("few", 3, |_, l| l);
    assert!(
        too_few.contains("3 points: a closed centerline needs at least 4"),
        "{too_few}"
    );
    let nan = import_error("nan", 300, |i, l| {
        if i == 10 {
            "nan,1.0,5.0,5.0".into()
        } else {
            l
        }
    });
    assert!(
        nan.contains("raw.csv:12: x_m = NaN: must be finite"),
        "{nan}"
    );
    let neg = import_error("neg", 300, |i, l| {
        if i == 20 {
            l.replace(",5.0,5.0", ",-1.0,5.0")
        } else {
            l
        }
    });
    assert!(
        neg.contains("raw.csv:22: track widths must be positive"),
        "{neg}"
    );
    let dup = import_error("dup", 300, |i, l| {
        if i == 31 {
            let a = 2.0 * std::f64::consts::PI * 30.0 / 300.0;
            format!("{:.4},{:.4},5.0,5.0", 300.0 * a.cos(), 150.0 * a.sin())
        } else {
            l
        }
    });
    assert!(
        dup.contains("raw.csv:33: point repeats the previous one"),
        "{dup}"
    );
    let closed = import_error("closed", 301, |i, l| {
        if i == 300 {
            "300.0000,0.0000,5.0,5.0".into()
        } else {
            l
        }
    });
    assert!(
        closed.contains("raw.csv:302: the last point repeats the first (line 2)"),
        "{closed}"
    );
}

#[test]
fn a_self_crossing_centerline_is_refused_unless_marked_as_a_figure_eight() {
    let root = temp_root("eight");
    let mut text = String::from("# x_m,y_m,w_tr_right_m,w_tr_left_m\n");
    for i in 0..400 {
        let t = 2.0 * std::f64::consts::PI * (i as f64 + 0.5) / 400.0;
        text.push_str(&format!(
            "{:.4},{:.4},4.0,4.0\n",
            400.0 * t.cos(),
            200.0 * (2.0 * t).sin()
        ));
    }
    let raw = root.join("eight.csv");
    std::fs::write(&raw, text).unwrap();
    let msg = import_track(&raw, &root, "Eight", false, false)
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("the centerline crosses itself: the stretch from line"),
        "{msg}"
    );
    assert!(msg.contains("--figure-eight"), "{msg}");
    let t = import_track(&raw, &root, "Eight", false, true).unwrap();
    assert_eq!(t.direction, "figure-eight");
    // A plain loop marked as a figure eight is refused too.
    let oval = ellipse_csv(&root, "oval.csv", 300, |_, l| l);
    let msg = import_track(&oval, &root, "Oval", false, true)
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("imported as a figure eight, but the curvature winds 1.00 times"),
        "{msg}"
    );
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn the_rebuilt_map_follows_the_raw_centerline_and_closes() {
    for t in load_track_index(&data_root().join("tracks/tracks.toml")).unwrap() {
        let profile = Profile::load(&t.profile_csv, t.lap_length).unwrap();
        let map = TrackMap::new(&profile, t.start_pose);
        let first = map.poses[0];
        let last = *map.poses.last().unwrap();
        let gap = (last[0] - first[0]).hypot(last[1] - first[1]);
        // README: the 1 m curvature rebuilds the smoothed centerline to 0.1-0.55 m per lap.
        assert!(gap < 0.6, "{}: lap closes within {gap} m", t.name);
        // The first raw point lies on the rebuilt start (within the smoothing shift).
        let raw = std::fs::read_to_string(t.raw_csv.as_ref().unwrap()).unwrap();
        let p: Vec<f64> = raw
            .lines()
            .find(|l| !l.starts_with('#'))
            .unwrap()
            .split(',')
            .map(|v| v.trim().parse().unwrap())
            .collect();
        assert!((p[0] - first[0]).hypot(p[1] - first[1]) < 1.5, "{}", t.name);
    }
}

#[test]
fn austin_has_its_four_hairpins_among_the_corners() {
    let t = load_track_index(&data_root().join("tracks/tracks.toml"))
        .unwrap()
        .into_iter()
        .find(|t| t.name == "Austin")
        .unwrap();
    let profile = Profile::load(&t.profile_csv, t.lap_length).unwrap();
    let cs = corners(&profile);
    // segments.toml: T1 at s 664, T11 at 2587, T12 at 3782, T15 at 4294 (R 11-14 m, left).
    for s in [664.0, 2587.0, 3782.0, 4294.0] {
        let c = cs
            .iter()
            .find(|c| (c.s_peak - s).abs() < 2.0)
            .expect("hairpin found");
        assert_eq!(c.direction(), "left");
        assert!(
            1.0 / c.kappa_peak < 15.0 && c.turn.to_degrees() > 110.0,
            "{c:?}"
        );
    }
    assert!(cs.windows(2).all(|w| w[0].s_peak < w[1].s_peak));
    assert_eq!(cs[0].number, 1);
}
