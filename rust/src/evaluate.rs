//! All three metrics of one map (SPEC sections 2-4, and 3a), and of many maps in parallel.

use crate::canonical::canonical_corners;
use crate::corners::count_corners;
use crate::enclosed::sweep;
use crate::grid::Grid;
use crate::params::Params;
use crate::proportion::{occupancy, Occupancy};
use rayon::prelude::*;

/// The integers of one evaluation; ratios are formed by the caller from these.
#[derive(Clone, Debug)]
pub struct Quality {
    pub occupancy: Occupancy,
    pub corners: usize,
    /// SPEC 3a: the dominant wall angle (radians, NaN when skipped) and `corners_canonical`
    /// (`None` when skipped or too large).
    pub wall_angle: f64,
    pub corners_canonical: Option<usize>,
    /// `count_u` for every swept `u`.
    pub curve: Vec<usize>,
}

// NaN never equals itself; two results are equal when their angles are bit-identical.
impl PartialEq for Quality {
    fn eq(&self, other: &Self) -> bool {
        self.occupancy == other.occupancy
            && self.corners == other.corners
            && self.wall_angle.to_bits() == other.wall_angle.to_bits()
            && self.corners_canonical == other.corners_canonical
            && self.curve == other.curve
    }
}

impl Eq for Quality {}

/// Bytes of working memory per cell that one evaluation may hold at its peak: the sweep's
/// forest (4) and value order (4), or the corner step's mask (1), and the runs of a
/// binarisation with their union-find arrays (up to about 8 for a checkerboard), rounded up.
pub const WORK_BYTES_PER_CELL: usize = 16;

/// The working memory of an evaluation could not be reserved (a memory limit, e.g.
/// `ulimit -v`, or a map too large for this machine).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OutOfMemory {
    /// The bytes asked for.
    pub bytes: usize,
}

impl std::fmt::Display for OutOfMemory {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "cannot reserve {} MiB of working memory for the evaluation",
            self.bytes.div_ceil(1 << 20)
        )
    }
}

/// Check, before any big buffer is allocated, that the peak working memory of evaluating a
/// map of `cells` cells can be had: reserve it fallibly (address space only, never touched)
/// and free it. An infallible allocation failing later would abort the whole process
/// (`handle_alloc_error`); this turns the common case, a memory limit, into an error.
pub fn reserve_working_set(cells: usize) -> Result<(), OutOfMemory> {
    let bytes = cells.saturating_mul(WORK_BYTES_PER_CELL);
    let mut probe: Vec<u8> = Vec::new();
    probe
        .try_reserve_exact(bytes)
        .map_err(|_| OutOfMemory { bytes })
}

/// Evaluate one map of `resolution` metres per cell (`None`: not known), or say that its
/// working memory cannot be had.
pub fn evaluate(
    grid: &Grid,
    resolution: Option<f64>,
    params: &Params,
) -> Result<Quality, OutOfMemory> {
    reserve_working_set(grid.height * grid.width)?;
    let hist = grid.histogram();
    let occupancy = occupancy(&hist);
    let corners = count_corners(grid, &params.corners);
    let curve = sweep(grid, &hist, &params.enclosed);
    let (wall_angle, corners_canonical) = if params.corners.canonical_resolution > 0.0 {
        let c = canonical_corners(grid, resolution, &params.corners)?;
        (c.angle, c.corners)
    } else {
        (f64::NAN, None)
    };
    Ok(Quality {
        occupancy,
        corners,
        wall_angle,
        corners_canonical,
        curve,
    })
}

/// Evaluate many maps in parallel (each map's own passes are parallel too); results in order.
pub fn evaluate_many(
    grids: &[(Grid, Option<f64>)],
    params: &Params,
) -> Vec<Result<Quality, OutOfMemory>> {
    grids
        .par_iter()
        .map(|(g, res)| evaluate(g, *res, params))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_working_set_that_cannot_exist_is_an_error_not_an_abort() {
        assert!(reserve_working_set(1 << 20).is_ok());
        let err = reserve_working_set(usize::MAX / 2).unwrap_err();
        assert_eq!(err.bytes, usize::MAX);
        assert!(err.to_string().contains("MiB of working memory"));
    }
}
