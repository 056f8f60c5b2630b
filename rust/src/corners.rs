//! Corner count (SPEC section 3, paper III.B): LoG structure mask, small dots dropped,
//! Harris response on the mask, relative threshold, 8-connected corner blobs counted.
//!
//! Everything up to the Harris response is exact integer arithmetic; the response is one
//! float64 formula, `R = (A*C - B*B) - k*(A + C)^2`, evaluated as `slamq.reference` does.
//! Work is done in fixed row bands in parallel; the one full-size intermediate is the 0/1
//! structure mask (one byte per cell). The blur and the Laplacian of a row run only over the
//! columns near its nonzero structure cells (unknown cells are 0 in S, so a map's unexplored
//! margins cost a scan, not a filter). Dot removal hands the mask's surviving runs on. The
//! Harris sums of a cell depend only on the 4x4 mask window around it, so they are tabulated
//! once per process for all 65,536 windows (by class of equal sums); a row's window codes
//! are built from four mask rows, only over the columns next to set structure cells, and
//! the window classes are ranked by their response for the given `k` (positive ones first, by
//! decreasing `R`), so that the pass over the cells needs no float: every visited cell's
//! rank is stored (two bytes a cell), the largest response is that of the smallest rank, and
//! the relative threshold is a cut on the ranks, applied to whole rows by a vector compare
//! before their runs are found; the corner blobs are counted from runs.

use crate::border::reflect101;
use crate::filter::{blur_row, laplacian_mask_row, structure_row, widen_row};
use crate::grid::{bands, Grid, BAND_ROWS};
use crate::label::{
    count_components, drop_small_runs, push_runs, Components, MaskRows, RowRuns, Run,
};
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
    structure_mask_runs(grid, log_threshold).0
}

/// Steps 1-4: the LoG structure mask (0/1 per cell) and its runs, each row's runs found
/// right after the row is written (while it is in cache) instead of by a second scan.
pub fn structure_mask_runs(grid: &Grid, log_threshold: f64) -> (Vec<u8>, RowRuns) {
    structure_mask_runs_by((grid.height, grid.width), log_threshold, &|r, row| {
        structure_row(grid.value_row(r), grid.unknown_row(r), row)
    })
}

/// An empty column span (`lo >= hi`), the unit of [`union_span`].
const EMPTY_SPAN: (usize, usize) = (usize::MAX, 0);

/// How far G and L rows are computed beyond their S rows' nonzero columns: G is 0 more than
/// 2 columns from them, and a slice that starts (ends) 4 columns before (after) them has
/// zeros where its own reflect-101 ends read (G 2 columns in, L 1 column of G), so the
/// slice's values equal the whole row's.
const SPAN_MARGIN: usize = 4;

/// The smallest span holding both spans (an empty one adds nothing).
fn union_span(a: (usize, usize), b: (usize, usize)) -> (usize, usize) {
    if b.0 >= b.1 {
        a
    } else {
        (a.0.min(b.0), a.1.max(b.1))
    }
}

/// `span` widened by [`SPAN_MARGIN`] each side, within `0..w` (empty stays empty).
fn widen_span((lo, hi): (usize, usize), w: usize) -> (usize, usize) {
    if lo >= hi {
        EMPTY_SPAN
    } else {
        (lo.saturating_sub(SPAN_MARGIN), (hi + SPAN_MARGIN).min(w))
    }
}

/// The columns `lo..hi` from a row's first nonzero cell to its last (empty when all zero),
/// found 32 cells a step (an OR of each chunk vectorises).
fn nonzero_span(row: &[u16]) -> (usize, usize) {
    const C: usize = 32;
    let any = |c: &[u16]| c.iter().fold(0u16, |a, &b| a | b) != 0;
    let Some((i, c)) = row.chunks(C).enumerate().find(|(_, c)| any(c)) else {
        return EMPTY_SPAN;
    };
    let lo = i * C + c.iter().position(|&x| x != 0).unwrap_or(0);
    let hi = row
        .chunks(C)
        .enumerate()
        .rev()
        .find(|(_, c)| any(c))
        .map_or(lo + 1, |(i, c)| {
            i * C + c.iter().rposition(|&x| x != 0).unwrap_or(0) + 1
        });
    (lo, hi)
}

/// [`structure_mask_runs`] of the `h x w` map whose structure image's row `r` is written by
/// `s_row(r, row)`.
fn structure_mask_runs_by(
    (h, w): (usize, usize),
    log_threshold: f64,
    s_row: &(impl Fn(usize, &mut [u16]) + Sync),
) -> (Vec<u8>, RowRuns) {
    let mut mask = vec![0u8; h * w];
    let Some(t) = integer_threshold(log_threshold * 255.0 * 256.0) else {
        let runs = RowRuns::concat(vec![(Vec::new(), vec![0; h])]);
        return (mask, runs);
    };
    // scratch rows per rayon job (S rows of a band, G rows of a band, the blur's vertical pass),
    // reused across the bands a job runs: every row read is written first in each band
    let parts: Vec<(Vec<Run>, Vec<usize>)> = mask
        .par_chunks_mut(BAND_ROWS * w)
        .zip(bands(h))
        .map_init(
            || (Vec::<u16>::new(), Vec::<u16>::new(), vec![0u16; w]),
            |(s_buf, g_buf, vbuf), (out, (r0, r1))| {
                // S rows needed: r0-3 ..= r1+2, reflect-mapped; those all fall in [base, end)
                let base = (r0 as isize - 3).max(0) as usize;
                let end = (r1 + 3).min(h);
                if s_buf.len() < (end - base) * w {
                    s_buf.resize((end - base) * w, 0);
                }
                // per S row, the columns of its nonzero cells (`lo..hi`, empty: `lo >= hi`):
                // beyond them S is 0, and so are G and L more than 2 and 3 columns away
                let mut s_span = Vec::with_capacity(end - base);
                for (rr, row) in (base..end).zip(s_buf.chunks_exact_mut(w)) {
                    s_row(rr, row);
                    s_span.push(nonzero_span(row));
                }
                let s_buf: &[u16] = s_buf;
                let s_of = |k: usize| -> &[u16] { &s_buf[(k - base) * w..(k - base + 1) * w] };
                // G rows r0-1 ..= r1 (reflect-mapped), each computed on the columns `ga..gb`
                // of its five S rows' nonzero columns widened by SPAN_MARGIN (0 elsewhere); a
                // row whose five S rows are all zero is zero
                let ng = r1 - r0 + 2;
                if g_buf.len() < ng * w {
                    g_buf.resize(ng * w, 0);
                }
                let mut g_span: Vec<(usize, usize)> = Vec::with_capacity(ng);
                for (k, g) in (r0 as isize - 1..r1 as isize + 1).zip(g_buf.chunks_exact_mut(w)) {
                    let gr = reflect101(k, h);
                    let span = (-2..=2)
                        .map(|j| s_span[reflect101(gr as isize + j, h) - base])
                        .fold(EMPTY_SPAN, union_span);
                    let (ga, gb) = widen_span(span, w);
                    if ga < gb {
                        // the slice's own reflect-101 ends read zeros where the row's do
                        // (SPAN_MARGIN), or are the row's ends
                        blur_row(
                            &|i| &s_of(i)[ga..gb],
                            gr,
                            h,
                            &mut vbuf[ga..gb],
                            &mut g[ga..gb],
                        );
                        g[..ga].fill(0);
                        g[gb..].fill(0);
                    } else {
                        g.fill(0);
                    }
                    g_span.push((ga, gb));
                }
                let g_row = |i: usize| &g_buf[i * w..(i + 1) * w];
                let outside = (0 > t) as u8; // the mask where L = 0
                let mut runs = Vec::new();
                let mut starts = Vec::with_capacity(r1 - r0);
                for r in r0..r1 {
                    let i = r - r0 + 1;
                    let row_out = &mut out[(r - r0) * w..(r - r0 + 1) * w];
                    starts.push(runs.len());
                    // L is 0 outside the three G rows' columns (each already widened)
                    let (la, lb) = g_span[i - 1..=i + 1]
                        .iter()
                        .copied()
                        .filter(|&(a, b)| a < b)
                        .fold(EMPTY_SPAN, union_span);
                    if outside != 0 {
                        row_out.fill(outside); // a fresh mask is 0 already
                    }
                    if la >= lb {
                        if outside != 0 {
                            push_runs(row_out, &mut runs);
                        }
                        continue;
                    }
                    let (up, mid, down) = (g_row(i - 1), g_row(i), g_row(i + 1));
                    laplacian_mask_row(
                        &up[la..lb],
                        &mid[la..lb],
                        &down[la..lb],
                        t,
                        &mut row_out[la..lb],
                    );
                    if outside != 0 {
                        push_runs(row_out, &mut runs);
                    } else {
                        let first = runs.len();
                        push_runs(&row_out[la..lb], &mut runs);
                        for run in &mut runs[first..] {
                            run.start += la as u32;
                            run.end += la as u32;
                        }
                    }
                }
                (runs, starts)
            },
        )
        .collect();
    (mask, RowRuns::concat(parts))
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

/// [`drop_dots`] given the mask's runs (from [`structure_mask_runs`]), which it consumes.
pub fn drop_dots_runs(
    mask: &mut [u8],
    runs: RowRuns,
    height: usize,
    width: usize,
    min_dot_area: u32,
) -> RowRuns {
    if min_dot_area <= 1 {
        return runs;
    }
    drop_small_runs(runs, mask, height, width, min_dot_area)
}

/// The Harris response of one cell's sums, exactly `(A*C - B*B) - k*(A+C)^2` in float64.
#[inline]
pub fn response(a: i64, b: i64, c: i64, k: f64) -> f64 {
    let s = a + c;
    ((a * c - b * b) as f64) - k * ((s * s) as f64)
}

/// The Harris sums `(A, B, C)` of one cell from its 4 x 4 mask window, for the cells whose
/// reflect-mapped window is consistent (every cell but those of row 0 and column 0, see
/// [`window_code`]): window rows are mask rows `r-2 ..= r+1`, columns `x-2 ..= x+1`, and
/// bit `4 * j + i` of the code is the mask at window row `i`, column `j`.
fn sums_of_code(code: u16) -> (i64, i64, i64) {
    let m: [[i64; 4]; 4] =
        std::array::from_fn(|i| std::array::from_fn(|j| ((code >> (4 * j + i)) & 1) as i64));
    let (mut a, mut b, mut c) = (0, 0, 0);
    // products at window rows {1, 2} (mask rows r-1, r) and columns {1, 2} (x-1, x)
    for y in 1..3 {
        for x in 1..3 {
            let ix = (m[y - 1][x + 1] + 2 * m[y][x + 1] + m[y + 1][x + 1])
                - (m[y - 1][x - 1] + 2 * m[y][x - 1] + m[y + 1][x - 1]);
            let iy = (m[y + 1][x - 1] + 2 * m[y + 1][x] + m[y + 1][x + 1])
                - (m[y - 1][x - 1] + 2 * m[y - 1][x] + m[y - 1][x + 1]);
            a += ix * ix;
            b += ix * iy;
            c += iy * iy;
        }
    }
    (a, b, c)
}

/// Every 4 x 4 window's class (its distinct `(A, B, C)`), built once per process: 128 KiB.
struct WindowClasses {
    class: Vec<u16>,
    sums: Vec<(i64, i64, i64)>,
}

fn window_classes() -> &'static WindowClasses {
    static TABLE: std::sync::OnceLock<WindowClasses> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        // |Ix|, |Iy| <= 4, so 0 <= A, C <= 64 and |B| <= 64: a dense index of (A, B, C)
        const SIDE: usize = 65;
        let key =
            |(a, b, c): (i64, i64, i64)| (a as usize * 129 + (b + 64) as usize) * SIDE + c as usize;
        let mut index = vec![u16::MAX; SIDE * 129 * SIDE];
        let mut sums = Vec::new();
        let class = (0..=u16::MAX)
            .map(|code| {
                let abc = sums_of_code(code);
                let slot = &mut index[key(abc)];
                if *slot == u16::MAX {
                    *slot = sums.len() as u16;
                    sums.push(abc);
                }
                *slot
            })
            .collect();
        WindowClasses { class, sums }
    })
}

/// The window classes ranked by their response for one Harris `k`: the classes with `R > 0`
/// first, by decreasing `R`, then all others (empty windows, `R <= 0`, NaN). A cell's rank
/// then says all the first pass needs without a float: whether `R > 0` (`rank < positive`),
/// and the largest response is that of the smallest rank seen; the cells above a positive
/// threshold are the ranks below a cut.
struct Ranked {
    /// Rank of every 4 x 4 window code.
    rank: Vec<u16>,
    /// Response by rank.
    resp: Vec<f64>,
    /// Number of ranks with `R > 0`.
    positive: usize,
}

impl Ranked {
    fn build(k: f64) -> Ranked {
        let table = window_classes();
        let resp_of: Vec<f64> = table
            .sums
            .iter()
            .map(|&(a, b, c)| response(a, b, c, k))
            .collect();
        // an empty window (A = C = 0, so B = 0) is never counted as positive
        let is_pos = |c: usize| {
            let (a, _, cc) = table.sums[c];
            (a != 0 || cc != 0) && resp_of[c] > 0.0
        };
        let mut order: Vec<usize> = (0..resp_of.len()).collect();
        // positive classes first by decreasing response (ties by class), then the rest
        order.sort_by(|&x, &y| match (is_pos(x), is_pos(y)) {
            (true, true) => resp_of[y].total_cmp(&resp_of[x]).then(x.cmp(&y)),
            (true, false) => std::cmp::Ordering::Less,
            (false, true) => std::cmp::Ordering::Greater,
            (false, false) => x.cmp(&y),
        });
        let mut rank_of_class = vec![0u16; order.len()];
        for (r, &c) in order.iter().enumerate() {
            rank_of_class[c] = r as u16;
        }
        // one entry of padding after the 2^16 codes: the AVX2 rank pass reads 32 bits at
        // every code's entry (the padding only ever lands in bits it masks off)
        let mut rank: Vec<u16> = table
            .class
            .iter()
            .map(|&c| rank_of_class[c as usize])
            .collect();
        rank.push(u16::MAX);
        Ranked {
            rank,
            resp: order.iter().map(|&c| resp_of[c]).collect(),
            positive: order.iter().filter(|&&c| is_pos(c)).count(),
        }
    }
}

/// [`Ranked`] for `k`, kept for the last `k` asked (building it takes ~65,536 steps).
fn ranked(k: f64) -> std::sync::Arc<Ranked> {
    use std::sync::{Arc, Mutex};
    static LAST: Mutex<Option<(u64, Arc<Ranked>)>> = Mutex::new(None);
    if let Ok(guard) = LAST.lock() {
        if let Some((bits, r)) = guard.as_ref() {
            if *bits == k.to_bits() {
                return r.clone();
            }
        }
    }
    let r = Arc::new(Ranked::build(k));
    if let Ok(mut guard) = LAST.lock() {
        *guard = Some((k.to_bits(), r.clone()));
    }
    r
}

/// The sums of one cell computed from the mask directly with reflect-101 everywhere (SPEC
/// section 3 step 6), for row 0 and column 0, where the box's row (column) above is
/// `reflect(-1) = 1`, below (right of) the cell, and the 4 x 4 window does not apply.
fn sums_direct(mask: &[u8], (h, w): (usize, usize), r: usize, x: usize) -> (i64, i64, i64) {
    let m = |rr: isize, cc: isize| mask[reflect101(rr, h) * w + reflect101(cc, w)] as i64;
    let (mut a, mut b, mut c) = (0, 0, 0);
    for y in [reflect101(r as isize - 1, h), r] {
        for xx in [reflect101(x as isize - 1, w), x] {
            let (y, xx) = (y as isize, xx as isize);
            let ix = (m(y - 1, xx + 1) + 2 * m(y, xx + 1) + m(y + 1, xx + 1))
                - (m(y - 1, xx - 1) + 2 * m(y, xx - 1) + m(y + 1, xx - 1));
            let iy = (m(y + 1, xx - 1) + 2 * m(y + 1, xx) + m(y + 1, xx + 1))
                - (m(y - 1, xx - 1) + 2 * m(y - 1, xx) + m(y - 1, xx + 1));
            a += ix * ix;
            b += ix * iy;
            c += iy * iy;
        }
    }
    (a, b, c)
}

/// Column nibbles of output row `r` (>= 1): bit `i` of `nib[c]` is the mask at row
/// `reflect(r - 2 + i)`, column `c`. The window code of column `x` (>= 1) is then
/// `nib[reflect(x-2)] | nib[x-1] << 4 | nib[x] << 8 | nib[reflect(x+1)] << 12`: for `r, x >= 1`
/// the reflect-mapped window holds exactly the mask cells the Sobel products of the box read
/// (row 0 and column 0 reflect their box onto the far side, so they are computed directly).
fn window_nibbles(
    mask: &[u8],
    (h, w): (usize, usize),
    r: usize,
    lo: usize,
    hi: usize,
    nib: &mut [u8],
) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: AVX2 is present
        unsafe { window_nibbles_avx2(mask, (h, w), r, lo, hi, nib) };
        return;
    }
    window_nibbles_in(mask, (h, w), r, lo, hi, nib);
}

/// [`window_nibbles`] compiled for AVX2 (the same bytes, 32 columns a register).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn window_nibbles_avx2(
    mask: &[u8],
    (h, w): (usize, usize),
    r: usize,
    lo: usize,
    hi: usize,
    nib: &mut [u8],
) {
    window_nibbles_in(mask, (h, w), r, lo, hi, nib);
}

#[inline(always)]
fn window_nibbles_in(
    mask: &[u8],
    (h, w): (usize, usize),
    r: usize,
    lo: usize,
    hi: usize,
    nib: &mut [u8],
) {
    let rows: [&[u8]; 4] = std::array::from_fn(|i| {
        let k = reflect101(r as isize - 2 + i as isize, h);
        &mask[k * w..(k + 1) * w]
    });
    for ((((n, &a), &b), &c), &d) in nib[lo..hi]
        .iter_mut()
        .zip(&rows[0][lo..hi])
        .zip(&rows[1][lo..hi])
        .zip(&rows[2][lo..hi])
        .zip(&rows[3][lo..hi])
    {
        *n = a | (b << 1) | (c << 2) | (d << 3);
    }
}

/// One band's Harris pass: the rank ([`Ranked`]) of every window cell, and the directly
/// computed cells (row 0, column 0) with `R > 0` as `(column, classes + i)` in row-major
/// order, `direct[i]` their response.
struct Positive {
    /// The largest response of the directly computed cells.
    best: f64,
    /// The smallest rank of the window cells.
    min_rank: u16,
    cells: Vec<(u32, u32)>,
    direct: Vec<f64>,
    /// Where each row of the band starts in `cells` (one more entry than rows).
    starts: Vec<usize>,
    /// The rank of every window cell of the band's rows, row-major, `u16::MAX` where no
    /// window was visited (above every cut): the pass over the ranks compares whole rows.
    ranks: Vec<u16>,
    /// Per row, the columns `lo..hi` holding every rank written and every directly
    /// computed cell (empty, `lo >= hi`, when there are none): elsewhere no cell passes.
    spans: Vec<(usize, usize)>,
}

impl Positive {
    /// Keep one directly computed cell's response: the running maximum, and the cell if R > 0.
    #[inline]
    fn visit_direct(&mut self, classes: usize, x: usize, resp: f64) {
        if resp > self.best {
            self.best = resp;
        }
        if resp > 0.0 {
            self.cells
                .push((x as u32, (classes + self.direct.len()) as u32));
            self.direct.push(resp);
        }
    }

    /// Keep one window cell of rank `rank` (at offset `at` of `ranks`).
    #[inline]
    fn visit_rank(&mut self, at: usize, rank: u16) {
        self.min_rank = self.min_rank.min(rank);
        self.ranks[at] = rank;
    }
}

/// The eight-column blocks of the rank pass of [`corner_runs`] from column `x` while
/// `x + 8 <= hi` (the same ranks and minimum as its scalar loop): the eight window codes
/// from four 64-bit words of nibbles, their ranks by one gather. Returns the column after
/// the last block and the minimum rank so far.
///
/// # Safety
/// AVX2 must be present; `2 <= x`, `hi < nib.len()`, `hi <= ranks.len()`, and `table`
/// must hold at least `2^16 + 1` entries (each code's entry is read as 32 bits).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn rank_blocks_avx2(
    nib: &[u8],
    ranks: &mut [u16],
    table: &[u16],
    mut x: usize,
    hi: usize,
    min_rank: u16,
) -> (usize, u16) {
    use std::arch::x86_64::*;
    debug_assert!(x >= 2 && hi < nib.len() && hi <= ranks.len() && table.len() > 1 << 16);
    let word = |at: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&nib[at..at + 8]);
        u64::from_le_bytes(b)
    };
    let low16 = _mm256_set1_epi32(0xffff);
    let mut vmin = _mm_set1_epi16(-1);
    while x + 8 <= hi {
        let lo = word(x - 2) | word(x - 1) << 4;
        let hw = word(x) | word(x + 1) << 4;
        if lo | hw != 0 {
            // code t = byte t of `lo` | byte t of `hw` << 8
            let codes =
                _mm_unpacklo_epi8(_mm_cvtsi64_si128(lo as i64), _mm_cvtsi64_si128(hw as i64));
            let idx = _mm256_cvtepu16_epi32(codes);
            // SAFETY: every code is below 2^16 and `table` has an entry past the last, so
            // the 32 bits at 2 * code are inside it
            let g = _mm256_i32gather_epi32::<2>(table.as_ptr() as *const i32, idx);
            let g = _mm256_and_si256(g, low16);
            let r8 = _mm_packus_epi32(_mm256_castsi256_si128(g), _mm256_extracti128_si256::<1>(g));
            let out = &mut ranks[x..x + 8];
            // SAFETY: `out` holds eight u16 (unaligned store)
            _mm_storeu_si128(out.as_mut_ptr() as *mut __m128i, r8);
            vmin = _mm_min_epu16(vmin, r8);
        }
        x += 8;
    }
    let m = (_mm_cvtsi128_si32(_mm_minpos_epu16(vmin)) & 0xffff) as u16;
    (x, min_rank.min(m))
}

/// `keep[x] = (ranks[x] < cut)` as 0/1 for one row (AVX2 when present: 16 ranks a compare).
fn keep_row(ranks: &[u16], cut: u16, keep: &mut [u8]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: AVX2 is present
        unsafe { keep_row_avx2(ranks, cut, keep) };
        return;
    }
    keep_row_in(ranks, cut, keep);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn keep_row_avx2(ranks: &[u16], cut: u16, keep: &mut [u8]) {
    keep_row_in(ranks, cut, keep);
}

#[inline(always)]
fn keep_row_in(ranks: &[u16], cut: u16, keep: &mut [u8]) {
    for (k, &r) in keep.iter_mut().zip(ranks) {
        *k = (r < cut) as u8;
    }
}

/// Steps 6-7: the corner mask of a dot-free structure mask (given with its runs), as runs.
///
/// The sums are visited only next to set mask cells: elsewhere `A = B = C = 0`, so `R = 0`.
/// Only a cell with `R > 0` can pass `R > harris_quality * max R` (the threshold is never
/// negative, and a map whose largest response is `<= 0` has no corner), so those cells are
/// kept, with their rank ([`Ranked`]), in the one pass that also finds the maximum.
pub fn corner_runs(
    mask: &[u8],
    runs: &RowRuns,
    height: usize,
    width: usize,
    params: &CornerParams,
) -> RowRuns {
    let (h, w) = (height, width);
    let k = params.harris_k;
    let rk = ranked(k);
    let (nc, npos) = (rk.resp.len(), rk.positive);
    // the rank table as a plain slice, so that its pointer and length stay in registers
    // through the rank pass (read through the shared `Ranked`, they are loaded again after
    // every store of a rank)
    let rank_of: &[u16] = &rk.rank;
    #[cfg(target_arch = "x86_64")]
    let avx2 = std::arch::is_x86_feature_detected!("avx2");
    // per band: the ranks of the window cells and the directly computed cells with R > 0
    let found: Vec<Positive> = bands(h)
        .into_par_iter()
        .map(|(r0, r1)| {
            let mut pos = Positive {
                best: f64::NEG_INFINITY,
                min_rank: u16::MAX,
                cells: Vec::new(),
                direct: Vec::new(),
                starts: Vec::with_capacity(r1 - r0 + 1),
                ranks: vec![u16::MAX; (r1 - r0) * w],
                spans: vec![(0, 0); r1 - r0],
            };
            let mut nib = vec![0u8; w];
            for r in r0..r1 {
                pos.starts.push(pos.cells.len());
                // columns whose window can hold a set cell: the bounding interval of the runs
                // of mask rows r-2 ..= r+1, widened by the window's reach
                let (mut first, mut last) = (usize::MAX, 0usize);
                for i in 0..4 {
                    let rr = runs.row(reflect101(r as isize - 2 + i, h));
                    if let (Some(a), Some(b)) = (rr.first(), rr.last()) {
                        first = first.min(a.start as usize);
                        last = last.max(b.end as usize);
                    }
                }
                if first == usize::MAX {
                    continue; // A = B = C = 0 on the whole row
                }
                // every cell visited below (ranks, and the direct cells of row 0 and column
                // 0) lies in [first - 2, last + 2)
                pos.spans[r - r0] = (first.saturating_sub(2), (last + 2).min(w));
                if r == 0 {
                    // the sums can be non-zero on columns [first - 2, last + 2) only
                    for x in first.saturating_sub(2)..(last + 2).min(w) {
                        let (a, b, c) = sums_direct(mask, (h, w), 0, x);
                        if a != 0 || c != 0 {
                            pos.visit_direct(nc, x, response(a, b, c, k));
                        }
                    }
                    continue;
                }
                if first <= 2 {
                    // column 0 reads mask columns 0 ..= 2 only
                    let (a, b, c) = sums_direct(mask, (h, w), r, 0);
                    if a != 0 || c != 0 {
                        pos.visit_direct(nc, 0, response(a, b, c, k));
                    }
                }
                if w == 1 {
                    continue;
                }
                // window columns x-2 ..= x+1 hold a set cell only for x in [first-1, last+2)
                let xlo = first.saturating_sub(1).max(1);
                let xhi = (last + 2).min(w);
                if xlo >= xhi {
                    continue;
                }
                // nibbles of columns reflect(xlo-2) ..= reflect(xhi), all within [nlo, nhi)
                let nlo = xlo.saturating_sub(2);
                let nhi = (xhi + 1).min(w);
                window_nibbles(mask, (h, w), r, nlo, nhi, &mut nib);
                let nb = |c: isize| nib[reflect101(c, w)] as u16;
                // the window code of column x: nib[x-2] | nib[x-1] << 4 | nib[x] << 8 |
                // nib[x+1] << 12, reflect-mapped at the ends; each column's code is built on
                // its own (no chain from one column to the next). Columns x + 1 < w read
                // nib[x + 1] as it is; the last column reflects. No branch per cell: an
                // empty window (code 0) is a class of response -inf (a rank at or above
                // every cut), and every visited cell's rank is written
                let code_at = |x: usize| -> u16 {
                    nib[x - 2] as u16
                        | (nib[x - 1] as u16) << 4
                        | (nib[x] as u16) << 8
                        | (nib[x + 1] as u16) << 12
                };
                let inner_hi = xhi.min(w - 1);
                let row_ranks = &mut pos.ranks[(r - r0) * w..(r - r0 + 1) * w];
                let mut min_rank = pos.min_rank;
                let mut x = xlo;
                if x == 1 && x < inner_hi {
                    // column 1 reads the reflected column -1
                    let code = nb(-1) | nb(0) << 4 | nb(1) << 8 | nb(2) << 12;
                    let rank = rank_of[code as usize];
                    min_rank = min_rank.min(rank);
                    row_ranks[1] = rank;
                    x = 2;
                }
                #[cfg(target_arch = "x86_64")]
                if avx2 && x >= 2 && rank_of.len() > 1 << 16 {
                    // SAFETY: AVX2 is present, x >= 2, inner_hi < w = nib.len() and
                    // rank_of holds an entry past code 2^16 - 1
                    (x, min_rank) = unsafe {
                        rank_blocks_avx2(&nib, row_ranks, rank_of, x, inner_hi, min_rank)
                    };
                }
                while x < inner_hi {
                    if x + 8 <= inner_hi {
                        // eight columns at a time, one branch for the eight: they read
                        // nib[x-2 ..= x+8], and if that is all zero their ranks stay empty
                        // (their codes built eight at a time: byte t of `lo` is
                        // nib[x-2+t] | nib[x-1+t] << 4, of `hi` nib[x+t] | nib[x+1+t] << 4,
                        // nibbles being below 16)
                        let word = |at: usize| {
                            let mut b = [0u8; 8];
                            b.copy_from_slice(&nib[at..at + 8]);
                            u64::from_le_bytes(b)
                        };
                        let lo = word(x - 2) | word(x - 1) << 4;
                        let hi = word(x) | word(x + 1) << 4;
                        if lo | hi != 0 {
                            for (t, o) in row_ranks[x..x + 8].iter_mut().enumerate() {
                                let code = ((lo >> (8 * t)) & 0xff) | ((hi >> (8 * t)) & 0xff) << 8;
                                let rank = rank_of[code as usize];
                                min_rank = min_rank.min(rank);
                                *o = rank;
                            }
                        }
                        x += 8;
                    } else {
                        let rank = rank_of[code_at(x) as usize];
                        min_rank = min_rank.min(rank);
                        row_ranks[x] = rank;
                        x += 1;
                    }
                }
                pos.min_rank = min_rank;
                if xhi == w && inner_hi < w {
                    let x = w as isize - 1;
                    let code = nb(x - 2) | nb(x - 1) << 4 | nb(x) << 8 | nb(x + 1) << 12;
                    if code != 0 {
                        pos.visit_rank((r - r0) * w + x as usize, rank_of[code as usize]);
                    }
                }
            }
            pos.starts.push(pos.cells.len());
            pos
        })
        .collect();
    // the largest response where it is positive (otherwise no corner, whatever its value)
    let best = found
        .iter()
        .map(|p| {
            let ranked = match p.min_rank as usize {
                m if m < npos => rk.resp[m],
                _ => f64::NEG_INFINITY,
            };
            p.best.max(ranked)
        })
        .fold(f64::NEG_INFINITY, f64::max);
    let threshold = if best > 0.0 {
        params.harris_quality * best
    } else {
        f64::INFINITY
    };
    // the ranks that pass are those below `cut` (positive ranks by decreasing response)
    let cut = rk.resp[..npos].partition_point(|&r| r > threshold);
    let cut16 = cut as u16; // cut <= npos < the class count <= 65,536, so below u16::MAX
    let parts = found
        .into_par_iter()
        .zip(bands(h))
        .map(|(pos, (r0, r1))| {
            let mut out: Vec<Run> = Vec::new();
            let mut starts = Vec::with_capacity(r1 - r0);
            let mut keep = vec![0u8; w];
            for i in 0..r1 - r0 {
                starts.push(out.len());
                let direct = &pos.cells[pos.starts[i]..pos.starts[i + 1]];
                // only the row's span can pass (beyond it the ranks are empty)
                let (lo, hi) = pos.spans[i];
                if lo >= hi {
                    continue;
                }
                let keep = &mut keep[lo..hi];
                keep_row(&pos.ranks[i * w + lo..i * w + hi], cut16, keep);
                for &(x, key) in direct {
                    keep[x as usize - lo] = (pos.direct[key as usize - nc] > threshold) as u8;
                }
                let first = out.len();
                push_runs(keep, &mut out);
                for run in &mut out[first..] {
                    run.start += lo as u32;
                    run.end += lo as u32;
                }
            }
            (out, starts)
        })
        .collect();
    RowRuns::concat(parts)
}

/// Steps 1-8: the number of corners of a map.
pub fn count_corners(grid: &Grid, params: &CornerParams) -> usize {
    let (mask, runs) = structure_mask_runs(grid, params.log_threshold);
    corners_of_mask(mask, runs, (grid.height, grid.width), params)
}

/// Steps 1-8 of an `h x w` map given as its structure image `s` (SPEC 3 step 1: the value
/// of a known cell, 0 for an unknown one): [`count_corners`] of any map with that image.
pub fn count_corners_of_structure(s: &[u8], h: usize, w: usize, params: &CornerParams) -> usize {
    let (mask, runs) = structure_mask_runs_by((h, w), params.log_threshold, &|r, row| {
        widen_row(&s[r * w..(r + 1) * w], row)
    });
    corners_of_mask(mask, runs, (h, w), params)
}

/// Steps 5-8 from the structure mask and its runs.
fn corners_of_mask(
    mut mask: Vec<u8>,
    runs: RowRuns,
    (h, w): (usize, usize),
    params: &CornerParams,
) -> usize {
    let runs = drop_dots_runs(&mut mask, runs, h, w, params.min_dot_area);
    let corners = corner_runs(&mask, &runs, h, w, params);
    drop((mask, runs));
    count_components(&corners.runs, &corners.row_start, h)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn rank_blocks_avx2_equal_the_scalar_codes() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let rk = ranked(0.04);
        let w = 203;
        let mut state = 12345u64;
        for density in [0u64, 1, 3, 8, 16] {
            // nibbles with about density / 16 of their bits set, runs of zeros between
            let nib: Vec<u8> = (0..w)
                .map(|_| {
                    let mut n = 0u8;
                    for b in 0..4 {
                        state = state
                            .wrapping_mul(6364136223846793005)
                            .wrapping_add(1442695040888963407);
                        n |= (((state >> 33) % 16 < density) as u8) << b;
                    }
                    n
                })
                .collect();
            let (x0, hi) = (2, w - 1);
            let mut ranks = vec![u16::MAX; w];
            // SAFETY: AVX2 is present; 2 <= x0, hi < w, and the table is padded
            let (x, m) = unsafe { rank_blocks_avx2(&nib, &mut ranks, &rk.rank, x0, hi, 7000) };
            assert!(x + 8 > hi && x <= hi);
            let mut want = vec![u16::MAX; w];
            let mut want_min = 7000u16;
            for b in (x0..x).step_by(8) {
                if nib[b - 2..b + 9].iter().all(|&n| n == 0) {
                    continue;
                }
                for c in b..b + 8 {
                    let code = nib[c - 2] as usize
                        | (nib[c - 1] as usize) << 4
                        | (nib[c] as usize) << 8
                        | (nib[c + 1] as usize) << 12;
                    want[c] = rk.rank[code];
                    want_min = want_min.min(want[c]);
                }
            }
            assert_eq!((ranks, m), (want, want_min), "density {density}");
        }
    }

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
        let ks = [0.04, 0.0, -0.05, 0.25, -0.0];
        for trial in 0..600 {
            // default parameters, then other Harris k (negative too) and quality levels
            let mut p = CornerParams::default();
            if trial >= 300 {
                p.harris_k = ks[trial % ks.len()];
                p.harris_quality = [0.01, 0.0, 0.5, 0.9][trial % 4];
            }
            let h = 1 + next() % 23;
            let w = 1 + next() % if trial % 5 == 0 { 150 } else { 23 };
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
            if trial % 4 == 1 {
                // set cells only in a band of columns (a map's known area): the rows' spans
                let (a, b) = (next() % w, next() % w);
                for (i, m) in mask.iter_mut().enumerate() {
                    if i % w < a.min(b) || i % w > a.max(b) {
                        *m = 0;
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
    fn fused_mask_runs_equal_a_scan_of_the_mask() {
        let mut st = 5u64;
        for (h, w) in [(1, 1), (3, 7), (70, 33), (130, 20)] {
            let v: Vec<u8> = (0..h * w)
                .map(|_| {
                    st = st.wrapping_mul(6364136223846793005).wrapping_add(3);
                    [0u8, 128, 254, 254, 254][(st >> 40) as usize % 5]
                })
                .collect();
            let u: Vec<bool> = v.iter().map(|&x| x == 128).collect();
            let g = Grid::new(&v, &u, h, w).unwrap();
            let (mask, runs) = structure_mask_runs(&g, 0.1);
            let scan = RowRuns::of(
                &MaskRows {
                    mask: &mask,
                    width: w,
                },
                h,
                w,
            );
            assert_eq!((&runs.runs, &runs.row_start), (&scan.runs, &scan.row_start));
            let (mut m1, mut m2) = (mask.clone(), mask);
            let a = drop_dots(&mut m1, h, w, 5);
            let b = drop_dots_runs(&mut m2, scan, h, w, 5);
            assert_eq!((m1, a.runs, a.row_start), (m2, b.runs, b.row_start));
        }
    }

    /// Steps 1-4 literally: S, the 5 x 5 binomial blur and the Laplacian with reflect-101 at
    /// every cell, thresholded.
    fn naive_structure_mask(g: &Grid, t: f64) -> Vec<u8> {
        let (h, w) = (g.height, g.width);
        let s = |r: isize, c: isize| {
            let i = reflect101(r, h) * w + reflect101(c, w);
            if g.unknown[i] {
                0i64
            } else {
                g.values[i] as i64
            }
        };
        let b = [1i64, 4, 6, 4, 1];
        let blur = |r: isize, c: isize| {
            let (r, c) = (reflect101(r, h) as isize, reflect101(c, w) as isize);
            let mut acc = 0;
            for i in 0..5 {
                for j in 0..5 {
                    acc += b[i] * b[j] * s(r + i as isize - 2, c + j as isize - 2);
                }
            }
            acc
        };
        let mut out = vec![0u8; h * w];
        for r in 0..h as isize {
            for c in 0..w as isize {
                let l = blur(r - 1, c) + blur(r + 1, c) + blur(r, c - 1) + blur(r, c + 1)
                    - 4 * blur(r, c);
                out[r as usize * w + c as usize] = (l as f64 > t * 255.0 * 256.0) as u8;
            }
        }
        out
    }

    #[test]
    fn structure_mask_equals_the_literal_filters_for_any_thread_count() {
        let mut st = 11u64;
        for (h, w) in [
            (1, 1),
            (2, 9),
            (5, 5),
            (64, 7),
            (65, 12),
            (200, 9),
            (131, 30),
        ] {
            let v: Vec<u8> = (0..h * w)
                .map(|_| {
                    st = st.wrapping_mul(6364136223846793005).wrapping_add(3);
                    [0u8, 128, 254, 254, 254, 254, 37][(st >> 40) as usize % 7]
                })
                .collect();
            // unknown in blocks, so that some bands have all-zero S rows
            let u: Vec<bool> = (0..h * w)
                .map(|i| (i / w / 20) % 3 == 1 || v[i] == 128)
                .collect();
            let g = Grid::new(&v, &u, h, w).unwrap();
            for t in [0.1, 0.0, -0.05] {
                let expect = naive_structure_mask(&g, t);
                for (threads, (mask, _)) in masks_on_1_and_2_threads(&g, t) {
                    assert_eq!(mask, expect, "{h}x{w} t {t} threads {threads}");
                }
            }
        }
    }

    /// [`structure_mask_runs`] of `g` on a pool of 1 and of 2 threads.
    fn masks_on_1_and_2_threads(g: &Grid, t: f64) -> Vec<(usize, (Vec<u8>, RowRuns))> {
        [1, 2]
            .map(|threads| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                (threads, pool.install(|| structure_mask_runs(g, t)))
            })
            .into()
    }

    #[test]
    fn structure_mask_of_partly_known_rows_equals_the_literal_filters() {
        // known cells only in a band of columns per row (a turned box, strips at every
        // distance from the edges, single cells): the filters run on those columns only
        let mut next = crate::edt::tests::rng(23);
        for trial in 0..40 {
            let (h, w) = (5 + next() as usize % 90, 1 + next() as usize % 140);
            let (h, w) = if trial < 4 {
                (h, [1, 2, 5, 9][trial])
            } else {
                (h, w)
            };
            let (mut v, mut u) = (vec![0u8; h * w], vec![true; h * w]);
            let (cx, cy) = (next() as usize % w, next() as usize % h);
            let radius = 1 + next() as usize % (w + h);
            for r in 0..h {
                for c in 0..w {
                    let d = r.abs_diff(cy) + c.abs_diff(cx);
                    let strip = trial % 3 == 0 && c.abs_diff(cx) <= trial % 7;
                    if d <= radius || strip {
                        let i = r * w + c;
                        u[i] = next() % 13 == 0;
                        v[i] = [0u8, 254, 254, 254, 200, 37][next() as usize % 6];
                    }
                }
            }
            let g = Grid::new(&v, &u, h, w).unwrap();
            for t in [0.1, 0.0, -0.05] {
                let expect = naive_structure_mask(&g, t);
                for (threads, (mask, runs)) in masks_on_1_and_2_threads(&g, t) {
                    assert_eq!(
                        mask, expect,
                        "trial {trial} {h}x{w} t {t} threads {threads}"
                    );
                    let scan = RowRuns::of(
                        &MaskRows {
                            mask: &mask,
                            width: w,
                        },
                        h,
                        w,
                    );
                    assert_eq!(
                        (&runs.runs, &runs.row_start),
                        (&scan.runs, &scan.row_start),
                        "trial {trial} runs"
                    );
                }
            }
        }
    }

    #[test]
    fn nonzero_span_finds_the_first_and_last_nonzero_cells() {
        for n in [0usize, 1, 31, 32, 33, 100] {
            assert!(nonzero_span(&vec![0u16; n]).0 >= nonzero_span(&vec![0u16; n]).1);
            for a in 0..n {
                for b in [a, (a + 40).min(n - 1), n - 1] {
                    let mut row = vec![0u16; n];
                    row[a] = 3;
                    row[b] = 1;
                    assert_eq!(nonzero_span(&row), (a, b + 1), "{n} {a} {b}");
                }
            }
        }
    }

    #[test]
    fn corners_of_the_structure_image_are_those_of_the_map() {
        let mut st = 19u64;
        for (h, w) in [(1, 1), (3, 7), (70, 33), (130, 90)] {
            let v: Vec<u8> = (0..h * w)
                .map(|i| {
                    st = st.wrapping_mul(6364136223846793005).wrapping_add(3);
                    if (i / w) % 9 < 3 {
                        254
                    } else {
                        [0u8, 128, 254, 254, 254, 200][(st >> 40) as usize % 6]
                    }
                })
                .collect();
            let u: Vec<bool> = v.iter().map(|&x| x == 128).collect();
            let s: Vec<u8> = v
                .iter()
                .zip(&u)
                .map(|(&x, &k)| if k { 0 } else { x })
                .collect();
            let g = Grid::new(&v, &u, h, w).unwrap();
            for lt in [0.1, 0.0, -0.05] {
                let p = CornerParams {
                    log_threshold: lt,
                    ..CornerParams::default()
                };
                assert_eq!(
                    count_corners_of_structure(&s, h, w, &p),
                    count_corners(&g, &p)
                );
            }
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
