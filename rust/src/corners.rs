//! Corner count (SPEC section 3, paper III.B): LoG structure mask, small dots dropped,
//! Harris response on the mask, relative threshold, 8-connected corner blobs counted.
//!
//! Everything up to the Harris response is exact integer arithmetic; the response is one
//! float64 formula, `R = (A*C - B*B) - k*(A + C)^2`, evaluated as `slamq.reference` does.
//! Work is done in fixed row bands in parallel; full-size intermediates are one byte per
//! cell (the mask) and four (the packed Harris sums `A, B, C`).

use crate::border::reflect101;
use crate::filter::{blur_row, laplacian_mask_row, sobel_products_row, structure_row};
use crate::grid::{bands, Grid, BAND_ROWS};
use crate::label::{Components, MaskRows};
use rayon::prelude::*;

/// Parameters of SPEC section 3 (defaults in `Default`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CornerParams {
    /// Structure mask: `L > log_threshold * 255 * 256`.
    pub log_threshold: f64,
    /// Mask components with fewer cells are dropped.
    pub min_dot_area: u32,
    /// Harris `k`.
    pub harris_k: f64,
    /// Corner mask: `R > harris_quality * max R`.
    pub harris_quality: f64,
}

impl Default for CornerParams {
    fn default() -> Self {
        CornerParams {
            log_threshold: 0.1,
            min_dot_area: 5,
            harris_k: 0.04,
            harris_quality: 0.01,
        }
    }
}

/// The integer threshold equivalent to `L as f64 > threshold` for integer `L`.
fn integer_threshold(threshold: f64) -> Option<i32> {
    if threshold.is_nan() {
        None
    } else {
        // |L| <= 4 * 65280, so clamping keeps every comparison and lets L stay in i32
        Some(threshold.floor().clamp(-(1 << 20) as f64, (1 << 20) as f64) as i32)
    }
}

/// Steps 1-4: the LoG structure mask (0/1 per cell).
pub fn structure_mask(grid: &Grid, log_threshold: f64) -> Vec<u8> {
    let (h, w) = (grid.height, grid.width);
    let mut mask = vec![0u8; h * w];
    let Some(t) = integer_threshold(log_threshold * 255.0 * 256.0) else {
        return mask;
    };
    mask.par_chunks_mut(BAND_ROWS * w)
        .zip(bands(h))
        .for_each(|(out, (r0, r1))| {
            // S rows needed: r0-3 ..= r1+2, reflect-mapped; those all fall in [base, end)
            let base = (r0 as isize - 3).max(0) as usize;
            let end = (r1 + 3).min(h);
            let s_rows: Vec<Vec<u16>> = (base..end)
                .map(|rr| {
                    let mut row = vec![0u16; w];
                    structure_row(grid.value_row(rr), grid.unknown_row(rr), &mut row);
                    row
                })
                .collect();
            let s_of = |k: usize| -> &[u16] { &s_rows[k - base] };
            let s_any: Vec<bool> = s_rows
                .iter()
                .map(|row| row.iter().any(|&x| x != 0))
                .collect();
            let mut vbuf = vec![0u16; w];
            // G rows r0-1 ..= r1 (reflect-mapped); a row whose five S rows are all zero is zero
            let mut g_rows: Vec<Vec<u16>> = Vec::with_capacity(r1 - r0 + 2);
            let mut g_any: Vec<bool> = Vec::with_capacity(r1 - r0 + 2);
            for k in r0 as isize - 1..r1 as isize + 1 {
                let gr = reflect101(k, h);
                let nonzero = (-2..=2).any(|j| s_any[reflect101(gr as isize + j, h) - base]);
                let mut g = vec![0u16; w];
                if nonzero {
                    blur_row(&s_of, gr, h, &mut vbuf, &mut g);
                }
                g_rows.push(g);
                g_any.push(nonzero);
            }
            for r in r0..r1 {
                let i = r - r0 + 1;
                let row_out = &mut out[(r - r0) * w..(r - r0 + 1) * w];
                if !(g_any[i - 1] || g_any[i] || g_any[i + 1]) {
                    row_out.fill((0 > t) as u8); // L = 0 everywhere on this row
                    continue;
                }
                laplacian_mask_row(&g_rows[i - 1], &g_rows[i], &g_rows[i + 1], t, row_out);
            }
        });
    mask
}

/// Step 5: remove 8-connected mask components with fewer than `min_dot_area` cells.
pub fn drop_dots(mask: &mut [u8], height: usize, width: usize, min_dot_area: u32) {
    if min_dot_area <= 1 {
        return;
    }
    let comps = Components::label(&MaskRows { mask, width }, height, width);
    comps.clear_small(mask, min_dot_area);
}

/// Pack the Harris sums; 0 means `A = B = C = 0` (then `R = 0`).
#[inline]
fn pack(a: i32, b: i32, c: i32) -> u32 {
    if a == 0 && c == 0 {
        0
    } else {
        (a as u32) | ((c as u32) << 8) | (((b + 128) as u32) << 16)
    }
}

#[inline]
fn unpack(t: u32) -> (i64, i64, i64) {
    (
        (t & 0xff) as i64,
        ((t >> 16) & 0xff) as i64 - 128,
        ((t >> 8) & 0xff) as i64,
    )
}

/// The Harris response of packed sums, exactly `(A*C - B*B) - k*(A+C)^2` in float64.
#[inline]
pub fn response(a: i64, b: i64, c: i64, k: f64) -> f64 {
    let s = a + c;
    ((a * c - b * b) as f64) - k * ((s * s) as f64)
}

/// Whether each row of a 0/1 mask has a set cell.
fn row_any(mask: &[u8], height: usize, width: usize) -> Vec<bool> {
    (0..height)
        .into_par_iter()
        .map(|r| mask[r * width..(r + 1) * width].iter().any(|&b| b != 0))
        .collect()
}

/// Step 6: the packed Harris sums of every cell of a 0/1 mask, and the largest response over
/// the cells whose sums are not all zero (`None` when there is none; every other cell has
/// `R = 0`).
pub fn harris_sums(mask: &[u8], height: usize, width: usize, k: f64) -> (Vec<u32>, Option<f64>) {
    let (h, w) = (height, width);
    let mut abc = vec![0u32; h * w];
    let any = row_any(mask, h, w);
    let m_row = |r: usize| &mask[r * w..(r + 1) * w];
    // a product row is all zero when its three mask rows are
    let product_zero = |yy: usize| {
        !(any[reflect101(yy as isize - 1, h)] || any[yy] || any[reflect101(yy as isize + 1, h)])
    };
    let maxima: Vec<Option<f64>> = abc
        .par_chunks_mut(BAND_ROWS * w)
        .zip(bands(h))
        .map(|(out, (r0, r1))| {
            let mut p = vec![0i16; w];
            let mut d = vec![0i16; w];
            // products of rows r-1 (prev) and r (cur); `*_zero` marks a row known all zero
            let mut prev: [Vec<i16>; 3] = std::array::from_fn(|_| vec![0i16; w]);
            let mut cur: [Vec<i16>; 3] = std::array::from_fn(|_| vec![0i16; w]);
            let mut fill = |yy: usize, bufs: &mut [Vec<i16>; 3]| -> bool {
                if product_zero(yy) {
                    return true;
                }
                let up = m_row(reflect101(yy as isize - 1, h));
                let dn = m_row(reflect101(yy as isize + 1, h));
                let [xx, xy, yyv] = bufs;
                sobel_products_row(up, m_row(yy), dn, &mut p, &mut d, xx, xy, yyv);
                false
            };
            let mut prev_zero = fill(reflect101(r0 as isize - 1, h), &mut prev);
            let mut cur_zero;
            let (mut sa, mut sb, mut sc) = (vec![0i16; w], vec![0i16; w], vec![0i16; w]);
            let mut best = f64::NEG_INFINITY;
            let mut seen = false;
            for r in r0..r1 {
                cur_zero = fill(r, &mut cur);
                if !(prev_zero && cur_zero) {
                    if prev_zero {
                        prev.iter_mut().for_each(|b| b.fill(0));
                    }
                    if cur_zero {
                        cur.iter_mut().for_each(|b| b.fill(0));
                    }
                    // column sums of the two rows, then the 2x2 box as neighbouring column pairs
                    for (s, (pv, cv)) in [&mut sa, &mut sb, &mut sc]
                        .into_iter()
                        .zip(prev.iter().zip(&cur))
                    {
                        for x in 0..w {
                            s[x] = pv[x] + cv[x];
                        }
                    }
                    let l0 = reflect101(-1, w);
                    let row_out = &mut out[(r - r0) * w..(r - r0 + 1) * w];
                    let mut put = |x: usize, l: usize| {
                        let a = (sa[l] + sa[x]) as i32;
                        let b = (sb[l] + sb[x]) as i32;
                        let c = (sc[l] + sc[x]) as i32;
                        row_out[x] = pack(a, b, c);
                    };
                    put(0, l0);
                    for x in 1..w {
                        put(x, x - 1);
                    }
                    for &t in row_out.iter() {
                        if t != 0 {
                            let (a, b, c) = unpack(t);
                            let resp = response(a, b, c, k);
                            if resp > best {
                                best = resp;
                            }
                            seen = true;
                        }
                    }
                }
                std::mem::swap(&mut prev, &mut cur);
                prev_zero = cur_zero;
            }
            seen.then_some(best)
        })
        .collect();
    let best = maxima.into_iter().flatten().reduce(f64::max);
    (abc, best)
}

/// Steps 1-8: the number of corners of a map.
pub fn count_corners(grid: &Grid, params: &CornerParams) -> usize {
    let (h, w) = (grid.height, grid.width);
    let mut mask = structure_mask(grid, params.log_threshold);
    drop_dots(&mut mask, h, w, params.min_dot_area);
    corner_mask_in_place(&mut mask, h, w, params);
    Components::label(
        &MaskRows {
            mask: &mask,
            width: w,
        },
        h,
        w,
    )
    .count()
}

/// Steps 6-7: turn the (dot-free) structure mask into the corner mask, in place.
pub fn corner_mask_in_place(mask: &mut [u8], height: usize, width: usize, params: &CornerParams) {
    let (abc, best) = harris_sums(mask, height, width, params.harris_k);
    let threshold = match best {
        // cells with all-zero sums have R = 0; a max <= 0 means no corner at all
        Some(m) if m > 0.0 => params.harris_quality * m,
        _ => {
            mask.fill(0);
            return;
        }
    };
    let k = params.harris_k;
    mask.par_chunks_mut(BAND_ROWS * width)
        .zip(abc.par_chunks(BAND_ROWS * width))
        .for_each(|(m, t)| {
            for (mv, &tv) in m.iter_mut().zip(t) {
                *mv = if tv == 0 {
                    0
                } else {
                    let (a, b, c) = unpack(tv);
                    (response(a, b, c, k) > threshold) as u8
                };
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square_map(n: usize, lo: usize, hi: usize) -> (Vec<u8>, Vec<bool>) {
        let mut v = vec![254u8; n * n];
        for r in lo..hi {
            for c in lo..hi {
                v[r * n + c] = 0;
            }
        }
        (v, vec![false; n * n])
    }

    #[test]
    fn filled_square_gives_outer_and_inner_ring_corners() {
        // the LoG mask of a filled dark square is a thick ring along its edge; Harris fires
        // at the ring's four outer and four inner corners
        let (v, u) = square_map(40, 12, 28);
        let g = Grid::new(&v, &u, 40, 40).unwrap();
        assert_eq!(count_corners(&g, &CornerParams::default()), 8);
    }

    #[test]
    fn empty_map_has_none() {
        let v = vec![254u8; 30 * 20];
        let u = vec![false; 30 * 20];
        let g = Grid::new(&v, &u, 30, 20).unwrap();
        assert_eq!(count_corners(&g, &CornerParams::default()), 0);
    }

    #[test]
    fn tiny_maps_do_not_panic() {
        for (h, w) in [(1, 1), (1, 7), (7, 1), (2, 2), (3, 3)] {
            let v: Vec<u8> = (0..h * w)
                .map(|i| if i % 2 == 0 { 0 } else { 254 })
                .collect();
            let u = vec![false; h * w];
            let g = Grid::new(&v, &u, h, w).unwrap();
            let _ = count_corners(&g, &CornerParams::default());
        }
    }

    #[test]
    fn pack_roundtrip() {
        for a in 0..=64 {
            for c in [0, 1, 33, 64] {
                for b in [-64, -1, 0, 5, 64] {
                    if a == 0 && c == 0 {
                        continue;
                    }
                    assert_eq!(unpack(pack(a, b, c)), (a as i64, b as i64, c as i64));
                }
            }
        }
    }
}
