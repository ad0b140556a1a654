//! Checks of a raw closed centerline before smoothing: enough points, the loop not closed
//! twice, and no self-crossing unless the track is a figure eight.
//!
//! The raw points p_0 .. p_{n-1} form the closed polygon with edges p_i -> p_{i+1 mod n}.
//! Two non-adjacent edges that share a point (they cross, touch, or one point repeats) make
//! the polygon self-crossing. Edges are binned on a uniform grid whose cell is the mean
//! edge length, so only edges in a shared cell are compared (near-linear for track-like
//! data).

use super::csv::Row;
use super::TrackFileError;
use crate::elementary::hypot;
use std::collections::BTreeMap;
use std::path::Path;

/// Fewest raw points a closed centerline may have.
pub const MIN_POINTS: usize = 4;

/// Most raw points a centerline may have (bounds memory and the crossing search).
pub const MAX_POINTS: usize = 1_000_000;

/// Largest number of grid cells one edge may cover in the crossing search.
const MAX_CELLS_PER_EDGE: i64 = 10_000;

/// Orientation of the triangle (a, b, c): positive counter-clockwise, 0 collinear.
fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Whether c lies in the bounding box of a and b (used for collinear points).
fn within(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> bool {
    c[0] >= a[0].min(b[0])
        && c[0] <= a[0].max(b[0])
        && c[1] >= a[1].min(b[1])
        && c[1] <= a[1].max(b[1])
}

/// Whether the closed segments p1-p2 and q1-q2 share a point.
fn segments_meet(p1: [f64; 2], p2: [f64; 2], q1: [f64; 2], q2: [f64; 2]) -> bool {
    let d1 = orient(q1, q2, p1);
    let d2 = orient(q1, q2, p2);
    let d3 = orient(p1, p2, q1);
    let d4 = orient(p1, p2, q2);
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    (d1 == 0.0 && within(q1, q2, p1))
        || (d2 == 0.0 && within(q1, q2, p2))
        || (d3 == 0.0 && within(p1, p2, q1))
        || (d4 == 0.0 && within(p1, p2, q2))
}

/// The first pair of non-adjacent edges (i, j), i < j, of the closed polygon `points` that
/// share a point, if any (smallest i, then smallest j).
pub(crate) fn first_crossing(points: &[[f64; 2]]) -> Option<(usize, usize)> {
    let n = points.len();
    if n < 4 {
        return None;
    }
    let edge = |i: usize| (points[i], points[(i + 1) % n]);
    let perimeter: f64 = (0..n)
        .map(|i| {
            let (a, b) = edge(i);
            hypot(b[0] - a[0], b[1] - a[1])
        })
        .sum();
    let h = (perimeter / n as f64).max(1e-9);
    let cell = |v: f64| (v / h).floor() as i64;
    let mut grid: BTreeMap<(i64, i64), Vec<usize>> = BTreeMap::new();
    for i in 0..n {
        let (a, b) = edge(i);
        let (x0, x1) = (cell(a[0].min(b[0])), cell(a[0].max(b[0])));
        let (y0, y1) = (cell(a[1].min(b[1])), cell(a[1].max(b[1])));
        // A very long edge is clipped to a bounded number of cells: it can then miss a
        // crossing far along it, never report a false one.
        let x1 = x1.min(x0 + MAX_CELLS_PER_EDGE);
        let y1 = y1.min(y0 + MAX_CELLS_PER_EDGE / (x1 - x0 + 1).max(1));
        for cx in x0..=x1 {
            for cy in y0..=y1 {
                grid.entry((cx, cy)).or_default().push(i);
            }
        }
    }
    let adjacent = |i: usize, j: usize| j == i + 1 || (i == 0 && j == n - 1);
    let mut best: Option<(usize, usize)> = None;
    for members in grid.values() {
        for (a, &i) in members.iter().enumerate() {
            for &j in &members[a + 1..] {
                let (i, j) = (i.min(j), i.max(j));
                if i == j || adjacent(i, j) || best.is_some_and(|b| b <= (i, j)) {
                    continue;
                }
                let (p1, p2) = edge(i);
                let (q1, q2) = edge(j);
                if segments_meet(p1, p2, q1, q2) {
                    best = Some((i, j));
                }
            }
        }
    }
    best
}

/// Checks the raw rows of `path` (x, y, w_right, w_left): between [`MIN_POINTS`] and
/// [`MAX_POINTS`] points, the last point not repeating the first, and no self-crossing unless
/// `figure_eight`. Each error names the rows at fault.
pub(crate) fn check_loop(
    path: &Path,
    rows: &[Row<4>],
    figure_eight: bool,
) -> Result<(), TrackFileError> {
    let n = rows.len();
    if n < MIN_POINTS {
        return Err(TrackFileError::csv(
            path,
            0,
            format!("{n} points: a closed centerline needs at least {MIN_POINTS}"),
        ));
    }
    if n > MAX_POINTS {
        return Err(TrackFileError::csv(
            path,
            0,
            format!("{n} points: at most {MAX_POINTS} are read"),
        ));
    }
    let points: Vec<[f64; 2]> = rows.iter().map(|r| [r.values[0], r.values[1]]).collect();
    if let Some(i) = (1..n).find(|&i| points[i] == points[i - 1]) {
        return Err(TrackFileError::csv(
            path,
            rows[i].line,
            format!("point repeats the previous one (line {})", rows[i - 1].line),
        ));
    }
    if points[0] == points[n - 1] {
        return Err(TrackFileError::csv(
            path,
            rows[n - 1].line,
            format!(
                "the last point repeats the first (line {}): list each point once, the loop \
                 closes from the last point back to the first by itself",
                rows[0].line
            ),
        ));
    }
    if figure_eight {
        return Ok(());
    }
    if let Some((i, j)) = first_crossing(&points) {
        let line = |k: usize| rows[k % n].line;
        return Err(TrackFileError::csv(
            path,
            line(j),
            format!(
                "the centerline crosses itself: the stretch from line {} to line {} meets the \
                 stretch from line {} to line {} (a figure-eight track must be imported as one: \
                 --figure-eight)",
                line(i),
                line(i + 1),
                line(j),
                line(j + 1)
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn circle(n: usize) -> Vec<[f64; 2]> {
        (0..n)
            .map(|i| {
                let a = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
                [100.0 * a.cos(), 100.0 * a.sin()]
            })
            .collect()
    }

    #[test]
    fn a_circle_does_not_cross_itself() {
        assert_eq!(first_crossing(&circle(200)), None);
    }

    #[test]
    fn a_figure_eight_crosses_itself_at_its_waist() {
        // Lemniscate of Gerono: x = cos t, y = sin t cos t crosses at the origin.
        let pts: Vec<[f64; 2]> = (0..400)
            .map(|i| {
                let t = 2.0 * std::f64::consts::PI * (i as f64 + 0.5) / 400.0;
                [200.0 * t.cos(), 200.0 * t.sin() * t.cos()]
            })
            .collect();
        let (i, j) = first_crossing(&pts).expect("crossing");
        assert!(i < 110 && (290..310).contains(&j), "{i} {j}");
    }

    #[test]
    fn a_point_repeated_later_counts_as_touching() {
        let mut pts = circle(100);
        pts[60] = pts[20];
        assert!(first_crossing(&pts).is_some());
    }
}
