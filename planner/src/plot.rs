//! Figures of a planned [`Trajectory`]: the top view of the car's path on the road
//! (coloured by speed) next to speed, sideslip, steering and torque against arc length,
//! rendered to PNG with the pure-Rust `plotters` backend and a bundled font.

use std::ops::Range;
use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{register_font, FontStyle};

use crate::io::{write_atomic, WriteError};
use crate::model::{iu, ix};
use crate::trajectory::Trajectory;

/// Size of the PNG written by [`plot_trajectory`] \[px\].
pub const FIGURE_SIZE: (u32, u32) = (1400, 1000);

/// Width of the left (top view) half of the figure \[px\].
const LEFT_WIDTH: u32 = 700;

/// Font family every text of the figure uses (registered from the bundled DejaVu Sans).
pub(crate) const FONT: &str = "sans-serif";

/// A polyline in the plane, (x, y) \[m\] per node.
pub type Polyline = Vec<(f64, f64)>;

/// Why a figure could not be drawn.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The trajectory has no nodes.
    #[error("trajectory has no nodes")]
    Empty,
    /// The per-node arrays of the trajectory disagree in length.
    #[error("inconsistent trajectory: {0}")]
    Inconsistent(String),
    /// The bundled font could not be registered.
    #[error("cannot register the plot font")]
    Font,
    /// Drawing the image failed (the plotters error, as text).
    #[error("plotters: {0}")]
    Draw(String),
    /// The PNG file could not be written (nothing is left under its name).
    #[error(transparent)]
    Write(#[from] WriteError),
}

/// Converts any plotters (or backend) error into [`PlotError::Draw`].
pub(crate) fn draw_err<E: std::fmt::Display>(e: E) -> PlotError {
    PlotError::Draw(e.to_string())
}

/// The drawing area of a figure rendered in memory (RGB, 8 bits per channel).
pub type Canvas<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// Renders a `size` figure in memory with `draw` and writes it to `path` as a PNG,
/// atomically ([`write_atomic`]): `path` holds the complete image or is left as it was,
/// and a failed write is an error naming `path` and the operating system's reason.
pub fn save_png<E: From<PlotError>>(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&Canvas<'_>) -> Result<(), E>,
) -> Result<(), E> {
    let (w, h) = size;
    let mut rgb = vec![0u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        draw(&root)?;
        root.present().map_err(draw_err)?;
    }
    write_atomic(path, |file| {
        let mut encoder = png::Encoder::new(file, w, h);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_compression(png::Compression::Default);
        encoder.set_filter(png::FilterType::Sub);
        encoder.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
        let mut writer = encoder.write_header()?;
        writer.write_image_data(&rgb)?;
        writer.finish()?;
        Ok(())
    })
    .map_err(|e| E::from(PlotError::Write(e)))
}

/// Registers the bundled font once per process; later calls return the first outcome.
pub fn ensure_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        register_font(
            FONT,
            FontStyle::Normal,
            include_bytes!("../assets/DejaVuSans.ttf"),
        )
        .is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(PlotError::Font)
    }
}

/// (x, y, heading) of the reference path at the nodes s_k = k ds, from (0, 0, 0), with
/// heading' = kappa integrated by the trapezoid rule and each step an exact circular arc.
pub fn centerline_xy(kappa: &[f64], ds: f64) -> Vec<(f64, f64, f64)> {
    let mut out = Vec::with_capacity(kappa.len());
    let (mut x, mut y, mut psi) = (0.0_f64, 0.0_f64, 0.0_f64);
    if !kappa.is_empty() {
        out.push((x, y, psi));
    }
    for w in kappa.windows(2) {
        // Constant curvature on the step: the chord has length ds sin(a)/a, a = dpsi/2,
        // and points along the mean heading psi + a.
        let dpsi = 0.5 * (w[0] + w[1]) * ds;
        let a = 0.5 * dpsi;
        let chord = if a.abs() < 1e-6 {
            ds * (1.0 - a * a / 6.0)
        } else {
            ds * a.sin() / a
        };
        x += chord * (psi + a).cos();
        y += chord * (psi + a).sin();
        psi += dpsi;
        out.push((x, y, psi));
    }
    out
}

/// Poses of the reference path at the nodes as (x, y, heading): in the track's frame for a
/// horizon placed on a track ([`Trajectory::reference_poses`]), else from (0, 0, 0).
fn frame(traj: &Trajectory) -> Vec<(f64, f64, f64)> {
    traj.reference_poses()
        .into_iter()
        .map(|[x, y, h]| (x, y, h))
        .collect()
}

/// Points at lateral offsets `e` (positive to the left) from the centerline nodes.
fn offset_xy(center: &[(f64, f64, f64)], e: impl IntoIterator<Item = f64>) -> Polyline {
    center
        .iter()
        .zip(e)
        .map(|(&(x, y, psi), e)| (x - e * psi.sin(), y + e * psi.cos()))
        .collect()
}

/// The car's CG position at the nodes: centerline + e * left normal.
pub fn path_xy(traj: &Trajectory) -> Polyline {
    let center = frame(traj);
    offset_xy(&center, traj.x.iter().map(|x| x[ix::E]))
}

/// The lane edges as polylines: (right edge at e_min, left edge at e_max).
pub fn lane_edges_xy(traj: &Trajectory) -> (Polyline, Polyline) {
    let center = frame(traj);
    (
        offset_xy(&center, traj.e_min.iter().copied()),
        offset_xy(&center, traj.e_max.iter().copied()),
    )
}

/// Viridis colour map (8 stops, linear interpolation) at t in [0, 1].
fn viridis(t: f64) -> RGBColor {
    const STOPS: [(u8, u8, u8); 8] = [
        (68, 1, 84),
        (70, 50, 127),
        (54, 92, 141),
        (39, 127, 143),
        (31, 162, 136),
        (74, 194, 110),
        (160, 219, 57),
        (254, 232, 37),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let f = t * (STOPS.len() - 1) as f64;
    let i = (f.floor() as usize).min(STOPS.len() - 2);
    let w = f - i as f64;
    let lerp = |a: u8, b: u8| (f64::from(a) + w * (f64::from(b) - f64::from(a))).round() as u8;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    RGBColor(lerp(a.0, b.0), lerp(a.1, b.1), lerp(a.2, b.2))
}

/// Smallest and largest finite value, if any.
fn finite_min_max(values: impl IntoIterator<Item = f64>) -> Option<(f64, f64)> {
    values
        .into_iter()
        .filter(|v| v.is_finite())
        .fold(None, |acc, v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
        })
}

/// Axis range covering the finite values with a 5 % margin (never empty).
fn padded_range(values: impl IntoIterator<Item = f64>) -> Range<f64> {
    match finite_min_max(values) {
        None => -1.0..1.0,
        Some((lo, hi)) => {
            let pad = if hi > lo {
                0.05 * (hi - lo)
            } else {
                0.5 * lo.abs().max(1.0)
            };
            (lo - pad)..(hi + pad)
        }
    }
}

/// Tick label for `v` on an axis spanning `span`: just enough decimals, no "-0".
fn tick_label(v: f64, span: f64) -> String {
    let step = (span.abs() / 5.0).max(1e-12);
    let decimals = (-step.log10()).ceil().clamp(0.0, 6.0) as usize;
    let text = format!("{v:.decimals$}");
    match text.strip_prefix('-') {
        Some(rest) if rest.chars().all(|c| c == '0' || c == '.') => rest.to_string(),
        _ => text,
    }
}

/// Splits a polyline at non-finite points into finite pieces of at least two points.
fn finite_pieces(points: &[(f64, f64)]) -> Vec<Vec<(f64, f64)>> {
    points
        .split(|p| !(p.0.is_finite() && p.1.is_finite()))
        .filter(|piece| piece.len() >= 2)
        .map(<[(f64, f64)]>::to_vec)
        .collect()
}

/// Checks that every per-node array matches the N + 1 states and N controls.
fn check_consistent(traj: &Trajectory) -> Result<(), PlotError> {
    let n1 = traj.x.len();
    if n1 == 0 {
        return Err(PlotError::Empty);
    }
    let lens = [
        ("kappa", traj.kappa.len(), n1),
        ("e_min", traj.e_min.len(), n1),
        ("e_max", traj.e_max.len(), n1),
        ("lane_e_min", traj.lane_e_min.len(), n1),
        ("lane_e_max", traj.lane_e_max.len(), n1),
        ("u", traj.u.len(), n1 - 1),
    ];
    for (name, got, want) in lens {
        if got != want {
            return Err(PlotError::Inconsistent(format!(
                "{name} has {got} entries, expected {want} for {n1} nodes"
            )));
        }
    }
    if !(traj.ds.is_finite() && traj.ds > 0.0) {
        return Err(PlotError::Inconsistent(format!(
            "ds = {} is not positive",
            traj.ds
        )));
    }
    Ok(())
}

/// One curve of a panel against s.
struct Curve {
    /// Legend entry (None: no legend).
    label: Option<&'static str>,
    /// Line colour.
    color: RGBColor,
    /// (s, value) points.
    points: Vec<(f64, f64)>,
}

/// Draws one panel of curves against s on `area`.
fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    s_range: Range<f64>,
    y_desc: &str,
    x_desc: Option<&str>,
    curves: &[Curve],
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let y_range = padded_range(curves.iter().flat_map(|c| c.points.iter().map(|p| p.1)));
    let (x_span, y_span) = (s_range.end - s_range.start, y_range.end - y_range.start);
    let x_fmt = move |v: &f64| tick_label(*v, x_span);
    let y_fmt = move |v: &f64| tick_label(*v, y_span);
    let mut chart = ChartBuilder::on(area)
        .margin_top(8)
        .margin_right(16)
        .margin_left(4)
        .x_label_area_size(if x_desc.is_some() { 42 } else { 24 })
        .y_label_area_size(70)
        .build_cartesian_2d(s_range, y_range)
        .map_err(draw_err)?;
    let mut mesh = chart.configure_mesh();
    mesh.y_desc(y_desc)
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.08))
        .x_labels(10)
        .y_labels(5)
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt);
    if let Some(d) = x_desc {
        mesh.x_desc(d);
    }
    mesh.draw().map_err(draw_err)?;
    for c in curves {
        let style = c.color.stroke_width(2);
        let mut first = true;
        for piece in finite_pieces(&c.points) {
            let ann = chart
                .draw_series(LineSeries::new(piece, style))
                .map_err(draw_err)?;
            if let (true, Some(label)) = (first, c.label) {
                let color = c.color;
                ann.label(label).legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 20, y)], color.stroke_width(2))
                });
                first = false;
            }
        }
    }
    if curves.iter().any(|c| c.label.is_some()) {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font((FONT, 14))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.3))
            .draw()
            .map_err(draw_err)?;
    }
    Ok(())
}

/// Stairs of a piecewise-constant control u_k on [s_k, s_k+1) as (s, value) points.
fn control_steps(traj: &Trajectory, index: usize, scale: f64) -> Vec<(f64, f64)> {
    let mut pts = Vec::with_capacity(2 * traj.u.len());
    for (k, u) in traj.u.iter().enumerate() {
        let v = u[index] * scale;
        pts.push((k as f64 * traj.ds, v));
        pts.push(((k + 1) as f64 * traj.ds, v));
    }
    pts
}

/// Expands the (x, y) ranges about their centres so one metre spans the same number of
/// pixels on both axes of a plotting area of `w` x `h` pixels.
fn equal_aspect(xr: Range<f64>, yr: Range<f64>, w: u32, h: u32) -> (Range<f64>, Range<f64>) {
    let (w, h) = (f64::from(w.max(1)), f64::from(h.max(1)));
    let (dx, dy) = (xr.end - xr.start, yr.end - yr.start);
    let scale = (dx / w).max(dy / h); // metres per pixel
    let (cx, cy) = (0.5 * (xr.start + xr.end), 0.5 * (yr.start + yr.end));
    let (hx, hy) = (0.5 * scale * w, 0.5 * scale * h);
    ((cx - hx)..(cx + hx), (cy - hy)..(cy + hy))
}

/// Draws the top view (lane edges, centerline, path coloured by V) and its colour bar.
fn draw_top_view<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    traj: &Trajectory,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let center = frame(traj);
    let center_pts: Vec<(f64, f64)> = center.iter().map(|&(x, y, _)| (x, y)).collect();
    let path = path_xy(traj);
    let (right, left) = lane_edges_xy(traj);
    let speeds: Vec<f64> = traj.x.iter().map(|x| x[ix::V]).collect();
    let (v_lo, v_hi) = finite_min_max(speeds.iter().copied()).unwrap_or((0.0, 1.0));
    let v_hi = if v_hi > v_lo { v_hi } else { v_lo + 1.0 };

    let (_, area_h) = area.dim_in_pixel();
    let (view, bar) = area.split_vertically(area_h.saturating_sub(90));

    // Ranges of everything drawn, made isotropic for the plotting area's pixel size.
    let all = || right.iter().chain(&left).chain(&center_pts).chain(&path);
    let xr = padded_range(all().map(|p| p.0));
    let yr = padded_range(all().map(|p| p.1));
    let build = |xr: Range<f64>, yr: Range<f64>| {
        ChartBuilder::on(&view)
            .margin(12)
            .x_label_area_size(42)
            .y_label_area_size(64)
            .build_cartesian_2d(xr, yr)
            .map_err(draw_err)
    };
    let (pw, ph) = build(xr.clone(), yr.clone())?
        .plotting_area()
        .dim_in_pixel();
    let (xr, yr) = equal_aspect(xr, yr, pw, ph);
    let (x_span, y_span) = (xr.end - xr.start, yr.end - yr.start);
    let x_fmt = move |v: &f64| tick_label(*v, x_span);
    let y_fmt = move |v: &f64| tick_label(*v, y_span);
    let mut chart = build(xr, yr)?;
    chart
        .configure_mesh()
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .x_desc("x [m]")
        .y_desc("y [m]")
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.08))
        .draw()
        .map_err(draw_err)?;

    let edge_style = RGBColor(120, 120, 120).stroke_width(2);
    let mut first = true;
    for edge in [&right, &left] {
        for piece in finite_pieces(edge) {
            let ann = chart
                .draw_series(LineSeries::new(piece, edge_style))
                .map_err(draw_err)?;
            if first {
                ann.label("lane edges")
                    .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], edge_style));
                first = false;
            }
        }
    }
    let center_style = RGBColor(150, 150, 150).stroke_width(1);
    let mut first = true;
    for piece in finite_pieces(&center_pts) {
        let ann = chart
            .draw_series(DashedLineSeries::new(piece, 6, 5, center_style))
            .map_err(draw_err)?;
        if first {
            ann.label("centerline")
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 8, y)], center_style));
            first = false;
        }
    }
    // Path: one segment per interval, coloured by the mean speed of its end nodes.
    let segments = path.windows(2).zip(speeds.windows(2)).filter_map(|(p, v)| {
        let ok = p.iter().all(|q| q.0.is_finite() && q.1.is_finite());
        ok.then(|| {
            let c = viridis((0.5 * (v[0] + v[1]) - v_lo) / (v_hi - v_lo));
            PathElement::new([p[0], p[1]], c.stroke_width(4))
        })
    });
    chart
        .draw_series(segments)
        .map_err(draw_err)?
        .label("path (colour = V)")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], viridis(0.5).stroke_width(4)));
    if let Some(&p0) = path.first().filter(|p| p.0.is_finite() && p.1.is_finite()) {
        chart
            .draw_series(std::iter::once(Circle::new(p0, 6, BLACK.filled())))
            .map_err(draw_err)?
            .label("start")
            .legend(|(x, y)| Circle::new((x + 10, y), 5, BLACK.filled()));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .label_font((FONT, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .draw()
        .map_err(draw_err)?;

    draw_speed_bar(&bar, v_lo, v_hi)
}

/// Draws the horizontal colour bar of the speed V over [v_lo, v_hi] on `bar`, with the
/// exact extremes beside its ends.
fn draw_speed_bar<DB: DrawingBackend>(
    bar: &DrawingArea<DB, Shift>,
    v_lo: f64,
    v_hi: f64,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let mut cb = ChartBuilder::on(bar)
        .margin_left(140)
        .margin_right(140)
        .margin_top(10)
        .margin_bottom(4)
        .x_label_area_size(46)
        .build_cartesian_2d(v_lo..v_hi, 0.0..1.0)
        .map_err(draw_err)?;
    cb.configure_mesh()
        .disable_y_mesh()
        .disable_y_axis()
        .disable_x_mesh()
        .x_labels(6)
        .x_label_formatter(&|v: &f64| tick_label(*v, v_hi - v_lo))
        .x_desc("speed V [m/s]")
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .draw()
        .map_err(draw_err)?;
    // Exact extremes beside the bar ends (the ticks are rounded).
    let (bar_w, _) = bar.dim_in_pixel();
    let bar_mid = 25;
    let end_label =
        |h: HPos| TextStyle::from((FONT, 15).into_font()).pos(Pos::new(h, VPos::Center));
    bar.draw(&Text::new(
        format!("min {v_lo:.2} m/s"),
        (130, bar_mid),
        end_label(HPos::Right),
    ))
    .map_err(draw_err)?;
    bar.draw(&Text::new(
        format!("max {v_hi:.2} m/s"),
        (bar_w as i32 - 130, bar_mid),
        end_label(HPos::Left),
    ))
    .map_err(draw_err)?;
    const BANDS: usize = 200;
    let dv = (v_hi - v_lo) / BANDS as f64;
    cb.draw_series((0..BANDS).map(|i| {
        let v0 = v_lo + i as f64 * dv;
        Rectangle::new(
            [(v0, 0.0), (v0 + dv, 1.0)],
            viridis((i as f64 + 0.5) / BANDS as f64).filled(),
        )
    }))
    .map_err(draw_err)?;
    Ok(())
}

/// Writes a PNG of `traj` to `path`: top view coloured by speed (left), and V / V_wr,
/// beta, delta and T_comb / T_bf against s (right).
pub fn plot_trajectory(traj: &Trajectory, path: &Path) -> Result<(), PlotError> {
    check_consistent(traj)?;
    ensure_font()?;
    save_png(path, FIGURE_SIZE, |root| draw_trajectory(root, traj))
}

/// Draws the figure of [`plot_trajectory`] on `root`.
fn draw_trajectory(root: &Canvas<'_>, traj: &Trajectory) -> Result<(), PlotError> {
    root.fill(&WHITE).map_err(draw_err)?;
    let title = format!("{}: t_N = {:.3} s", traj.name, traj.t_final());
    let body = root.titled(&title, (FONT, 26)).map_err(draw_err)?;
    let (left, right) = body.split_horizontally(LEFT_WIDTH);

    draw_top_view(&left, traj)?;

    let s_end = traj.n_intervals() as f64 * traj.ds;
    let s_range = 0.0..if s_end > 0.0 { s_end } else { traj.ds };
    let s_of = |k: usize| k as f64 * traj.ds;
    let node_series = |index: usize| -> Vec<(f64, f64)> {
        traj.x
            .iter()
            .enumerate()
            .map(|(k, x)| (s_of(k), x[index]))
            .collect()
    };
    let panels = right.split_evenly((4, 1));
    let blue = RGBColor(31, 119, 180);
    let orange = RGBColor(255, 127, 14);
    let specs: [(&str, Vec<Curve>); 4] = [
        (
            "speed [m/s]",
            vec![
                Curve {
                    label: Some("V"),
                    color: blue,
                    points: node_series(ix::V),
                },
                Curve {
                    label: Some("V_wr"),
                    color: orange,
                    points: node_series(ix::VWR),
                },
            ],
        ),
        (
            "sideslip β [rad]",
            vec![Curve {
                label: None,
                color: blue,
                points: node_series(ix::BETA),
            }],
        ),
        (
            "steering δ [rad]",
            vec![Curve {
                label: None,
                color: blue,
                points: control_steps(traj, iu::DELTA, 1.0),
            }],
        ),
        (
            "torque [kN m]",
            vec![
                Curve {
                    label: Some("T_comb"),
                    color: blue,
                    points: control_steps(traj, iu::TCOMB, 1e-3),
                },
                Curve {
                    label: Some("T_bf"),
                    color: orange,
                    points: control_steps(traj, iu::TBF, 1e-3),
                },
            ],
        ),
    ];
    let n_panels = specs.len();
    for (i, (panel, (y_desc, curves))) in panels.iter().zip(specs).enumerate() {
        let x_desc = (i + 1 == n_panels).then_some("s [m]");
        draw_panel(panel, s_range.clone(), y_desc, x_desc, &curves)?;
    }
    Ok(())
}

/// Outline drawn by [`plot_footprint`]: Lexus LC 500 length and width \[m\] (spec sheet).
const CAR_OUTLINE: (f64, f64) = (4.77, 1.92);

/// Size of the PNG written by [`plot_footprint`] \[px\].
pub const FOOTPRINT_SIZE: (u32, u32) = (1400, 900);

/// Corners of the car's outline at node `k`: centred on the CG, turned to the body
/// heading psi_ref + dpsi - beta (dpsi is the velocity's heading error, beta the sideslip).
fn outline(center: &[(f64, f64, f64)], traj: &Trajectory, k: usize) -> [(f64, f64); 4] {
    let (x, y, psi) = center[k];
    let st = &traj.x[k];
    let (px, py) = (x - st[ix::E] * psi.sin(), y + st[ix::E] * psi.cos());
    let h = psi + st[ix::DPSI] - st[ix::BETA];
    let (l, w) = (0.5 * CAR_OUTLINE.0, 0.5 * CAR_OUTLINE.1);
    let (c, s) = (h.cos(), h.sin());
    [(l, w), (l, -w), (-l, -w), (-l, w)].map(|(a, b)| (px + a * c - b * s, py + a * s + b * c))
}

/// Whether an obstacle blocks node k on the right and on the left: the bound there is
/// tighter than the lane's bound without obstacles (a bounds override), by more than 1 nm.
pub fn blocked_nodes(traj: &Trajectory) -> Vec<(bool, bool)> {
    (0..traj.e_min.len().min(traj.lane_e_min.len()))
        .map(|k| {
            (
                traj.e_min[k] > traj.lane_e_min[k] + 1e-9,
                traj.e_max[k] < traj.lane_e_max[k] - 1e-9,
            )
        })
        .collect()
}

/// Obstacles as polygons: at nodes an obstacle blocks ([`blocked_nodes`]), the excluded
/// strip between the lane's bound and the tightened one (contiguous nodes form one polygon).
fn obstacle_polygons(center: &[(f64, f64, f64)], traj: &Trajectory) -> Vec<Polyline> {
    let blocked_at = blocked_nodes(traj);
    let at = |k: usize, e: f64| {
        let (x, y, psi) = center[k];
        (x - e * psi.sin(), y + e * psi.cos())
    };
    let n = center.len().min(blocked_at.len());
    let mut polys = Vec::new();
    for right in [true, false] {
        let blocked = |k: usize| {
            if right {
                blocked_at[k].0
            } else {
                blocked_at[k].1
            }
        };
        let (edge, bound): (&[f64], &[f64]) = if right {
            (&traj.lane_e_min, &traj.e_min)
        } else {
            (&traj.lane_e_max, &traj.e_max)
        };
        let mut k = 0;
        while k < n {
            if !blocked(k) {
                k += 1;
                continue;
            }
            let start = k;
            while k < n && blocked(k) {
                k += 1;
            }
            let mut poly: Polyline = (start..k).map(|j| at(j, edge[j])).collect();
            poly.extend((start..k).rev().map(|j| at(j, bound[j])));
            polys.push(poly);
        }
    }
    polys
}

/// Writes the footprint figure: the road with its obstacles and the car's outline along
/// the path (every other node, coloured by |beta|, so a drift shows as the body turned
/// against the path), and sideslip against s below.
pub fn plot_footprint(traj: &Trajectory, path: &Path) -> Result<(), PlotError> {
    check_consistent(traj)?;
    ensure_font()?;
    save_png(path, FOOTPRINT_SIZE, |root| draw_footprint(root, traj))
}

/// Draws the figure of [`plot_footprint`] on `root`.
fn draw_footprint(root: &Canvas<'_>, traj: &Trajectory) -> Result<(), PlotError> {
    root.fill(&WHITE).map_err(draw_err)?;
    let (top, bottom) = root.split_vertically(560);
    let center = frame(traj);
    let (right, left) = lane_edges_xy(traj);
    let xs = right.iter().chain(&left).map(|p| p.0);
    let ys = right.iter().chain(&left).map(|p| p.1);
    let (xr, yr) = equal_aspect(
        padded_range(xs),
        padded_range(ys),
        FOOTPRINT_SIZE.0 - 90,
        560 - 90,
    );
    let title = format!(
        "{}: footprint (colour = |beta|), max |beta| = {:.3} rad, t_N = {:.3} s",
        traj.name,
        traj.max_abs_beta(),
        traj.t_final()
    );
    let mut chart = ChartBuilder::on(&top)
        .caption(title, (FONT, 22))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(45)
        .build_cartesian_2d(xr, yr)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc("x [m]")
        .y_desc("y [m]")
        .label_style((FONT, 14))
        .draw()
        .map_err(draw_err)?;
    for poly in obstacle_polygons(&center, traj) {
        chart
            .draw_series(std::iter::once(Polygon::new(
                poly,
                RGBColor(200, 60, 60).mix(0.5).filled(),
            )))
            .map_err(draw_err)?;
    }
    for edge in [&right, &left] {
        chart
            .draw_series(LineSeries::new(edge.iter().copied(), BLACK.stroke_width(2)))
            .map_err(draw_err)?;
    }
    let beta_max = traj.max_abs_beta().max(1e-6);
    for k in (0..traj.x.len()).step_by(2) {
        let corners = outline(&center, traj, k);
        if corners.iter().any(|p| !p.0.is_finite() || !p.1.is_finite()) {
            continue;
        }
        let colour = viridis(traj.x[k][ix::BETA].abs() / beta_max);
        let mut closed = corners.to_vec();
        closed.push(corners[0]);
        chart
            .draw_series(std::iter::once(PathElement::new(
                closed,
                colour.stroke_width(2),
            )))
            .map_err(draw_err)?;
        // Nose marker: the front edge's midpoint.
        let nose = (
            0.5 * (corners[0].0 + corners[1].0),
            0.5 * (corners[0].1 + corners[1].1),
        );
        chart
            .draw_series(std::iter::once(Circle::new(nose, 2, colour.filled())))
            .map_err(draw_err)?;
    }
    let s_max = traj.ds * traj.n_intervals() as f64;
    let betas: Vec<(f64, f64)> = traj
        .x
        .iter()
        .enumerate()
        .map(|(k, x)| (k as f64 * traj.ds, x[ix::BETA]))
        .collect();
    let br = padded_range(betas.iter().map(|p| p.1).chain([0.0]));
    let mut chart = ChartBuilder::on(&bottom)
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(55)
        .build_cartesian_2d(0.0..s_max, br.clone())
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc("s [m]")
        .y_desc("sideslip beta [rad]")
        .label_style((FONT, 14))
        .draw()
        .map_err(draw_err)?;
    // Obstacle intervals shaded.
    for (k, (r, l)) in blocked_nodes(traj).into_iter().enumerate() {
        if r || l {
            let s0 = (k as f64 - 0.5).max(0.0) * traj.ds;
            let s1 = ((k as f64 + 0.5) * traj.ds).min(s_max);
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(s0, br.start), (s1, br.end)],
                    RGBColor(200, 60, 60).mix(0.25).filled(),
                )))
                .map_err(draw_err)?;
        }
    }
    chart
        .draw_series(LineSeries::new(betas, BLUE.stroke_width(2)))
        .map_err(draw_err)?;
    Ok(())
}
