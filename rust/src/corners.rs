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

/// How far (in columns, each side) a set mask cell can make the Harris sums non-zero:
/// `A, B, C` at column `x` read mask columns `x-2 ..= x+1` (reflect-101 included).
const REACH: usize = 3;

/// Harris sums over the parts of one output row where they can be non-zero.
struct HarrisRow<'a> {
    mask: &'a [u8],
    runs: &'a RowRuns,
    height: usize,
    width: usize,
    spans: Vec<(usize, usize)>,
    // scratch, indexed from the start of the current span's gather window
    p: Vec<i16>,
    d: Vec<i16>,
    prod: [[Vec<i16>; 3]; 2],
}

impl<'a> HarrisRow<'a> {
    fn new(mask: &'a [u8], runs: &'a RowRuns, height: usize, width: usize) -> Self {
        HarrisRow {
            mask,
            runs,
            height,
            width,
            spans: Vec::new(),
            p: Default::default(),
            d: Default::default(),
            prod: Default::default(),
        }
    }

    /// Column intervals `[a, b)` of row `r` outside which `A = B = C = 0`: the set runs of
    /// mask rows `r-2 ..= r+1` (reflect-mapped), widened by [`REACH`] and merged.
    fn find_spans(&mut self, r: usize) {
        let (h, w) = (self.height, self.width);
        self.spans.clear();
        let mut rows = [0usize; 4];
        for (k, dr) in (-2isize..=1).enumerate() {
            rows[k] = reflect101(r as isize + dr, h);
        }
        rows.sort_unstable();
        let mut prev_row = usize::MAX;
        for &rr in &rows {
            if rr == prev_row {
                continue;
            }
            prev_row = rr;
            for run in self.runs.row(rr) {
                let a = (run.start as usize).saturating_sub(REACH);
                let b = (run.end as usize + REACH).min(w);
                self.spans.push((a, b));
            }
        }
        self.spans.sort_unstable();
        let mut merged: Vec<(usize, usize)> = Vec::with_capacity(self.spans.len());
        for &(a, b) in &self.spans {
            match merged.last_mut() {
                Some(last) if a <= last.1 => last.1 = last.1.max(b),
                _ => merged.push((a, b)),
            }
        }
        self.spans = merged;
    }

    /// Call `visit(x, A, B, C)` for every column of row `r` where the sums are not all zero.
    fn for_each(&mut self, r: usize, mut visit: impl FnMut(usize, i32, i32, i32)) {
        self.find_spans(r);
        let (h, w) = (self.height, self.width);
        let m_row = |k: usize| &self.mask[k * w..(k + 1) * w];
        // product rows: reflect(r-1) (box row above) and r
        let yys = [reflect101(r as isize - 1, h), r];
        let spans = std::mem::take(&mut self.spans);
        for &(a, b) in &spans {
            // product columns needed: reflect(x-1) and x for x in [a, b)
            let lo = a.saturating_sub(1);
            let hi = if a == 0 { b.max(2.min(w)) } else { b };
            for (slot, &yy) in yys.iter().enumerate() {
                let [xx, xy, yy2] = &mut self.prod[slot];
                sobel_products(
                    m_row(reflect101(yy as isize - 1, h)),
                    m_row(yy),
                    m_row(reflect101(yy as isize + 1, h)),
                    (lo, hi),
                    &mut self.p,
                    &mut self.d,
                    xx,
                    xy,
                    yy2,
                );
            }
            let [pxx, pxy, pyy] = &self.prod[0];
            let [cxx, cxy, cyy] = &self.prod[1];
            for x in a..b {
                let l = reflect101(x as isize - 1, w) - lo;
                let i = x - lo;
                let av = (pxx[l] + pxx[i] + cxx[l] + cxx[i]) as i32;
                let cv = (pyy[l] + pyy[i] + cyy[l] + cyy[i]) as i32;
                if av == 0 && cv == 0 {
                    continue; // then B = 0 too (B^2 <= A*C), and R = 0
                }
                let bv = (pxy[l] + pxy[i] + cxy[l] + cxy[i]) as i32;
                visit(x, av, bv, cv);
            }
        }
        self.spans = spans;
    }
}

/// One band's largest response and its cells with `R > 0`, as `(row, column, R)` in order.
type BandResponses = (f64, Vec<(usize, usize, f64)>);

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
            let mut rows = HarrisRow::new(mask, runs, h, w);
            let mut best = f64::NEG_INFINITY;
            let mut positive = Vec::new();
            for r in r0..r1 {
                rows.for_each(r, |x, a, b, c| {
                    let resp = response(a as i64, b as i64, c as i64, k);
                    if resp > best {
                        best = resp;
                    }
                    if resp > 0.0 {
                        positive.push((r, x, resp));
                    }
                });
            }
            (best, positive)
        })
        .collect();
    let best = found
        .iter()
        .map(|(b, _)| *b)
        .fold(f64::NEG_INFINITY, f64::max);
    let threshold = if best > 0.0 {
        params.harris_quality * best
    } else {
        f64::INFINITY
    };
    let parts = found
        .into_par_iter()
        .zip(bands(h))
        .map(|((_, positive), (r0, r1))| {
            let mut out: Vec<Run> = Vec::new();
            let mut starts = Vec::with_capacity(r1 - r0);
            let mut cells = positive
                .into_iter()
                .filter(|&(_, _, resp)| resp > threshold)
                .peekable();
            for r in r0..r1 {
                starts.push(out.len());
                let row_first = out.len();
                while let Some(&(_, x, _)) = cells.peek().filter(|c| c.0 == r) {
                    cells.next();
                    let n = out.len();
                    if n > row_first && out[n - 1].end as usize == x {
                        out[n - 1].end += 1; // the cell right of the row's last run
                    } else {
                        out.push(Run {
                            start: x as u32,
                            end: x as u32 + 1,
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
