//! A borrowed occupancy grid: values (uint8, 0 = occupied ... 255 = free) and an unknown mask,
//! both row-major H x W, plus the helpers every metric shares (row bands, the value histogram).

use rayon::prelude::*;
use std::fmt;

/// Rows per band for the parallel passes. Fixed (not derived from the thread count) so that
/// the work split, and therefore every intermediate, is the same for any number of threads.
pub const BAND_ROWS: usize = 64;

/// Why a pair of buffers is not a valid grid.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum GridError {
    /// Height or width is zero.
    Empty { height: usize, width: usize },
    /// A buffer's length is not `height * width`.
    Length {
        what: &'static str,
        expected: usize,
        got: usize,
    },
    /// The grid has more cells than the core indexes (2^32 - 1).
    TooLarge { cells: usize },
}

impl fmt::Display for GridError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GridError::Empty { height, width } => {
                write!(f, "the map has zero cells ({height} x {width})")
            }
            GridError::Length {
                what,
                expected,
                got,
            } => {
                write!(f, "{what} holds {got} cells, expected {expected}")
            }
            GridError::TooLarge { cells } => {
                write!(
                    f,
                    "the map has {cells} cells; at most 4294967295 are supported"
                )
            }
        }
    }
}

impl std::error::Error for GridError {}

/// A read-only view of one map. Unknown cells' values are ignored by every metric.
#[derive(Clone, Copy, Debug)]
pub struct Grid<'a> {
    pub values: &'a [u8],
    pub unknown: &'a [bool],
    pub height: usize,
    pub width: usize,
}

impl<'a> Grid<'a> {
    /// Check the buffers against the shape.
    pub fn new(
        values: &'a [u8],
        unknown: &'a [bool],
        height: usize,
        width: usize,
    ) -> Result<Self, GridError> {
        if height == 0 || width == 0 {
            return Err(GridError::Empty { height, width });
        }
        let cells = height
            .checked_mul(width)
            .ok_or(GridError::TooLarge { cells: usize::MAX })?;
        if cells > u32::MAX as usize {
            return Err(GridError::TooLarge { cells });
        }
        for (what, got) in [("values", values.len()), ("unknown mask", unknown.len())] {
            if got != cells {
                return Err(GridError::Length {
                    what,
                    expected: cells,
                    got,
                });
            }
        }
        Ok(Grid {
            values,
            unknown,
            height,
            width,
        })
    }

    /// Number of cells.
    #[inline]
    pub fn cells(&self) -> usize {
        self.height * self.width
    }

    /// Row `r` of the values.
    #[inline]
    pub fn value_row(&self, r: usize) -> &'a [u8] {
        &self.values[r * self.width..(r + 1) * self.width]
    }

    /// Row `r` of the unknown mask.
    #[inline]
    pub fn unknown_row(&self, r: usize) -> &'a [bool] {
        &self.unknown[r * self.width..(r + 1) * self.width]
    }

    /// Histogram of the known cells' values, the number of unknown cells, and the histogram
    /// of the unknown cells' values.
    pub fn histogram(&self) -> Histogram {
        self.histogram_with(None)
    }

    /// [`Grid::histogram`], the unknown cells counted by the value of `shade` at the same
    /// cell (the loader's pixels, whose shade says how the map was saved) instead of their
    /// value; `None`, or a `shade` of another length: their value.
    pub fn histogram_with(&self, shade: Option<&[u8]>) -> Histogram {
        let w = self.width;
        let band = BAND_ROWS * w;
        let shade = match shade {
            Some(s) if s.len() == self.values.len() => s,
            _ => self.values,
        };
        let parts: Vec<([u64; 256], [u64; 256])> = self
            .values
            .par_chunks(band)
            .zip(self.unknown.par_chunks(band))
            .zip(shade.par_chunks(band))
            .map(|((vals, unk), sh)| band_histogram(vals, unk, sh))
            .collect();
        let mut known = [0u64; 256];
        let mut unknown_values = [0u64; 256];
        for (h, sh) in parts {
            for (k, c) in known.iter_mut().zip(h.iter()) {
                *k += c;
            }
            for (k, c) in unknown_values.iter_mut().zip(sh.iter()) {
                *k += c;
            }
        }
        Histogram {
            known,
            unknown: unknown_values.iter().sum(),
            unknown_values,
        }
    }
}

/// Cells per block of [`band_histogram`]'s hot-key pass.
const HOT_BLOCK: usize = 32;

/// The histogram of one band: known cells by value, unknown cells by shade.
///
/// Maps are dominated by a few keys (free, occupied, unknown shade), which a sample of the band
/// finds; blocks of cells are counted against those three keys by compare-and-add (branch-free,
/// so the loop vectorises), and only the cells of other keys go through the 512-bin table
/// (four sub-tables break the store-to-load dependency on repeated values). Which keys are hot
/// changes the speed, never the counts.
fn band_histogram(vals: &[u8], unk: &[bool], sh: &[u8]) -> ([u64; 256], [u64; 256]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: AVX2 is present
        return unsafe { band_histogram_avx2(vals, unk, sh) };
    }
    band_histogram_in(vals, unk, sh)
}

/// [`band_histogram`] compiled for AVX2 (the same integer counts, wider registers).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn band_histogram_avx2(vals: &[u8], unk: &[bool], sh: &[u8]) -> ([u64; 256], [u64; 256]) {
    band_histogram_in(vals, unk, sh)
}

#[inline(always)]
fn band_histogram_in(vals: &[u8], unk: &[bool], sh: &[u8]) -> ([u64; 256], [u64; 256]) {
    let key = |i: usize| {
        if unk[i] {
            256 + sh[i] as usize
        } else {
            vals[i] as usize
        }
    };
    // the three commonest keys of a sample (distinct; an unused slot matches no cell)
    let mut sample = [0u32; 512];
    for i in (0..vals.len()).step_by(61) {
        sample[key(i)] = sample[key(i)].saturating_add(1); // wide maps: only the speed
    }
    let sampled = vals.len().div_ceil(61);
    let mut covered = 0usize;
    let mut hv = [0u8; 3];
    let mut hu = [2u8; 3]; // 2: no cell's unknown flag
    for k in 0..3 {
        let (mut top, mut at) = (0u32, 0usize);
        for (j, &c) in sample.iter().enumerate() {
            if c > top {
                (top, at) = (c, j);
            }
        }
        if top == 0 {
            break;
        }
        sample[at] = 0;
        covered += top as usize;
        hv[k] = (at & 255) as u8;
        hu[k] = (at >> 8) as u8;
    }
    if covered * 8 < sampled * 7 {
        // graded maps: most cells are of other keys, the table alone is faster
        return band_histogram_table(vals, unk, sh);
    }
    let mut hot = [0u64; 3];
    // per-lane counts of the hot keys, flushed before they can overflow (no per-block sum)
    let mut lanes = [[0u8; HOT_BLOCK]; 3];
    let mut pending = 0u32;
    let flush = |lanes: &mut [[u8; HOT_BLOCK]; 3], hot: &mut [u64; 3]| {
        for (n, l) in hot.iter_mut().zip(lanes.iter_mut()) {
            *n += l.iter().map(|&c| u64::from(c)).sum::<u64>();
            *l = [0u8; HOT_BLOCK];
        }
    };
    let mut h = [[0u32; 512]; 4];
    let mut vc = vals.chunks_exact(HOT_BLOCK);
    let mut uc = unk.chunks_exact(HOT_BLOCK);
    let mut sc = sh.chunks_exact(HOT_BLOCK);
    for ((v, u), s) in (&mut vc).zip(&mut uc).zip(&mut sc) {
        // the value, or for an unknown cell its shade, with no branch
        let mut x = [0u8; HOT_BLOCK];
        let mut uu = [0u8; HOT_BLOCK];
        for j in 0..HOT_BLOCK {
            let m = u8::from(u[j]);
            uu[j] = m;
            let m = m.wrapping_neg();
            x[j] = (v[j] & !m) | (s[j] & m);
        }
        let mut hit = [0u8; HOT_BLOCK];
        for (l, (&hvk, &huk)) in lanes.iter_mut().zip(hv.iter().zip(&hu)) {
            for j in 0..HOT_BLOCK {
                let e = u8::from(x[j] == hvk) & u8::from(uu[j] == huk);
                hit[j] |= e;
                l[j] += e;
            }
        }
        // every cell matched one hot key (at most one: the keys are distinct)?
        let mut all = u64::MAX;
        for c in hit.chunks_exact(8) {
            let mut word = [0u8; 8];
            word.copy_from_slice(c);
            all &= u64::from_le_bytes(word);
        }
        if all != 0x0101_0101_0101_0101 {
            for j in 0..HOT_BLOCK {
                // no branch per cell: a hot cell adds 0
                h[j & 3][x[j] as usize | (usize::from(uu[j]) << 8)] += u32::from(hit[j] ^ 1);
            }
        }
        pending += 1;
        if pending == 255 {
            flush(&mut lanes, &mut hot);
            pending = 0;
        }
    }
    flush(&mut lanes, &mut hot);
    let done = vals.len() - vc.remainder().len();
    for i in done..vals.len() {
        h[0][key(i)] += 1;
    }
    let (mut known, mut shades) = ([0u64; 256], [0u64; 256]);
    for i in 0..256 {
        known[i] = h.iter().map(|hk| u64::from(hk[i])).sum();
        shades[i] = h.iter().map(|hk| u64::from(hk[256 + i])).sum();
    }
    for k in 0..3 {
        match hu[k] {
            0 => known[hv[k] as usize] += hot[k],
            1 => shades[hv[k] as usize] += hot[k],
            _ => {}
        }
    }
    (known, shades)
}

/// [`band_histogram`] by the table alone: one table of 512 bins (known cells by value in
/// 0..256, unknown cells by shade in 256..512), four sub-tables against the store-to-load
/// dependency on repeated values; blocks of 8 cells that are all known (or all unknown) with
/// one value (shade), long runs of free space and canvas, are counted at once.
fn band_histogram_table(vals: &[u8], unk: &[bool], sh: &[u8]) -> ([u64; 256], [u64; 256]) {
    let mut h = [[0u32; 512]; 4];
    let mut vc = vals.chunks_exact(8);
    let mut uc = unk.chunks_exact(8);
    let mut sc = sh.chunks_exact(8);
    for ((v, u), s) in (&mut vc).zip(&mut uc).zip(&mut sc) {
        let n_unknown = u.iter().filter(|&&x| x).count();
        if n_unknown == 8 && s.iter().all(|&x| x == s[0]) {
            h[0][256 + s[0] as usize] += 8;
            continue;
        }
        if n_unknown == 0 && v.iter().all(|&x| x == v[0]) {
            h[0][v[0] as usize] += 8;
            continue;
        }
        for k in 0..8 {
            // no branch: the value, or for an unknown cell its shade, and the half of the table
            let m = u8::from(u[k]).wrapping_neg();
            let x = (v[k] & !m) | (s[k] & m);
            h[k & 3][x as usize | (usize::from(u[k]) << 8)] += 1;
        }
    }
    for ((v, u), s) in vc
        .remainder()
        .iter()
        .zip(uc.remainder())
        .zip(sc.remainder())
    {
        let x = if *u { 256 + *s as usize } else { *v as usize };
        h[0][x] += 1;
    }
    let (mut known, mut shades) = ([0u64; 256], [0u64; 256]);
    for i in 0..256 {
        known[i] = h.iter().map(|hk| u64::from(hk[i])).sum();
        shades[i] = h.iter().map(|hk| u64::from(hk[256 + i])).sum();
    }
    (known, shades)
}

/// Rows `r0..r1` and columns `c0..c1` of a box: `(r0, r1, c0, c1)`.
pub type Bounds = (usize, usize, usize, usize);

/// The known cells' bounding box, or `None`.
///
/// Reads only what lies outside the box found so far: the all-unknown rows above and below
/// it, and in each row between them the cells left of its first column and right of its
/// last (a row's middle cannot widen the box), eight cells to a word ([`first_known`],
/// [`last_known`]).
pub fn known_bounds(grid: &Grid) -> Option<Bounds> {
    let w = grid.width;
    let row = |r: usize| &grid.unknown[r * w..(r + 1) * w];
    let r0 = (0..grid.height).find(|&r| first_known(row(r)).is_some())?;
    let r1 = (r0..grid.height)
        .rev()
        .find(|&r| first_known(row(r)).is_some())?
        + 1;
    let (mut c0, mut c1) = (w, 0);
    for r in r0..r1 {
        let cells = row(r);
        if let Some(first) = first_known(&cells[..c0]) {
            c0 = first;
        }
        // the last known cell is at or after the first
        let from = c1.max(c0);
        if let Some(last) = last_known(&cells[from..]) {
            c1 = from + last + 1;
        }
    }
    Some((r0, r1, c0, c1))
}

/// The bytes of a slice of bools (0 or 1 each).
#[inline]
pub(crate) fn bytes(b: &[bool]) -> &[u8] {
    // SAFETY: a bool is one byte holding 0 or 1, so every bool is a valid u8, and the
    // slice keeps its length, alignment (1) and lifetime
    unsafe { std::slice::from_raw_parts(b.as_ptr().cast::<u8>(), b.len()) }
}

/// The first eight bytes of `b` as a little-endian word (`b` holds at least eight).
#[inline]
pub(crate) fn word(b: &[u8]) -> u64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&b[..8]);
    u64::from_le_bytes(a)
}

/// A one in every byte of a word: eight `true` flags ([`bytes`], [`word`]).
pub(crate) const ONES: u64 = 0x0101_0101_0101_0101;

/// The index of the first known cell of `cells` (`false`), eight at a time.
pub fn first_known(cells: &[bool]) -> Option<usize> {
    let words = bytes(cells).chunks_exact(8);
    let tail = words.remainder();
    for (i, c) in words.enumerate() {
        let known = word(c) ^ ONES; // 1 in the bytes of known cells
        if known != 0 {
            return Some(8 * i + known.trailing_zeros() as usize / 8);
        }
    }
    let start = cells.len() - tail.len();
    tail.iter().position(|&u| u == 0).map(|i| start + i)
}

/// The index of the last known cell of `cells` (`false`), eight at a time.
pub fn last_known(cells: &[bool]) -> Option<usize> {
    let words = bytes(cells).rchunks_exact(8);
    let head = words.remainder();
    let n = cells.len();
    for (i, c) in words.enumerate() {
        let known = word(c) ^ ONES;
        if known != 0 {
            return Some(n - 8 * (i + 1) + 7 - known.leading_zeros() as usize / 8);
        }
    }
    head.iter().rposition(|&u| u == 0)
}

/// Value histogram of the known cells plus the unknown count.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Histogram {
    pub known: [u64; 256],
    pub unknown: u64,
    /// The unknown cells by value (or by the shade they were histogrammed with).
    pub unknown_values: [u64; 256],
}

impl Histogram {
    /// Number of known cells.
    pub fn known_count(&self) -> u64 {
        self.known.iter().sum()
    }
}

/// Row ranges `[start, end)` of the fixed-size bands covering `height` rows.
pub fn bands(height: usize) -> Vec<(usize, usize)> {
    (0..height)
        .step_by(BAND_ROWS)
        .map(|s| (s, (s + BAND_ROWS).min(height)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_bad_shapes() {
        let v = [0u8; 6];
        let u = [false; 6];
        assert!(Grid::new(&v, &u, 2, 3).is_ok());
        assert!(matches!(
            Grid::new(&v, &u, 0, 3),
            Err(GridError::Empty { .. })
        ));
        assert!(matches!(
            Grid::new(&v, &u[..5], 2, 3),
            Err(GridError::Length { .. })
        ));
        assert!(matches!(
            Grid::new(&v, &u, 3, 3),
            Err(GridError::Length { .. })
        ));
    }

    /// A 64-bit linear congruential generator from `seed` (its high 31 bits per draw).
    fn lcg(seed: u64) -> impl FnMut() -> u64 {
        let mut st = seed;
        move || {
            st = st
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            st >> 33
        }
    }

    /// The box as the plain scan finds it.
    fn plain_bounds(u: &[bool], h: usize, w: usize) -> Option<Bounds> {
        let known: Vec<(usize, usize)> = (0..h * w)
            .filter(|&i| !u[i])
            .map(|i| (i / w, i % w))
            .collect();
        let r0 = known.iter().map(|k| k.0).min()?;
        let r1 = known.iter().map(|k| k.0).max()? + 1;
        let c0 = known.iter().map(|k| k.1).min()?;
        let c1 = known.iter().map(|k| k.1).max()? + 1;
        Some((r0, r1, c0, c1))
    }

    #[test]
    fn known_bounds_equal_a_plain_scan_on_random_maps() {
        let mut next = lcg(11);
        for trial in 0..400 {
            let (h, w) = (1 + next() as usize % 40, 1 + next() as usize % 70);
            // from no known cell to all known, and a few cells in one small rectangle
            let pct = [0u64, 1, 3, 20, 100][trial % 5];
            let mut u: Vec<bool> = (0..h * w).map(|_| next() % 1000 >= pct * 10).collect();
            if trial % 7 == 0 {
                u.fill(true);
                let (r, c) = (next() as usize % h, next() as usize % w);
                u[r * w + c] = false;
            }
            let v = vec![0u8; h * w];
            let g = Grid::new(&v, &u, h, w).unwrap();
            assert_eq!(known_bounds(&g), plain_bounds(&u, h, w), "trial {trial}");
            for r in 0..h {
                let row = &u[r * w..(r + 1) * w];
                assert_eq!(first_known(row), row.iter().position(|&x| !x));
                assert_eq!(last_known(row), row.iter().rposition(|&x| !x));
            }
        }
    }

    #[test]
    fn histogram_equals_a_plain_count_on_random_maps() {
        let mut next = lcg(3);
        for trial in 0..60 {
            let (h, w) = (1 + next() as usize % 150, 1 + next() as usize % 90);
            // few keys (hot path), many keys (fallback), and shades unlike the values
            let levels = [1u64, 2, 3, 4, 7, 256][trial % 6];
            let unk_pct = next() % 101;
            let v: Vec<u8> = (0..h * w).map(|_| (next() % levels * 37) as u8).collect();
            let u: Vec<bool> = (0..h * w).map(|_| next() % 100 < unk_pct).collect();
            let shade: Vec<u8> = (0..h * w).map(|_| (next() % levels * 11) as u8).collect();
            let g = Grid::new(&v, &u, h, w).unwrap();
            for sh in [None, Some(&shade[..])] {
                let (mut known, mut unknown) = ([0u64; 256], [0u64; 256]);
                for i in 0..h * w {
                    if u[i] {
                        unknown[sh.map_or(v[i], |s| s[i]) as usize] += 1;
                    } else {
                        known[v[i] as usize] += 1;
                    }
                }
                let got = g.histogram_with(sh);
                assert_eq!(got.known, known, "trial {trial}");
                assert_eq!(got.unknown_values, unknown, "trial {trial}");
                assert_eq!(got.unknown, unknown.iter().sum::<u64>());
            }
        }
    }

    #[test]
    fn histogram_counts_known_and_unknown() {
        let v: Vec<u8> = (0..200u32).map(|i| (i % 7) as u8).collect();
        let u: Vec<bool> = (0..200u32).map(|i| i % 3 == 0).collect();
        let g = Grid::new(&v, &u, 10, 20).unwrap();
        let h = g.histogram();
        let mut expect = [0u64; 256];
        for (a, b) in v.iter().zip(&u) {
            if !b {
                expect[*a as usize] += 1;
            }
        }
        assert_eq!(h.known, expect);
        assert_eq!(h.unknown, u.iter().filter(|x| **x).count() as u64);
        // the unknown cells by value, and by another array's value (a shade)
        let shade: Vec<u8> = (0..200u32).map(|i| (i % 11) as u8 + 100).collect();
        let (mut by_value, mut by_shade) = ([0u64; 256], [0u64; 256]);
        for ((a, s), b) in v.iter().zip(&shade).zip(&u) {
            if *b {
                by_value[*a as usize] += 1;
                by_shade[*s as usize] += 1;
            }
        }
        assert_eq!(h.unknown_values, by_value);
        let hs = g.histogram_with(Some(&shade));
        assert_eq!((hs.known, hs.unknown), (h.known, h.unknown));
        assert_eq!(hs.unknown_values, by_shade);
        // blocks of 8 all-unknown cells of one shade, and all-known of one value
        let v = vec![7u8; 64];
        let u: Vec<bool> = (0..64).map(|i| i < 32).collect();
        let g = Grid::new(&v, &u, 4, 16).unwrap();
        let h = g.histogram_with(Some(&[205u8; 64]));
        assert_eq!((h.known[7], h.unknown, h.unknown_values[205]), (32, 32, 32));
    }
}
