//! Otsu's threshold exactly as OpenCV's `getThreshVal_Otsu_8u` computes it (SPEC section 4
//! step 2), and the threshold `T_u` for every unknown value `u` from one histogram.

use crate::grid::Histogram;

/// `FLT_EPSILON` promoted to double, as in OpenCV's comparison.
const FLT_EPSILON: f64 = f32::EPSILON as f64;

/// Otsu threshold of a 256-bin histogram of `total` cells, with OpenCV's operation order.
///
/// Returns 0 when every bin is skipped (e.g. a single grey level).
pub fn otsu(hist: &[u64; 256], total: u64) -> u8 {
    let scale = 1.0 / (total as f64);
    let mut mu = 0.0f64;
    for (i, &h) in hist.iter().enumerate() {
        mu += (i as f64) * (h as f64);
    }
    mu *= scale;
    let mut mu1 = 0.0f64;
    let mut q1 = 0.0f64;
    let mut max_sigma = 0.0f64;
    let mut max_val = 0u8;
    for (i, &h) in hist.iter().enumerate() {
        let p_i = (h as f64) * scale;
        mu1 *= q1;
        q1 += p_i;
        let q2 = 1.0 - q1;
        if q1.min(q2) < FLT_EPSILON || q1.max(q2) > 1.0 - FLT_EPSILON {
            continue;
        }
        mu1 = (mu1 + (i as f64) * p_i) / q1;
        let mu2 = (mu - q1 * mu1) / q2;
        let d = mu1 - mu2;
        let sigma = q1 * q2 * d * d;
        if sigma > max_sigma {
            max_sigma = sigma;
            max_val = i as u8;
        }
    }
    max_val
}

/// `T_u` for every `u` in 0..=255: the Otsu threshold of the map with its unknown cells set
/// to `u` (SPEC section 4 steps 1-2).
///
/// The 256 computations are run side by side (lane `u` holds the state of [`otsu`] for the
/// histogram with `unknown` added to bin `u`), so that the loop vectorises and the division
/// chains of different `u` overlap. Every lane performs exactly [`otsu`]'s operations in
/// its order, so the thresholds are the same bit for bit (tested against it).
pub fn threshold_table(hist: &Histogram) -> [u8; 256] {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: AVX2 is present
        return unsafe { threshold_table_avx2(hist) };
    }
    threshold_table_in(hist)
}

/// [`threshold_table`] compiled for AVX2: the same float operations in the same order, four
/// lanes a register instead of two (no FMA, so every result is the same bit for bit).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn threshold_table_avx2(hist: &Histogram) -> [u8; 256] {
    threshold_table_in(hist)
}

#[inline(always)]
fn threshold_table_in(hist: &Histogram) -> [u8; 256] {
    let total = hist.known_count() + hist.unknown;
    let scale = 1.0 / (total as f64);
    const N: usize = 256;
    // mu of every lane: sum of i * h_u[i] in order i = 0..255, then times scale
    let mut mu = [0.0f64; N];
    for (i, &h) in hist.known.iter().enumerate() {
        let (fi, hk) = (i as f64, h as f64);
        for (u, m) in mu.iter_mut().enumerate() {
            let hu = if u == i {
                (h + hist.unknown) as f64
            } else {
                hk
            };
            *m += fi * hu;
        }
    }
    for m in mu.iter_mut() {
        *m *= scale;
    }
    let mut mu1 = [0.0f64; N];
    let mut q1 = [0.0f64; N];
    let mut max_sigma = [0.0f64; N];
    let mut max_val = [0.0f64; N]; // f64 so that the lane loop is one vector type
    for (i, &h) in hist.known.iter().enumerate() {
        let fi = i as f64;
        let p_known = (h as f64) * scale;
        let p_here = ((h + hist.unknown) as f64) * scale;
        // every lane but i sees the known bin; lane i the bin with the unknown cells added
        let lanes = |lo: usize, hi: usize, p_i: f64, st: &mut OtsuLanes| {
            for ((((m1, q), ms), mv), &m) in st.mu1[lo..hi]
                .iter_mut()
                .zip(&mut st.q1[lo..hi])
                .zip(&mut st.max_sigma[lo..hi])
                .zip(&mut st.max_val[lo..hi])
                .zip(&st.mu[lo..hi])
            {
                otsu_step(m1, q, ms, mv, m, fi, p_i);
            }
        };
        let mut st = OtsuLanes {
            mu1: &mut mu1,
            q1: &mut q1,
            max_sigma: &mut max_sigma,
            max_val: &mut max_val,
            mu: &mu,
        };
        lanes(0, i, p_known, &mut st);
        lanes(i, i + 1, p_here, &mut st);
        lanes(i + 1, N, p_known, &mut st);
    }
    let mut out = [0u8; N];
    for (o, &v) in out.iter_mut().zip(&max_val) {
        *o = v as u8;
    }
    out
}

/// The per-lane state of [`threshold_table`].
struct OtsuLanes<'a> {
    mu1: &'a mut [f64; 256],
    q1: &'a mut [f64; 256],
    max_sigma: &'a mut [f64; 256],
    max_val: &'a mut [f64; 256],
    mu: &'a [f64; 256],
}

/// One bin of [`otsu`]'s loop for one lane, with its operations in its order (selects
/// instead of `continue`, so that lanes vectorise).
#[inline(always)]
fn otsu_step(
    mu1: &mut f64,
    q1: &mut f64,
    max_sigma: &mut f64,
    max_val: &mut f64,
    mu: f64,
    fi: f64,
    p_i: f64,
) {
    let m1 = *mu1 * *q1;
    let q = *q1 + p_i;
    *q1 = q;
    let q2 = 1.0 - q;
    let skip = q.min(q2) < FLT_EPSILON || q.max(q2) > 1.0 - FLT_EPSILON;
    let m1_new = (m1 + fi * p_i) / q;
    let mu2 = (mu - q * m1_new) / q2;
    let d = m1_new - mu2;
    let sigma = q * q2 * d * d;
    *mu1 = if skip { m1 } else { m1_new };
    let better = !skip && sigma > *max_sigma;
    *max_sigma = if better { sigma } else { *max_sigma };
    *max_val = if better { fi } else { *max_val };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_levels_split_between_them() {
        let mut h = [0u64; 256];
        h[10] = 50;
        h[200] = 50;
        assert_eq!(otsu(&h, 100), 10);
    }

    #[test]
    fn single_level_is_zero() {
        let mut h = [0u64; 256];
        h[77] = 9;
        assert_eq!(otsu(&h, 9), 0);
    }

    #[test]
    fn table_equals_one_otsu_per_unknown_value() {
        let mut state = 99u64;
        for trial in 0..60 {
            let mut known = [0u64; 256];
            let levels = 1 + trial % 40;
            for _ in 0..levels {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(7);
                let v = (state >> 40) as usize % 256;
                known[v] += 1 + (state >> 20) % 5000;
            }
            let unknown = if trial % 5 == 0 {
                0
            } else {
                (state >> 30) % 100_000
            };
            let hist = Histogram {
                known,
                unknown,
                unknown_values: [0; 256],
            };
            let total = hist.known_count() + unknown;
            let table = threshold_table(&hist);
            for u in 0..256 {
                let mut h = known;
                h[u] += unknown;
                assert_eq!(table[u], otsu(&h, total), "trial {trial} u {u}");
            }
        }
    }

    #[test]
    fn three_levels() {
        // a map_saver map: walls, a lot of unknown, free space
        let mut h = [0u64; 256];
        h[0] = 100;
        h[205] = 1000;
        h[254] = 400;
        let t = otsu(&h, 1500);
        assert!(t < 205, "walls split from the rest, got {t}");
    }
}
