//! Enclosed areas (SPEC section 4, paper III.C): for every unknown value `u`, the map with its
//! unknown cells set to `u` is split at its Otsu threshold `T_u`, and the free components that
//! touch no image border (and have at least `min_area` cells) are counted.
//!
//! Literally that is 256 labellings. Here:
//! 1. `T_u` for every `u` comes from one histogram ([`threshold_table`]).
//! 2. A binarisation is fixed by which known values are free (`v > T_u`, so only the rank of
//!    `T_u` among the known values present matters) and whether unknown cells are free
//!    (`u > T_u`). Most maps have two or three distinct binarisations across all 256 `u`.
//! 3. Each family (unknown free / unknown not free) with few distinct thresholds is labelled
//!    directly by runs ([`Components`]); a family with many (graded maps) is counted in one
//!    incremental union-find pass over the known cells in decreasing value order, reading the
//!    count off as the threshold falls past each needed value.
//!
//! Both paths count exactly what the literal definition counts, for any thread count.

use crate::grid::{bands, Grid, Histogram};
use crate::label::{count_enclosed_runs, push_runs_by, Components, RowRuns, RowSource, Run};
use crate::otsu::threshold_table;
use crate::params::EnclosedParams;
use rayon::prelude::*;
use std::collections::BTreeMap;

/// A family with at most this many distinct thresholds is labelled directly, one run
/// labelling per threshold; more go through the incremental pass.
pub const DIRECT_MAX: usize = 4;

/// Known cells are free iff `v >= cut` (`cut` in 0..=256); unknown cells iff `unknown_free`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct Binarisation {
    unknown_free: bool,
    cut: u16,
}

/// The rows of one binarisation, computed on the fly from the grid.
struct FreeRows<'a> {
    grid: &'a Grid<'a>,
    cut: u16,
    unknown_free: bool,
}

impl RowSource for FreeRows<'_> {
    #[inline]
    fn row<'b>(&'b self, r: usize, buf: &'b mut [u8]) -> &'b [u8] {
        let (vals, unk) = (self.grid.value_row(r), self.grid.unknown_row(r));
        let uf = self.unknown_free as u8;
        for ((b, &v), &u) in buf.iter_mut().zip(vals).zip(unk) {
            let u = u as u8;
            *b = (((v as u16) >= self.cut) as u8 & (u ^ 1)) | (uf & u);
        }
        buf
    }

    /// The runs straight from the values and unknown flags, 64 cells a word, without the
    /// byte row (AVX2 when present: compare and `movemask`, 32 cells an instruction).
    #[inline]
    fn push_row_runs(&self, r: usize, buf: &mut [u8], out: &mut Vec<Run>) {
        let (vals, unk) = (self.grid.value_row(r), self.grid.unknown_row(r));
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: AVX2 is present
            unsafe { free_runs_avx2(vals, unk, self.cut, self.unknown_free, out) };
            return;
        }
        let _ = buf;
        free_runs_plain(vals, unk, self.cut, self.unknown_free, out);
    }
}

/// Whether one cell is free: known and `v >= cut`, or unknown and `unknown_free`.
#[inline(always)]
fn is_free(v: u8, u: bool, cut: u16, unknown_free: bool) -> bool {
    if u {
        unknown_free
    } else {
        v as u16 >= cut
    }
}

/// The runs of one row of a binarisation, 64 cells packed at a time without SIMD.
fn free_runs_plain(vals: &[u8], unk: &[bool], cut: u16, unknown_free: bool, out: &mut Vec<Run>) {
    let uf = unknown_free as u8;
    push_runs_by(
        vals.len(),
        |base| {
            let mut bits = 0u64;
            for (i, (&v, &u)) in vals[base..base + 64]
                .iter()
                .zip(&unk[base..base + 64])
                .enumerate()
            {
                let u = u as u8;
                let b = (((v as u16) >= cut) as u8 & (u ^ 1)) | (uf & u);
                bits |= (b as u64) << i;
            }
            bits
        },
        |i| is_free(vals[i], unk[i], cut, unknown_free),
        out,
    );
}

/// [`free_runs_plain`] with AVX2: `v >= cut` as `max(v, cut) == v` (for `cut <= 255`; no
/// known cell is free when `cut = 256`), selected against the unknown flags, then `movemask`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn free_runs_avx2(vals: &[u8], unk: &[bool], cut: u16, unknown_free: bool, out: &mut Vec<Run>) {
    use std::arch::x86_64::*;
    let n = vals.len().min(unk.len());
    let cutv = _mm256_set1_epi8(cut.min(255) as u8 as i8);
    let known_on = _mm256_set1_epi8(if cut <= 255 { -1 } else { 0 });
    let unknown_on = _mm256_set1_epi8(if unknown_free { -1 } else { 0 });
    let zero = _mm256_setzero_si256();
    let half = |base: usize| -> u64 {
        // SAFETY: the caller asks for base + 64 <= n, so 32 bytes from base (and from
        // base + 32) are in both rows; a bool is one byte, 0 or 1
        unsafe {
            let v = _mm256_loadu_si256(vals.as_ptr().add(base) as *const __m256i);
            let u = _mm256_loadu_si256(unk.as_ptr().add(base) as *const __m256i);
            let ge = _mm256_and_si256(_mm256_cmpeq_epi8(_mm256_max_epu8(v, cutv), v), known_on);
            let known = _mm256_cmpeq_epi8(u, zero);
            let free = _mm256_or_si256(
                _mm256_and_si256(ge, known),
                _mm256_andnot_si256(known, unknown_on),
            );
            _mm256_movemask_epi8(free) as u32 as u64
        }
    };
    push_runs_by(
        n,
        |base| half(base) | (half(base + 32) << 32),
        |i| is_free(vals[i], unk[i], cut, unknown_free),
        out,
    );
}

/// The binarisation of every swept `u` (in `(0..256).step_by(sweep_step)` order).
fn keys_of(hist: &Histogram, params: &EnclosedParams) -> Vec<Binarisation> {
    let table = threshold_table(hist);
    // cut_of[t]: the smallest present known value above t (256 if none), so that the known
    // free set {v > t} is {v >= cut_of[t]}; equal cuts mean equal binarisations.
    let mut cut_of = [256u16; 256];
    let mut next = 256u16;
    for t in (0..256).rev() {
        cut_of[t] = next;
        if hist.known[t] > 0 {
            next = t as u16;
        }
    }
    let step = params.sweep_step.max(1);
    (0..256usize)
        .step_by(step)
        .map(|u| {
            let t = table[u];
            Binarisation {
                unknown_free: hist.unknown > 0 && u > t as usize,
                cut: cut_of[t as usize],
            }
        })
        .collect()
}

/// The distinct binarisations of the sweep as `(unknown_free, cut)`: known cells are free iff
/// `v >= cut`, unknown cells iff `unknown_free` (for per-stage timing and tests).
pub fn binarisations(hist: &Histogram, params: &EnclosedParams) -> Vec<(bool, u16)> {
    let set: std::collections::BTreeSet<Binarisation> = keys_of(hist, params).into_iter().collect();
    set.into_iter().map(|b| (b.unknown_free, b.cut)).collect()
}

/// `count_u` of one binarisation `(unknown_free, cut)`, labelled directly by runs.
pub fn count_binarisation(grid: &Grid, (unknown_free, cut): (bool, u16), min_area: u32) -> usize {
    direct(grid, cut, unknown_free, min_area)
}

/// `count_u` for every swept `u` (in `(0..256).step_by(sweep_step)` order).
pub fn sweep(grid: &Grid, hist: &Histogram, params: &EnclosedParams) -> Vec<usize> {
    let keys = keys_of(hist, params);
    let mut counts: BTreeMap<Binarisation, usize> = keys.iter().map(|k| (*k, 0)).collect();
    // the binarisations labelled directly, their runs found together in one pass
    let mut direct_keys = Vec::new();
    for unknown_free in [false, true] {
        let cuts: Vec<u16> = counts
            .keys()
            .filter(|k| k.unknown_free == unknown_free)
            .map(|k| k.cut)
            .collect();
        if cuts.is_empty() {
            continue;
        }
        if cuts.len() <= DIRECT_MAX {
            direct_keys.extend(
                cuts.iter()
                    .map(|&cut| Binarisation { unknown_free, cut })
                    .filter(|b| b.cut < 256 || b.unknown_free), // else nothing is free: 0
            );
        } else {
            for (cut, n) in incremental(grid, hist, unknown_free, &cuts, params.min_area) {
                counts.insert(Binarisation { unknown_free, cut }, n);
            }
        }
    }
    for (b, runs) in direct_keys.iter().zip(runs_of_many(grid, &direct_keys)) {
        counts.insert(*b, count_direct(grid, &runs, params.min_area));
    }
    keys.iter().map(|k| counts[k]).collect()
}

/// The runs of several binarisations in one pass over the grid: each row is read from
/// memory once and binarised once per key while it is in cache (the labellings of a
/// sweep are otherwise bound by reading the grid).
fn runs_of_many(grid: &Grid, keys: &[Binarisation]) -> Vec<RowRuns> {
    if keys.is_empty() {
        return Vec::new();
    }
    let sources: Vec<FreeRows> = keys
        .iter()
        .map(|b| FreeRows {
            grid,
            cut: b.cut,
            unknown_free: b.unknown_free,
        })
        .collect();
    let w = grid.width;
    let parts: Vec<Vec<(Vec<Run>, Vec<usize>)>> = bands(grid.height)
        .into_par_iter()
        .map(|(r0, r1)| {
            let mut buf = vec![0u8; w];
            let mut per: Vec<(Vec<Run>, Vec<usize>)> = keys
                .iter()
                .map(|_| (Vec::new(), Vec::with_capacity(r1 - r0)))
                .collect();
            for r in r0..r1 {
                for (src, (runs, starts)) in sources.iter().zip(per.iter_mut()) {
                    starts.push(runs.len());
                    src.push_row_runs(r, &mut buf, runs);
                }
            }
            per
        })
        .collect();
    let mut by_key: Vec<Vec<(Vec<Run>, Vec<usize>)>> = keys
        .iter()
        .map(|_| Vec::with_capacity(parts.len()))
        .collect();
    for band in parts {
        for (k, part) in by_key.iter_mut().zip(band) {
            k.push(part);
        }
    }
    by_key.into_iter().map(RowRuns::concat).collect()
}

/// `count_u` of one binarisation given by its runs.
fn count_direct(grid: &Grid, runs: &RowRuns, min_area: u32) -> usize {
    count_enclosed_runs(
        &runs.runs,
        &runs.row_start,
        grid.height,
        grid.width,
        min_area,
    )
}

/// One binarisation labelled by runs.
fn direct(grid: &Grid, cut: u16, unknown_free: bool, min_area: u32) -> usize {
    if cut == 256 && !unknown_free {
        return 0; // nothing is free
    }
    let rows = FreeRows {
        grid,
        cut,
        unknown_free,
    };
    let runs = RowRuns::of(&rows, grid.height, grid.width);
    count_direct(grid, &runs, min_area)
}

const ABSENT: i32 = i32::MIN;

/// Union-find over cells with incremental counting of "good" components (no border cell,
/// at least `min_area` cells). Roots hold `-size`; absent cells hold [`ABSENT`].
struct Forest {
    parent: Vec<i32>,
    border: Vec<u64>,
    min_area: u32,
    good: usize,
}

impl Forest {
    #[inline]
    fn find(&mut self, mut x: usize) -> usize {
        loop {
            let p = self.parent[x];
            if p < 0 {
                return x;
            }
            let gp = self.parent[p as usize];
            if gp < 0 {
                return p as usize;
            }
            self.parent[x] = gp;
            x = gp as usize;
        }
    }

    #[inline]
    fn is_good(&self, root: usize) -> bool {
        let size = (-(self.parent[root] as i64)) as u64;
        (self.border[root >> 6] >> (root & 63)) & 1 == 0 && size >= self.min_area as u64
    }

    #[inline]
    fn add(&mut self, x: usize, on_border: bool) {
        self.parent[x] = -1;
        if on_border {
            self.border[x >> 6] |= 1 << (x & 63);
        }
        self.good += self.is_good(x) as usize;
    }

    #[inline]
    fn join(&mut self, a: usize, b: usize) {
        let ra = self.find(a);
        let rb = self.find(b);
        if ra == rb {
            return;
        }
        self.good -= self.is_good(ra) as usize + self.is_good(rb) as usize;
        let (sa, sb) = (-(self.parent[ra] as i64), -(self.parent[rb] as i64));
        let (big, small) = if sa >= sb { (ra, rb) } else { (rb, ra) };
        // sizes saturate at i32::MAX, above any allowed min_area
        self.parent[big] = -((sa + sb).min(i32::MAX as i64) as i32);
        self.parent[small] = big as i32;
        if (self.border[small >> 6] >> (small & 63)) & 1 == 1 {
            self.border[big >> 6] |= 1 << (big & 63);
        }
        self.good += self.is_good(big) as usize;
    }

    #[inline]
    fn present(&self, x: usize) -> bool {
        self.parent[x] != ABSENT
    }
}

/// Every threshold of one family in one pass. The smallest free set (the highest cut) is
/// labelled by runs and seeds the forest; the known cells below that cut then join in
/// decreasing value order, and the count of good components is read off each time the cut
/// falls to a needed value.
fn incremental(
    grid: &Grid,
    hist: &Histogram,
    unknown_free: bool,
    cuts: &[u16],
    min_area: u32,
) -> Vec<(u16, usize)> {
    let (h, w) = (grid.height, grid.width);
    let mut wanted: Vec<u16> = cuts.to_vec();
    wanted.sort_unstable_by(|a, b| b.cmp(a));
    wanted.dedup();
    let (Some(&top), Some(&lowest)) = (wanted.first(), wanted.last()) else {
        return Vec::new();
    };
    let (top, lowest) = (top as usize, lowest as usize);
    let mut f = seed(grid, top as u16, unknown_free, min_area);
    // counting sort of the known cells with lowest <= v < top, by value (raster order within
    // one value): bucket v is order[start[v + 1]..start[v]]
    let mut start = [0usize; 257];
    for v in (lowest..top).rev() {
        start[v] = start[v + 1] + hist.known[v] as usize;
    }
    let mut fill = [0usize; 256];
    fill[lowest..top].copy_from_slice(&start[lowest + 1..top + 1]);
    let mut order = vec![0u32; start[lowest]];
    if lowest < top {
        // blocks of 16 cells with no known value in [lowest, top) (most of a map: free space,
        // walls, canvas) are passed over after one branch-free test
        let (lo16, span) = (lowest as u16, (top - lowest) as u16);
        let in_range = |v: u8, u: bool| !u & ((v as u16).wrapping_sub(lo16) < span);
        for (blk, (vs, us)) in grid
            .values
            .chunks(16)
            .zip(grid.unknown.chunks(16))
            .enumerate()
        {
            if !vs
                .iter()
                .zip(us)
                .fold(false, |a, (&v, &u)| a | in_range(v, u))
            {
                continue;
            }
            for (j, (&v, &u)) in vs.iter().zip(us).enumerate() {
                if in_range(v, u) {
                    let v = v as usize;
                    order[fill[v]] = (blk * 16 + j) as u32;
                    fill[v] += 1;
                }
            }
        }
    }
    let edge = |r: usize, c: usize| r == 0 || c == 0 || r + 1 == h || c + 1 == w;
    let mut out = Vec::with_capacity(wanted.len());
    let mut v = top; // known values >= v have joined
    for cut in wanted {
        while v > cut as usize {
            v -= 1;
            let bucket = &order[start[v + 1]..start[v]];
            let (mut r, mut row0) = (0usize, 0usize);
            for &idx in bucket {
                let idx = idx as usize;
                while idx >= row0 + w {
                    r += 1;
                    row0 += w;
                }
                let c = idx - row0;
                f.add(idx, edge(r, c));
                let (up, down, left, right) = (r > 0, r + 1 < h, c > 0, c + 1 < w);
                let mut try_join = |n: usize| {
                    if f.present(n) {
                        f.join(idx, n);
                    }
                };
                if up {
                    if left {
                        try_join(idx - w - 1);
                    }
                    try_join(idx - w);
                    if right {
                        try_join(idx - w + 1);
                    }
                }
                if left {
                    try_join(idx - 1);
                }
                if right {
                    try_join(idx + 1);
                }
                if down {
                    if left {
                        try_join(idx + w - 1);
                    }
                    try_join(idx + w);
                    if right {
                        try_join(idx + w + 1);
                    }
                }
            }
        }
        out.push((cut, f.good));
    }
    out
}

/// A forest holding the components of one binarisation, from a run labelling: every cell
/// of a component points at the component's first cell, which holds its size.
fn seed(grid: &Grid, cut: u16, unknown_free: bool, min_area: u32) -> Forest {
    let (h, w) = (grid.height, grid.width);
    let mut f = Forest {
        parent: vec![ABSENT; h * w],
        border: vec![0u64; (h * w).div_ceil(64)],
        min_area,
        good: 0,
    };
    let rows = FreeRows {
        grid,
        cut,
        unknown_free,
    };
    let comps = Components::label(&rows, h, w);
    comps.for_each_run(|r, run, root_cell, size, on_border| {
        let base = r * w;
        let cells = base + run.start as usize..base + run.end as usize;
        f.parent[cells].fill(root_cell as i32);
        if base + run.start as usize == root_cell {
            f.parent[root_cell] = -(size.min(i32::MAX as u32) as i32);
            if on_border {
                f.border[root_cell >> 6] |= 1 << (root_cell & 63);
            }
            f.good += f.is_good(root_cell) as usize;
        }
    });
    f
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_straight_from_the_grid_equal_the_byte_rows() {
        let mut st = 41u64;
        let mut next = || {
            st = st
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            st >> 33
        };
        for trial in 0..40 {
            let (h, w) = (1 + next() as usize % 9, 1 + next() as usize % 300);
            let v: Vec<u8> = (0..h * w)
                .map(|_| [0u8, 1, 100, 205, 253, 254, 255][next() as usize % 7])
                .collect();
            let u: Vec<bool> = (0..h * w).map(|_| next() % 100 < trial * 2).collect();
            let grid = Grid::new(&v, &u, h, w).unwrap();
            let mut keys = Vec::new();
            for unknown_free in [false, true] {
                for cut in [0u16, 1, 100, 254, 255, 256] {
                    keys.push(Binarisation { unknown_free, cut });
                    let rows = FreeRows {
                        grid: &grid,
                        cut,
                        unknown_free,
                    };
                    let mut buf = vec![0u8; w];
                    let bytes: Vec<u8> = (0..h)
                        .flat_map(|r| rows.row(r, &mut buf).to_vec())
                        .collect();
                    let expect = RowRuns::of(
                        &crate::label::MaskRows {
                            mask: &bytes,
                            width: w,
                        },
                        h,
                        w,
                    );
                    let got = RowRuns::of(&rows, h, w);
                    assert_eq!(
                        (&got.runs, &got.row_start),
                        (&expect.runs, &expect.row_start)
                    );
                    for r in 0..h {
                        let mut plain = Vec::new();
                        free_runs_plain(
                            grid.value_row(r),
                            grid.unknown_row(r),
                            cut,
                            unknown_free,
                            &mut plain,
                        );
                        assert_eq!(plain, expect.row(r), "{h}x{w} cut {cut} row {r}");
                    }
                }
            }
            for (b, many) in keys.iter().zip(runs_of_many(&grid, &keys)) {
                let one = RowRuns::of(
                    &FreeRows {
                        grid: &grid,
                        cut: b.cut,
                        unknown_free: b.unknown_free,
                    },
                    h,
                    w,
                );
                assert_eq!((&many.runs, &many.row_start), (&one.runs, &one.row_start));
            }
        }
    }

    /// The literal definition: one labelling per swept u.
    fn literal(grid: &Grid, hist: &Histogram, params: &EnclosedParams) -> Vec<usize> {
        let table = threshold_table(hist);
        (0..256usize)
            .step_by(params.sweep_step)
            .map(|u| {
                let t = table[u] as usize;
                let free: Vec<u8> = grid
                    .values
                    .iter()
                    .zip(grid.unknown)
                    .map(|(&v, &k)| ((if k { u } else { v as usize }) > t) as u8)
                    .collect();
                let rows = crate::label::MaskRows {
                    mask: &free,
                    width: grid.width,
                };
                Components::label(&rows, grid.height, grid.width).count_enclosed(params.min_area)
            })
            .collect()
    }

    fn lcg(state: &mut u64) -> u64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        *state >> 33
    }

    #[test]
    fn rooms() {
        // two closed rooms in unknown space
        let rows = [
            "??????????????",
            "?#####?#####??",
            "?#...#?#...#??",
            "?#...#?#.#.#??",
            "?#####?#####??",
            "??????????????",
        ];
        let (h, w) = (rows.len(), rows[0].len());
        let mut v = Vec::new();
        let mut u = Vec::new();
        for r in rows {
            for b in r.bytes() {
                v.push(match b {
                    b'#' => 0,
                    b'.' => 254,
                    _ => 205,
                });
                u.push(b == b'?');
            }
        }
        let g = Grid::new(&v, &u, h, w).unwrap();
        let hist = g.histogram();
        let p = EnclosedParams::default();
        let c = sweep(&g, &hist, &p);
        assert_eq!(c, literal(&g, &hist, &p));
        assert_eq!(*c.iter().max().unwrap(), 2);
    }

    #[test]
    fn fast_equals_literal_on_graded_noise() {
        let mut s = 7u64;
        for trial in 0..40 {
            let h = 1 + (lcg(&mut s) % 40) as usize;
            let w = 1 + (lcg(&mut s) % 40) as usize;
            let levels = 2 + lcg(&mut s) % 200;
            let unk_pct = lcg(&mut s) % 60;
            let v: Vec<u8> = (0..h * w)
                .map(|_| ((lcg(&mut s) % levels) * 255 / levels.max(1)) as u8)
                .collect();
            let u: Vec<bool> = (0..h * w).map(|_| lcg(&mut s) % 100 < unk_pct).collect();
            let g = Grid::new(&v, &u, h, w).unwrap();
            let hist = g.histogram();
            for p in [
                EnclosedParams {
                    sweep_step: 1,
                    min_area: 1,
                },
                EnclosedParams {
                    sweep_step: 3,
                    min_area: 3,
                },
            ] {
                assert_eq!(
                    sweep(&g, &hist, &p),
                    literal(&g, &hist, &p),
                    "trial {trial}"
                );
                // force the incremental path too, against direct labelling
                for uf in [false, true] {
                    let cuts: Vec<u16> = (0..=256u16).step_by(17).collect();
                    for (cut, n) in incremental(&g, &hist, uf, &cuts, p.min_area) {
                        assert_eq!(
                            n,
                            direct(&g, cut, uf, p.min_area),
                            "trial {trial} cut {cut}"
                        );
                    }
                }
            }
        }
    }
}
