//! Exact integer filters for the corner metric (SPEC section 3), row at a time so that the
//! callers can stream row bands without full-size intermediates. Every border is reflect-101.
//! (The 2x2 box sum of the Harris products is fused with packing in `corners`.)

use crate::border::reflect101;

/// Binomial taps `[1 4 6 4 1]` (the 5-tap Gaussian OpenCV uses for sigma ~ 1).
const B: [u16; 5] = [1, 4, 6, 4, 1];

/// Row `r` of the structure image `S = v` for known cells, `0` for unknown ones.
#[inline]
pub fn structure_row(values: &[u8], unknown: &[bool], out: &mut [u16]) {
    for ((o, &v), &u) in out.iter_mut().zip(values).zip(unknown) {
        *o = if u { 0 } else { v as u16 };
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
    // vertical taps
    for (x, v) in vbuf.iter_mut().enumerate() {
        *v = rows[0][x] + 4 * rows[1][x] + 6 * rows[2][x] + 4 * rows[3][x] + rows[4][x];
    }
    // horizontal taps: interior without index mapping, the two cells at each end with it
    let w = vbuf.len();
    if w >= 5 {
        for x in 2..w - 2 {
            out[x] = vbuf[x - 2] + 4 * vbuf[x - 1] + 6 * vbuf[x] + 4 * vbuf[x + 1] + vbuf[x + 2];
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
        for x in 1..w - 1 {
            out[x] = (lap(x, x - 1, x + 1) > t) as u8;
        }
    }
    for x in [0, w - 1] {
        let l = reflect101(x as isize - 1, w);
        let r = reflect101(x as isize + 1, w);
        out[x] = (lap(x, l, r) > t) as u8;
    }
}

/// Sobel derivative products of one row of a 0/1 mask: `xx = Ix^2`, `xy = Ix Iy`,
/// `yy = Iy^2` with `Ix`, `Iy` OpenCV's 3x3 Sobel (`dx = right - left`, `dy = down - up`).
/// `up`, `mid`, `down` are the mask rows above, at and below (already reflect-mapped);
/// `p`, `d` are scratch of the row width.
#[allow(clippy::too_many_arguments)]
pub fn sobel_products_row(
    up: &[u8],
    mid: &[u8],
    down: &[u8],
    p: &mut [i16],
    d: &mut [i16],
    xx: &mut [i16],
    xy: &mut [i16],
    yy: &mut [i16],
) {
    let w = mid.len();
    for x in 0..w {
        p[x] = up[x] as i16 + 2 * mid[x] as i16 + down[x] as i16;
        d[x] = down[x] as i16 - up[x] as i16;
    }
    let mut put = |x: usize, l: usize, r: usize| {
        let ix = p[r] - p[l];
        let iy = d[l] + 2 * d[x] + d[r];
        xx[x] = ix * ix;
        xy[x] = ix * iy;
        yy[x] = iy * iy;
    };
    if w >= 3 {
        for x in 1..w - 1 {
            put(x, x - 1, x + 1);
        }
    }
    for x in [0, w - 1] {
        put(
            x,
            reflect101(x as isize - 1, w),
            reflect101(x as isize + 1, w),
        );
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
