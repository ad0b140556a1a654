//! Figures of the reproduction report that no other study draws: Fig. 4b (the oval's
//! iterates overlaid, light yellow to dark blue as in the paper) and Fig. 5 (||Z - Z*||_2
//! of every segment's iterates, log scale).

use std::path::Path;

use plotters::prelude::*;

use crate::model::{iu, ix, NU, NX};
use crate::ocp::OcpSpec;
use crate::plot::{centerline_xy, draw_err, ensure_font, save_png, PlotError, FONT};

/// Physical (states at the N + 1 nodes, controls on the N intervals) of one iterate.
pub type PhysTrajectory = (Vec<[f64; NX]>, Vec<[f64; NU]>);

/// One value per node of an iterate: (states, controls, node) -> value.
type NodeValue = dyn Fn(&[[f64; NX]], &[[f64; NU]], usize) -> f64;

/// Colour of iterate `i` of `n`: light yellow (first) to dark blue (last).
fn ramp(i: usize, n: usize) -> RGBColor {
    let t = if n > 1 {
        i as f64 / (n - 1) as f64
    } else {
        1.0
    };
    let mix = |a: u8, b: u8| (f64::from(a) + t * (f64::from(b) - f64::from(a))).round() as u8;
    RGBColor(mix(255, 8), mix(237, 29), mix(160, 88))
}

/// One panel: `value(states, controls, k)` against s for every iterate.
fn panel(
    area: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    title: &str,
    s: &[f64],
    series: &[Vec<f64>],
) -> Result<(), PlotError> {
    let finite = series.iter().flatten().copied().filter(|v| v.is_finite());
    let (lo, hi) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    let (lo, hi) = if lo < hi {
        (lo, hi)
    } else {
        (lo - 1.0, lo + 1.0)
    };
    let pad = 0.05 * (hi - lo);
    let s_max = s.last().copied().unwrap_or(1.0).max(1e-9);
    let mut chart = ChartBuilder::on(area)
        .caption(title, (FONT, 20))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(60)
        .build_cartesian_2d(0f64..s_max, (lo - pad)..(hi + pad))
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc("s [m]")
        .draw()
        .map_err(draw_err)?;
    for (i, v) in series.iter().enumerate() {
        let pts = s
            .iter()
            .zip(v)
            .map(|(&a, &b)| (a, b))
            .filter(|p| p.1.is_finite());
        chart
            .draw_series(LineSeries::new(
                pts,
                ramp(i, series.len()).stroke_width(if i + 1 == series.len() { 3 } else { 1 }),
            ))
            .map_err(draw_err)?;
    }
    Ok(())
}

/// Fig. 4b: the path in the plane with the road edges, and V, beta and delta against s,
/// one curve per iterate.
pub fn plot_iterates(
    spec: &OcpSpec,
    iterates: &[PhysTrajectory],
    path: &Path,
) -> Result<(), PlotError> {
    ensure_font()?;
    let ds = spec.ds();
    let center = centerline_xy(&spec.kappa, ds);
    let offset = |e: &mut dyn Iterator<Item = f64>| -> Vec<(f64, f64)> {
        center
            .iter()
            .zip(e)
            .map(|(&(x, y, psi), e)| (x - e * psi.sin(), y + e * psi.cos()))
            .collect()
    };
    let s: Vec<f64> = (0..=spec.n_intervals).map(|k| k as f64 * ds).collect();
    let edges = [
        offset(&mut spec.e_min.iter().copied()),
        offset(&mut spec.e_max.iter().copied()),
    ];
    let paths: Vec<Vec<(f64, f64)>> = iterates
        .iter()
        .map(|(x, _)| offset(&mut x.iter().map(|x| x[ix::E])))
        .collect();
    let of = |f: &NodeValue| -> Vec<Vec<f64>> {
        iterates
            .iter()
            .map(|(x, u)| (0..x.len()).map(|k| f(x, u, k)).collect())
            .collect()
    };
    let speed = of(&|x, _, k| x[k][ix::V]);
    let beta = of(&|x, _, k| x[k][ix::BETA]);
    let delta = of(&|_, u, k| {
        u.get(k.min(u.len().saturating_sub(1)))
            .map_or(f64::NAN, |u| u[iu::DELTA])
    });
    save_png(path, (1400, 1000), |root| {
        root.fill(&WHITE).map_err(draw_err)?;
        let areas = root.split_evenly((2, 2));
        let all = edges.iter().chain(&paths).flatten();
        let (mut x0, mut x1, mut y0, mut y1) = (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        );
        for &(x, y) in all.filter(|p| p.0.is_finite() && p.1.is_finite()) {
            (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
        }
        let half = 0.55 * (x1 - x0).max(y1 - y0).max(1.0);
        let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
        let mut chart = ChartBuilder::on(&areas[0])
            .caption("path (iterates light to dark)", (FONT, 20))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d((cx - half)..(cx + half), (cy - half)..(cy + half))
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc("x [m]")
            .y_desc("y [m]")
            .draw()
            .map_err(draw_err)?;
        for e in &edges {
            chart
                .draw_series(LineSeries::new(e.iter().copied(), BLACK.stroke_width(2)))
                .map_err(draw_err)?;
        }
        for (i, p) in paths.iter().enumerate() {
            let pts = p
                .iter()
                .copied()
                .filter(|p| p.0.is_finite() && p.1.is_finite());
            chart
                .draw_series(LineSeries::new(
                    pts,
                    ramp(i, paths.len()).stroke_width(if i + 1 == paths.len() { 3 } else { 1 }),
                ))
                .map_err(draw_err)?;
        }
        panel(&areas[1], "V [m/s]", &s, &speed)?;
        panel(&areas[2], "beta [rad]", &s, &beta)?;
        panel(&areas[3], "delta [rad]", &s, &delta)?;
        Ok(())
    })
}

/// Fig. 5: ||Z - Z*||_2 against the iteration, one curve per (label, distances).
pub fn plot_distances(curves: &[(String, Vec<f64>)], path: &Path) -> Result<(), PlotError> {
    ensure_font()?;
    let max_it = curves.iter().map(|c| c.1.len()).max().unwrap_or(2).max(2);
    save_png(path, (1000, 650), |root| {
        root.fill(&WHITE).map_err(draw_err)?;
        let mut chart = ChartBuilder::on(root)
            .caption(
                "||Z - Z*||_2 (scaled variables), equilibrium guess",
                (FONT, 22),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(0f64..max_it as f64, (1e-10f64..1e3f64).log_scale())
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc("iteration")
            .y_desc("||Z - Z*||_2")
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()
            .map_err(draw_err)?;
        for (i, (label, d)) in curves.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            let pts: Vec<(f64, f64)> = d
                .iter()
                .enumerate()
                .map(|(k, &e)| (k as f64, e.clamp(1e-10, 1e3)))
                .collect();
            chart
                .draw_series(LineSeries::new(pts, color.stroke_width(2)))
                .map_err(draw_err)?
                .label(label.as_str())
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], color));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(draw_err)?;
        Ok(())
    })
}
