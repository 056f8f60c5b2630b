//! All three metrics of one map (SPEC sections 2-4), and of many maps in parallel.

use crate::corners::count_corners;
use crate::enclosed::sweep;
use crate::grid::Grid;
use crate::params::Params;
use crate::proportion::{occupancy, Occupancy};
use rayon::prelude::*;

/// The integers of one evaluation; ratios are formed by the caller from these.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Quality {
    pub occupancy: Occupancy,
    pub corners: usize,
    /// `count_u` for every swept `u`.
    pub curve: Vec<usize>,
}

/// Evaluate one map.
pub fn evaluate(grid: &Grid, params: &Params) -> Quality {
    let hist = grid.histogram();
    let occupancy = occupancy(&hist);
    let corners = count_corners(grid, &params.corners);
    let curve = sweep(grid, &hist, &params.enclosed);
    Quality {
        occupancy,
        corners,
        curve,
    }
}

/// Evaluate many maps in parallel (each map's own passes are parallel too); results in order.
pub fn evaluate_many(grids: &[Grid], params: &Params) -> Vec<Quality> {
    grids.par_iter().map(|g| evaluate(g, params)).collect()
}
