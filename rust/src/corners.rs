//! Corner count (SPEC section 3, paper III.B): LoG structure mask, small dots dropped,
//! Harris response on the mask, relative threshold, 8-connected corner blobs counted.
//!
//! Everything up to the Harris response is exact integer arithmetic; the response is one
//! float64 formula, `R = (A*C - B*B) - k*(A + C)^2`, evaluated as `slamq.reference` does.
//! Work is done in fixed row bands in parallel; the one full-size intermediate is the 0/1
//! structure mask (one byte per cell). Dot removal hands the mask's surviving runs on; the
//! Harris sums (with their 2x2 box sum, fused here) are computed once, only on column spans
//! next to set structure cells, keeping the cells with `R > 0` and their response, so the
//! relative threshold needs no second pass; the corner blobs are counted from runs.

use crate::border::reflect101;
use crate::filter::{blur_row, laplacian_mask_row, sobel_products, structure_row};
use crate::grid::{bands, Grid, BAND_ROWS};
use crate::label::{Components, MaskRows, RowRuns, Run};
use crate::params::CornerParams;
use rayon::prelude::*;

/// The integer threshold equivalent to `L as f64 > threshold` for integer `L`.
fn integer_threshold(threshold: f64) -> Option<i32> {
    if threshold.is_nan() {
        None
    } else {
        // |L| <= 4 * 65280, so clamping keeps every comparison and lets L stay in i32
        Some(threshold.floor().clamp(-(1 << 20) as f64, (1 << 20) as f64) as i32)
    }
}

/// Steps 1-4: the LoG structure mask (0/1 per cell).
pub fn structure_mask(grid: &Grid, log_threshold: f64) -> Vec<u8> {
    let (h, w) = (grid.height, grid.width);
    let mut mask = vec![0u8; h * w];
    let Some(t) = integer_threshold(log_threshold * 255.0 * 256.0) else {
        return mask;
    };
    mask.par_chunks_mut(BAND_ROWS * w)
        .zip(bands(h))
        .for_each(|(out, (r0, r1))| {
            // S rows needed: r0-3 ..= r1+2, reflect-mapped; those all fall in [base, end)
            let base = (r0 as isize - 3).max(0) as usize;
            let end = (r1 + 3).min(h);
            let s_rows: Vec<Vec<u16>> = (base..end)
                .map(|rr| {
                    let mut row = vec![0u16; w];
                    structure_row(grid.value_row(rr), grid.unknown_row(rr), &mut row);
                    row
                })
                .collect();
            let s_of = |k: usize| -> &[u16] { &s_rows[k - base] };
            let s_any: Vec<bool> = s_rows
                .iter()
                .map(|row| row.iter().any(|&x| x != 0))
                .collect();
            let mut vbuf = vec![0u16; w];
            // G rows r0-1 ..= r1 (reflect-mapped); a row whose five S rows are all zero is zero
            let mut g_rows: Vec<Vec<u16>> = Vec::with_capacity(r1 - r0 + 2);
            let mut g_any: Vec<bool> = Vec::with_capacity(r1 - r0 + 2);
            for k in r0 as isize - 1..r1 as isize + 1 {
                let gr = reflect101(k, h);
                let nonzero = (-2..=2).any(|j| s_any[reflect101(gr as isize + j, h) - base]);
                let mut g = vec![0u16; w];
                if nonzero {
                    blur_row(&s_of, gr, h, &mut vbuf, &mut g);
                }
                g_rows.push(g);
                g_any.push(nonzero);
            }
            for r in r0..r1 {
                let i = r - r0 + 1;
                let row_out = &mut out[(r - r0) * w..(r - r0 + 1) * w];
                if !(g_any[i - 1] || g_any[i] || g_any[i + 1]) {
                    row_out.fill((0 > t) as u8); // L = 0 everywhere on this row
                    continue;
                }
                laplacian_mask_row(&g_rows[i - 1], &g_rows[i], &g_rows[i + 1], t, row_out);
            }
        });
    mask
}

/// Step 5: remove 8-connected mask components with fewer than `min_dot_area` cells; returns
/// the runs of what remains (the corner step reads them instead of scanning the mask again).
pub fn drop_dots(mask: &mut [u8], height: usize, width: usize, min_dot_area: u32) -> RowRuns {
    let rows = MaskRows { mask, width };
    if min_dot_area <= 1 {
        return RowRuns::of(&rows, height, width);
    }
    let comps = Components::label(&rows, height, width);
    comps.clear_small(mask, min_dot_area);
    comps.runs_of_large(min_dot_area)
}

/// The Harris response of one cell's sums, exactly `(A*C - B*B) - k*(A+C)^2` in float64.
#[inline]
pub fn response(a: i64, b: i64, c: i64, k: f64) -> f64 {
    let s = a + c;
    ((a * c - b * b) as f64) - k * ((s * s) as f64)
}

/// Horizontal pair sums of one mask row's Sobel products: `h[x] = P[reflect(x-1)] + P[x]` for
/// `P` in `Ix^2`, `Ix Iy`, `Iy^2`, so that the 2x2 box sum of output row `r` is the pair row
/// of `reflect(r-1)` plus the pair row of `r`. Full-width buffers, zero outside `[lo, hi)`.
#[derive(Default)]
struct PairRow {
    xx: Vec<i16>,
    xy: Vec<i16>,
    yy: Vec<i16>,
    lo: usize,
    hi: usize,
}

/// Scratch of one band's Harris pass.
#[derive(Default)]
struct Scratch {
    p: Vec<i16>,
    d: Vec<i16>,
    xx: Vec<i16>,
    xy: Vec<i16>,
    yy: Vec<i16>,
}

impl PairRow {
    fn new(width: usize) -> Self {
        PairRow {
            xx: vec![0; width],
            xy: vec![0; width],
            yy: vec![0; width],
            lo: 0,
            hi: 0,
        }
    }

    /// Compute the pair row of mask row `y`: products only where mask rows `y-1 ..= y+1`
    /// (reflect-mapped) have set cells within one column, from the bounding interval of
    /// their runs (no per-run spans, no sorting).
    fn compute(
        &mut self,
        mask: &[u8],
        runs: &RowRuns,
        (h, w): (usize, usize),
        y: usize,
        s: &mut Scratch,
    ) {
        // clear what the previous row left
        let (olo, ohi) = (self.lo, self.hi);
        self.xx[olo..ohi].fill(0);
        self.xy[olo..ohi].fill(0);
        self.yy[olo..ohi].fill(0);
        self.lo = 0;
        self.hi = 0;
        let rows = [
            reflect101(y as isize - 1, h),
            y,
            reflect101(y as isize + 1, h),
        ];
        let (mut first, mut last) = (usize::MAX, 0usize);
        for &k in &rows {
            let rr = runs.row(k);
            if let (Some(a), Some(b)) = (rr.first(), rr.last()) {
                first = first.min(a.start as usize);
                last = last.max(b.end as usize);
            }
        }
        if first == usize::MAX {
            return;
        }
        // products can be non-zero on [first - 1, last + 1); the pair sums one column further
        // right, and at column 0 (which reads column 1)
        let plo = first.saturating_sub(1);
        let phi = (last + 1).min(w);
        let hlo = if plo <= 1 { 0 } else { plo };
        let hhi = (phi + 1).min(w);
        // products on columns [pl, ph): every column the pair sums of [hlo, hhi) read
        let pl = hlo.saturating_sub(1);
        let ph = if hlo == 0 { hhi.max(2.min(w)) } else { hhi };
        let m_row = |k: usize| &mask[k * w..(k + 1) * w];
        sobel_products(
            m_row(rows[0]),
            m_row(rows[1]),
            m_row(rows[2]),
            (pl, ph),
            &mut s.p,
            &mut s.d,
            &mut s.xx,
            &mut s.xy,
            &mut s.yy,
        );
        for (out, prod) in [
            (&mut self.xx, &s.xx),
            (&mut self.xy, &s.xy),
            (&mut self.yy, &s.yy),
        ] {
            // column x >= 1: P[x - 1] + P[x] (product index q is column pl + q)
            let from = hlo.max(1);
            if from < hhi {
                let dst = &mut out[from..hhi];
                let src = &prod[from - 1 - pl..hhi - pl];
                for (o, pair) in dst.iter_mut().zip(src.windows(2)) {
                    *o = pair[0] + pair[1];
                }
            }
            if hlo == 0 {
                out[0] = prod[reflect101(-1, w) - pl] + prod[0];
            }
        }
        self.lo = hlo;
        self.hi = hhi;
    }
}

/// One band's largest response, its cells with `R > 0` as `(column, R)` in row-major order,
/// and where each of its rows starts in that list (one more entry than rows).
type BandResponses = (f64, Vec<(u32, f64)>, Vec<usize>);

/// Steps 6-7: the corner mask of a dot-free structure mask (given with its runs), as runs.
///
/// The sums are visited only next to set mask cells: elsewhere `A = B = C = 0`, so `R = 0`.
/// Only a cell with `R > 0` can pass `R > harris_quality * max R` (the threshold is never
/// negative, and a map whose largest response is `<= 0` has no corner), so those cells are
/// kept, with their response, in the one pass that also finds the maximum.
pub fn corner_runs(
    mask: &[u8],
    runs: &RowRuns,
    height: usize,
    width: usize,
    params: &CornerParams,
) -> RowRuns {
    let (h, w) = (height, width);
    let k = params.harris_k;
    // per band, in row-major order: the cells with R > 0 as (row, column, R)
    let found: Vec<BandResponses> = bands(h)
        .into_par_iter()
        .map(|(r0, r1)| {
            let mut prev = PairRow::new(w);
            let mut cur = PairRow::new(w);
            let mut scratch = Scratch::default();
            let (mut sa, mut sc): (Vec<i16>, Vec<i16>) = (Vec::new(), Vec::new());
            prev.compute(
                mask,
                runs,
                (h, w),
                reflect101(r0 as isize - 1, h),
                &mut scratch,
            );
            let mut best = f64::NEG_INFINITY;
            let mut positive: Vec<(u32, f64)> = Vec::new();
            let mut starts = Vec::with_capacity(r1 - r0 + 1);
            for r in r0..r1 {
                cur.compute(mask, runs, (h, w), r, &mut scratch);
                // the union of the two rows' non-zero intervals (an empty one counts for nothing)
                let (lo, hi) = if prev.lo >= prev.hi {
                    (cur.lo, cur.hi)
                } else if cur.lo >= cur.hi {
                    (prev.lo, prev.hi)
                } else {
                    (prev.lo.min(cur.lo), prev.hi.max(cur.hi))
                };
                // A and C over the interval in one vectorised pass; blocks of 8 cells where
                // both are zero (then B = 0 too, as B^2 <= A*C, and R = 0) are skipped whole
                let n = hi - lo;
                sa.resize(n, 0);
                sc.resize(n, 0);
                for ((o, &p), &c) in sa.iter_mut().zip(&prev.xx[lo..hi]).zip(&cur.xx[lo..hi]) {
                    *o = p + c;
                }
                for ((q, &p), &c) in sc.iter_mut().zip(&prev.yy[lo..hi]).zip(&cur.yy[lo..hi]) {
                    *q = p + c;
                }
                starts.push(positive.len());
                for (blk, (a8, c8)) in sa.chunks(8).zip(sc.chunks(8)).enumerate() {
                    if a8.iter().zip(c8).fold(0i16, |acc, (&a, &c)| acc | a | c) == 0 {
                        continue;
                    }
                    // branch-free within a block: a cell with A = C = 0 has B = 0 and R = 0,
                    // which changes neither a positive maximum nor the cells with R > 0
                    let x0 = lo + blk * 8;
                    let mut len = positive.len();
                    positive.resize(len + a8.len(), (0, 0.0));
                    for (j, (&av, &cv)) in a8.iter().zip(c8).enumerate() {
                        let x = x0 + j;
                        let bv = prev.xy[x] as i64 + cur.xy[x] as i64;
                        let resp = response(av as i64, bv, cv as i64, k);
                        if resp > best {
                            best = resp;
                        }
                        positive[len] = (x as u32, resp);
                        len += (resp > 0.0) as usize;
                    }
                    positive.truncate(len);
                }
                std::mem::swap(&mut prev, &mut cur);
            }
            starts.push(positive.len());
            (best, positive, starts)
        })
        .collect();
    let best = found
        .iter()
        .map(|(b, _, _)| *b)
        .fold(f64::NEG_INFINITY, f64::max);
    let threshold = if best > 0.0 {
        params.harris_quality * best
    } else {
        f64::INFINITY
    };
    let parts = found
        .into_par_iter()
        .zip(bands(h))
        .map(|((_, positive, pos_start), (r0, r1))| {
            let mut out: Vec<Run> = Vec::new();
            let mut starts = Vec::with_capacity(r1 - r0);
            for i in 0..r1 - r0 {
                starts.push(out.len());
                let row_first = out.len();
                for &(x, resp) in &positive[pos_start[i]..pos_start[i + 1]] {
                    if resp <= threshold || resp.is_nan() {
                        continue;
                    }
                    let n = out.len();
                    if n > row_first && out[n - 1].end == x {
                        out[n - 1].end += 1; // the cell right of the row's last run
                    } else {
                        out.push(Run {
                            start: x,
                            end: x + 1,
                        });
                    }
                }
            }
            (out, starts)
        })
        .collect();
    RowRuns::concat(parts)
}

/// Steps 1-8: the number of corners of a map.
pub fn count_corners(grid: &Grid, params: &CornerParams) -> usize {
    let (h, w) = (grid.height, grid.width);
    let mut mask = structure_mask(grid, params.log_threshold);
    let runs = drop_dots(&mut mask, h, w, params.min_dot_area);
    let corners = corner_runs(&mask, &runs, h, w, params);
    drop((mask, runs));
    Components::from_runs(corners.runs, corners.row_start, h, w).count()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square_map(n: usize, lo: usize, hi: usize) -> (Vec<u8>, Vec<bool>) {
        let mut v = vec![254u8; n * n];
        for r in lo..hi {
            for c in lo..hi {
                v[r * n + c] = 0;
            }
        }
        (v, vec![false; n * n])
    }

    #[test]
    fn filled_square_gives_outer_and_inner_ring_corners() {
        // the LoG mask of a filled dark square is a thick ring along its edge; Harris fires
        // at the ring's four outer and four inner corners
        let (v, u) = square_map(40, 12, 28);
        let g = Grid::new(&v, &u, 40, 40).unwrap();
        assert_eq!(count_corners(&g, &CornerParams::default()), 8);
    }

    /// Steps 6-7 literally, cell by cell with reflect-101 everywhere: the corner mask.
    fn naive_corner_mask(mask: &[u8], h: usize, w: usize, p: &CornerParams) -> Vec<u8> {
        let m = |r: isize, c: isize| mask[reflect101(r, h) * w + reflect101(c, w)] as i64;
        let prod = |r: isize, c: isize| {
            let ix = (m(r - 1, c + 1) + 2 * m(r, c + 1) + m(r + 1, c + 1))
                - (m(r - 1, c - 1) + 2 * m(r, c - 1) + m(r + 1, c - 1));
            let iy = (m(r + 1, c - 1) + 2 * m(r + 1, c) + m(r + 1, c + 1))
                - (m(r - 1, c - 1) + 2 * m(r - 1, c) + m(r - 1, c + 1));
            (ix * ix, ix * iy, iy * iy)
        };
        let mut resp = vec![0.0f64; h * w];
        for r in 0..h {
            for c in 0..w {
                let (mut a, mut b, mut cc) = (0, 0, 0);
                for rr in [reflect101(r as isize - 1, h), r] {
                    for c2 in [reflect101(c as isize - 1, w), c] {
                        let (x, y, z) = prod(rr as isize, c2 as isize);
                        a += x;
                        b += y;
                        cc += z;
                    }
                }
                resp[r * w + c] = response(a, b, cc, p.harris_k);
            }
        }
        let best = resp.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        resp.iter()
            .map(|&x| (best > 0.0 && x > p.harris_quality * best) as u8)
            .collect()
    }

    #[test]
    fn corner_runs_equal_the_literal_harris_on_random_masks() {
        let mut s = 12345u64;
        let mut next = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1);
            (s >> 33) as usize
        };
        let p = CornerParams::default();
        for trial in 0..300 {
            let h = 1 + next() % 23;
            let w = 1 + next() % 23;
            let density = next() % 100;
            let mut mask: Vec<u8> = (0..h * w).map(|_| (next() % 100 < density) as u8).collect();
            if trial % 3 == 0 {
                // empty rows and columns, so that the intervals matter
                for r in 0..h {
                    if next() % 3 == 0 {
                        mask[r * w..(r + 1) * w].fill(0);
                    }
                }
            }
            let runs = RowRuns::of(
                &MaskRows {
                    mask: &mask,
                    width: w,
                },
                h,
                w,
            );
            let got = corner_runs(&mask, &runs, h, w, &p);
            let mut cm = vec![0u8; h * w];
            for r in 0..h {
                for run in got.row(r) {
                    cm[r * w + run.start as usize..r * w + run.end as usize].fill(1);
                }
            }
            assert_eq!(
                cm,
                naive_corner_mask(&mask, h, w, &p),
                "trial {trial}: {h}x{w}"
            );
        }
    }

    #[test]
    fn empty_map_has_none() {
        let v = vec![254u8; 30 * 20];
        let u = vec![false; 30 * 20];
        let g = Grid::new(&v, &u, 30, 20).unwrap();
        assert_eq!(count_corners(&g, &CornerParams::default()), 0);
    }

    #[test]
    fn tiny_maps_do_not_panic() {
        for (h, w) in [(1, 1), (1, 7), (7, 1), (2, 2), (3, 3)] {
            let v: Vec<u8> = (0..h * w)
                .map(|i| if i % 2 == 0 { 0 } else { 254 })
                .collect();
            let u = vec![false; h * w];
            let g = Grid::new(&v, &u, h, w).unwrap();
            let _ = count_corners(&g, &CornerParams::default());
        }
    }
}
