//! Exact 2D laser ray casting on an occupancy grid (ground truth on demand's sensor).
//!
//! A beam starts at the laser's position and walks the grid cell by cell (Amanatides & Woo,
//! "A fast voxel traversal algorithm", 1987) until it enters a cell that stops it; its
//! range is the exact distance from the laser to where it enters that cell (0 when the
//! laser sits in one), or `inf` when no such cell lies within the maximum range or the beam
//! leaves the grid. Cells outside the grid stop nothing.
//!
//! Frames: the grid is held image-style (row 0 at the top); `origin` is the pose
//! `(x, y, yaw)` of the lower-left corner of the lower-left cell (ROS map_server). Poses
//! are `(x, y, yaw)` in the world frame; beam angles are relative to the pose's heading.
//!
//! `python/slamq/synth/sensors.py`'s `cast_numpy` is this module's numpy twin: the same
//! walk, the same floating-point operations in the same order, on numpy arrays.

use rayon::prelude::*;
use std::fmt;

/// The value of a padding cell around the grid: the beam left the grid.
const OUTSIDE: u8 = 2;

/// Why a cast could not be made.
#[derive(Debug, Clone, PartialEq)]
pub struct CastError(pub String);

impl fmt::Display for CastError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for CastError {}

/// `n` copies of `v`, or an error when the memory cannot be had (no abort on a huge input).
fn filled<T: Clone>(n: usize, v: T) -> Result<Vec<T>, CastError> {
    let mut out = Vec::new();
    out.try_reserve_exact(n).map_err(|_| {
        CastError(format!(
            "cannot allocate {n} values of {} bytes",
            std::mem::size_of::<T>()
        ))
    })?;
    out.resize(n, v);
    Ok(out)
}

/// A grid ready for casting: which cells stop a beam, with a one-cell ring of [`OUTSIDE`]
/// around it so that the walk needs no bounds check.
#[derive(Clone, Debug)]
pub struct RayGrid {
    /// `(height + 2) x (width + 2)`, row 0 at the top: 0 = free, 1 = stops, 2 = outside.
    cells: Vec<u8>,
    height: usize,
    width: usize,
    resolution: f64,
    origin: [f64; 3],
    /// `cos` and `sin` of the origin's yaw.
    rot: [f64; 2],
}

impl RayGrid {
    /// A grid from `blocked` (`height x width`, row 0 at the top; non-zero = the cell stops
    /// a beam), `resolution` metres per cell and the lower-left corner's pose `origin`.
    pub fn new(
        blocked: &[u8],
        height: usize,
        width: usize,
        resolution: f64,
        origin: [f64; 3],
    ) -> Result<Self, CastError> {
        if height == 0 || width == 0 {
            return Err(CastError("the grid has zero cells".into()));
        }
        if height.checked_mul(width) != Some(blocked.len()) {
            return Err(CastError(format!(
                "{} cells for a {height} x {width} grid",
                blocked.len()
            )));
        }
        if !resolution.is_finite() || resolution <= 0.0 {
            return Err(CastError(format!(
                "resolution must be a positive number, got {resolution}"
            )));
        }
        if !origin.iter().all(|v| v.is_finite()) {
            return Err(CastError(format!("origin must be finite, got {origin:?}")));
        }
        // the padded grid's size, with room for the index arithmetic in isize
        let pw = width + 2;
        let n = (height + 2)
            .checked_mul(pw)
            .filter(|&n| n < isize::MAX as usize / 2)
            .ok_or_else(|| CastError(format!("a {height} x {width} grid is too large")))?;
        let mut cells = filled(n, OUTSIDE)?;
        for (r, row) in blocked.chunks_exact(width).enumerate() {
            let dst = &mut cells[(r + 1) * pw + 1..(r + 1) * pw + 1 + width];
            for (d, &b) in dst.iter_mut().zip(row) {
                *d = u8::from(b != 0);
            }
        }
        Ok(RayGrid {
            cells,
            height,
            width,
            resolution,
            origin,
            rot: [origin[2].cos(), origin[2].sin()],
        })
    }

    /// The range of one beam at world angle `angle` from the world point `(x, y)`, metres
    /// (`inf`: no stopping cell within `max_range`); NaN when an argument is not finite
    /// (or `max_range` not positive).
    pub fn cast(&self, x: f64, y: f64, angle: f64, max_range: f64) -> f64 {
        match self.start(x, y, angle, max_range) {
            Err(r) => r,
            Ok(mut walk) => loop {
                if let Some(r) = walk.step(&self.cells) {
                    return r;
                }
            },
        }
    }

    /// A beam's walk at its first cell, or its range when it needs no walk.
    #[inline]
    fn start(&self, x: f64, y: f64, angle: f64, max_range: f64) -> Result<Walk, f64> {
        if !(x.is_finite() && y.is_finite() && angle.is_finite())
            || max_range.is_nan()
            || max_range <= 0.0
        {
            return Err(f64::NAN);
        }
        let [c, s] = self.rot;
        let res = self.resolution;
        // the laser in grid units: x along columns, y up along rows counted from the bottom
        let (wx, wy) = (x - self.origin[0], y - self.origin[1]);
        let ox = (c * wx + s * wy) / res;
        let oy = (c * wy - s * wx) / res;
        let a = angle - self.origin[2];
        let (dx, dy) = (a.cos(), a.sin());
        let t_range = max_range / res;
        let (w, h) = (self.width as f64, self.height as f64);
        // where the beam is inside the grid's box [0, w] x [0, h] (slabs)
        let (mut t0, mut t1) = (0.0f64, t_range);
        for (o, d, size) in [(ox, dx, w), (oy, dy, h)] {
            if d == 0.0 {
                if !(0.0..size).contains(&o) {
                    return Err(f64::INFINITY);
                }
            } else {
                let (ta, tb) = ((0.0 - o) / d, (size - o) / d);
                t0 = t0.max(ta.min(tb));
                t1 = t1.min(ta.max(tb));
            }
        }
        if t0.is_nan() || t1.is_nan() || t0 > t1 {
            return Err(f64::INFINITY);
        }
        // the first cell: where the beam is at t0, kept inside the grid against rounding
        let ix = ((ox + t0 * dx).floor()).clamp(0.0, w - 1.0);
        let iy = ((oy + t0 * dy).floor()).clamp(0.0, h - 1.0);
        let pw = (self.width + 2) as isize;
        let idx = (self.height as isize - iy as isize) * pw + ix as isize + 1;
        // the beam's parameter at the next column and row boundary, and between boundaries
        let (tx, tdx, sx) = if dx > 0.0 {
            ((ix + 1.0 - ox) / dx, 1.0 / dx, 1isize)
        } else if dx < 0.0 {
            ((ix - ox) / dx, -1.0 / dx, -1isize)
        } else {
            (f64::INFINITY, 0.0, 0isize)
        };
        let (ty, tdy, sy) = if dy > 0.0 {
            ((iy + 1.0 - oy) / dy, 1.0 / dy, -pw)
        } else if dy < 0.0 {
            ((iy - oy) / dy, -1.0 / dy, pw)
        } else {
            (f64::INFINITY, 0.0, 0isize)
        };
        Ok(Walk {
            t: t0,
            tx,
            ty,
            tdx,
            tdy,
            idx,
            sx,
            sy,
            t_range,
            res,
        })
    }

    /// One scan: the range of each beam at `angles` (relative to the pose's yaw) from
    /// `pose` into `out`.
    pub fn scan(&self, pose: [f64; 3], angles: &[f64], max_range: f64, out: &mut [f64]) {
        for (o, &a) in out.iter_mut().zip(angles) {
            *o = self.cast(pose[0], pose[1], pose[2] + a, max_range);
        }
    }
}

/// A beam's walk through the grid (Amanatides-Woo): its parameter `t` (cells along the
/// beam) where it entered the current cell `idx`, and where it meets the next column and
/// row boundaries.
#[derive(Clone, Copy, Debug)]
struct Walk {
    t: f64,
    tx: f64,
    ty: f64,
    tdx: f64,
    tdy: f64,
    idx: isize,
    sx: isize,
    sy: isize,
    t_range: f64,
    res: f64,
}

impl Walk {
    /// Look at the current cell: the range when it ends the walk, else move to the next.
    #[inline(always)]
    fn step(&mut self, cells: &[u8]) -> Option<f64> {
        // idx stays inside the padded grid: it starts inside the grid and moves one cell at
        // a time, and the walk ends on the ring of OUTSIDE cells around it
        let v = cells[self.idx as usize];
        if v != 0 {
            return Some(if v == 1 && self.t <= self.t_range {
                self.t * self.res
            } else {
                f64::INFINITY
            });
        }
        // branch-free step to the nearer boundary
        let step_x = self.tx < self.ty;
        self.t = if step_x { self.tx } else { self.ty };
        if self.t > self.t_range {
            return Some(f64::INFINITY);
        }
        self.tx += if step_x { self.tdx } else { 0.0 };
        self.ty += if step_x { 0.0 } else { self.tdy };
        self.idx += if step_x { self.sx } else { self.sy };
        None
    }
}

/// Every scan of `poses` (`(x, y, yaw)` triples, flat) with beams at `angles`:
/// `poses.len() / 3 x angles.len()` ranges, row-major, scans in parallel on the current
/// rayon pool (the same numbers for any number of threads). `max_range` must be positive
/// (it may be `inf`); poses and angles must be finite.
pub fn cast_scans(
    grid: &RayGrid,
    poses: &[f64],
    angles: &[f64],
    max_range: f64,
) -> Result<Vec<f64>, CastError> {
    if max_range.is_nan() || max_range <= 0.0 {
        return Err(CastError(format!(
            "max_range must be positive, got {max_range}"
        )));
    }
    if poses.len() % 3 != 0 {
        return Err(CastError(format!(
            "poses must be (x, y, yaw) triples, got {} numbers",
            poses.len()
        )));
    }
    if let Some(p) = poses
        .chunks_exact(3)
        .find(|p| !p.iter().all(|v| v.is_finite()))
    {
        return Err(CastError(format!("poses must be finite, got {p:?}")));
    }
    if let Some(a) = angles.iter().find(|a| !a.is_finite()) {
        return Err(CastError(format!("angles must be finite, got {a}")));
    }
    let b = angles.len();
    let n = poses.len() / 3;
    let total = n
        .checked_mul(b)
        .ok_or_else(|| CastError(format!("{n} x {b} ranges is too many")))?;
    let mut out = filled(total, 0.0f64)?;
    if b == 0 {
        return Ok(out);
    }
    out.par_chunks_mut(b)
        .zip(poses.par_chunks_exact(3))
        .with_min_len(4)
        .for_each(|(row, p)| grid.scan([p[0], p[1], p[2]], angles, max_range, row));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 10 x 10 grid at 0.1 m with a wall in column 7 (x in [0.7, 0.8]).
    fn wall() -> RayGrid {
        let mut b = vec![0u8; 100];
        for r in 0..10 {
            b[r * 10 + 7] = 1;
        }
        RayGrid::new(&b, 10, 10, 0.1, [0.0, 0.0, 0.0]).unwrap()
    }

    #[test]
    fn straight_hits_enter_the_cell() {
        let g = wall();
        assert!((g.cast(0.25, 0.55, 0.0, 10.0) - 0.45).abs() < 1e-12);
        // 60 degrees: the wall's face at x = 0.7 is 0.45 / cos(60) away
        let d = g.cast(0.25, 0.15, std::f64::consts::FRAC_PI_3, 10.0);
        assert!((d - 0.9).abs() < 1e-12, "{d}");
        assert_eq!(
            g.cast(0.25, 0.55, std::f64::consts::PI, 10.0),
            f64::INFINITY
        );
        assert_eq!(g.cast(0.25, 0.55, 0.0, 0.4), f64::INFINITY);
        assert_eq!(g.cast(0.75, 0.55, 0.0, 10.0), 0.0);
    }

    #[test]
    fn from_outside_the_grid() {
        let g = wall();
        assert!((g.cast(-1.0, 0.55, 0.0, 10.0) - 1.7).abs() < 1e-12);
        assert_eq!(g.cast(-1.0, 0.55, 0.0, 1.5), f64::INFINITY);
        assert_eq!(g.cast(-1.0, 2.0, 0.0, 10.0), f64::INFINITY);
        assert_eq!(g.cast(2.0, 0.55, 0.0, 10.0), f64::INFINITY);
        // from the right, it enters the wall's far face
        assert!((g.cast(2.0, 0.55, std::f64::consts::PI, 10.0) - 1.2).abs() < 1e-12);
    }

    #[test]
    fn rotated_origin() {
        // the same wall, its map turned by 90 degrees and moved
        let mut b = vec![0u8; 100];
        for r in 0..10 {
            b[r * 10 + 7] = 1;
        }
        let half_pi = std::f64::consts::FRAC_PI_2;
        let g = RayGrid::new(&b, 10, 10, 0.1, [5.0, 1.0, half_pi]).unwrap();
        // map point (0.25, 0.55) is world (5 - 0.55, 1 + 0.25); the beam along map x is
        // world +y
        let d = g.cast(5.0 - 0.55, 1.25, half_pi, 10.0);
        assert!((d - 0.45).abs() < 1e-12, "{d}");
    }

    #[test]
    fn bad_input_is_an_error() {
        assert!(RayGrid::new(&[0; 5], 2, 2, 0.1, [0.0; 3]).is_err());
        assert!(RayGrid::new(&[], 0, 0, 0.1, [0.0; 3]).is_err());
        assert!(RayGrid::new(&[0; 4], 2, 2, -1.0, [0.0; 3]).is_err());
        assert!(RayGrid::new(&[0; 4], 2, 2, 0.1, [f64::NAN, 0.0, 0.0]).is_err());
        let g = wall();
        assert!(cast_scans(&g, &[f64::NAN, 0.0, 0.0], &[0.0], 1.0).is_err());
        assert!(cast_scans(&g, &[0.0, 0.0], &[0.0], 1.0).is_err());
        assert!(cast_scans(&g, &[0.0; 3], &[f64::INFINITY], 1.0).is_err());
        assert!(cast_scans(&g, &[0.0; 3], &[0.0], 0.0).is_err());
        assert!(cast_scans(&g, &[0.0; 3], &[0.0], f64::NAN).is_err());
        assert!(cast_scans(&g, &[0.0; 3], &[0.0], f64::INFINITY).is_ok());
    }

    #[test]
    fn infinite_range_and_far_poses_end() {
        let g = RayGrid::new(&[0; 4], 2, 2, 0.1, [0.0; 3]).unwrap();
        for a in [0.0, 0.3, 1.0, 2.0, 3.0, -1.0, -2.5] {
            assert_eq!(g.cast(0.05, 0.05, a, f64::INFINITY), f64::INFINITY);
            assert_eq!(g.cast(1e300, -1e300, a, f64::INFINITY), f64::INFINITY);
        }
    }

    #[test]
    fn thread_counts_agree() {
        let mut b = vec![0u8; 400];
        for (i, v) in b.iter_mut().enumerate() {
            *v = u8::from(i * 7919 % 13 == 0);
        }
        let g = RayGrid::new(&b, 20, 20, 0.05, [0.0; 3]).unwrap();
        let poses: Vec<f64> = (0..50)
            .flat_map(|i| {
                [
                    0.1 + 0.017 * i as f64,
                    0.9 - 0.013 * i as f64,
                    0.3 * i as f64,
                ]
            })
            .collect();
        let angles: Vec<f64> = (0..181).map(|i| -1.5 + 3.0 * i as f64 / 180.0).collect();
        let run = |n| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap()
                .install(|| cast_scans(&g, &poses, &angles, 5.0).unwrap())
        };
        let one = run(1);
        assert_eq!(one, run(3));
        assert!(one.iter().any(|v| v.is_finite()));
    }
}
