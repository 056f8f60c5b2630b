//! The distances of one map's occupied cells to the other's (SPEC section 7): matches
//! within the tolerance, sums of (truncated) distances, by the other map's bits or its
//! column pass.

use super::scan::RowCol;
use crate::edt::{Columns, EdtError, Sparse};
use rayon::prelude::*;

/// Per-chunk partial sums of one side (E or G), summed in chunk order.
#[derive(Clone, Copy, Default)]
pub(super) struct Side {
    pub(super) matched: u64,
    pub(super) sum: f64,
    pub(super) truncated: u64,
    /// Cells that are also cells of the other map (for E: |E n G|).
    pub(super) both: u64,
}

/// The other map of [`side`]'s distances: its set cells' bits, or its column pass when the
/// queries are far from them (both give the same distances).
pub(super) enum Other<'a> {
    Sparse(&'a Sparse),
    Columns(&'a Columns),
}

/// Queries of [`Sparse`] cost a few times what those of [`Columns`] do once its column
/// pass is made: past this many columns looked at per grid cell (estimated from a sample of
/// the queries), the pass is made.
const DENSE_VISITS_PER_CELL: f64 = 0.3;
/// Queries in that sample.
const SAMPLE: usize = 256;

/// How [`side`] should query `near` for the cells of `list`: by the bits, or (queries far
/// from its cells, e.g. maps far apart) by a column pass made here. The choice changes no
/// result, only the time.
pub(super) fn plan(near: &Sparse, list: &[u32]) -> Result<Option<Columns>, EdtError> {
    let (h, w) = (near.height, near.width);
    if list.is_empty() {
        return Ok(None);
    }
    let stride = list.len().div_ceil(SAMPLE).max(1);
    let (mut asked, mut visits) = (0usize, 0usize);
    for &i in list.iter().step_by(stride) {
        let i = i as usize;
        visits += near.distance(i / w, i % w).1;
        asked += 1;
    }
    let expected = visits as f64 / asked as f64 * list.len() as f64;
    if expected <= DENSE_VISITS_PER_CELL * (h * w) as f64 {
        return Ok(None);
    }
    near.columns().map(Some)
}

/// For every cell of `list`, its distance to the other map (queries of `other`): matches
/// within `tol2`, the sum of distances (truncated at `max`), how many cells `also` (given
/// row and column) holds for, and (when `want`) the matched flag of every cell.
pub(super) fn side(
    list: &[u32],
    other: Other,
    tol2: f64,
    max: Option<f64>,
    also: impl Fn(usize, usize) -> bool + Sync,
    want: bool,
) -> (Side, Vec<bool>) {
    const CHUNK: usize = 4096;
    let w = match other {
        Other::Sparse(s) => s.width,
        Other::Columns(c) => c.width,
    };
    let parts: Vec<(Side, Vec<bool>)> = list
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut s = Side::default();
            let mut matched = Vec::with_capacity(if want { chunk.len() } else { 0 });
            let mut at = RowCol::new(w);
            for &i in chunk {
                let i = i as usize;
                let (r, c) = at.get(i);
                let sq = match other {
                    Other::Sparse(near) => near.distance(r, c).0,
                    Other::Columns(cols) => cols.distance(r, c),
                }
                .unwrap_or(u32::MAX);
                let ok = sq != u32::MAX && sq as f64 <= tol2;
                s.matched += ok as u64;
                let (d, t) = distance(sq, max);
                s.sum += d;
                s.truncated += t as u64;
                s.both += also(r, c) as u64;
                if want {
                    matched.push(ok);
                }
            }
            (s, matched)
        })
        .collect();
    let mut total = Side::default();
    let mut matched = Vec::new();
    for (s, m) in parts {
        total.matched += s.matched;
        total.sum += s.sum;
        total.truncated += s.truncated;
        total.both += s.both;
        matched.extend(m);
    }
    (total, matched)
}

/// A distance (cells) from a squared one, truncated; and whether it was.
#[inline]
fn distance(sq: u32, max: Option<f64>) -> (f64, bool) {
    let d = if sq == u32::MAX {
        f64::INFINITY
    } else {
        (sq as f64).sqrt()
    };
    match max {
        Some(m) if d > m => (m, true),
        _ => (d, false),
    }
}
