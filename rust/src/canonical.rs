//! SPEC section 3a: the canonical corner count. The map's known bounding box is turned to
//! its dominant wall direction and resampled to a reference resolution, and the SPEC-3
//! corners of that canonical map are counted. The reference function is
//! `slamq.metrics.reference.canonical_corner_count`; every step below is integer
//! arithmetic or one float64 formula evaluated in the same order on both sides.

use crate::border::reflect101;
use crate::corners::count_corners;
use crate::evaluate::{reserve_working_set, OutOfMemory};
use crate::grid::Grid;
use crate::params::CornerParams;
use rayon::prelude::*;

/// Canonical maps larger than this are not built (`corners_canonical` is then `None`): a
/// very coarse map resampled to a fine reference resolution.
pub const MAX_CANONICAL_CELLS: usize = 1 << 30;

/// Rows `r0..r1` and columns `c0..c1` of a box: `(r0, r1, c0, c1)`.
pub type Bounds = (usize, usize, usize, usize);

/// The known cells' bounding box, or `None`.
pub fn known_bounds(grid: &Grid) -> Option<Bounds> {
    let w = grid.width;
    let known_row = |r: usize| grid.unknown[r * w..(r + 1) * w].iter().any(|&u| !u);
    let r0 = (0..grid.height).find(|&r| known_row(r))?;
    let r1 = (0..grid.height).rev().find(|&r| known_row(r))? + 1;
    let (mut c0, mut c1) = (w, 0);
    for r in r0..r1 {
        let row = &grid.unknown[r * w..(r + 1) * w];
        if let Some(first) = row.iter().position(|&u| !u) {
            c0 = c0.min(first);
            c1 = c1.max(w - row.iter().rev().position(|&u| !u).unwrap_or(0));
        }
    }
    Some((r0, r1, c0, c1))
}

/// A `Vec` of `n` copies of `x`, or `OutOfMemory`.
fn filled<T: Clone>(n: usize, x: T) -> Result<Vec<T>, OutOfMemory> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| OutOfMemory {
        bytes: n.saturating_mul(std::mem::size_of::<T>()),
    })?;
    v.resize(n, x);
    Ok(v)
}

/// The 9-tap binomial (two 5-tap binomial blurs in one), sum 256.
const B9: [i32; 9] = [1, 8, 28, 56, 70, 56, 28, 8, 1];

/// `D`: the 9x9 binomial sum of the box's known values (unknown cells count 0; reflect-101
/// at the box's edges) at every second row and column (rows and columns 0, 2, 4, ...),
/// `ceil(h/2) x ceil(w/2)`; exact in `i32` (at most 255 * 256^2). Each output row is one
/// vertical pass over nine input rows, straight from the map, then the decimated
/// horizontal taps: no full-size copy of the box.
fn blur9_decimated(
    grid: &Grid,
    (r0, r1, c0, c1): Bounds,
) -> Result<(Vec<i32>, usize, usize), OutOfMemory> {
    let (h, w) = (r1 - r0, c1 - c0);
    let (hd, wd) = (h.div_ceil(2), w.div_ceil(2));
    let mut out = filled(hd * wd, 0i32)?;
    out.par_chunks_mut(wd).enumerate().for_each_init(
        || vec![0i32; w],
        |vert, (rd, o)| {
            vert.fill(0);
            for (k, &b) in B9.iter().enumerate() {
                let rr = reflect101((2 * rd) as isize + k as isize - 4, h);
                let at = (r0 + rr) * grid.width + c0;
                let (v, u) = (&grid.values[at..at + w], &grid.unknown[at..at + w]);
                for ((acc, &v), &u) in vert.iter_mut().zip(v).zip(u) {
                    *acc += b * (i32::from(v) * i32::from(!u));
                }
            }
            for (xd, o) in o.iter_mut().enumerate() {
                let x = 2 * xd;
                *o = if x >= 4 && x + 4 < w {
                    (0..9).map(|k| B9[k] * vert[x + k - 4]).sum()
                } else {
                    (0..9)
                        .map(|k| B9[k] * vert[reflect101(x as isize + k as isize - 4, w)])
                        .sum()
                };
            }
        },
    );
    Ok((out, hd, wd))
}

/// `x` rounded half to even, for `|x| < 2^51` (the terms are below `|g| < 2^31`): adding
/// and subtracting 1.5 * 2^52 rounds in the FPU's default mode, which is half to even, the
/// same as `round_ties_even` and numpy's `rint`, without the libm call that baseline x86-64
/// makes of `round_ties_even`.
#[inline]
fn rint(x: f64) -> i64 {
    const MAGIC: f64 = 6_755_399_441_055_744.0;
    ((x + MAGIC) - MAGIC) as i64
}

/// The `g**4 / |g|**3` terms of one cell's Sobel gradient, rounded half to even (SPEC 3a.2).
#[inline]
fn angle_terms(gx: i64, gy: i64) -> (i64, i64) {
    let (x, y) = (gx as f64, gy as f64);
    let r2 = x * x + y * y;
    if r2 <= 0.0 {
        return (0, 0);
    }
    let a = x * x - y * y;
    let b = 2.0 * (x * y);
    let w = r2 * r2.sqrt();
    (rint((a * a - b * b) / w), rint((2.0 * (a * b)) / w))
}

/// The dominant wall direction modulo 90 degrees of the known bounding box, radians in
/// (-pi/4, pi/4] (image axes: +x right, +y down). 0 for a map without known cells or
/// gradient. SPEC 3a.2: the structure image's 9x9 binomial blur taken at every second row
/// and column (`D`), its 3x3 Sobel derivatives on that grid (reflect-101), and the sum of
/// `g**4 / |g|**3` per cell, rounded to integers.
pub fn wall_angle(grid: &Grid) -> Result<f64, OutOfMemory> {
    match known_bounds(grid) {
        Some(b) => angle_in(grid, b),
        None => Ok(0.0),
    }
}

/// [`wall_angle`] of the box `b` (the known cells' bounding box).
fn angle_in(grid: &Grid, (r0, r1, c0, c1): Bounds) -> Result<f64, OutOfMemory> {
    let (g2, h, w) = blur9_decimated(grid, (r0, r1, c0, c1))?;
    let (re, im) = (0..h)
        .into_par_iter()
        .map(|r| {
            let row = |k: isize| {
                let rr = reflect101(r as isize + k, h);
                &g2[rr * w..(rr + 1) * w]
            };
            let (up, mid, down) = (row(-1), row(0), row(1));
            let (mut sre, mut sim) = (0i64, 0i64);
            for x in 0..w {
                let (l, rt) = if x >= 1 && x + 1 < w {
                    (x - 1, x + 1)
                } else {
                    (reflect101(x as isize - 1, w), reflect101(x as isize + 1, w))
                };
                let col = |c: usize| up[c] as i64 + 2 * mid[c] as i64 + down[c] as i64;
                let gx = col(rt) - col(l);
                let gy = (down[l] as i64 + 2 * down[x] as i64 + down[rt] as i64)
                    - (up[l] as i64 + 2 * up[x] as i64 + up[rt] as i64);
                let (a, b) = angle_terms(gx, gy);
                sre += a;
                sim += b;
            }
            (sre, sim)
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    if re == 0 && im == 0 {
        return Ok(0.0);
    }
    Ok((im as f64).atan2(re as f64) / 4.0)
}

/// A canonical map: owned values and unknown mask.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CanonicalMap {
    pub values: Vec<u8>,
    pub unknown: Vec<bool>,
    pub height: usize,
    pub width: usize,
}

/// What the canonical step found: the wall angle, and the corner count of the canonical map
/// (`None` when it would exceed [`MAX_CANONICAL_CELLS`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Canonical {
    pub angle: f64,
    pub corners: Option<usize>,
}

/// The map turned by `-angle` about its known box's centre cell and sampled every
/// `reference / resolution` input cells (SPEC 3a.3); `None` if it would be too large.
pub fn canonical_map(
    grid: &Grid,
    angle: f64,
    resolution: Option<f64>,
    reference: f64,
) -> Result<Option<CanonicalMap>, OutOfMemory> {
    match known_bounds(grid) {
        Some(b) => map_in(grid, b, angle, resolution, reference),
        None => Ok(Some(CanonicalMap {
            values: grid.values.to_vec(),
            unknown: grid.unknown.to_vec(),
            height: grid.height,
            width: grid.width,
        })),
    }
}

/// [`canonical_map`] of the box `b` (the known cells' bounding box).
fn map_in(
    grid: &Grid,
    (r0, r1, c0, c1): Bounds,
    angle: f64,
    resolution: Option<f64>,
    reference: f64,
) -> Result<Option<CanonicalMap>, OutOfMemory> {
    let (h, w) = (r1 - r0, c1 - c0);
    let f = match resolution {
        Some(res) => reference / res,
        None => 1.0,
    };
    let (c, s) = (angle.cos(), angle.sin());
    let half = |a: f64, b: f64| ((a.abs() * w as f64 + b.abs() * h as f64) / (2.0 * f)).ceil();
    let (hw, hh) = (half(c, s), half(s, c));
    if !(hw.is_finite() && hh.is_finite()) || hw * hh > MAX_CANONICAL_CELLS as f64 {
        return Ok(None);
    }
    let big_w = 2 * (hw as usize + 2);
    let big_h = 2 * (hh as usize + 2);
    if big_w.saturating_mul(big_h) > MAX_CANONICAL_CELLS {
        return Ok(None);
    }
    let n = (f.ceil() as usize).max(2);
    let nf = n as f64;
    let (cx, cy) = ((w / 2) as f64, (h / 2) as f64);
    let (half_w, half_h) = ((big_w / 2) as f64, (big_h / 2) as f64);
    let mut values = filled(big_w * big_h, 0u8)?;
    let mut unknown = filled(big_w * big_h, true)?;
    // the sub-cell offsets, and per output column j and sub-column m the rotated x parts
    // c*qx and s*qx (the same float64 products as the reference's, computed once), laid out
    // m-major so that the address pass vectorises
    let offs: Vec<f64> = (0..n).map(|k| (k as f64 + 0.5) / nf).collect();
    let (wf, hf) = (w as f64, h as f64);
    let cols = big_w * n;
    let mut cqx = filled(cols, 0.0f64)?;
    let mut sqx = filled(cols, 0.0f64)?;
    for (m, o) in offs.iter().enumerate() {
        for j in 0..big_w {
            let q = ((j as f64 - half_w) + o) * f;
            cqx[m * big_w + j] = c * q;
            sqx[m * big_w + j] = s * q;
        }
    }
    let (w1, h1) = (wf - 1.0, hf - 1.0);
    let (stride, base) = (grid.width, r0 * grid.width + c0);
    let need = (n * n) as u32;
    // which BLOCK x BLOCK blocks of the box hold a known cell: an output tile whose samples
    // all fall in blocks without one is unknown, and is skipped (most of a turned, partly
    // explored map's canonical grid)
    const BLOCK: usize = 8;
    let (bh, bw) = (h.div_ceil(BLOCK), w.div_ceil(BLOCK));
    let mut known_block = filled(bh * bw, false)?;
    known_block
        .par_chunks_mut(bw)
        .enumerate()
        .for_each(|(br, out)| {
            for r in br * BLOCK..((br + 1) * BLOCK).min(h) {
                let row = &grid.unknown[base + r * stride..base + r * stride + w];
                for (o, cells) in out.iter_mut().zip(row.chunks(BLOCK)) {
                    *o |= cells.iter().any(|&u| !u);
                }
            }
        });
    // the box cell (row, column) under sample (k, m) of output cell (i, j): the address
    // pass below computes the same, many at a time
    let cell_of = |i: usize, k: usize, j: usize, m: usize| {
        let q = (i as f64 - half_h + offs[k]) * f;
        let px = (cqx[m * big_w + j] - s * q) + cx;
        let py = (sqx[m * big_w + j] + c * q) + cy;
        (
            py.max(0.0).min(h1) as i64 as usize,
            px.max(0.0).min(w1) as i64 as usize,
        )
    };
    // a tile (output rows i0..i1, columns j0..j1) of which every sample is unknown: its
    // samples lie in the bounding box of its four corner samples (the map is affine), taken
    // one cell wider against rounding
    let all_unknown = |i0: usize, i1: usize, j0: usize, j1: usize| {
        let corners = [
            cell_of(i0, 0, j0, 0),
            cell_of(i0, 0, j1 - 1, n - 1),
            cell_of(i1 - 1, n - 1, j0, 0),
            cell_of(i1 - 1, n - 1, j1 - 1, n - 1),
        ];
        // the rows (columns) the corner samples span, one wider on each side, in 0..=last
        let span = |at: [usize; 4], last: usize| {
            let lo = at.iter().copied().min().unwrap_or(0).saturating_sub(1);
            let hi = at.iter().copied().max().unwrap_or(last);
            (lo, hi.saturating_add(1).min(last))
        };
        let (y0, y1) = span(corners.map(|c| c.0), h - 1);
        let (x0, x1) = span(corners.map(|c| c.1), w - 1);
        (y0 / BLOCK..=y1 / BLOCK).all(|br| {
            known_block[br * bw + x0 / BLOCK..=br * bw + x1 / BLOCK]
                .iter()
                .all(|&k| !k)
        })
    };
    // output tiles of TILE x TILE cells: the input cells one tile samples lie in a small
    // turned square, so the gathers stay in cache (row by row over a wide turned map, every
    // sample was a cache miss)
    const TILE: usize = 64;
    values
        .par_chunks_mut(big_w * TILE)
        .zip(unknown.par_chunks_mut(big_w * TILE))
        .enumerate()
        .for_each(|(t, (vblock, ublock))| {
            let rows = vblock.len() / big_w;
            // per output cell of a tile row: the sum and the number of its known samples
            let mut total = [0u32; TILE];
            let mut count = [0u32; TILE];
            let mut at = [0usize; TILE];
            for j0 in (0..big_w).step_by(TILE) {
                let j1 = (j0 + TILE).min(big_w);
                let cells = j1 - j0;
                if all_unknown(t * TILE, t * TILE + rows, j0, j1) {
                    continue; // left unknown, as allocated
                }
                for r in 0..rows {
                    let ii = (t * TILE + r) as f64 - half_h;
                    total[..cells].fill(0);
                    count[..cells].fill(0);
                    for o in &offs {
                        let q = (ii + o) * f;
                        let (sqy, cqy) = (s * q, c * q);
                        for m in 0..n {
                            let cx_row = &cqx[m * big_w + j0..m * big_w + j1];
                            let sx_row = &sqx[m * big_w + j0..m * big_w + j1];
                            // addresses: the box cell under each sample (floor, clamped to
                            // the box: samples beyond its edge take the edge cell, so a
                            // fully known map gets no artificial frontier); for px >= 0,
                            // truncation is floor
                            for ((a, &cq), &sq) in at[..cells].iter_mut().zip(cx_row).zip(sx_row) {
                                let px = (cq - sqy) + cx;
                                let py = (sq + cqy) + cy;
                                // clamped to 0..w-1 first: the i64 cast is one
                                // instruction, where a usize cast is several
                                let xi = px.max(0.0).min(w1) as i64 as usize;
                                let yi = py.max(0.0).min(h1) as i64 as usize;
                                *a = base + yi * stride + xi;
                            }
                            // branch-free: known and unknown cells alternate unpredictably
                            for ((t, k), &a) in total[..cells]
                                .iter_mut()
                                .zip(&mut count[..cells])
                                .zip(&at[..cells])
                            {
                                let known = u32::from(!grid.unknown[a]);
                                *t += u32::from(grid.values[a]) * known;
                                *k += known;
                            }
                        }
                    }
                    let row = r * big_w + j0;
                    for x in 0..cells {
                        let (t, k) = (u64::from(total[x]), u64::from(count[x]));
                        if 2 * k >= u64::from(need) {
                            // the mean of the known samples, rounded half up
                            vblock[row + x] = ((2 * t + k) / (2 * k)) as u8;
                            ublock[row + x] = false;
                        }
                    }
                }
            }
        });
    Ok(Some(CanonicalMap {
        values,
        unknown,
        height: big_h,
        width: big_w,
    }))
}

/// SPEC 3a: the wall angle and `corners_canonical` of a map of `resolution` metres per cell
/// (`None`: unknown, taken as the reference resolution).
pub fn canonical_corners(
    grid: &Grid,
    resolution: Option<f64>,
    params: &CornerParams,
) -> Result<Canonical, OutOfMemory> {
    canonical_corners_in(grid, known_bounds(grid), resolution, params)
}

/// [`canonical_corners`] with the known cells' bounding box already found
/// ([`known_bounds`]).
pub fn canonical_corners_in(
    grid: &Grid,
    bounds: Option<Bounds>,
    resolution: Option<f64>,
    params: &CornerParams,
) -> Result<Canonical, OutOfMemory> {
    // both steps work inside the box
    let Some(b) = bounds else {
        return Ok(Canonical {
            angle: 0.0,
            corners: Some(0),
        });
    };
    let angle = angle_in(grid, b)?;
    let Some(map) = map_in(grid, b, angle, resolution, params.canonical_resolution)? else {
        return Ok(Canonical {
            angle,
            corners: None,
        });
    };
    reserve_working_set(map.height * map.width)?;
    let g = Grid {
        values: &map.values,
        unknown: &map.unknown,
        height: map.height,
        width: map.width,
    };
    Ok(Canonical {
        angle,
        corners: Some(count_corners(&g, params)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn room(n: usize) -> (Vec<u8>, Vec<bool>) {
        let mut v = vec![254u8; n * n];
        for i in 5..n - 5 {
            for &(r, c) in &[(5, i), (n - 6, i), (i, 5), (i, n - 6)] {
                v[r * n + c] = 0;
            }
        }
        (v, vec![false; n * n])
    }

    #[test]
    fn axis_aligned_walls_have_angle_zero_and_keep_their_corners() {
        let (v, u) = room(40);
        let g = Grid::new(&v, &u, 40, 40).unwrap();
        let a = wall_angle(&g).unwrap();
        assert!(a.abs() < 1e-3, "{a}");
        let p = CornerParams::default();
        let c = canonical_corners(&g, Some(0.05), &p).unwrap();
        assert_eq!(c.corners, Some(count_corners(&g, &p)));
    }

    #[test]
    fn no_known_cell_gives_angle_zero() {
        let v = vec![0u8; 12];
        let u = vec![true; 12];
        let g = Grid::new(&v, &u, 3, 4).unwrap();
        assert_eq!(known_bounds(&g), None);
        assert_eq!(wall_angle(&g).unwrap(), 0.0);
        let c = canonical_corners(&g, Some(0.05), &CornerParams::default()).unwrap();
        assert_eq!(c.corners, Some(0));
    }

    #[test]
    fn a_huge_canonical_map_is_skipped_not_allocated() {
        let (v, u) = room(40);
        let g = Grid::new(&v, &u, 40, 40).unwrap();
        let p = CornerParams {
            canonical_resolution: 1e-6,
            ..CornerParams::default()
        };
        let c = canonical_corners(&g, Some(1.0), &p).unwrap();
        assert_eq!(c.corners, None);
    }

    #[test]
    fn rint_rounds_half_to_even_like_round_ties_even() {
        for x in [
            0.5,
            1.5,
            2.5,
            -0.5,
            -1.5,
            -2.5,
            0.49999999999999994,
            1e9 + 0.5,
            -7.25,
            123.75,
        ] {
            assert_eq!(rint(x), x.round_ties_even() as i64, "{x}");
        }
        let mut x = -1e6;
        while x < 1e6 {
            assert_eq!(rint(x), x.round_ties_even() as i64, "{x}");
            x += 0.123_456_7;
        }
    }

    #[test]
    fn bounds_are_the_known_box() {
        let mut u = vec![true; 5 * 6];
        for r in 1..3 {
            for c in 2..5 {
                u[r * 6 + c] = false;
            }
        }
        let v = vec![0u8; 30];
        let g = Grid::new(&v, &u, 5, 6).unwrap();
        assert_eq!(known_bounds(&g), Some((1, 3, 2, 5)));
    }
}
#[cfg(test)]
mod timing {
    use super::*;
    #[test]
    #[ignore]
    fn time_steps() {
        // CANON_RAW=MAP.raw:H:W (values then the 0/1 unknown mask, as examples/stages.rs
        // reads them) times a real map; else a 1000 x 1000 grid of walls
        let (v, u, h, w) = match std::env::var("CANON_RAW") {
            Ok(spec) => {
                let parts: Vec<&str> = spec.split(':').collect();
                let (h, w): (usize, usize) = (parts[1].parse().unwrap(), parts[2].parse().unwrap());
                let bytes = std::fs::read(parts[0]).unwrap();
                let u: Vec<bool> = bytes[h * w..].iter().map(|&b| b != 0).collect();
                (bytes[..h * w].to_vec(), u, h, w)
            }
            Err(_) => {
                let n = 1000;
                let mut v = vec![254u8; n * n];
                for i in 0..n * n {
                    if (i / n) % 37 == 0 || (i % n) % 53 == 0 {
                        v[i] = 0;
                    }
                }
                (v, vec![false; n * n], n, n)
            }
        };
        let g = Grid::new(&v, &u, h, w).unwrap();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        pool.install(|| {
            let mut best = [f64::MAX; 3];
            let reps: usize = std::env::var("REPS")
                .ok()
                .and_then(|r| r.parse().ok())
                .unwrap_or(25);
            for _ in 0..reps {
                let t = std::time::Instant::now();
                let a = wall_angle(&g).unwrap();
                let t1 = t.elapsed().as_secs_f64();
                let m = canonical_map(&g, a, Some(0.05), 0.07).unwrap().unwrap();
                let t2 = t.elapsed().as_secs_f64();
                let g2 = Grid::new(&m.values, &m.unknown, m.height, m.width).unwrap();
                let _ = count_corners(&g2, &CornerParams::default());
                let t3 = t.elapsed().as_secs_f64();
                for (b, x) in best.iter_mut().zip([t1, t2 - t1, t3 - t2]) {
                    *b = b.min(x);
                }
            }
            eprintln!(
                "min ms: angle {:.2} resample {:.2} corners {:.2}",
                best[0] * 1e3,
                best[1] * 1e3,
                best[2] * 1e3
            );
        });
    }
}
