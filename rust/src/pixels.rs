//! The loader's per-pixel pass over a map_saver image (python/slamq/sources/pixels.py,
//! `_map_saver_shades`; SPEC section 1): which of map_saver's grey levels an image holds,
//! whether it holds any other, and its unknown mask (`== 205`), in one pass.

/// The grey levels ROS map_saver writes: occupied, unknown, free (+ 255, also free).
pub const MAP_SAVER_SHADES: [u8; 4] = [0, 205, 254, 255];
/// map_saver's unknown shade.
pub const MAP_SAVER_UNKNOWN: u8 = 205;

/// Cells per block: the flags of a block are folded once, so the inner loop has no branch
/// and vectorises.
const BLOCK: usize = 256;

/// Which of [`MAP_SAVER_SHADES`] `grey` holds (in that order), or `None` when it holds any
/// other value; `unknown` (as long as `grey`) receives `grey[i] == 205` either way.
///
/// # Panics
/// When `unknown` and `grey` differ in length (a caller's bug, never user data).
pub fn map_saver_shades(grey: &[u8], unknown: &mut [bool]) -> Option<[bool; 4]> {
    assert_eq!(
        grey.len(),
        unknown.len(),
        "grey and unknown differ in length"
    );
    let mut seen = [false; 4];
    let mut other = false;
    for (g, u) in grey.chunks(BLOCK).zip(unknown.chunks_mut(BLOCK)) {
        // per block: bit k of `any` set when shade k occurs, bit 4 when another value does
        let mut any = 0u8;
        for (&v, out) in g.iter().zip(u.iter_mut()) {
            let bits = (v == 0) as u8
                | (((v == MAP_SAVER_UNKNOWN) as u8) << 1)
                | (((v == 254) as u8) << 2)
                | (((v == 255) as u8) << 3);
            *out = v == MAP_SAVER_UNKNOWN;
            any |= bits | (((bits == 0) as u8) << 4);
        }
        for (k, s) in seen.iter_mut().enumerate() {
            *s |= any & (1 << k) != 0;
        }
        other |= any & 0x10 != 0;
    }
    (!other).then_some(seen)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The definition, cell by cell.
    fn naive(grey: &[u8]) -> (Option<[bool; 4]>, Vec<bool>) {
        let unknown = grey.iter().map(|&v| v == MAP_SAVER_UNKNOWN).collect();
        if grey.iter().any(|v| !MAP_SAVER_SHADES.contains(v)) {
            return (None, unknown);
        }
        let seen = MAP_SAVER_SHADES.map(|s| grey.contains(&s));
        (Some(seen), unknown)
    }

    #[test]
    fn equals_the_definition_on_shade_mixes_and_lengths() {
        let mut x = 12345u64;
        let mut next = || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 33) as usize
        };
        for len in [0usize, 1, 7, 255, 256, 257, 1000, 4099] {
            for mix in 0..12 {
                let palette: Vec<u8> = match mix % 4 {
                    0 => vec![0, 205, 254],
                    1 => vec![205],
                    2 => vec![0, 205, 254, 255],
                    _ => vec![0, 254, 17],
                };
                let mut grey: Vec<u8> = (0..len).map(|_| palette[next() % palette.len()]).collect();
                if mix >= 8 && len > 0 {
                    let i = next() % len;
                    grey[i] = 100; // one stray value anywhere
                }
                let mut unknown = vec![true; len];
                let got = map_saver_shades(&grey, &mut unknown);
                let (want, want_unknown) = naive(&grey);
                assert_eq!(got, want, "len {len} mix {mix}");
                assert_eq!(unknown, want_unknown, "len {len} mix {mix}");
            }
        }
    }
}
