//! Exact Euclidean distance transform of a binary grid, with the nearest set cell of every
//! cell (SPEC section 7): a column pass (distance to the nearest set cell in the same
//! column, two sweeps) then, per row, Felzenszwalb & Huttenlocher's lower envelope of
//! parabolas (Theory of Computing 8, 2012).
//!
//! Squared distances are integers (cells^2), so the result is exact. The row pass runs over
//! fixed bands of rows in parallel, each row on its own: the result is the same for any
//! number of threads. Among equidistant set cells the nearest one reported is
//! the one the envelope keeps (deterministic, not necessarily the lowest index).

use crate::grid::BAND_ROWS;
use rayon::prelude::*;
use std::fmt;

/// "No set cell": the nearest index of every cell when the mask has no set cell.
pub const NONE: u32 = u32::MAX;

/// Why a distance transform could not be computed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum EdtError {
    /// `mask.len() != height * width`, or an empty grid.
    Shape {
        height: usize,
        width: usize,
        len: usize,
    },
    /// The squared diagonal does not fit the u32 distances (diagonal over 65535 cells), or
    /// the grid has more cells than a u32 index.
    TooLarge { height: usize, width: usize },
    /// A buffer could not be allocated.
    Alloc { bytes: usize },
}

impl fmt::Display for EdtError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EdtError::Shape { height, width, len } => {
                write!(f, "mask holds {len} cells, not {height} x {width}")
            }
            EdtError::TooLarge { height, width } => write!(
                f,
                "a {height} x {width} grid is too large for the distance transform \
                 (diagonal at most 65535 cells)"
            ),
            EdtError::Alloc { bytes } => write!(f, "cannot allocate {bytes} bytes"),
        }
    }
}

impl std::error::Error for EdtError {}

/// A zero-filled vector of `n` elements, or [`EdtError::Alloc`].
pub(crate) fn filled<T: Clone>(n: usize, value: T) -> Result<Vec<T>, EdtError> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| EdtError::Alloc {
        bytes: n.saturating_mul(std::mem::size_of::<T>()),
    })?;
    v.resize(n, value);
    Ok(v)
}

/// The distance transform of a mask: for every cell, the squared distance (cells^2) to the
/// nearest set cell and that cell's row-major index ([`NONE`] / `u32::MAX` distance when
/// the mask has no set cell).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Edt {
    pub height: usize,
    pub width: usize,
    pub sqdist: Vec<u32>,
    pub nearest: Vec<u32>,
}

impl Edt {
    /// Squared distance of cell `(r, c)`.
    #[inline]
    pub fn at(&self, r: usize, c: usize) -> u32 {
        self.sqdist[r * self.width + c]
    }
}

/// Check the shape and the size limits.
fn check(height: usize, width: usize, len: usize) -> Result<(), EdtError> {
    if height == 0 || width == 0 || height.checked_mul(width) != Some(len) {
        return Err(EdtError::Shape { height, width, len });
    }
    let (h, w) = ((height - 1) as u64, (width - 1) as u64);
    let diag = h
        .checked_mul(h)
        .and_then(|a| w.checked_mul(w).and_then(|b| a.checked_add(b)));
    if len >= NONE as usize || diag.is_none_or(|d| d >= u32::MAX as u64) {
        return Err(EdtError::TooLarge { height, width });
    }
    Ok(())
}

/// The exact Euclidean distance transform of `mask` (row-major, `height x width`, `true` =
/// set), the row pass parallel over row bands.
pub fn edt(mask: &[bool], height: usize, width: usize) -> Result<Edt, EdtError> {
    check(height, width, mask.len())?;
    let cells = mask.len();
    // column pass: the row of the nearest set cell in the same column (NONE if none)
    let mut near_row = filled(cells, NONE)?;
    column_pass(mask, &mut near_row, height, width);
    let mut sqdist = filled(cells, u32::MAX)?;
    let mut nearest = filled(cells, NONE)?;
    let band = BAND_ROWS * width;
    sqdist
        .par_chunks_mut(band)
        .zip(nearest.par_chunks_mut(band))
        .zip(near_row.par_chunks(band))
        .enumerate()
        .for_each(|(b, ((d, n), nr))| {
            let mut env = Envelope::new(width);
            for (k, ((drow, nrow), rrow)) in d
                .chunks_mut(width)
                .zip(n.chunks_mut(width))
                .zip(nr.chunks(width))
                .enumerate()
            {
                env.row(b * BAND_ROWS + k, rrow, drow, nrow, width);
            }
        });
    Ok(Edt {
        height,
        width,
        sqdist,
        nearest,
    })
}

/// For each cell, the row of the nearest set cell in its column: a downward then an upward
/// sweep over whole rows (each step is a vectorisable loop over the columns; this pass is
/// memory bound and cheap next to the row pass, so it stays on one thread). Ties between
/// the set cell above and the one below go to the one above.
fn column_pass(mask: &[bool], near_row: &mut [u32], height: usize, width: usize) {
    for r in 0..height {
        let (done, rest) = near_row.split_at_mut(r * width);
        let out = &mut rest[..width];
        let m = &mask[r * width..(r + 1) * width];
        if r == 0 {
            for (o, &b) in out.iter_mut().zip(m) {
                *o = if b { 0 } else { NONE };
            }
        } else {
            let prev = &done[(r - 1) * width..];
            for ((o, &b), &p) in out.iter_mut().zip(m).zip(prev) {
                *o = if b { r as u32 } else { p };
            }
        }
    }
    let mut below = vec![NONE; width];
    for r in (0..height).rev() {
        let out = &mut near_row[r * width..(r + 1) * width];
        let m = &mask[r * width..(r + 1) * width];
        let r32 = r as u32;
        for ((o, &b), low) in out.iter_mut().zip(m).zip(below.iter_mut()) {
            if b {
                *low = r32;
            }
            // `*o` (at or above r) is NONE or <= r; `*low` (at or below r) is NONE or >= r
            if *low != NONE && (*o == NONE || *low - r32 < r32 - *o) {
                *o = *low;
            }
        }
    }
}

/// Work space of the lower envelope of one row's parabolas.
struct Envelope {
    /// Columns of the parabolas in the envelope.
    v: Vec<usize>,
    /// Boundaries between them (`z[k]`..`z[k+1]` is parabola `k`'s range).
    z: Vec<f64>,
    /// Squared column distance `f(q)` of every column (u64: no overflow in `f + q^2`).
    f: Vec<u64>,
}

impl Envelope {
    fn new(width: usize) -> Self {
        Envelope {
            v: vec![0; width],
            z: vec![0.0; width + 1],
            f: vec![0; width],
        }
    }

    /// One row: `near_row[c]` is the row of the nearest set cell in column `c`.
    fn row(&mut self, r: usize, near_row: &[u32], d: &mut [u32], n: &mut [u32], width: usize) {
        let mut k: isize = -1;
        for q in 0..width {
            if near_row[q] == NONE {
                continue;
            }
            let dr = (r as i64 - near_row[q] as i64).unsigned_abs();
            self.f[q] = dr * dr;
            let fq = (self.f[q] + (q * q) as u64) as f64;
            let mut s = f64::NEG_INFINITY;
            while k >= 0 {
                let p = self.v[k as usize];
                let fp = (self.f[p] + (p * p) as u64) as f64;
                s = (fq - fp) / (2.0 * (q - p) as f64);
                if s <= self.z[k as usize] {
                    k -= 1;
                } else {
                    break;
                }
            }
            if k < 0 {
                s = f64::NEG_INFINITY;
            }
            k += 1;
            self.v[k as usize] = q;
            self.z[k as usize] = s;
            self.z[k as usize + 1] = f64::INFINITY;
        }
        if k < 0 {
            return; // no set cell in the whole grid: d and n keep their "none" fill
        }
        let mut j = 0usize;
        for q in 0..width {
            while self.z[j + 1] < q as f64 {
                j += 1;
            }
            let p = self.v[j];
            let dq = q.abs_diff(p) as u64;
            // fits u32: checked against the diagonal in `check`
            d[q] = (dq * dq + self.f[p]) as u32;
            n[q] = (near_row[p] as usize * width + p) as u32;
        }
    }
}

/// The squared distance transform by brute force (every cell against every set cell), for
/// tests: O(cells x set cells).
pub fn brute_force(mask: &[bool], height: usize, width: usize) -> Vec<u32> {
    let set: Vec<(i64, i64)> = (0..mask.len())
        .filter(|&i| mask[i])
        .map(|i| ((i / width) as i64, (i % width) as i64))
        .collect();
    let _ = height;
    (0..mask.len())
        .map(|i| {
            let (r, c) = ((i / width) as i64, (i % width) as i64);
            set.iter()
                .map(|&(a, b)| ((r - a) * (r - a) + (c - b) * (c - b)) as u32)
                .min()
                .unwrap_or(u32::MAX)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (xorshift), so tests need no crate.
    fn rng(seed: u64) -> impl FnMut() -> u64 {
        let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        }
    }

    fn check_against_brute(mask: &[bool], h: usize, w: usize) {
        let e = edt(mask, h, w).unwrap();
        assert_eq!(e.sqdist, brute_force(mask, h, w), "{h}x{w}");
        for i in 0..mask.len() {
            if e.nearest[i] == NONE {
                assert!(!mask.iter().any(|&b| b));
                continue;
            }
            let n = e.nearest[i] as usize;
            assert!(mask[n], "nearest of {i} is not set");
            let (r, c) = ((i / w) as i64, (i % w) as i64);
            let (a, b) = ((n / w) as i64, (n % w) as i64);
            assert_eq!(((r - a).pow(2) + (c - b).pow(2)) as u32, e.sqdist[i]);
        }
    }

    #[test]
    fn equals_brute_force_on_random_masks() {
        let mut next = rng(7);
        for case in 0..300 {
            let h = 1 + (next() % 40) as usize;
            let w = 1 + (next() % 300) as usize; // crosses a strip boundary sometimes
            let density = [1u64, 3, 20, 50, 97][case % 5];
            let mask: Vec<bool> = (0..h * w).map(|_| next() % 100 < density).collect();
            check_against_brute(&mask, h, w);
        }
    }

    #[test]
    fn single_cell_and_empty() {
        let mut mask = vec![false; 7 * 5];
        let e = edt(&mask, 7, 5).unwrap();
        assert!(e.sqdist.iter().all(|&d| d == u32::MAX));
        assert!(e.nearest.iter().all(|&n| n == NONE));
        mask[2 * 5 + 3] = true;
        check_against_brute(&mask, 7, 5);
        let e = edt(&mask, 7, 5).unwrap();
        assert_eq!(e.at(0, 0), 4 + 9);
        assert_eq!(e.at(6, 4), 16 + 1);
    }

    #[test]
    fn tall_masks_cross_row_bands() {
        let mut next = rng(11);
        let (h, w) = (150, 9);
        let mask: Vec<bool> = (0..h * w).map(|_| next() % 100 < 2).collect();
        check_against_brute(&mask, h, w);
    }

    #[test]
    fn same_result_for_any_thread_count() {
        let mut next = rng(3);
        let (h, w) = (300, 700);
        let mask: Vec<bool> = (0..h * w).map(|_| next() % 100 < 1).collect();
        let run = |t: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap()
                .install(|| edt(&mask, h, w).unwrap())
        };
        let one = run(1);
        assert_eq!(one, run(3));
        assert_eq!(one.sqdist, brute_force(&mask, h, w));
    }

    #[test]
    fn refuses_bad_shapes() {
        assert!(matches!(edt(&[true; 6], 2, 2), Err(EdtError::Shape { .. })));
        assert!(matches!(edt(&[], 0, 0), Err(EdtError::Shape { .. })));
    }
}
