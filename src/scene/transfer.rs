//! The transfer function of `scene.md`: control points `[s, r, g, b, opacity]`,
//! piecewise linear in between, clamped outside `[s_first, s_last]`.
//!
//! Opacity is VTK's "scalar opacity per unit distance": a slab of thickness
//! `unit_distance` with constant opacity `o` lets `1 - o` of the light through,
//! so the extinction coefficient is `tau(s) = -ln(1 - o(s)) / unit_distance`.
//! An opacity of exactly 1 is clamped to `1 - 1e-6` (`OPACITY_MAX`).

/// Largest opacity used in the extinction `-ln(1 - o)`; the spec clamps 1 to this.
pub const OPACITY_MAX: f64 = 1.0 - 1e-6;

/// One control point of the transfer function.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlPoint {
    /// Normalised scalar in `[0, 1]`.
    pub s: f64,
    /// Colour (not premultiplied).
    pub rgb: [f64; 3],
    /// Opacity per `unit_distance`, in `[0, 1]`.
    pub opacity: f64,
}

/// A validated transfer function.
#[derive(Debug, Clone, PartialEq)]
pub struct TransferFunction {
    /// Control points, `s` non-decreasing, at least one.
    pub points: Vec<ControlPoint>,
    /// World length over which `opacity` applies (VTK's ScalarOpacityUnitDistance).
    pub unit_distance: f64,
}

impl TransferFunction {
    /// A transfer function from rows `[s, r, g, b, opacity]`, as written in a
    /// scene file, without validation (for code that builds one directly;
    /// scene files go through [`Scene::parse`](super::Scene::parse), which checks them).
    pub fn from_rows(rows: &[[f64; 5]], unit_distance: f64) -> TransferFunction {
        TransferFunction {
            points: rows
                .iter()
                .map(|p| ControlPoint {
                    s: p[0],
                    rgb: [p[1], p[2], p[3]],
                    opacity: p[4],
                })
                .collect(),
            unit_distance,
        }
    }

    /// Colour and opacity at normalised scalar `s` (clamped outside the points).
    pub fn eval(&self, s: f64) -> ([f64; 3], f64) {
        let p = &self.points;
        if s <= p[0].s {
            return (p[0].rgb, p[0].opacity);
        }
        let last = p[p.len() - 1];
        if s >= last.s {
            return (last.rgb, last.opacity);
        }
        // First point strictly right of s; s lies in [p[k-1].s, p[k].s).
        let k = p.partition_point(|c| c.s <= s);
        let (a, b) = (p[k - 1], p[k]);
        let w = if b.s > a.s {
            (s - a.s) / (b.s - a.s)
        } else {
            0.0
        };
        let lerp = |x: f64, y: f64| x + (y - x) * w;
        (
            [
                lerp(a.rgb[0], b.rgb[0]),
                lerp(a.rgb[1], b.rgb[1]),
                lerp(a.rgb[2], b.rgb[2]),
            ],
            lerp(a.opacity, b.opacity),
        )
    }

    /// Extinction per world unit at `s`: `-ln(1 - min(o, OPACITY_MAX)) / unit_distance`.
    pub fn extinction(&self, s: f64) -> f64 {
        let o = self.eval(s).1.min(OPACITY_MAX);
        -(1.0 - o).ln() / self.unit_distance
    }

    /// The largest opacity over the closed scalar interval `[a, b]`. Because the
    /// function is piecewise linear, the maximum is at an end or a control point.
    pub fn max_opacity_in(&self, a: f64, b: f64) -> f64 {
        let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
        let mut m = self.eval(lo).1.max(self.eval(hi).1);
        for c in &self.points {
            if c.s > lo && c.s < hi {
                m = m.max(c.opacity);
            }
        }
        m
    }

    /// The largest emitted radiance, `max over points of max(r, g, b)`. ERT's
    /// per-pixel error bound is `(1 - threshold)` times this.
    pub fn max_radiance(&self) -> f64 {
        self.points
            .iter()
            .map(|c| c.rgb.iter().cloned().fold(0.0, f64::max))
            .fold(0.0, f64::max)
    }

    /// Scalars of the control points strictly inside `(0, 1)`: the places where
    /// the piecewise-linear functions have kinks.
    pub fn breakpoints(&self) -> impl Iterator<Item = f64> + '_ {
        self.points.iter().map(|c| c.s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tf() -> TransferFunction {
        TransferFunction {
            points: vec![
                ControlPoint {
                    s: 0.0,
                    rgb: [0.0, 0.0, 1.0],
                    opacity: 0.0,
                },
                ControlPoint {
                    s: 0.5,
                    rgb: [0.0, 1.0, 0.0],
                    opacity: 0.5,
                },
                ControlPoint {
                    s: 1.0,
                    rgb: [1.0, 0.0, 0.0],
                    opacity: 0.2,
                },
            ],
            unit_distance: 2.0,
        }
    }

    #[test]
    fn eval_interpolates_and_clamps() {
        let t = tf();
        assert_eq!(t.eval(-1.0).1, 0.0);
        assert_eq!(t.eval(2.0).1, 0.2);
        assert!((t.eval(0.25).1 - 0.25).abs() < 1e-12);
        assert!((t.eval(0.75).0[0] - 0.5).abs() < 1e-12);
    }

    #[test]
    fn extinction_is_vtk_unit_distance() {
        let t = tf();
        // o = 0.5 over unit_distance 2: transmittance over 2 units is 0.5.
        assert!((t.extinction(0.5) * 2.0 - 2f64.ln()).abs() < 1e-12);
    }

    #[test]
    fn max_opacity_sees_interior_peaks() {
        let t = tf();
        assert!((t.max_opacity_in(0.1, 0.9) - 0.5).abs() < 1e-12);
        assert_eq!(t.max_opacity_in(0.0, 0.0), 0.0);
    }
}
