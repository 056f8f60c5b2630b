//! The aligned estimate on the ground truth's grid (SPEC section 7): nearest-neighbour
//! sampling in 32.32 fixed point, literal ([`resample`], with per-cell flags) or
//! visiting only what the figures need ([`resample_sparse`]).

use super::flag;
use super::scan::{band_list, concat, RowCol, Scan, BLOCK};
use crate::edt::{filled, EdtError, Sparse};
use crate::error::Error;
use crate::grid::{Grid, BAND_ROWS};
use crate::se2::{floor_i64, Affine, Frame, Placed, Se2};
use rayon::prelude::*;

/// Affine map from a ground-truth cell `(row, col)` to the fractional cell position in the
/// estimate (floor = the estimate cell holding the ground-truth cell's centre), under the
/// estimate motion `t`.
fn gt_to_estimate(gt: &Frame, est: &Frame, t: &Se2) -> Affine {
    est.world_to_cell_affine()
        .after(&t.inverse().affine())
        .after(&gt.cell_to_world())
}

/// The aligned estimate on the ground truth's grid, as [`flag`] bits per ground-truth cell:
/// [`flag::ESTIMATE`], [`flag::ESTIMATE_KNOWN`], and [`flag::GROUND_TRUTH_FREE`]. A
/// ground-truth cell takes the state of the estimate cell holding its centre (nearest
/// neighbour); then every occupied estimate cell marks the ground-truth cell holding its own
/// centre, so that thin walls survive when the estimate's grid is finer.
pub(super) struct Resampled {
    pub(super) cells: Vec<u8>,
    /// The cells of E: row-major as the resampling finds them, then those only the
    /// occupied estimate cells' centres mark, in the estimate's row-major order.
    pub(super) e_list: Vec<u32>,
    /// Occupied estimate cells whose centre falls outside the ground truth's grid.
    pub(super) outside: u64,
    /// The ground truth's free cells, and those the estimate knows.
    pub(super) free: u64,
    pub(super) covered: u64,
}

/// `x` in 32.32 fixed point (saturating: positions far outside any grid stay outside).
#[inline]
fn fixed(x: f64) -> i64 {
    (x * 4294967296.0).round() as i64
}

/// What the figures need of the resampling: the cells of E (in [`Resampled::e_list`]'s
/// order), `outside`, the ground truth's free cells and those the estimate knows.
pub(super) struct Sampled {
    pub(super) e_list: Vec<u32>,
    pub(super) outside: u64,
    pub(super) free: u64,
    pub(super) covered: u64,
}

/// Side of the square tiles of ground-truth cells whose coverage [`resample_sparse`] counts
/// at once when the estimate cells they sample are all known (or all unknown).
const TILE: usize = 2 * BLOCK;

/// [`resample`] without the per-cell flags, visiting only what the figures need (the same
/// cells of E in the same order, the same counts): the ground-truth cells each occupied
/// estimate cell holds the centre of, found from that estimate cell (its square mapped onto
/// the ground truth's grid, each candidate tested with [`resample`]'s own fixed-point
/// position); and the coverage per [`TILE`] x [`TILE`] tile of the ground truth: a tile
/// whose samples all fall on known estimate blocks covers its free cells, one whose samples
/// all fall on unknown blocks (or outside the estimate) none, the others cell by cell. None
/// when the positions could overflow the fixed point (frames far apart): then [`resample`].
#[allow(clippy::too_many_arguments)]
pub(super) fn resample_sparse(
    est: &Placed,
    ground_truth: &Placed,
    g_scan: &Scan,
    g_near: &Sparse,
    e_scan: &Scan,
    t: &Se2,
    points: &[(f64, f64)],
) -> Result<Option<Sampled>, Error> {
    let gt = &ground_truth.frame;
    let gu = ground_truth.grid.unknown;
    let (h, w) = (gt.height, gt.width);
    let eg = &est.grid;
    let (eh, ew) = (eg.height as i64, eg.width as i64);
    let m = gt_to_estimate(gt, &est.frame, t);
    let Some(inv) = m.inverse() else {
        return Ok(None);
    };
    // the estimate position of column 0 of every row, and one column's step, in 32.32
    // fixed point exactly as `resample` steps them (no saturation: checked)
    const LIMIT: i64 = 1 << 61;
    let (sr, sc) = (fixed(m.m[0][1]), fixed(m.m[1][1]));
    let span = |s: i64| (s.unsigned_abs() as u128) * (w as u128) < LIMIT as u128;
    if !(span(sr) && span(sc)) {
        return Ok(None);
    }
    let mut starts = Vec::new();
    starts
        .try_reserve_exact(h)
        .map_err(|_| EdtError::Alloc { bytes: h * 16 })?;
    for r in 0..h {
        let (er0, ec0) = m.apply(r as f64, 0.0);
        let (a, b) = (fixed(er0), fixed(ec0));
        if a.abs() >= LIMIT || b.abs() >= LIMIT {
            return Ok(None);
        }
        starts.push((a, b));
    }
    // the estimate cell holding the centre of ground-truth cell (r, c), as `resample` finds
    #[inline]
    fn at(starts: &[(i64, i64)], sr: i64, sc: i64, r: usize, c: usize) -> (i64, i64) {
        let (a, b) = starts[r];
        ((a + c as i64 * sr) >> 32, (b + c as i64 * sc) >> 32)
    }
    let known_at = |r: usize, c: usize| {
        let (ir, ic) = at(&starts, sr, sc, r, c);
        ir >= 0 && ic >= 0 && ir < eh && ic < ew && !eg.unknown[(ir * ew + ic) as usize]
    };
    // E: from each occupied estimate cell, the ground-truth cells whose centre it holds
    let words = w.div_ceil(64);
    let mut e_bits = filled(h * words, 0u64)?;
    let ew_u = eg.width;
    // a margin far above the rounding of the two affine maps and of the fixed point (cells)
    const EPS: f64 = 1e-3;
    let (hm, wm) = ((h - 1) as i64, (w - 1) as i64);
    let ((a, b), (c, d)) = ((inv.m[0][0], inv.m[0][1]), (inv.m[1][0], inv.m[1][1]));
    // the estimate square's corners are its cell's corner (er, ec) mapped plus a
    // combination of one row's and one column's step: its bounding box on the ground
    // truth's grid is that point plus the offsets' extremes, in 32.32 fixed point with
    // the margin (the fixed point's rounding, < ew / 2^33 cells, is far below it)
    let eps = fixed(EPS);
    let lo = (
        fixed(a.min(0.0) + b.min(0.0)) - eps,
        fixed(c.min(0.0) + d.min(0.0)) - eps,
    );
    let hi = (
        fixed(a.max(0.0) + b.max(0.0)) + eps,
        fixed(c.max(0.0) + d.max(0.0)) + eps,
    );
    // every corner of the estimate grid (so every cell corner) maps within 2^26 cells:
    // no sum below overflows; and a column step's rounding stays far below the margin
    const REACH: f64 = (1u64 << 26) as f64;
    let corners = [
        (0.0, 0.0),
        (eh as f64, 0.0),
        (0.0, ew as f64),
        (eh as f64, ew as f64),
    ];
    let near = corners.iter().all(|&(x, y)| {
        let (p, q) = inv.apply(x, y);
        p.abs() < REACH && q.abs() < REACH
    });
    if !near || ew_u > 1 << 20 {
        return Ok(None);
    }
    let (step_r, step_c) = (fixed(b), fixed(d));
    let (mut row_start, mut row_end) = (0usize, 0usize);
    let (mut er, mut base_r, mut base_c) = (0i64, 0i64, 0i64);
    for &i in &e_scan.cells {
        let i = i as usize;
        if i >= row_end {
            // a new estimate row (ascending indices): its column 0's corner
            let r = i / ew_u;
            (row_start, row_end) = (r * ew_u, (r + 1) * ew_u);
            er = r as i64;
            let (p, q) = inv.apply(r as f64, 0.0);
            (base_r, base_c) = (fixed(p), fixed(q));
        }
        let ec = (i - row_start) as i64;
        let (pr, pc) = (base_r + ec * step_r, base_c + ec * step_c);
        // ceil(x + lo) and floor(x + hi) (arithmetic shifts floor), clamped onto the grid
        let (r0, r1) = (
            (-((-(pr + lo.0)) >> 32)).max(0),
            ((pr + hi.0) >> 32).min(hm),
        );
        let (c0, c1) = (
            (-((-(pc + lo.1)) >> 32)).max(0),
            ((pc + hi.1) >> 32).min(wm),
        );
        if !(r0 <= r1 && c0 <= c1) {
            continue;
        }
        for r in r0 as usize..=r1 as usize {
            let (a, b) = starts[r];
            let (mut x, mut y) = (a + c0 * sr, b + c0 * sc);
            for c in c0 as usize..=c1 as usize {
                if x >> 32 == er && y >> 32 == ec {
                    e_bits[r * words + c / 64] |= 1u64 << (c % 64);
                }
                x += sr;
                y += sc;
            }
        }
    }
    let mut e_list = Vec::new();
    let found: usize = e_bits.iter().map(|b| b.count_ones() as usize).sum();
    e_list
        .try_reserve_exact(found + points.len())
        .map_err(|_| EdtError::Alloc {
            bytes: (found + points.len()).saturating_mul(4),
        })?;
    for r in 0..h {
        for (k, &word) in e_bits[r * words..(r + 1) * words].iter().enumerate() {
            let mut b = word;
            while b != 0 {
                e_list.push((r * w + k * 64 + b.trailing_zeros() as usize) as u32);
                b &= b - 1;
            }
        }
    }
    // the cells only the estimate's points mark (known from then on)
    let gt_free = |i: usize| !gu[i] && !g_near.get_index(i);
    let (mut outside, mut covered) = (0u64, 0u64);
    let to_cell = gt.world_to_cell_affine().after(&t.affine());
    for &(x, y) in points {
        let (r, c) = to_cell.apply(x, y);
        let (r, c) = (floor_i64(r), floor_i64(c));
        if r >= 0 && c >= 0 && r < h as i64 && c < w as i64 {
            let (r, c) = (r as usize, c as usize);
            let (word, bit) = (r * words + c / 64, 1u64 << (c % 64));
            if e_bits[word] & bit == 0 {
                e_bits[word] |= bit;
                let i = r * w + c;
                e_list.push(i as u32);
                covered += (!known_at(r, c) && gt_free(i)) as u64;
            }
        } else {
            outside += 1;
        }
    }
    // coverage, tile by tile
    let (th, tw) = (h.div_ceil(TILE), w.div_ceil(TILE));
    let mut g_in_tile = filled(th * tw, 0u32)?;
    let mut at = RowCol::new(w);
    for &i in &g_scan.cells {
        let (r, c) = at.get(i as usize);
        g_in_tile[(r / TILE) * tw + c / TILE] += 1;
    }
    let ebw = e_scan.blocks_wide;
    let (ebh, ebw_i) = (eg.height.div_ceil(BLOCK) as i64, ebw as i64);
    let per = TILE / BLOCK;
    for ti in 0..th {
        let (r0, r1) = (ti * TILE, ((ti + 1) * TILE).min(h));
        // the extremes of the tile rows' starts
        let (mut a_lo, mut a_hi, mut b_lo, mut b_hi) = (i64::MAX, i64::MIN, i64::MAX, i64::MIN);
        for &(a, b) in &starts[r0..r1] {
            a_lo = a_lo.min(a);
            a_hi = a_hi.max(a);
            b_lo = b_lo.min(b);
            b_hi = b_hi.max(b);
        }
        for tj in 0..tw {
            let (c0, c1) = (tj * TILE, ((tj + 1) * TILE).min(w));
            // the estimate cells the tile samples: a sample is its row's start plus a column
            // step term, so the extremes are the starts' plus the step terms' (at the tile's
            // first or last column), exactly; the floor (a shift) keeps the order
            let (x0, x1) = (c0 as i64 * sr, (c1 - 1) as i64 * sr);
            let (y0, y1) = (c0 as i64 * sc, (c1 - 1) as i64 * sc);
            let (lo_r, hi_r) = ((a_lo + x0.min(x1)) >> 32, (a_hi + x0.max(x1)) >> 32);
            let (lo_c, hi_c) = ((b_lo + y0.min(y1)) >> 32, (b_hi + y0.max(y1)) >> 32);
            let mut unknown = lo_r < 0 || lo_c < 0 || hi_r >= eh || hi_c >= ew;
            let mut known = false;
            let (b0, b1) = (lo_r.max(0) / BLOCK as i64, hi_r.min(eh - 1) / BLOCK as i64);
            let (k0, k1) = (lo_c.max(0) / BLOCK as i64, hi_c.min(ew - 1) / BLOCK as i64);
            if lo_r < eh && hi_r >= 0 && lo_c < ew && hi_c >= 0 {
                for bi in b0..=b1.min(ebh - 1) {
                    for bj in k0..=k1.min(ebw_i - 1) {
                        let (bi, bj) = (bi as usize, bj as usize);
                        let n = e_scan.known[bi * ebw + bj];
                        known |= n > 0;
                        unknown |= n < e_scan.block_cells(bi, bj, eg.height, eg.width);
                    }
                }
            }
            if !known {
                continue;
            }
            if !unknown {
                // every sample known: the tile's free cells are covered
                let mut k = 0u32;
                for bi in ti * per..((ti + 1) * per).min(h.div_ceil(BLOCK)) {
                    for bj in tj * per..((tj + 1) * per).min(g_scan.blocks_wide) {
                        k += g_scan.known[bi * g_scan.blocks_wide + bj] as u32;
                    }
                }
                covered += (k - g_in_tile[ti * tw + tj]) as u64;
                continue;
            }
            // every sample inside the estimate: no bounds to test per cell
            let inside = lo_r >= 0 && lo_c >= 0 && hi_r < eh && hi_c < ew;
            let tile = ((r0, r1), (c0, c1));
            covered += if inside {
                tile_covered::<true>(&starts, sr, sc, tile, gu, g_near, eg)
            } else {
                tile_covered::<false>(&starts, sr, sc, tile, gu, g_near, eg)
            };
        }
    }
    let free = g_scan.known_cells - g_scan.cells.len() as u64;
    Ok(Some(Sampled {
        e_list,
        outside,
        free,
        covered,
    }))
}

/// The free cells of the ground-truth tile `rows` x `cols` whose sample (the estimate cell
/// holding its centre: `starts[r]` plus `c` column steps `(sr, sc)`, in 32.32 fixed point)
/// is a known cell of `eg`, cell by cell: the positions stepped along each row (exact
/// integer steps, as [`resample_sparse`]'s `at`), G's bits read a column of the tile at a
/// time (at most [`TILE`] rows, one word: tiles start at multiples of [`TILE`]). `INSIDE`:
/// the caller found every sample of the tile inside the estimate's grid.
#[inline(never)]
fn tile_covered<const INSIDE: bool>(
    starts: &[(i64, i64)],
    sr: i64,
    sc: i64,
    ((r0, r1), (c0, c1)): ((usize, usize), (usize, usize)),
    gu: &[bool],
    g_near: &Sparse,
    eg: &Grid,
) -> u64 {
    let (eh, ew) = (eg.height as i64, eg.width as i64);
    let w = g_near.width;
    let mut g_cols = [0u64; TILE];
    for (c, g) in (c0..c1).zip(g_cols.iter_mut()) {
        *g = g_near.column_bits(c, r0 as isize, (r1 - r0) as u32);
    }
    let mut covered = 0u64;
    for (k, (r, &(a, b))) in (r0..r1).zip(&starts[r0..r1]).enumerate() {
        let (mut a, mut b) = (a + c0 as i64 * sr, b + c0 as i64 * sc);
        for (&u, &g) in gu[r * w + c0..r * w + c1].iter().zip(&g_cols) {
            let (ir, ic) = (a >> 32, b >> 32);
            let free = !u && (g >> k) & 1 == 0;
            if INSIDE {
                // branch-free: the sample is a cell of the estimate
                covered += (free & !eg.unknown[(ir * ew + ic) as usize]) as u64;
            } else if free && ir >= 0 && ic >= 0 && ir < eh && ic < ew {
                covered += !eg.unknown[(ir * ew + ic) as usize] as u64;
            }
            a += sr;
            b += sc;
        }
    }
    covered
}

/// The estimate cell holding the 32.32 fixed-point position `(er, ec)` of a cell's centre:
/// None when it is off the estimate's `eh` x `ew` grid or unknown, else whether it is
/// occupied (`occ` of its value).
#[inline(always)]
fn estimate_cell(eg: &Grid, occ: &[bool; 256], eh: i64, ew: i64, er: i64, ec: i64) -> Option<bool> {
    let (ir, ic) = (er >> 32, ec >> 32);
    if ir >= 0 && ic >= 0 && ir < eh && ic < ew {
        let i = ir as usize * eg.width + ic as usize;
        if !eg.unknown[i] {
            return Some(occ[eg.values[i] as usize]);
        }
    }
    None
}

/// A cell's flags: [`flag::GROUND_TRUTH_FREE`] when the ground truth knows it free, and
/// what the estimate cell at its centre says ([`estimate_cell`]).
#[inline(always)]
fn cell_flags(is_free: bool, seen: Option<bool>) -> u8 {
    let mut f = (is_free as u8) * flag::GROUND_TRUTH_FREE;
    if let Some(occupied) = seen {
        f |= flag::ESTIMATE_KNOWN | ((occupied as u8) * flag::ESTIMATE);
    }
    f
}

pub(super) fn resample(
    est: &Placed,
    ground_truth: &Placed,
    g_mask: &[bool],
    t: &Se2,
    occ: &[bool; 256],
    points: &[(f64, f64)],
) -> Result<Resampled, Error> {
    let gt = &ground_truth.frame;
    let gu = ground_truth.grid.unknown;
    let (h, w) = (gt.height, gt.width);
    let mut cells = filled(h * w, 0u8)?;
    let m = gt_to_estimate(gt, &est.frame, t);
    let (eh, ew) = (est.grid.height as i64, est.grid.width as i64);
    let eg = &est.grid;
    let band = BAND_ROWS * w;
    // per band: the cells of E found, free cells, covered free cells
    let parts: Vec<(Vec<u32>, u64, u64)> = cells
        .par_chunks_mut(band)
        .zip(g_mask.par_chunks(band).zip(gu.par_chunks(band)))
        .enumerate()
        .map(|(b, (chunk, (gm, un)))| {
            let mut list = band_list(chunk.len())?;
            let (mut free, mut covered) = (0u64, 0u64);
            for (k, row) in chunk.chunks_mut(w).enumerate() {
                let r = b * BAND_ROWS + k;
                // the estimate position of column 0 of this row, then one column step each
                // in 32.32 fixed point: the floor is a shift, and the steps add exactly
                let (er0, ec0) = m.apply(r as f64, 0.0);
                let (mut er, mut ec) = (fixed(er0), fixed(ec0));
                let (sr, sc) = (fixed(m.m[0][1]), fixed(m.m[1][1]));
                let (gm, un) = (&gm[k * w..(k + 1) * w], &un[k * w..(k + 1) * w]);
                for (c, ((cell, &g), &u)) in row.iter_mut().zip(gm).zip(un).enumerate() {
                    let is_free = !u && !g;
                    let seen = estimate_cell(eg, occ, eh, ew, er, ec);
                    if let Some(occupied) = seen {
                        covered += is_free as u64;
                        if occupied {
                            list.push((r * w + c) as u32);
                        }
                    }
                    free += is_free as u64;
                    *cell = cell_flags(is_free, seen);
                    er = er.saturating_add(sr);
                    ec = ec.saturating_add(sc);
                }
            }
            Ok((list, free, covered))
        })
        .collect::<Result<_, EdtError>>()?;
    let (mut free, mut covered) = (0u64, 0u64);
    let mut lists = Vec::with_capacity(parts.len());
    for (list, f, c) in parts {
        lists.push(list);
        free += f;
        covered += c;
    }
    let mut e_list = concat(lists)?;
    // room for the cells only the estimate's points mark
    e_list
        .try_reserve(points.len())
        .map_err(|_| EdtError::Alloc {
            bytes: points.len().saturating_mul(4),
        })?;
    let mut outside = 0u64;
    let to_cell = gt.world_to_cell_affine().after(&t.affine());
    for &(x, y) in points {
        let (r, c) = to_cell.apply(x, y);
        let (r, c) = (floor_i64(r), floor_i64(c));
        if r >= 0 && c >= 0 && r < h as i64 && c < w as i64 {
            let i = r as usize * w + c as usize;
            let f = cells[i];
            if f & flag::ESTIMATE == 0 {
                e_list.push(i as u32);
                // a cell an occupied estimate cell marks is known
                let newly = f & flag::ESTIMATE_KNOWN == 0 && f & flag::GROUND_TRUTH_FREE != 0;
                covered += newly as u64;
            }
            cells[i] = f | flag::ESTIMATE | flag::ESTIMATE_KNOWN;
        } else {
            outside += 1;
        }
    }
    Ok(Resampled {
        cells,
        e_list,
        outside,
        free,
        covered,
    })
}

/// The rows `r0..r1` and columns `c0..c1` of ground-truth cells, a box of its grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CellBox {
    pub r0: usize,
    pub r1: usize,
    pub c0: usize,
    pub c1: usize,
}

impl CellBox {
    /// The box clipped to a `h x w` grid (empty when it lies outside).
    pub fn clip(self, h: usize, w: usize) -> CellBox {
        let (r1, c1) = (self.r1.min(h), self.c1.min(w));
        CellBox {
            r0: self.r0.min(r1),
            r1,
            c0: self.c0.min(c1),
            c1,
        }
    }

    pub fn height(&self) -> usize {
        self.r1 - self.r0
    }

    pub fn width(&self) -> usize {
        self.c1 - self.c0
    }

    /// The index in the box of the grid cell `i` (row-major, `w` columns), when it is in.
    #[inline]
    pub fn index(&self, i: usize, w: usize) -> Option<usize> {
        let (r, c) = (i / w, i % w);
        (r >= self.r0 && r < self.r1 && c >= self.c0 && c < self.c1)
            .then(|| (r - self.r0) * self.width() + (c - self.c0))
    }
}

/// [`resample`]'s flags of the cells of `b` alone ([`flag::ESTIMATE`] only where the
/// estimate cell holding a cell's centre is occupied: the caller marks the cells only the
/// estimate's points mark). Each cell's estimate position is [`resample`]'s own: row
/// start plus `c` column steps in 32.32 fixed point, which [`resample_sparse`] has checked
/// cannot saturate (call it only when that one gave its counts). `g_list`: the ground
/// truth's walls (row-major indices).
pub(super) fn resample_box(
    est: &Placed,
    ground_truth: &Placed,
    b: CellBox,
    g_list: &[u32],
    t: &Se2,
    occ: &[bool; 256],
) -> Result<Vec<u8>, Error> {
    let gt = &ground_truth.frame;
    let gu = ground_truth.grid.unknown;
    let w = gt.width;
    let (bh, bw) = (b.height(), b.width());
    let mut cells = filled(bh * bw, 0u8)?;
    if bw == 0 {
        return Ok(cells);
    }
    // the walls in the box, row-major as the cells are visited
    let mut g_box = filled(bh * bw, false)?;
    for &i in g_list {
        if let Some(k) = b.index(i as usize, w) {
            g_box[k] = true;
        }
    }
    let m = gt_to_estimate(gt, &est.frame, t);
    let (eh, ew) = (est.grid.height as i64, est.grid.width as i64);
    let eg = &est.grid;
    let (sr, sc) = (fixed(m.m[0][1]), fixed(m.m[1][1]));
    cells
        .par_chunks_mut(BAND_ROWS * bw)
        .zip(g_box.par_chunks(BAND_ROWS * bw))
        .enumerate()
        .for_each(|(k, (chunk, g_band))| {
            for (j, (row, g_row)) in chunk.chunks_mut(bw).zip(g_band.chunks(bw)).enumerate() {
                let r = b.r0 + k * BAND_ROWS + j;
                let (er0, ec0) = m.apply(r as f64, 0.0);
                // checked by resample_sparse: no step saturates, so c steps are one product
                let (mut er, mut ec) =
                    (fixed(er0) + b.c0 as i64 * sr, fixed(ec0) + b.c0 as i64 * sc);
                let un = &gu[r * w + b.c0..r * w + b.c1];
                for ((cell, &g), &u) in row.iter_mut().zip(g_row).zip(un) {
                    *cell = cell_flags(!u && !g, estimate_cell(eg, occ, eh, ew, er, ec));
                    er += sr;
                    ec += sc;
                }
            }
        });
    Ok(cells)
}
