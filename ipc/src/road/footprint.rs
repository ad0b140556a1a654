//! Clearance between the car's body and the obstacles of an open road.
//!
//! On the straight road of an obstacle scenario the road frame (s, e) is Cartesian. The
//! car's footprint is a rectangle of length L and width W centred on the CG at (s, e),
//! turned by the body's heading against the road, psi = dpsi - beta (dpsi is the heading
//! of the velocity: e' = V sin dpsi). An obstacle's bounds override limits the CG and
//! already holds a half-width h of the car (the scenario's convention, h = 1 m): an
//! override that raises e_min to e_lo on [s_from, s_to] is a box filling the road from its
//! right edge up to e = e_lo - h, one that lowers e_max to e_hi fills it from e = e_hi + h
//! to the left edge. The clearance of two convex polygons is their distance when they are
//! apart (the smallest vertex-to-edge distance) and minus their smallest overlap along a
//! separating-axis candidate when they intersect.

use planner::track::BoundsOverride;

/// Body length of the Lexus LC 500 \[m\] (manufacturer specification, 4770 mm); the vehicle
/// file carries the single-track model only.
pub const CAR_LENGTH_M: f64 = 4.77;
/// Body width of the Lexus LC 500 \[m\] (manufacturer specification, 1920 mm).
pub const CAR_WIDTH_M: f64 = 1.92;
/// Half-width the obstacle scenarios' CG bounds include \[m\].
pub const BOUNDS_HALF_WIDTH_M: f64 = 1.0;

/// A convex quadrilateral in the road frame (s, e), corners in order.
pub type Quad = [[f64; 2]; 4];

/// The car's footprint at CG (s, e) with body heading `psi` against the road \[rad\].
pub fn footprint(s: f64, e: f64, psi: f64, length: f64, width: f64) -> Quad {
    let (sn, cs) = psi.sin_cos();
    let (hl, hw) = (0.5 * length, 0.5 * width);
    let corner = |a: f64, b: f64| [s + a * cs - b * sn, e + a * sn + b * cs];
    [
        corner(hl, hw),
        corner(-hl, hw),
        corner(-hl, -hw),
        corner(hl, -hw),
    ]
}

/// The physical boxes of one obstacle on a road with CG edges [road_lo, road_hi]: one per
/// side whose bound it moves (usually one).
pub fn obstacle_boxes(o: &BoundsOverride, road_lo: f64, road_hi: f64) -> [Option<Quad>; 2] {
    let h = BOUNDS_HALF_WIDTH_M;
    let rect = |e0: f64, e1: f64| [[o.s_from, e0], [o.s_to, e0], [o.s_to, e1], [o.s_from, e1]];
    [
        (o.e_min > road_lo).then(|| rect(road_lo - h, o.e_min - h)),
        (o.e_max < road_hi).then(|| rect(o.e_max + h, road_hi + h)),
    ]
}

fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

fn dot(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// Distance from point p to segment ab.
fn point_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let ab = sub(b, a);
    let len2 = dot(ab, ab);
    let t = if len2 > 0.0 {
        (dot(sub(p, a), ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let d = sub(p, [a[0] + t * ab[0], a[1] + t * ab[1]]);
    dot(d, d).sqrt()
}

/// Smallest overlap of the projections of `a` and `b` on the edge normals of both
/// (negative: a separating axis exists, the gap along it).
fn min_overlap(a: &Quad, b: &Quad) -> f64 {
    let mut least = f64::INFINITY;
    for poly in [a, b] {
        for i in 0..4 {
            let edge = sub(poly[(i + 1) % 4], poly[i]);
            let len = dot(edge, edge).sqrt();
            if len == 0.0 {
                continue;
            }
            let n = [-edge[1] / len, edge[0] / len];
            let proj = |q: &Quad| {
                q.iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                        let x = dot(*p, n);
                        (lo.min(x), hi.max(x))
                    })
            };
            let ((alo, ahi), (blo, bhi)) = (proj(a), proj(b));
            least = least.min(ahi.min(bhi) - alo.max(blo));
        }
    }
    least
}

/// Signed clearance of two convex quadrilaterals \[m\]: their distance when apart, minus
/// their smallest overlap depth when they intersect.
pub fn clearance(a: &Quad, b: &Quad) -> f64 {
    let overlap = min_overlap(a, b);
    if overlap > 0.0 {
        return -overlap;
    }
    let mut d = f64::INFINITY;
    for (p, q) in [(a, b), (b, a)] {
        for v in p {
            for i in 0..4 {
                d = d.min(point_segment(*v, q[i], q[(i + 1) % 4]));
            }
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_car_beside_a_box_is_its_gap_away_and_one_inside_is_negative() {
        let o = BoundsOverride {
            s_from: 40.0,
            s_to: 45.0,
            e_min: 1.0,
            e_max: 3.5,
        };
        let [Some(b), None] = obstacle_boxes(&o, -3.5, 3.5) else {
            panic!("one box on the right")
        };
        // The box fills e <= 0 on s in [40, 45]; a car 2 m wide centred at e = 2 is 1 m clear.
        let car = footprint(42.0, 2.0, 0.0, 4.0, 2.0);
        assert!((clearance(&car, &b) - 1.0).abs() < 1e-12);
        // Behind the box by 3 m (car front at s = 37).
        let car = footprint(35.0, -1.0, 0.0, 4.0, 2.0);
        assert!((clearance(&car, &b) - 3.0).abs() < 1e-12);
        // Centred on the lane line: 1 m into the box.
        let car = footprint(42.0, 0.0, 0.0, 4.0, 2.0);
        assert!((clearance(&car, &b) + 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_turned_car_reaches_further_sideways() {
        let b = [[0.0, -10.0], [10.0, -10.0], [10.0, 0.0], [0.0, 0.0]];
        let straight = clearance(&footprint(5.0, 2.0, 0.0, 4.0, 2.0), &b);
        let turned = clearance(&footprint(5.0, 2.0, 0.5, 4.0, 2.0), &b);
        assert!((straight - 1.0).abs() < 1e-12);
        // Rear corner at 2 - 2 sin 0.5 - cos 0.5 above the box's top edge.
        let want = 2.0 - 2.0 * 0.5f64.sin() - 0.5f64.cos();
        assert!((turned - want).abs() < 1e-9, "{turned} vs {want}");
    }
}
