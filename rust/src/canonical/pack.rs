//! The known box of a map packed one `u16` per cell, which the wall angle and the resample
//! read, and what both share (fallible buffers, the processor's AVX2).

use crate::grid::{Bounds, Grid};
use crate::memory::OutOfMemory;
use rayon::prelude::*;

/// A `Vec` of `n` copies of `x`, or `OutOfMemory`.
pub(super) fn filled<T: Clone>(n: usize, x: T) -> Result<Vec<T>, OutOfMemory> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| OutOfMemory {
        bytes: n.saturating_mul(std::mem::size_of::<T>()),
    })?;
    v.resize(n, x);
    Ok(v)
}

/// Whether the processor has AVX2 (cached by std after the first call): the hot loops of
/// this module then run as AVX2 copies of themselves, the same operations on wider
/// registers (the same results; no FMA).
#[cfg(target_arch = "x86_64")]
#[inline]
pub(super) fn has_avx2() -> bool {
    std::arch::is_x86_feature_detected!("avx2")
}

/// A known cell of the packed box ([`pack_box`]) has this bit set, on top of its value.
pub(super) const KNOWN: u16 = 1 << 12;

/// The value bits of a packed cell (its value when known, 0 when unknown).
pub(super) const VALUE: u16 = KNOWN - 1;

/// The box's cells packed one `u16` each, row-major with the box's width as stride (then
/// zeros up to a power-of-two length): the value plus [`KNOWN`] for a known cell, 0 for an
/// unknown one. `p & VALUE` is the
/// structure image (SPEC 3 step 1); the sum of up to 16 packed cells is `sum + 4096 k`
/// (`k` the number of known ones), which is what a resampled cell needs.
pub(super) fn pack_box(grid: &Grid, (r0, r1, c0, c1): Bounds) -> Result<Vec<u16>, OutOfMemory> {
    let (h, w) = (r1 - r0, c1 - c0);
    const ROWS: usize = 64; // per parallel task
                            // zero-padded to a power of two: the resample's gathers mask their indices instead of
                            // checking them
    let n = (h * w).next_power_of_two();
    let mut out: Vec<u16> = Vec::new();
    out.try_reserve_exact(n)
        .map_err(|_| OutOfMemory { bytes: 2 * n })?;
    // every cell written once (no zero fill first)
    let spare = &mut out.spare_capacity_mut()[..n];
    let (cells, padding) = spare.split_at_mut(h * w);
    cells
        .par_chunks_mut(w * ROWS)
        .enumerate()
        .for_each(|(t, block)| {
            for (i, o) in block.chunks_mut(w).enumerate() {
                let at = (r0 + t * ROWS + i) * grid.width + c0;
                let (v, u) = (&grid.values[at..at + w], &grid.unknown[at..at + w]);
                for ((o, &v), &u) in o.iter_mut().zip(v).zip(u) {
                    o.write((u16::from(v) | KNOWN) * u16::from(!u));
                }
            }
        });
    for p in padding {
        p.write(0);
    }
    // SAFETY: the first n elements were all written just above
    unsafe { out.set_len(n) };
    Ok(out)
}
