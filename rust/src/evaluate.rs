//! All three metrics of one map (SPEC sections 2-4, and 3a), and of many maps in parallel.

use crate::canonical::{canonical_corners_in, WallSums};
use crate::corners::count_corners;
use crate::enclosed::sweep;
use crate::grid::{known_bounds, Bounds, Grid};
use crate::memory::{reserve_working_set, OutOfMemory};
use crate::params::Params;
use crate::proportion::{occupancy, Occupancy};
use rayon::prelude::*;

/// The integers of one evaluation; ratios are formed by the caller from these.
#[derive(Clone, Debug)]
pub struct Quality {
    pub occupancy: Occupancy,
    pub corners: usize,
    /// SPEC 3a: the dominant wall angle (radians; always computed) and `corners_canonical`
    /// (`None` when skipped, the default, or too large).
    pub wall_angle: f64,
    /// SPEC 3a.2: the wall-direction sums the angle comes from (fourth and sixth harmonic,
    /// weight), always computed.
    pub wall_sums: WallSums,
    pub corners_canonical: Option<usize>,
    /// `count_u` for every swept `u`.
    pub curve: Vec<usize>,
    /// What the map's numbers depend on besides the place (the comparability checks): the
    /// number of distinct values among the known cells, the commonest value (or shade,
    /// [`Grid::histogram_with`]) of the unknown cells (the smallest of equals; `None`
    /// without unknown cells), and the known cells' bounding box `(r0, r1, c0, c1)`.
    pub known_levels: usize,
    pub unknown_shade: Option<u8>,
    pub known_box: Option<Bounds>,
}

// NaN never equals itself; two results are equal when their angles are bit-identical.
impl PartialEq for Quality {
    fn eq(&self, other: &Self) -> bool {
        self.occupancy == other.occupancy
            && self.corners == other.corners
            && self.wall_angle.to_bits() == other.wall_angle.to_bits()
            && self.wall_sums == other.wall_sums
            && self.corners_canonical == other.corners_canonical
            && self.curve == other.curve
            && (self.known_levels, self.unknown_shade, self.known_box)
                == (other.known_levels, other.unknown_shade, other.known_box)
    }
}

impl Eq for Quality {}

/// Evaluate one map of `resolution` metres per cell (`None`: not known), or say that its
/// working memory cannot be had. `shade`: the array whose values give the unknown cells'
/// shade (`Quality::unknown_shade`; the loader's pixels), `None`: the map's values.
pub fn evaluate(
    grid: &Grid,
    resolution: Option<f64>,
    params: &Params,
    shade: Option<&[u8]>,
) -> Result<Quality, OutOfMemory> {
    reserve_working_set(grid.height * grid.width)?;
    let hist = grid.histogram_with(shade);
    let occupancy = occupancy(&hist);
    let corners = count_corners(grid, &params.corners);
    let curve = sweep(grid, &hist, &params.enclosed);
    let known_box = known_bounds(grid);
    // the wall angle always (the verdict needs every map's orientation), the canonical count
    // only with a reference resolution
    let canonical = canonical_corners_in(grid, known_box, resolution, &params.corners)?;
    // the first of equal counts, as numpy's argmax
    let unknown_shade = (hist.unknown > 0).then(|| {
        let top = hist.unknown_values.iter().copied().max().unwrap_or(0);
        hist.unknown_values
            .iter()
            .position(|&c| c == top)
            .unwrap_or(0) as u8
    });
    Ok(Quality {
        occupancy,
        corners,
        wall_angle: canonical.angle,
        wall_sums: canonical.sums,
        corners_canonical: canonical.corners,
        curve,
        known_levels: hist.known.iter().filter(|&&c| c > 0).count(),
        unknown_shade,
        known_box,
    })
}

/// Evaluate many maps in parallel (each map's own passes are parallel too); results in order.
pub fn evaluate_many(
    grids: &[(Grid, Option<f64>)],
    params: &Params,
) -> Vec<Result<Quality, OutOfMemory>> {
    grids
        .par_iter()
        .map(|(g, res)| evaluate(g, *res, params, None))
        .collect()
}
