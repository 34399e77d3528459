//! Clipping curves to the visible box by intersection (a segment leaving the box ends exactly on its
//! edge; nothing is clamped onto the frame), and the arc-length helpers used to place arrows.

/// An axis-aligned rectangle `[x0, x1] × [y0, y1]` (x0 ≤ x1, y0 ≤ y1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewBox {
    /// Left edge.
    pub x0: f64,
    /// Right edge.
    pub x1: f64,
    /// Bottom edge.
    pub y0: f64,
    /// Top edge.
    pub y1: f64,
}

impl ViewBox {
    /// Whether `(x, y)` lies inside or on the box.
    pub fn contains(&self, x: f64, y: f64) -> bool {
        x >= self.x0 && x <= self.x1 && y >= self.y0 && y <= self.y1
    }
}

/// The part of the segment `a`–`b` inside the box (Liang–Barsky), or `None` when it misses the box.
/// An end outside the box is moved along the segment to the exact boundary crossing.
pub fn clip_segment(a: (f64, f64), b: (f64, f64), bx: &ViewBox) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let mut t0: f64 = 0.0;
    let mut t1: f64 = 1.0;
    for (p, q) in [
        (-dx, a.0 - bx.x0),
        (dx, bx.x1 - a.0),
        (-dy, a.1 - bx.y0),
        (dy, bx.y1 - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
            if t0 > t1 {
                return None;
            }
        }
    }
    if !(t0.is_finite() && t1.is_finite()) {
        return None;
    }
    let at = |t: f64| (a.0 + t * dx, a.1 + t * dy);
    // Ends already inside keep their exact coordinates (no rounding through t).
    let p0 = if t0 == 0.0 { a } else { at(t0) };
    let p1 = if t1 == 1.0 { b } else { at(t1) };
    Some((p0, p1))
}

/// Splits a polyline into the runs that are visible in the box; every run that enters or leaves the
/// box starts or ends on its edge. Non-finite points break the line.
pub fn clip_polyline(points: &[(f64, f64)], bx: &ViewBox) -> Vec<Vec<(f64, f64)>> {
    let mut runs: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut cur: Vec<(f64, f64)> = Vec::new();
    let finite = |p: &(f64, f64)| p.0.is_finite() && p.1.is_finite();
    if points.len() == 1 && finite(&points[0]) && bx.contains(points[0].0, points[0].1) {
        return vec![points.to_vec()];
    }
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        if !(finite(&a) && finite(&b)) {
            if cur.len() > 1 {
                runs.push(std::mem::take(&mut cur));
            }
            cur.clear();
            continue;
        }
        match clip_segment(a, b, bx) {
            Some((p, q)) => {
                if cur.last() != Some(&p) {
                    if cur.len() > 1 {
                        runs.push(std::mem::take(&mut cur));
                    }
                    cur.clear();
                    cur.push(p);
                }
                cur.push(q);
                if q != b {
                    // Left the box.
                    runs.push(std::mem::take(&mut cur));
                }
            }
            None => {
                if cur.len() > 1 {
                    runs.push(std::mem::take(&mut cur));
                }
                cur.clear();
            }
        }
    }
    if cur.len() > 1 {
        runs.push(cur);
    }
    runs
}

/// Clips a closed polygon to the box (Sutherland–Hodgman); used for shaded bands.
pub fn clip_polygon(poly: &[(f64, f64)], bx: &ViewBox) -> Vec<(f64, f64)> {
    type Edge = (
        fn(&ViewBox, (f64, f64)) -> bool,
        fn(&ViewBox, (f64, f64), (f64, f64)) -> (f64, f64),
    );
    fn lerp_x(a: (f64, f64), b: (f64, f64), x: f64) -> (f64, f64) {
        let t = (x - a.0) / (b.0 - a.0);
        (x, a.1 + t * (b.1 - a.1))
    }
    fn lerp_y(a: (f64, f64), b: (f64, f64), y: f64) -> (f64, f64) {
        let t = (y - a.1) / (b.1 - a.1);
        (a.0 + t * (b.0 - a.0), y)
    }
    let edges: [Edge; 4] = [
        (|b, p| p.0 >= b.x0, |b, p, q| lerp_x(p, q, b.x0)),
        (|b, p| p.0 <= b.x1, |b, p, q| lerp_x(p, q, b.x1)),
        (|b, p| p.1 >= b.y0, |b, p, q| lerp_y(p, q, b.y0)),
        (|b, p| p.1 <= b.y1, |b, p, q| lerp_y(p, q, b.y1)),
    ];
    let mut out: Vec<(f64, f64)> = poly
        .iter()
        .copied()
        .filter(|p| p.0.is_finite() && p.1.is_finite())
        .collect();
    for (inside, cross) in edges {
        if out.is_empty() {
            break;
        }
        let input = std::mem::take(&mut out);
        let mut prev = input[input.len() - 1];
        for &p in &input {
            match (inside(bx, p), inside(bx, prev)) {
                (true, true) => out.push(p),
                (true, false) => {
                    out.push(cross(bx, prev, p));
                    out.push(p);
                }
                (false, true) => out.push(cross(bx, prev, p)),
                (false, false) => {}
            }
            prev = p;
        }
    }
    out
}

/// Points at the given fractions (0…1) of the total length of the visible runs, each with the unit
/// direction of travel there: where to put arrowheads along a curve.
pub fn points_along(runs: &[Vec<(f64, f64)>], fractions: &[f64]) -> Vec<((f64, f64), (f64, f64))> {
    let seg_len = |a: (f64, f64), b: (f64, f64)| ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
    let total: f64 = runs
        .iter()
        .flat_map(|r| r.windows(2).map(|w| seg_len(w[0], w[1])))
        .sum();
    if total.is_nan() || total <= 0.0 {
        return Vec::new();
    }
    let mut out = Vec::new();
    for &f in fractions {
        let target = f.clamp(0.0, 1.0) * total;
        let mut acc = 0.0;
        'find: for r in runs {
            for w in r.windows(2) {
                let l = seg_len(w[0], w[1]);
                if l > 0.0 && acc + l >= target {
                    let t = (target - acc) / l;
                    let p = (w[0].0 + t * (w[1].0 - w[0].0), w[0].1 + t * (w[1].1 - w[0].1));
                    out.push((p, ((w[1].0 - w[0].0) / l, (w[1].1 - w[0].1) / l)));
                    break 'find;
                }
                acc += l;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const B: ViewBox = ViewBox {
        x0: -2.0,
        x1: 2.0,
        y0: -2.0,
        y1: 2.0,
    };

    #[test]
    fn a_crossing_segment_is_cut_at_the_boundary() {
        // From (0, 0) to (4, 1): leaves through x = 2 at y = 0.5.
        let (p, q) = clip_segment((0.0, 0.0), (4.0, 1.0), &B).expect("visible");
        assert_eq!(p, (0.0, 0.0));
        assert!((q.0 - 2.0).abs() < 1e-15 && (q.1 - 0.5).abs() < 1e-15, "{q:?}");
        // Through the box corner to corner beyond both edges.
        let (p, q) = clip_segment((-4.0, -1.0), (4.0, 1.0), &B).expect("visible");
        assert!((p.0 + 2.0).abs() < 1e-15 && (p.1 + 0.5).abs() < 1e-15);
        assert!((q.0 - 2.0).abs() < 1e-15 && (q.1 - 0.5).abs() < 1e-15);
        assert!(clip_segment((3.0, 0.0), (3.0, 1.0), &B).is_none());
        assert!(clip_segment((3.0, 3.0), (5.0, -1.0), &B).is_none());
    }

    #[test]
    fn a_polyline_leaving_and_returning_gives_two_runs_not_a_line_on_the_frame() {
        let pts = [(0.0, 0.0), (1.0, 0.0), (5.0, 0.0), (5.0, 1.0), (1.0, 1.0), (0.0, 1.0)];
        let runs = clip_polyline(&pts, &B);
        assert_eq!(runs.len(), 2);
        assert_eq!(runs[0], vec![(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)]);
        assert_eq!(runs[1], vec![(2.0, 1.0), (1.0, 1.0), (0.0, 1.0)]);
        // No point lies on x = 2 except the two cut ends (clamping would put (2, 0) … (2, 1) on the frame).
        let on_frame = runs.iter().flatten().filter(|p| p.0 == 2.0).count();
        assert_eq!(on_frame, 2);
    }

    #[test]
    fn polygons_are_cut_to_the_box() {
        let sq = [(-3.0, -1.0), (3.0, -1.0), (3.0, 1.0), (-3.0, 1.0)];
        let c = clip_polygon(&sq, &B);
        assert!(c.iter().all(|p| B.contains(p.0, p.1)));
        assert_eq!(c.len(), 4);
    }

    #[test]
    fn arrows_are_spread_along_the_curve() {
        let runs = vec![vec![(0.0, 0.0), (1.0, 0.0)]];
        let a = points_along(&runs, &[0.5]);
        assert_eq!(a, vec![((0.5, 0.0), (1.0, 0.0))]);
    }
}
