//! The track figure: the map of a closed track (centerline and edges rebuilt from its
//! profile, s marks every [`S_MARK_M`], corners numbered at their peak) next to curvature
//! and widths against s; with a planned [`Trajectory`], its path is drawn on the map.

use std::path::Path;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::plot::{draw_err, ensure_font, save_png, Canvas, PlotError, FONT};
use crate::track::map::{Corner, TrackMap};
use crate::track::Profile;
use crate::trajectory::Trajectory;

/// Size of the track figure \[px\].
pub const TRACK_FIGURE_SIZE: (u32, u32) = (1600, 1000);

/// Spacing of the s marks on the map \[m\].
pub const S_MARK_M: f64 = 250.0;

/// Width of the map (left) part of the figure \[px\].
const MAP_WIDTH: u32 = 950;

/// What the track figure shows.
pub struct TrackFigure<'a> {
    /// Track name (the title).
    pub name: &'a str,
    /// The profile (curvature and widths against s).
    pub profile: &'a Profile,
    /// The centerline in the plane.
    pub map: &'a TrackMap,
    /// The corners to number.
    pub corners: &'a [Corner],
    /// A plan placed on this track, drawn on the map and marked in the panels.
    pub plan: Option<&'a Trajectory>,
}

/// Points of the map at lateral offset `e(i)` from the centerline poses.
fn offset(map: &TrackMap, e: impl Fn(usize) -> f64) -> Vec<(f64, f64)> {
    let n = map.poses.len() - 1;
    (0..=n)
        .map(|i| {
            let [x, y, h] = map.poses[i];
            let e = e(i % n);
            (x - e * h.sin(), y + e * h.cos())
        })
        .collect()
}

/// Axis ranges holding `points` with a margin, stretched so one metre spans as many pixels
/// on both axes of a `w` x `h` area.
fn square_ranges(
    points: &[(f64, f64)],
    w: u32,
    h: u32,
) -> (std::ops::Range<f64>, std::ops::Range<f64>) {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in points.iter().filter(|p| p.0.is_finite() && p.1.is_finite()) {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    if x0 > x1 {
        return (-1.0..1.0, -1.0..1.0);
    }
    let pad = 0.04 * (x1 - x0).max(y1 - y0).max(1.0);
    let (dx, dy) = (x1 - x0 + 2.0 * pad, y1 - y0 + 2.0 * pad);
    let scale = (dx / f64::from(w.max(1))).max(dy / f64::from(h.max(1)));
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let (hx, hy) = (0.5 * scale * f64::from(w), 0.5 * scale * f64::from(h));
    ((cx - hx)..(cx + hx), (cy - hy)..(cy + hy))
}

/// Writes the track figure to `path` (PNG, written atomically).
pub fn plot_track(fig: &TrackFigure<'_>, path: &Path) -> Result<(), PlotError> {
    if fig.profile.n_rows() < 2 || fig.map.poses.len() != fig.profile.n_rows() + 1 {
        return Err(PlotError::Inconsistent(
            "the map does not match the profile".into(),
        ));
    }
    ensure_font()?;
    save_png(path, TRACK_FIGURE_SIZE, |root| draw(root, fig))
}

/// Draws the whole figure on `root`.
fn draw(root: &Canvas<'_>, fig: &TrackFigure<'_>) -> Result<(), PlotError> {
    root.fill(&WHITE).map_err(draw_err)?;
    let title = match fig.plan {
        Some(t) => format!(
            "{}: {:.1} m lap, {} corners; plan {} (t_N = {:.3} s)",
            fig.name,
            fig.profile.lap_length(),
            fig.corners.len(),
            t.name,
            t.t_final()
        ),
        None => format!(
            "{}: {:.1} m lap, {} corners",
            fig.name,
            fig.profile.lap_length(),
            fig.corners.len()
        ),
    };
    let body = root.titled(&title, (FONT, 26)).map_err(draw_err)?;
    let (left, right) = body.split_horizontally(MAP_WIDTH);
    draw_map(&left, fig)?;
    let (top, bottom) = right.split_vertically(right.dim_in_pixel().1 / 2);
    draw_profile_panels(&top, &bottom, fig)
}

/// The map: edges, dashed centerline, s marks, corner numbers and the plan's path.
fn draw_map(area: &Canvas<'_>, fig: &TrackFigure<'_>) -> Result<(), PlotError> {
    let map = fig.map;
    let p = fig.profile;
    let left = offset(map, |i| p.w_left()[i]);
    let right = offset(map, |i| -p.w_right()[i]);
    let center = offset(map, |_| 0.0);
    let all: Vec<(f64, f64)> = left.iter().chain(&right).copied().collect();
    let (w, h) = area.dim_in_pixel();
    let (xr, yr) = square_ranges(&all, w.saturating_sub(100), h.saturating_sub(70));
    let mut chart = ChartBuilder::on(area)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(64)
        .build_cartesian_2d(xr, yr)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc("x [m]")
        .y_desc("y [m]")
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.06))
        .draw()
        .map_err(draw_err)?;
    let grey = RGBColor(110, 110, 110);
    for edge in [left, right] {
        chart
            .draw_series(LineSeries::new(edge, grey.stroke_width(2)))
            .map_err(draw_err)?;
    }
    chart
        .draw_series(DashedLineSeries::new(
            center,
            4,
            4,
            RGBColor(170, 170, 170).stroke_width(1),
        ))
        .map_err(draw_err)?;
    if let Some(t) = fig.plan {
        let path: Vec<(f64, f64)> = t.car_poses().iter().map(|q| (q[0], q[1])).collect();
        chart
            .draw_series(LineSeries::new(path, RGBColor(214, 39, 40).stroke_width(4)))
            .map_err(draw_err)?;
    }
    // s marks: a dot on the centerline and the value beside it, outward to the right.
    let label = |h: HPos| TextStyle::from((FONT, 13).into_font()).pos(Pos::new(h, VPos::Center));
    let blue = RGBColor(31, 119, 180);
    let n_marks = (p.lap_length() / S_MARK_M).ceil() as usize;
    for j in 0..n_marks {
        let s = j as f64 * S_MARK_M;
        let [x, y, hd] = map.pose_at(s);
        let (_, wr, _) = p.sample(s);
        let e = -(wr + 12.0);
        let at = (x - e * hd.sin(), y + e * hd.cos());
        chart
            .draw_series(std::iter::once(Circle::new((x, y), 3, blue.filled())))
            .map_err(draw_err)?;
        chart
            .draw_series(std::iter::once(Text::new(
                format!("{s:.0}"),
                at,
                label(HPos::Center).color(&blue),
            )))
            .map_err(draw_err)?;
    }
    // Corners: the number outside the turn (right of a left turn, left of a right turn).
    let red = RGBColor(180, 30, 30);
    for c in fig.corners {
        let [x, y, hd] = map.pose_at(c.s_peak);
        let (_, wr, wl) = p.sample(c.s_peak);
        let e = if c.kappa_peak > 0.0 {
            -(wr + 28.0)
        } else {
            wl + 28.0
        };
        chart
            .draw_series(std::iter::once(Text::new(
                format!("{}", c.number),
                (x - e * hd.sin(), y + e * hd.cos()),
                TextStyle::from((FONT, 17).into_font())
                    .pos(Pos::new(HPos::Center, VPos::Center))
                    .color(&red),
            )))
            .map_err(draw_err)?;
    }
    Ok(())
}

/// Curvature (top) and widths (bottom) against s, with the corners' peaks and the plan's
/// stretch marked.
fn draw_profile_panels(
    top: &Canvas<'_>,
    bottom: &Canvas<'_>,
    fig: &TrackFigure<'_>,
) -> Result<(), PlotError> {
    let p = fig.profile;
    let s_of = |i: usize| i as f64 * p.step();
    let lap = p.lap_length();
    let kappa: Vec<(f64, f64)> = (0..p.n_rows()).map(|i| (s_of(i), p.kappa()[i])).collect();
    let k_max = p.kappa().iter().fold(0.01_f64, |a, k| a.max(k.abs())) * 1.1;
    let mut chart = ChartBuilder::on(top)
        .margin(12)
        .x_label_area_size(30)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..lap, -k_max..k_max)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .y_desc("curvature κ [1/m] (+ left)")
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(draw_err)?;
    shade_plan(&mut chart, fig, -k_max..k_max)?;
    chart
        .draw_series(LineSeries::new(
            kappa,
            RGBColor(31, 119, 180).stroke_width(2),
        ))
        .map_err(draw_err)?;
    let red = RGBColor(180, 30, 30);
    for c in fig.corners {
        let y = c.kappa_peak + 0.08 * k_max * c.kappa_peak.signum();
        chart
            .draw_series(std::iter::once(Text::new(
                format!("{}", c.number),
                (c.s_peak, y),
                TextStyle::from((FONT, 14).into_font())
                    .pos(Pos::new(HPos::Center, VPos::Center))
                    .color(&red),
            )))
            .map_err(draw_err)?;
    }

    let w_hi = p
        .w_left()
        .iter()
        .chain(p.w_right())
        .fold(1.0_f64, |a, w| a.max(*w))
        * 1.1;
    let mut chart = ChartBuilder::on(bottom)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..lap, 0.0..w_hi)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc("s [m]")
        .y_desc("width [m]")
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(draw_err)?;
    shade_plan(&mut chart, fig, 0.0..w_hi)?;
    let blue = RGBColor(31, 119, 180);
    let orange = RGBColor(255, 127, 14);
    for (label, color, w) in [
        ("w_left", blue, p.w_left()),
        ("w_right", orange, p.w_right()),
    ] {
        let pts: Vec<(f64, f64)> = (0..p.n_rows()).map(|i| (s_of(i), w[i])).collect();
        chart
            .draw_series(LineSeries::new(pts, color.stroke_width(2)))
            .map_err(draw_err)?
            .label(label)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .label_font((FONT, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .draw()
        .map_err(draw_err)?;
    Ok(())
}

/// Shades the plan's stretch of track s (split at the lap end) over the y range `y`.
fn shade_plan<DB: DrawingBackend>(
    chart: &mut ChartContext<
        '_,
        DB,
        Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
    >,
    fig: &TrackFigure<'_>,
    y: std::ops::Range<f64>,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let Some(t) = fig.plan else { return Ok(()) };
    let lap = fig.profile.lap_length();
    let s0 = t.s_track(0);
    let len = t.ds * t.n_intervals() as f64;
    let mut pieces = vec![(s0, (s0 + len).min(lap))];
    if s0 + len > lap {
        pieces.push((0.0, s0 + len - lap));
    }
    for (a, b) in pieces {
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(a, y.start), (b, y.end)],
                RGBColor(214, 39, 40).mix(0.15).filled(),
            )))
            .map_err(draw_err)?;
    }
    Ok(())
}
