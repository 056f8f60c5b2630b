//! SPEC 3a.1-2: the wall angle, from the 9x9 binomial blur of the structure image, its
//! Sobel gradients and the `g^4/|g|^3` terms, a few rows at a time.

#[cfg(target_arch = "x86_64")]
use super::pack::has_avx2;
use super::pack::VALUE;
use crate::border::reflect101;
use crate::grid::{known_bounds, Bounds, Grid};
use crate::memory::OutOfMemory;
use rayon::prelude::*;

/// The 9-tap binomial (two 5-tap binomial blurs in one), sum 256.
pub(super) const B9: [u16; 9] = [1, 8, 28, 56, 70, 56, 28, 8, 1];

/// One row of `D` ([`blur9_decimated`]) from the nine structure rows around it (packed
/// cells, [`pack_box`], or plain values: the value bits are taken): the vertical taps into
/// `vert` (`u16`), split into its even and odd columns in `split` (`w` cells), and the
/// horizontal taps at every second column into `o`.
#[inline(always)]
pub(super) fn blur_row_in(rows: [&[u16]; 9], vert: &mut [u16], split: &mut [u16], o: &mut [i32]) {
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
pub(super) fn rint_f(x: f64) -> f64 {
    const MAGIC: f64 = 6_755_399_441_055_744.0;
    (x + MAGIC) - MAGIC
}

/// The sums of the wall-direction terms of SPEC 3a.2 over a box: the fourth harmonic
/// (`g**4 / |g|**3`: the wall angle modulo 90 degrees), the sixth (`g**6 / |g|**5`: modulo
/// 60 degrees) and the weight (`|g|`), each term rounded half to even and summed exactly.
/// `slamq.models.quality.wall_symmetry` tells from them whether the walls are rectilinear,
/// hexagonal or neither.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WallSums {
    pub re4: i64,
    pub im4: i64,
    pub re6: i64,
    pub im6: i64,
    pub weight: i64,
}

impl std::ops::Add for WallSums {
    type Output = WallSums;
    fn add(self, o: WallSums) -> WallSums {
        WallSums {
            re4: self.re4 + o.re4,
            im4: self.im4 + o.im4,
            re6: self.re6 + o.re6,
            im6: self.im6 + o.im6,
            weight: self.weight + o.weight,
        }
    }
}

impl WallSums {
    /// The wall angle modulo 90 degrees, radians in (-pi/4, pi/4]: `atan2(im4, re4) / 4`,
    /// 0 when both sums are 0 (SPEC 3a.2; the canonical map is turned by it).
    pub fn angle(&self) -> f64 {
        if self.re4 == 0 && self.im4 == 0 {
            return 0.0;
        }
        (self.im4 as f64).atan2(self.re4 as f64) / 4.0
    }

    /// The five sums in the order `(re4, im4, re6, im6, weight)`.
    pub fn to_tuple(self) -> (i64, i64, i64, i64, i64) {
        (self.re4, self.im4, self.re6, self.im6, self.weight)
    }
}

/// The terms of one cell's Sobel gradient `g = x + i y` (SPEC 3a.2), rounded half to even,
/// as integer-valued floats: `g**4 / |g|**3` (re, im), `g**6 / |g|**5` (re, im) and `|g|`;
/// all 0 for a zero gradient. Branch-free, so that a row of them vectorises: a zero
/// gradient divides its zero numerators by 1 instead of by 0.
#[inline]
fn angle_terms(x: f64, y: f64) -> [f64; 5] {
    let r2 = x * x + y * y;
    let a = x * x - y * y;
    let b = 2.0 * (x * y);
    let root = r2.sqrt();
    let w = if r2 > 0.0 { r2 * root } else { 1.0 };
    let v = if r2 > 0.0 { (r2 * root) * r2 } else { 1.0 };
    let (p, q) = (a * a - b * b, 2.0 * (a * b));
    [
        rint_f(p / w),
        rint_f(q / w),
        rint_f((p * a - q * b) / v),
        rint_f((p * b + q * a) / v),
        rint_f(root),
    ]
}

/// Cells per partial sum of the angle terms: each term is an integer of at most `|g| < 2^27`
/// (`D < 2^24`, a Sobel derivative at most 4 of them), so a float sum of this many is
/// exact (below 2^53) whatever the order.
const TERMS_PER_SUM: usize = 1 << 20;

/// Scratch rows of [`sobel_terms_row`]: per column of a row of `D`, the vertical Sobel
/// smoothing `up + 2 mid + down`, the vertical difference `down - up`, and the two
/// derivatives.
#[derive(Default)]
pub(super) struct SobelRows {
    col: Vec<i32>,
    dv: Vec<i32>,
    gx: Vec<i32>,
    gy: Vec<i32>,
}

/// The sums of the rounded wall-direction terms (SPEC 3a.2) of one row of `D`, given its rows
/// `[up, mid, down]` (reflect-101 already applied). The 3x3 Sobel derivatives are exact in
/// `i32` (at most 4 * 255 * 256^2), so `gy` may be formed from the vertical differences.
/// Inlined into its callers, so that in [`angle_task_avx2`] the integer loops are AVX2 too.
#[inline(always)]
pub(super) fn sobel_terms_row([up, mid, down]: [&[i32]; 3], s: &mut SobelRows) -> WallSums {
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
    let mut sums = [0i64; 5];
    for (xs, ys) in s.gx.chunks(TERMS_PER_SUM).zip(s.gy.chunks(TERMS_PER_SUM)) {
        // four partial sums, so that the loop vectorises (exact in any order)
        for (total, lanes) in sums.iter_mut().zip(angle_sums(xs, ys, true)) {
            *total += lanes.iter().map(|&v| v as i64).sum::<i64>();
        }
    }
    let [re4, im4, re6, im6, weight] = sums;
    WallSums {
        re4,
        im4,
        re6,
        im6,
        weight,
    }
}

/// Four partial sums (lanes) of each of the five [`angle_terms`] of `xs`, `ys` (at most
/// [`TERMS_PER_SUM`] cells: exact in any order); with AVX2 when `best` and the processor has
/// it (the same terms).
pub(super) fn angle_sums(xs: &[i32], ys: &[i32], best: bool) -> [[f64; 4]; 5] {
    let (xq, yq) = (xs.chunks_exact(4), ys.chunks_exact(4));
    let (xr, yr) = (xq.remainder(), yq.remainder());
    let mut lanes = [[0.0f64; 4]; 5];
    #[cfg(target_arch = "x86_64")]
    let simd = best && has_avx2();
    #[cfg(not(target_arch = "x86_64"))]
    let simd = best && false;
    if simd {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: the processor has AVX2, checked just above
            lanes = unsafe { angle_sums_avx2(xs, ys) };
        }
    } else {
        for (x4, y4) in xq.zip(yq) {
            // most cells of a map have no gradient (unknown canvas, open floor): their
            // terms are 0
            if (x4[0] | x4[1] | x4[2] | x4[3] | y4[0] | y4[1] | y4[2] | y4[3]) == 0 {
                continue;
            }
            for l in 0..4 {
                let terms = angle_terms(f64::from(x4[l]), f64::from(y4[l]));
                for (lane, t) in lanes.iter_mut().zip(terms) {
                    lane[l] += t;
                }
            }
        }
    }
    for (&x, &y) in xr.iter().zip(yr) {
        let terms = angle_terms(f64::from(x), f64::from(y));
        for (lane, t) in lanes.iter_mut().zip(terms) {
            lane[0] += t;
        }
    }
    lanes
}

/// The four lanes' sums of [`angle_terms`] over the whole groups of four of `xs`, `ys` (the
/// caller adds the remainder), with AVX2: the same float64 operations in the same order
/// (no FMA), four cells at a time, so the same terms; groups without a gradient skipped.
///
/// # Safety
/// The processor must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn angle_sums_avx2(xs: &[i32], ys: &[i32]) -> [[f64; 4]; 5] {
    use std::arch::x86_64::*;
    let (mut re, mut im) = (_mm256_setzero_pd(), _mm256_setzero_pd());
    let (mut re6, mut im6, mut weight) = (
        _mm256_setzero_pd(),
        _mm256_setzero_pd(),
        _mm256_setzero_pd(),
    );
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
        let root = _mm256_sqrt_pd(r2);
        let wr = _mm256_mul_pd(r2, root);
        // a zero gradient divides its zero numerators by 1
        let nonzero = _mm256_cmp_pd::<_CMP_GT_OQ>(r2, zero);
        let w = _mm256_blendv_pd(one, wr, nonzero);
        let v = _mm256_blendv_pd(one, _mm256_mul_pd(wr, r2), nonzero);
        let num_re = _mm256_sub_pd(_mm256_mul_pd(a, a), _mm256_mul_pd(b, b));
        let num_im = _mm256_mul_pd(two, _mm256_mul_pd(a, b));
        let num_re6 = _mm256_sub_pd(_mm256_mul_pd(num_re, a), _mm256_mul_pd(num_im, b));
        let num_im6 = _mm256_add_pd(_mm256_mul_pd(num_re, b), _mm256_mul_pd(num_im, a));
        let rint = |v: __m256d| _mm256_sub_pd(_mm256_add_pd(v, magic), magic);
        re = _mm256_add_pd(re, rint(_mm256_div_pd(num_re, w)));
        im = _mm256_add_pd(im, rint(_mm256_div_pd(num_im, w)));
        re6 = _mm256_add_pd(re6, rint(_mm256_div_pd(num_re6, v)));
        im6 = _mm256_add_pd(im6, rint(_mm256_div_pd(num_im6, v)));
        weight = _mm256_add_pd(weight, rint(root));
    }
    let mut lanes = [[0.0f64; 4]; 5];
    for (lane, sum) in lanes.iter_mut().zip([re, im, re6, im6, weight]) {
        // SAFETY: 32 bytes into each [f64; 4]
        unsafe { _mm256_storeu_pd(lane.as_mut_ptr(), sum) };
    }
    lanes
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
    Ok(wall_sums_in(grid, bounds)?.angle())
}

/// The wall-direction sums of SPEC 3a.2 ([`WallSums`]) of the known bounding box (all 0
/// for a map without known cells).
pub fn wall_sums_in(grid: &Grid, bounds: Option<Bounds>) -> Result<WallSums, OutOfMemory> {
    Ok(match bounds {
        Some(b) => angle_of_box(grid, b),
        None => WallSums::default(),
    })
}

/// Rows of `D` per parallel task of [`angle_of_box`].
pub(super) const ANGLE_TASK_ROWS: usize = 64;

/// Rows of the structure image a task of [`angle_of_box`] holds: a power of two above the
/// nine that one row of `D` reads, which lie within nine consecutive rows, so that they
/// never share a slot.
const STRUCTURE_SLOTS: usize = 16;

/// One task's rows of the box's structure image (SPEC 3 step 1: a known cell's value, 0
/// for an unknown one), row `i` in slot `i % STRUCTURE_SLOTS`, each made once.
pub(super) struct StructureRows {
    cells: Vec<u16>,
    held: [usize; STRUCTURE_SLOTS],
}

impl StructureRows {
    pub(super) fn new(w: usize) -> Self {
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
pub(super) fn angle_of_box(grid: &Grid, b: Bounds) -> WallSums {
    let (h, w) = (b.1 - b.0, b.3 - b.2);
    let (hd, wd) = (h.div_ceil(2), w.div_ceil(2));
    let tasks = hd.div_ceil(ANGLE_TASK_ROWS);
    (0..tasks)
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
        .reduce(WallSums::default, |x, y| x + y)
}

/// What one task of [`angle_of_box`] works in: its structure rows, the blur's two rows, three
/// rows of `D` and the Sobel rows.
pub(super) struct AngleScratch {
    pub(super) structure: StructureRows,
    pub(super) vert: Vec<u16>,
    pub(super) split: Vec<u16>,
    pub(super) ring: Vec<i32>,
    pub(super) sobel: SobelRows,
}

/// The sums of the angle terms of rows `t * ANGLE_TASK_ROWS ..` of `D` (at most
/// [`ANGLE_TASK_ROWS`] of them) in the known box `b`; with AVX2 when the processor has it
/// (integer arithmetic and the same angle terms: the same sums).
pub(super) fn angle_task(grid: &Grid, b: Bounds, t: usize, scratch: &mut AngleScratch) -> WallSums {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        // SAFETY: the processor has AVX2, checked just above
        return unsafe { angle_task_avx2(grid, b, t, scratch) };
    }
    angle_task_in(grid, b, t, scratch)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn angle_task_avx2(grid: &Grid, b: Bounds, t: usize, scratch: &mut AngleScratch) -> WallSums {
    angle_task_in(grid, b, t, scratch)
}

#[inline(always)]
pub(super) fn angle_task_in(
    grid: &Grid,
    b: Bounds,
    t: usize,
    scratch: &mut AngleScratch,
) -> WallSums {
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
    let mut sums = WallSums::default();
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
            sums = sums + sobel_terms_row([row(n - 2), row(n - 1), row(n)], sobel);
        }
    }
    sums
}
