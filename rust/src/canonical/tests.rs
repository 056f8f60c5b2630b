//! The canonical step's tests: every path of the wall angle and of the resample against
//! each other and against literal ones (the oracles below).

use super::angle::*;
use super::pack::*;
use super::resample::*;
use super::*;
use crate::border::reflect101;
use crate::corners::count_corners;
use rayon::prelude::*;

fn room(n: usize) -> (Vec<u8>, Vec<bool>) {
    let mut v = vec![254u8; n * n];
    for i in 5..n - 5 {
        for &(r, c) in &[(5, i), (n - 6, i), (i, 5), (i, n - 6)] {
            v[r * n + c] = 0;
        }
    }
    (v, vec![false; n * n])
}

#[test]
fn axis_aligned_walls_have_angle_zero_and_keep_their_corners() {
    let (v, u) = room(40);
    let g = Grid::new(&v, &u, 40, 40).unwrap();
    let a = wall_angle(&g).unwrap();
    assert!(a.abs() < 1e-3, "{a}");
    let p = CornerParams {
        canonical_resolution: 0.07,
        ..CornerParams::default()
    };
    let c = canonical_corners(&g, Some(0.05), &p).unwrap();
    assert_eq!(c.corners, Some(count_corners(&g, &p)));
}

#[test]
fn no_known_cell_gives_angle_zero() {
    let v = vec![0u8; 12];
    let u = vec![true; 12];
    let g = Grid::new(&v, &u, 3, 4).unwrap();
    assert_eq!(known_bounds(&g), None);
    assert_eq!(wall_angle(&g).unwrap(), 0.0);
    let p = CornerParams {
        canonical_resolution: 0.07,
        ..CornerParams::default()
    };
    let c = canonical_corners(&g, Some(0.05), &p).unwrap();
    assert_eq!(c.corners, Some(0));
}

#[test]
fn a_huge_canonical_map_is_skipped_not_allocated() {
    let (v, u) = room(40);
    let g = Grid::new(&v, &u, 40, 40).unwrap();
    let p = CornerParams {
        canonical_resolution: 1e-6,
        ..CornerParams::default()
    };
    let c = canonical_corners(&g, Some(1.0), &p).unwrap();
    assert_eq!(c.corners, None);
}

#[test]
fn rint_rounds_half_to_even_like_round_ties_even() {
    for x in [
        0.5,
        1.5,
        2.5,
        -0.5,
        -1.5,
        -2.5,
        0.49999999999999994,
        1e9 + 0.5,
        -7.25,
        123.75,
    ] {
        assert_eq!(rint(x), x.round_ties_even() as i64, "{x}");
    }
    let mut x = -1e6;
    while x < 1e6 {
        assert_eq!(rint(x), x.round_ties_even() as i64, "{x}");
        x += 0.123_456_7;
    }
}

/// A pseudo-random map: walls, free cells, graded values and unknown patches.
fn random_map(h: usize, w: usize, seed: u64) -> (Vec<u8>, Vec<bool>) {
    let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    };
    let p_unknown = next() % 100;
    let mut v = vec![0u8; h * w];
    let mut u = vec![false; h * w];
    for i in 0..h * w {
        let r = next();
        v[i] = match r % 4 {
            0 => 0,
            1 => 254,
            2 => 205,
            _ => (r >> 8) as u8,
        };
        u[i] = (r >> 20) % 100 < p_unknown;
    }
    (v, u)
}

#[test]
fn the_fast_resample_equals_the_general_one() {
    // every sample count the fast path takes (n = 2, 3, 4: f up to 4), turned by angles
    // that put samples exactly on cell edges (0, 45 degrees) and anywhere else
    let angles = [
        0.0,
        0.3,
        -std::f64::consts::FRAC_PI_4,
        std::f64::consts::FRAC_PI_4,
        -0.1,
        1e-9,
    ];
    let mut checked = 0;
    for seed in 0..40u64 {
        let (h, w) = (1 + (seed as usize * 7) % 53, 1 + (seed as usize * 13) % 61);
        let (v, u) = random_map(h, w, seed);
        let g = Grid::new(&v, &u, h, w).unwrap();
        let Some(b) = known_bounds(&g) else { continue };
        let packed = pack_box(&g, b).unwrap();
        for (k, res) in [
            None,
            Some(0.05),
            Some(0.035),
            Some(0.02),
            Some(0.0175),
            Some(0.07),
        ]
        .into_iter()
        .enumerate()
        {
            let a = angles[(seed as usize + k) % angles.len()];
            let slow = map_in_with(&g, &packed, b, a, res, 0.07, Path::General).unwrap();
            for path in [Path::Best, Path::Baseline] {
                let fast = map_in_with(&g, &packed, b, a, res, 0.07, path).unwrap();
                assert_eq!(
                    fast, slow,
                    "{path:?}: seed {seed}, resolution {res:?}, angle {a}"
                );
            }
            checked += 1;
        }
    }
    assert!(checked > 150, "{checked}");
}

/// SPEC 3a.3 literally: every sample of every output cell, no tiles, no skipping.
fn literal_canonical(g: &Grid, angle: f64, f: f64) -> CanonicalMap {
    let (r0, r1, c0, c1) = known_bounds(g).unwrap();
    let (h, w) = (r1 - r0, c1 - c0);
    let (c, s) = (angle.cos(), angle.sin());
    let half = |a: f64, b: f64| ((a.abs() * w as f64 + b.abs() * h as f64) / (2.0 * f)).ceil();
    let (big_w, big_h) = (2 * (half(c, s) as usize + 2), 2 * (half(s, c) as usize + 2));
    let n = (f.ceil() as usize).max(2);
    let mut out = CanonicalMap {
        values: vec![0; big_w * big_h],
        unknown: vec![true; big_w * big_h],
        height: big_h,
        width: big_w,
    };
    for i in 0..big_h {
        for j in 0..big_w {
            let (mut t, mut k) = (0u64, 0u64);
            for a in 0..n {
                for b in 0..n {
                    let qy = ((i as f64 - (big_h / 2) as f64) + (a as f64 + 0.5) / n as f64) * f;
                    let qx = ((j as f64 - (big_w / 2) as f64) + (b as f64 + 0.5) / n as f64) * f;
                    let px = (c * qx - s * qy) + (w / 2) as f64;
                    let py = (s * qx + c * qy) + (h / 2) as f64;
                    let y = py.floor().clamp(0.0, (h - 1) as f64) as usize;
                    let x = px.floor().clamp(0.0, (w - 1) as f64) as usize;
                    let at = (r0 + y) * g.width + c0 + x;
                    if !g.unknown[at] {
                        t += u64::from(g.values[at]);
                        k += 1;
                    }
                }
            }
            if 2 * k >= (n * n) as u64 {
                out.values[i * big_w + j] = ((2 * t + k) / (2 * k)) as u8;
                out.unknown[i * big_w + j] = false;
            }
        }
    }
    out
}

#[test]
fn the_resample_equals_the_literal_one_on_maps_with_open_areas() {
    // large one-valued and unknown areas (the tiles filled or skipped without sampling),
    // beside noise, walls and a frontier
    for seed in 0..12u64 {
        let (h, w) = (
            150 + (seed as usize * 37) % 90,
            170 + (seed as usize * 53) % 80,
        );
        let (noise, nu) = random_map(h, w, seed + 7);
        let mut v = vec![254u8; h * w];
        let mut u = vec![false; h * w];
        for r in 0..h {
            for c in 0..w {
                let i = r * w + c;
                if c > w * 2 / 3 || (r < 20 && c < 60) {
                    u[i] = true; // unexplored
                } else if (r / 16 + c / 24) % 5 == 0 {
                    (v[i], u[i]) = (noise[i], nu[i]); // busy patches
                } else if r % 41 == 3 || c % 57 == 5 {
                    v[i] = 0; // walls
                } else if (r + c) % 97 < 30 {
                    v[i] = 200; // another open shade
                }
            }
        }
        let g = Grid::new(&v, &u, h, w).unwrap();
        let b = known_bounds(&g).unwrap();
        let packed = pack_box(&g, b).unwrap();
        for (k, res) in [0.05, 0.07, 0.035, 0.1, 0.02].into_iter().enumerate() {
            let a = [0.0, 0.3, -std::f64::consts::FRAC_PI_4, 0.05, -0.2][(seed as usize + k) % 5];
            let want = literal_canonical(&g, a, 0.07 / res);
            for path in [Path::Best, Path::Baseline, Path::General] {
                let got = map_in_with(&g, &packed, b, a, Some(res), 0.07, path)
                    .unwrap()
                    .unwrap();
                assert_eq!(
                    got, want,
                    "{path:?}: seed {seed}, resolution {res}, angle {a}"
                );
            }
        }
    }
}

#[test]
fn the_canonical_corners_equal_those_of_the_whole_canonical_map() {
    // the corners counted from the resample's structure image alone (no unknown mask
    // built): the same count as SPEC 3 on the materialised canonical map, for any thread
    // count
    for seed in 0..10u64 {
        let (h, w) = (
            120 + (seed as usize * 29) % 90,
            140 + (seed as usize * 41) % 80,
        );
        let (noise, nu) = random_map(h, w, seed + 3);
        let mut v = vec![254u8; h * w];
        let mut u = vec![false; h * w];
        for r in 0..h {
            for c in 0..w {
                let i = r * w + c;
                if c > w * 3 / 4 || (r < 15 && c < 50) {
                    u[i] = true;
                } else if (r / 20 + c / 30) % 6 == 0 {
                    (v[i], u[i]) = (noise[i], nu[i]);
                } else if r % 37 == 3 || c % 43 == 5 || (r + 2 * c) % 91 == 0 {
                    v[i] = 0;
                }
            }
        }
        let g = Grid::new(&v, &u, h, w).unwrap();
        for (k, res) in [None, Some(0.05), Some(0.1), Some(0.035), Some(0.02)]
            .into_iter()
            .enumerate()
        {
            let p = CornerParams {
                log_threshold: [0.1, 0.0, 0.1, -0.05, 0.3][k],
                canonical_resolution: 0.07,
                ..CornerParams::default()
            };
            let angle = wall_angle(&g).unwrap();
            let m = canonical_map(&g, angle, res, p.canonical_resolution)
                .unwrap()
                .unwrap();
            let mg = Grid::new(&m.values, &m.unknown, m.height, m.width).unwrap();
            let want = count_corners(&mg, &p);
            for threads in [1, 2] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let got = pool.install(|| canonical_corners(&g, res, &p).unwrap());
                assert_eq!(got.corners, Some(want), "seed {seed} res {res:?}");
                assert_eq!(got.angle.to_bits(), angle.to_bits());
            }
        }
    }
}

#[test]
fn angle_sums_are_the_same_on_every_path() {
    // gradients of every size up to the largest (4 * 255 * 256^2), zero runs, ties
    let mut x = 0x2545_F491_4F6C_DD1Du64;
    let mut next = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    };
    let big = 4 * 255 * 65536i64;
    for len in [0usize, 1, 3, 4, 5, 8, 17, 64, 1001] {
        let mut gen = |n: u64| -> Vec<i32> {
            (0..len)
                .map(|_| match next() % 6 {
                    0 => 0,
                    1 => ((next() % (2 * big as u64 + 1)) as i64 - big) as i32,
                    2 => (next() % 9) as i32 - 4,
                    _ => ((next() % (2 * n + 1)) as i64 - n as i64) as i32,
                })
                .collect()
        };
        let (xs, ys) = (gen(3000), gen(70_000));
        let scalar = angle_sums(&xs, &ys, false);
        let best = angle_sums(&xs, &ys, true);
        for (k, (s, b)) in scalar.iter().zip(&best).enumerate() {
            assert_eq!(s.map(f64::to_bits), b.map(f64::to_bits), "{len}, sum {k}");
        }
    }
}

#[test]
fn wall_sums_follow_the_walls_symmetry() {
    // a square room: the fourth harmonic holds the walls' whole weight, the sixth none; a
    // triangle (walls 60 degrees apart): the other way round
    let n = 120usize;
    let (mut v, u) = (vec![254u8; n * n], vec![false; n * n]);
    for i in 20..100 {
        for t in 0..2 {
            v[(20 + t) * n + i] = 0;
            v[(98 + t) * n + i] = 0;
            v[i * n + 20 + t] = 0;
            v[i * n + 98 + t] = 0;
        }
    }
    let g = Grid::new(&v, &u, n, n).unwrap();
    let s = wall_sums_in(&g, known_bounds(&g)).unwrap();
    let r4 = ((s.re4 as f64).hypot(s.im4 as f64)) / s.weight as f64;
    let r6 = ((s.re6 as f64).hypot(s.im6 as f64)) / s.weight as f64;
    assert!(r4 > 0.8 && r6 < 0.05, "square: {s:?}");
    assert_eq!(s.angle(), wall_angle(&g).unwrap());
    let mut v = vec![254u8; n * n];
    let corners = [(10.0f64, 100.0f64), (110.0, 100.0), (60.0, 100.0 - 86.6)];
    for k in 0..3 {
        let ((x0, y0), (x1, y1)) = (corners[k], corners[(k + 1) % 3]);
        for i in 0..=400 {
            let f = i as f64 / 400.0;
            let (x, y) = (x0 + f * (x1 - x0), y0 + f * (y1 - y0));
            v[y.round() as usize * n + x.round() as usize] = 0;
        }
    }
    let g = Grid::new(&v, &u, n, n).unwrap();
    let s = wall_sums_in(&g, known_bounds(&g)).unwrap();
    let r4 = ((s.re4 as f64).hypot(s.im4 as f64)) / s.weight as f64;
    let r6 = ((s.re6 as f64).hypot(s.im6 as f64)) / s.weight as f64;
    assert!(r6 > 0.5 && r4 < 0.2, "triangle: {s:?} r4 {r4} r6 {r6}");
}

#[test]
fn the_decimated_blur_is_the_9x9_binomial_sum() {
    for seed in 0..30u64 {
        let (h, w) = (1 + (seed as usize * 5) % 23, 1 + (seed as usize * 11) % 29);
        let (v, u) = random_map(h, w, seed + 100);
        let g = Grid::new(&v, &u, h, w).unwrap();
        let packed = pack_box(&g, (0, h, 0, w)).unwrap();
        let (d, hd, wd) = blur9_decimated(&packed, h, w).unwrap();
        assert_eq!((hd, wd), (h.div_ceil(2), w.div_ceil(2)));
        let s = |r: usize, c: usize| {
            if u[r * w + c] {
                0
            } else {
                i32::from(v[r * w + c])
            }
        };
        for rd in 0..hd {
            let rows: [&[u16]; 9] = std::array::from_fn(|k| {
                let rr = reflect101((2 * rd) as isize + k as isize - 4, h);
                &packed[rr * w..(rr + 1) * w]
            });
            let mut baseline = vec![0i32; wd];
            blur_row_in(rows, &mut vec![0u16; w], &mut vec![0u16; w], &mut baseline);
            for cd in 0..wd {
                let mut want = 0;
                for i in 0..9 {
                    for j in 0..9 {
                        let r = reflect101((2 * rd + i) as isize - 4, h);
                        let c = reflect101((2 * cd + j) as isize - 4, w);
                        want += i32::from(B9[i]) * i32::from(B9[j]) * s(r, c);
                    }
                }
                assert_eq!(d[rd * wd + cd], want, "{h} x {w} at ({rd}, {cd})");
                assert_eq!(baseline[cd], want, "{h} x {w} at ({rd}, {cd})");
            }
        }
    }
}

#[test]
fn the_wall_angle_by_tasks_equals_the_one_from_the_whole_blur() {
    // boxes of one to three tasks' rows, odd and even sizes, inside a larger grid
    for seed in 0..24u64 {
        let h = [1, 2, 9, 17, 128, 129, 131, 300][seed as usize % 8];
        let w = [1, 3, 10, 57, 200][seed as usize % 5];
        let (v, mut u) = random_map(h + 6, w + 4, seed + 7);
        for r in 0..h + 6 {
            for c in 0..w + 4 {
                if r < 3 || r >= h + 3 || c < 2 || c >= w + 2 {
                    u[r * (w + 4) + c] = true;
                }
            }
        }
        let g = Grid::new(&v, &u, h + 6, w + 4).unwrap();
        let Some(b) = known_bounds(&g) else { continue };
        let want = sums_in(&pack_box(&g, b).unwrap(), b.1 - b.0, b.3 - b.2);
        assert_eq!(angle_of_box(&g, b), want, "{h} x {w}");
        assert_eq!(wall_angle(&g).unwrap().to_bits(), want.angle().to_bits());
        // each task's sums: the AVX2 path (where there is one) and the baseline one
        let (bh, bw) = (b.1 - b.0, b.3 - b.2);
        let scratch = || AngleScratch {
            structure: StructureRows::new(bw),
            vert: vec![0u16; bw],
            split: vec![0u16; bw],
            ring: vec![0i32; 3 * bw.div_ceil(2)],
            sobel: SobelRows::default(),
        };
        let (mut best, mut base) = (scratch(), scratch());
        for t in 0..bh.div_ceil(2).div_ceil(ANGLE_TASK_ROWS) {
            assert_eq!(
                angle_task(&g, b, t, &mut best),
                angle_task_in(&g, b, t, &mut base),
                "{h} x {w} task {t}"
            );
        }
    }
}

#[test]
fn half_up_mean_divides_exactly() {
    for k in 1..=16u32 {
        for t in 0..=255 * k {
            assert_eq!(half_up_mean(t, k), (2 * t + k) / (2 * k), "{t} / {k}");
        }
    }
    assert_eq!(half_up_mean(0, 0), 0);
    for k in 2..=4u32 {
        for t in 0..=255 * k {
            assert_eq!(half_up_mean_of_4(t, k), (2 * t + k) / (2 * k), "{t} / {k}");
        }
    }
}

#[test]
fn floor_in_is_the_clamped_floor() {
    for &(p, last) in &[
        (-0.5, 9.0),
        (0.0, 9.0),
        (0.49999999999999994, 9.0),
        (0.5, 9.0),
        (1.5, 9.0),
        (2.5, 9.0),
        (2.9999999999999996, 9.0),
        (3.0, 9.0),
        (8.999_999, 9.0),
        (9.0, 9.0),
        (12.5, 9.0),
        (f64::NAN, 9.0),
        (4_503_599_627_370_495.5, 4_503_599_627_370_495.0),
    ] {
        let want = if p.is_nan() {
            0.0
        } else {
            p.max(0.0).min(last).floor()
        };
        assert_eq!(floor_in::<false>(p, last), want, "{p}");
        assert_eq!(floor_in::<true>(p, last), want, "{p}");
        assert_eq!(float_bits_index(want), want as u64);
    }
}

#[test]
fn bounds_are_the_known_box() {
    let mut u = vec![true; 5 * 6];
    for r in 1..3 {
        for c in 2..5 {
            u[r * 6 + c] = false;
        }
    }
    let v = vec![0u8; 30];
    let g = Grid::new(&v, &u, 5, 6).unwrap();
    assert_eq!(known_bounds(&g), Some((1, 3, 2, 5)));
}

/// `D`: the 9x9 binomial sum of the packed box's known values ([`pack_box`], `h x w`;
/// unknown cells count 0; reflect-101 at the box's edges) at every second row and column
/// (rows and columns 0, 2, 4, ...), `ceil(h/2) x ceil(w/2)`; exact in `i32` (at most
/// 255 * 256^2). Each output row is one vertical pass over nine input rows, exact in `u16`
/// (at most 255 * 256), then the decimated horizontal taps. (The wall angle computes the
/// same rows a few at a time, [`angle_of_box`]; this whole image is the tests' baseline.)
fn blur9_decimated(
    packed: &[u16],
    h: usize,
    w: usize,
) -> Result<(Vec<i32>, usize, usize), OutOfMemory> {
    let (hd, wd) = (h.div_ceil(2), w.div_ceil(2));
    let mut out = filled(hd * wd, 0i32)?;
    out.par_chunks_mut(wd).enumerate().for_each_init(
        || (vec![0u16; w], vec![0u16; w]),
        |(vert, full), (rd, o)| {
            let rows: [&[u16]; 9] = std::array::from_fn(|k| {
                let rr = reflect101((2 * rd) as isize + k as isize - 4, h);
                &packed[rr * w..(rr + 1) * w]
            });
            blur_row_in(rows, vert, full, o);
        },
    );
    Ok((out, hd, wd))
}

fn rint(x: f64) -> i64 {
    rint_f(x) as i64
}

/// The [`WallSums`] of the packed box ([`pack_box`], `h x w`), from the whole of `D`: the
/// tests' baseline for [`angle_of_box`].
fn sums_in(packed: &[u16], h: usize, w: usize) -> WallSums {
    let (g2, h, w) = blur9_decimated(packed, h, w).unwrap();
    g2.par_chunks(w)
        .enumerate()
        .map_init(SobelRows::default, |scratch, (r, _)| {
            let row = |k: isize| {
                let rr = reflect101(r as isize + k, h);
                &g2[rr * w..(rr + 1) * w]
            };
            sobel_terms_row([row(-1), row(0), row(1)], scratch)
        })
        .reduce(WallSums::default, |a, b| a + b)
}
