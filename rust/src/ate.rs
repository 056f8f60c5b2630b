//! The absolute trajectory error's passes over the poses (docs/spec.md section 6), for
//! `slamq.metrics.ate`: association by nearest timestamp (evo's rule), the sums the
//! Umeyama alignment needs (means, spread, cross-covariance), the per-pose errors after
//! the alignment and their statistics. The 3x3 SVD and the decisions on it stay in Python
//! (numpy, as evo), which `python/slamq/metrics/align.py` keeps as the reference.
//!
//! Every float sum is taken over fixed chunks of [`CHUNK`] poses, each summed in order,
//! and the chunk sums added in order: the results do not depend on the number of threads.
//! Element-wise arithmetic is the numpy reference's, operation by operation (no fused
//! multiply-add), so the per-pose errors are bit-equal to it; the sums differ from numpy's
//! pairwise sums by rounding only (about 1e-16 relative).

use rayon::prelude::*;

/// Poses a chunk of every sum; fixed, so that sums do not depend on the thread count.
pub const CHUNK: usize = 1 << 12;

/// Poses per parallel task of the association.
const MATCH_CHUNK: usize = 1 << 16;

/// The first index `k` in `lo..hi` with `at(k) > x`, for non-decreasing `at` (`hi` when
/// none), as numpy's `searchsorted(side="right")`.
fn upper_in(at: &impl Fn(usize) -> f64, x: f64, mut lo: usize, mut hi: usize) -> usize {
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if at(mid) <= x {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    lo
}

/// [`upper_in`] over `0..n` searched from `hint` (the answer for the stamp before), by
/// galloping: O(log distance), so sorted stamps cost about one step each.
fn upper_from(at: &impl Fn(usize) -> f64, n: usize, x: f64, hint: usize) -> usize {
    if hint > 0 && at(hint - 1) > x {
        return upper_in(at, x, 0, hint - 1);
    }
    // the usual steps of two sorted trajectories: the same pose, or the next one
    if hint == n || at(hint) > x {
        return hint;
    }
    if hint + 1 == n || at(hint + 1) > x {
        return hint + 1;
    }
    let (mut lo, mut step) = (hint, 1usize);
    while lo + step <= n && at(lo + step - 1) <= x {
        lo += step;
        step *= 2;
    }
    upper_in(at, x, lo, (lo + step).min(n))
}

/// Indices `(i1, i2)` of the best match in `stamps_2 + offset_2` of each of `stamps_1`
/// within `max_dt`, exactly as `slamq.metrics.sync.matching_indices` (evo's
/// `matching_time_indices`): the nearest, a tie to the earlier; stamps outside the range
/// of `stamps_2` widened by `max_dt` are not matched. `stamps_2` must be non-decreasing
/// (`stamps_1` need not be: sorted stamps are only faster).
pub fn matching_indices(
    stamps_1: &[f64],
    stamps_2: &[f64],
    max_dt: f64,
    offset_2: f64,
) -> (Vec<i64>, Vec<i64>) {
    let n2 = stamps_2.len();
    if n2 == 0 || stamps_1.is_empty() {
        return (Vec::new(), Vec::new());
    }
    let at = |k: usize| stamps_2[k] + offset_2;
    let (low, high) = (at(0) - max_dt, at(n2 - 1) + max_dt);
    let parts: Vec<(Vec<i64>, Vec<i64>)> = stamps_1
        .par_chunks(MATCH_CHUNK)
        .enumerate()
        .map(|(c, s1)| {
            let base = c * MATCH_CHUNK;
            let (mut i1, mut i2) = (Vec::with_capacity(s1.len()), Vec::with_capacity(s1.len()));
            let mut hint = 0usize;
            for (k, &s) in s1.iter().enumerate() {
                let up = upper_from(&at, n2, s, hint);
                hint = up;
                if s < low || s > high {
                    continue;
                }
                let idx = up.min(n2 - 1);
                let diff_ub = at(idx) - s;
                let diff_lb = if idx > 0 {
                    s - at(idx - 1)
                } else {
                    f64::INFINITY
                };
                let pick_ub = diff_ub <= max_dt && diff_ub < diff_lb;
                let pick_lb = !pick_ub && diff_lb <= max_dt && diff_lb <= diff_ub;
                if pick_ub || pick_lb {
                    i1.push((base + k) as i64);
                    i2.push(if pick_ub { idx as i64 } else { idx as i64 - 1 });
                }
            }
            (i1, i2)
        })
        .collect();
    let total = parts.iter().map(|p| p.0.len()).sum();
    let (mut i1, mut i2) = (Vec::with_capacity(total), Vec::with_capacity(total));
    for (a, b) in parts {
        i1.extend_from_slice(&a);
        i2.extend_from_slice(&b);
    }
    (i1, i2)
}

/// Associated pairs of poses: rows `gi[k]` of the ground truth's and `ei[k]` of the
/// estimate's positions (`(n, 3)` row-major each).
#[derive(Clone, Copy, Debug)]
pub struct Pairs<'a> {
    pub gt: &'a [f64],
    pub est: &'a [f64],
    pub gi: &'a [i64],
    pub ei: &'a [i64],
}

/// Why pairs cannot be used.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PairsError {
    /// Position arrays whose length is not a multiple of 3, or index arrays of different
    /// lengths.
    Shape,
    /// An index outside its positions.
    Index,
}

impl std::fmt::Display for PairsError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PairsError::Shape => write!(f, "positions must be (n, 3) and gi, ei equally long"),
            PairsError::Index => write!(f, "a pose index is out of range"),
        }
    }
}

impl<'a> Pairs<'a> {
    /// Checked pairs: shapes agree and every index is inside its positions.
    pub fn new(
        gt: &'a [f64],
        est: &'a [f64],
        gi: &'a [i64],
        ei: &'a [i64],
    ) -> Result<Self, PairsError> {
        if gt.len() % 3 != 0 || est.len() % 3 != 0 || gi.len() != ei.len() {
            return Err(PairsError::Shape);
        }
        let inside =
            |idx: &[i64], n: usize| idx.par_iter().all(|&i| i >= 0 && (i as u64) < n as u64);
        if !inside(gi, gt.len() / 3) || !inside(ei, est.len() / 3) {
            return Err(PairsError::Index);
        }
        Ok(Pairs { gt, est, gi, ei })
    }

    /// The number of pairs.
    pub fn len(&self) -> usize {
        self.gi.len()
    }

    /// Whether there is no pair.
    pub fn is_empty(&self) -> bool {
        self.gi.is_empty()
    }

    fn gt_at(&self, k: usize) -> &[f64] {
        let i = self.gi[k] as usize;
        &self.gt[3 * i..3 * i + 3]
    }

    fn est_at(&self, k: usize) -> &[f64] {
        let i = self.ei[k] as usize;
        &self.est[3 * i..3 * i + 3]
    }
}

/// Sums over `0..n` of `f(k)` (an array of `W` sums), over fixed chunks in parallel.
fn chunked_sums<const W: usize>(n: usize, f: impl Fn(usize, &mut [f64; W]) + Sync) -> [f64; W] {
    let parts: Vec<[f64; W]> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut acc = [0.0; W];
            for k in c * CHUNK..((c + 1) * CHUNK).min(n) {
                f(k, &mut acc);
            }
            acc
        })
        .collect();
    let mut total = [0.0; W];
    for p in parts {
        for (t, v) in total.iter_mut().zip(p) {
            *t += v;
        }
    }
    total
}

/// What the Umeyama alignment of the estimate (`x`) onto the ground truth (`y`) needs, over
/// the first `dims` (2 or 3) coordinates: the means, `sigma_x` = mean squared distance of
/// `x` from its mean, and `cov[r][c]` = mean of `(y_r - mean_y_r) (x_c - mean_x_c)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Moments {
    pub mean_x: [f64; 3],
    pub mean_y: [f64; 3],
    pub sigma_x: f64,
    pub cov: [[f64; 3]; 3],
}

/// [`Moments`] of the pairs over their first `dims` (1 to 3) coordinates (zeros beyond);
/// two passes (the means, then the centred sums), as `slamq.metrics.align.umeyama`.
pub fn moments(pairs: &Pairs<'_>, dims: usize) -> Moments {
    let n = pairs.len();
    let d = dims.clamp(1, 3);
    let inv_n = 1.0 / n as f64;
    let s: [f64; 6] = chunked_sums(n, |k, acc| {
        let (x, y) = (pairs.est_at(k), pairs.gt_at(k));
        for c in 0..d {
            acc[c] += x[c];
            acc[3 + c] += y[c];
        }
    });
    let (mut mean_x, mut mean_y) = ([0.0; 3], [0.0; 3]);
    for c in 0..d {
        mean_x[c] = s[c] / n as f64;
        mean_y[c] = s[3 + c] / n as f64;
    }
    // [sum |xc|^2, cov row-major 3x3]
    let s: [f64; 10] = chunked_sums(n, |k, acc| {
        let (x, y) = (pairs.est_at(k), pairs.gt_at(k));
        let mut xc = [0.0; 3];
        let mut yc = [0.0; 3];
        for c in 0..d {
            xc[c] = x[c] - mean_x[c];
            yc[c] = y[c] - mean_y[c];
            acc[0] += xc[c] * xc[c];
        }
        for r in 0..d {
            for c in 0..d {
                acc[1 + 3 * r + c] += yc[r] * xc[c];
            }
        }
    });
    let mut cov = [[0.0; 3]; 3];
    for r in 0..d {
        for c in 0..d {
            cov[r][c] = inv_n * s[1 + 3 * r + c];
        }
    }
    // numpy's `1.0 / n * (np.linalg.norm(xc) ** 2)`: the root squared again
    let norm = s[0].sqrt();
    Moments {
        mean_x,
        mean_y,
        sigma_x: inv_n * (norm * norm),
        cov,
    }
}

/// A similarity `p -> scale * rotation p + translation` (row-major rotation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Similarity {
    pub rotation: [[f64; 3]; 3],
    pub translation: [f64; 3],
    pub scale: f64,
}

/// The statistics of the per-pose errors, as evo's `get_statistic`: `sum` and `sse` (sum
/// of squares), `ssd` (sum of squared deviations from `sum / n`), `min`, `max`, `median`
/// (numpy's: the mean of the two middle values for an even count).
#[derive(Clone, Debug, PartialEq)]
pub struct Stats {
    pub sum: f64,
    pub sse: f64,
    pub ssd: f64,
    pub min: f64,
    pub max: f64,
    pub median: f64,
}

/// The distance of each pair after moving the estimate by `align` (`None`: as is), with
/// the reference's operations: row `k` of `scale * R p + t` as `((R_k0 x + R_k1 y) + R_k2
/// z)`, times the scale unless it is 1, plus `t_k`; the distance as numpy's `einsum` sums
/// a row of three (`(dx^2 + dz^2) + dy^2`).
pub fn errors(pairs: &Pairs<'_>, align: Option<&Similarity>) -> Vec<f64> {
    let mut out = vec![0.0; pairs.len()];
    out.par_chunks_mut(CHUNK)
        .enumerate()
        .for_each(|(c, chunk)| {
            for (j, e) in chunk.iter_mut().enumerate() {
                let k = c * CHUNK + j;
                let (g, p) = (pairs.gt_at(k), pairs.est_at(k));
                let mut q = [p[0], p[1], p[2]];
                if let Some(a) = align {
                    for (r, out) in q.iter_mut().enumerate() {
                        let rr = &a.rotation[r];
                        let mut col = rr[0] * p[0] + rr[1] * p[1] + rr[2] * p[2];
                        if a.scale != 1.0 {
                            col *= a.scale;
                        }
                        *out = col + a.translation[r];
                    }
                }
                let (dx, dy, dz) = (q[0] - g[0], q[1] - g[1], q[2] - g[2]);
                *e = (dx * dx + dz * dz + dy * dy).sqrt();
            }
        });
    out
}

/// [`Stats`] of `errors` (at least one).
pub fn stats(errors: &[f64]) -> Stats {
    let n = errors.len();
    let s: [f64; 2] = chunked_sums(n, |k, acc| {
        let e = errors[k];
        acc[0] += e;
        acc[1] += e * e;
    });
    let mean = s[0] / n as f64;
    let [ssd]: [f64; 1] = chunked_sums(n, |k, acc| {
        let d = errors[k] - mean;
        acc[0] += d * d;
    });
    let (min, max) = errors
        .par_chunks(CHUNK)
        .map(|c| {
            c.iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &e| {
                    (lo.min(e), hi.max(e))
                })
        })
        .reduce(
            || (f64::INFINITY, f64::NEG_INFINITY),
            |a, b| (a.0.min(b.0), a.1.max(b.1)),
        );
    Stats {
        sum: s[0],
        sse: s[1],
        ssd,
        min,
        max,
        median: median(errors),
    }
}

/// numpy's median of finite values: the middle one, or the mean of the two middle ones.
fn median(v: &[f64]) -> f64 {
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    let mut w = v.to_vec();
    let h = n / 2;
    let (lower, mid, _) = w.select_nth_unstable_by(h, f64::total_cmp);
    let hi = *mid;
    if n % 2 == 1 {
        return hi;
    }
    let lo = lower.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    (lo + hi) / 2.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The numpy reference's rule, one stamp at a time, with a plain binary search.
    fn matching_reference(s1: &[f64], s2: &[f64], max_dt: f64, off: f64) -> (Vec<i64>, Vec<i64>) {
        let s2o: Vec<f64> = s2.iter().map(|s| s + off).collect();
        let n2 = s2o.len();
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for (k, &s) in s1.iter().enumerate() {
            let inside = !(s < s2o[0] - max_dt || s > s2o[n2 - 1] + max_dt);
            let idx = s2o.partition_point(|&v| v <= s).min(n2 - 1);
            let ub = s2o[idx] - s;
            let lb = if idx > 0 {
                s - s2o[idx - 1]
            } else {
                f64::INFINITY
            };
            let pu = ub <= max_dt && ub < lb;
            let pl = !pu && lb <= max_dt && lb <= ub;
            if inside && (pu || pl) {
                a.push(k as i64);
                b.push(if pu { idx as i64 } else { idx as i64 - 1 });
            }
        }
        (a, b)
    }

    fn lcg(x: &mut u64) -> f64 {
        *x = x
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (*x >> 11) as f64 / (1u64 << 53) as f64
    }

    #[test]
    fn matching_equals_the_reference_rule_sorted_or_not() {
        let mut x = 7u64;
        let mut s2: Vec<f64> = (0..200_000).map(|i| i as f64 * 0.01).collect();
        s2[500] = s2[499]; // a duplicate stamp
        s2[501] = s2[499];
        let mut s1: Vec<f64> = (0..150_000)
            .map(|i| i as f64 * 0.0133 + (lcg(&mut x) - 0.5) * 0.02 - 3.0)
            .collect();
        s1.sort_by(f64::total_cmp);
        for (dt, off) in [(0.01, 0.0), (0.003, 0.25), (0.0, 0.0), (1.0, -2.0)] {
            assert_eq!(
                matching_indices(&s1, &s2, dt, off),
                matching_reference(&s1, &s2, dt, off)
            );
        }
        let mut shuffled = s1.clone();
        shuffled.reverse();
        shuffled.swap(3, 90_000);
        assert_eq!(
            matching_indices(&shuffled, &s2, 0.01, 0.1),
            matching_reference(&shuffled, &s2, 0.01, 0.1)
        );
        // exact ties go to the earlier pose
        assert_eq!(
            matching_indices(&[0.5], &[0.0, 0.25, 0.75], 0.3, 0.0),
            (vec![0], vec![1])
        );
        assert_eq!(matching_indices(&[], &[1.0], 0.1, 0.0), (vec![], vec![]));
    }

    #[test]
    fn moments_and_errors_of_a_known_motion() {
        // est = gt rotated by 90 degrees about z and shifted
        let gt: Vec<f64> = (0..10_000)
            .flat_map(|i| {
                let a = i as f64 * 0.001;
                [a.cos(), (2.0 * a).sin(), 0.1 * a]
            })
            .collect();
        let est: Vec<f64> = gt
            .chunks(3)
            .flat_map(|p| [-p[1] + 1.0, p[0] - 2.0, p[2]])
            .collect();
        let idx: Vec<i64> = (0..10_000).collect();
        let pairs = Pairs::new(&gt, &est, &idx, &idx).unwrap();
        let m = moments(&pairs, 3);
        let mean_g: Vec<f64> = (0..3)
            .map(|c| gt.chunks(3).map(|p| p[c]).sum::<f64>() / 1e4)
            .collect();
        for c in 0..3 {
            assert!((m.mean_y[c] - mean_g[c]).abs() < 1e-12);
        }
        assert!((m.mean_x[0] - (1.0 - mean_g[1])).abs() < 1e-12);
        // the inverse motion brings the estimate back: errors are (almost) zero
        let a = Similarity {
            rotation: [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
            translation: [2.0, 1.0, 0.0],
            scale: 1.0,
        };
        let e = errors(&pairs, Some(&a));
        assert!(e.iter().all(|&v| v < 1e-12));
        let none = errors(&pairs, None);
        assert!(none.iter().any(|&v| v > 1.0));
        assert_eq!(
            Pairs::new(&gt, &est, &[0, 10_000], &[0, 1]).unwrap_err(),
            PairsError::Index
        );
        assert_eq!(
            Pairs::new(&gt, &est, &[0], &[0, 1]).unwrap_err(),
            PairsError::Shape
        );
    }

    #[test]
    fn statistics_and_the_median() {
        let s = stats(&[3.0, 1.0, 2.0, 10.0]);
        assert_eq!(
            (s.sum, s.sse, s.min, s.max, s.median),
            (16.0, 114.0, 1.0, 10.0, 2.5)
        );
        assert_eq!(s.ssd, 1.0 + 9.0 + 4.0 + 36.0);
        assert_eq!(stats(&[5.0, 1.0, 2.0]).median, 2.0);
        assert_eq!(stats(&[0.25]).median, 0.25);
    }

    #[test]
    fn sums_do_not_depend_on_the_thread_count() {
        let mut x = 3u64;
        let v: Vec<f64> = (0..300_001).map(|_| lcg(&mut x) * 1e3).collect();
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let three = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap();
        let a = one.install(|| stats(&v));
        let b = three.install(|| stats(&v));
        assert_eq!(a, b);
    }
}
