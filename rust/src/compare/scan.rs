//! The one pass over a map's cells that [`super::compare`] starts with: its occupied cells
//! (row-major), and per 8 x 8 block how many cells are known; SIMD (SSE2, AVX2) and
//! scalar copies of the block scan give the same counts. Also the row / column of
//! row-major indices and the fallible cell lists the other passes share.

use crate::edt::{filled, EdtError};
use crate::error::Error;
use crate::grid::{bytes, word, Grid, BAND_ROWS, ONES};
use rayon::prelude::*;

/// Row and column of row-major indices of a grid `w` wide, with no division while the
/// indices stay in one row (ascending lists); any index is answered exactly.
#[derive(Clone, Copy)]
pub(super) struct RowCol {
    w: usize,
    row: usize,
    start: usize,
    end: usize,
}

impl RowCol {
    pub(super) fn new(w: usize) -> Self {
        RowCol {
            w,
            row: 0,
            start: 0,
            end: 0,
        }
    }

    #[inline]
    pub(super) fn get(&mut self, i: usize) -> (usize, usize) {
        if i < self.start || i >= self.end {
            self.row = i / self.w.max(1);
            self.start = self.row * self.w;
            self.end = self.start + self.w;
        }
        (self.row, i - self.start)
    }
}

/// Side of the square blocks [`Scan::known`] counts over.
pub(super) const BLOCK: usize = 8;

/// One pass over a grid: its occupied cells and, per block of [`BLOCK`] x [`BLOCK`] cells,
/// how many are known.
pub(super) struct Scan {
    /// Occupied cells, row-major indices, ascending.
    pub(super) cells: Vec<u32>,
    /// Known cells per block, row-major over the blocks (`blocks_wide` per block row).
    pub(super) known: Vec<u8>,
    pub(super) blocks_wide: usize,
    /// Known cells in all.
    pub(super) known_cells: u64,
}

impl Scan {
    /// The cells block `(bi, bj)` holds (fewer at the grid's lower and right edges).
    #[inline]
    pub(super) fn block_cells(&self, bi: usize, bj: usize, height: usize, width: usize) -> u8 {
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
pub(super) fn scan_avx2() -> bool {
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
pub(super) fn scan_block_scalar(
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
pub(super) fn scan_block_sse2(
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
pub(super) unsafe fn scan_block_avx2(
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
pub(super) fn scan(g: &Grid, occ: &[bool; 256]) -> Result<Scan, Error> {
    let (h, w) = (g.height, g.width);
    // occupied values are a prefix of 0..=255: p = (255 - v) / 255 falls as v grows
    let below = occ.iter().take_while(|&&o| o).count();
    if occ[below..].iter().any(|&o| o) {
        return Err(Error::Invalid(
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

/// An empty cell list with room for a whole band of `cells` (so that filling it never
/// allocates again), or [`EdtError::Alloc`].
pub(super) fn band_list(cells: usize) -> Result<Vec<u32>, EdtError> {
    let mut v = Vec::new();
    v.try_reserve_exact(cells).map_err(|_| EdtError::Alloc {
        bytes: cells.saturating_mul(4),
    })?;
    Ok(v)
}

/// The lists one after the other, in one buffer allocated fallibly.
pub(super) fn concat(parts: Vec<Vec<u32>>) -> Result<Vec<u32>, EdtError> {
    let n = parts.iter().map(Vec::len).sum();
    let mut out = band_list(n)?;
    for p in parts {
        out.extend(p);
    }
    Ok(out)
}
