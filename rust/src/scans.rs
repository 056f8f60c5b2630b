//! A map against its own laser scans (SPEC section 7b): every beam of every scan, placed at
//! the map's estimated pose, either ends on a wall of the map (a hit), ends away from one
//! (a miss), ends on an unknown cell or off the grid, and may pass through a wall the map
//! has before its end (a free-space violation: the laser saw through it). A violation is a
//! *crossing* when the beam, after the wall, comes out into known free space clear of every
//! wall (farther than the tolerance from any occupied cell) before its end: the laser saw
//! through the wall, not along it (a beam grazing a wall drawn a cell too thick stays near
//! it).
//!
//! Frames are [`crate::raycast`]'s (and SPEC section 7's): the grid is held image-style
//! (row 0 at the top), `origin` is the pose `(x, y, yaw)` of the lower-left corner of the
//! lower-left cell, and a beam is walked in grid units (x along columns, y up along rows
//! counted from the bottom) with the Amanatides-Woo traversal; on a tie at a cell corner
//! the walk steps to the row neighbour first.
//!
//! Every count is an integer computed for one scan alone; the violation grid is the sum of
//! per-chunk lists of cells added in scan order, so the result is the same for any number
//! of threads. `python/slamq/metrics/scans.py`'s `scan_consistency_reference` is this
//! module's numpy twin (the same floating-point operations in the same order).

use rayon::prelude::*;
use std::fmt;

/// A known cell with occupancy probability above the threshold.
const OCCUPIED: u8 = 1;
/// An unknown cell.
const UNKNOWN: u8 = 2;
/// An occupied cell lies within the tolerance (Euclidean, between cell centres).
const NEAR: u8 = 4;
/// The ring of padding around the grid: the walk left it.
const OUTSIDE: u8 = 8;

/// The largest tolerance, in cells, that the near-wall mask is built for.
pub const MAX_TOLERANCE_CELLS: f64 = 256.0;

/// Scans per unit of parallel work (fixed, so that the work split never depends on the
/// thread count).
const CHUNK: usize = 8;

/// The counts of one scan, in this order (the columns of [`consistency`]'s output).
pub const COLUMNS: [&str; 7] = [
    "valid",
    "hits",
    "misses",
    "unknown",
    "outside",
    "violations",
    "crossings",
];

/// Why a score could not be made.
#[derive(Debug, Clone, PartialEq)]
pub struct ScanError(pub String);

impl fmt::Display for ScanError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ScanError {}

/// `n` copies of `v`, or an error when the memory cannot be had.
pub(crate) fn filled<T: Clone>(n: usize, v: T) -> Result<Vec<T>, ScanError> {
    let mut out = Vec::new();
    out.try_reserve_exact(n).map_err(|_| {
        ScanError(format!(
            "cannot allocate {n} values of {} bytes",
            std::mem::size_of::<T>()
        ))
    })?;
    out.resize(n, v);
    Ok(out)
}

/// A map ready for scoring scans: each cell's state bits (occupied, unknown, near a wall)
/// with a one-cell ring of [`OUTSIDE`] around it.
#[derive(Clone, Debug)]
pub struct ScanGrid {
    /// `(height + 2) x (width + 2)`, row 0 at the top.
    cells: Vec<u8>,
    height: usize,
    width: usize,
    resolution: f64,
    origin: [f64; 3],
    /// `cos` and `sin` of the origin's yaw.
    rot: [f64; 2],
    /// The tolerance in cells (`tolerance / resolution`).
    tol: f64,
}

/// The offsets `(di, dj)` of the disc `di^2 + dj^2 <= tol^2` (float64 compare), as the
/// half-width of each row `di` in `-reach..=reach`.
fn disc(tol: f64) -> (isize, Vec<isize>) {
    let t2 = tol * tol;
    let reach = tol.floor() as isize;
    let rows = (-reach..=reach)
        .map(|di| {
            let mut dj = 0isize;
            while ((di * di + (dj + 1) * (dj + 1)) as f64) <= t2 {
                dj += 1;
            }
            dj
        })
        .collect();
    (reach, rows)
}

/// The walk's start along one axis, for a ray at `o + t d` in cell `cell` (`floor` of
/// where it starts): the `t` of the first cell boundary it meets, the `t` between two
/// boundaries, and the step (+1, -1; 0 and an infinite `t` when `d` is 0).
#[inline]
pub(crate) fn first_boundary(o: f64, d: f64, cell: f64) -> (f64, f64, isize) {
    if d > 0.0 {
        ((cell + 1.0 - o) / d, 1.0 / d, 1)
    } else if d < 0.0 {
        ((cell - o) / d, -1.0 / d, -1)
    } else {
        (f64::INFINITY, 0.0, 0)
    }
}

impl ScanGrid {
    /// A grid from the map's `values` and `unknown` mask (`height x width`, row 0 at the
    /// top): a known cell is occupied when `(255 - v) / 255 > occupied_threshold`;
    /// `tolerance` in metres (> 0).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        values: &[u8],
        unknown: &[bool],
        height: usize,
        width: usize,
        resolution: f64,
        origin: [f64; 3],
        occupied_threshold: f64,
        tolerance: f64,
    ) -> Result<Self, ScanError> {
        if height == 0 || width == 0 {
            return Err(ScanError("the map has zero cells".into()));
        }
        if height.checked_mul(width) != Some(values.len()) || unknown.len() != values.len() {
            return Err(ScanError(format!(
                "{} values and {} unknown flags for a {height} x {width} map",
                values.len(),
                unknown.len()
            )));
        }
        if !resolution.is_finite() || resolution <= 0.0 {
            return Err(ScanError(format!(
                "resolution must be a positive number, got {resolution}"
            )));
        }
        if !origin.iter().all(|v| v.is_finite()) {
            return Err(ScanError(format!("origin must be finite, got {origin:?}")));
        }
        if occupied_threshold.is_nan() {
            return Err(ScanError("occupied_threshold must be a number".into()));
        }
        let tol = tolerance / resolution;
        if !(tolerance.is_finite() && tolerance > 0.0) || tol > MAX_TOLERANCE_CELLS {
            return Err(ScanError(format!(
                "tolerance must be positive and at most {MAX_TOLERANCE_CELLS} cells, got \
                 {tolerance} m ({tol} cells)"
            )));
        }
        let pw = width + 2;
        let n = (height + 2)
            .checked_mul(pw)
            .filter(|&n| n < isize::MAX as usize / 2 && height * width <= u32::MAX as usize)
            .ok_or_else(|| ScanError(format!("a {height} x {width} map is too large")))?;
        let mut cells = filled(n, OUTSIDE)?;
        let occupied: [bool; 256] =
            std::array::from_fn(|v| (255 - v) as f64 / 255.0 > occupied_threshold);
        for r in 0..height {
            let dst = &mut cells[(r + 1) * pw + 1..(r + 1) * pw + 1 + width];
            let src = &values[r * width..(r + 1) * width];
            let unk = &unknown[r * width..(r + 1) * width];
            for ((d, &v), &u) in dst.iter_mut().zip(src).zip(unk) {
                *d = if u {
                    UNKNOWN
                } else if occupied[v as usize] {
                    OCCUPIED
                } else {
                    0
                };
            }
        }
        // the near mask: every cell within the disc around an occupied cell
        let (reach, half) = disc(tol);
        let (hi, wi) = (height as isize, width as isize);
        for r in 0..hi {
            for c in 0..wi {
                let p = ((r + 1) * pw as isize + c + 1) as usize;
                if cells[p] & OCCUPIED == 0 {
                    continue;
                }
                for (k, &dj) in half.iter().enumerate() {
                    let rr = r + k as isize - reach;
                    if rr < 0 || rr >= hi {
                        continue;
                    }
                    let (c0, c1) = ((c - dj).max(0), (c + dj).min(wi - 1));
                    let base = (rr + 1) * pw as isize + 1;
                    for cell in &mut cells[(base + c0) as usize..=(base + c1) as usize] {
                        *cell |= NEAR;
                    }
                }
            }
        }
        Ok(ScanGrid {
            cells,
            height,
            width,
            resolution,
            origin,
            rot: [origin[2].cos(), origin[2].sin()],
            tol,
        })
    }

    /// The counts ([`COLUMNS`]) of one scan taken by a laser at `pose` (`(x, y, yaw)` in
    /// the world frame) with beams at `angles` (relative to the yaw) reading `ranges`;
    /// the (unpadded, row-major) index of every occupied cell a beam passed through is
    /// pushed onto `violated`, and onto `crossed` too when that beam crossed a wall.
    #[allow(clippy::too_many_arguments)]
    pub fn scan(
        &self,
        pose: [f64; 3],
        angles: &[f64],
        ranges: &[f64],
        min_range: f64,
        max_range: f64,
        violated: &mut Vec<u32>,
        crossed: &mut Vec<u32>,
    ) -> [i64; 7] {
        let mut out = [0i64; 7];
        let [c, s] = self.rot;
        let res = self.resolution;
        let (wx, wy) = (pose[0] - self.origin[0], pose[1] - self.origin[1]);
        let ox = (c * wx + s * wy) / res;
        let oy = (c * wy - s * wx) / res;
        let (w, h) = (self.width as f64, self.height as f64);
        let pw = self.width + 2;
        for (&angle, &r) in angles.iter().zip(ranges) {
            if !(r.is_finite() && r > min_range && r < max_range) {
                continue;
            }
            out[0] += 1;
            let a = (pose[2] + angle) - self.origin[2];
            let (dx, dy) = (a.cos(), a.sin());
            let len = r / res;
            let ex = ox + len * dx;
            let ey = oy + len * dy;
            let (fx, fy) = (ex.floor(), ey.floor());
            if !((0.0..w).contains(&fx) && (0.0..h).contains(&fy)) {
                out[4] += 1;
            } else {
                let idx = (self.height - fy as usize) * pw + fx as usize + 1;
                let v = self.cells[idx];
                out[if v & NEAR != 0 {
                    1
                } else if v & UNKNOWN != 0 {
                    3
                } else {
                    2
                }] += 1;
            }
            let start = violated.len();
            let (violation, crossing) = self.walk(ox, oy, dx, dy, len - self.tol, violated);
            out[5] += i64::from(violation);
            out[6] += i64::from(crossing);
            if crossing {
                crossed.extend_from_slice(&violated[start..]);
            }
        }
        out
    }

    /// Walk the beam from `(ox, oy)` along `(dx, dy)` (grid units) through every cell it
    /// enters at a parameter `t < t_end`; push the occupied ones onto `violated`. Returns
    /// whether there was one (a violation), and whether a known free cell clear of every
    /// wall followed one (a crossing).
    #[inline]
    fn walk(
        &self,
        ox: f64,
        oy: f64,
        dx: f64,
        dy: f64,
        t_end: f64,
        violated: &mut Vec<u32>,
    ) -> (bool, bool) {
        if t_end.is_nan() || t_end <= 0.0 {
            return (false, false);
        }
        let (w, h) = (self.width as f64, self.height as f64);
        // where the beam is inside the grid's box [0, w] x [0, h] (slabs)
        let (mut t0, mut t1) = (0.0f64, t_end);
        for (o, d, size) in [(ox, dx, w), (oy, dy, h)] {
            if d == 0.0 {
                if !(0.0..size).contains(&o) {
                    return (false, false);
                }
            } else {
                let (ta, tb) = ((0.0 - o) / d, (size - o) / d);
                t0 = t0.max(ta.min(tb));
                t1 = t1.min(ta.max(tb));
            }
        }
        if t0.is_nan() || t1.is_nan() || t0 > t1 || t0 >= t_end {
            return (false, false);
        }
        let ix = ((ox + t0 * dx).floor()).clamp(0.0, w - 1.0);
        let iy = ((oy + t0 * dy).floor()).clamp(0.0, h - 1.0);
        let pw = (self.width + 2) as isize;
        let mut idx = (self.height as isize - iy as isize) * pw + ix as isize + 1;
        let (mut tx, tdx, sx) = first_boundary(ox, dx, ix);
        let (mut ty, tdy, sy) = first_boundary(oy, dy, iy);
        let sy = -sy * pw; // up one row is back one padded row
        let (mut any, mut crossed) = (false, false);
        loop {
            // idx stays inside the padded grid: it starts inside the grid, moves one cell
            // at a time, and the walk ends on the ring of OUTSIDE cells
            let v = self.cells[idx as usize];
            if v & (OUTSIDE | OCCUPIED) != 0 {
                if v & OUTSIDE != 0 {
                    return (any, crossed);
                }
                any = true;
                let (row, col) = (idx / pw - 1, idx % pw - 1);
                violated.push((row * self.width as isize + col) as u32);
            } else if v == 0 {
                // known, free and clear of every wall: after a wall, the beam crossed it
                crossed |= any;
            }
            // branch-free step to the nearer boundary (the row's on a tie)
            let step_x = tx < ty;
            let t = if step_x { tx } else { ty };
            if t >= t_end {
                return (any, crossed);
            }
            tx += if step_x { tdx } else { 0.0 };
            ty += if step_x { 0.0 } else { tdy };
            idx += if step_x { sx } else { sy };
        }
    }

    /// `(height, width)` in cells.
    pub fn shape(&self) -> (usize, usize) {
        (self.height, self.width)
    }
}

/// What [`consistency`] returns: the counts of every scan (`n x 7`, row-major, columns
/// [`COLUMNS`]), the number of beams that passed through each cell while it was occupied,
/// and of those, the beams that crossed a wall (both `height x width`, row 0 at the top).
#[derive(Clone, Debug, PartialEq)]
pub struct Consistency {
    pub counts: Vec<i64>,
    pub violations: Vec<u32>,
    pub crossings: Vec<u32>,
}

/// Check laser `poses` (flat `(x, y, yaw)` triples, finite), beam `angles` (finite),
/// `ranges` (`n x angles.len()`) and `0 <= min_range < max_range`; returns `(n, beams)`.
pub fn check_recording(
    poses: &[f64],
    angles: &[f64],
    ranges: &[f64],
    min_range: f64,
    max_range: f64,
) -> Result<(usize, usize), ScanError> {
    if !(min_range.is_finite() && min_range >= 0.0) {
        return Err(ScanError(format!(
            "min_range must be a finite number >= 0, got {min_range}"
        )));
    }
    if max_range.is_nan() || max_range <= min_range {
        return Err(ScanError(format!(
            "max_range must exceed min_range ({min_range}), got {max_range}"
        )));
    }
    if poses.len() % 3 != 0 {
        return Err(ScanError(format!(
            "poses must be (x, y, yaw) triples, got {} numbers",
            poses.len()
        )));
    }
    if let Some((i, p)) = poses
        .chunks_exact(3)
        .enumerate()
        .find(|(_, p)| !p.iter().all(|v| v.is_finite()))
    {
        return Err(ScanError(format!("pose {i} must be finite, got {p:?}")));
    }
    if let Some(a) = angles.iter().find(|a| !a.is_finite()) {
        return Err(ScanError(format!("angles must be finite, got {a}")));
    }
    let (n, b) = (poses.len() / 3, angles.len());
    if n.checked_mul(b) != Some(ranges.len()) {
        return Err(ScanError(format!(
            "ranges hold {} values for {n} scans of {b} beams",
            ranges.len()
        )));
    }
    Ok((n, b))
}

/// Score every scan: laser `poses` (`(x, y, yaw)` triples in the world frame, flat),
/// beams at `angles`, `ranges` (`n x angles.len()`, row-major, metres; a beam is valid when
/// finite and `min_range < r < max_range`), in parallel on the current rayon pool (the
/// same numbers for any number of threads).
pub fn consistency(
    grid: &ScanGrid,
    poses: &[f64],
    angles: &[f64],
    ranges: &[f64],
    min_range: f64,
    max_range: f64,
) -> Result<Consistency, ScanError> {
    let (n, b) = check_recording(poses, angles, ranges, min_range, max_range)?;
    let (h, w) = grid.shape();
    let mut counts = filled(n * COLUMNS.len(), 0i64)?;
    let mut violations = filled(h * w, 0u32)?;
    let mut crossings = filled(h * w, 0u32)?;
    let lists: Vec<(Vec<u32>, Vec<u32>)> = counts
        .par_chunks_mut(COLUMNS.len() * CHUNK)
        .zip(poses.par_chunks(3 * CHUNK))
        .enumerate()
        .map(|(k, (out, ps))| {
            let (mut violated, mut crossed) = (Vec::new(), Vec::new());
            for (i, (o, p)) in out
                .chunks_exact_mut(COLUMNS.len())
                .zip(ps.chunks_exact(3))
                .enumerate()
            {
                let row = (k * CHUNK + i) * b;
                let got = grid.scan(
                    [p[0], p[1], p[2]],
                    angles,
                    &ranges[row..row + b],
                    min_range,
                    max_range,
                    &mut violated,
                    &mut crossed,
                );
                o.copy_from_slice(&got);
            }
            (violated, crossed)
        })
        .collect();
    for (violated, crossed) in &lists {
        for (list, grid) in [(violated, &mut violations), (crossed, &mut crossings)] {
            for &i in list {
                let v = &mut grid[i as usize];
                *v = v.saturating_add(1);
            }
        }
    }
    Ok(Consistency {
        counts,
        violations,
        crossings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 10 x 10 map at 0.1 m, all known and free, with a wall in column 7 (x in
    /// [0.7, 0.8]).
    fn wall() -> ScanGrid {
        let mut v = vec![254u8; 100];
        for r in 0..10 {
            v[r * 10 + 7] = 0;
        }
        ScanGrid::new(&v, &[false; 100], 10, 10, 0.1, [0.0; 3], 0.5, 0.1).unwrap()
    }

    fn one(g: &ScanGrid, pose: [f64; 3], angle: f64, r: f64) -> ([i64; 7], Vec<u32>) {
        let (c, v, x) = both(g, pose, angle, r);
        // a crossing beam's cells are its violated cells, else it has none
        assert_eq!(x, if c[6] == 1 { v.clone() } else { vec![] });
        (c, v)
    }

    fn both(g: &ScanGrid, pose: [f64; 3], angle: f64, r: f64) -> ([i64; 7], Vec<u32>, Vec<u32>) {
        let (mut v, mut x) = (Vec::new(), Vec::new());
        let c = g.scan(pose, &[angle], &[r], 0.0, 20.0, &mut v, &mut x);
        (c, v, x)
    }

    #[test]
    fn hits_misses_and_violations() {
        let g = wall();
        // ends on the wall's face: a hit, no violation
        assert_eq!(
            one(&g, [0.25, 0.55, 0.0], 0.0, 0.46).0,
            [1, 1, 0, 0, 0, 0, 0]
        );
        // ends one cell short of it: still within the tolerance
        assert_eq!(
            one(&g, [0.25, 0.55, 0.0], 0.0, 0.37).0,
            [1, 1, 0, 0, 0, 0, 0]
        );
        // ends far short: a miss
        assert_eq!(
            one(&g, [0.25, 0.55, 0.0], 0.0, 0.2).0,
            [1, 0, 1, 0, 0, 0, 0]
        );
        // passes through the wall and ends beyond it: a violation in row 4, column 7, not
        // a crossing (column 8 is within the tolerance of the wall, column 9 is its end)
        let (c, v) = one(&g, [0.25, 0.55, 0.0], 0.0, 0.7);
        assert_eq!(c, [1, 0, 1, 0, 0, 1, 0]);
        assert_eq!(v, vec![4 * 10 + 7]);
        // off the grid, through the wall and out into column 9, clear of it: a crossing
        assert_eq!(
            one(&g, [0.25, 0.55, 0.0], 0.0, 5.0).0,
            [1, 0, 0, 0, 1, 1, 1]
        );
        // invalid beams count nowhere
        assert_eq!(one(&g, [0.25, 0.55, 0.0], 0.0, f64::INFINITY).0, [0; 7]);
        assert_eq!(one(&g, [0.25, 0.55, 0.0], 0.0, 20.0).0, [0; 7]);
        assert_eq!(one(&g, [0.25, 0.55, 0.0], 0.0, f64::NAN).0, [0; 7]);
    }

    #[test]
    fn a_graze_is_no_crossing() {
        // a 20 x 11 map at 0.1 m with a wall in row 1 (y in [0.9, 1.0]) and one cell
        // jutting out below it in row 2, column 10 (x in [1.0, 1.1], y in [0.8, 0.9])
        let (h, w) = (11, 20);
        let mut v = vec![254u8; h * w];
        for c in 0..w {
            v[w + c] = 0;
        }
        v[2 * w + 10] = 0;
        let g = ScanGrid::new(&v, &vec![false; h * w], h, w, 0.1, [0.0; 3], 0.5, 0.1).unwrap();
        // a beam rising at 0.05 clips the jutting cell, runs along the wall and ends by it
        let angle = 0.05f64.atan();
        let r = 1.85 / angle.cos();
        let (c, cells) = one(&g, [0.05, 0.801, 0.0], angle, r);
        assert_eq!(c, [1, 1, 0, 0, 0, 1, 0]);
        assert_eq!(cells, vec![2 * w as u32 + 10]);
        // the same beam lower down passes under the jutting cell: no violation
        assert_eq!(one(&g, [0.05, 0.70, 0.0], angle, r).0[5], 0);
        // a beam up through the wall into the free cells beyond the tolerance: a crossing
        let v2: Vec<u8> = (0..h * w)
            .map(|i| if i / w == 5 { 0 } else { 254 })
            .collect();
        let g2 = ScanGrid::new(&v2, &vec![false; h * w], h, w, 0.1, [0.0; 3], 0.5, 0.1).unwrap();
        let up = std::f64::consts::FRAC_PI_2;
        assert_eq!(
            one(&g2, [0.55, 0.15, 0.0], up, 0.9).0,
            [1, 0, 1, 0, 0, 1, 1]
        );
    }

    #[test]
    fn unknown_endpoints() {
        let v = vec![254u8; 100];
        let mut u = vec![false; 100];
        u[4 * 10 + 2] = true;
        let g = ScanGrid::new(&v, &u, 10, 10, 0.1, [0.0; 3], 0.5, 0.1).unwrap();
        assert_eq!(
            one(&g, [0.05, 0.55, 0.0], 0.0, 0.2).0,
            [1, 0, 0, 1, 0, 0, 0]
        );
    }

    #[test]
    fn bad_input_is_an_error() {
        let v = [254u8; 4];
        let u = [false; 4];
        assert!(ScanGrid::new(&v, &u, 2, 3, 0.1, [0.0; 3], 0.5, 0.1).is_err());
        assert!(ScanGrid::new(&v, &u[..3], 2, 2, 0.1, [0.0; 3], 0.5, 0.1).is_err());
        assert!(ScanGrid::new(&v, &u, 2, 2, 0.0, [0.0; 3], 0.5, 0.1).is_err());
        assert!(ScanGrid::new(&v, &u, 2, 2, 0.1, [f64::NAN; 3], 0.5, 0.1).is_err());
        assert!(ScanGrid::new(&v, &u, 2, 2, 0.1, [0.0; 3], 0.5, 0.0).is_err());
        assert!(ScanGrid::new(&v, &u, 2, 2, 0.1, [0.0; 3], 0.5, 1e9).is_err());
        let g = wall();
        assert!(consistency(&g, &[0.0; 2], &[0.0], &[1.0], 0.0, 5.0).is_err());
        assert!(consistency(&g, &[f64::NAN, 0.0, 0.0], &[0.0], &[1.0], 0.0, 5.0).is_err());
        assert!(consistency(&g, &[0.0; 3], &[f64::NAN], &[1.0], 0.0, 5.0).is_err());
        assert!(consistency(&g, &[0.0; 3], &[0.0], &[1.0, 2.0], 0.0, 5.0).is_err());
        assert!(consistency(&g, &[0.0; 3], &[0.0], &[1.0], 5.0, 5.0).is_err());
        assert!(consistency(&g, &[0.0; 3], &[0.0], &[1.0], -1.0, 5.0).is_err());
        assert!(consistency(&g, &[0.0; 3], &[0.0], &[1.0], 0.0, f64::INFINITY).is_ok());
    }

    #[test]
    fn thread_counts_agree() {
        let mut v = vec![254u8; 1600];
        for (i, x) in v.iter_mut().enumerate() {
            if i * 7919 % 17 == 0 {
                *x = 0;
            }
        }
        let g = ScanGrid::new(&v, &[false; 1600], 40, 40, 0.05, [0.0; 3], 0.5, 0.1).unwrap();
        let n = 50;
        let poses: Vec<f64> = (0..n)
            .flat_map(|i| [0.1 + 0.03 * i as f64, 1.9 - 0.02 * i as f64, 0.3 * i as f64])
            .collect();
        let angles: Vec<f64> = (0..91).map(|i| -1.5 + 3.0 * i as f64 / 90.0).collect();
        let ranges: Vec<f64> = (0..n * 91).map(|i| 0.05 + (i % 37) as f64 * 0.05).collect();
        let run = |t| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap()
                .install(|| consistency(&g, &poses, &angles, &ranges, 0.0, 20.0).unwrap())
        };
        let a = run(1);
        assert_eq!(a, run(3));
        assert!(a.violations.iter().any(|&v| v > 0));
        assert!(a.crossings.iter().any(|&v| v > 0));
        assert!(a.crossings.iter().zip(&a.violations).all(|(c, v)| c <= v));
        assert!(a.counts.chunks(7).any(|c| c[1] > 0));
        assert!(a.counts.chunks(7).all(|c| c[6] <= c[5]));
    }
}
