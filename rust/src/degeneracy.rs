//! Scans that see walls in one direction only (SPEC section 7c). For each scan, the
//! endpoints that lie on a straight stretch of wall give the stretch's normal; the scan's
//! information is the sum of `n n^T` over them, and its *ratio* the smaller over the larger
//! eigenvalue of that sum: near 0 when every stretch faces one way (a corridor's two
//! sides: a pose error along them is invisible to the scan), near 1 when they face every
//! way.
//!
//! An endpoint (beam `i`, valid when finite and `min_range < r < 0.99 max_range`, at
//! `(r cos a, r sin a)` in the laser frame, beams in angle order) has the *near* endpoints
//! among beams `i - NEIGHBOURS ..= i + NEIGHBOURS` (itself included) closer than
//! [`NEAR_M`]; it is on a straight stretch when at least `2 NEIGHBOURS` are near and the
//! smaller eigenvalue of their scatter is under [`LINE_SPREAD`] times the larger. Its
//! normal is perpendicular to the scatter's principal axis. A scan with fewer than
//! [`MIN_LINE_POINTS`] such endpoints has no ratio (NaN).
//!
//! Each scan is computed alone (in parallel, chunks of a fixed size), so the result is the
//! same for any number of threads. `python/slamq/metrics/degeneracy.py`'s
//! `scan_ratios_reference` is this module's numpy twin (the same operations; the sums of
//! the normals over a scan may differ in the last bits, numpy summing pairwise).

use rayon::prelude::*;
use std::fmt;

/// Beams on each side of an endpoint whose endpoints may share its stretch.
pub const NEIGHBOURS: usize = 3;
/// Metres: a neighbour's endpoint farther than this is not on the endpoint's stretch.
pub const NEAR_M: f64 = 0.9;
/// A stretch is straight when the variance across it is under this share of the variance
/// along it.
pub const LINE_SPREAD: f64 = 0.05;
/// Endpoints on straight stretches a scan needs for a ratio.
pub const MIN_LINE_POINTS: usize = 10;
/// Scans per unit of parallel work.
const CHUNK: usize = 16;

/// Why the ratios could not be computed.
#[derive(Debug, Clone, PartialEq)]
pub struct DegeneracyError(pub String);

impl fmt::Display for DegeneracyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for DegeneracyError {}

/// The larger and smaller eigenvalues of the symmetric matrix `[[a, c], [c, b]]`:
/// `h +- hypot((a - b) / 2, c)`, which does not cancel when the two are nearly equal (the
/// form `sqrt(h^2 - (ab - c^2))` turned a last-bit difference in the sums into 1e-9 in a
/// ratio near 1).
fn eig(a: f64, b: f64, c: f64) -> (f64, f64) {
    let half = (a + b) / 2.0;
    let disc = ((a - b) / 2.0).hypot(c);
    (half + disc, half - disc)
}

/// The ratio of one scan: `x`, `y` its endpoints (NaN: invalid beam), in angle order.
fn ratio(x: &[f64], y: &[f64]) -> f64 {
    let b = x.len();
    let w = 2 * NEIGHBOURS + 1;
    let (mut jxx, mut jyy, mut jxy) = (0.0f64, 0.0f64, 0.0f64);
    let mut lines = 0usize;
    for i in 0..b {
        if x[i].is_nan() {
            continue;
        }
        // the near endpoints of the window i - NEIGHBOURS ..= i + NEIGHBOURS (beams off
        // either end absent), in beam order
        let mut near = [(0.0f64, 0.0f64); 2 * NEIGHBOURS + 1];
        let mut count = 0usize;
        for j in i.saturating_sub(NEIGHBOURS)..(i + NEIGHBOURS + 1).min(b) {
            if (x[j] - x[i]).hypot(y[j] - y[i]) < NEAR_M {
                near[count] = (x[j], y[j]);
                count += 1;
            }
        }
        let near = &near[..count];
        let (mut sx, mut sy) = (0.0f64, 0.0f64);
        for &(px, py) in near {
            sx += px;
            sy += py;
        }
        let c = count.max(1) as f64;
        let (mx, my) = (sx / c, sy / c);
        let (mut sxx, mut syy, mut sxy) = (0.0f64, 0.0f64, 0.0f64);
        for &(px, py) in near {
            let (dx, dy) = (px - mx, py - my);
            sxx += dx * dx;
            syy += dy * dy;
            sxy += dx * dy;
        }
        let (along, across) = eig(sxx, syy, sxy);
        if count + 1 < w || across >= LINE_SPREAD * along.max(1e-12) {
            continue;
        }
        let normal = 0.5 * (2.0 * sxy).atan2(sxx - syy) + std::f64::consts::FRAC_PI_2;
        let (ns, nc) = normal.sin_cos();
        jxx += nc * nc;
        jyy += ns * ns;
        jxy += nc * ns;
        lines += 1;
    }
    if lines < MIN_LINE_POINTS {
        return f64::NAN;
    }
    let (big, small) = eig(jxx, jyy, jxy);
    small / big.max(1e-12)
}

/// The ratio of every scan of `ranges` (`n x b`, row-major, metres) with beams at `angles`
/// (`b`, radians, any order: sorted here), valid when finite and
/// `min_range < r < 0.99 max_range`.
///
/// # Errors
/// `ranges` is not `n x b` for some `n`, or the ranges' bounds are not
/// `0 <= min_range < max_range`, or an angle is not finite.
pub fn scan_ratios(
    angles: &[f64],
    ranges: &[f64],
    min_range: f64,
    max_range: f64,
) -> Result<Vec<f64>, DegeneracyError> {
    let b = angles.len();
    if b == 0 || ranges.len() % b != 0 {
        return Err(DegeneracyError(format!(
            "ranges hold {} values, not a whole number of scans of {b} beams",
            ranges.len()
        )));
    }
    if !(min_range >= 0.0 && max_range > min_range) {
        return Err(DegeneracyError(format!(
            "need 0 <= min_range < max_range, got {min_range}, {max_range}"
        )));
    }
    if angles.iter().any(|a| !a.is_finite()) {
        return Err(DegeneracyError("angles must be finite".into()));
    }
    let mut order: Vec<usize> = (0..b).collect();
    order.sort_by(|&p, &q| angles[p].total_cmp(&angles[q]));
    let (cos, sin): (Vec<f64>, Vec<f64>) = order
        .iter()
        .map(|&k| angles[k].cos())
        .zip(order.iter().map(|&k| angles[k].sin()))
        .unzip();
    let far = 0.99 * max_range;
    let n = ranges.len() / b;
    let mut out = vec![f64::NAN; n];
    out.par_chunks_mut(CHUNK)
        .enumerate()
        .for_each(|(chunk, dst)| {
            let (mut x, mut y) = (vec![0.0f64; b], vec![0.0f64; b]);
            for (k, slot) in dst.iter_mut().enumerate() {
                let row = &ranges[(chunk * CHUNK + k) * b..(chunk * CHUNK + k + 1) * b];
                for (p, &beam) in order.iter().enumerate() {
                    let r = row[beam];
                    let ok = r.is_finite() && r > min_range && r < far;
                    x[p] = if ok { r * cos[p] } else { f64::NAN };
                    y[p] = if ok { r * sin[p] } else { f64::NAN };
                }
                *slot = ratio(&x, &y);
            }
        });
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn circle(b: usize) -> Vec<f64> {
        (0..b)
            .map(|k| -PI + 2.0 * PI * k as f64 / b as f64)
            .collect()
    }

    #[test]
    fn corridor_is_one_direction_room_is_two() {
        let a = circle(360);
        let corridor: Vec<f64> = a
            .iter()
            .map(|t| (1.0 / t.sin().abs().max(1e-9)).min(50.0))
            .collect();
        let room: Vec<f64> = a
            .iter()
            .map(|t| (2.0 / t.cos().abs().max(1e-9)).min(2.0 / t.sin().abs().max(1e-9)))
            .collect();
        let r = scan_ratios(&a, &[corridor, room].concat(), 0.0, 60.0).unwrap();
        assert!(r[0] < 1e-6, "corridor ratio {}", r[0]);
        assert!(r[1] > 0.9, "room ratio {}", r[1]);
    }

    #[test]
    fn too_few_endpoints_give_nan_and_bad_input_an_error() {
        let a = circle(8);
        let r = scan_ratios(&a, &[1.0; 8], 0.0, 10.0).unwrap();
        assert!(r[0].is_nan());
        assert!(scan_ratios(&a, &[1.0; 7], 0.0, 10.0).is_err());
        assert!(scan_ratios(&a, &[1.0; 8], 5.0, 1.0).is_err());
        assert!(scan_ratios(&[f64::NAN], &[1.0], 0.0, 10.0).is_err());
    }

    #[test]
    fn same_for_any_thread_count() {
        let a = circle(181);
        let ranges: Vec<f64> = (0..181 * 40)
            .map(|k| 1.0 + ((k * 7919) % 97) as f64 / 50.0)
            .collect();
        let run = |t: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap()
                .install(|| scan_ratios(&a, &ranges, 0.0, 30.0).unwrap())
        };
        let (one, four) = (run(1), run(4));
        assert_eq!(
            one.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            four.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
    }
}
