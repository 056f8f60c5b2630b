//! SPEC section 3a: the canonical corner count. The map's known bounding box is turned to
//! its dominant wall direction and resampled to a reference resolution, and the SPEC-3
//! corners of that canonical map are counted. The reference function is
//! `slamq.metrics.reference.canonical_corner_count`; every step below is integer
//! arithmetic or one float64 formula evaluated in the same order on both sides.
//!
//! The wall angle reads the grid a few rows at a time (`angle_of_box`: neither the
//! structure image nor its blur is ever whole in memory); the resample reads the box packed
//! one `u16` per cell (`pack_box`). The resample has a fast path for up to 4 x 4 samples per
//! output cell (one gather per sample, addresses in float arithmetic that vectorises) beside
//! the general one; output tiles (32 x 32, and 8 x 8 inside them on the fast path) whose
//! samples all fall on unknown 8 x 8 blocks of the box are left unknown, and those whose
//! samples all fall on known blocks of one value take that value, without sampling. The
//! wall angle's tasks (blur, Sobel and the `g^4/|g|^3`, `g^6/|g|^5` and `|g|` terms) and the fast resample run as AVX2
//! copies of themselves when the processor has it (runtime detection; the same operations,
//! so the same results). The tests compare every path with each other and the resample with
//! a literal one.
//!
//! Parts: `pack` (the packed box, and what both steps share), `angle` (the wall angle),
//! `resample` (the canonical map).

use crate::corners::count_corners_of_structure;
use crate::grid::{known_bounds, Bounds, Grid};
use crate::memory::{reserve_working_set, OutOfMemory};
use crate::params::CornerParams;
use angle::angle_of_box;
pub use angle::{wall_angle, wall_angle_in, wall_sums_in, WallSums};
use pack::pack_box;
pub use resample::MAX_CANONICAL_CELLS;
use resample::{resample, Path};

mod angle;
mod pack;
mod resample;
#[cfg(test)]
mod tests;

/// A canonical map: owned values and unknown mask.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CanonicalMap {
    pub values: Vec<u8>,
    pub unknown: Vec<bool>,
    pub height: usize,
    pub width: usize,
}

/// What the canonical step found: the wall angle (from `sums`, [`WallSums::angle`]), the
/// wall-direction sums, and the corner count of the canonical map (`None` when it would
/// exceed [`MAX_CANONICAL_CELLS`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Canonical {
    pub angle: f64,
    pub sums: WallSums,
    pub corners: Option<usize>,
}

/// The map turned by `-angle` about its known box's centre cell and sampled every
/// `reference / resolution` input cells (SPEC 3a.3); `None` if it would be too large.
pub fn canonical_map(
    grid: &Grid,
    angle: f64,
    resolution: Option<f64>,
    reference: f64,
) -> Result<Option<CanonicalMap>, OutOfMemory> {
    match known_bounds(grid) {
        Some(b) => map_in(grid, &pack_box(grid, b)?, b, angle, resolution, reference),
        None => Ok(Some(CanonicalMap {
            values: grid.values.to_vec(),
            unknown: grid.unknown.to_vec(),
            height: grid.height,
            width: grid.width,
        })),
    }
}

/// [`canonical_map`] of the box `b` (the known cells' bounding box), `packed` its cells
/// ([`pack_box`]).
fn map_in(
    grid: &Grid,
    packed: &[u16],
    b: Bounds,
    angle: f64,
    resolution: Option<f64>,
    reference: f64,
) -> Result<Option<CanonicalMap>, OutOfMemory> {
    map_in_with(grid, packed, b, angle, resolution, reference, Path::Best)
}

/// [`map_in`] by the resampling `path`.
fn map_in_with(
    grid: &Grid,
    packed: &[u16],
    b: Bounds,
    angle: f64,
    resolution: Option<f64>,
    reference: f64,
    path: Path,
) -> Result<Option<CanonicalMap>, OutOfMemory> {
    let r = resample(grid, packed, b, angle, resolution, reference, path, true)?;
    Ok(r.map(|r| CanonicalMap {
        values: r.values,
        unknown: r.unknown,
        height: r.height,
        width: r.width,
    }))
}

/// SPEC 3a: the wall angle and `corners_canonical` of a map of `resolution` metres per cell
/// (`None`: unknown, taken as the reference resolution).
pub fn canonical_corners(
    grid: &Grid,
    resolution: Option<f64>,
    params: &CornerParams,
) -> Result<Canonical, OutOfMemory> {
    canonical_corners_in(grid, known_bounds(grid), resolution, params)
}

/// [`canonical_corners`] (the wall angle alone, `corners` None, when
/// `params.canonical_resolution` is 0) with the known cells' bounding box already found
/// ([`known_bounds`]).
pub fn canonical_corners_in(
    grid: &Grid,
    bounds: Option<Bounds>,
    resolution: Option<f64>,
    params: &CornerParams,
) -> Result<Canonical, OutOfMemory> {
    if params.canonical_resolution.is_nan() || params.canonical_resolution <= 0.0 {
        // no reference resolution: the wall angle alone, as `evaluate` gives it
        let sums = wall_sums_in(grid, bounds)?;
        return Ok(Canonical {
            angle: sums.angle(),
            sums,
            corners: None,
        });
    }
    // both steps work inside the box
    let Some(b) = bounds else {
        return Ok(Canonical {
            angle: 0.0,
            sums: WallSums::default(),
            corners: Some(0),
        });
    };
    let sums = angle_of_box(grid, b);
    let angle = sums.angle();
    let packed = pack_box(grid, b)?;
    // the structure image of the canonical map is all the corners need (no unknown mask)
    let map = resample(
        grid,
        &packed,
        b,
        angle,
        resolution,
        params.canonical_resolution,
        Path::Best,
        false,
    )?;
    drop(packed);
    let Some(map) = map else {
        return Ok(Canonical {
            angle,
            sums,
            corners: None,
        });
    };
    reserve_working_set(map.height * map.width)?;
    let corners = count_corners_of_structure(&map.values, map.height, map.width, params);
    Ok(Canonical {
        angle,
        sums,
        corners: Some(corners),
    })
}
