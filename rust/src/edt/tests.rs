//! The distance transform's tests, and the oracles they hold it to: the brute-force
//! transform and the former scan queries.

use super::*;

/// A small deterministic generator (xorshift), so tests need no crate (also used by
/// compare's tests).
pub(crate) fn rng(seed: u64) -> impl FnMut() -> u64 {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    }
}

fn check_against_brute(mask: &[bool], h: usize, w: usize) {
    let brute = brute_force(mask, h, w);
    let d = distances(|i| mask[i], h, w).unwrap();
    assert_eq!(d, brute, "{h}x{w}");
    let n = nearest(|i| mask[i], h, w).unwrap();
    for i in 0..mask.len() {
        if n[i] == NONE {
            assert!(!mask.iter().any(|&b| b));
            assert_eq!(d[i], u32::MAX);
            continue;
        }
        assert!(mask[n[i] as usize], "nearest of {i} is not set");
        assert_eq!(sqdist_between(i, n[i] as usize, w), d[i]);
    }
    let query: Vec<bool> = (0..mask.len()).map(|i| (i * 7919) % 3 == 0).collect();
    let at = distances_at(|i| mask[i], h, w, &query).unwrap();
    for i in 0..mask.len() {
        assert_eq!(at[i], if query[i] { d[i] } else { u32::MAX });
    }
}

#[test]
fn equals_brute_force_on_random_masks() {
    let mut next = rng(7);
    for case in 0..300 {
        let h = 1 + (next() % 40) as usize;
        let w = 1 + (next() % 300) as usize;
        let density = [1u64, 3, 20, 50, 97][case % 5];
        let mask: Vec<bool> = (0..h * w).map(|_| next() % 100 < density).collect();
        check_against_brute(&mask, h, w);
    }
}

/// The column pass literally: per column, the nearest set row (ties: the one above).
fn literal_columns(mask: &[bool], h: usize, w: usize) -> Vec<u32> {
    let mut out = vec![NONE; h * w];
    for c in 0..w {
        for r in 0..h {
            let mut best: Option<(usize, usize)> = None;
            for q in 0..h {
                if mask[q * w + c] {
                    let d = r.abs_diff(q);
                    if best.is_none_or(|(bd, _)| d < bd) {
                        best = Some((d, q));
                    }
                }
            }
            if let Some((_, q)) = best {
                out[r * w + c] = q as u32;
            }
        }
    }
    out
}

#[test]
fn column_pass_equals_the_literal_one() {
    let mut next = rng(11);
    for case in 0..60 {
        let h = 1 + (next() % 30) as usize;
        let w = 1 + (next() % 200) as usize;
        let density = [1u64, 5, 30, 90][case % 4];
        let mask: Vec<bool> = (0..h * w).map(|_| next() % 100 < density).collect();
        let got = column_pass(&|i| mask[i], h, w).unwrap();
        assert_eq!(got, literal_columns(&mask, h, w), "{h} x {w}");
        let list: Vec<u32> = (0..h * w).filter(|&i| mask[i]).map(|i| i as u32).collect();
        let sparse = Sparse::new(&list, h, w).unwrap();
        assert_eq!(
            sparse.columns().unwrap().near,
            got,
            "{h} x {w} from the bits"
        );
    }
}

#[test]
fn column_pass_from_the_bits_on_tall_masks() {
    // columns of several words, sparse and dense, empty columns, walls across
    let mut next = rng(29);
    for case in 0..40 {
        let h = 1 + (next() % 260) as usize;
        let w = 1 + (next() % 40) as usize;
        let density = [0u64, 2, 10, 100, 600][case % 5];
        let mut mask: Vec<bool> = (0..h * w).map(|_| next() % 1000 < density).collect();
        if case % 4 == 1 {
            let r = (next() % h as u64) as usize;
            for q in 0..w {
                mask[r * w + q] = true;
            }
        }
        let list: Vec<u32> = (0..h * w).filter(|&i| mask[i]).map(|i| i as u32).collect();
        let sparse = Sparse::new(&list, h, w).unwrap();
        let want = column_pass(&|i| mask[i], h, w).unwrap();
        assert_eq!(want, literal_columns(&mask, h, w), "{h} x {w}");
        assert_eq!(sparse.columns().unwrap().near, want, "{h} x {w}");
    }
}

#[test]
fn single_cell_and_empty() {
    let mut mask = vec![false; 7 * 5];
    assert!(distances(|i| mask[i], 7, 5)
        .unwrap()
        .iter()
        .all(|&d| d == u32::MAX));
    assert!(nearest(|i| mask[i], 7, 5)
        .unwrap()
        .iter()
        .all(|&n| n == NONE));
    mask[2 * 5 + 3] = true;
    check_against_brute(&mask, 7, 5);
    let d = distances(|i| mask[i], 7, 5).unwrap();
    assert_eq!(d[0], 4 + 9);
    assert_eq!(d[6 * 5 + 4], 16 + 1);
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
            .install(|| {
                (
                    nearest(|i| mask[i], h, w).unwrap(),
                    distances(|i| mask[i], h, w).unwrap(),
                )
            })
    };
    let one = run(1);
    assert_eq!(one, run(3));
    assert_eq!(one.1, brute_force(&mask, h, w));
}

#[test]
fn point_queries_equal_the_transform() {
    let mut next = rng(5);
    for case in 0..120 {
        let h = 1 + (next() % 60) as usize;
        let w = 1 + (next() % 200) as usize;
        let density = [0u64, 1, 5, 30][case % 4];
        let mask: Vec<bool> = (0..h * w).map(|_| next() % 1000 < density * 10).collect();
        let d = brute_force(&mask, h, w);
        let cols = Columns::new(|i| mask[i], h, w).unwrap();
        for i in 0..h * w {
            match cols.query(i / w, i % w) {
                None => assert_eq!(d[i], u32::MAX),
                Some((n, sq)) => {
                    assert_eq!(sq, d[i], "{h}x{w} cell {i}");
                    assert!(mask[n as usize]);
                    assert_eq!(sqdist_between(i, n as usize, w), sq);
                }
            }
        }
    }
}

#[test]
fn sparse_queries_equal_the_column_pass() {
    let mut next = rng(17);
    for case in 0..160 {
        let h = 1 + (next() % 150) as usize;
        let w = 1 + (next() % 230) as usize;
        // densities from empty to dense, and walls: rows and columns of set cells
        let density = [0u64, 1, 3, 20, 300][case % 5];
        let mut mask: Vec<bool> = (0..h * w).map(|_| next() % 1000 < density).collect();
        if case % 3 == 0 {
            let (r, c) = ((next() % h as u64) as usize, (next() % w as u64) as usize);
            for q in 0..w {
                mask[r * w + q] = true;
            }
            for q in 0..h {
                mask[q * w + c] = q % 7 != 0;
            }
        }
        let list: Vec<u32> = (0..h * w).filter(|&i| mask[i]).map(|i| i as u32).collect();
        let cols = Columns::new(|i| mask[i], h, w).unwrap();
        let sparse = Sparse::new(&list, h, w).unwrap();
        let dense = sparse.columns().unwrap();
        for i in 0..h * w {
            let (r, c) = (i / w, i % w);
            let want = cols.query(r, c);
            assert_eq!(NearestCell::query(&sparse, r, c), want, "{h}x{w} {i}");
            assert_eq!(dense.query(r, c), want);
            assert_eq!(cols.distance(r, c), want.map(|(_, d)| d));
            assert_eq!(sparse.distance(r, c).0, want.map(|(_, d)| d));
            assert_eq!(sparse.get(r, c), mask[i]);
        }
    }
}

/// Far queries: the longer scan answers the envelope's cell and distance, on wide
/// rows with few set cells (most queries past `SCAN` columns) and many ties (set cells
/// placed symmetrically, rows of equal distance).
#[test]
fn far_queries_equal_the_envelope() {
    let mut next = rng(53);
    for case in 0..120 {
        let h = 1 + (next() % 120) as usize;
        let w = 60 + (next() % 400) as usize;
        let mut mask = vec![false; h * w];
        for _ in 0..(next() % 6) {
            let (r, c) = ((next() % h as u64) as usize, (next() % w as u64) as usize);
            mask[r * w + c] = true;
            if case % 2 == 0 {
                // its mirror about a column and a row: ties
                let (m, rr) = (w - 1 - c, h - 1 - r);
                mask[r * w + m] = true;
                mask[rr * w + c] = true;
                mask[rr * w + m] = true;
            }
        }
        let cols = Columns::new(|i| mask[i], h, w).unwrap();
        let list: Vec<u32> = (0..h * w).filter(|&i| mask[i]).map(|i| i as u32).collect();
        let sparse = Sparse::new(&list, h, w).unwrap();
        let mut env = Envelope::new(w);
        for i in 0..h * w {
            let (r, c) = (i / w, i % w);
            let row = &cols.near[r * w..(r + 1) * w];
            let want = scan_query_envelope(r, c, w, |q| row[q], &mut env);
            assert_eq!(cols.query(r, c), want, "{h}x{w} ({r}, {c})");
            assert_eq!(NearestCell::query(&sparse, r, c), want);
        }
    }
}

/// The scan without per-column tests answers the former scan's cell and distance at
/// every cell of random masks: empty to dense, narrow and wide (far queries past
/// `SCAN`), walls, mirrored (tied) cells; through `Columns::query`,
/// `Columns::nearest_cell` and `Sparse`.
#[test]
fn scan_equals_the_literal_scan() {
    let mut next = rng(59);
    for case in 0..200 {
        let h = 1 + (next() % 90) as usize;
        let w = 1 + (next() % [8, 60, 300][case % 3]) as usize;
        let density = [0u64, 1, 4, 30, 400][case % 5];
        let mut mask: Vec<bool> = (0..h * w).map(|_| next() % 1000 < density).collect();
        if case % 4 == 1 {
            let r = (next() % h as u64) as usize;
            for q in 0..w {
                mask[r * w + q] = q % 5 != 0;
            }
        }
        if case % 2 == 0 {
            for i in 0..h * w {
                let (r, c) = (i / w, i % w);
                if mask[i] {
                    mask[r * w + (w - 1 - c)] = true;
                }
            }
        }
        let cols = Columns::new(|i| mask[i], h, w).unwrap();
        let list: Vec<u32> = (0..h * w).filter(|&i| mask[i]).map(|i| i as u32).collect();
        let sparse = Sparse::new(&list, h, w).unwrap();
        for i in 0..h * w {
            let (r, c) = (i / w, i % w);
            let row = &cols.near[r * w..(r + 1) * w];
            let want = scan_query_literal(r, c, w, |q| row[q]);
            assert_eq!(cols.query(r, c), want, "{h}x{w} ({r}, {c})");
            assert_eq!(
                cols.nearest_cell(r, c),
                want.map(|(n, _)| (n as usize / w, n as usize % w))
            );
            assert_eq!(NearestCell::query(&sparse, r, c), want);
        }
    }
}

#[test]
fn refuses_bad_shapes() {
    assert!(matches!(
        distances(|_| true, 0, 3),
        Err(EdtError::Shape { .. })
    ));
    assert!(matches!(
        distances_at(|_| true, 2, 2, &[true; 3]),
        Err(EdtError::Shape { .. })
    ));
    assert!(matches!(
        distances(|_| true, 70_000, 70_000),
        Err(EdtError::TooLarge { .. })
    ));
}

/// The former [`scan_query`] (a test for [`NONE`] and for both bounds per column): what the
/// tests hold [`scan_arg`] to.
fn scan_query_literal(
    r: usize,
    c: usize,
    w: usize,
    near: impl Fn(usize) -> u32,
) -> Option<(u32, u32)> {
    let ri = r as i64;
    let f = |q: usize| -> Option<u64> {
        let n = near(q);
        (n != NONE).then(|| {
            let d = (ri - n as i64).unsigned_abs();
            d * d
        })
    };
    let (mut best, mut arg) = (u64::MAX, usize::MAX);
    if let Some(v) = f(c) {
        (best, arg) = (v, c);
    }
    let mut k = 1usize;
    loop {
        let k2 = (k * k) as u64;
        if k2 >= best || (k > c && c + k >= w) {
            break;
        }
        if k > SCAN {
            return far_query(c, w, k, best, &f)
                .map(|(q, b)| ((near(q) as usize * w + q) as u32, b as u32));
        }
        if k <= c {
            if let Some(v) = f(c - k) {
                if k2 + v < best {
                    (best, arg) = (k2 + v, c - k);
                }
            }
        }
        if c + k < w {
            if let Some(v) = f(c + k) {
                if k2 + v < best {
                    (best, arg) = (k2 + v, c + k);
                }
            }
        }
        k += 1;
    }
    if arg == usize::MAX {
        return None;
    }
    Some(((near(arg) as usize * w + arg) as u32, best as u32))
}

/// The former [`scan_query`], whose far queries built the row's lower envelope: what the
/// tests hold the longer scan to.
fn scan_query_envelope(
    r: usize,
    c: usize,
    w: usize,
    near: impl Fn(usize) -> u32,
    env: &mut Envelope,
) -> Option<(u32, u32)> {
    let ri = r as i64;
    let f = |q: usize| -> Option<u64> {
        let n = near(q);
        (n != NONE).then(|| {
            let d = (ri - n as i64).unsigned_abs();
            d * d
        })
    };
    let (mut best, mut arg) = (u64::MAX, usize::MAX);
    if let Some(v) = f(c) {
        (best, arg) = (v, c);
    }
    let mut k = 1usize;
    loop {
        let k2 = (k * k) as u64;
        if k2 >= best || (k > c && c + k >= w) {
            break;
        }
        if k > SCAN {
            let row: Vec<u32> = (0..w).map(&near).collect();
            let n = env.build(r, &row);
            if n == 0 {
                return None;
            }
            let ci = c as i64;
            let mut j = 0usize;
            while j + 1 < n && env.g[j + 1] - env.g[j] < 2 * ci * (env.v[j + 1] - env.v[j]) {
                j += 1;
            }
            let p = env.v[j];
            let d = (env.g[j] - 2 * ci * p + ci * ci) as u32;
            return Some(((row[p as usize] as usize * w + p as usize) as u32, d));
        }
        if k <= c {
            if let Some(v) = f(c - k) {
                if k2 + v < best {
                    (best, arg) = (k2 + v, c - k);
                }
            }
        }
        if c + k < w {
            if let Some(v) = f(c + k) {
                if k2 + v < best {
                    (best, arg) = (k2 + v, c + k);
                }
            }
        }
        k += 1;
    }
    if arg == usize::MAX {
        return None;
    }
    Some(((near(arg) as usize * w + arg) as u32, best as u32))
}

/// The squared distance transform by brute force (every cell against every set cell), for
/// tests: O(cells x set cells).
pub(crate) fn brute_force(mask: &[bool], height: usize, width: usize) -> Vec<u32> {
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
