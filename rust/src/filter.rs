//! Exact integer filters for the corner metric (SPEC section 3), row at a time so that the
//! callers can stream row bands without full-size intermediates. Every border is reflect-101.
//! (The Sobel products and their 2x2 box sum are tabulated per 4x4 mask window in `corners`.)

use crate::border::reflect101;

/// Binomial taps `[1 4 6 4 1]` (the 5-tap Gaussian OpenCV uses for sigma ~ 1).
const B: [u16; 5] = [1, 4, 6, 4, 1];

/// Row `r` of the structure image `S = v` for known cells, `0` for unknown ones.
#[inline]
pub fn structure_row(values: &[u8], unknown: &[bool], out: &mut [u16]) {
    for ((o, &v), &u) in out.iter_mut().zip(values).zip(unknown) {
        // branch-free (v masked by 0 or 0xff), so that the loop vectorises
        *o = (v & (u as u8).wrapping_sub(1)) as u16;
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
    fn blur_of_constant_is_256_times() {
        let s = [255u16; 6 * 6];
        let row = |k: usize| &s[k * 6..(k + 1) * 6];
        let (mut vbuf, mut out) = (vec![0u16; 6], vec![0u16; 6]);
        blur_row(&row, 0, 6, &mut vbuf, &mut out);
        assert!(out.iter().all(|&g| g == 65280));
    }
}
