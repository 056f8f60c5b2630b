//! Planar rigid transforms (SE(2)), map frames (ROS map_server's resolution and origin), and
//! the least-squares fit of a rigid transform to point pairs (SPEC section 7).

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

    /// The affine map from `(row, col)` (as floats) to world: `world = a * (row, col) + b`,
    /// as `[[a00, a01], [a10, a11]]` and `b`.
    pub fn cell_to_world(&self) -> ([[f64; 2]; 2], [f64; 2]) {
        let (s, c) = self.origin.theta.sin_cos();
        let r = self.resolution;
        // map frame: x = (col + 0.5) r, y = (height - row - 0.5) r
        let (mx0, my0) = (0.5 * r, (self.height as f64 - 0.5) * r);
        let b = [
            c * mx0 - s * my0 + self.origin.tx,
            s * mx0 + c * my0 + self.origin.ty,
        ];
        // d/d row: (0, -r) rotated; d/d col: (r, 0) rotated
        let a = [[s * r, c * r], [-c * r, s * r]];
        (a, b)
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
        let (a, b) = f.cell_to_world();
        let (wx, wy) = (
            a[0][0] * 3.0 + a[0][1] * 7.0 + b[0],
            a[1][0] * 3.0 + a[1][1] * 7.0 + b[1],
        );
        assert!((wx - x).abs() < 1e-12 && (wy - y).abs() < 1e-12);
        assert_eq!(f.cell_of(-100.0, 0.0), None);
        assert!((wrap(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
    }
}
