//! 8-connected component labelling of binary images, by runs.
//!
//! Each row is cut into runs of set cells; a union-find over runs joins runs of neighbouring
//! rows that touch (8-connectivity: their column ranges overlap or meet diagonally). Rows are
//! processed in fixed bands of [`BAND_ROWS`](crate::grid::BAND_ROWS) in parallel, then the
//! band seams are joined. Union is by smaller run index, so after one flattening pass every
//! run points straight at its root, and the component statistics (size, border contact) are
//! the same whatever the thread count.

use crate::grid::{bands, BAND_ROWS};
use rayon::prelude::*;

/// A run of set cells `[start, end)` in one row.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Run {
    pub start: u32,
    pub end: u32,
}

/// Where rows of a binary image come from.
pub trait RowSource: Sync {
    /// Row `r` as 0/1 bytes, either borrowed from the source or written into `buf`
    /// (`buf.len()` is the width).
    fn row<'b>(&'b self, r: usize, buf: &'b mut [u8]) -> &'b [u8];

    /// Append the runs of row `r` to `out` (`buf.len()` is the width): by default
    /// [`push_runs`] of [`RowSource::row`]; a source may find them without the byte row.
    #[inline]
    fn push_row_runs(&self, r: usize, buf: &mut [u8], out: &mut Vec<Run>) {
        push_runs(self.row(r, buf), out);
    }
}

/// A binary image held as a row-major 0/1 byte mask.
pub struct MaskRows<'a> {
    pub mask: &'a [u8],
    pub width: usize,
}

impl RowSource for MaskRows<'_> {
    #[inline]
    fn row<'b>(&'b self, r: usize, _buf: &'b mut [u8]) -> &'b [u8] {
        &self.mask[r * self.width..(r + 1) * self.width]
    }
}

/// The runs of set cells of every row of a binary image, found in parallel row bands.
pub struct RowRuns {
    /// Runs of all rows, concatenated in row order.
    pub runs: Vec<Run>,
    /// `row_start[r]..row_start[r + 1]` are the runs of row `r` (length `height + 1`).
    pub row_start: Vec<usize>,
}

impl RowRuns {
    /// The runs of every row of `source`.
    pub fn of<S: RowSource>(source: &S, height: usize, width: usize) -> RowRuns {
        let parts: Vec<(Vec<Run>, Vec<usize>)> = bands(height)
            .into_par_iter()
            .map(|(r0, r1)| {
                let mut buf = vec![0u8; width];
                let mut runs = Vec::new();
                let mut starts = Vec::with_capacity(r1 - r0);
                for r in r0..r1 {
                    starts.push(runs.len());
                    source.push_row_runs(r, &mut buf, &mut runs);
                }
                (runs, starts)
            })
            .collect();
        RowRuns::concat(parts)
    }

    /// Join per-band `(runs, row starts relative to the band)` in band order.
    pub fn concat(parts: Vec<(Vec<Run>, Vec<usize>)>) -> RowRuns {
        let total: usize = parts.iter().map(|(r, _)| r.len()).sum();
        let rows: usize = parts.iter().map(|(_, s)| s.len()).sum();
        let mut runs = Vec::with_capacity(total);
        let mut row_start = Vec::with_capacity(rows + 1);
        for (part, starts) in parts {
            let base = runs.len();
            row_start.extend(starts.iter().map(|s| s + base));
            runs.extend_from_slice(&part);
        }
        row_start.push(runs.len());
        RowRuns { runs, row_start }
    }

    /// The runs of row `r`.
    #[inline]
    pub fn row(&self, r: usize) -> &[Run] {
        &self.runs[self.row_start[r]..self.row_start[r + 1]]
    }

    fn into_parts(self) -> (Vec<Run>, Vec<usize>) {
        (self.runs, self.row_start)
    }
}

/// The labelled components of one binary image.
pub struct Components {
    height: usize,
    width: usize,
    /// Runs of all rows, concatenated in row order.
    runs: Vec<Run>,
    /// `row_start[r]..row_start[r + 1]` are the runs of row `r`.
    row_start: Vec<usize>,
    /// For every run, the index of its component's root run.
    root: Vec<u32>,
    /// At root runs: the component's cell count (saturating).
    size: Vec<u32>,
    /// At root runs: whether the component touches the image border.
    border: Vec<bool>,
}

/// The 0/1 bytes of one 64-cell block packed into bits (bit `i` = byte `i`): eight bytes at a
/// time by one multiplication, which moves byte `i`'s low bit to bit `49 + i` (every partial
/// product lands on its own bit, so nothing carries).
#[cfg(target_arch = "x86_64")]
#[inline]
fn pack64(block: &[u8]) -> u64 {
    // SSE2 (baseline on x86_64): each byte's low bit moved to its sign bit, then `movemask`
    use std::arch::x86_64::{__m128i, _mm_loadu_si128, _mm_movemask_epi8, _mm_slli_epi16};
    debug_assert!(block.len() >= 64);
    let mut bits = 0u64;
    for k in 0..4 {
        let c = &block[16 * k..16 * k + 16];
        // SAFETY: `c` holds 16 bytes (unaligned load); SSE2 is always present on x86_64
        let m = unsafe {
            let x = _mm_loadu_si128(c.as_ptr() as *const __m128i);
            _mm_movemask_epi8(_mm_slli_epi16(x, 7)) as u32 as u64
        };
        bits |= (m & 0xffff) << (16 * k);
    }
    bits
}

/// [`pack64`] without SSE2.
#[cfg(not(target_arch = "x86_64"))]
#[inline]
fn pack64(block: &[u8]) -> u64 {
    pack64_scalar(block)
}

/// The multiplication form of [`pack64`] (also the reference its test compares with).
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
#[inline]
fn pack64_scalar(block: &[u8]) -> u64 {
    const M: u64 = 0x0002_0408_1020_4081; // sum of 2^(7j), j = 0..8
    let mut bits = 0u64;
    for (k, c) in block.chunks_exact(8).enumerate() {
        let mut word = [0u8; 8];
        word.copy_from_slice(c);
        let x = u64::from_le_bytes(word) & 0x0101_0101_0101_0101;
        bits |= ((x.wrapping_mul(M) >> 49) & 0xff) << (8 * k);
    }
    bits
}

/// Append the runs of one 0/1 row to `out`.
///
/// The row is packed into 64-bit words; a word's run edges (cells that differ from the cell
/// before them) are visited by trailing-zero counts, one loop exit per word instead of one
/// unpredictable branch per run boundary (noisy maps have many short runs).
pub fn push_runs(row: &[u8], out: &mut Vec<Run>) {
    push_runs_by(
        row.len(),
        |base| pack64(&row[base..base + 64]),
        |i| row[i] & 1 != 0,
        out,
    );
}

/// [`push_runs`] of a row of `n` cells given by `block(base)`, the bits of cells
/// `base..base + 64` (bit `i` = cell `base + i`; asked for `base + 64 <= n` only: every
/// multiple of 64 in order, then `n - 64` for the last `n % 64` cells), and `cell(i)`, asked
/// only for rows shorter than 64 cells.
#[inline(always)]
pub fn push_runs_by(
    n: usize,
    mut block: impl FnMut(usize) -> u64,
    cell: impl Fn(usize) -> bool,
    out: &mut Vec<Run>,
) {
    let mut open: Option<u32> = None;
    let mut carry = 0u64; // the last cell of the previous word
                          // runs alternate start and end edges, a pattern branch predictors follow
    let edge = |pos: u32, open: &mut Option<u32>, out: &mut Vec<Run>| match open.take() {
        Some(start) => out.push(Run { start, end: pos }),
        None => *open = Some(pos),
    };
    let mut base = 0usize;
    while base + 64 <= n {
        let bits = block(base);
        let mut edges = bits ^ ((bits << 1) | carry);
        carry = bits >> 63;
        while edges != 0 {
            edge(
                (base + edges.trailing_zeros() as usize) as u32,
                &mut open,
                out,
            );
            edges &= edges - 1;
        }
        base += 64;
    }
    let rem = n - base;
    if rem > 0 && n >= 64 {
        // the last `rem` cells as the top of the word that ends the row, shifted down
        let bits = block(n - 64) >> (64 - rem);
        let mut edges = (bits ^ ((bits << 1) | carry)) & ((1u64 << rem) - 1);
        while edges != 0 {
            edge(
                (base + edges.trailing_zeros() as usize) as u32,
                &mut open,
                out,
            );
            edges &= edges - 1;
        }
    } else {
        for i in base..n {
            let bit = cell(i) as u64;
            if bit != carry {
                edge(i as u32, &mut open, out);
            }
            carry = bit;
        }
    }
    if let Some(start) = open {
        out.push(Run {
            start,
            end: n as u32,
        });
    }
}

/// Call `touch(i, j)` for every run `i` of the previous row (`runs[prev.0..prev.1]`) and
/// run `j` of the current row (`runs[cur.0..cur.1]`) that are 8-connected: their column
/// ranges overlap or meet diagonally. In merge order: `j` never decreases.
///
/// The pairs are first gathered into `pairs` (scratch, grown as needed) by a merge scan
/// without a branch per step: whether two runs touch is unpredictable on noisy maps, so
/// every step writes its pair and only advances the count when they touch.
fn touching_runs(
    runs: &[Run],
    prev: (usize, usize),
    cur: (usize, usize),
    pairs: &mut Vec<(u32, u32)>,
    mut touch: impl FnMut(usize, usize),
) {
    let (i0, pe) = prev;
    let (j0, ce) = cur;
    if i0 >= pe || j0 >= ce {
        return;
    }
    // each step advances i or j, so there are fewer steps than runs in the two rows
    let steps = (pe - i0) + (ce - j0);
    if pairs.len() < steps {
        pairs.resize(steps, (0, 0));
    }
    let (prev_runs, cur_runs) = (&runs[i0..pe], &runs[j0..ce]);
    let mut n = 0usize;
    let (mut ii, mut jj) = (0usize, 0usize);
    while ii < prev_runs.len() && jj < cur_runs.len() {
        let (a, b) = (prev_runs[ii], cur_runs[jj]);
        pairs[n] = (ii as u32, jj as u32);
        n += ((a.start <= b.end) & (b.start <= a.end)) as usize;
        // advance the run that ends first
        let step = (a.end < b.end) as usize;
        ii += step;
        jj += 1 - step;
    }
    for &(a, b) in &pairs[..n] {
        touch(i0 + a as usize, j0 + b as usize);
    }
}

/// `v` cut into the consecutive pieces `v[base[b]..base[b + 1]]`, one per band.
fn split_bands<'v, T>(v: &'v mut [T], base: &[usize]) -> Vec<&'v mut [T]> {
    let mut out = Vec::with_capacity(base.len().saturating_sub(1));
    let mut rest = v;
    for b in base.windows(2) {
        let (head, tail) = rest.split_at_mut(b[1] - b[0]);
        out.push(head);
        rest = tail;
    }
    out
}

/// A union-find over the runs of an image (`runs[row_start[r]..row_start[r + 1]]` are row
/// `r`'s runs, left to right) joining every two 8-connected runs: the bands of rows in
/// parallel, each on its own slice, then the band seams. Returns the parent of every run and
/// the number of unions that joined two components (`runs.len()` minus the component count).
///
/// Union is by smaller index and paths are only ever shortened, so `parent[i] <= i`, and one
/// ascending pass `parent[i] = parent[parent[i]]` points every run at its root. The result
/// is the same for any thread count.
fn union_runs(runs: &[Run], row_start: &[usize], height: usize) -> (Vec<u32>, usize) {
    let bands = bands(height);
    let mut band_base: Vec<usize> = bands.iter().map(|&(r0, _)| row_start[r0]).collect();
    band_base.push(runs.len());
    debug_assert!(runs.len() < u32::MAX as usize);
    let mut parent: Vec<u32> = vec![0; runs.len()];
    let merged: usize = split_bands(&mut parent, &band_base)
        .into_par_iter()
        .zip(bands.par_iter().zip(band_base.par_iter()))
        .map(|(par, (&(r0, r1), &base))| {
            for (k, p) in par.iter_mut().enumerate() {
                *p = (base + k) as u32;
            }
            let mut merged = 0usize;
            union_band(par, runs, row_start, (r0, r1), base, |_, _| merged += 1);
            merged
        })
        .sum();
    let mut seams = 0usize;
    let mut pairs = Vec::new();
    for &(r0, _) in bands.iter().skip(1) {
        touching_runs(
            runs,
            (row_start[r0 - 1], row_start[r0]),
            (row_start[r0], row_start[r0 + 1]),
            &mut pairs,
            |i, j| seams += union_in(&mut parent, i as u32, j as u32, 0) as usize,
        );
    }
    (parent, merged + seams)
}

/// The number of 8-connected components of an image given by its runs
/// (`runs[row_start[r]..row_start[r + 1]]` are row `r`'s runs, left to right), without
/// labelling them: every union of [`union_runs`] that joins two components removes one of
/// the `runs.len()` singletons. The count is the same for any thread count.
pub fn count_components(runs: &[Run], row_start: &[usize], height: usize) -> usize {
    runs.len() - union_runs(runs, row_start, height).1
}

/// The number of 8-connected components of an `height x width` image given by its runs that
/// touch no image border and have at least `min_area` cells, without labelling them: the
/// unions of [`union_runs`], then, for `min_area <= 1` (every component is large enough),
/// the component count less the distinct roots of the runs on the border; otherwise one
/// ascending pass that points every run at its root and adds its size and border contact
/// to the root's. The count is the same for any thread count.
pub fn count_enclosed_runs(
    runs: &[Run],
    row_start: &[usize],
    height: usize,
    width: usize,
    min_area: u32,
) -> usize {
    let (mut parent, merged) = union_runs(runs, row_start, height);
    if min_area <= 1 {
        // every component is large enough: the components less those touching the border,
        // found from the border runs alone (rows 0 and h-1, and runs at columns 0 or w-1)
        let mut touching: Vec<u32> = Vec::new();
        for r in 0..height {
            let row = &runs[row_start[r]..row_start[r + 1]];
            let base = row_start[r];
            if r == 0 || r + 1 == height {
                touching.extend((0..row.len()).map(|k| find_in(&mut parent, (base + k) as u32, 0)));
            } else if let (Some(first), Some(last)) = (row.first(), row.last()) {
                if first.start == 0 {
                    touching.push(find_in(&mut parent, base as u32, 0));
                }
                if last.end as usize == width {
                    touching.push(find_in(&mut parent, (base + row.len() - 1) as u32, 0));
                }
            }
        }
        touching.sort_unstable();
        touching.dedup();
        return runs.len() - merged - touching.len();
    }
    // size (at most the cell count, below 2^32) with the border flag in the top bit
    const EDGE: u64 = 1 << 63;
    let mut stat: Vec<u64> = vec![0; runs.len()];
    for r in 0..height {
        let edge_row = r == 0 || r + 1 == height;
        for i in row_start[r]..row_start[r + 1] {
            let run = runs[i];
            let root = parent[parent[i] as usize];
            parent[i] = root;
            let edge = edge_row | (run.start == 0) | (run.end as usize == width);
            stat[root as usize] |= if edge { EDGE } else { 0 };
            stat[root as usize] += u64::from(run.end - run.start);
        }
    }
    parent
        .iter()
        .zip(&stat)
        .enumerate()
        .map(|(i, (&p, &st))| {
            ((p as usize == i) & (st & EDGE == 0) & (st >= u64::from(min_area))) as usize
        })
        .sum()
}

/// Drop the 8-connected components of fewer than `min_size` cells from an image given as
/// `mask` (row-major, `height x width`, zeroed where a component is dropped) and its runs;
/// returns the runs that remain. The same as [`Components::clear_small`] and
/// [`Components::runs_of_large`] after labelling, without the labels: a union-find with the
/// sizes at the roots (bands in parallel, then the seams), one ascending pass that points
/// every run at its root (a non-root's parent always has a smaller index), and one pass per
/// band that keeps or clears each run.
pub fn drop_small_runs(
    rr: RowRuns,
    mask: &mut [u8],
    height: usize,
    width: usize,
    min_size: u32,
) -> RowRuns {
    let (runs, row_start) = (&rr.runs, &rr.row_start);
    let bands = bands(height);
    let mut band_base: Vec<usize> = bands.iter().map(|&(r0, _)| row_start[r0]).collect();
    band_base.push(runs.len());
    debug_assert!(runs.len() < u32::MAX as usize);
    let n = runs.len();
    let mut parent: Vec<u32> = vec![0; n];
    let mut size: Vec<u32> = vec![0; n];
    split_bands(&mut parent, &band_base)
        .into_par_iter()
        .zip(split_bands(&mut size, &band_base))
        .zip(bands.par_iter().zip(band_base.par_iter()))
        .for_each(|((par, siz), (&(r0, r1), &base))| {
            for (k, (p, sz)) in par.iter_mut().zip(siz.iter_mut()).enumerate() {
                *p = (base + k) as u32;
                let run = runs[base + k];
                *sz = run.end - run.start;
            }
            union_band(par, runs, row_start, (r0, r1), base, |lo, hi| {
                siz[lo] = siz[lo].saturating_add(siz[hi]);
            });
        });
    let mut pairs = Vec::new();
    for &(r0, _) in bands.iter().skip(1) {
        touching_runs(
            runs,
            (row_start[r0 - 1], row_start[r0]),
            (row_start[r0], row_start[r0 + 1]),
            &mut pairs,
            |i, j| {
                let ra = find_in(&mut parent, i as u32, 0) as usize;
                let rb = find_in(&mut parent, j as u32, 0) as usize;
                let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
                if lo != hi {
                    parent[hi] = lo as u32;
                    size[lo] = size[lo].saturating_add(size[hi]);
                }
            },
        );
    }
    for i in 0..n {
        parent[i] = parent[parent[i] as usize];
    }
    let parts: Vec<(Vec<Run>, Vec<usize>)> = mask
        .par_chunks_mut(BAND_ROWS * width)
        .zip(bands.par_iter())
        .map(|(band, &(r0, r1))| {
            let mut kept = Vec::new();
            let mut starts = Vec::with_capacity(r1 - r0);
            for r in r0..r1 {
                starts.push(kept.len());
                let row = &mut band[(r - r0) * width..(r - r0 + 1) * width];
                for i in row_start[r]..row_start[r + 1] {
                    let run = runs[i];
                    if size[parent[i] as usize] >= min_size {
                        kept.push(run);
                    } else {
                        row[run.start as usize..run.end as usize].fill(0);
                    }
                }
            }
            (kept, starts)
        })
        .collect();
    RowRuns::concat(parts)
}

/// The unions of one band's rows `r0 + 1..r1`: every two touching runs of consecutive rows
/// join their components, on the band's slice `par` of a parent array of global indices
/// (`base`: the index of its first entry; initialised to `base + k`), the larger root
/// under the smaller, so a run's parent never has a larger index. `joined(lo, hi)` is
/// called with the band-local roots of every join (`hi` now under `lo`): the one place the
/// component counts, [`drop_small_runs`] and [`Components::from_runs`] differ.
///
/// A run of the current row is a singleton until its first contact, which links it
/// straight to the other run's root (a smaller index) without a second find.
#[inline(always)]
fn union_band(
    par: &mut [u32],
    runs: &[Run],
    row_start: &[usize],
    (r0, r1): (usize, usize),
    base: usize,
    mut joined: impl FnMut(usize, usize),
) {
    let mut pairs = Vec::new();
    for r in r0 + 1..r1 {
        let mut last = usize::MAX;
        touching_runs(
            runs,
            (row_start[r - 1], row_start[r]),
            (row_start[r], row_start[r + 1]),
            &mut pairs,
            |i, j| {
                let (a, b) = ((i - base) as u32, j - base);
                let ra = (find_in(par, a, base) - base as u32) as usize;
                if j != last {
                    last = j;
                    par[b] = (ra + base) as u32;
                    joined(ra, b);
                } else {
                    let rb = (find_in(par, b as u32, base) - base as u32) as usize;
                    let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
                    if lo != hi {
                        par[hi] = (lo + base) as u32;
                        joined(lo, hi);
                    }
                }
            },
        );
    }
}

/// The root of `x` (union-find with path halving) on a band's slice of a parent array
/// holding global indices (`base`: the index of the slice's first entry; 0 for the whole
/// array); returns the root's global index.
///
/// A run and its parent are read before the first test, so that the common cases (the run
/// is a root, or its parent is) leave after one predictable branch; longer paths are halved.
#[inline]
fn find_in(parent: &mut [u32], x: u32, base: usize) -> u32 {
    let b = base as u32;
    let mut x = x;
    loop {
        let p = parent[x as usize] - b;
        let gp = parent[p as usize];
        if gp - b == p {
            return gp;
        }
        parent[x as usize] = gp;
        x = gp - b;
    }
}

/// Join the components of `a` and `b` (band-local indices) on a band's slice of global
/// indices, the larger root under the smaller; whether two components were joined.
#[inline]
fn union_in(parent: &mut [u32], a: u32, b: u32, base: usize) -> bool {
    let ra = find_in(parent, a, base) - base as u32;
    let rb = find_in(parent, b, base) - base as u32;
    if ra < rb {
        parent[rb as usize] = ra + base as u32;
    } else if rb < ra {
        parent[ra as usize] = rb + base as u32;
    }
    ra != rb
}

impl Components {
    /// Label the 8-connected components of an `height x width` binary image.
    pub fn label<S: RowSource>(source: &S, height: usize, width: usize) -> Components {
        let (runs, row_start) = RowRuns::of(source, height, width).into_parts();
        Components::from_runs(runs, row_start, height, width)
    }

    /// Label components given the runs of every row (`runs[row_start[r]..row_start[r + 1]]`
    /// are row `r`'s runs, left to right).
    pub fn from_runs(runs: Vec<Run>, row_start: Vec<usize>, height: usize, width: usize) -> Self {
        let bands = bands(height);
        let mut band_base: Vec<usize> = bands.iter().map(|&(r0, _)| row_start[r0]).collect();
        band_base.push(runs.len());
        // a grid has at most u32::MAX cells (Grid::new), so at most half as many runs plus
        // one per row: run indices fit in u32
        debug_assert!(runs.len() < u32::MAX as usize);

        // 2. in parallel, each band on its own slices: unions of its rows, flattening (union by
        // smaller index keeps parent[i] <= i, so one ascending pass resolves every run to its
        // band-local root), and the band-local components' size and border contact
        let mut parent: Vec<u32> = vec![0; runs.len()];
        let mut size = vec![0u32; runs.len()];
        let mut border = vec![false; runs.len()];
        let local_roots: Vec<Vec<u32>> = {
            let parts = split_bands(&mut parent, &band_base)
                .into_iter()
                .zip(split_bands(&mut size, &band_base))
                .zip(split_bands(&mut border, &band_base));
            let jobs: Vec<_> = parts.zip(bands.iter().zip(&band_base)).collect();
            let (runs_ref, rs) = (&runs, &row_start);
            jobs.into_par_iter()
                .map(|(((par, siz), bor), (&(r0, r1), &base))| {
                    for (k, p) in par.iter_mut().enumerate() {
                        *p = (base + k) as u32;
                    }
                    union_band(par, runs_ref, rs, (r0, r1), base, |_, _| {});
                    let mut roots = Vec::new();
                    for r in r0..r1 {
                        let edge_row = r == 0 || r + 1 == height;
                        for i in rs[r]..rs[r + 1] {
                            let k = i - base;
                            let root = par[par[k] as usize - base];
                            par[k] = root;
                            if root as usize == i {
                                roots.push(root);
                            }
                            let run = runs_ref[i];
                            let root = root as usize - base;
                            siz[root] = siz[root].saturating_add(run.end - run.start);
                            bor[root] |= edge_row || run.start == 0 || run.end as usize == width;
                        }
                    }
                    roots
                })
                .collect()
        };
        // 3. the seams between bands: unions of band-local roots (never of the other runs,
        // whose parent must stay their band-local root for step 5)
        let mut pairs = Vec::new();
        for &(r0, _) in bands.iter().skip(1) {
            let (prev, cur) = (
                (row_start[r0 - 1], row_start[r0]),
                (row_start[r0], row_start[r0 + 1]),
            );
            touching_runs(&runs, prev, cur, &mut pairs, |i, j| {
                let (ra, rb) = (parent[i], parent[j]);
                union_in(&mut parent, ra, rb, 0);
            });
        }
        // 4. each band-local root hands its statistics to its component's root and then
        // points straight at it (serial, but over components, not runs)
        for &lr in local_roots.iter().flatten() {
            let g = find_in(&mut parent, lr, 0);
            if g != lr {
                let (g, lr) = (g as usize, lr as usize);
                size[g] = size[g].saturating_add(size[lr]);
                border[g] |= border[lr];
                parent[lr] = g as u32;
            }
        }
        // 5. every run points at its component's root: its band-local root's parent
        split_bands(&mut parent, &band_base)
            .into_par_iter()
            .zip(band_base.par_iter())
            .for_each(|(par, &base)| {
                let band = base..base + par.len();
                for k in 0..par.len() {
                    // a run points at its band-local root, or (a merged local root) already
                    // at the component's root, which may lie in another band
                    let p = par[k] as usize;
                    if band.contains(&p) {
                        par[k] = par[p - base];
                    }
                }
            });
        Components {
            height,
            width,
            runs,
            row_start,
            root: parent,
            size,
            border,
        }
    }

    /// Indices of the root runs (one per component).
    fn roots(&self) -> impl ParallelIterator<Item = usize> + '_ {
        self.root
            .par_iter()
            .enumerate()
            .filter(|(i, r)| *i == **r as usize)
            .map(|(i, _)| i)
    }

    /// Number of components.
    pub fn count(&self) -> usize {
        self.roots().count()
    }

    /// Number of components that touch no border cell and have at least `min_area` cells.
    pub fn count_enclosed(&self, min_area: u32) -> usize {
        self.roots()
            .filter(|&i| !self.border[i] && self.size[i] >= min_area)
            .count()
    }

    /// Zero, in `mask` (row-major, this image's shape), the cells of every component with
    /// fewer than `min_size` cells.
    pub fn clear_small(&self, mask: &mut [u8], min_size: u32) {
        let w = self.width;
        mask.par_chunks_mut(BAND_ROWS * w)
            .zip(bands(self.height))
            .for_each(|(band, (r0, r1))| {
                for r in r0..r1 {
                    let row = &mut band[(r - r0) * w..(r - r0 + 1) * w];
                    for i in self.row_start[r]..self.row_start[r + 1] {
                        if self.size[self.root[i] as usize] < min_size {
                            let run = self.runs[i];
                            row[run.start as usize..run.end as usize].fill(0);
                        }
                    }
                }
            });
    }

    /// The runs of the components with at least `min_size` cells (what [`clear_small`] keeps).
    ///
    /// [`clear_small`]: Components::clear_small
    pub fn runs_of_large(&self, min_size: u32) -> RowRuns {
        let parts: Vec<(Vec<Run>, Vec<usize>)> = bands(self.height)
            .into_par_iter()
            .map(|(r0, r1)| {
                let mut runs = Vec::new();
                let mut starts = Vec::with_capacity(r1 - r0);
                for r in r0..r1 {
                    starts.push(runs.len());
                    for i in self.row_start[r]..self.row_start[r + 1] {
                        if self.size[self.root[i] as usize] >= min_size {
                            runs.push(self.runs[i]);
                        }
                    }
                }
                (runs, starts)
            })
            .collect();
        RowRuns::concat(parts)
    }

    /// Visit every run in row order as `(row, run, root_cell, size, border)`: `root_cell` is
    /// the row-major index of the first cell of the run's component (the first cell of its
    /// root run), `size` and `border` the component's.
    pub fn for_each_run(&self, mut visit: impl FnMut(usize, Run, usize, u32, bool)) {
        // the root run has the smallest index of its component, so it is seen first
        let mut root_cell = vec![0usize; self.runs.len()];
        for r in 0..self.height {
            for i in self.row_start[r]..self.row_start[r + 1] {
                let run = self.runs[i];
                let root = self.root[i] as usize;
                if root == i {
                    root_cell[i] = r * self.width + run.start as usize;
                }
                visit(r, run, root_cell[root], self.size[root], self.border[root]);
            }
        }
    }

    /// Component label of every cell (0 = background, 1.. in order of first run), for tests
    /// and overlays.
    pub fn labels(&self) -> Vec<u32> {
        let mut ids = vec![0u32; self.runs.len()];
        let mut next = 0u32;
        let mut out = vec![0u32; self.height * self.width];
        for r in 0..self.height {
            for i in self.row_start[r]..self.row_start[r + 1] {
                let root = self.root[i] as usize;
                if ids[root] == 0 {
                    next += 1;
                    ids[root] = next;
                }
                let run = self.runs[i];
                out[r * self.width + run.start as usize..r * self.width + run.end as usize]
                    .fill(ids[root]);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` cells, each set with probability `density`% (a seeded LCG: the same masks on
    /// every run).
    fn random_mask(state: &mut u64, n: usize, density: u64) -> Vec<u8> {
        (0..n)
            .map(|_| {
                *state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((*state >> 33) % 100 < density) as u8
            })
            .collect()
    }

    fn pool_of(threads: usize) -> rayon::ThreadPool {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
    }

    fn from_str(rows: &[&str]) -> (Vec<u8>, usize, usize) {
        let h = rows.len();
        let w = rows[0].len();
        let mut m = Vec::with_capacity(h * w);
        for r in rows {
            m.extend(r.bytes().map(|b| (b == b'#') as u8));
        }
        (m, h, w)
    }

    fn naive_count(mask: &[u8], h: usize, w: usize) -> (usize, usize) {
        // flood fill: (components, components touching no border)
        let mut seen = vec![false; h * w];
        let (mut all, mut inner) = (0, 0);
        for s in 0..h * w {
            if mask[s] == 0 || seen[s] {
                continue;
            }
            all += 1;
            let mut border = false;
            let mut stack = vec![s];
            seen[s] = true;
            while let Some(c) = stack.pop() {
                let (r, x) = (c / w, c % w);
                border |= r == 0 || x == 0 || r + 1 == h || x + 1 == w;
                for dr in -1i64..=1 {
                    for dx in -1i64..=1 {
                        let (rr, xx) = (r as i64 + dr, x as i64 + dx);
                        if rr < 0 || xx < 0 || rr >= h as i64 || xx >= w as i64 {
                            continue;
                        }
                        let n = rr as usize * w + xx as usize;
                        if mask[n] != 0 && !seen[n] {
                            seen[n] = true;
                            stack.push(n);
                        }
                    }
                }
            }
            if !border {
                inner += 1;
            }
        }
        (all, inner)
    }

    #[test]
    fn diagonal_contact_joins() {
        let (m, h, w) = from_str(&["......", ".#....", "..#...", "....#.", "......"]);
        let c = Components::label(&MaskRows { mask: &m, width: w }, h, w);
        assert_eq!(c.count(), 2);
        assert_eq!(c.count_enclosed(1), 2);
        assert_eq!(c.count_enclosed(2), 1);
    }

    #[test]
    fn border_contact() {
        let (m, h, w) = from_str(&["#.....", "......", "..##..", "......", ".....#"]);
        let c = Components::label(&MaskRows { mask: &m, width: w }, h, w);
        assert_eq!(c.count(), 3);
        assert_eq!(c.count_enclosed(1), 1);
    }

    #[test]
    fn matches_flood_fill_across_bands() {
        // pseudo-random masks taller than one band
        let mut state = 12345u64;
        for density in [20u64, 45, 60] {
            let (h, w) = (300, 37);
            let m = random_mask(&mut state, h * w, density);
            let c = Components::label(&MaskRows { mask: &m, width: w }, h, w);
            assert_eq!((c.count(), c.count_enclosed(1)), naive_count(&m, h, w));
        }
    }

    /// Runs by a plain scan, cell by cell.
    fn naive_runs(row: &[u8]) -> Vec<Run> {
        let mut out = Vec::new();
        let mut x = 0;
        while x < row.len() {
            if row[x] != 0 {
                let s = x;
                while x < row.len() && row[x] != 0 {
                    x += 1;
                }
                out.push(Run {
                    start: s as u32,
                    end: x as u32,
                });
            } else {
                x += 1;
            }
        }
        out
    }

    #[test]
    fn packed_runs_equal_a_plain_scan() {
        let mut state = 99u64;
        for trial in 0..2000 {
            let w = 1 + trial % 300;
            let density = trial % 101;
            let row = random_mask(&mut state, w, density as u64);
            let mut got = vec![Run { start: 7, end: 9 }]; // appended to, not replaced
            push_runs(&row, &mut got);
            let mut expect = vec![Run { start: 7, end: 9 }];
            expect.extend(naive_runs(&row));
            assert_eq!(got, expect, "width {w}: {row:?}");
        }
        for w in [63, 64, 65, 128, 129] {
            for row in [vec![1u8; w], vec![0u8; w]] {
                assert_eq!(
                    {
                        let mut o = Vec::new();
                        push_runs(&row, &mut o);
                        o
                    },
                    naive_runs(&row)
                );
            }
        }
    }

    #[test]
    fn pack64_equals_the_multiplication_form() {
        let mut state = 5u64;
        for density in 0..=100u64 {
            for _ in 0..50 {
                let block = random_mask(&mut state, 64, density);
                let bits = pack64(&block);
                assert_eq!(bits, pack64_scalar(&block));
                for (i, &b) in block.iter().enumerate() {
                    assert_eq!((bits >> i) & 1, b as u64);
                }
            }
        }
    }

    #[test]
    fn component_count_without_labels_equals_the_labelling() {
        let mut state = 777u64;
        for (h, w, density) in [
            (1, 1, 50),
            (300, 37, 20),
            (300, 37, 45),
            (130, 64, 60),
            (65, 5, 70),
        ] {
            let m = random_mask(&mut state, h * w, density);
            let rows = MaskRows { mask: &m, width: w };
            let rr = RowRuns::of(&rows, h, w);
            let expect = naive_count(&m, h, w).0;
            for threads in [1, 2] {
                let pool = pool_of(threads);
                let got = pool.install(|| count_components(&rr.runs, &rr.row_start, h));
                assert_eq!(got, expect, "{h}x{w} density {density} threads {threads}");
            }
        }
    }

    #[test]
    fn enclosed_count_without_labels_equals_the_labelling() {
        let mut state = 4242u64;
        for (h, w, density) in [
            (1, 1, 50),
            (300, 37, 50),
            (300, 37, 65),
            (130, 64, 60),
            (65, 5, 80),
        ] {
            let m = random_mask(&mut state, h * w, density);
            let rows = MaskRows { mask: &m, width: w };
            let rr = RowRuns::of(&rows, h, w);
            let c = Components::label(&rows, h, w);
            for min_area in [0, 1, 2, 5, 40] {
                let expect = c.count_enclosed(min_area);
                for threads in [1, 2] {
                    let pool = pool_of(threads);
                    let got = pool
                        .install(|| count_enclosed_runs(&rr.runs, &rr.row_start, h, w, min_area));
                    assert_eq!(got, expect, "{h}x{w} {density}% min {min_area} x{threads}");
                }
            }
            assert_eq!(c.count_enclosed(1), naive_count(&m, h, w).1);
        }
    }

    #[test]
    fn dropping_small_components_by_runs_equals_the_labelling() {
        let mut state = 31u64;
        for (h, w, density) in [
            (1, 1, 50),
            (300, 37, 20),
            (300, 37, 45),
            (130, 64, 55),
            (65, 5, 30),
        ] {
            let m = random_mask(&mut state, h * w, density);
            for min_size in [0, 1, 2, 5, 30] {
                let c = Components::label(&MaskRows { mask: &m, width: w }, h, w);
                let mut expect_mask = m.clone();
                c.clear_small(&mut expect_mask, min_size);
                let expect = c.runs_of_large(min_size);
                for threads in [1, 2] {
                    let pool = pool_of(threads);
                    let mut got_mask = m.clone();
                    let rr = RowRuns::of(&MaskRows { mask: &m, width: w }, h, w);
                    let got = pool.install(|| drop_small_runs(rr, &mut got_mask, h, w, min_size));
                    let what = format!("{h}x{w} {density}% min {min_size} x{threads}");
                    assert_eq!(got_mask, expect_mask, "{what}");
                    assert_eq!(got.runs, expect.runs, "{what}");
                    assert_eq!(got.row_start, expect.row_start, "{what}");
                }
            }
        }
    }

    #[test]
    fn clear_small_removes_dots() {
        let (mut m, h, w) = from_str(&["#....", "..###", ".....", "#...."]);
        let c = Components::label(&MaskRows { mask: &m, width: w }, h, w);
        c.clear_small(&mut m, 2);
        let (expect, _, _) = from_str(&[".....", "..###", ".....", "....."]);
        assert_eq!(m, expect);
    }
}
