//! Occupied proportion (SPEC section 2, paper III.A).
//!
//! A known cell with darkness `d = 255 - v` is occupied iff `d * n > sum(d)` over the `n`
//! known cells (exact integers: `p > mean p`, ties free). Since `d` is an integer this is
//! `d > floor(sum / n)`, so the value histogram is all that is needed.

use crate::grid::Histogram;

/// The integers of SPEC section 2; ratios are formed by the caller.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Occupancy {
    /// Number of known cells, `n`.
    pub known: u64,
    /// Known cells darker than the mean darkness.
    pub occupied: u64,
    /// Sum of the darkness `255 - v` over known cells.
    pub sum_darkness: u64,
}

/// Occupancy counts from the known-value histogram.
pub fn occupancy(hist: &Histogram) -> Occupancy {
    let known = hist.known_count();
    let sum_darkness: u64 = hist
        .known
        .iter()
        .enumerate()
        .map(|(v, &c)| (255 - v as u64) * c)
        .sum();
    if known == 0 {
        return Occupancy {
            known,
            occupied: 0,
            sum_darkness,
        };
    }
    let floor_mean = sum_darkness / known;
    // d > floor_mean  <=>  v < 255 - floor_mean
    let occupied = hist
        .known
        .iter()
        .enumerate()
        .filter(|(v, _)| 255 - (*v as u64) > floor_mean)
        .map(|(_, &c)| c)
        .sum();
    Occupancy {
        known,
        occupied,
        sum_darkness,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hist(pairs: &[(usize, u64)], unknown: u64) -> Histogram {
        let mut known = [0u64; 256];
        for &(v, c) in pairs {
            known[v] = c;
        }
        Histogram {
            known,
            unknown,
            unknown_values: [0; 256],
        }
    }

    #[test]
    fn walls_in_free_space() {
        let o = occupancy(&hist(&[(0, 10), (254, 90)], 500));
        assert_eq!(
            o,
            Occupancy {
                known: 100,
                occupied: 10,
                sum_darkness: 10 * 255 + 90
            }
        );
    }

    #[test]
    fn ties_are_free() {
        // all cells equal: d * n == sum for each, so none is occupied
        let o = occupancy(&hist(&[(100, 7)], 0));
        assert_eq!(o.occupied, 0);
    }

    #[test]
    fn matches_the_definition() {
        let pairs = [(0usize, 3u64), (17, 5), (128, 11), (129, 2), (254, 40)];
        let h = hist(&pairs, 3);
        let o = occupancy(&h);
        let n: u64 = pairs.iter().map(|p| p.1).sum();
        let s: u64 = pairs.iter().map(|p| (255 - p.0 as u64) * p.1).sum();
        let occ: u64 = pairs
            .iter()
            .filter(|p| (255 - p.0 as u64) * n > s)
            .map(|p| p.1)
            .sum();
        assert_eq!(o.occupied, occ);
    }

    #[test]
    fn nothing_known() {
        let o = occupancy(&hist(&[], 12));
        assert_eq!((o.known, o.occupied), (0, 0));
    }
}
