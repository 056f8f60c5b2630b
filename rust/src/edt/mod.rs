//! Exact Euclidean distance transform of a binary grid, with the nearest set cell of every
//! cell (SPEC section 7): a column pass (distance to the nearest set cell in the same
//! column, two sweeps) then, per row, Felzenszwalb & Huttenlocher's lower envelope of
//! parabolas (Theory of Computing 8, 2012).
//!
//! Two ways to use it: the whole transform ([`nearest`], [`distances`], [`distances_at`]),
//! or point queries ([`Columns`]: the column pass kept, each query scanning its row outward
//! from the cell until no nearer set cell can exist, with the row's envelope as the fallback
//! for far queries). `compare` uses the queries: it needs distances at wall cells and at
//! the ICP's points only.
//!
//! Squared distances are integers (cells^2), so the result is exact. The row pass runs over
//! fixed bands of rows in parallel, each row on its own: the result is the same for any
//! number of threads. Among equidistant set cells the nearest one reported is
//! the one the envelope (or the scan) finds first (deterministic, not necessarily the lowest
//! index).

use crate::grid::BAND_ROWS;
use rayon::prelude::*;
use std::cell::RefCell;
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

/// Check the shape and the size limits.
pub(crate) fn check(height: usize, width: usize, len: usize) -> Result<(), EdtError> {
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

/// What the row pass writes for every cell.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Out {
    /// The squared distance to the nearest set cell (`u32::MAX`: none).
    Distance,
    /// The row-major index of the nearest set cell ([`NONE`]: none).
    Nearest,
}

/// The nearest set cell of every cell of a `height x width` grid whose set cells are those
/// `set(index)` says (row-major indices; [`NONE`] everywhere when no cell is set).
pub fn nearest<F>(set: F, height: usize, width: usize) -> Result<Vec<u32>, EdtError>
where
    F: Fn(usize) -> bool + Sync,
{
    transform(&set, height, width, Out::Nearest, None)
}

/// The squared distance (cells^2) of every cell to the nearest set cell (`u32::MAX` when
/// no cell is set).
pub fn distances<F>(set: F, height: usize, width: usize) -> Result<Vec<u32>, EdtError>
where
    F: Fn(usize) -> bool + Sync,
{
    transform(&set, height, width, Out::Distance, None)
}

/// [`distances`] at the cells where `query` is true (`u32::MAX` elsewhere): rows without a
/// query cell skip the row pass, and the others evaluate the envelope at the query cells
/// only.
pub fn distances_at<F>(
    set: F,
    height: usize,
    width: usize,
    query: &[bool],
) -> Result<Vec<u32>, EdtError>
where
    F: Fn(usize) -> bool + Sync,
{
    transform(&set, height, width, Out::Distance, Some(query))
}

/// The squared distance between cells `a` and `b` (row-major indices) of a `width`-wide
/// grid.
#[inline]
pub fn sqdist_between(a: usize, b: usize, width: usize) -> u32 {
    let (ra, ca) = (a / width, a % width);
    let (rb, cb) = (b / width, b % width);
    let (dr, dc) = (ra.abs_diff(rb) as u64, ca.abs_diff(cb) as u64);
    (dr * dr + dc * dc) as u32
}

fn transform<F>(
    set: &F,
    height: usize,
    width: usize,
    out: Out,
    query: Option<&[bool]>,
) -> Result<Vec<u32>, EdtError>
where
    F: Fn(usize) -> bool + Sync,
{
    let cells = height.saturating_mul(width);
    check(height, width, cells)?;
    if let Some(q) = query {
        if q.len() != cells {
            return Err(EdtError::Shape {
                height,
                width,
                len: q.len(),
            });
        }
    }
    // column pass: the row of the nearest set cell in the same column (NONE if none); the
    // row pass then overwrites each row in place, from a copy of it
    let mut buf = column_pass(set, height, width)?;
    let band = BAND_ROWS * width;
    let rows = |b: usize, chunk: &mut [u32], qb: Option<&[bool]>| {
        let mut env = Envelope::new(width);
        let mut near_row = vec![NONE; width];
        for (k, row) in chunk.chunks_mut(width).enumerate() {
            near_row.copy_from_slice(row);
            let r = b * BAND_ROWS + k;
            match qb {
                Some(qb) => env.row_at(r, &near_row, row, &qb[k * width..(k + 1) * width]),
                None => env.row(r, &near_row, row, out),
            }
        }
    };
    match query {
        Some(q) => buf
            .par_chunks_mut(band)
            .zip(q.par_chunks(band))
            .enumerate()
            .for_each(|(b, (chunk, qb))| rows(b, chunk, Some(qb))),
        None => buf
            .par_chunks_mut(band)
            .enumerate()
            .for_each(|(b, chunk)| rows(b, chunk, None)),
    }
    Ok(buf)
}

/// For each cell, the row of the nearest set cell in its column: a downward sweep that
/// copies the row above and marks the set cells, then an upward sweep (each step a
/// vectorisable loop over the columns; this pass is memory bound and cheap next to the row
/// pass, so it stays on one thread). Ties between the set cell above and the one below go
/// to the one above.
fn column_pass<F>(set: &F, height: usize, width: usize) -> Result<Vec<u32>, EdtError>
where
    F: Fn(usize) -> bool,
{
    let cells = height * width;
    let mut near = take_buffer(cells)?;
    near.resize(width, NONE);
    for r in 0..height {
        let base = r * width;
        if r > 0 {
            near.extend_from_within(base - width..base);
        }
        let r32 = r as u32;
        for (c, o) in near[base..base + width].iter_mut().enumerate() {
            if set(base + c) {
                *o = r32;
            }
        }
    }
    let mut below = vec![NONE; width];
    for r in (0..height).rev() {
        let out = &mut near[r * width..(r + 1) * width];
        let r32 = r as u32;
        for (o, low) in out.iter_mut().zip(below.iter_mut()) {
            if *o == r32 {
                *low = r32; // a set cell (the downward sweep marked it with its own row)
            }
            // `*o` (at or above r) is NONE or <= r; `*low` (at or below r) is NONE or >= r
            if *low != NONE && (*o == NONE || *low - r32 < r32 - *o) {
                *o = *low;
            }
        }
    }
    Ok(near)
}

/// Work space of the lower envelope of one row's parabolas `y = (x - v)^2 + f(v)`, kept
/// as `g(v) = f(v) + v^2` so that every comparison is exact integer arithmetic (no
/// division: the intersections are compared by cross-multiplying; the products stay below
/// 2^50 for grids whose diagonal is under 65536 cells).
struct Envelope {
    /// Columns of the parabolas in the envelope, left to right.
    v: Vec<i64>,
    /// Their `g(v)`.
    g: Vec<i64>,
}

impl Envelope {
    fn new(width: usize) -> Self {
        Envelope {
            v: vec![0; width],
            g: vec![0; width],
        }
    }

    /// One row: `near_row[c]` is the row of the nearest set cell in column `c`. Writes the
    /// squared distances or the nearest cells (`out`) to `d`.
    fn row(&mut self, r: usize, near_row: &[u32], d: &mut [u32], out: Out) {
        let width = near_row.len();
        let k = self.build(r, near_row);
        let (v, g) = (&self.v[..width], &self.g[..width]);
        if k == 0 {
            d.fill(u32::MAX); // no set cell in the whole grid (u32::MAX is also NONE)
            return;
        }
        // parabola j is the lowest from the previous one's end to the last column before
        // its intersection with parabola j + 1 (ties: the left one, as in the sweep)
        let w = width as i64;
        let mut start = 0i64;
        for j in 0..k {
            let end = if j + 1 < k {
                // intersection x = dg / dv with dg = g[j+1] - g[j], dv = 2 (v[j+1] - v[j]);
                // the last column q with q <= x, i.e. the largest q with q dv <= dg: a
                // float division (exact operands below 2^53) corrected by one exact step
                let (dg, dv) = (g[j + 1] - g[j], 2 * (v[j + 1] - v[j]));
                let x = dg as f64 / dv as f64;
                let mut e = x as i64 - ((x < (x as i64) as f64) as i64);
                if (e + 1) * dv <= dg {
                    e += 1;
                } else if e * dv > dg {
                    e -= 1;
                }
                e.min(w - 1)
            } else {
                w - 1
            };
            if end < start {
                continue;
            }
            let (p, gp) = (v[j], g[j]);
            let (s, e) = (start as usize, end as usize + 1);
            match out {
                // (q - p)^2 + f(p) = g(p) - 2 q p + q^2; fits u32: checked against the
                // diagonal
                Out::Distance => {
                    for (q, dq) in (start..).zip(d[s..e].iter_mut()) {
                        *dq = (gp - 2 * q * p + q * q) as u32;
                    }
                }
                Out::Nearest => {
                    d[s..e].fill((near_row[p as usize] as usize * width + p as usize) as u32)
                }
            }
            start = end + 1;
            if start >= w {
                break;
            }
        }
    }

    /// One row's squared distances at the `query` columns only (others: `u32::MAX`).
    fn row_at(&mut self, r: usize, near_row: &[u32], d: &mut [u32], query: &[bool]) {
        d.fill(u32::MAX);
        if !query.iter().any(|&b| b) {
            return;
        }
        let k = self.build(r, near_row);
        if k == 0 {
            return;
        }
        let (v, g) = (&self.v, &self.g);
        let mut j = 0usize;
        for (q, (dq, _)) in d.iter_mut().zip(query).enumerate().filter(|(_, (_, &b))| b) {
            let q = q as i64;
            // move right while the next parabola is lower at q (their intersection < q)
            while j + 1 < k && g[j + 1] - g[j] < 2 * q * (v[j + 1] - v[j]) {
                j += 1;
            }
            *dq = (g[j] - 2 * q * v[j] + q * q) as u32;
        }
    }

    /// The lower envelope of row `r`'s parabolas; returns how many it holds (in `v`, `g`).
    fn build(&mut self, r: usize, near_row: &[u32]) -> usize {
        let (v, g) = (&mut self.v[..near_row.len()], &mut self.g[..near_row.len()]);
        let r = r as i64;
        let mut k = 0usize;
        // the last two parabolas of the envelope, kept in registers: (av, ag) below the top
        // (bv, bg); valid when k >= 2 and k >= 1
        let (mut av, mut ag, mut bv, mut bg) = (0i64, 0i64, 0i64, 0i64);
        for (q, &nr) in near_row.iter().enumerate() {
            if nr == NONE {
                continue;
            }
            let q = q as i64;
            let dr = r - nr as i64;
            let gq = dr * dr + q * q;
            // drop the last parabola while the new one hides it: the intersection of the
            // last two is at or right of the intersection of the last one with the new one
            while k >= 2 && (gq - bg) * (bv - av) <= (bg - ag) * (q - bv) {
                k -= 1;
                (bv, bg) = (av, ag);
                if k >= 2 {
                    (av, ag) = (v[k - 2], g[k - 2]);
                }
            }
            v[k] = q;
            g[k] = gq;
            k += 1;
            (av, ag, bv, bg) = (bv, bg, q, gq);
        }
        k
    }
}

thread_local! {
    /// Column-pass buffers kept between calls on this thread (at most [`SPARE_COUNT`], of
    /// at most [`SPARE_MAX`] cells each): a fresh buffer of megabytes costs one page fault
    /// per 4 KiB when first written, which is a fifth of a comparison's time.
    static SPARE: RefCell<Vec<Vec<u32>>> = const { RefCell::new(Vec::new()) };
}
const SPARE_COUNT: usize = 2;
const SPARE_MAX: usize = 1 << 24;

/// An empty buffer with room for `cells` values: a spare one when it is large enough.
fn take_buffer(cells: usize) -> Result<Vec<u32>, EdtError> {
    let spare = SPARE.with(|s| {
        let mut s = s.borrow_mut();
        let i = s.iter().position(|v| v.capacity() >= cells)?;
        Some(s.swap_remove(i))
    });
    let mut v = spare.unwrap_or_default();
    v.clear();
    v.try_reserve_exact(cells).map_err(|_| EdtError::Alloc {
        bytes: cells.saturating_mul(4),
    })?;
    Ok(v)
}

/// Keep `v` for a later [`take_buffer`] on this thread, if there is room.
fn give_back(v: Vec<u32>) {
    if v.capacity() == 0 || v.capacity() > SPARE_MAX {
        return;
    }
    // a thread being torn down has no spares any more: the buffer is simply freed
    let _ = SPARE.try_with(|s| {
        let mut s = s.borrow_mut();
        if s.len() < SPARE_COUNT {
            s.push(v);
        }
    });
}

/// Columns scanned outward from a query before the row's envelope is built instead.
const SCAN: usize = 48;

/// Point queries of the distance transform: the column pass of a mask, kept, answers "which
/// set cell is nearest to cell (r, c)" by scanning the columns of row `r` outward from `c`
/// (column `q` at `k` columns offers `k^2 + f(q)`; the scan stops once `k^2` reaches the
/// best offer, which is exact), and after [`SCAN`] columns falls back to the row's lower
/// envelope. Queries near set cells (the usual case: walls near walls) cost a few steps
/// instead of a transform of the whole grid.
pub struct Columns {
    pub height: usize,
    pub width: usize,
    near: Vec<u32>,
}

impl Drop for Columns {
    fn drop(&mut self) {
        give_back(std::mem::take(&mut self.near));
    }
}

/// Nearest-set-cell queries, as [`Columns::query`] answers them (the same cell, the same
/// squared distance): what the ICP's target needs.
pub trait NearestCell: Sync {
    /// The nearest set cell of cell `(r, c)` (row-major index) and the squared distance to
    /// it, or None when no cell is set.
    fn query(&self, r: usize, c: usize) -> Option<(u32, u32)>;

    /// The [`Columns`] answering the queries, when they are that (the ICP then calls
    /// [`Columns::nearest_cell`] directly instead of through the trait object).
    fn as_columns(&self) -> Option<&Columns> {
        None
    }
}

impl NearestCell for Columns {
    fn query(&self, r: usize, c: usize) -> Option<(u32, u32)> {
        Columns::query(self, r, c)
    }

    fn as_columns(&self) -> Option<&Columns> {
        Some(self)
    }
}

impl Columns {
    /// The column pass of the mask whose set cells are those `set(index)` says.
    pub fn new<F>(set: F, height: usize, width: usize) -> Result<Self, EdtError>
    where
        F: Fn(usize) -> bool,
    {
        let cells = height.saturating_mul(width);
        check(height, width, cells)?;
        Ok(Columns {
            height,
            width,
            near: column_pass(&set, height, width)?,
        })
    }

    /// The nearest set cell of cell `(r, c)` (row-major index) and the squared distance to
    /// it, or None when no cell is set. Ties: the first offer found (the cell's own column,
    /// then nearer columns, left before right).
    pub fn query(&self, r: usize, c: usize) -> Option<(u32, u32)> {
        let w = self.width;
        let row = &self.near[r * w..(r + 1) * w];
        scan_query(r, c, w, |q| row[q])
    }

    /// [`Columns::query`]'s cell as (row, column), without its distance.
    #[inline]
    pub fn nearest_cell(&self, r: usize, c: usize) -> Option<(usize, usize)> {
        let w = self.width;
        let row = &self.near[r * w..(r + 1) * w];
        let (q, _) = scan_arg(r, c, w, &|q| row[q])?;
        Some((row[q] as usize, q))
    }
}

impl Columns {
    /// The squared distance from cell `(r, c)` to the nearest set cell (None when no cell
    /// is set): [`Columns::query`]'s, by its scan of the row's columns taken as far as
    /// needed. It is [`scan_query`]'s loop without the cell: `query(r, c)`'s distance
    /// instead cost `compare` 0.5 M more instructions a call (62.3 M, callgrind).
    pub fn distance(&self, r: usize, c: usize) -> Option<u32> {
        let w = self.width;
        let row = &self.near[r * w..(r + 1) * w];
        let ri = r as i64;
        // column q's offer at k columns (k2 = k^2), u64::MAX when it has no set cell
        let offer = |q: usize, k2: u64| -> u64 {
            let n = row[q];
            if n == NONE {
                u64::MAX
            } else {
                let d = (ri - n as i64).unsigned_abs();
                k2 + d * d
            }
        };
        let mut best = offer(c, 0);
        let mut k = 1usize;
        loop {
            let k2 = (k * k) as u64;
            if k2 >= best || (k > c && c + k >= w) {
                break;
            }
            if k <= c {
                best = best.min(offer(c - k, k2));
            }
            if c + k < w {
                best = best.min(offer(c + k, k2));
            }
            k += 1;
        }
        // fits u32: checked against the diagonal
        (best != u64::MAX).then_some(best as u32)
    }
}

/// [`Columns::query`] on the row of column-nearest cells `near(q)` (the row of the nearest
/// set cell in column `q`, [`NONE`]: none) of row `r`. Past [`SCAN`] columns (far from
/// every set cell of this row's columns) the scan goes on to the exact minimum and answers
/// its leftmost column: the row's lower envelope's choice, which answered there before
/// (parabolas tied at `c` are ordered by their columns just left of `c`, where the
/// leftmost is the lowest: it is on the envelope, and the first there that is lowest at
/// `c`).
#[inline]
fn scan_query(r: usize, c: usize, w: usize, near: impl Fn(usize) -> u32) -> Option<(u32, u32)> {
    let (arg, best) = scan_arg(r, c, w, &near)?;
    // fits u32: checked against the diagonal
    Some(((near(arg) as usize * w + arg) as u32, best as u32))
}

/// [`scan_query`]'s column and squared distance: the former scan's (kept as
/// `scan_query_literal` for the tests) without a test for [`NONE`] per column. A column
/// without a set cell offers `(r - NONE)^2`, which is above every real offer (those are
/// below `u32::MAX`, checked against the diagonal, and `r < 2^16`) and so never chosen
/// while one is, and no sum overflows (`(2^32 - 1)^2 + 48^2 < 2^64`): the same strict
/// comparisons choose the same column, and the best offer is real exactly when a set cell
/// was seen. While both sides are inside the row the columns `c - k` and `c + k` are taken
/// without the bounds tests; the rest is the former loop.
#[inline]
fn scan_arg(r: usize, c: usize, w: usize, near: &impl Fn(usize) -> u32) -> Option<(usize, u64)> {
    let ri = r as i64;
    let offer = |q: usize| -> u64 {
        let d = (ri - near(q) as i64).unsigned_abs();
        d * d
    };
    let (mut best, mut arg) = (offer(c), c);
    let both = c.min(w - 1 - c).min(SCAN);
    let mut k = 1usize;
    while k <= both {
        let k2 = (k * k) as u64;
        if k2 >= best {
            return (best <= REAL).then_some((arg, best));
        }
        let v = k2 + offer(c - k);
        if v < best {
            (best, arg) = (v, c - k);
        }
        let v = k2 + offer(c + k);
        if v < best {
            (best, arg) = (v, c + k);
        }
        k += 1;
    }
    loop {
        let k2 = (k * k) as u64;
        if k2 >= best || (k > c && c + k >= w) {
            break;
        }
        if k > SCAN {
            let f = |q: usize| -> Option<u64> {
                let n = near(q);
                (n != NONE).then(|| {
                    let d = (ri - n as i64).unsigned_abs();
                    d * d
                })
            };
            let best = if best <= REAL { best } else { u64::MAX };
            return far_query(c, w, k, best, &f);
        }
        if k <= c {
            let v = k2 + offer(c - k);
            if v < best {
                (best, arg) = (v, c - k);
            }
        }
        if c + k < w {
            let v = k2 + offer(c + k);
            if v < best {
                (best, arg) = (v, c + k);
            }
        }
        k += 1;
    }
    (best <= REAL).then_some((arg, best))
}

/// The largest real offer of [`scan_arg`] (squared distances fit `u32`).
const REAL: u64 = u32::MAX as u64;

/// [`scan_query`] past [`SCAN`] columns, from `k` columns on with the best offer so far
/// `best` (`u64::MAX`: none): the exact minimum (every column that could offer as little:
/// `k^2 <= best`), then the leftmost column offering it, and the minimum.
#[cold]
#[inline(never)]
fn far_query(
    c: usize,
    w: usize,
    mut k: usize,
    mut best: u64,
    f: &impl Fn(usize) -> Option<u64>,
) -> Option<(usize, u64)> {
    loop {
        let k2 = (k * k) as u64;
        if k2 > best || (k > c && c + k >= w) {
            break;
        }
        for q in [c.wrapping_sub(k), c + k] {
            if q < w {
                if let Some(v) = f(q) {
                    best = best.min(k2 + v);
                }
            }
        }
        k += 1;
    }
    if best == u64::MAX {
        return None;
    }
    // every column offering `best` is within k - 1 columns of c
    let lo = c.saturating_sub(k);
    let q = (lo..w.min(c + k + 1)).find(|&q| {
        let d = (q as i64 - c as i64).unsigned_abs();
        f(q).is_some_and(|v| d * d + v == best)
    })?;
    Some((q, best))
}

/// [`Columns`] without the column pass, for sparse masks (walls): the set cells as one bit
/// each, column by column (64 rows a word), so that the nearest set cell of a column to a
/// row, which the column pass stores, is found when a query asks for it (one or two words
/// near walls). The queries are [`Columns::query`]'s on those values: the same answers,
/// ties included; a query far from every set cell gathers its row's values for the
/// envelope.
pub struct Sparse {
    pub height: usize,
    pub width: usize,
    /// 64-bit words per column.
    words: usize,
    bits: Vec<u64>,
    /// Per column, the first and last set rows ([`NONE`]: none).
    span: Vec<(u32, u32)>,
}

impl Sparse {
    /// The mask of a `height x width` grid whose set cells are `cells` (row-major indices;
    /// those beyond the grid are ignored).
    pub fn new(cells: &[u32], height: usize, width: usize) -> Result<Self, EdtError> {
        let n = height.saturating_mul(width);
        check(height, width, n)?;
        let words = height.div_ceil(64);
        let mut bits = filled(width * words, 0u64)?;
        let mut span = filled(width, (NONE, 0u32))?;
        for &i in cells {
            let i = i as usize;
            if i < n {
                let (r, c) = (i / width, i % width);
                bits[c * words + r / 64] |= 1u64 << (r % 64);
                let s = &mut span[c];
                s.0 = s.0.min(r as u32);
                s.1 = s.1.max(r as u32);
            }
        }
        Ok(Sparse {
            height,
            width,
            words,
            bits,
            span,
        })
    }

    /// Whether cell `(r, c)` is set.
    #[inline]
    pub fn get(&self, r: usize, c: usize) -> bool {
        self.bits[c * self.words + r / 64] >> (r % 64) & 1 != 0
    }

    /// The bits of column `c` from row `start` (may be negative) on, `len` (< 64) of them:
    /// bit `k` is row `start + k`; rows outside the grid read as unset.
    #[inline]
    pub fn column_bits(&self, c: usize, start: isize, len: u32) -> u64 {
        let col = &self.bits[c * self.words..(c + 1) * self.words];
        let get = |k: isize| -> u64 {
            if k < 0 {
                0
            } else {
                col.get(k as usize).copied().unwrap_or(0)
            }
        };
        let (k, off) = (start.div_euclid(64), start.rem_euclid(64) as u32);
        let lo = get(k) >> off;
        let hi = if off == 0 {
            0
        } else {
            get(k + 1) << (64 - off)
        };
        (lo | hi) & ((1u64 << len) - 1)
    }

    /// Whether cell `i` (row-major) is set.
    #[inline]
    pub fn get_index(&self, i: usize) -> bool {
        self.get(i / self.width, i % self.width)
    }

    /// The set rows of column `c`, ascending.
    #[inline]
    fn rows_of(&self, c: usize) -> impl Iterator<Item = usize> + '_ {
        self.bits[c * self.words..(c + 1) * self.words]
            .iter()
            .enumerate()
            .flat_map(|(k, &word)| {
                let mut b = word;
                std::iter::from_fn(move || {
                    (b != 0).then(|| {
                        let t = b.trailing_zeros() as usize;
                        b &= b - 1;
                        k * 64 + t
                    })
                })
            })
    }

    /// The consecutive set rows `(a, b)` of column `c`, top down.
    #[inline]
    fn pairs_of(&self, c: usize) -> impl Iterator<Item = (usize, usize)> + '_ {
        let mut rows = self.rows_of(c).peekable();
        std::iter::from_fn(move || Some((rows.next()?, *rows.peek()?)))
    }

    /// The [`Columns`] of the same mask: [`column_pass`]'s values, made from the bits. Down
    /// a column the value changes only where the nearest set row passes from one set row
    /// `a` to the next `b`, at row `(a + b) / 2 + 1` (ties go to the one above); so each row
    /// is the row above copied, then those changes written (one per pair of consecutive
    /// set cells in a column), instead of a visit of every cell.
    pub fn columns(&self) -> Result<Columns, EdtError> {
        let (h, w) = (self.height, self.width);
        // row 0's values (the first set row of each column), and the changes per row
        let mut first = filled(w, NONE)?;
        let mut start = filled(h + 1, 0u32)?;
        for (c, f) in first.iter_mut().enumerate() {
            *f = self.rows_of(c).next().map_or(NONE, |r| r as u32);
            for (a, b) in self.pairs_of(c) {
                start[(a + b) / 2 + 1] += 1;
            }
        }
        let mut sum = 0u32;
        for s in start.iter_mut() {
            let n = *s;
            *s = sum;
            sum += n;
        }
        let mut fill = start.clone();
        let mut change = filled(sum as usize, (0u32, 0u32))?;
        for c in 0..w {
            for (a, b) in self.pairs_of(c) {
                let k = &mut fill[(a + b) / 2 + 1];
                change[*k as usize] = (c as u32, b as u32);
                *k += 1;
            }
        }
        let mut near = take_buffer(h * w)?;
        near.extend_from_slice(&first);
        for r in 1..h {
            near.extend_from_within((r - 1) * w..r * w);
            let row = &mut near[r * w..(r + 1) * w];
            for &(c, v) in &change[start[r] as usize..start[r + 1] as usize] {
                row[c as usize] = v;
            }
        }
        Ok(Columns {
            height: h,
            width: w,
            near,
        })
    }

    /// The row of the set cell of column `c` nearest to row `r` (ties: the one above), or
    /// [`NONE`]: what [`column_pass`] stores at `(r, c)`.
    #[inline]
    fn column_nearest(&self, r: usize, c: usize) -> u32 {
        let col = &self.bits[c * self.words..(c + 1) * self.words];
        let (wi, b) = (r / 64, r % 64);
        // rows at or below r
        let mut down = usize::MAX;
        let x = col[wi] >> b;
        if x != 0 {
            down = x.trailing_zeros() as usize;
        } else {
            let mut base = 64 - b;
            for &x in &col[wi + 1..] {
                if x != 0 {
                    down = base + x.trailing_zeros() as usize;
                    break;
                }
                base += 64;
            }
        }
        if down == 0 {
            return r as u32;
        }
        // rows above r, no farther than `down`
        let mut up = usize::MAX;
        let x = col[wi] << (63 - b);
        if x != 0 {
            up = x.leading_zeros() as usize;
        } else {
            let mut base = b + 1;
            for &x in col[..wi].iter().rev() {
                if base > down {
                    break;
                }
                if x != 0 {
                    up = base + x.leading_zeros() as usize;
                    break;
                }
                base += 64;
            }
        }
        if up == usize::MAX && down == usize::MAX {
            NONE
        } else if up <= down {
            (r - up) as u32
        } else {
            (r + down) as u32
        }
    }

    /// The row distance from `r` to the nearest set cell of column `c` if it is at most
    /// `limit` (else `usize::MAX`).
    #[inline]
    fn column_distance(&self, r: usize, c: usize, limit: usize) -> usize {
        let (lo, hi) = self.span[c];
        if lo == NONE {
            return usize::MAX;
        }
        let (lo, hi) = (lo as usize, hi as usize);
        let d = if r <= lo {
            lo - r
        } else if r >= hi {
            r - hi
        } else {
            // between the first and the last set cell: one set at or below r, one above
            let col = &self.bits[c * self.words..(c + 1) * self.words];
            let (wi, b) = (r / 64, r % 64);
            let x = col[wi] >> b;
            let down = if x != 0 {
                x.trailing_zeros() as usize
            } else {
                let mut base = 64 - b;
                let mut j = wi + 1;
                while col[j] == 0 && base <= limit {
                    j += 1;
                    base += 64;
                }
                base + col[j].trailing_zeros() as usize
            };
            if down == 0 {
                return 0;
            }
            let x = col[wi] << (63 - b);
            let up = if x != 0 {
                x.leading_zeros() as usize
            } else {
                let mut base = b + 1;
                let mut j = wi - 1;
                while col[j] == 0 && base <= limit.min(down) {
                    j -= 1;
                    base += 64;
                }
                base + col[j].leading_zeros() as usize
            };
            up.min(down)
        };
        if d <= limit {
            d
        } else {
            usize::MAX
        }
    }

    /// The squared distance from cell `(r, c)` to the nearest set cell (None when no cell is
    /// set): [`Columns::query`]'s, by its scan of the row's columns taken as far as needed
    /// (no envelope: which cell is nearest does not matter here); and how many columns the
    /// scan looked at.
    #[inline]
    pub fn distance(&self, r: usize, c: usize) -> (Option<u32>, usize) {
        let w = self.width;
        // rows farther than `limit` cannot beat `best` (limit >= sqrt(best): a bound, larger
        // is safe)
        let limit_of = |best: u64| {
            if best == u64::MAX {
                usize::MAX
            } else {
                (best as f64).sqrt() as usize + 1
            }
        };
        let offer = |q: usize, k2: u64, limit: usize| -> u64 {
            match self.column_distance(r, q, limit) {
                usize::MAX => u64::MAX,
                d => k2 + (d * d) as u64,
            }
        };
        let mut best = offer(c, 0, usize::MAX);
        let mut limit = limit_of(best);
        let mut k = 1usize;
        loop {
            let k2 = (k * k) as u64;
            if k2 >= best || (k > c && c + k >= w) {
                break;
            }
            let mut b = best;
            if k <= c {
                b = b.min(offer(c - k, k2, limit));
            }
            if c + k < w {
                b = b.min(offer(c + k, k2, limit));
            }
            if b < best {
                best = b;
                limit = limit_of(best);
            }
            k += 1;
        }
        // fits u32: checked against the diagonal
        ((best != u64::MAX).then_some(best as u32), 2 * k - 1)
    }
}

impl NearestCell for Sparse {
    #[inline]
    fn query(&self, r: usize, c: usize) -> Option<(u32, u32)> {
        scan_query(r, c, self.width, |q| self.column_nearest(r, q))
    }
}

#[cfg(test)]
pub(crate) mod tests;
