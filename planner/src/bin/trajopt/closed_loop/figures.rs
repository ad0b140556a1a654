//! The closed loop's figures: `<road>_lap.png`, the road's edges in the plane (the
//! centerline integrated from the curvature) with the driven path coloured by speed and
//! markers where a plan did not converge (red) or came after its period (orange); and
//! `<road>_speed.png`, the driven speed and every plan's node speeds against the distance
//! from the start.

use std::path::Path;

use planner::plot::{centerline_xy, ensure_font, save_png, PlotError};
use plotters::prelude::*;

use super::road::RoadMap;
use super::trace::{Driven, PlanLine};

const FONT: &str = "sans-serif";

fn draw_err<E: std::fmt::Display>(e: E) -> PlotError {
    PlotError::Draw(e.to_string())
}

/// Blue (slow) to red (fast) at t in [0, 1].
fn speed_colour(t: f64) -> RGBColor {
    let t = t.clamp(0.0, 1.0);
    RGBColor(
        (255.0 * t) as u8,
        (80.0 * (1.0 - (2.0 * t - 1.0).abs())) as u8,
        (255.0 * (1.0 - t)) as u8,
    )
}

/// Maps road (s, e) to the plane through the centerline of `map`.
struct Plane {
    center: Vec<(f64, f64, f64)>,
    step: f64,
    length: f64,
    closed: bool,
}

impl Plane {
    fn new(map: &RoadMap) -> Self {
        Self {
            center: centerline_xy(&map.kappa, map.step),
            step: map.step,
            length: map.length,
            closed: map.closed,
        }
    }

    fn xy(&self, s: f64, e: f64) -> (f64, f64) {
        let n = self.center.len();
        let u = if self.closed {
            s.rem_euclid(self.length)
        } else {
            s
        };
        let q = u / self.step;
        let k = (q.floor().max(0.0) as usize).min(n - 1);
        let (x, y, psi) = self.center[k];
        // Past the last node: straight on along its heading.
        let d = u - k as f64 * self.step;
        let (x, y) = (x + d * psi.cos(), y + d * psi.sin());
        (x - e * psi.sin(), y + e * psi.cos())
    }
}

/// Writes both figures into `dir` as `<name>_lap.png` and `<name>_speed.png`.
pub fn draw(
    dir: &Path,
    name: &str,
    map: &RoadMap,
    driven: &Driven,
    plans: &[PlanLine],
    period_s: f64,
    start_s: f64,
) -> Result<Vec<String>, PlotError> {
    ensure_font()?;
    let _ = std::fs::create_dir_all(dir);
    let lap = dir.join(format!("{name}_lap.png"));
    let speed = dir.join(format!("{name}_speed.png"));
    save_png(&lap, (1000, 1000), |root| {
        draw_lap(root, name, map, driven, plans, period_s)
    })?;
    save_png(&speed, (1400, 600), |root| {
        draw_speed(root, name, driven, plans, start_s)
    })?;
    Ok(vec![lap.display().to_string(), speed.display().to_string()])
}

fn draw_lap(
    root: &planner::plot::Canvas<'_>,
    name: &str,
    map: &RoadMap,
    driven: &Driven,
    plans: &[PlanLine],
    period_s: f64,
) -> Result<(), PlotError> {
    root.fill(&WHITE).map_err(draw_err)?;
    let plane = Plane::new(map);
    let s_of = |k: usize| k as f64 * map.step;
    let edge = |e: &[f64]| -> Vec<(f64, f64)> {
        e.iter()
            .enumerate()
            .map(|(k, &e)| plane.xy(s_of(k), e))
            .collect()
    };
    let (right, left) = (edge(&map.e_min), edge(&map.e_max));
    let path: Vec<(f64, f64, f64)> = driven
        .rows
        .iter()
        .map(|r| {
            let (x, y) = plane.xy(r[1], r[2]);
            (x, y, r[3])
        })
        .collect();
    let all = right
        .iter()
        .chain(&left)
        .copied()
        .chain(path.iter().map(|p| (p.0, p.1)));
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (x, y) in all {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    // Equal scales: a square box around the centre.
    let half = 0.5 * (x1 - x0).max(y1 - y0).max(1.0) * 1.05;
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let (v_lo, v_hi) = path
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.2), b.max(p.2)));
    let title = format!("{name}: driven path, speed {v_lo:.0} (blue) to {v_hi:.0} m/s (red)");
    let mut chart = ChartBuilder::on(root)
        .caption(title, (FONT, 22))
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(50)
        .build_cartesian_2d(cx - half..cx + half, cy - half..cy + half)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc("x [m]")
        .y_desc("y [m]")
        .label_style((FONT, 14))
        .draw()
        .map_err(draw_err)?;
    for e in [right, left] {
        chart
            .draw_series(LineSeries::new(e, BLACK.stroke_width(1)))
            .map_err(draw_err)?;
    }
    let span = (v_hi - v_lo).max(1e-9);
    chart
        .draw_series(path.windows(2).map(|w| {
            let c = speed_colour((w[0].2 - v_lo) / span);
            PathElement::new(vec![(w[0].0, w[0].1), (w[1].0, w[1].1)], c.stroke_width(2))
        }))
        .map_err(draw_err)?;
    let e_at = |s: f64| {
        driven
            .rows
            .iter()
            .min_by(|a, b| (a[1] - s).abs().total_cmp(&(b[1] - s).abs()))
            .map_or(0.0, |r| r[2])
    };
    for p in plans {
        let colour = if p.status > 1 || notice(p) {
            RED
        } else if p.solve_time_s > period_s {
            RGBColor(255, 140, 0)
        } else {
            continue;
        };
        let at = plane.xy(p.s_car, e_at(p.s_car));
        chart
            .draw_series(std::iter::once(Cross::new(at, 6, colour.stroke_width(2))))
            .map_err(draw_err)?;
    }
    Ok(())
}

/// A notice that its cycle had no drivable plan: its nodes hold the measured state.
fn notice(p: &PlanLine) -> bool {
    p.kind == planner::plan::choice::NO_PLAN_CODE
}

fn draw_speed(
    root: &planner::plot::Canvas<'_>,
    name: &str,
    driven: &Driven,
    plans: &[PlanLine],
    start_s: f64,
) -> Result<(), PlotError> {
    root.fill(&WHITE).map_err(draw_err)?;
    let d_end = driven.rows.last().map_or(1.0, |r| r[1] - start_s).max(1.0);
    let v_max = driven
        .rows
        .iter()
        .map(|r| r[3])
        .chain(
            plans
                .iter()
                .filter(|p| !notice(p))
                .flat_map(|p| p.v.iter().copied()),
        )
        .fold(1.0, f64::max);
    let mut chart = ChartBuilder::on(root)
        .caption(
            format!("{name}: driven speed (black) and the plans' node speeds (colour)"),
            (FONT, 22),
        )
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..d_end, 0.0..v_max * 1.05)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc("distance from the start [m]")
        .y_desc("V [m/s]")
        .label_style((FONT, 14))
        .draw()
        .map_err(draw_err)?;
    let n = plans.len().max(1) as f64;
    for (i, p) in plans.iter().enumerate().filter(|(_, p)| !notice(p)) {
        let c = speed_colour(i as f64 / n).mix(0.35);
        let pts: Vec<(f64, f64)> =
            p.v.iter()
                .enumerate()
                .map(|(k, &v)| (p.s_origin + k as f64 * p.ds - start_s, v))
                .filter(|(d, _)| *d <= d_end)
                .collect();
        chart
            .draw_series(LineSeries::new(pts, c.stroke_width(1)))
            .map_err(draw_err)?;
    }
    chart
        .draw_series(LineSeries::new(
            driven.rows.iter().map(|r| (r[1] - start_s, r[3])),
            BLACK.stroke_width(2),
        ))
        .map_err(draw_err)?;
    Ok(())
}
