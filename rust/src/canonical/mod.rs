//! SPEC section 3a: the canonical corner count. The map's known bounding box is turned to
//! its dominant wall direction and resampled to a reference resolution, and the SPEC-3
//! corners of that canonical map are counted. The reference function is
//! `slamq.metrics.reference.canonical_corner_count`; every step below is integer
//! arithmetic or one float64 formula evaluated in the same order on both sides.
//!
//! The wall angle reads the grid a few rows at a time (`angle_of_box`: neither the
//! structure image nor its blur is ever whole in memory); the resample reads the box packed
//! one `u16` per cell (`pack_box`). The resample has a fast path for up to 4 x 4 samples per
//! output cell (one gather per sample, addresses in float arithmetic that vectorises) beside
//! the general one; output tiles (32 x 32, and 8 x 8 inside them on the fast path) whose
//! samples all fall on unknown 8 x 8 blocks of the box are left unknown, and those whose
//! samples all fall on known blocks of one value take that value, without sampling. The
//! wall angle's tasks (blur, Sobel and `g^4/|g|^3` terms) and the fast resample run as AVX2
//! copies of themselves when the processor has it (runtime detection; the same operations,
//! so the same results). The tests compare every path with each other and the resample with
//! a literal one.

use crate::border::reflect101;
use crate::corners::count_corners_of_structure;
use crate::grid::{known_bounds, Bounds, Grid};
use crate::memory::{reserve_working_set, OutOfMemory};
use crate::params::CornerParams;
use rayon::prelude::*;

/// Canonical maps larger than this are not built (`corners_canonical` is then `None`): a
/// very coarse map resampled to a fine reference resolution.
pub const MAX_CANONICAL_CELLS: usize = 1 << 30;

/// A `Vec` of `n` copies of `x`, or `OutOfMemory`.
fn filled<T: Clone>(n: usize, x: T) -> Result<Vec<T>, OutOfMemory> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| OutOfMemory {
        bytes: n.saturating_mul(std::mem::size_of::<T>()),
    })?;
    v.resize(n, x);
    Ok(v)
}

/// Whether the processor has AVX2 (cached by std after the first call): the hot loops of
/// this module then run as AVX2 copies of themselves, the same operations on wider
/// registers (the same results; no FMA).
#[cfg(target_arch = "x86_64")]
#[inline]
fn has_avx2() -> bool {
    std::arch::is_x86_feature_detected!("avx2")
}

/// A known cell of the packed box ([`pack_box`]) has this bit set, on top of its value.
const KNOWN: u16 = 1 << 12;
/// The value bits of a packed cell (its value when known, 0 when unknown).
const VALUE: u16 = KNOWN - 1;

/// The box's cells packed one `u16` each, row-major with the box's width as stride (then
/// zeros up to a power-of-two length): the value plus [`KNOWN`] for a known cell, 0 for an
/// unknown one. `p & VALUE` is the
/// structure image (SPEC 3 step 1); the sum of up to 16 packed cells is `sum + 4096 k`
/// (`k` the number of known ones), which is what a resampled cell needs.
fn pack_box(grid: &Grid, (r0, r1, c0, c1): Bounds) -> Result<Vec<u16>, OutOfMemory> {
    let (h, w) = (r1 - r0, c1 - c0);
    const ROWS: usize = 64; // per parallel task
                            // zero-padded to a power of two: the resample's gathers mask their indices instead of
                            // checking them
    let n = (h * w).next_power_of_two();
    let mut out: Vec<u16> = Vec::new();
    out.try_reserve_exact(n)
        .map_err(|_| OutOfMemory { bytes: 2 * n })?;
    // every cell written once (no zero fill first)
    let spare = &mut out.spare_capacity_mut()[..n];
    let (cells, padding) = spare.split_at_mut(h * w);
    cells
        .par_chunks_mut(w * ROWS)
        .enumerate()
        .for_each(|(t, block)| {
            for (i, o) in block.chunks_mut(w).enumerate() {
                let at = (r0 + t * ROWS + i) * grid.width + c0;
                let (v, u) = (&grid.values[at..at + w], &grid.unknown[at..at + w]);
                for ((o, &v), &u) in o.iter_mut().zip(v).zip(u) {
                    o.write((u16::from(v) | KNOWN) * u16::from(!u));
                }
            }
        });
    for p in padding {
        p.write(0);
    }
    // SAFETY: the first n elements were all written just above
    unsafe { out.set_len(n) };
    Ok(out)
}

/// The 9-tap binomial (two 5-tap binomial blurs in one), sum 256.
const B9: [u16; 9] = [1, 8, 28, 56, 70, 56, 28, 8, 1];

/// `D`: the 9x9 binomial sum of the packed box's known values ([`pack_box`], `h x w`;
/// unknown cells count 0; reflect-101 at the box's edges) at every second row and column
/// (rows and columns 0, 2, 4, ...), `ceil(h/2) x ceil(w/2)`; exact in `i32` (at most
/// 255 * 256^2). Each output row is one vertical pass over nine input rows, exact in `u16`
/// (at most 255 * 256), then the decimated horizontal taps. (The wall angle computes the
/// same rows a few at a time, [`angle_of_box`]; this whole image is the tests' baseline.)
#[cfg(test)]
fn blur9_decimated(
    packed: &[u16],
    h: usize,
    w: usize,
) -> Result<(Vec<i32>, usize, usize), OutOfMemory> {
    let (hd, wd) = (h.div_ceil(2), w.div_ceil(2));
    let mut out = filled(hd * wd, 0i32)?;
    out.par_chunks_mut(wd).enumerate().for_each_init(
        || (vec![0u16; w], vec![0u16; w]),
        |(vert, full), (rd, o)| {
            let rows: [&[u16]; 9] = std::array::from_fn(|k| {
                let rr = reflect101((2 * rd) as isize + k as isize - 4, h);
                &packed[rr * w..(rr + 1) * w]
            });
            blur_row_in(rows, vert, full, o);
        },
    );
    Ok((out, hd, wd))
}

/// One row of `D` ([`blur9_decimated`]) from the nine structure rows around it (packed
/// cells, [`pack_box`], or plain values: the value bits are taken): the vertical taps into
/// `vert` (`u16`), split into its even and odd columns in `split` (`w` cells), and the
/// horizontal taps at every second column into `o`.
#[inline(always)]
fn blur_row_in(rows: [&[u16]; 9], vert: &mut [u16], split: &mut [u16], o: &mut [i32]) {
    let w = vert.len();
    // the symmetric taps 1, 8, 28, 56 | 70: four sums of a pair and the centre, exact in u16
    let [r0, r1, r2, r3, r4, r5, r6, r7, r8] = rows.map(|r| &r[..w]);
    for (x, v) in vert.iter_mut().enumerate() {
        let p = |r: &[u16]| r[x] & VALUE;
        *v = (p(r0) + p(r8))
            + 8 * (p(r1) + p(r7))
            + 28 * (p(r2) + p(r6))
            + 56 * (p(r3) + p(r5))
            + 70 * p(r4);
    }
    let tap = |x: usize, k: usize| i32::from(B9[k]) * i32::from(vert[x]);
    // the horizontal taps only at the even columns D keeps: with the even and odd columns
    // apart, the taps of x = 2 xd are shifted slices again (even columns x-4, x-2, .., x+4
    // are ve[xd-2 ..= xd+2], odd ones x-3, .., x+3 are vo[xd-2 ..= xd+1])
    let inner = (2usize, w.saturating_sub(3) / 2); // xd with 4 <= 2 xd and 2 xd + 4 < w
    if w >= 9 {
        let (ve, vo) = split.split_at_mut(w.div_ceil(2));
        for ((e, o), pair) in ve.iter_mut().zip(vo.iter_mut()).zip(vert.chunks_exact(2)) {
            *e = pair[0];
            *o = pair[1];
        }
        if w % 2 == 1 {
            ve[w / 2] = vert[w - 1];
        }
        let n = inner.1 - inner.0;
        let e = |k: usize| &ve[k..k + n];
        let d = |k: usize| &vo[k..k + n];
        let (e0, e1, e2, e3, e4) = (e(0), e(1), e(2), e(3), e(4));
        let (d0, d1, d2, d3) = (d(0), d(1), d(2), d(3));
        for (x, f) in o[inner.0..inner.1].iter_mut().enumerate() {
            let q = |s: &[u16]| i32::from(s[x]);
            *f = (q(e0) + q(e4))
                + 8 * (q(d0) + q(d3))
                + 28 * (q(e1) + q(e3))
                + 56 * (q(d1) + q(d2))
                + 70 * q(e2);
        }
    }
    // the columns near the edges (all of them in a row narrower than 9)
    let wd = o.len();
    let (left, right) = if w >= 9 { inner } else { (wd, wd) };
    for xd in (0..left).chain(right..wd) {
        let x = 2 * xd;
        o[xd] = (0..9)
            .map(|k| tap(reflect101(x as isize + k as isize - 4, w), k))
            .sum();
    }
}

/// `x` rounded half to even, for `|x| < 2^51` (the terms are below `|g| < 2^31`): adding
/// and subtracting 1.5 * 2^52 rounds in the FPU's default mode, which is half to even, the
/// same as `round_ties_even` and numpy's `rint`, without the libm call that baseline x86-64
/// makes of `round_ties_even`.
#[inline]
fn rint_f(x: f64) -> f64 {
    const MAGIC: f64 = 6_755_399_441_055_744.0;
    (x + MAGIC) - MAGIC
}

#[cfg(test)]
fn rint(x: f64) -> i64 {
    rint_f(x) as i64
}

/// The `g**4 / |g|**3` terms of one cell's Sobel gradient, rounded half to even (SPEC 3a.2),
/// as integer-valued floats: `(0, 0)` for a zero gradient. Branch-free, so that a row of
/// them vectorises: a zero gradient divides its zero numerators by 1 instead of by 0.
#[inline]
fn angle_terms(x: f64, y: f64) -> (f64, f64) {
    let r2 = x * x + y * y;
    let a = x * x - y * y;
    let b = 2.0 * (x * y);
    let w = if r2 > 0.0 { r2 * r2.sqrt() } else { 1.0 };
    (rint_f((a * a - b * b) / w), rint_f((2.0 * (a * b)) / w))
}

/// Cells per partial sum of the angle terms: each term is an integer below `|g| < 2^27`
/// (`D < 2^24`, a Sobel derivative at most 4 of them), so a float sum of this many is
/// exact (below 2^53) whatever the order.
const TERMS_PER_SUM: usize = 1 << 20;

/// Scratch rows of [`sobel_terms_row`]: per column of a row of `D`, the vertical Sobel
/// smoothing `up + 2 mid + down`, the vertical difference `down - up`, and the two
/// derivatives.
#[derive(Default)]
struct SobelRows {
    col: Vec<i32>,
    dv: Vec<i32>,
    gx: Vec<i32>,
    gy: Vec<i32>,
}

/// The sums of the rounded angle terms (SPEC 3a.2) of one row of `D`, given its rows
/// `[up, mid, down]` (reflect-101 already applied). The 3x3 Sobel derivatives are exact in
/// `i32` (at most 4 * 255 * 256^2), so `gy` may be formed from the vertical differences.
/// Inlined into its callers, so that in [`angle_task_avx2`] the integer loops are AVX2 too.
#[inline(always)]
fn sobel_terms_row([up, mid, down]: [&[i32]; 3], s: &mut SobelRows) -> (i64, i64) {
    let w = mid.len();
    for v in [&mut s.col, &mut s.dv, &mut s.gx, &mut s.gy] {
        v.resize(w, 0);
    }
    for (((c, d), (&u, &m)), &dn) in s
        .col
        .iter_mut()
        .zip(&mut s.dv)
        .zip(up.iter().zip(mid))
        .zip(down)
    {
        *c = u + 2 * m + dn;
        *d = dn - u;
    }
    let (col, dv) = (&s.col, &s.dv);
    for x in [0, w - 1] {
        let (l, rt) = (reflect101(x as isize - 1, w), reflect101(x as isize + 1, w));
        s.gx[x] = col[rt] - col[l];
        s.gy[x] = dv[l] + 2 * dv[x] + dv[rt];
    }
    if w > 2 {
        let inner = s.gx[1..w - 1].iter_mut().zip(&mut s.gy[1..w - 1]);
        let (cl, cr) = (&col[..w - 2], &col[2..]);
        let (dl, dm, dr) = (&dv[..w - 2], &dv[1..w - 1], &dv[2..]);
        for (((gx, gy), (&cl, &cr)), ((&dl, &dm), &dr)) in
            inner.zip(cl.iter().zip(cr)).zip(dl.iter().zip(dm).zip(dr))
        {
            *gx = cr - cl;
            *gy = dl + 2 * dm + dr;
        }
    }
    let (mut sre, mut sim) = (0i64, 0i64);
    for (xs, ys) in s.gx.chunks(TERMS_PER_SUM).zip(s.gy.chunks(TERMS_PER_SUM)) {
        // four partial sums, so that the loop vectorises (exact in any order)
        let (re4, im4) = angle_sums(xs, ys, true);
        sre += re4.iter().map(|&v| v as i64).sum::<i64>();
        sim += im4.iter().map(|&v| v as i64).sum::<i64>();
    }
    (sre, sim)
}

/// Four partial sums (lanes) of the [`angle_terms`] of `xs`, `ys` (at most
/// [`TERMS_PER_SUM`] cells: exact in any order); with AVX2 when `best` and the processor has
/// it (the same terms).
fn angle_sums(xs: &[i32], ys: &[i32], best: bool) -> ([f64; 4], [f64; 4]) {
    let (xq, yq) = (xs.chunks_exact(4), ys.chunks_exact(4));
    let (xr, yr) = (xq.remainder(), yq.remainder());
    let (mut re4, mut im4) = ([0.0f64; 4], [0.0f64; 4]);
    #[cfg(target_arch = "x86_64")]
    let simd = best && has_avx2();
    #[cfg(not(target_arch = "x86_64"))]
    let simd = best && false;
    if simd {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: the processor has AVX2, checked just above
            (re4, im4) = unsafe { angle_sums_avx2(xs, ys) };
        }
    } else {
        for (x4, y4) in xq.zip(yq) {
            // most cells of a map have no gradient (unknown canvas, open floor): their
            // terms are 0
            if (x4[0] | x4[1] | x4[2] | x4[3] | y4[0] | y4[1] | y4[2] | y4[3]) == 0 {
                continue;
            }
            for l in 0..4 {
                let (a, b) = angle_terms(f64::from(x4[l]), f64::from(y4[l]));
                re4[l] += a;
                im4[l] += b;
            }
        }
    }
    for (&x, &y) in xr.iter().zip(yr) {
        let (a, b) = angle_terms(f64::from(x), f64::from(y));
        re4[0] += a;
        im4[0] += b;
    }
    (re4, im4)
}

/// The four lanes' sums of [`angle_terms`] over the whole groups of four of `xs`, `ys` (the
/// caller adds the remainder), with AVX2: the same float64 operations in the same order
/// (no FMA), four cells at a time, so the same terms; groups without a gradient skipped.
///
/// # Safety
/// The processor must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn angle_sums_avx2(xs: &[i32], ys: &[i32]) -> ([f64; 4], [f64; 4]) {
    use std::arch::x86_64::*;
    let (mut re, mut im) = (_mm256_setzero_pd(), _mm256_setzero_pd());
    let zero = _mm256_setzero_pd();
    let (one, two) = (_mm256_set1_pd(1.0), _mm256_set1_pd(2.0));
    let magic = _mm256_set1_pd(6_755_399_441_055_744.0);
    for (x4, y4) in xs.chunks_exact(4).zip(ys.chunks_exact(4)) {
        // SAFETY: 16 bytes of each chunk of four i32
        let (xi, yi) = unsafe {
            (
                _mm_loadu_si128(x4.as_ptr() as *const __m128i),
                _mm_loadu_si128(y4.as_ptr() as *const __m128i),
            )
        };
        if _mm_testz_si128(_mm_or_si128(xi, yi), _mm_or_si128(xi, yi)) != 0 {
            continue; // no gradient: terms 0
        }
        let (x, y) = (_mm256_cvtepi32_pd(xi), _mm256_cvtepi32_pd(yi));
        let (xx, yy) = (_mm256_mul_pd(x, x), _mm256_mul_pd(y, y));
        let r2 = _mm256_add_pd(xx, yy);
        let a = _mm256_sub_pd(xx, yy);
        let b = _mm256_mul_pd(two, _mm256_mul_pd(x, y));
        let wr = _mm256_mul_pd(r2, _mm256_sqrt_pd(r2));
        // a zero gradient divides its zero numerators by 1
        let w = _mm256_blendv_pd(one, wr, _mm256_cmp_pd::<_CMP_GT_OQ>(r2, zero));
        let num_re = _mm256_sub_pd(_mm256_mul_pd(a, a), _mm256_mul_pd(b, b));
        let num_im = _mm256_mul_pd(two, _mm256_mul_pd(a, b));
        let rint = |v: __m256d| _mm256_sub_pd(_mm256_add_pd(v, magic), magic);
        re = _mm256_add_pd(re, rint(_mm256_div_pd(num_re, w)));
        im = _mm256_add_pd(im, rint(_mm256_div_pd(num_im, w)));
    }
    let (mut r4, mut i4) = ([0.0f64; 4], [0.0f64; 4]);
    // SAFETY: 32 bytes into each [f64; 4]
    unsafe {
        _mm256_storeu_pd(r4.as_mut_ptr(), re);
        _mm256_storeu_pd(i4.as_mut_ptr(), im);
    }
    (r4, i4)
}

/// The dominant wall direction modulo 90 degrees of the known bounding box, radians in
/// (-pi/4, pi/4] (image axes: +x right, +y down). 0 for a map without known cells or
/// gradient. SPEC 3a.2: the structure image's 9x9 binomial blur taken at every second row
/// and column (`D`), its 3x3 Sobel derivatives on that grid (reflect-101), and the sum of
/// `g**4 / |g|**3` per cell, rounded to integers.
pub fn wall_angle(grid: &Grid) -> Result<f64, OutOfMemory> {
    wall_angle_in(grid, known_bounds(grid))
}

/// [`wall_angle`] with the known cells' bounding box already found ([`known_bounds`]).
pub fn wall_angle_in(grid: &Grid, bounds: Option<Bounds>) -> Result<f64, OutOfMemory> {
    Ok(match bounds {
        Some(b) => angle_of_box(grid, b),
        None => 0.0,
    })
}

/// Rows of `D` per parallel task of [`angle_of_box`].
const ANGLE_TASK_ROWS: usize = 64;

/// Rows of the structure image a task of [`angle_of_box`] holds: a power of two above the
/// nine that one row of `D` reads, which lie within nine consecutive rows, so that they
/// never share a slot.
const STRUCTURE_SLOTS: usize = 16;

/// One task's rows of the box's structure image (SPEC 3 step 1: a known cell's value, 0
/// for an unknown one), row `i` in slot `i % STRUCTURE_SLOTS`, each made once.
struct StructureRows {
    cells: Vec<u16>,
    held: [usize; STRUCTURE_SLOTS],
}

impl StructureRows {
    fn new(w: usize) -> Self {
        StructureRows {
            cells: vec![0; STRUCTURE_SLOTS * w],
            held: [usize::MAX; STRUCTURE_SLOTS],
        }
    }

    /// Box rows `rows` (each below the box's height), made from the grid where not held.
    #[inline(always)]
    fn get(&mut self, grid: &Grid, (r0, _, c0, c1): Bounds, rows: [usize; 9]) -> [&[u16]; 9] {
        let w = c1 - c0;
        for i in rows {
            let slot = i % STRUCTURE_SLOTS;
            if self.held[slot] != i {
                let at = (r0 + i) * grid.width + c0;
                let (v, u) = (&grid.values[at..at + w], &grid.unknown[at..at + w]);
                let out = &mut self.cells[slot * w..(slot + 1) * w];
                for ((o, &v), &u) in out.iter_mut().zip(v).zip(u) {
                    *o = u16::from(v) * u16::from(!u);
                }
                self.held[slot] = i;
            }
        }
        let cells = &self.cells;
        rows.map(|i| {
            let slot = i % STRUCTURE_SLOTS;
            &cells[slot * w..(slot + 1) * w]
        })
    }
}

/// [`wall_angle`] of the known box `b`: the rows of `D` ([`blur9_decimated`]'s image) and
/// their Sobel terms made a few rows at a time, in tasks of [`ANGLE_TASK_ROWS`] rows of
/// `D`, each reading its structure rows from the grid once ([`StructureRows`]) and keeping
/// three rows of `D` (the one above its first row and the one below its last made again),
/// so that neither the structure image nor `D` is ever whole in memory. The integer sums do
/// not depend on the tasks.
fn angle_of_box(grid: &Grid, b: Bounds) -> f64 {
    let (h, w) = (b.1 - b.0, b.3 - b.2);
    let (hd, wd) = (h.div_ceil(2), w.div_ceil(2));
    let tasks = hd.div_ceil(ANGLE_TASK_ROWS);
    let (re, im) = (0..tasks)
        .into_par_iter()
        .map_init(
            || AngleScratch {
                structure: StructureRows::new(w),
                vert: vec![0u16; w],
                split: vec![0u16; w],
                ring: vec![0i32; 3 * wd],
                sobel: SobelRows::default(),
            },
            |scratch, t| angle_task(grid, b, t, scratch),
        )
        .reduce(|| (0, 0), |x, y| (x.0 + y.0, x.1 + y.1));
    if re == 0 && im == 0 {
        return 0.0;
    }
    (im as f64).atan2(re as f64) / 4.0
}

/// What one task of [`angle_of_box`] works in: its structure rows, the blur's two rows, three
/// rows of `D` and the Sobel rows.
struct AngleScratch {
    structure: StructureRows,
    vert: Vec<u16>,
    split: Vec<u16>,
    ring: Vec<i32>,
    sobel: SobelRows,
}

/// The sums of the angle terms of rows `t * ANGLE_TASK_ROWS ..` of `D` (at most
/// [`ANGLE_TASK_ROWS`] of them) in the known box `b`; with AVX2 when the processor has it
/// (integer arithmetic and the same angle terms: the same sums).
fn angle_task(grid: &Grid, b: Bounds, t: usize, scratch: &mut AngleScratch) -> (i64, i64) {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        // SAFETY: the processor has AVX2, checked just above
        return unsafe { angle_task_avx2(grid, b, t, scratch) };
    }
    angle_task_in(grid, b, t, scratch)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn angle_task_avx2(grid: &Grid, b: Bounds, t: usize, scratch: &mut AngleScratch) -> (i64, i64) {
    angle_task_in(grid, b, t, scratch)
}

#[inline(always)]
fn angle_task_in(grid: &Grid, b: Bounds, t: usize, scratch: &mut AngleScratch) -> (i64, i64) {
    let (h, w) = (b.1 - b.0, b.3 - b.2);
    let (hd, wd) = (h.div_ceil(2), w.div_ceil(2));
    let (a, z) = (t * ANGLE_TASK_ROWS, ((t + 1) * ANGLE_TASK_ROWS).min(hd));
    let AngleScratch {
        structure,
        vert,
        split,
        ring,
        sobel,
    } = scratch;
    let (mut re, mut im) = (0i64, 0i64);
    // rows a - 1 ..= z of D (reflect-101 at D's edges), in ring slots by their place; the
    // Sobel terms of row k as soon as row k + 1 is made
    for (n, k) in (a as isize - 1..=z as isize).enumerate() {
        let rd = reflect101(k, hd);
        let rows: [usize; 9] =
            std::array::from_fn(|j| reflect101((2 * rd) as isize + j as isize - 4, h));
        let o = &mut ring[(n % 3) * wd..(n % 3 + 1) * wd];
        blur_row_in(structure.get(grid, b, rows), vert, split, o);
        if n >= 2 {
            let row = |m: usize| &ring[(m % 3) * wd..(m % 3 + 1) * wd];
            let (r, i) = sobel_terms_row([row(n - 2), row(n - 1), row(n)], sobel);
            re += r;
            im += i;
        }
    }
    (re, im)
}

/// [`wall_angle`] of the packed box ([`pack_box`], `h x w`), from the whole of `D`: the
/// tests' baseline for [`angle_of_box`].
#[cfg(test)]
fn angle_in(packed: &[u16], h: usize, w: usize) -> f64 {
    let (g2, h, w) = blur9_decimated(packed, h, w).unwrap();
    let (re, im) = g2
        .par_chunks(w)
        .enumerate()
        .map_init(SobelRows::default, |scratch, (r, _)| {
            let row = |k: isize| {
                let rr = reflect101(r as isize + k, h);
                &g2[rr * w..(rr + 1) * w]
            };
            sobel_terms_row([row(-1), row(0), row(1)], scratch)
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    if re == 0 && im == 0 {
        return 0.0;
    }
    (im as f64).atan2(re as f64) / 4.0
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
        Some(b) => map_in(grid, &pack_box(grid, b)?, b, angle, resolution, reference),
        None => Ok(Some(CanonicalMap {
            values: grid.values.to_vec(),
            unknown: grid.unknown.to_vec(),
            height: grid.height,
            width: grid.width,
        })),
    }
}

/// 2^52: a float in `0..2^52` plus this has its integer part as the low bits of its
/// mantissa, rounded to nearest.
const TWO52: f64 = 4_503_599_627_370_496.0;

/// `floor(clamp(p, 0, last))` for `last < 2^52` (NaN gives 0), in float operations only:
/// with `ROUND` by `floor` (one instruction where SSE4.1 is enabled, a library call on
/// baseline x86-64), else the clamped value rounded to an integer (to nearest), less one
/// where that rounded up. Both are exact: the same result.
#[inline(always)]
fn floor_in<const ROUND: bool>(p: f64, last: f64) -> f64 {
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
fn float_bits_index(x: f64) -> u64 {
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
fn half_up_mean(t: u32, k: u32) -> u32 {
    let m = HALF_UP_RECIPROCALS[(k as usize).min(16)];
    ((2 * t + k) * m) >> 18
}

/// [`half_up_mean`] for at most 4 samples, of which at least 2 are known (the other case is
/// unknown, its mean unused): `x / 4`, `x / 6` (`x * ceil(2^16 / 6) / 2^16`: too large by
/// less than `x / 2^16 * 1/3 < 1/6` for `x < 2^13`) or `x / 8`, chosen without a branch or
/// a table lookup, so that a row of them vectorises.
#[inline(always)]
fn half_up_mean_of_4(t: u32, k: u32) -> u32 {
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

/// [`canonical_map`] of the box `b` (the known cells' bounding box), `packed` its cells
/// ([`pack_box`]).
fn map_in(
    grid: &Grid,
    packed: &[u16],
    b: Bounds,
    angle: f64,
    resolution: Option<f64>,
    reference: f64,
) -> Result<Option<CanonicalMap>, OutOfMemory> {
    map_in_with(grid, packed, b, angle, resolution, reference, Path::Best)
}

/// Which way [`map_in_with`] resamples (the tests compare them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Path {
    /// The fast path where it applies, with AVX2 when the processor has it.
    Best,
    /// The fast path where it applies, never AVX2.
    #[cfg(test)]
    Baseline,
    /// The general path only.
    #[cfg(test)]
    General,
}

/// [`map_in`] by the resampling `path`.
fn map_in_with(
    grid: &Grid,
    packed: &[u16],
    b: Bounds,
    angle: f64,
    resolution: Option<f64>,
    reference: f64,
    path: Path,
) -> Result<Option<CanonicalMap>, OutOfMemory> {
    let r = resample(grid, packed, b, angle, resolution, reference, path, true)?;
    Ok(r.map(|r| CanonicalMap {
        values: r.values,
        unknown: r.unknown,
        height: r.height,
        width: r.width,
    }))
}

/// The canonical map, its values being its structure image (SPEC 3 step 1: the value of a
/// known cell, 0 for an unknown one).
struct Resampled {
    /// The canonical map's values, 0 at unknown cells: its structure image.
    values: Vec<u8>,
    /// Its unknown mask, or empty when not asked for.
    unknown: Vec<bool>,
    height: usize,
    width: usize,
}

/// SPEC 3a.3: the canonical map of the box `b` ([`map_in`]), by the resampling `path`; the
/// unknown mask only when `want_unknown` (the corners need only the structure image).
#[allow(clippy::too_many_arguments)]
fn resample(
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

/// SPEC 3a: the wall angle and `corners_canonical` of a map of `resolution` metres per cell
/// (`None`: unknown, taken as the reference resolution).
pub fn canonical_corners(
    grid: &Grid,
    resolution: Option<f64>,
    params: &CornerParams,
) -> Result<Canonical, OutOfMemory> {
    canonical_corners_in(grid, known_bounds(grid), resolution, params)
}

/// [`canonical_corners`] (the wall angle alone, `corners` None, when
/// `params.canonical_resolution` is 0) with the known cells' bounding box already found
/// ([`known_bounds`]).
pub fn canonical_corners_in(
    grid: &Grid,
    bounds: Option<Bounds>,
    resolution: Option<f64>,
    params: &CornerParams,
) -> Result<Canonical, OutOfMemory> {
    if params.canonical_resolution.is_nan() || params.canonical_resolution <= 0.0 {
        // no reference resolution: the wall angle alone, as `evaluate` gives it
        return Ok(Canonical {
            angle: wall_angle_in(grid, bounds)?,
            corners: None,
        });
    }
    // both steps work inside the box
    let Some(b) = bounds else {
        return Ok(Canonical {
            angle: 0.0,
            corners: Some(0),
        });
    };
    let angle = angle_of_box(grid, b);
    let packed = pack_box(grid, b)?;
    // the structure image of the canonical map is all the corners need (no unknown mask)
    let map = resample(
        grid,
        &packed,
        b,
        angle,
        resolution,
        params.canonical_resolution,
        Path::Best,
        false,
    )?;
    drop(packed);
    let Some(map) = map else {
        return Ok(Canonical {
            angle,
            corners: None,
        });
    };
    reserve_working_set(map.height * map.width)?;
    let corners = count_corners_of_structure(&map.values, map.height, map.width, params);
    Ok(Canonical {
        angle,
        corners: Some(corners),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::corners::count_corners;

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
        let p = CornerParams {
            canonical_resolution: 0.07,
            ..CornerParams::default()
        };
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
        let p = CornerParams {
            canonical_resolution: 0.07,
            ..CornerParams::default()
        };
        let c = canonical_corners(&g, Some(0.05), &p).unwrap();
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

    /// A pseudo-random map: walls, free cells, graded values and unknown patches.
    fn random_map(h: usize, w: usize, seed: u64) -> (Vec<u8>, Vec<bool>) {
        let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let mut next = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let p_unknown = next() % 100;
        let mut v = vec![0u8; h * w];
        let mut u = vec![false; h * w];
        for i in 0..h * w {
            let r = next();
            v[i] = match r % 4 {
                0 => 0,
                1 => 254,
                2 => 205,
                _ => (r >> 8) as u8,
            };
            u[i] = (r >> 20) % 100 < p_unknown;
        }
        (v, u)
    }

    #[test]
    fn the_fast_resample_equals_the_general_one() {
        // every sample count the fast path takes (n = 2, 3, 4: f up to 4), turned by angles
        // that put samples exactly on cell edges (0, 45 degrees) and anywhere else
        let angles = [
            0.0,
            0.3,
            -std::f64::consts::FRAC_PI_4,
            std::f64::consts::FRAC_PI_4,
            -0.1,
            1e-9,
        ];
        let mut checked = 0;
        for seed in 0..40u64 {
            let (h, w) = (1 + (seed as usize * 7) % 53, 1 + (seed as usize * 13) % 61);
            let (v, u) = random_map(h, w, seed);
            let g = Grid::new(&v, &u, h, w).unwrap();
            let Some(b) = known_bounds(&g) else { continue };
            let packed = pack_box(&g, b).unwrap();
            for (k, res) in [
                None,
                Some(0.05),
                Some(0.035),
                Some(0.02),
                Some(0.0175),
                Some(0.07),
            ]
            .into_iter()
            .enumerate()
            {
                let a = angles[(seed as usize + k) % angles.len()];
                let slow = map_in_with(&g, &packed, b, a, res, 0.07, Path::General).unwrap();
                for path in [Path::Best, Path::Baseline] {
                    let fast = map_in_with(&g, &packed, b, a, res, 0.07, path).unwrap();
                    assert_eq!(
                        fast, slow,
                        "{path:?}: seed {seed}, resolution {res:?}, angle {a}"
                    );
                }
                checked += 1;
            }
        }
        assert!(checked > 150, "{checked}");
    }

    /// SPEC 3a.3 literally: every sample of every output cell, no tiles, no skipping.
    fn literal_canonical(g: &Grid, angle: f64, f: f64) -> CanonicalMap {
        let (r0, r1, c0, c1) = known_bounds(g).unwrap();
        let (h, w) = (r1 - r0, c1 - c0);
        let (c, s) = (angle.cos(), angle.sin());
        let half = |a: f64, b: f64| ((a.abs() * w as f64 + b.abs() * h as f64) / (2.0 * f)).ceil();
        let (big_w, big_h) = (2 * (half(c, s) as usize + 2), 2 * (half(s, c) as usize + 2));
        let n = (f.ceil() as usize).max(2);
        let mut out = CanonicalMap {
            values: vec![0; big_w * big_h],
            unknown: vec![true; big_w * big_h],
            height: big_h,
            width: big_w,
        };
        for i in 0..big_h {
            for j in 0..big_w {
                let (mut t, mut k) = (0u64, 0u64);
                for a in 0..n {
                    for b in 0..n {
                        let qy =
                            ((i as f64 - (big_h / 2) as f64) + (a as f64 + 0.5) / n as f64) * f;
                        let qx =
                            ((j as f64 - (big_w / 2) as f64) + (b as f64 + 0.5) / n as f64) * f;
                        let px = (c * qx - s * qy) + (w / 2) as f64;
                        let py = (s * qx + c * qy) + (h / 2) as f64;
                        let y = py.floor().clamp(0.0, (h - 1) as f64) as usize;
                        let x = px.floor().clamp(0.0, (w - 1) as f64) as usize;
                        let at = (r0 + y) * g.width + c0 + x;
                        if !g.unknown[at] {
                            t += u64::from(g.values[at]);
                            k += 1;
                        }
                    }
                }
                if 2 * k >= (n * n) as u64 {
                    out.values[i * big_w + j] = ((2 * t + k) / (2 * k)) as u8;
                    out.unknown[i * big_w + j] = false;
                }
            }
        }
        out
    }

    #[test]
    fn the_resample_equals_the_literal_one_on_maps_with_open_areas() {
        // large one-valued and unknown areas (the tiles filled or skipped without sampling),
        // beside noise, walls and a frontier
        for seed in 0..12u64 {
            let (h, w) = (
                150 + (seed as usize * 37) % 90,
                170 + (seed as usize * 53) % 80,
            );
            let (noise, nu) = random_map(h, w, seed + 7);
            let mut v = vec![254u8; h * w];
            let mut u = vec![false; h * w];
            for r in 0..h {
                for c in 0..w {
                    let i = r * w + c;
                    if c > w * 2 / 3 || (r < 20 && c < 60) {
                        u[i] = true; // unexplored
                    } else if (r / 16 + c / 24) % 5 == 0 {
                        (v[i], u[i]) = (noise[i], nu[i]); // busy patches
                    } else if r % 41 == 3 || c % 57 == 5 {
                        v[i] = 0; // walls
                    } else if (r + c) % 97 < 30 {
                        v[i] = 200; // another open shade
                    }
                }
            }
            let g = Grid::new(&v, &u, h, w).unwrap();
            let b = known_bounds(&g).unwrap();
            let packed = pack_box(&g, b).unwrap();
            for (k, res) in [0.05, 0.07, 0.035, 0.1, 0.02].into_iter().enumerate() {
                let a =
                    [0.0, 0.3, -std::f64::consts::FRAC_PI_4, 0.05, -0.2][(seed as usize + k) % 5];
                let want = literal_canonical(&g, a, 0.07 / res);
                for path in [Path::Best, Path::Baseline, Path::General] {
                    let got = map_in_with(&g, &packed, b, a, Some(res), 0.07, path)
                        .unwrap()
                        .unwrap();
                    assert_eq!(
                        got, want,
                        "{path:?}: seed {seed}, resolution {res}, angle {a}"
                    );
                }
            }
        }
    }

    #[test]
    fn the_canonical_corners_equal_those_of_the_whole_canonical_map() {
        // the corners counted from the resample's structure image alone (no unknown mask
        // built): the same count as SPEC 3 on the materialised canonical map, for any thread
        // count
        for seed in 0..10u64 {
            let (h, w) = (
                120 + (seed as usize * 29) % 90,
                140 + (seed as usize * 41) % 80,
            );
            let (noise, nu) = random_map(h, w, seed + 3);
            let mut v = vec![254u8; h * w];
            let mut u = vec![false; h * w];
            for r in 0..h {
                for c in 0..w {
                    let i = r * w + c;
                    if c > w * 3 / 4 || (r < 15 && c < 50) {
                        u[i] = true;
                    } else if (r / 20 + c / 30) % 6 == 0 {
                        (v[i], u[i]) = (noise[i], nu[i]);
                    } else if r % 37 == 3 || c % 43 == 5 || (r + 2 * c) % 91 == 0 {
                        v[i] = 0;
                    }
                }
            }
            let g = Grid::new(&v, &u, h, w).unwrap();
            for (k, res) in [None, Some(0.05), Some(0.1), Some(0.035), Some(0.02)]
                .into_iter()
                .enumerate()
            {
                let p = CornerParams {
                    log_threshold: [0.1, 0.0, 0.1, -0.05, 0.3][k],
                    canonical_resolution: 0.07,
                    ..CornerParams::default()
                };
                let angle = wall_angle(&g).unwrap();
                let m = canonical_map(&g, angle, res, p.canonical_resolution)
                    .unwrap()
                    .unwrap();
                let mg = Grid::new(&m.values, &m.unknown, m.height, m.width).unwrap();
                let want = count_corners(&mg, &p);
                for threads in [1, 2] {
                    let pool = rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .build()
                        .unwrap();
                    let got = pool.install(|| canonical_corners(&g, res, &p).unwrap());
                    assert_eq!(got.corners, Some(want), "seed {seed} res {res:?}");
                    assert_eq!(got.angle.to_bits(), angle.to_bits());
                }
            }
        }
    }

    #[test]
    fn angle_sums_are_the_same_on_every_path() {
        // gradients of every size up to the largest (4 * 255 * 256^2), zero runs, ties
        let mut x = 0x2545_F491_4F6C_DD1Du64;
        let mut next = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let big = 4 * 255 * 65536i64;
        for len in [0usize, 1, 3, 4, 5, 8, 17, 64, 1001] {
            let mut gen = |n: u64| -> Vec<i32> {
                (0..len)
                    .map(|_| match next() % 6 {
                        0 => 0,
                        1 => ((next() % (2 * big as u64 + 1)) as i64 - big) as i32,
                        2 => (next() % 9) as i32 - 4,
                        _ => ((next() % (2 * n + 1)) as i64 - n as i64) as i32,
                    })
                    .collect()
            };
            let (xs, ys) = (gen(3000), gen(70_000));
            let scalar = angle_sums(&xs, &ys, false);
            let best = angle_sums(&xs, &ys, true);
            assert_eq!(
                scalar.0.map(f64::to_bits),
                best.0.map(f64::to_bits),
                "{len}"
            );
            assert_eq!(
                scalar.1.map(f64::to_bits),
                best.1.map(f64::to_bits),
                "{len}"
            );
        }
    }

    #[test]
    fn the_decimated_blur_is_the_9x9_binomial_sum() {
        for seed in 0..30u64 {
            let (h, w) = (1 + (seed as usize * 5) % 23, 1 + (seed as usize * 11) % 29);
            let (v, u) = random_map(h, w, seed + 100);
            let g = Grid::new(&v, &u, h, w).unwrap();
            let packed = pack_box(&g, (0, h, 0, w)).unwrap();
            let (d, hd, wd) = blur9_decimated(&packed, h, w).unwrap();
            assert_eq!((hd, wd), (h.div_ceil(2), w.div_ceil(2)));
            let s = |r: usize, c: usize| {
                if u[r * w + c] {
                    0
                } else {
                    i32::from(v[r * w + c])
                }
            };
            for rd in 0..hd {
                let rows: [&[u16]; 9] = std::array::from_fn(|k| {
                    let rr = reflect101((2 * rd) as isize + k as isize - 4, h);
                    &packed[rr * w..(rr + 1) * w]
                });
                let mut baseline = vec![0i32; wd];
                blur_row_in(rows, &mut vec![0u16; w], &mut vec![0u16; w], &mut baseline);
                for cd in 0..wd {
                    let mut want = 0;
                    for i in 0..9 {
                        for j in 0..9 {
                            let r = reflect101((2 * rd + i) as isize - 4, h);
                            let c = reflect101((2 * cd + j) as isize - 4, w);
                            want += i32::from(B9[i]) * i32::from(B9[j]) * s(r, c);
                        }
                    }
                    assert_eq!(d[rd * wd + cd], want, "{h} x {w} at ({rd}, {cd})");
                    assert_eq!(baseline[cd], want, "{h} x {w} at ({rd}, {cd})");
                }
            }
        }
    }

    #[test]
    fn the_wall_angle_by_tasks_equals_the_one_from_the_whole_blur() {
        // boxes of one to three tasks' rows, odd and even sizes, inside a larger grid
        for seed in 0..24u64 {
            let h = [1, 2, 9, 17, 128, 129, 131, 300][seed as usize % 8];
            let w = [1, 3, 10, 57, 200][seed as usize % 5];
            let (v, mut u) = random_map(h + 6, w + 4, seed + 7);
            for r in 0..h + 6 {
                for c in 0..w + 4 {
                    if r < 3 || r >= h + 3 || c < 2 || c >= w + 2 {
                        u[r * (w + 4) + c] = true;
                    }
                }
            }
            let g = Grid::new(&v, &u, h + 6, w + 4).unwrap();
            let Some(b) = known_bounds(&g) else { continue };
            let want = angle_in(&pack_box(&g, b).unwrap(), b.1 - b.0, b.3 - b.2);
            assert_eq!(angle_of_box(&g, b).to_bits(), want.to_bits(), "{h} x {w}");
            assert_eq!(wall_angle(&g).unwrap().to_bits(), want.to_bits());
            // each task's sums: the AVX2 path (where there is one) and the baseline one
            let (bh, bw) = (b.1 - b.0, b.3 - b.2);
            let scratch = || AngleScratch {
                structure: StructureRows::new(bw),
                vert: vec![0u16; bw],
                split: vec![0u16; bw],
                ring: vec![0i32; 3 * bw.div_ceil(2)],
                sobel: SobelRows::default(),
            };
            let (mut best, mut base) = (scratch(), scratch());
            for t in 0..bh.div_ceil(2).div_ceil(ANGLE_TASK_ROWS) {
                assert_eq!(
                    angle_task(&g, b, t, &mut best),
                    angle_task_in(&g, b, t, &mut base),
                    "{h} x {w} task {t}"
                );
            }
        }
    }

    #[test]
    fn half_up_mean_divides_exactly() {
        for k in 1..=16u32 {
            for t in 0..=255 * k {
                assert_eq!(half_up_mean(t, k), (2 * t + k) / (2 * k), "{t} / {k}");
            }
        }
        assert_eq!(half_up_mean(0, 0), 0);
        for k in 2..=4u32 {
            for t in 0..=255 * k {
                assert_eq!(half_up_mean_of_4(t, k), (2 * t + k) / (2 * k), "{t} / {k}");
            }
        }
    }

    #[test]
    fn floor_in_is_the_clamped_floor() {
        for &(p, last) in &[
            (-0.5, 9.0),
            (0.0, 9.0),
            (0.49999999999999994, 9.0),
            (0.5, 9.0),
            (1.5, 9.0),
            (2.5, 9.0),
            (2.9999999999999996, 9.0),
            (3.0, 9.0),
            (8.999_999, 9.0),
            (9.0, 9.0),
            (12.5, 9.0),
            (f64::NAN, 9.0),
            (4_503_599_627_370_495.5, 4_503_599_627_370_495.0),
        ] {
            let want = if p.is_nan() {
                0.0
            } else {
                p.max(0.0).min(last).floor()
            };
            assert_eq!(floor_in::<false>(p, last), want, "{p}");
            assert_eq!(floor_in::<true>(p, last), want, "{p}");
            assert_eq!(float_bits_index(want), want as u64);
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
    use crate::corners::count_corners;
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
