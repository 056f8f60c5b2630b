//! Reflect-101 border handling (OpenCV `BORDER_REFLECT_101`: `gfedcb|abcdefgh|gfedcba`).

/// Map a possibly out-of-range index `p` onto `0..len` the way OpenCV's
/// `borderInterpolate(p, len, BORDER_REFLECT_101)` does (a length-1 axis maps to 0).
///
/// `len` must be at least 1.
#[inline]
pub fn reflect101(p: isize, len: usize) -> usize {
    let n = len as isize;
    if n <= 1 {
        return 0;
    }
    let mut p = p;
    while p < 0 || p >= n {
        if p < 0 {
            p = -p;
        } else {
            p = 2 * (n - 1) - p;
        }
    }
    p as usize
}

#[cfg(test)]
mod tests {
    use super::reflect101;

    #[test]
    fn matches_opencv_pattern() {
        // gfedcb|abcdefgh|gfedcba for len 8
        let got: Vec<usize> = (-3..11).map(|p| reflect101(p, 8)).collect();
        assert_eq!(got, vec![3, 2, 1, 0, 1, 2, 3, 4, 5, 6, 7, 6, 5, 4]);
    }

    #[test]
    fn short_axes() {
        assert_eq!(reflect101(-2, 1), 0);
        assert_eq!(reflect101(5, 1), 0);
        // len 2: ... 0 1 0 1 | 0 1 | 0 1 0 ...
        assert_eq!(reflect101(-2, 2), 0);
        assert_eq!(reflect101(-1, 2), 1);
        assert_eq!(reflect101(2, 2), 0);
        assert_eq!(reflect101(3, 2), 1);
    }
}
