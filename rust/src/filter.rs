//! Exact integer filters for the corner metric (SPEC section 3), row at a time so that the
//! callers can stream row bands without full-size intermediates. Every border is reflect-101.
//! (The Sobel products and their 2x2 box sum are tabulated per 4x4 mask window in `corners`.)

use crate::border::reflect101;

/// Binomial taps `[1 4 6 4 1]` (the 5-tap Gaussian OpenCV uses for sigma ~ 1).
const B: [u16; 5] = [1, 4, 6, 4, 1];

/// Whether the processor has AVX2 (cached by std after the first call): the row filters then
/// run as AVX2 copies of themselves, the same integer operations on wider registers.
#[cfg(target_arch = "x86_64")]
#[inline]
fn has_avx2() -> bool {
    std::arch::is_x86_feature_detected!("avx2")
}

/// Row `r` of the structure image `S = v` for known cells, `0` for unknown ones.
#[inline]
pub fn structure_row(values: &[u8], unknown: &[bool], out: &mut [u16]) {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        // SAFETY: AVX2 is present
        unsafe { structure_row_avx2(values, unknown, out) };
        return;
    }
    structure_row_in(values, unknown, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn structure_row_avx2(values: &[u8], unknown: &[bool], out: &mut [u16]) {
    structure_row_in(values, unknown, out);
}

#[inline(always)]
fn structure_row_in(values: &[u8], unknown: &[bool], out: &mut [u16]) {
    for ((o, &v), &u) in out.iter_mut().zip(values).zip(unknown) {
        // branch-free (v masked by 0 or 0xff), so that the loop vectorises
        *o = (v & (u as u8).wrapping_sub(1)) as u16;
    }
}

/// A row of one byte a cell widened to `u16` (a structure image given as bytes).
#[inline]
pub fn widen_row(values: &[u8], out: &mut [u16]) {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        // SAFETY: AVX2 is present
        unsafe { widen_row_avx2(values, out) };
        return;
    }
    widen_row_in(values, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn widen_row_avx2(values: &[u8], out: &mut [u16]) {
    widen_row_in(values, out);
}

#[inline(always)]
fn widen_row_in(values: &[u8], out: &mut [u16]) {
    for (o, &v) in out.iter_mut().zip(values) {
        *o = u16::from(v);
    }
}

/// Row `r` of `G = sum b_i b_j S` over the 5x5 window (256 x OpenCV's `GaussianBlur(S, 5x5)`
/// without rounding). `s_row(k)` returns row `k` of S; `vbuf` is scratch of the row width.
/// Values stay below 65,281, so `u16` is exact.
pub fn blur_row<'s>(
    s_row: &impl Fn(usize) -> &'s [u16],
    r: usize,
    height: usize,
    vbuf: &mut [u16],
    out: &mut [u16],
) {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        // SAFETY: AVX2 is present
        unsafe { blur_row_avx2(s_row, r, height, vbuf, out) };
        return;
    }
    blur_row_in(s_row, r, height, vbuf, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn blur_row_avx2<'s>(
    s_row: &impl Fn(usize) -> &'s [u16],
    r: usize,
    height: usize,
    vbuf: &mut [u16],
    out: &mut [u16],
) {
    blur_row_in(s_row, r, height, vbuf, out);
}

#[inline(always)]
fn blur_row_in<'s>(
    s_row: &impl Fn(usize) -> &'s [u16],
    r: usize,
    height: usize,
    vbuf: &mut [u16],
    out: &mut [u16],
) {
    let rows: [&[u16]; 5] =
        std::array::from_fn(|k| s_row(reflect101(r as isize + k as isize - 2, height)));
    // vertical taps (zipped slices: no bounds checks, so the loop vectorises)
    let [r0, r1, r2, r3, r4] = rows;
    for ((((v, &a), &b), &c), (&d, &e)) in vbuf
        .iter_mut()
        .zip(r0)
        .zip(r1)
        .zip(r2)
        .zip(r3.iter().zip(r4))
    {
        *v = a + 4 * b + 6 * c + 4 * d + e;
    }
    // horizontal taps: interior without index mapping, the two cells at each end with it
    let w = vbuf.len();
    if w >= 5 {
        // five shifted slices zipped (not `windows`), so that the loop vectorises
        let n = w - 4;
        let (t0, t1, t2, t3, t4) = (
            &vbuf[..n],
            &vbuf[1..n + 1],
            &vbuf[2..n + 2],
            &vbuf[3..n + 3],
            &vbuf[4..n + 4],
        );
        for (((o, &a), &b), ((&c, &d), &e)) in out[2..w - 2]
            .iter_mut()
            .zip(t0)
            .zip(t1)
            .zip(t2.iter().zip(t3).zip(t4))
        {
            *o = a + 4 * b + 6 * c + 4 * d + e;
        }
    }
    for x in (0..w.min(2)).chain(w.saturating_sub(2).max(2.min(w))..w) {
        out[x] = (0..5)
            .map(|k| B[k] * vbuf[reflect101(x as isize + k as isize - 2, w)])
            .sum();
    }
}

/// Row of the Laplacian `L = G(up) + G(down) + G(left) + G(right) - 4 G` (OpenCV
/// `Laplacian` ksize 1), thresholded: `out[x] = (L > t)` as 0/1, with `t` an integer
/// (the caller turns the float threshold into `floor`, which is exact for integer L).
pub fn laplacian_mask_row(up: &[u16], mid: &[u16], down: &[u16], t: i32, out: &mut [u8]) {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        // SAFETY: AVX2 is present
        unsafe { laplacian_mask_row_avx2(up, mid, down, t, out) };
        return;
    }
    laplacian_mask_row_in(up, mid, down, t, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn laplacian_mask_row_avx2(up: &[u16], mid: &[u16], down: &[u16], t: i32, out: &mut [u8]) {
    laplacian_mask_row_in(up, mid, down, t, out);
}

#[inline(always)]
fn laplacian_mask_row_in(up: &[u16], mid: &[u16], down: &[u16], t: i32, out: &mut [u8]) {
    let w = mid.len();
    let lap = |x: usize, l: usize, r: usize| -> i32 {
        up[x] as i32 + down[x] as i32 + mid[l] as i32 + mid[r] as i32 - 4 * mid[x] as i32
    };
    if w >= 3 {
        // shifted slices zipped (not `windows`), so that the loop vectorises
        let n = w - 2;
        let inner = out[1..w - 1]
            .iter_mut()
            .zip(mid[..n].iter().zip(&mid[1..n + 1]).zip(&mid[2..n + 2]))
            .zip(up[1..n + 1].iter().zip(&down[1..n + 1]));
        for ((o, ((&ml, &mc), &mr)), (&u, &d)) in inner {
            let l = u as i32 + d as i32 + ml as i32 + mr as i32 - 4 * mc as i32;
            *o = (l > t) as u8;
        }
    }
    for x in [0, w - 1] {
        let l = reflect101(x as isize - 1, w);
        let r = reflect101(x as isize + 1, w);
        out[x] = (lap(x, l, r) > t) as u8;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blur_naive(s: &[u16], h: usize, w: usize, r: usize, x: usize) -> u32 {
        let mut acc = 0u32;
        for i in 0..5 {
            for j in 0..5 {
                let rr = reflect101(r as isize + i as isize - 2, h);
                let xx = reflect101(x as isize + j as isize - 2, w);
                acc += B[i] as u32 * B[j] as u32 * s[rr * w + xx] as u32;
            }
        }
        acc
    }

    #[test]
    fn blur_matches_naive_on_all_shapes() {
        for (h, w) in [(1, 1), (1, 4), (3, 2), (4, 5), (7, 9), (2, 13)] {
            let s: Vec<u16> = (0..h * w).map(|i| ((i * 37 + 11) % 256) as u16).collect();
            let row = |k: usize| &s[k * w..(k + 1) * w];
            let mut vbuf = vec![0u16; w];
            let mut out = vec![0u16; w];
            for r in 0..h {
                blur_row(&row, r, h, &mut vbuf, &mut out);
                for x in 0..w {
                    assert_eq!(
                        out[x] as u32,
                        blur_naive(&s, h, w, r, x),
                        "{h}x{w} at {r},{x}"
                    );
                }
            }
        }
    }

    #[test]
    fn dispatched_rows_equal_the_plain_copies() {
        // on a machine with AVX2 the public functions run the AVX2 copies
        for w in [1usize, 2, 3, 5, 17, 64, 301] {
            let h = 6;
            let v: Vec<u8> = (0..h * w).map(|i| ((i * 97 + 5) % 256) as u8).collect();
            let u: Vec<bool> = (0..h * w).map(|i| i % 7 == 3).collect();
            let (mut s1, mut s2) = (vec![0u16; h * w], vec![0u16; h * w]);
            structure_row(&v, &u, &mut s1);
            structure_row_in(&v, &u, &mut s2);
            assert_eq!(s1, s2);
            let row = |k: usize| &s1[k * w..(k + 1) * w];
            let mut vbuf = vec![0u16; w];
            let (mut g1, mut g2) = (vec![0u16; h * w], vec![0u16; h * w]);
            for r in 0..h {
                blur_row(&row, r, h, &mut vbuf, &mut g1[r * w..(r + 1) * w]);
                blur_row_in(&row, r, h, &mut vbuf, &mut g2[r * w..(r + 1) * w]);
            }
            assert_eq!(g1, g2);
            let g = |k: usize| &g1[k * w..(k + 1) * w];
            for t in [-5000, -1, 0, 1, 3000] {
                let (mut o1, mut o2) = (vec![0u8; w], vec![0u8; w]);
                laplacian_mask_row(g(1), g(2), g(3), t, &mut o1);
                laplacian_mask_row_in(g(1), g(2), g(3), t, &mut o2);
                assert_eq!(o1, o2, "width {w} t {t}");
            }
        }
    }

    #[test]
    fn blur_of_constant_is_256_times() {
        let s = [255u16; 6 * 6];
        let row = |k: usize| &s[k * 6..(k + 1) * 6];
        let (mut vbuf, mut out) = (vec![0u16; 6], vec![0u16; 6]);
        blur_row(&row, 0, 6, &mut vbuf, &mut out);
        assert!(out.iter().all(|&g| g == 65280));
    }
}
