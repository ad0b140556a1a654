//! Figures of the segment study: the convergence plot (optimality error against iteration,
//! every segment; paper Fig. 5) and the planned paths of all segments on the whole track.

use std::path::Path;

use plotters::prelude::*;
use serde::Deserialize;

use super::segments::SegmentsStudy;
use super::StudyError;
use crate::config::data_root_of;
use crate::model::ix;
use crate::plot::{centerline_xy, draw_err, ensure_font, save_png, FONT};
use crate::track::Profile;

/// Convergence figure: two panels (equilibrium guess, zero guess), one log-scale curve of
/// the optimality error per segment.
pub fn plot_convergence(study: &SegmentsStudy, path: &Path) -> Result<(), StudyError> {
    ensure_font()?;
    save_png(path, (1400, 600), |root| {
        root.fill(&WHITE).map_err(draw_err)?;
        let panels = root.split_evenly((1, 2));
        for (area, guess) in panels.iter().zip(["equilibrium", "zero"]) {
            let runs: Vec<_> = study.runs.iter().filter(|r| r.guess == guess).collect();
            let max_it = runs
                .iter()
                .map(|r| r.history.len())
                .max()
                .unwrap_or(1)
                .max(2);
            let mut chart = ChartBuilder::on(area)
                .caption(format!("optimality error, {guess} guess"), (FONT, 22))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(0f64..max_it as f64, (1e-10f64..1e5f64).log_scale())
                .map_err(draw_err)?;
            chart
                .configure_mesh()
                .x_desc("iteration")
                .y_desc("max(inf_pr, inf_du, compl)")
                .y_label_formatter(&|v| format!("{v:.0e}"))
                .draw()
                .map_err(draw_err)?;
            for (i, r) in runs.iter().enumerate() {
                let color = Palette99::pick(i).to_rgba();
                let pts: Vec<(f64, f64)> = r
                    .history
                    .iter()
                    .enumerate()
                    .map(|(k, &e)| (k as f64, e.clamp(1e-10, 1e5)))
                    .collect();
                chart
                    .draw_series(LineSeries::new(pts, color.stroke_width(2)))
                    .map_err(draw_err)?
                    .label(format!("{} ({})", r.segment, r.status))
                    .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], color));
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::LowerLeft)
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(draw_err)?;
        }
        Ok(())
    })
}

/// The parts of a segments file the path figure needs (other keys are ignored here; the
/// scenario loader validates the whole file).
#[derive(Deserialize)]
struct SegmentsFile {
    tracks: Vec<TrackEntry>,
    segments: Vec<SegmentEntry>,
}

#[derive(Deserialize)]
struct TrackEntry {
    name: String,
    profile_csv: String,
    lap_length_m: f64,
}

#[derive(Deserialize)]
struct SegmentEntry {
    name: String,
    track: String,
    s_start_m: f64,
}

/// Linear interpolation of (x, y, heading) on a 1-D grid of spacing `step`.
fn at(center: &[(f64, f64, f64)], step: f64, s: f64) -> (f64, f64, f64) {
    let last = center.len().saturating_sub(1);
    let f = (s / step).max(0.0);
    let i = (f.floor() as usize).min(last.saturating_sub(1));
    let w = (f - i as f64).clamp(0.0, 1.0);
    let (a, b) = (center[i], center[(i + 1).min(last)]);
    (
        a.0 + w * (b.0 - a.0),
        a.1 + w * (b.1 - a.1),
        a.2 + w * (b.2 - a.2),
    )
}

/// The equilibrium-guess path of every segment drawn on its whole track (centerline from
/// the track profile's curvature, paper Sec. II), each segment in its own colour.
pub fn plot_paths(scenario: &Path, study: &SegmentsStudy, path: &Path) -> Result<(), StudyError> {
    ensure_font()?;
    let text = std::fs::read_to_string(scenario).map_err(|e| StudyError::File {
        path: scenario.display().to_string(),
        message: e.to_string(),
    })?;
    let file: SegmentsFile = toml::from_str(&text).map_err(|e| StudyError::File {
        path: scenario.display().to_string(),
        message: e.to_string(),
    })?;
    let root_dir = data_root_of(scenario);
    let Some(track) = file.tracks.first() else {
        return Err(StudyError::File {
            path: scenario.display().to_string(),
            message: "no [[tracks]] entry".into(),
        });
    };
    let profile = Profile::load(&root_dir.join(&track.profile_csv), track.lap_length_m)
        .map_err(|e| StudyError::Config(e.into()))?;
    let center = centerline_xy(profile.kappa(), profile.step());
    let lap: Vec<(f64, f64)> = center.iter().map(|&(x, y, _)| (x, y)).collect();

    let mut paths = Vec::new();
    for run in study.runs.iter().filter(|r| r.guess == "equilibrium") {
        let (Some(traj), Some(seg)) = (
            run.trajectory.as_ref(),
            file.segments
                .iter()
                .find(|s| s.name == run.segment && s.track == track.name),
        ) else {
            continue;
        };
        let pts: Vec<(f64, f64)> = traj
            .x
            .iter()
            .enumerate()
            .map(|(k, x)| {
                let (cx, cy, psi) = at(&center, profile.step(), seg.s_start_m + k as f64 * traj.ds);
                let e = x[ix::E];
                (cx - e * psi.sin(), cy + e * psi.cos())
            })
            .collect();
        paths.push((run.segment.clone(), pts));
    }

    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in &lap {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    // Equal aspect: pad the shorter span.
    let span = (x1 - x0).max(y1 - y0).max(1.0) * 1.05;
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    save_png(path, (1100, 1100), |root| {
        root.fill(&WHITE).map_err(draw_err)?;
        let mut chart = ChartBuilder::on(root)
            .caption(
                format!("{}: segment paths (equilibrium guess)", track.name),
                (FONT, 24),
            )
            .margin(16)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(
                (cx - 0.5 * span)..(cx + 0.5 * span),
                (cy - 0.5 * span)..(cy + 0.5 * span),
            )
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc("x [m]")
            .y_desc("y [m]")
            .draw()
            .map_err(draw_err)?;
        chart
            .draw_series(LineSeries::new(
                lap,
                RGBColor(180, 180, 180).stroke_width(8),
            ))
            .map_err(draw_err)?;
        for (i, (name, pts)) in paths.into_iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            let first = pts.first().copied();
            chart
                .draw_series(LineSeries::new(pts, color.stroke_width(3)))
                .map_err(draw_err)?
                .label(name.clone())
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], color));
            if let Some(p) = first {
                chart
                    .draw_series(std::iter::once(Text::new(name, p, (FONT, 16))))
                    .map_err(draw_err)?;
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(draw_err)?;
        Ok(())
    })
}
