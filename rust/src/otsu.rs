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
pub fn threshold_table(hist: &Histogram) -> [u8; 256] {
    let total = hist.known_count() + hist.unknown;
    let mut out = [0u8; 256];
    let mut h = hist.known;
    for (u, t) in out.iter_mut().enumerate() {
        h[u] += hist.unknown;
        *t = otsu(&h, total);
        h[u] -= hist.unknown;
    }
    out
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
