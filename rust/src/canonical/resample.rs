//! SPEC 3a.3: the packed box turned by the wall angle and sampled at the reference
//! resolution, each output cell the half-up mean of its known samples; a fast path for
//! up to 4 x 4 samples per output cell beside the general one.

#[cfg(target_arch = "x86_64")]
use super::pack::has_avx2;
use super::pack::{filled, KNOWN, VALUE};
use crate::grid::{Bounds, Grid};
use crate::memory::OutOfMemory;
use rayon::prelude::*;

/// Canonical maps larger than this are not built (`corners_canonical` is then `None`): a
/// very coarse map resampled to a fine reference resolution.
pub const MAX_CANONICAL_CELLS: usize = 1 << 30;

/// 2^52: a float in `0..2^52` plus this has its integer part as the low bits of its
/// mantissa, rounded to nearest.
const TWO52: f64 = 4_503_599_627_370_496.0;

/// `floor(clamp(p, 0, last))` for `last < 2^52` (NaN gives 0), in float operations only:
/// with `ROUND` by `floor` (one instruction where SSE4.1 is enabled, a library call on
/// baseline x86-64), else the clamped value rounded to an integer (to nearest), less one
/// where that rounded up. Both are exact: the same result.
#[inline(always)]
pub(super) fn floor_in<const ROUND: bool>(p: f64, last: f64) -> f64 {
    let p = if p > 0.0 { p } else { 0.0 };
    let p = if p < last { p } else { last };
    if ROUND {
        return p.floor();
    }
    let r = (p + TWO52) - TWO52;
    r - if r > p { 1.0 } else { 0.0 }
}

/// The integer value of an integer-valued float in `0..2^52`, from its bits.
#[inline]
pub(super) fn float_bits_index(x: f64) -> u64 {
    (x + TWO52).to_bits() - TWO52.to_bits()
}

/// `ceil(2^18 / 2k)` for `k` in `0..=16` (0 for `k = 0`): [`half_up_mean`]'s divisions.
const HALF_UP_RECIPROCALS: [u32; 17] = {
    let mut m = [0u32; 17];
    let mut k = 1;
    while k <= 16 {
        m[k] = (1u32 << 18).div_ceil(2 * k as u32);
        k += 1;
    }
    m
};

/// `(2t + k) / 2k`, the mean of `k <= 16` values of sum `t <= 255 k` rounded half up (0 for
/// `k = 0`), by a multiplication: `x * ceil(2^18 / d) / 2^18` exceeds `x / d` by less than
/// `x / 2^18 < 1/32 <= 1/d` for `x < 2^13`, so its floor is `x / d`'s.
#[inline]
pub(super) fn half_up_mean(t: u32, k: u32) -> u32 {
    let m = HALF_UP_RECIPROCALS[(k as usize).min(16)];
    ((2 * t + k) * m) >> 18
}

/// [`half_up_mean`] for at most 4 samples, of which at least 2 are known (the other case is
/// unknown, its mean unused): `x / 4`, `x / 6` (`x * ceil(2^16 / 6) / 2^16`: too large by
/// less than `x / 2^16 * 1/3 < 1/6` for `x < 2^13`) or `x / 8`, chosen without a branch or
/// a table lookup, so that a row of them vectorises.
#[inline(always)]
pub(super) fn half_up_mean_of_4(t: u32, k: u32) -> u32 {
    let x = 2 * t + k;
    let by6 = (x * 10_923) >> 16;
    match k {
        3 => by6,
        4 => x >> 3,
        _ => x >> 2,
    }
}

/// Output tiles of `TILE x TILE` cells: the input cells one tile samples lie in a small
/// turned square, so the gathers stay in cache (row by row over a wide turned map, every
/// sample was a cache miss).
const TILE: usize = 32;

/// Sub-tiles of `SUB x SUB` cells of the fast path, told unknown, one-valued or neither.
const SUB: usize = 8;

/// A block of the box whose cells are all unknown ([`map_in_with`]'s block codes; a block of
/// known cells of one value has that value, 0..=255).
const BLOCK_UNKNOWN: u16 = 256;
/// A block of the box with cells of different values or knowledge.
const BLOCK_MIXED: u16 = 257;

/// Rows `rows` and columns `cols` of output rows `vblock` / `ublock` (`big_w` cells each)
/// set known, with value `v` (0..=255); `ublock` empty: not asked for.
fn fill(
    vblock: &mut [u8],
    ublock: &mut [bool],
    big_w: usize,
    rows: std::ops::Range<usize>,
    cols: std::ops::Range<usize>,
    v: u16,
) {
    for r in rows {
        let (a, b) = (r * big_w + cols.start, r * big_w + cols.end);
        vblock[a..b].fill(v as u8);
        if !ublock.is_empty() {
            ublock[a..b].fill(false);
        }
    }
}

/// The resample's fast path (SPEC 3a.3 for at most 4 x 4 samples per output cell): what an
/// output tile needs of the geometry, the same floats as the general path's.
struct FastTile<'a> {
    packed: &'a [u16],
    cqx: &'a [f64],
    sqx: &'a [f64],
    offs: &'a [f64],
    big_w: usize,
    f: f64,
    c: f64,
    s: f64,
    cx: f64,
    cy: f64,
    half_h: f64,
    w1: f64,
    h1: f64,
    wf: f64,
    need: u32,
    /// [`Path::Best`] except in the tests ([`Path`]; read on x86-64 only)
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    path: Path,
}

impl FastTile<'_> {
    /// Fill columns `j0..j1` of the output rows in `vblock` / `ublock` (rows `row0..` of the
    /// canonical map): with AVX2 when the processor has it (the same float operations, four
    /// at a time instead of two), else with baseline x86-64 (SSE2) or the target's own.
    fn run(&self, vblock: &mut [u8], ublock: &mut [bool], row0: usize, j0: usize, j1: usize) {
        #[cfg(target_arch = "x86_64")]
        if self.path == Path::Best && has_avx2() {
            // SAFETY: the processor has AVX2, checked just above
            unsafe { self.run_avx2(vblock, ublock, row0, j0, j1) };
            return;
        }
        match self.offs.len() {
            2 => self.tile::<false, 2>(vblock, ublock, row0, j0, j1),
            3 => self.tile::<false, 3>(vblock, ublock, row0, j0, j1),
            _ => self.tile::<false, 4>(vblock, ublock, row0, j0, j1),
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn run_avx2(&self, vblock: &mut [u8], ublock: &mut [bool], row0: usize, j0: usize, j1: usize) {
        match self.offs.len() {
            2 => self.tile::<true, 2>(vblock, ublock, row0, j0, j1),
            3 => self.tile::<true, 3>(vblock, ublock, row0, j0, j1),
            _ => self.tile::<true, 4>(vblock, ublock, row0, j0, j1),
        }
    }

    /// [`FastTile::run`] for `N` samples a side (`N = self.offs.len()`, 2 to 4); `ROUND`:
    /// floors by `floor` ([`floor_in`]).
    #[inline(always)]
    fn tile<const ROUND: bool, const N: usize>(
        &self,
        vblock: &mut [u8],
        ublock: &mut [bool],
        row0: usize,
        j0: usize,
        j1: usize,
    ) {
        let big_w = self.big_w;
        let (f, c, s, cx, cy) = (self.f, self.c, self.s, self.cx, self.cy);
        let (w1, h1, wf) = (self.w1, self.h1, self.wf);
        let cells = j1 - j0;
        // per output cell of a tile row: the sum of its packed samples; per sample, its box
        // cell (row * w + column)
        let mut sums = [0u32; TILE];
        let mut cell = [[0u64; TILE]; N];
        let mask = self.packed.len().saturating_sub(1);
        let packed = &self.packed[..=mask];
        let offs: &[f64; N] = match self.offs.try_into() {
            Ok(o) => o,
            Err(_) => return,
        };
        for r in 0..vblock.len() / big_w {
            let ii = (row0 + r) as f64 - self.half_h;
            sums[..cells].fill(0);
            for o in offs {
                let q = (ii + o) * f;
                let (sqy, cqy) = (s * q, c * q);
                for (m, cell) in cell.iter_mut().enumerate() {
                    let cx_row = &self.cqx[m * big_w + j0..m * big_w + j1];
                    let sx_row = &self.sqx[m * big_w + j0..m * big_w + j1];
                    // the same cells as the general path's, in float arithmetic throughout
                    // so that the loop vectorises
                    for ((a, &cq), &sq) in cell[..cells].iter_mut().zip(cx_row).zip(sx_row) {
                        let px = (cq - sqy) + cx;
                        let py = (sq + cqy) + cy;
                        let idx = floor_in::<ROUND>(py, h1) * wf + floor_in::<ROUND>(px, w1);
                        *a = float_bits_index(idx);
                    }
                }
                // the N samples of this sample row of each output cell (the indices are
                // below h * w, so the mask keeps them; it spares the bounds checks)
                for (x, a) in sums[..cells].iter_mut().enumerate() {
                    *a += cell
                        .iter()
                        .map(|c| u32::from(packed[c[x] as usize & mask]))
                        .sum::<u32>();
                }
            }
            let row = r * big_w + j0;
            for (v, &a) in vblock[row..row + cells].iter_mut().zip(&sums[..cells]) {
                // the sum of the known samples' values, and their number; branch-free (known
                // and unknown cells alternate unpredictably on a noisy map)
                let (t, k) = (a & u32::from(VALUE), a >> KNOWN.trailing_zeros());
                let known = 2 * k >= self.need;
                let mean = if N == 2 {
                    half_up_mean_of_4(t, k)
                } else {
                    half_up_mean(t, k)
                };
                *v = (mean * u32::from(known)) as u8;
            }
            if !ublock.is_empty() {
                for (u, &a) in ublock[row..row + cells].iter_mut().zip(&sums[..cells]) {
                    *u = 2 * (a >> KNOWN.trailing_zeros()) < self.need;
                }
            }
        }
    }
}

/// Which way [`map_in_with`] resamples (the tests compare them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Path {
    /// The fast path where it applies, with AVX2 when the processor has it.
    Best,
    /// The fast path where it applies, never AVX2.
    #[cfg(test)]
    Baseline,
    /// The general path only.
    #[cfg(test)]
    General,
}

/// The canonical map, its values being its structure image (SPEC 3 step 1: the value of a
/// known cell, 0 for an unknown one).
pub(super) struct Resampled {
    /// The canonical map's values, 0 at unknown cells: its structure image.
    pub(super) values: Vec<u8>,
    /// Its unknown mask, or empty when not asked for.
    pub(super) unknown: Vec<bool>,
    pub(super) height: usize,
    pub(super) width: usize,
}

/// SPEC 3a.3: the canonical map of the box `b` ([`map_in`]), by the resampling `path`; the
/// unknown mask only when `want_unknown` (the corners need only the structure image).
#[allow(clippy::too_many_arguments)]
pub(super) fn resample(
    grid: &Grid,
    packed: &[u16],
    (r0, r1, c0, c1): Bounds,
    angle: f64,
    resolution: Option<f64>,
    reference: f64,
    path: Path,
    want_unknown: bool,
) -> Result<Option<Resampled>, OutOfMemory> {
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
    let mut unknown = filled(if want_unknown { big_w * big_h } else { 0 }, true)?;
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
    // per BLOCK x BLOCK block of the box, what its cells are: all unknown
    // ([`BLOCK_UNKNOWN`]), all known with one value (that value), or neither
    // ([`BLOCK_MIXED`]). An output tile whose samples all fall in unknown blocks is unknown
    // and skipped (most of a turned, partly explored map's canonical grid); one whose
    // samples all fall in blocks of one value v is v (every sample known: the mean is v),
    // filled without sampling (open floor)
    const BLOCK: usize = 8;
    let (bh, bw) = (h.div_ceil(BLOCK), w.div_ceil(BLOCK));
    let mut block_code = filled(bh * bw, 0u16)?;
    block_code
        .par_chunks_mut(bw)
        .enumerate()
        .for_each(|(br, out)| {
            // per column, the least and greatest key of the block row's cells (an unknown
            // cell's key BLOCK_UNKNOWN, a known one's its value), then per block
            let (mut lo_c, mut hi_c) = (vec![u16::MAX; w], vec![0u16; w]);
            for r in br * BLOCK..((br + 1) * BLOCK).min(h) {
                let at = base + r * stride;
                let (vals, unk) = (&grid.values[at..at + w], &grid.unknown[at..at + w]);
                for (((lo, hi), &v), &u) in lo_c.iter_mut().zip(&mut hi_c).zip(vals).zip(unk) {
                    let key = u16::from(v) | (u16::from(u) * BLOCK_UNKNOWN);
                    let key = key.min(BLOCK_UNKNOWN);
                    *lo = (*lo).min(key);
                    *hi = (*hi).max(key);
                }
            }
            let lo: Vec<u16> = lo_c
                .chunks(BLOCK)
                .map(|c| c.iter().copied().min().unwrap_or(0))
                .collect();
            let hi: Vec<u16> = hi_c
                .chunks(BLOCK)
                .map(|c| c.iter().copied().max().unwrap_or(0))
                .collect();
            for ((o, &lo), &hi) in out.iter_mut().zip(&lo).zip(&hi) {
                *o = if lo == hi { lo } else { BLOCK_MIXED };
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
    // what the samples of a tile (output rows i0..i1, columns j0..j1) fall on: one block
    // code for all (BLOCK_UNKNOWN or a value), or BLOCK_MIXED. The samples lie in the
    // bounding box of the tile's four corner samples (the map is affine), taken one cell
    // wider against rounding
    let tile_code = |i0: usize, i1: usize, j0: usize, j1: usize| -> u16 {
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
        let first = block_code[(y0 / BLOCK) * bw + x0 / BLOCK];
        if first == BLOCK_MIXED {
            return BLOCK_MIXED;
        }
        let same = (y0 / BLOCK..=y1 / BLOCK).all(|br| {
            block_code[br * bw + x0 / BLOCK..=br * bw + x1 / BLOCK]
                .iter()
                .all(|&k| k == first)
        });
        if same {
            first
        } else {
            BLOCK_MIXED
        }
    };
    // the fast path, when an output cell's packed samples sum without carrying into the
    // count (at most 16 of them, 16 * 255 < 4096) and a box cell's index is exact in a
    // float: one gather per sample from the packed box
    #[cfg(test)]
    let allow_fast = path != Path::General;
    #[cfg(not(test))]
    let allow_fast = true;
    let fast = allow_fast && need <= 16 && h * w < 1 << 52 && packed.len().is_power_of_two();
    let fast_tile = FastTile {
        packed,
        cqx: &cqx,
        sqx: &sqx,
        offs: &offs,
        big_w,
        f,
        c,
        s,
        cx,
        cy,
        half_h,
        w1,
        h1,
        wf,
        need,
        path,
    };
    // per tile row, its rows of the unknown mask (empty slices when not asked for)
    let ublocks: Vec<&mut [bool]> = if want_unknown {
        unknown.chunks_mut(big_w * TILE).collect()
    } else {
        (0..big_h.div_ceil(TILE))
            .map(|_| Default::default())
            .collect()
    };
    values
        .par_chunks_mut(big_w * TILE)
        .zip(ublocks.into_par_iter())
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
                let i0 = t * TILE;
                match tile_code(i0, i0 + rows, j0, j1) {
                    BLOCK_UNKNOWN => continue, // left unknown, as allocated
                    BLOCK_MIXED => {}
                    v => {
                        fill(vblock, ublock, big_w, 0..rows, j0..j1, v);
                        continue;
                    }
                }
                if fast {
                    // SUB x SUB sub-tiles: the unknown and one-valued ones as above, runs of
                    // the others along a row of sub-tiles sampled together
                    for s0 in (0..rows).step_by(SUB) {
                        let s1 = (s0 + SUB).min(rows);
                        let vrows = &mut vblock[s0 * big_w..s1 * big_w];
                        let urows: &mut [bool] = if ublock.is_empty() {
                            &mut []
                        } else {
                            &mut ublock[s0 * big_w..s1 * big_w]
                        };
                        let mut run: Option<usize> = None;
                        for c0 in (j0..j1).step_by(SUB).chain([j1]) {
                            let code = if c0 < j1 {
                                tile_code(i0 + s0, i0 + s1, c0, (c0 + SUB).min(j1))
                            } else {
                                BLOCK_UNKNOWN // flushes the last run
                            };
                            if code == BLOCK_MIXED {
                                run.get_or_insert(c0);
                                continue;
                            }
                            if let Some(start) = run.take() {
                                fast_tile.run(vrows, urows, i0 + s0, start, c0);
                            }
                            if c0 < j1 && code != BLOCK_UNKNOWN {
                                fill(
                                    vrows,
                                    urows,
                                    big_w,
                                    0..s1 - s0,
                                    c0..(c0 + SUB).min(j1),
                                    code,
                                );
                            }
                        }
                    }
                    continue;
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
                            if !ublock.is_empty() {
                                ublock[row + x] = false;
                            }
                        }
                    }
                }
            }
        });
    Ok(Some(Resampled {
        values,
        unknown,
        height: big_h,
        width: big_w,
    }))
}
