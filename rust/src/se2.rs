//! Planar rigid transforms (SE(2)), map frames (ROS map_server's resolution and origin), and
//! maps placed in their frames, and the least-squares fit of a rigid transform to point pairs
//! (SPEC section 7).

use crate::grid::Grid;

/// One map and where its cells are.
#[derive(Clone, Copy, Debug)]
pub struct Placed<'a> {
    pub grid: Grid<'a>,
    pub frame: Frame,
}

/// A rigid motion of the plane: `p -> R(theta) p + (tx, ty)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Se2 {
    pub theta: f64,
    pub tx: f64,
    pub ty: f64,
}

impl Se2 {
    /// The identity.
    pub const IDENTITY: Se2 = Se2 {
        theta: 0.0,
        tx: 0.0,
        ty: 0.0,
    };

    /// Apply to a point.
    #[inline]
    pub fn apply(&self, x: f64, y: f64) -> (f64, f64) {
        let (s, c) = self.theta.sin_cos();
        (c * x - s * y + self.tx, s * x + c * y + self.ty)
    }

    /// The motion as a matrix and a translation (sine and cosine computed once).
    pub fn affine(&self) -> Affine {
        let (s, c) = self.theta.sin_cos();
        Affine {
            m: [[c, -s], [s, c]],
            t: [self.tx, self.ty],
        }
    }

    /// The inverse motion.
    pub fn inverse(&self) -> Se2 {
        let (s, c) = self.theta.sin_cos();
        Se2 {
            theta: -self.theta,
            tx: -(c * self.tx + s * self.ty),
            ty: -(-s * self.tx + c * self.ty),
        }
    }

    /// `self` after `first`: `p -> self(first(p))`.
    pub fn compose(&self, first: &Se2) -> Se2 {
        let (tx, ty) = self.apply(first.tx, first.ty);
        Se2 {
            theta: wrap(self.theta + first.theta),
            tx,
            ty,
        }
    }
}

/// A planar affine map `p -> m p + t`, for the hot loops (no trigonometry per point).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Affine {
    pub m: [[f64; 2]; 2],
    pub t: [f64; 2],
}

impl Affine {
    /// Apply to a point.
    #[inline]
    pub fn apply(&self, x: f64, y: f64) -> (f64, f64) {
        (
            self.m[0][0] * x + self.m[0][1] * y + self.t[0],
            self.m[1][0] * x + self.m[1][1] * y + self.t[1],
        )
    }

    /// `self` after `first`.
    pub fn after(&self, first: &Affine) -> Affine {
        let (a, b) = (&self.m, &first.m);
        let mut m = [[0.0; 2]; 2];
        for i in 0..2 {
            for j in 0..2 {
                m[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j];
            }
        }
        let (tx, ty) = self.apply(first.t[0], first.t[1]);
        Affine { m, t: [tx, ty] }
    }

    /// The inverse map (None when singular).
    pub fn inverse(&self) -> Option<Affine> {
        let m = &self.m;
        let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let inv = [
            [m[1][1] / det, -m[0][1] / det],
            [-m[1][0] / det, m[0][0] / det],
        ];
        let t = [
            -(inv[0][0] * self.t[0] + inv[0][1] * self.t[1]),
            -(inv[1][0] * self.t[0] + inv[1][1] * self.t[1]),
        ];
        Some(Affine { m: inv, t })
    }
}

/// `floor(x)` as an integer, inline (`f64::floor` is a libm call on baseline x86-64).
/// Saturates outside the i64 range (below -2^63 too: `i64::MIN`, not a wrap to
/// `i64::MAX`), NaN gives 0; callers check bounds.
#[inline]
pub fn floor_i64(x: f64) -> i64 {
    let i = x as i64;
    i.saturating_sub((x < i as f64) as i64)
}

/// An angle wrapped to (-pi, pi].
pub fn wrap(a: f64) -> f64 {
    let t = std::f64::consts::TAU;
    let w = a - t * (a / t).round();
    if w <= -std::f64::consts::PI {
        w + t
    } else {
        w
    }
}

/// Where a map's cells are: metres per cell and the pose (x, y, yaw) of the lower-left
/// corner of the lower-left cell, as ROS map_server's YAML says. Rows are held image-style
/// (row 0 at the top), so cell `(row, col)` of an `height`-row map has its centre at
/// `((col + 0.5) res, (height - row - 0.5) res)` in the map's own frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub resolution: f64,
    pub height: usize,
    pub width: usize,
    pub origin: Se2,
}

impl Frame {
    /// World position of the centre of cell `(row, col)`.
    #[inline]
    pub fn centre(&self, row: usize, col: usize) -> (f64, f64) {
        let x = (col as f64 + 0.5) * self.resolution;
        let y = (self.height as f64 - row as f64 - 0.5) * self.resolution;
        self.origin.apply(x, y)
    }

    /// The affine map from `(row, col)` (as floats) to world: cell centres at integers.
    pub fn cell_to_world(&self) -> Affine {
        let (s, c) = self.origin.theta.sin_cos();
        let r = self.resolution;
        // map frame: x = (col + 0.5) r, y = (height - row - 0.5) r
        let (mx0, my0) = (0.5 * r, (self.height as f64 - 0.5) * r);
        let t = [
            c * mx0 - s * my0 + self.origin.tx,
            s * mx0 + c * my0 + self.origin.ty,
        ];
        // d/d row: (0, -r) rotated; d/d col: (r, 0) rotated
        Affine {
            m: [[s * r, c * r], [-c * r, s * r]],
            t,
        }
    }

    /// The affine map from world to the fractional `(row, col)` position whose `floor` is
    /// the cell holding the point (the inverse of [`Frame::cell_to_world`], shifted by half
    /// a cell).
    pub fn world_to_cell_affine(&self) -> Affine {
        let (s, c) = self.origin.theta.sin_cos();
        let r = self.resolution;
        // map frame (mx, my) = R^T (p - o); row = height - my / r, col = mx / r
        let (ox, oy) = (self.origin.tx, self.origin.ty);
        let mx = [c / r, s / r, -(c * ox + s * oy) / r];
        let my = [-s / r, c / r, -(-s * ox + c * oy) / r];
        Affine {
            m: [[-my[0], -my[1]], [mx[0], mx[1]]],
            t: [self.height as f64 - my[2], mx[2]],
        }
    }

    /// The (fractional) `(row, col)` position of a world point: the inverse of
    /// [`Frame::cell_to_world`]. The cell holding the point is `floor` of both.
    #[inline]
    pub fn world_to_cell(&self, x: f64, y: f64) -> (f64, f64) {
        let (mx, my) = self.origin.inverse().apply(x, y);
        let col = mx / self.resolution;
        let row = self.height as f64 - my / self.resolution;
        (row, col)
    }

    /// The cell holding a world point, if inside the grid.
    #[inline]
    pub fn cell_of(&self, x: f64, y: f64) -> Option<(usize, usize)> {
        let (r, c) = self.world_to_cell(x, y);
        let (r, c) = (r.floor(), c.floor());
        if r >= 0.0 && c >= 0.0 && r < self.height as f64 && c < self.width as f64 {
            Some((r as usize, c as usize))
        } else {
            None
        }
    }
}

/// Sums of point pairs `(p, q)` for the least-squares rigid fit `q ~ T p`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PairSums {
    pub n: f64,
    pub px: f64,
    pub py: f64,
    pub qx: f64,
    pub qy: f64,
    pub sxx: f64,
    pub sxy: f64,
    pub syx: f64,
    pub syy: f64,
}

impl PairSums {
    /// Add one pair.
    #[inline]
    pub fn add(&mut self, p: (f64, f64), q: (f64, f64)) {
        self.n += 1.0;
        self.px += p.0;
        self.py += p.1;
        self.qx += q.0;
        self.qy += q.1;
        self.sxx += p.0 * q.0;
        self.sxy += p.0 * q.1;
        self.syx += p.1 * q.0;
        self.syy += p.1 * q.1;
    }

    /// The rigid motion minimising the sum of squared distances `|T p - q|^2` (the 2-D
    /// Kabsch / Umeyama solution without scale); None for no pair.
    pub fn fit(&self) -> Option<Se2> {
        if self.n < 1.0 {
            return None;
        }
        let n = self.n;
        let (mpx, mpy, mqx, mqy) = (self.px / n, self.py / n, self.qx / n, self.qy / n);
        // centred cross-covariance
        let cxx = self.sxx - n * mpx * mqx;
        let cxy = self.sxy - n * mpx * mqy;
        let cyx = self.syx - n * mpy * mqx;
        let cyy = self.syy - n * mpy * mqy;
        let theta = (cxy - cyx).atan2(cxx + cyy);
        let (s, c) = theta.sin_cos();
        Some(Se2 {
            theta,
            tx: mqx - (c * mpx - s * mpy),
            ty: mqy - (s * mpx + c * mpy),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `floor_i64` is the floor, saturated at both ends of the i64 range (it wrapped to
    /// `i64::MAX` below -2^63, and overflowed in debug builds).
    #[test]
    fn floor_i64_is_the_saturated_floor() {
        let two63 = 9_223_372_036_854_775_808.0;
        for (x, want) in [
            (0.0, 0),
            (-0.0, 0),
            (0.5, 0),
            (-0.5, -1),
            (-1.0, -1),
            (2.999, 2),
            (-2.001, -3),
            (f64::NAN, 0),
            (f64::INFINITY, i64::MAX),
            (f64::NEG_INFINITY, i64::MIN),
            (1e300, i64::MAX),
            (-1e300, i64::MIN),
            (-9.3e18, i64::MIN),
            (two63, i64::MAX),
            (-two63, i64::MIN),
            (-two63 - 4096.0, i64::MIN),
            (-4503599627370495.5, -4503599627370496),
        ] {
            assert_eq!(floor_i64(x), want, "{x}");
        }
    }

    #[test]
    fn fit_recovers_a_motion() {
        let t = Se2 {
            theta: 0.3,
            tx: 1.5,
            ty: -2.0,
        };
        let mut sums = PairSums::default();
        for (x, y) in [(0.0, 0.0), (1.0, 0.0), (0.0, 2.0), (3.0, 1.0)] {
            sums.add((x, y), t.apply(x, y));
        }
        let f = sums.fit().unwrap();
        assert!((f.theta - 0.3).abs() < 1e-12 && (f.tx - 1.5).abs() < 1e-12);
        assert!((f.ty + 2.0).abs() < 1e-12);
        let back = t.inverse().compose(&t);
        assert!(back.theta.abs() < 1e-12 && back.tx.abs() < 1e-12 && back.ty.abs() < 1e-12);
    }

    #[test]
    fn frames_round_trip() {
        let f = Frame {
            resolution: 0.05,
            height: 10,
            width: 20,
            origin: Se2 {
                theta: 0.2,
                tx: -3.0,
                ty: 1.0,
            },
        };
        let (x, y) = f.centre(3, 7);
        assert_eq!(f.cell_of(x, y), Some((3, 7)));
        let (wx, wy) = f.cell_to_world().apply(3.0, 7.0);
        assert!((wx - x).abs() < 1e-12 && (wy - y).abs() < 1e-12);
        let (r, c) = f.world_to_cell_affine().apply(x, y);
        assert!((r - 3.5).abs() < 1e-9 && (c - 7.5).abs() < 1e-9);
        let back = f.cell_to_world().inverse().unwrap().apply(x, y);
        assert!((back.0 - 3.0).abs() < 1e-9 && (back.1 - 7.0).abs() < 1e-9);
        assert_eq!(f.cell_of(-100.0, 0.0), None);
        assert!((wrap(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
    }
}
