//! The latency figure of a replay: latency over the drive (replayed and as recorded,
//! with the budget) above a histogram of the replayed latency.

use std::path::Path;

use planner::plot::Canvas;
use plotters::prelude::*;

use crate::run::RunReport;

/// Why the figure could not be drawn.
#[derive(Debug, thiserror::Error)]
#[error("{path}: figure not written: {what}")]
pub struct PlotError {
    /// The file.
    pub path: String,
    /// What failed.
    pub what: String,
}

/// Draws `report` to a PNG at `path`, atomically ([`planner::plot::save_png`]): the file
/// holds the complete figure or is left as it was.
pub fn plot_latency(report: &RunReport, path: &Path) -> Result<(), PlotError> {
    let err = |what: String| PlotError {
        path: path.display().to_string(),
        what,
    };
    planner::plot::ensure_font().map_err(|e| err(e.to_string()))?;
    planner::plot::save_png(path, (1200, 900), |root| {
        draw(report, root).map_err(planner::plot::PlotError::Draw)
    })
    .map_err(|e| match e {
        planner::plot::PlotError::Write(w) => err(format!("cannot write: {}", w.source)),
        e => err(e.to_string()),
    })
}

fn draw(report: &RunReport, root: &Canvas<'_>) -> Result<(), String> {
    let e = |x: &dyn std::fmt::Display| x.to_string();
    root.fill(&WHITE).map_err(|x| e(&x))?;
    let (top, bottom) = root.split_vertically(480);
    let lat: Vec<f64> = report.per_plan.iter().map(|p| p.latency_ms).collect();
    let rec: Vec<f64> = report
        .per_plan
        .iter()
        .filter_map(|p| p.recorded_ms)
        .collect();
    let y_max = lat
        .iter()
        .chain(&rec)
        .copied()
        .fold(report.budget_ms, f64::max)
        * 1.1;
    let n = lat.len().max(1);
    let l = &report.latency;
    let mut chart = ChartBuilder::on(&top)
        .caption(
            format!(
                "Solve latency over the drive: p50 {:.1} ms, p99 {:.1} ms, max {:.1} ms, {} of {} over {:.0} ms",
                l.p50_ms, l.p99_ms, l.max_ms, report.deadline_misses, report.plans, report.budget_ms
            ),
            ("sans-serif", 20),
        )
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0f64..n as f64, 0f64..y_max)
        .map_err(|x| e(&x))?;
    chart
        .configure_mesh()
        .x_desc("plan")
        .y_desc("latency [ms]")
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(|x| e(&x))?;
    chart
        .draw_series(LineSeries::new(
            lat.iter().enumerate().map(|(i, v)| (i as f64, *v)),
            BLUE.stroke_width(2),
        ))
        .map_err(|x| e(&x))?
        .label("replayed (pinned)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE.stroke_width(2)));
    if !rec.is_empty() {
        chart
            .draw_series(report.per_plan.iter().enumerate().filter_map(|(i, p)| {
                p.recorded_ms
                    .map(|r| Circle::new((i as f64, r), 3, RED.filled()))
            }))
            .map_err(|x| e(&x))?
            .label("as recorded")
            .legend(|(x, y)| Circle::new((x + 10, y), 3, RED.filled()));
    }
    chart
        .draw_series(LineSeries::new(
            [(0.0, report.budget_ms), (n as f64, report.budget_ms)],
            BLACK.stroke_width(1),
        ))
        .map_err(|x| e(&x))?
        .label("budget")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(|x| e(&x))?;

    // Histogram: 40 bins from 0 to the largest latency.
    let hi = lat.iter().copied().fold(0.0, f64::max).max(1e-3) * 1.05;
    let bins = 40usize;
    let w = hi / bins as f64;
    let mut counts = vec![0u32; bins];
    for v in &lat {
        let b = ((v / w) as usize).min(bins - 1);
        counts[b] += 1;
    }
    let c_max = counts.iter().copied().max().unwrap_or(1).max(1);
    let mut hist = ChartBuilder::on(&bottom)
        .caption(
            format!(
                "Histogram of replayed latency (jitter: max - p50 {:.1} ms, std dev {:.1} ms)",
                l.jitter_ms, l.stdev_ms
            ),
            ("sans-serif", 20),
        )
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0f64..hi, 0u32..c_max + 1)
        .map_err(|x| e(&x))?;
    hist.configure_mesh()
        .x_desc("latency [ms]")
        .y_desc("plans")
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(|x| e(&x))?;
    hist.draw_series(counts.iter().enumerate().map(|(i, c)| {
        let x0 = i as f64 * w;
        Rectangle::new([(x0, 0), (x0 + w, *c)], BLUE.mix(0.6).filled())
    }))
    .map_err(|x| e(&x))?;
    Ok(())
}
