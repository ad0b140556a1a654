//! Track profiles: the shipped canonical CSVs, smoothing raw centerlines, segment sampling.

use planner::config::{load_track_index, Direction, TrackInfo};
use planner::track::{BoundsOverride, Profile, Road, Segment};
use std::f64::consts::PI;
use std::path::PathBuf;

fn data_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../config")
}

fn index() -> Vec<TrackInfo> {
    load_track_index(&data_root().join("tracks/tracks.toml")).expect("shipped track index loads")
}

#[test]
fn index_lists_the_five_tracks_with_directions() {
    let idx = index();
    let names: Vec<&str> = idx.iter().map(|t| t.name.as_str()).collect();
    assert_eq!(
        names,
        ["Austin", "Budapest", "Montreal", "Silverstone", "Spa"]
    );
    assert_eq!(idx[0].direction, Direction::Ccw);
    assert!(idx[1..].iter().all(|t| t.direction == Direction::Cw));
    assert!(idx.iter().all(|t| t.profile_csv.is_file()));
    assert!(idx
        .iter()
        .all(|t| t.raw_csv.as_ref().is_some_and(|p| p.is_file())));
}

#[test]
fn shipped_profiles_load_and_close_the_loop() {
    for t in index() {
        let p = Profile::load(&t.profile_csv, t.lap_length).expect("profile loads");
        assert_eq!(p.n_rows(), t.lap_length.ceil() as usize, "{}", t.name);
        let turns = p.total_turning() / (2.0 * PI);
        assert!(
            (turns - t.direction.winding()).abs() < 0.01,
            "{}: {turns} turns",
            t.name
        );
    }
}

#[test]
fn profile_sampling_interpolates_and_wraps() {
    let t = &index()[0];
    let p = Profile::load(&t.profile_csv, t.lap_length).unwrap();
    let lap = p.lap_length();
    // On a row: the row itself. Between rows: the mean.
    let (k10, wr10, wl10) = p.sample(10.0);
    assert_eq!(
        (k10, wr10, wl10),
        (p.kappa()[10], p.w_right()[10], p.w_left()[10])
    );
    let (k, _, _) = p.sample(10.5);
    assert!((k - 0.5 * (p.kappa()[10] + p.kappa()[11])).abs() < 1e-15);
    // Wrap-around: one lap later / earlier is the same point.
    for s in [0.0, 123.4, 5000.25] {
        let a = p.sample(s);
        for b in [
            p.sample(s + lap),
            p.sample(s - lap),
            p.sample(s + 3.0 * lap),
        ] {
            assert!(
                (a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9 && (a.2 - b.2).abs() < 1e-9
            );
        }
    }
    // Past the last row: toward row 0 placed at s = lap.
    let last = p.n_rows() - 1;
    let s_last = last as f64;
    let mid = 0.5 * (s_last + lap);
    let (k, wr, _) = p.sample(mid);
    assert!((k - 0.5 * (p.kappa()[last] + p.kappa()[0])).abs() < 1e-12);
    assert!((wr - 0.5 * (p.w_right()[last] + p.w_right()[0])).abs() < 1e-12);
    // Continuity at the lap end.
    let (k_end, _, _) = p.sample(lap - 1e-9);
    assert!((k_end - p.kappa()[0]).abs() < 1e-9);
}

/// Smoothing every raw centerline reproduces the direction (lap integral of kappa =
/// +-2 pi within 1 %) and the shipped profile (RMS of the curvature difference).
#[test]
fn centerline_smoothing_matches_shipped_profiles() {
    for t in index() {
        let raw = t.raw_csv.as_ref().expect("raw csv named");
        let ours = Profile::from_centerline(raw).expect("raw centerline smooths");
        let turns = ours.total_turning() / (2.0 * PI);
        let want = t.direction.winding();
        assert!(
            (turns - want).abs() < 0.01,
            "{}: {turns} turns, want {want}",
            t.name
        );
        assert!(
            (ours.lap_length() - t.lap_length).abs() < 0.01,
            "{}: lap {} vs {}",
            t.name,
            ours.lap_length(),
            t.lap_length
        );
        let shipped = Profile::load(&t.profile_csv, t.lap_length).unwrap();
        let n = shipped.n_rows().min(ours.n_rows());
        let rms = |a: &[f64], b: &[f64]| {
            (a[..n]
                .iter()
                .zip(&b[..n])
                .map(|(x, y)| (x - y).powi(2))
                .sum::<f64>()
                / n as f64)
                .sqrt()
        };
        let rms_k = rms(ours.kappa(), shipped.kappa());
        let rms_shipped = rms(shipped.kappa(), &vec![0.0; n]);
        let rms_wr = rms(ours.w_right(), shipped.w_right());
        let rms_wl = rms(ours.w_left(), shipped.w_left());
        println!(
            "{}: turns {turns:.6}, lap {:.3} (index {:.3}), rms kappa diff {rms_k:.2e} (rms kappa {rms_shipped:.2e}), rms width diff {rms_wr:.2e} / {rms_wl:.2e}",
            t.name,
            ours.lap_length(),
            t.lap_length
        );
        // The shipped CSV rounds kappa to 1e-8 and widths to 1e-3 (RMS rounding error
        // 2.9e-9 and 2.9e-4): the same method gives the same profile up to that.
        assert!(rms_k < 1e-7, "{}: rms kappa difference {rms_k}", t.name);
        assert!(
            rms_wr < 1e-3 && rms_wl < 1e-3,
            "{}: rms width difference {rms_wr} / {rms_wl}",
            t.name
        );
    }
}

#[test]
fn segment_wraps_around_the_lap_end() {
    let t = &index()[0];
    let p = Profile::load(&t.profile_csv, t.lap_length).unwrap();
    let seg = Segment {
        s_start: p.lap_length() - 50.0,
        length: 100.0,
        n_intervals: 40,
    };
    let road = seg.sample(&p, 1.0);
    assert_eq!(road.kappa.len(), 41);
    // Node 20 sits at local s = 50, i.e. exactly on the lap start.
    let (k0, wr0, wl0) = p.sample(0.0);
    assert!((road.kappa[20] - k0).abs() < 1e-9);
    assert!((road.e_min[20] - (-wr0 + 1.0)).abs() < 1e-9);
    assert!((road.e_max[20] - (wl0 - 1.0)).abs() < 1e-9);
    // Node 40 (local s = 100) is track s = 50 of the next lap.
    let (k50, _, _) = p.sample(50.0);
    assert!((road.kappa[40] - k50).abs() < 1e-9);
}

#[test]
fn overrides_replace_bounds_on_closed_intervals() {
    let mut road = Road::uniform(10.0, 10, 0.0, -3.0, 3.0);
    road.apply_overrides(&[
        BoundsOverride {
            s_from: 2.0,
            s_to: 4.0,
            e_min: 1.0,
            e_max: 3.0,
        },
        BoundsOverride {
            s_from: 7.5,
            s_to: 7.9,
            e_min: -3.0,
            e_max: -1.0,
        },
    ]);
    assert_eq!(
        road.e_min,
        [-3.0, -3.0, 1.0, 1.0, 1.0, -3.0, -3.0, -3.0, -3.0, -3.0, -3.0]
    );
    // [7.5, 7.9] contains no node: nothing changes.
    assert!(road.e_max.iter().all(|&e| e == 3.0));
}

#[test]
fn a_profile_row_whose_lane_reaches_the_curvature_centre_is_refused_with_its_line() {
    use planner::track::beyond_curvature_centre;
    assert_eq!(beyond_curvature_centre(0.04, -4.0, 4.0), None);
    assert_eq!(
        beyond_curvature_centre(0.25, -4.0, 4.0),
        Some(("e_max", 0.0))
    );
    assert_eq!(
        beyond_curvature_centre(-0.5, -4.0, 4.0),
        Some(("e_min", -1.0))
    );
    assert!(beyond_curvature_centre(f64::NAN, -4.0, 4.0).is_some());
    let dir = std::env::temp_dir().join(format!("planner-track-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("curl_profile.csv");
    let mut text = String::from("s_m,kappa_1pm,w_right_m,w_left_m\n");
    for i in 0..10 {
        let kappa = if i == 6 { "1e308" } else { "0.01" };
        text.push_str(&format!("{i}.0,{kappa},5.0,5.0\n"));
    }
    std::fs::write(&path, &text).unwrap();
    let msg = Profile::load(&path, 10.0).unwrap_err().to_string();
    assert!(
        msg.contains("curl_profile.csv:8: kappa_1pm = 1e308: the track edge w_left_m = 5"),
        "{msg}"
    );
    // At the edge's limit, 1/kappa = 5 m: still refused (1 - kappa e = 0).
    std::fs::write(&path, text.replace("1e308", "0.2")).unwrap();
    assert!(Profile::load(&path, 10.0).is_err());
    std::fs::write(&path, text.replace("1e308", "0.19")).unwrap();
    assert!(Profile::load(&path, 10.0).is_ok());
    let _ = std::fs::remove_dir_all(&dir);
}
