//! The comparison's tests: known motions, literal counts, every scan and resampling path
//! against the literal one.

use super::resample::*;
use super::scan::*;
use super::*;
use crate::edt::tests::rng;
use crate::grid::Grid;
use crate::se2::Frame;

/// A `h x w` map, free everywhere, with walls where `wall(r, c)`; unknown outside
/// `known(r, c)`.
fn map(
    h: usize,
    w: usize,
    wall: impl Fn(usize, usize) -> bool,
    known: impl Fn(usize, usize) -> bool,
) -> (Vec<u8>, Vec<bool>) {
    let mut v = vec![254u8; h * w];
    let mut u = vec![false; h * w];
    for r in 0..h {
        for c in 0..w {
            if wall(r, c) {
                v[r * w + c] = 0;
            }
            u[r * w + c] = !known(r, c);
        }
    }
    (v, u)
}

fn frame(h: usize, w: usize, res: f64, origin: Se2) -> Frame {
    Frame {
        resolution: res,
        height: h,
        width: w,
        origin,
    }
}

/// Walls of a building: the outline and a few inner walls with doors, plus a pillar.
fn building(r: usize, c: usize) -> bool {
    let outer = r == 10 || r == 110 || c == 10 || c == 150;
    let inner = (c == 70 && !(40..50).contains(&r)) || (r == 60 && c < 70 && c > 30);
    let pillar = (85..90).contains(&r) && (110..115).contains(&c);
    ((10..=110).contains(&r) && (10..=150).contains(&c)) && (outer || inner || pillar)
}

#[test]
fn identical_maps_match_perfectly() {
    let (h, w) = (120, 160);
    let (v, u) = map(h, w, building, |_, _| true);
    let g = Grid::new(&v, &u, h, w).unwrap();
    let f = frame(h, w, 0.05, Se2::IDENTITY);
    let p = Placed { grid: g, frame: f };
    for align in [Align::Origin, Align::Icp] {
        let params = CompareParams {
            align,
            ..Default::default()
        };
        let c = compare(&p, &p, &params, true).unwrap();
        assert_eq!(c.estimate_occupied, c.ground_truth_occupied);
        assert_eq!(c.intersection, c.union);
        assert_eq!(c.estimate_matched, c.estimate_occupied);
        assert_eq!(c.sum_ne, 0.0);
        assert_eq!(c.sum_reverse, 0.0);
        assert!(c.transform.theta.abs() < 1e-12);
        assert!(c.transform.tx.abs() < 1e-12 && c.transform.ty.abs() < 1e-12);
        assert_eq!(c.covered, c.ground_truth_free);
        assert_eq!(c.outside, 0);
    }
}

/// The building compared with itself, its ground-truth copy's frame moved by `moved`.
fn compare_moved(moved: Se2, params: &CompareParams) -> Comparison {
    let (h, w) = (120, 160);
    let (v, u) = map(h, w, building, |_, _| true);
    let g = Grid::new(&v, &u, h, w).unwrap();
    let est = Placed {
        grid: g,
        frame: frame(h, w, 0.05, Se2::IDENTITY),
    };
    let gt = Placed {
        grid: g,
        frame: frame(h, w, 0.05, moved),
    };
    compare(&est, &gt, params, false).unwrap()
}

#[test]
fn recovers_a_known_motion() {
    // the ground truth's frame is moved: the estimate must follow it back
    let moved = Se2 {
        theta: 3f64.to_radians(),
        tx: 0.3,
        ty: -0.2,
    };
    let c = compare_moved(moved, &CompareParams::default());
    let t = c.transform;
    assert!((t.theta - moved.theta).abs() < 0.5f64.to_radians(), "{t:?}");
    assert!(
        (t.tx - moved.tx).abs() < 0.05 && (t.ty - moved.ty).abs() < 0.05,
        "{t:?}"
    );
    let o = compare_moved(
        moved,
        &CompareParams {
            align: Align::Origin,
            ..Default::default()
        },
    );
    assert!(c.sum_reverse < o.sum_reverse / 4.0);
}

#[test]
fn search_finds_a_large_rotation() {
    let moved = Se2 {
        theta: 97f64.to_radians(),
        tx: 5.0,
        ty: 1.0,
    };
    let p = CompareParams {
        align: Align::Search,
        ..Default::default()
    };
    let c = compare_moved(moved, &p);
    assert!((c.transform.theta - moved.theta).abs() < 0.5f64.to_radians());
    assert_eq!(c.estimate_matched, c.estimate_occupied);
}

#[test]
fn missing_and_doubled_walls() {
    let (h, w) = (120, 160);
    let (gv, gu) = map(h, w, building, |_, _| true);
    let f = frame(h, w, 0.05, Se2::IDENTITY);
    let gt = Placed {
        grid: Grid::new(&gv, &gu, h, w).unwrap(),
        frame: f,
    };
    let p = CompareParams {
        align: Align::Origin,
        ..Default::default()
    };
    // missing: the inner wall at r == 60
    let (mv, mu) = map(h, w, |r, c| building(r, c) && r != 60, |_, _| true);
    let est = Placed {
        grid: Grid::new(&mv, &mu, h, w).unwrap(),
        frame: f,
    };
    let c = compare(&est, &gt, &p, false).unwrap();
    assert!(c.ground_truth_matched < c.ground_truth_occupied && c.sum_ne > 0.0);
    assert_eq!(c.sum_reverse, 0.0);
    assert_eq!(c.estimate_matched, c.estimate_occupied);
    // doubled: a copy of the wall at c == 150 at c == 140
    let (dv, du) = map(
        h,
        w,
        |r, c| building(r, c) || (c == 140 && (10..=110).contains(&r)),
        |_, _| true,
    );
    let est = Placed {
        grid: Grid::new(&dv, &du, h, w).unwrap(),
        frame: f,
    };
    let c = compare(&est, &gt, &p, false).unwrap();
    assert!(c.estimate_matched < c.estimate_occupied && c.sum_reverse > 0.0);
    assert_eq!(c.sum_ne, 0.0);
    // truncation bounds every distance
    let t = CompareParams {
        max_distance: Some(3.0),
        ..p
    };
    let c = compare(&est, &gt, &t, false).unwrap();
    assert!(c.truncated_reverse > 0 && c.sum_reverse <= 3.0 * c.estimate_occupied as f64);
}

#[test]
fn scan_equals_a_literal_count() {
    let mut next = rng(31);
    for case in 0..60 {
        let (h, w) = (1 + (next() % 90) as usize, 1 + (next() % 150) as usize);
        let values: Vec<u8> = (0..h * w).map(|_| next() as u8).collect();
        let unknown: Vec<bool> = (0..h * w).map(|_| next() % 7 < case as u64 % 4).collect();
        let threshold = [0.0, 0.2, 0.5, 0.65, 0.9, 0.999][case % 6];
        let occ = occupied_table(threshold);
        let s = scan(&Grid::new(&values, &unknown, h, w).unwrap(), &occ).unwrap();
        let cells: Vec<u32> = (0..h * w)
            .filter(|&i| !unknown[i] && occ[values[i] as usize])
            .map(|i| i as u32)
            .collect();
        assert_eq!(s.cells, cells, "{h} x {w}");
        let bw = w.div_ceil(BLOCK);
        let mut known = vec![0u8; h.div_ceil(BLOCK) * bw];
        for i in 0..h * w {
            known[(i / w / BLOCK) * bw + (i % w) / BLOCK] += (!unknown[i]) as u8;
        }
        assert_eq!(s.known, known, "{h} x {w}");
        assert_eq!(
            s.known_cells,
            unknown.iter().filter(|&&u| !u).count() as u64
        );
    }
}

/// The SSE2 block-row scan gives the scalar rows' list and counts, on random block
/// rows of 1-8 rows and every width to 70 (pairs of blocks, an odd block, a short
/// tail), every threshold.
#[cfg(target_arch = "x86_64")]
#[test]
fn scan_block_sse2_equals_scalar() {
    let mut next = rng(37);
    for case in 0..3000 {
        let w = 1 + case % 70;
        let n = 1 + (next() % 8) as usize;
        let below = [0usize, 1, 2, 77, 128, 129, 200, 255, 256][case % 9];
        let vals: Vec<u8> = (0..n * w).map(|_| next() as u8).collect();
        let unknown: Vec<u8> = (0..n * w)
            .map(|_| (next() % 5 < case as u64 % 3) as u8)
            .collect();
        let bw = w.div_ceil(BLOCK);
        let start: Vec<u8> = (0..bw).map(|_| (next() % 50) as u8).collect();
        let base = (next() % 1000) as usize;
        let (mut k1, mut k2) = (start.clone(), start.clone());
        let (mut l1, mut l2) = (vec![7u32], vec![7u32]);
        let n1 = scan_block_scalar(&vals, &unknown, w, &mut k1, below, &mut l1, base).unwrap();
        let n2 = scan_block_sse2(&vals, &unknown, w, &mut k2, below, &mut l2, base).unwrap();
        assert_eq!((n1, &k1, &l1), (n2, &k2, &l2), "w {w} n {n} below {below}");
    }
}

/// [`scan_block_avx2`] against the scalar rows: block rows of 1-8 rows, every width to
/// 140 (quads of blocks, a pair, an odd block, a short tail) and some past the 64
/// quads kept on the stack, every threshold.
#[cfg(target_arch = "x86_64")]
#[test]
fn scan_block_avx2_equals_scalar() {
    if !scan_avx2() {
        return;
    }
    let mut next = rng(41);
    for case in 0..4000 {
        let w = if case % 100 == 99 {
            2040 + case % 70
        } else {
            1 + case % 140
        };
        let n = 1 + (next() % 8) as usize;
        let below = [0usize, 1, 2, 77, 128, 129, 200, 255, 256][case % 9];
        let vals: Vec<u8> = (0..n * w).map(|_| next() as u8).collect();
        let unknown: Vec<u8> = (0..n * w)
            .map(|_| (next() % 5 < case as u64 % 3) as u8)
            .collect();
        let bw = w.div_ceil(BLOCK);
        let start: Vec<u8> = (0..bw).map(|_| (next() % 50) as u8).collect();
        let base = (next() % 1000) as usize;
        let (mut k1, mut k2) = (start.clone(), start.clone());
        let (mut l1, mut l2) = (vec![7u32], vec![7u32]);
        let n1 = scan_block_scalar(&vals, &unknown, w, &mut k1, below, &mut l1, base).unwrap();
        // SAFETY: AVX2 is present (checked above)
        let n2 =
            unsafe { scan_block_avx2(&vals, &unknown, w, &mut k2, below, &mut l2, base) }.unwrap();
        assert_eq!((n1, &k1, &l1), (n2, &k2, &l2), "w {w} n {n} below {below}");
    }
}

#[test]
fn row_col_equals_division() {
    let mut next = rng(43);
    for w in [1usize, 2, 7, 64, 1000] {
        let mut at = RowCol::new(w);
        // ascending runs, then jumps back and forth
        let mut i = 0usize;
        for k in 0..3000 {
            i = if k % 50 == 49 {
                (next() % 100_000) as usize
            } else {
                i + (next() % 5) as usize
            };
            assert_eq!(at.get(i), (i / w, i % w), "w {w} i {i}");
        }
    }
}

#[test]
fn sparse_resampling_equals_the_literal_one() {
    let mut next = rng(23);
    let mut unit = move || (next() % 1_000_000) as f64 / 1_000_000.0;
    for case in 0..120 {
        let (h, w) = (
            40 + (unit() * 90.0) as usize,
            40 + (unit() * 120.0) as usize,
        );
        let (eh, ew) = (
            30 + (unit() * 100.0) as usize,
            30 + (unit() * 110.0) as usize,
        );
        let density = [0.0, 0.01, 0.05, 0.3][case % 4];
        let mut rand = (0..eh * ew).map(|_| unit()).collect::<Vec<_>>().into_iter();
        let (mut ev, mut eu) = map(eh, ew, building, |r, c| (r * 7 + c * 3) % 50 < 40);
        for i in 0..eh * ew {
            let x = rand.next().unwrap();
            if x < density {
                ev[i] = (x * 2e4) as u8;
            }
            if case % 5 == 0 && i % 13 == 0 {
                eu[i] = !eu[i];
            }
        }
        let (gv, mut gu) = map(h, w, building, |_, _| true);
        if case % 2 == 1 {
            for (i, u) in gu.iter_mut().enumerate() {
                *u = (i / w) % 17 < 3;
            }
        }
        let est = Placed {
            grid: Grid::new(&ev, &eu, eh, ew).unwrap(),
            frame: frame(
                eh,
                ew,
                [0.05, 0.04, 0.07, 0.2, 0.013][case % 5],
                Se2 {
                    theta: (unit() - 0.5) * [0.1, 1.0, 6.0][case % 3],
                    tx: (unit() - 0.5) * 2.0,
                    ty: (unit() - 0.5) * 2.0,
                },
            ),
        };
        let gt = Placed {
            grid: Grid::new(&gv, &gu, h, w).unwrap(),
            frame: frame(h, w, 0.05, Se2::IDENTITY),
        };
        let occ = occupied_table(0.5);
        let t = Se2 {
            theta: (unit() - 0.5) * 0.2,
            tx: (unit() - 0.5) * 0.5,
            ty: (unit() - 0.5) * 0.5,
        };
        let g_scan = scan(&gt.grid, &occ).unwrap();
        let e_scan = scan(&est.grid, &occ).unwrap();
        let g_mask: Vec<bool> = (0..h * w).map(|i| !gu[i] && occ[gv[i] as usize]).collect();
        let lit: Vec<u32> = (0..h * w)
            .filter(|&i| g_mask[i])
            .map(|i| i as u32)
            .collect();
        assert_eq!(g_scan.cells, lit);
        let points = occupied_points(&est, &e_scan.cells).unwrap();
        let g_near = Sparse::new(&g_scan.cells, h, w).unwrap();
        let want = resample(&est, &gt, &g_mask, &t, &occ, &points).unwrap();
        let got = resample_sparse(&est, &gt, &g_scan, &g_near, &e_scan, &t, &points)
            .unwrap()
            .unwrap();
        assert_eq!(got.e_list, want.e_list, "case {case}");
        assert_eq!(
            (got.outside, got.free, got.covered),
            (want.outside, want.free, want.covered),
            "case {case}"
        );
    }
}

/// Frames the sparse resampling cannot place in its fixed point (far apart, or grids
/// whose cells differ by orders of magnitude) take the literal resampling: the same
/// counts as with the per-cell flags. Without them it once read an empty mask of G:
/// no free cell, coverage NaN.
#[test]
fn frames_far_apart_give_the_counts_of_the_cells_path() {
    let (h, w) = (120, 160);
    let (v, u) = map(h, w, building, |r, _| r < 90);
    let g = Grid::new(&v, &u, h, w).unwrap();
    let at = |tx: f64, ty: f64| Se2 { theta: 0.0, tx, ty };
    let cases = [
        (0.05, at(1e8, 0.0), 0.05),
        (0.05, at(-1e300, 3.0), 0.05),
        (0.05, at(3e7, -2e7), 0.05),
        // one estimate cell holds the whole ground truth (a 1e-6 m grid)
        (1000.0, at(-50_000.0, -50_000.0), 1e-6),
    ];
    for (k, &(res, origin, gt_res)) in cases.iter().enumerate() {
        let est = Placed {
            grid: g,
            frame: frame(h, w, res, origin),
        };
        let gt = Placed {
            grid: g,
            frame: frame(h, w, gt_res, Se2::IDENTITY),
        };
        for align in [Align::Origin, Align::Icp] {
            let p = CompareParams {
                align,
                ..Default::default()
            };
            let mut with = compare(&est, &gt, &p, true).unwrap();
            with.cells = None;
            let without = compare(&est, &gt, &p, false).unwrap();
            // (as text: an ICP that found nothing gives a NaN RMS on both)
            assert_eq!(
                format!("{without:?}"),
                format!("{with:?}"),
                "case {k} {align:?}"
            );
            let free = u.iter().zip(&v).filter(|(&u, &v)| !u && v > 127).count();
            assert_eq!(with.ground_truth_free, free as u64, "case {k}");
        }
    }
}

#[test]
fn same_result_for_any_thread_count() {
    let (h, w) = (120, 160);
    let (v, u) = map(h, w, building, |r, _| r < 90);
    let g = Grid::new(&v, &u, h, w).unwrap();
    let est = Placed {
        grid: g,
        frame: frame(h, w, 0.05, Se2::IDENTITY),
    };
    let gt = Placed {
        grid: g,
        frame: frame(
            h,
            w,
            0.04,
            Se2 {
                theta: 0.03,
                tx: 0.1,
                ty: 0.2,
            },
        ),
    };
    let run = |t: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .unwrap()
            .install(|| compare(&est, &gt, &CompareParams::default(), true).unwrap())
    };
    assert_eq!(run(1), run(3));
    // without the per-cell flags (the sparse resampling): the same counts
    let mut with = run(1);
    with.cells = None;
    assert_eq!(
        compare(&est, &gt, &CompareParams::default(), false).unwrap(),
        with
    );
}

#[test]
fn flags_within_a_box_are_the_whole_grids_cut() {
    let (h, w) = (120, 160);
    let (v, u) = map(h, w, building, |r, c| r < 90 && c > 10);
    let g = Grid::new(&v, &u, h, w).unwrap();
    let est = Placed {
        grid: g,
        frame: frame(h, w, 0.05, Se2::IDENTITY),
    };
    let moved = Se2 {
        theta: 0.03,
        tx: 0.1,
        ty: 0.2,
    };
    // the last: frames far apart (the literal resampling, cut)
    let far = Se2 {
        theta: 0.0,
        tx: 1e8,
        ty: 0.0,
    };
    for (res, origin) in [
        (0.04, moved),
        (0.05, Se2::IDENTITY),
        (0.06, moved),
        (0.05, far),
    ] {
        let gt = Placed {
            grid: g,
            frame: frame(h, w, res, origin),
        };
        let p = CompareParams::default();
        let all = compare(&est, &gt, &p, true).unwrap();
        let flags = all.cells.clone().unwrap();
        for b in [
            CellBox {
                r0: 7,
                r1: 95,
                c0: 13,
                c1: 150,
            },
            CellBox {
                r0: 0,
                r1: h,
                c0: 0,
                c1: 40,
            },
            CellBox {
                r0: 50,
                r1: 500,
                c0: 100,
                c1: 900,
            },
            CellBox {
                r0: 30,
                r1: 30,
                c0: 0,
                c1: w,
            },
            CellBox {
                r0: 0,
                r1: h,
                c0: 0,
                c1: w,
            },
        ] {
            let got = compare_within(&est, &gt, &p, Some(b)).unwrap();
            let c = b.clip(h, w);
            let mut want = Vec::new();
            for r in c.r0..c.r1 {
                want.extend_from_slice(&flags[r * w + c.c0..r * w + c.c1]);
            }
            assert_eq!(got.cells.as_ref().unwrap(), &want, "{b:?} at {res}");
            let (mut x, mut y) = (got, all.clone());
            x.cells = None;
            y.cells = None;
            assert_eq!(x, y, "the counts, {b:?} at {res}");
        }
    }
}
