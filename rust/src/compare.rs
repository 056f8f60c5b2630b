//! A map against a ground-truth map (SPEC section 7): align the estimate (frames from the
//! map files, refined by trimmed ICP), resample it onto the ground truth's grid, and count
//! what the figures need (matches within the tolerance, sums of distances, coverage).
//! Ratios and metres are formed by the caller from these.

use crate::edt::{filled, Columns, EdtError, NearestCell, Sparse};
use crate::grid::{bytes, word, Grid, BAND_ROWS, ONES};
use crate::icp::{icp, Occupied, Target};
use crate::params::{Align, CompareParams};
use crate::register::{register, RegisterError, RegisterParams};
use crate::se2::{floor_i64, Affine, Frame, Se2};
use rayon::prelude::*;
use std::fmt;

/// Bits of the per-cell flags [`Comparison::cells`] holds (one byte per ground-truth cell).
pub mod flag {
    /// The aligned estimate is occupied here (a cell of E).
    pub const ESTIMATE: u8 = 1;
    /// The ground truth is occupied here (a cell of G).
    pub const GROUND_TRUTH: u8 = 2;
    /// A cell of E within the tolerance of G (a matched estimate wall).
    pub const ESTIMATE_MATCHED: u8 = 4;
    /// A cell of G within the tolerance of E (a ground-truth wall the estimate has).
    pub const GROUND_TRUTH_MATCHED: u8 = 8;
    /// The aligned estimate knows this cell.
    pub const ESTIMATE_KNOWN: u8 = 16;
    /// The ground truth says this cell is free.
    pub const GROUND_TRUTH_FREE: u8 = 32;
}

/// One map and where its cells are.
#[derive(Clone, Copy, Debug)]
pub struct Placed<'a> {
    pub grid: Grid<'a>,
    pub frame: Frame,
}

/// Why two maps could not be compared.
#[derive(Debug, Clone, PartialEq)]
pub enum CompareError {
    /// A resolution that is not a positive finite number, a frame whose size differs from
    /// its grid's, or a parameter out of range.
    Invalid(String),
    /// The distance transform failed (size, memory).
    Edt(EdtError),
}

impl fmt::Display for CompareError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CompareError::Invalid(s) => f.write_str(s),
            CompareError::Edt(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for CompareError {}

impl From<EdtError> for CompareError {
    fn from(e: EdtError) -> Self {
        CompareError::Edt(e)
    }
}

/// The counts and sums of one comparison. Distances are in cells of the ground truth's
/// grid; E and G are the occupied cells of the aligned estimate and of the ground truth on
/// that grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    /// |E|, |G|.
    pub estimate_occupied: u64,
    pub ground_truth_occupied: u64,
    /// Cells of E within the tolerance of G; cells of G within the tolerance of E.
    pub estimate_matched: u64,
    pub ground_truth_matched: u64,
    /// |E n G|, |E u G|.
    pub intersection: u64,
    pub union: u64,
    /// Sum over E of d(e, G); sum over G of d(g, E) (each truncated at `max_distance`).
    pub sum_reverse: f64,
    pub sum_ne: f64,
    /// How many of those distances were truncated.
    pub truncated_reverse: u64,
    pub truncated_ne: u64,
    /// Free cells of the ground truth, and those the aligned estimate knows.
    pub ground_truth_free: u64,
    pub covered: u64,
    /// Occupied estimate cells whose centre, aligned, falls outside the ground truth's grid.
    pub outside: u64,
    /// The motion applied to the estimate's world frame.
    pub transform: Se2,
    /// The ICP's inlier RMS (metres), its iterations and kept pairs (NaN, 0, 0 without ICP).
    pub icp_rms: f64,
    pub icp_iterations: usize,
    pub icp_inliers: usize,
    /// Per ground-truth cell, the [`flag`] bits, when asked for.
    pub cells: Option<Vec<u8>>,
}

/// `occupied[v]`: a known cell of value `v` is occupied (`(255 - v) / 255 > threshold`).
fn occupied_table(threshold: f64) -> [bool; 256] {
    let mut t = [false; 256];
    for (v, o) in t.iter_mut().enumerate() {
        *o = (255 - v) as f64 / 255.0 > threshold;
    }
    t
}

fn check(p: &Placed, what: &str) -> Result<(), CompareError> {
    let f = &p.frame;
    let ok = f.resolution.is_finite()
        && f.resolution > 0.0
        && f.origin.theta.is_finite()
        && f.origin.tx.is_finite()
        && f.origin.ty.is_finite();
    if !ok {
        return Err(CompareError::Invalid(format!(
            "{what}: resolution must be positive and origin finite"
        )));
    }
    if f.height != p.grid.height || f.width != p.grid.width {
        return Err(CompareError::Invalid(format!(
            "{what}: frame size differs from the grid's"
        )));
    }
    Ok(())
}

fn check_params(p: &CompareParams) -> Result<(), CompareError> {
    let ok = p.tolerance.is_finite()
        && p.tolerance >= 0.0
        && p.occupied_threshold.is_finite()
        && (0.0..1.0).contains(&p.occupied_threshold)
        && p.max_distance.is_none_or(|m| m.is_finite() && m > 0.0)
        && (0.0..1.0).contains(&p.trim);
    if ok {
        Ok(())
    } else {
        Err(CompareError::Invalid(format!(
            "comparison parameters out of range: {p:?}"
        )))
    }
}

/// Row and column of row-major indices of a grid `w` wide, with no division while the
/// indices stay in one row (ascending lists); any index is answered exactly.
#[derive(Clone, Copy)]
struct RowCol {
    w: usize,
    row: usize,
    start: usize,
    end: usize,
}

impl RowCol {
    fn new(w: usize) -> Self {
        RowCol {
            w,
            row: 0,
            start: 0,
            end: 0,
        }
    }

    #[inline]
    fn get(&mut self, i: usize) -> (usize, usize) {
        if i < self.start || i >= self.end {
            self.row = i / self.w.max(1);
            self.start = self.row * self.w;
            self.end = self.start + self.w;
        }
        (self.row, i - self.start)
    }
}

/// World centres of the cells `cells` (row-major indices) of `p`.
fn occupied_points(p: &Placed, cells: &[u32]) -> Result<Vec<(f64, f64)>, CompareError> {
    let w = p.grid.width;
    let mut pts: Vec<(f64, f64)> = Vec::new();
    pts.try_reserve_exact(cells.len())
        .map_err(|_| EdtError::Alloc {
            bytes: cells.len().saturating_mul(16),
        })?;
    let to_world = p.frame.cell_to_world();
    let mut at = RowCol::new(w);
    pts.extend(cells.iter().map(|&i| {
        let (r, c) = at.get(i as usize);
        to_world.apply(r as f64, c as f64)
    }));
    Ok(pts)
}

/// Side of the square blocks [`Scan::known`] counts over.
const BLOCK: usize = 8;

/// One pass over a grid: its occupied cells and, per block of [`BLOCK`] x [`BLOCK`] cells,
/// how many are known.
struct Scan {
    /// Occupied cells, row-major indices, ascending.
    cells: Vec<u32>,
    /// Known cells per block, row-major over the blocks (`blocks_wide` per block row).
    known: Vec<u8>,
    blocks_wide: usize,
    /// Known cells in all.
    known_cells: u64,
}

impl Scan {
    /// The cells block `(bi, bj)` holds (fewer at the grid's lower and right edges).
    #[inline]
    fn block_cells(&self, bi: usize, bj: usize, height: usize, width: usize) -> u8 {
        let rows = (height - bi * BLOCK).min(BLOCK);
        let cols = (width - bj * BLOCK).min(BLOCK);
        (rows * cols) as u8
    }
}

/// Whether a byte of a word is below `n`: exact for `n <= 128` by the carry trick, larger
/// `n` byte by byte.
#[derive(Clone, Copy)]
struct Less {
    n: usize,
    sub: u64,
}

impl Less {
    fn new(n: usize) -> Self {
        Less {
            n,
            sub: ONES.wrapping_mul(n as u64),
        }
    }

    #[inline]
    fn any(self, x: u64) -> bool {
        if self.n <= 128 {
            (x.wrapping_sub(self.sub) & !x & (ONES * 0x80)) != 0
        } else {
            x.to_le_bytes().iter().any(|&b| (b as usize) < self.n)
        }
    }
}

/// Append to `list` the cells `base + q` of the run `vals`/`unknown` (unknown flags as 0/1
/// bytes) that are known and occupied (value below `below`).
#[inline(never)]
fn push_run(
    list: &mut Vec<u32>,
    base: usize,
    vals: &[u8],
    unknown: &[u8],
    below: usize,
) -> Result<(), EdtError> {
    if list.len() + vals.len() > list.capacity() {
        list.try_reserve(list.capacity().max(1024))
            .map_err(|_| EdtError::Alloc {
                bytes: list.capacity().saturating_mul(8),
            })?;
    }
    for (q, (&v, &u)) in vals.iter().zip(unknown).enumerate() {
        if u == 0 && (v as usize) < below {
            list.push((base + q) as u32);
        }
    }
    Ok(())
}

/// One block row of [`scan`] (`n <= BLOCK` rows of width `w`, `base` the first cell's
/// index): append to `list` the known cells of `vals`/`unknown` (unknown flags as 0/1
/// bytes) with value below `below`, row by row; add the known cells of each block to
/// `krow`; returns the known cells. With `avx2` (which [`scan_avx2`] found) four blocks at
/// a time ([`scan_block_avx2`]), else SSE2 (every x86-64) two at a time
/// ([`scan_block_sse2`]), elsewhere [`scan_row_scalar`] row by row: the same lists and
/// counts.
#[allow(clippy::too_many_arguments)]
#[inline]
fn scan_block(
    avx2: bool,
    vals: &[u8],
    unknown: &[u8],
    w: usize,
    krow: &mut [u8],
    below: usize,
    list: &mut Vec<u32>,
    base: usize,
) -> Result<u64, EdtError> {
    #[cfg(target_arch = "x86_64")]
    {
        if avx2 {
            // SAFETY: the caller found AVX2 present
            unsafe { scan_block_avx2(vals, unknown, w, krow, below, list, base) }
        } else {
            scan_block_sse2(vals, unknown, w, krow, below, list, base)
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = avx2;
        scan_block_scalar(vals, unknown, w, krow, below, list, base)
    }
}

/// Whether [`scan_block`] may take its AVX2 path.
fn scan_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// [`scan_block`] row by row with [`scan_row_scalar`].
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
fn scan_block_scalar(
    vals: &[u8],
    unknown: &[u8],
    w: usize,
    krow: &mut [u8],
    below: usize,
    list: &mut Vec<u32>,
    base: usize,
) -> Result<u64, EdtError> {
    let mut known = 0u64;
    for (k, (vr, ur)) in vals.chunks(w).zip(unknown.chunks(w)).enumerate() {
        known += scan_row_scalar(vr, ur, krow, below, list, base + k * w)?;
    }
    Ok(known)
}

/// [`scan_row`] eight cells at once, in plain integer arithmetic.
fn scan_row_scalar(
    vals: &[u8],
    unknown: &[u8],
    krow: &mut [u8],
    below: usize,
    list: &mut Vec<u32>,
    base: usize,
) -> Result<u64, EdtError> {
    let less = Less::new(below);
    let (vs, us) = (vals.chunks_exact(BLOCK), unknown.chunks_exact(BLOCK));
    let (vt, ut) = (vs.remainder(), us.remainder());
    let mut known_row = 0u64;
    // eight cells at once: unknown flags are 0/1 bytes (their sum by one multiplication);
    // an unknown cell's value is taken as 255, never occupied here
    for (j, ((vc, uc), kc)) in vs.zip(us).zip(krow.iter_mut()).enumerate() {
        let u = word(uc);
        let n = BLOCK as u8 - (u.wrapping_mul(ONES) >> 56) as u8;
        *kc += n;
        known_row += n as u64;
        if less.any(word(vc) | (u * 0xFF)) {
            push_run(list, base + j * BLOCK, vc, uc, below)?;
        }
    }
    if !vt.is_empty() {
        let j = vals.len() / BLOCK;
        known_row += scan_tail(vt, ut, &mut krow[j], below, list, base + j * BLOCK)?;
    }
    Ok(known_row)
}

/// The last, short block of a row (fewer than [`BLOCK`] cells), cell by cell.
fn scan_tail(
    vt: &[u8],
    ut: &[u8],
    kc: &mut u8,
    below: usize,
    list: &mut Vec<u32>,
    base: usize,
) -> Result<u64, EdtError> {
    let (mut n, mut any) = (0u8, false);
    for (&v, &u) in vt.iter().zip(ut) {
        n += (u == 0) as u8;
        any |= u == 0 && (v as usize) < below;
    }
    *kc += n;
    if any {
        push_run(list, base, vt, ut, below)?;
    }
    Ok(n as u64)
}

/// Push `at + i` for every set bit `i` of `m`, in ascending order, growing `list` first
/// when it has room for fewer than 32 more cells (the widest mask).
#[inline(always)]
fn push_mask(list: &mut Vec<u32>, mut m: u32, at: usize) -> Result<(), EdtError> {
    if m == 0 {
        return Ok(());
    }
    if list.len() + 32 > list.capacity() {
        list.try_reserve(list.capacity().max(1024))
            .map_err(|_| EdtError::Alloc {
                bytes: list.capacity().saturating_mul(8),
            })?;
    }
    while m != 0 {
        list.push((at + m.trailing_zeros() as usize) as u32);
        m &= m - 1;
    }
    Ok(())
}

/// Sixteen cells of a row in SSE2: their unknown flags added bytewise to `acc`, and the
/// mask of the occupied known ones (`v <= top` unsigned, as `min(v, top) == v`, and
/// `u == 0`).
///
/// # Safety
///
/// `v` and `u` must each be readable for 16 bytes.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn pair_mask(
    v: *const u8,
    u: *const u8,
    top: std::arch::x86_64::__m128i,
    acc: &mut std::arch::x86_64::__m128i,
) -> u32 {
    use std::arch::x86_64::*;
    // SAFETY: the caller's contract; SSE2 is part of x86-64
    unsafe {
        let (v, u) = (_mm_loadu_si128(v.cast()), _mm_loadu_si128(u.cast()));
        *acc = _mm_add_epi8(*acc, u);
        let occ = _mm_and_si128(
            _mm_cmpeq_epi8(_mm_min_epu8(v, top), v),
            _mm_cmpeq_epi8(u, _mm_setzero_si128()),
        );
        _mm_movemask_epi8(occ) as u32
    }
}

/// [`scan_block`] sixteen cells (two blocks) at once in SSE2: the occupied known cells of
/// a row as a 16-bit mask (`v <= below - 1` unsigned, as `min(v, below - 1) == v`, and
/// `u == 0`) whose set bits are pushed; the unknown flags added bytewise over the block
/// row's rows (at most 8 a byte), then summed per block by one `psadbw`. The columns past
/// the last pair by [`scan_row_scalar`].
#[cfg(target_arch = "x86_64")]
fn scan_block_sse2(
    vals: &[u8],
    unknown: &[u8],
    w: usize,
    krow: &mut [u8],
    below: usize,
    list: &mut Vec<u32>,
    base: usize,
) -> Result<u64, EdtError> {
    use std::arch::x86_64::*;
    const PAIR: usize = 2 * BLOCK;
    let n = vals.len().min(unknown.len()) / w.max(1);
    let pairs = w / PAIR;
    let done = pairs * PAIR;
    let mut known = 0u64;
    // SAFETY: SSE2 is part of x86-64; every load reads 16 bytes at `k * w + q * 16` with
    // `k < n`, `q < pairs`, inside both slices (their common length is at least `n * w`)
    unsafe {
        let zero = _mm_setzero_si128();
        // below == 0: nothing is occupied (the mask is cleared by `keep`)
        let top = _mm_set1_epi8(below.saturating_sub(1).min(255) as u8 as i8);
        let keep: u32 = if below == 0 { 0 } else { 0xFFFF };
        let mut acc = [zero; 8];
        let mut acc_big: Vec<__m128i> = Vec::new();
        let acc: &mut [__m128i] = if pairs <= acc.len() {
            &mut acc[..pairs]
        } else {
            acc_big.resize(pairs, zero);
            &mut acc_big
        };
        for k in 0..n {
            let (vr, ur) = (vals.as_ptr().add(k * w), unknown.as_ptr().add(k * w));
            let row_base = base + k * w;
            for (q, a) in acc.iter_mut().enumerate() {
                let m = pair_mask(vr.add(q * PAIR), ur.add(q * PAIR), top, a) & keep;
                push_mask(list, m, row_base + q * PAIR)?;
            }
            if done < w {
                known += scan_row_scalar(
                    &vals[k * w + done..(k + 1) * w],
                    &unknown[k * w + done..(k + 1) * w],
                    &mut krow[done / BLOCK..],
                    below,
                    list,
                    row_base + done,
                )?;
            }
        }
        let cells = (n * BLOCK) as u8;
        for (q, a) in acc.iter().enumerate() {
            let sad = _mm_sad_epu8(*a, zero);
            let (u0, u1) = (
                _mm_cvtsi128_si32(sad) as u8,
                _mm_extract_epi16::<4>(sad) as u8,
            );
            krow[2 * q] += cells - u0;
            krow[2 * q + 1] += cells - u1;
            known += 2 * cells as u64 - u0 as u64 - u1 as u64;
        }
    }
    Ok(known)
}

/// [`scan_block_sse2`] with AVX2: thirty-two cells (four blocks) at once, the same masks
/// and bytewise sums (one `vpsadbw` per four blocks at the block row's end); the rest of a
/// row by one SSE2 pair when 16 columns or more remain, then [`scan_row_scalar`].
///
/// # Safety
///
/// AVX2 must be present.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn scan_block_avx2(
    vals: &[u8],
    unknown: &[u8],
    w: usize,
    krow: &mut [u8],
    below: usize,
    list: &mut Vec<u32>,
    base: usize,
) -> Result<u64, EdtError> {
    use std::arch::x86_64::*;
    const QUAD: usize = 4 * BLOCK;
    const PAIR: usize = 2 * BLOCK;
    let n = vals.len().min(unknown.len()) / w.max(1);
    let quads = w / QUAD;
    let pair = w - quads * QUAD >= PAIR;
    let done = quads * QUAD + if pair { PAIR } else { 0 };
    let mut known = 0u64;
    // SAFETY: AVX2 (so SSE2) is present (the caller's contract); every load reads 32 bytes
    // at `k * w + q * 32` with `q < quads`, or 16 at `k * w + quads * 32` when `pair`,
    // with `k < n`: inside both slices (their common length is at least `n * w`)
    unsafe {
        let zero = _mm256_setzero_si256();
        let top = _mm256_set1_epi8(below.saturating_sub(1).min(255) as u8 as i8);
        let (zero1, top1) = (_mm_setzero_si128(), _mm256_castsi256_si128(top));
        // below == 0: nothing is occupied (the masks are cleared by `keep`)
        let keep: u32 = if below == 0 { 0 } else { u32::MAX };
        let mut acc = [zero; 64];
        let mut acc_big: Vec<__m256i> = Vec::new();
        let acc: &mut [__m256i] = if quads <= acc.len() {
            &mut acc[..quads]
        } else {
            acc_big.resize(quads, zero);
            &mut acc_big
        };
        let mut acc1 = zero1;
        for k in 0..n {
            let (vr, ur) = (vals.as_ptr().add(k * w), unknown.as_ptr().add(k * w));
            let row_base = base + k * w;
            for (q, a) in acc.iter_mut().enumerate() {
                let v = _mm256_loadu_si256(vr.add(q * QUAD).cast());
                let u = _mm256_loadu_si256(ur.add(q * QUAD).cast());
                *a = _mm256_add_epi8(*a, u);
                let occ = _mm256_and_si256(
                    _mm256_cmpeq_epi8(_mm256_min_epu8(v, top), v),
                    _mm256_cmpeq_epi8(u, zero),
                );
                let m = _mm256_movemask_epi8(occ) as u32 & keep;
                push_mask(list, m, row_base + q * QUAD)?;
            }
            if pair {
                let at = quads * QUAD;
                let m = pair_mask(vr.add(at), ur.add(at), top1, &mut acc1) & keep;
                push_mask(list, m, row_base + at)?;
            }
            if done < w {
                known += scan_row_scalar(
                    &vals[k * w + done..(k + 1) * w],
                    &unknown[k * w + done..(k + 1) * w],
                    &mut krow[done / BLOCK..],
                    below,
                    list,
                    row_base + done,
                )?;
            }
        }
        let cells = (n * BLOCK) as u8;
        for (q, a) in acc.iter().enumerate() {
            let mut sums = [0u64; 4];
            _mm256_storeu_si256(sums.as_mut_ptr().cast(), _mm256_sad_epu8(*a, zero));
            for (j, &u) in sums.iter().enumerate() {
                krow[4 * q + j] += cells - u as u8;
                known += cells as u64 - u;
            }
        }
        if pair {
            let sad = _mm_sad_epu8(acc1, zero1);
            let (u0, u1) = (
                _mm_cvtsi128_si32(sad) as u8,
                _mm_extract_epi16::<4>(sad) as u8,
            );
            let q = quads * 4;
            krow[q] += cells - u0;
            krow[q + 1] += cells - u1;
            known += 2 * cells as u64 - u0 as u64 - u1 as u64;
        }
    }
    Ok(known)
}

/// [`Scan`] of grid `g`, occupied meaning `occ[value]` for a known cell. Bands of rows in
/// parallel, their lists joined in order.
fn scan(g: &Grid, occ: &[bool; 256]) -> Result<Scan, CompareError> {
    let (h, w) = (g.height, g.width);
    // occupied values are a prefix of 0..=255: p = (255 - v) / 255 falls as v grows
    let below = occ.iter().take_while(|&&o| o).count();
    if occ[below..].iter().any(|&o| o) {
        return Err(CompareError::Invalid(
            "occupied values are not a prefix of 0..=255".into(),
        ));
    }
    let bw = w.div_ceil(BLOCK);
    let mut known = filled(h.div_ceil(BLOCK) * bw, 0u8)?;
    let band = BAND_ROWS * w;
    let avx2 = scan_avx2();
    let parts: Vec<(Vec<u32>, u64)> = known
        .par_chunks_mut((BAND_ROWS / BLOCK) * bw)
        .zip(g.values.par_chunks(band).zip(g.unknown.par_chunks(band)))
        .enumerate()
        .map(|(b, (kn, (vals, unk)))| {
            let mut list = Vec::new();
            let mut total = 0u64;
            let rows = BLOCK * w;
            for (k, (vb, ub)) in vals.chunks(rows).zip(unk.chunks(rows)).enumerate() {
                let r = b * BAND_ROWS + k * BLOCK;
                let krow = &mut kn[k * bw..(k + 1) * bw];
                total += scan_block(avx2, vb, bytes(ub), w, krow, below, &mut list, r * w)?;
            }
            Ok((list, total))
        })
        .collect::<Result<_, EdtError>>()?;
    let known_cells = parts.iter().map(|p| p.1).sum();
    let cells = concat(parts.into_iter().map(|p| p.0).collect())?;
    Ok(Scan {
        cells,
        known,
        blocks_wide: bw,
        known_cells,
    })
}

/// The motion aligning the estimate, with the ICP's RMS, iterations and inliers.
/// `Align::Search` starts the ICP from the global registration of the estimate onto the
/// ground truth (SPEC section 7a; its transform even when it refuses, the identity when it
/// found no candidate).
fn align(
    points: &[(f64, f64)],
    est: &Placed,
    gt: &Placed,
    g_columns: &dyn NearestCell,
    g_bits: &Sparse,
    g_list: &[u32],
    params: &CompareParams,
) -> Result<(Se2, f64, usize, usize), CompareError> {
    if params.align == Align::Origin {
        return Ok((Se2::IDENTITY, f64::NAN, 0, 0));
    }
    let target = Target::with(gt.frame, g_columns, Occupied::Bits(g_bits), g_list)?;
    let start = match params.align {
        Align::Origin => Se2::IDENTITY,
        Align::Icp => Se2::IDENTITY,
        Align::Search => {
            let p = RegisterParams {
                occupied_threshold: params.occupied_threshold,
                trim: params.trim,
                ..RegisterParams::default()
            };
            register(est, gt, &p)
                .map_err(|e| match e {
                    RegisterError::Invalid(s) => CompareError::Invalid(s),
                    RegisterError::Edt(e) => CompareError::Edt(e),
                })?
                .transform
        }
    };
    Ok(
        match icp(points, &target, start, params.trim, params.max_iterations) {
            Some(r) => (r.transform, r.rms, r.iterations, r.inliers),
            None => (start, f64::NAN, 0, 0),
        },
    )
}

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
struct Resampled {
    cells: Vec<u8>,
    /// The cells of E: row-major as the resampling finds them, then those only the
    /// occupied estimate cells' centres mark, in the estimate's row-major order.
    e_list: Vec<u32>,
    /// Occupied estimate cells whose centre falls outside the ground truth's grid.
    outside: u64,
    /// The ground truth's free cells, and those the estimate knows.
    free: u64,
    covered: u64,
}

/// `x` in 32.32 fixed point (saturating: positions far outside any grid stay outside).
#[inline]
fn fixed(x: f64) -> i64 {
    (x * 4294967296.0).round() as i64
}

/// What the figures need of the resampling: the cells of E (in [`Resampled::e_list`]'s
/// order), `outside`, the ground truth's free cells and those the estimate knows.
struct Sampled {
    e_list: Vec<u32>,
    outside: u64,
    free: u64,
    covered: u64,
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
fn resample_sparse(
    est: &Placed,
    ground_truth: &Placed,
    g_scan: &Scan,
    g_near: &Sparse,
    e_scan: &Scan,
    t: &Se2,
    points: &[(f64, f64)],
) -> Result<Option<Sampled>, CompareError> {
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

fn resample(
    est: &Placed,
    ground_truth: &Placed,
    g_mask: &[bool],
    t: &Se2,
    occ: &[bool; 256],
    points: &[(f64, f64)],
) -> Result<Resampled, CompareError> {
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
                    let (ir, ic) = (er >> 32, ec >> 32);
                    let is_free = !u && !g;
                    let mut f = (is_free as u8) * flag::GROUND_TRUTH_FREE;
                    if ir >= 0 && ic >= 0 && ir < eh && ic < ew {
                        let i = ir as usize * eg.width + ic as usize;
                        if !eg.unknown[i] {
                            let occupied = occ[eg.values[i] as usize];
                            f |= flag::ESTIMATE_KNOWN | ((occupied as u8) * flag::ESTIMATE);
                            covered += is_free as u64;
                            if occupied {
                                list.push((r * w + c) as u32);
                            }
                        }
                    }
                    free += is_free as u64;
                    *cell = f;
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

/// An empty cell list with room for a whole band of `cells` (so that filling it never
/// allocates again), or [`EdtError::Alloc`].
fn band_list(cells: usize) -> Result<Vec<u32>, EdtError> {
    let mut v = Vec::new();
    v.try_reserve_exact(cells).map_err(|_| EdtError::Alloc {
        bytes: cells.saturating_mul(4),
    })?;
    Ok(v)
}

/// The lists one after the other, in one buffer allocated fallibly.
fn concat(parts: Vec<Vec<u32>>) -> Result<Vec<u32>, EdtError> {
    let n = parts.iter().map(Vec::len).sum();
    let mut out = band_list(n)?;
    for p in parts {
        out.extend(p);
    }
    Ok(out)
}

/// Per-chunk partial sums of one side (E or G), summed in chunk order.
#[derive(Clone, Copy, Default)]
struct Side {
    matched: u64,
    sum: f64,
    truncated: u64,
    /// Cells that are also cells of the other map (for E: |E n G|).
    both: u64,
}

/// The other map of [`side`]'s distances: its set cells' bits, or its column pass when the
/// queries are far from them (both give the same distances).
enum Other<'a> {
    Sparse(&'a Sparse),
    Columns(&'a Columns),
}

/// Queries of [`Sparse`] cost a few times what those of [`Columns`] do once its column
/// pass is made: past this many columns looked at per grid cell (estimated from a sample of
/// the queries), the pass is made.
const DENSE_VISITS_PER_CELL: f64 = 0.3;
/// Queries in that sample.
const SAMPLE: usize = 256;

/// How [`side`] should query `near` for the cells of `list`: by the bits, or (queries far
/// from its cells, e.g. maps far apart) by a column pass made here. The choice changes no
/// result, only the time.
fn plan(near: &Sparse, list: &[u32]) -> Result<Option<Columns>, EdtError> {
    let (h, w) = (near.height, near.width);
    if list.is_empty() {
        return Ok(None);
    }
    let stride = list.len().div_ceil(SAMPLE).max(1);
    let (mut asked, mut visits) = (0usize, 0usize);
    for &i in list.iter().step_by(stride) {
        let i = i as usize;
        visits += near.distance(i / w, i % w).1;
        asked += 1;
    }
    let expected = visits as f64 / asked as f64 * list.len() as f64;
    if expected <= DENSE_VISITS_PER_CELL * (h * w) as f64 {
        return Ok(None);
    }
    near.columns().map(Some)
}

/// For every cell of `list`, its distance to the other map (queries of `other`): matches
/// within `tol2`, the sum of distances (truncated at `max`), how many cells `also` (given
/// row and column) holds for, and (when `want`) the matched flag of every cell.
fn side(
    list: &[u32],
    other: Other,
    tol2: f64,
    max: Option<f64>,
    also: impl Fn(usize, usize) -> bool + Sync,
    want: bool,
) -> (Side, Vec<bool>) {
    const CHUNK: usize = 4096;
    let w = match other {
        Other::Sparse(s) => s.width,
        Other::Columns(c) => c.width,
    };
    let parts: Vec<(Side, Vec<bool>)> = list
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut s = Side::default();
            let mut matched = Vec::with_capacity(if want { chunk.len() } else { 0 });
            let mut at = RowCol::new(w);
            for &i in chunk {
                let i = i as usize;
                let (r, c) = at.get(i);
                let sq = match other {
                    Other::Sparse(near) => near.distance(r, c).0,
                    Other::Columns(cols) => cols.distance(r, c),
                }
                .unwrap_or(u32::MAX);
                let ok = sq != u32::MAX && sq as f64 <= tol2;
                s.matched += ok as u64;
                let (d, t) = distance(sq, max);
                s.sum += d;
                s.truncated += t as u64;
                s.both += also(r, c) as u64;
                if want {
                    matched.push(ok);
                }
            }
            (s, matched)
        })
        .collect();
    let mut total = Side::default();
    let mut matched = Vec::new();
    for (s, m) in parts {
        total.matched += s.matched;
        total.sum += s.sum;
        total.truncated += s.truncated;
        total.both += s.both;
        matched.extend(m);
    }
    (total, matched)
}

/// A distance (cells) from a squared one, truncated; and whether it was.
#[inline]
fn distance(sq: u32, max: Option<f64>) -> (f64, bool) {
    let d = if sq == u32::MAX {
        f64::INFINITY
    } else {
        (sq as f64).sqrt()
    };
    match max {
        Some(m) if d > m => (m, true),
        _ => (d, false),
    }
}

/// Compare an estimate with a ground truth (SPEC section 7). `want_cells` keeps the per-cell
/// [`flag`] bits (for overlays).
pub fn compare(
    estimate: &Placed,
    ground_truth: &Placed,
    params: &CompareParams,
    want_cells: bool,
) -> Result<Comparison, CompareError> {
    check(estimate, "estimate")?;
    check(ground_truth, "ground truth")?;
    check_params(params)?;
    let occ = occupied_table(params.occupied_threshold);
    let gt = &ground_truth.grid;
    let (h, w) = (gt.height, gt.width);
    // G (and how many cells of each block of the ground truth are known), the estimate's
    // occupied cells
    let g_scan = scan(gt, &occ)?;
    let e_scan = scan(&estimate.grid, &occ)?;
    // nearest-cell queries of G (ICP correspondences, d(e, G))
    let g_near = Sparse::new(&g_scan.cells, h, w)?;
    let g_list = &g_scan.cells;
    let points = occupied_points(estimate, &e_scan.cells)?;
    // the ICP asks the nearest cell of G many times: its column pass pays off there
    let g_columns = if params.align != Align::Origin {
        Some(g_near.columns()?)
    } else {
        None
    };
    let (transform, icp_rms, icp_iterations, icp_inliers) = match &g_columns {
        Some(cols) => align(
            &points,
            estimate,
            ground_truth,
            cols,
            &g_near,
            g_list,
            params,
        )?,
        None => (Se2::IDENTITY, f64::NAN, 0, 0),
    };
    let sparse = if want_cells {
        None
    } else {
        resample_sparse(
            estimate,
            ground_truth,
            &g_scan,
            &g_near,
            &e_scan,
            &transform,
            &points,
        )?
    };
    let (mut cells, res) = match sparse {
        Some(r) => (Vec::new(), r),
        None => {
            // the literal resampling: with the cells, or when the sparse one cannot place
            // the frames in its fixed point (frames far apart); it reads G as a mask
            let mut g_mask = filled(h * w, false)?;
            for &i in g_list {
                g_mask[i as usize] = true;
            }
            let r = resample(estimate, ground_truth, &g_mask, &transform, &occ, &points)?;
            (
                r.cells,
                Sampled {
                    e_list: r.e_list,
                    outside: r.outside,
                    free: r.free,
                    covered: r.covered,
                },
            )
        }
    };
    drop(points);
    let e_list = res.e_list;
    let e_near = Sparse::new(&e_list, h, w)?;
    let e_columns = plan(&e_near, g_list)?;
    let g_far = match g_columns {
        Some(_) => None,
        None => plan(&g_near, &e_list)?,
    };
    let tol2 = params.tolerance * params.tolerance;
    let max = params.max_distance;
    let e_other = match &e_columns {
        Some(c) => Other::Columns(c),
        None => Other::Sparse(&e_near),
    };
    let (gs, g_matched) = side(g_list, e_other, tol2, max, |_, _| false, want_cells);
    let g_other = match (&g_columns, &g_far) {
        (Some(c), _) | (None, Some(c)) => Other::Columns(c),
        (None, None) => Other::Sparse(&g_near),
    };
    let (es, e_matched) = side(
        &e_list,
        g_other,
        tol2,
        max,
        |r, c| g_near.get(r, c),
        want_cells,
    );
    if want_cells {
        for (&i, &m) in g_list.iter().zip(&g_matched) {
            cells[i as usize] |= flag::GROUND_TRUTH | ((m as u8) * flag::GROUND_TRUTH_MATCHED);
        }
        for (&i, &m) in e_list.iter().zip(&e_matched) {
            cells[i as usize] |= (m as u8) * flag::ESTIMATE_MATCHED;
        }
    }
    let (e, g) = (e_list.len() as u64, g_list.len() as u64);
    Ok(Comparison {
        estimate_occupied: e,
        ground_truth_occupied: g,
        estimate_matched: es.matched,
        ground_truth_matched: gs.matched,
        intersection: es.both,
        union: e + g - es.both,
        sum_reverse: es.sum,
        sum_ne: gs.sum,
        truncated_reverse: es.truncated,
        truncated_ne: gs.truncated,
        ground_truth_free: res.free,
        covered: res.covered,
        outside: res.outside,
        transform,
        icp_rms,
        icp_iterations,
        icp_inliers,
        cells: want_cells.then_some(cells),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::edt::tests::rng;

    /// A `h x w` map, free everywhere, with walls where `wall(r, c)`; unknown outside
    /// `known(r, c)`.
    fn map(
        h: usize,
        w: usize,
        wall: impl Fn(usize, usize) -> bool,
        known: impl Fn(usize, usize) -> bool,
    ) -> (Vec<u8>, Vec<bool>) {
        let mut v = vec![254u8; h * w];
        let mut u = vec![false; h * w];
        for r in 0..h {
            for c in 0..w {
                if wall(r, c) {
                    v[r * w + c] = 0;
                }
                u[r * w + c] = !known(r, c);
            }
        }
        (v, u)
    }

    fn frame(h: usize, w: usize, res: f64, origin: Se2) -> Frame {
        Frame {
            resolution: res,
            height: h,
            width: w,
            origin,
        }
    }

    /// Walls of a building: the outline and a few inner walls with doors, plus a pillar.
    fn building(r: usize, c: usize) -> bool {
        let outer = r == 10 || r == 110 || c == 10 || c == 150;
        let inner = (c == 70 && !(40..50).contains(&r)) || (r == 60 && c < 70 && c > 30);
        let pillar = (85..90).contains(&r) && (110..115).contains(&c);
        ((10..=110).contains(&r) && (10..=150).contains(&c)) && (outer || inner || pillar)
    }

    #[test]
    fn identical_maps_match_perfectly() {
        let (h, w) = (120, 160);
        let (v, u) = map(h, w, building, |_, _| true);
        let g = Grid::new(&v, &u, h, w).unwrap();
        let f = frame(h, w, 0.05, Se2::IDENTITY);
        let p = Placed { grid: g, frame: f };
        for align in [Align::Origin, Align::Icp] {
            let params = CompareParams {
                align,
                ..Default::default()
            };
            let c = compare(&p, &p, &params, true).unwrap();
            assert_eq!(c.estimate_occupied, c.ground_truth_occupied);
            assert_eq!(c.intersection, c.union);
            assert_eq!(c.estimate_matched, c.estimate_occupied);
            assert_eq!(c.sum_ne, 0.0);
            assert_eq!(c.sum_reverse, 0.0);
            assert!(c.transform.theta.abs() < 1e-12);
            assert!(c.transform.tx.abs() < 1e-12 && c.transform.ty.abs() < 1e-12);
            assert_eq!(c.covered, c.ground_truth_free);
            assert_eq!(c.outside, 0);
        }
    }

    /// The building compared with itself, its ground-truth copy's frame moved by `moved`.
    fn compare_moved(moved: Se2, params: &CompareParams) -> Comparison {
        let (h, w) = (120, 160);
        let (v, u) = map(h, w, building, |_, _| true);
        let g = Grid::new(&v, &u, h, w).unwrap();
        let est = Placed {
            grid: g,
            frame: frame(h, w, 0.05, Se2::IDENTITY),
        };
        let gt = Placed {
            grid: g,
            frame: frame(h, w, 0.05, moved),
        };
        compare(&est, &gt, params, false).unwrap()
    }

    #[test]
    fn recovers_a_known_motion() {
        // the ground truth's frame is moved: the estimate must follow it back
        let moved = Se2 {
            theta: 3f64.to_radians(),
            tx: 0.3,
            ty: -0.2,
        };
        let c = compare_moved(moved, &CompareParams::default());
        let t = c.transform;
        assert!((t.theta - moved.theta).abs() < 0.5f64.to_radians(), "{t:?}");
        assert!(
            (t.tx - moved.tx).abs() < 0.05 && (t.ty - moved.ty).abs() < 0.05,
            "{t:?}"
        );
        let o = compare_moved(
            moved,
            &CompareParams {
                align: Align::Origin,
                ..Default::default()
            },
        );
        assert!(c.sum_reverse < o.sum_reverse / 4.0);
    }

    #[test]
    fn search_finds_a_large_rotation() {
        let moved = Se2 {
            theta: 97f64.to_radians(),
            tx: 5.0,
            ty: 1.0,
        };
        let p = CompareParams {
            align: Align::Search,
            ..Default::default()
        };
        let c = compare_moved(moved, &p);
        assert!((c.transform.theta - moved.theta).abs() < 0.5f64.to_radians());
        assert_eq!(c.estimate_matched, c.estimate_occupied);
    }

    #[test]
    fn missing_and_doubled_walls() {
        let (h, w) = (120, 160);
        let (gv, gu) = map(h, w, building, |_, _| true);
        let f = frame(h, w, 0.05, Se2::IDENTITY);
        let gt = Placed {
            grid: Grid::new(&gv, &gu, h, w).unwrap(),
            frame: f,
        };
        let p = CompareParams {
            align: Align::Origin,
            ..Default::default()
        };
        // missing: the inner wall at r == 60
        let (mv, mu) = map(h, w, |r, c| building(r, c) && r != 60, |_, _| true);
        let est = Placed {
            grid: Grid::new(&mv, &mu, h, w).unwrap(),
            frame: f,
        };
        let c = compare(&est, &gt, &p, false).unwrap();
        assert!(c.ground_truth_matched < c.ground_truth_occupied && c.sum_ne > 0.0);
        assert_eq!(c.sum_reverse, 0.0);
        assert_eq!(c.estimate_matched, c.estimate_occupied);
        // doubled: a copy of the wall at c == 150 at c == 140
        let (dv, du) = map(
            h,
            w,
            |r, c| building(r, c) || (c == 140 && (10..=110).contains(&r)),
            |_, _| true,
        );
        let est = Placed {
            grid: Grid::new(&dv, &du, h, w).unwrap(),
            frame: f,
        };
        let c = compare(&est, &gt, &p, false).unwrap();
        assert!(c.estimate_matched < c.estimate_occupied && c.sum_reverse > 0.0);
        assert_eq!(c.sum_ne, 0.0);
        // truncation bounds every distance
        let t = CompareParams {
            max_distance: Some(3.0),
            ..p
        };
        let c = compare(&est, &gt, &t, false).unwrap();
        assert!(c.truncated_reverse > 0 && c.sum_reverse <= 3.0 * c.estimate_occupied as f64);
    }

    #[test]
    fn scan_equals_a_literal_count() {
        let mut next = rng(31);
        for case in 0..60 {
            let (h, w) = (1 + (next() % 90) as usize, 1 + (next() % 150) as usize);
            let values: Vec<u8> = (0..h * w).map(|_| next() as u8).collect();
            let unknown: Vec<bool> = (0..h * w).map(|_| next() % 7 < case as u64 % 4).collect();
            let threshold = [0.0, 0.2, 0.5, 0.65, 0.9, 0.999][case % 6];
            let occ = occupied_table(threshold);
            let s = scan(&Grid::new(&values, &unknown, h, w).unwrap(), &occ).unwrap();
            let cells: Vec<u32> = (0..h * w)
                .filter(|&i| !unknown[i] && occ[values[i] as usize])
                .map(|i| i as u32)
                .collect();
            assert_eq!(s.cells, cells, "{h} x {w}");
            let bw = w.div_ceil(BLOCK);
            let mut known = vec![0u8; h.div_ceil(BLOCK) * bw];
            for i in 0..h * w {
                known[(i / w / BLOCK) * bw + (i % w) / BLOCK] += (!unknown[i]) as u8;
            }
            assert_eq!(s.known, known, "{h} x {w}");
            assert_eq!(
                s.known_cells,
                unknown.iter().filter(|&&u| !u).count() as u64
            );
        }
    }

    /// The SSE2 block-row scan gives the scalar rows' list and counts, on random block
    /// rows of 1-8 rows and every width to 70 (pairs of blocks, an odd block, a short
    /// tail), every threshold.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn scan_block_sse2_equals_scalar() {
        let mut next = rng(37);
        for case in 0..3000 {
            let w = 1 + case % 70;
            let n = 1 + (next() % 8) as usize;
            let below = [0usize, 1, 2, 77, 128, 129, 200, 255, 256][case % 9];
            let vals: Vec<u8> = (0..n * w).map(|_| next() as u8).collect();
            let unknown: Vec<u8> = (0..n * w)
                .map(|_| (next() % 5 < case as u64 % 3) as u8)
                .collect();
            let bw = w.div_ceil(BLOCK);
            let start: Vec<u8> = (0..bw).map(|_| (next() % 50) as u8).collect();
            let base = (next() % 1000) as usize;
            let (mut k1, mut k2) = (start.clone(), start.clone());
            let (mut l1, mut l2) = (vec![7u32], vec![7u32]);
            let n1 = scan_block_scalar(&vals, &unknown, w, &mut k1, below, &mut l1, base).unwrap();
            let n2 = scan_block_sse2(&vals, &unknown, w, &mut k2, below, &mut l2, base).unwrap();
            assert_eq!((n1, &k1, &l1), (n2, &k2, &l2), "w {w} n {n} below {below}");
        }
    }

    /// [`scan_block_avx2`] against the scalar rows: block rows of 1-8 rows, every width to
    /// 140 (quads of blocks, a pair, an odd block, a short tail) and some past the 64
    /// quads kept on the stack, every threshold.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn scan_block_avx2_equals_scalar() {
        if !scan_avx2() {
            return;
        }
        let mut next = rng(41);
        for case in 0..4000 {
            let w = if case % 100 == 99 {
                2040 + case % 70
            } else {
                1 + case % 140
            };
            let n = 1 + (next() % 8) as usize;
            let below = [0usize, 1, 2, 77, 128, 129, 200, 255, 256][case % 9];
            let vals: Vec<u8> = (0..n * w).map(|_| next() as u8).collect();
            let unknown: Vec<u8> = (0..n * w)
                .map(|_| (next() % 5 < case as u64 % 3) as u8)
                .collect();
            let bw = w.div_ceil(BLOCK);
            let start: Vec<u8> = (0..bw).map(|_| (next() % 50) as u8).collect();
            let base = (next() % 1000) as usize;
            let (mut k1, mut k2) = (start.clone(), start.clone());
            let (mut l1, mut l2) = (vec![7u32], vec![7u32]);
            let n1 = scan_block_scalar(&vals, &unknown, w, &mut k1, below, &mut l1, base).unwrap();
            // SAFETY: AVX2 is present (checked above)
            let n2 = unsafe { scan_block_avx2(&vals, &unknown, w, &mut k2, below, &mut l2, base) }
                .unwrap();
            assert_eq!((n1, &k1, &l1), (n2, &k2, &l2), "w {w} n {n} below {below}");
        }
    }

    #[test]
    fn row_col_equals_division() {
        let mut next = rng(43);
        for w in [1usize, 2, 7, 64, 1000] {
            let mut at = RowCol::new(w);
            // ascending runs, then jumps back and forth
            let mut i = 0usize;
            for k in 0..3000 {
                i = if k % 50 == 49 {
                    (next() % 100_000) as usize
                } else {
                    i + (next() % 5) as usize
                };
                assert_eq!(at.get(i), (i / w, i % w), "w {w} i {i}");
            }
        }
    }

    #[test]
    fn sparse_resampling_equals_the_literal_one() {
        let mut next = rng(23);
        let mut unit = move || (next() % 1_000_000) as f64 / 1_000_000.0;
        for case in 0..120 {
            let (h, w) = (
                40 + (unit() * 90.0) as usize,
                40 + (unit() * 120.0) as usize,
            );
            let (eh, ew) = (
                30 + (unit() * 100.0) as usize,
                30 + (unit() * 110.0) as usize,
            );
            let density = [0.0, 0.01, 0.05, 0.3][case % 4];
            let mut rand = (0..eh * ew).map(|_| unit()).collect::<Vec<_>>().into_iter();
            let (mut ev, mut eu) = map(eh, ew, building, |r, c| (r * 7 + c * 3) % 50 < 40);
            for i in 0..eh * ew {
                let x = rand.next().unwrap();
                if x < density {
                    ev[i] = (x * 2e4) as u8;
                }
                if case % 5 == 0 && i % 13 == 0 {
                    eu[i] = !eu[i];
                }
            }
            let (gv, mut gu) = map(h, w, building, |_, _| true);
            if case % 2 == 1 {
                for (i, u) in gu.iter_mut().enumerate() {
                    *u = (i / w) % 17 < 3;
                }
            }
            let est = Placed {
                grid: Grid::new(&ev, &eu, eh, ew).unwrap(),
                frame: frame(
                    eh,
                    ew,
                    [0.05, 0.04, 0.07, 0.2, 0.013][case % 5],
                    Se2 {
                        theta: (unit() - 0.5) * [0.1, 1.0, 6.0][case % 3],
                        tx: (unit() - 0.5) * 2.0,
                        ty: (unit() - 0.5) * 2.0,
                    },
                ),
            };
            let gt = Placed {
                grid: Grid::new(&gv, &gu, h, w).unwrap(),
                frame: frame(h, w, 0.05, Se2::IDENTITY),
            };
            let occ = occupied_table(0.5);
            let t = Se2 {
                theta: (unit() - 0.5) * 0.2,
                tx: (unit() - 0.5) * 0.5,
                ty: (unit() - 0.5) * 0.5,
            };
            let g_scan = scan(&gt.grid, &occ).unwrap();
            let e_scan = scan(&est.grid, &occ).unwrap();
            let g_mask: Vec<bool> = (0..h * w).map(|i| !gu[i] && occ[gv[i] as usize]).collect();
            let lit: Vec<u32> = (0..h * w)
                .filter(|&i| g_mask[i])
                .map(|i| i as u32)
                .collect();
            assert_eq!(g_scan.cells, lit);
            let points = occupied_points(&est, &e_scan.cells).unwrap();
            let g_near = Sparse::new(&g_scan.cells, h, w).unwrap();
            let want = resample(&est, &gt, &g_mask, &t, &occ, &points).unwrap();
            let got = resample_sparse(&est, &gt, &g_scan, &g_near, &e_scan, &t, &points)
                .unwrap()
                .unwrap();
            assert_eq!(got.e_list, want.e_list, "case {case}");
            assert_eq!(
                (got.outside, got.free, got.covered),
                (want.outside, want.free, want.covered),
                "case {case}"
            );
        }
    }

    /// Frames the sparse resampling cannot place in its fixed point (far apart, or grids
    /// whose cells differ by orders of magnitude) take the literal resampling: the same
    /// counts as with the per-cell flags. Without them it once read an empty mask of G:
    /// no free cell, coverage NaN.
    #[test]
    fn frames_far_apart_give_the_counts_of_the_cells_path() {
        let (h, w) = (120, 160);
        let (v, u) = map(h, w, building, |r, _| r < 90);
        let g = Grid::new(&v, &u, h, w).unwrap();
        let at = |tx: f64, ty: f64| Se2 { theta: 0.0, tx, ty };
        let cases = [
            (0.05, at(1e8, 0.0), 0.05),
            (0.05, at(-1e300, 3.0), 0.05),
            (0.05, at(3e7, -2e7), 0.05),
            // one estimate cell holds the whole ground truth (a 1e-6 m grid)
            (1000.0, at(-50_000.0, -50_000.0), 1e-6),
        ];
        for (k, &(res, origin, gt_res)) in cases.iter().enumerate() {
            let est = Placed {
                grid: g,
                frame: frame(h, w, res, origin),
            };
            let gt = Placed {
                grid: g,
                frame: frame(h, w, gt_res, Se2::IDENTITY),
            };
            for align in [Align::Origin, Align::Icp] {
                let p = CompareParams {
                    align,
                    ..Default::default()
                };
                let mut with = compare(&est, &gt, &p, true).unwrap();
                with.cells = None;
                let without = compare(&est, &gt, &p, false).unwrap();
                // (as text: an ICP that found nothing gives a NaN RMS on both)
                assert_eq!(
                    format!("{without:?}"),
                    format!("{with:?}"),
                    "case {k} {align:?}"
                );
                let free = u.iter().zip(&v).filter(|(&u, &v)| !u && v > 127).count();
                assert_eq!(with.ground_truth_free, free as u64, "case {k}");
            }
        }
    }

    #[test]
    fn same_result_for_any_thread_count() {
        let (h, w) = (120, 160);
        let (v, u) = map(h, w, building, |r, _| r < 90);
        let g = Grid::new(&v, &u, h, w).unwrap();
        let est = Placed {
            grid: g,
            frame: frame(h, w, 0.05, Se2::IDENTITY),
        };
        let gt = Placed {
            grid: g,
            frame: frame(
                h,
                w,
                0.04,
                Se2 {
                    theta: 0.03,
                    tx: 0.1,
                    ty: 0.2,
                },
            ),
        };
        let run = |t: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap()
                .install(|| compare(&est, &gt, &CompareParams::default(), true).unwrap())
        };
        assert_eq!(run(1), run(3));
        // without the per-cell flags (the sparse resampling): the same counts
        let mut with = run(1);
        with.cells = None;
        assert_eq!(
            compare(&est, &gt, &CompareParams::default(), false).unwrap(),
            with
        );
    }
}
