//! PNG figures of the studies: accuracy vs solve time of the integrators (paper Fig. 4a)
//! and the node-wise stiffness ratio with the state contributions (paper Fig. 3).

use std::path::Path;

use plotters::prelude::*;

use super::integrators::IntegratorStudy;
use super::stiffness::StiffnessStudy;
use crate::model::{NX, STATE_NAMES};
use crate::plot::{draw_err, ensure_font, save_png, PlotError, FONT};

/// Size of both figures \[px\].
pub const STUDY_FIGURE_SIZE: (u32, u32) = (1200, 800);

/// Log-axis range covering `v` (positive finite values) with a margin of a factor 2 below
/// and `up` above.
fn log_range(v: impl Iterator<Item = f64>, up: f64) -> std::ops::Range<f64> {
    let (lo, hi) = v
        .filter(|x| x.is_finite() && *x > 0.0)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
    if lo.is_finite() && hi.is_finite() {
        lo / 2.0..hi * up
    } else {
        0.1..10.0
    }
}

/// Fig. 4a: max NRMSE [%] (log) against the median solve time \[ms\] (log), one point per
/// integrator: filled blue = A-stable, filled orange = not A-stable, red cross = the solve
/// did not succeed (label carries the status). The ground truth (NRMSE 0 by definition)
/// and points without a positive NRMSE are left out and named in the caption.
pub fn plot_integrator_study(study: &IntegratorStudy, path: &Path) -> Result<(), PlotError> {
    ensure_font()?;
    let pts: Vec<_> = study
        .runs
        .iter()
        .filter(|r| r.integrator.name() != study.reference)
        .collect();
    let shown: Vec<_> = pts
        .iter()
        .filter(|r| r.max_nrmse_pct.is_finite() && r.max_nrmse_pct > 0.0 && r.median_ms > 0.0)
        .collect();
    let left_out: Vec<&str> = pts
        .iter()
        .filter(|r| !(r.max_nrmse_pct.is_finite() && r.max_nrmse_pct > 0.0 && r.median_ms > 0.0))
        .map(|r| r.integrator.name())
        .collect();
    // Room on the right for the labels.
    let xr = log_range(shown.iter().map(|r| r.median_ms), 6.0);
    let yr = log_range(shown.iter().map(|r| r.max_nrmse_pct), 2.0);
    save_png(path, STUDY_FIGURE_SIZE, |root| {
        root.fill(&WHITE).map_err(draw_err)?;
        let mut caption = format!(
            "{}: accuracy vs solve time (median of {}), NRMSE vs {}",
            study.scenario, study.repeat, study.reference
        );
        if !left_out.is_empty() {
            caption.push_str(&format!("; not shown: {}", left_out.join(", ")));
        }
        let mut chart = ChartBuilder::on(root)
            .caption(caption, (FONT, 22))
            .margin(20)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d(xr.log_scale(), yr.log_scale())
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc("median solve time [ms]")
            .y_desc("max NRMSE over controls [%]")
            .label_style((FONT, 16))
            .draw()
            .map_err(draw_err)?;
        let blue = RGBColor(31, 119, 180);
        let orange = RGBColor(255, 127, 14);
        for r in shown {
            let p = (r.median_ms, r.max_nrmse_pct);
            let label = if r.success {
                r.integrator.name().to_string()
            } else {
                format!("{} ({})", r.integrator.name(), r.status)
            };
            let text = Text::new(label, (10, -18), (FONT, 16));
            if r.success {
                let c = if r.a_stable { blue } else { orange };
                chart
                    .draw_series([EmptyElement::at(p) + Circle::new((0, 0), 7, c.filled()) + text])
                    .map_err(draw_err)?;
            } else {
                chart
                    .draw_series([EmptyElement::at(p)
                        + Cross::new((0, 0), 8, RED.stroke_width(3))
                        + text])
                    .map_err(draw_err)?;
            }
        }
        root.draw(&Text::new(
            "blue: A-stable, orange: not A-stable, red cross: solve failed (status in the label)",
            (110, 70),
            (FONT, 16),
        ))
        .map_err(draw_err)?;
        Ok(())
    })
}

/// Fig. 3: the stiffness ratio of eq. (7) against s (log), with the classical threshold
/// 1e3, above the participation of each state in the fastest mode (states that never
/// reach 5 % are omitted).
pub fn plot_stiffness(study: &StiffnessStudy, title: &str, path: &Path) -> Result<(), PlotError> {
    ensure_font()?;
    save_png(path, STUDY_FIGURE_SIZE, |root| {
        root.fill(&WHITE).map_err(draw_err)?;
        let (top, bottom) = root.split_vertically(STUDY_FIGURE_SIZE.1 / 2);
        let s_max = study.nodes.last().map_or(1.0, |n| n.s.max(1.0));
        let ratios: Vec<(f64, f64)> = study
            .nodes
            .iter()
            .filter_map(|n| n.ratio.map(|r| (n.s, r)))
            .collect();
        let yr = log_range(ratios.iter().map(|p| p.1).chain([1e3]), 2.0);
        let mut chart = ChartBuilder::on(&top)
            .caption(title, (FONT, 22))
            .margin(15)
            .x_label_area_size(35)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..s_max, yr.log_scale())
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .y_desc("stiffness ratio (eq. 7)")
            .label_style((FONT, 15))
            .draw()
            .map_err(draw_err)?;
        chart
            .draw_series(LineSeries::new(
                ratios.clone(),
                RGBColor(31, 119, 180).stroke_width(2),
            ))
            .map_err(draw_err)?
            .label("SR")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], RGBColor(31, 119, 180)));
        chart
            .draw_series(
                ratios
                    .iter()
                    .map(|&p| Circle::new(p, 2, RGBColor(31, 119, 180).filled())),
            )
            .map_err(draw_err)?;
        chart
            .draw_series(LineSeries::new(
                [(0.0, 1e3), (s_max, 1e3)],
                RED.stroke_width(1),
            ))
            .map_err(draw_err)?
            .label("stiff threshold 1e3")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], RED));
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font((FONT, 15))
            .draw()
            .map_err(draw_err)?;

        let mut chart = ChartBuilder::on(&bottom)
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..s_max, 0.0..1.05)
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc("s [m]")
            .y_desc("participation in fastest mode")
            .label_style((FONT, 15))
            .draw()
            .map_err(draw_err)?;
        for i in 0..NX {
            let pts: Vec<(f64, f64)> = study
                .nodes
                .iter()
                .filter(|n| n.ratio.is_some())
                .map(|n| (n.s, n.participation[i]))
                .collect();
            if pts.iter().all(|p| p.1 < 0.05) {
                continue;
            }
            let c = Palette99::pick(i).to_rgba();
            chart
                .draw_series(LineSeries::new(pts, c.stroke_width(2)))
                .map_err(draw_err)?
                .label(STATE_NAMES[i])
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font((FONT, 15))
            .draw()
            .map_err(draw_err)?;
        Ok(())
    })
}
