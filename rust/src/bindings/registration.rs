//! Binding of the global registration of maps of one place (rust/src/register.rs, SPEC
//! section 7a): `register`, `register_many` and the `RawRegistration` they return.

use super::comparison::{error, frame};
use super::grid;
use super::runtime::compute;
use crate::register::{
    register as register_maps, register_many as register_all, RegisterParams, Registration,
};
use crate::se2::Placed;
use numpy::PyReadonlyArray2;
use pyo3::prelude::*;

/// One registration (SPEC section 7a): the motion `(theta, tx, ty)` (radians, metres) taking
/// the moving map's world frame onto the fixed map's, and how far to trust it.
/// `slamq.Registration` is built from it.
#[pyclass(frozen, get_all, eq, module = "slamq._core")]
#[derive(PartialEq)]
pub(crate) struct RawRegistration {
    ok: bool,
    reason: String,
    theta: f64,
    tx: f64,
    ty: f64,
    inliers: f64,
    inliers_moving: f64,
    inliers_fixed: f64,
    overlap: f64,
    overlap_moving: f64,
    overlap_fixed: f64,
    score: f64,
    runner_up_score: f64,
    /// The best distinct runner-up's motion, when there is one.
    runner_up: Option<(f64, f64, f64)>,
    margin: f64,
    confidence: f64,
    icp_rms: f64,
    icp_iterations: usize,
    rotations: usize,
    candidates: usize,
    tolerance: f64,
}

impl From<&Registration> for RawRegistration {
    fn from(r: &Registration) -> Self {
        RawRegistration {
            ok: r.ok,
            reason: r.reason.clone(),
            theta: r.transform.theta,
            tx: r.transform.tx,
            ty: r.transform.ty,
            inliers: r.inliers,
            inliers_moving: r.inliers_moving,
            inliers_fixed: r.inliers_fixed,
            overlap: r.overlap,
            overlap_moving: r.overlap_moving,
            overlap_fixed: r.overlap_fixed,
            score: r.score,
            runner_up_score: r.runner_up_score,
            runner_up: r.runner_up.map(|t| (t.theta, t.tx, t.ty)),
            margin: r.margin,
            confidence: r.confidence,
            icp_rms: r.icp_rms,
            icp_iterations: r.icp_iterations,
            rotations: r.rotations,
            candidates: r.candidates,
            tolerance: r.tolerance,
        }
    }
}

#[pymethods]
impl RawRegistration {
    fn __repr__(&self) -> String {
        format!(
            "RawRegistration(ok={}, theta={}, tx={}, ty={}, inliers={}, margin={}, \
             confidence={})",
            self.ok, self.theta, self.tx, self.ty, self.inliers, self.margin, self.confidence
        )
    }
}

#[allow(clippy::too_many_arguments)]
fn params(
    occupied_threshold: f64,
    tolerance: Option<f64>,
    min_inliers: f64,
    min_overlap: f64,
    min_margin: f64,
) -> RegisterParams {
    RegisterParams {
        occupied_threshold,
        tolerance,
        min_inliers,
        min_overlap,
        min_margin,
        ..RegisterParams::default()
    }
}

/// register(moving_values, moving_unknown, moving_frame, fixed_values, fixed_unknown,
/// fixed_frame, occupied_threshold=0.5, tolerance=None, min_inliers=0.6, min_overlap=0.1,
/// min_margin=0.05, threads=0) -> RawRegistration
///
/// Register the moving map onto the fixed one (SPEC section 7a). Frames are `(resolution,
/// x, y, yaw)`; `tolerance` is in metres (None: the larger of 0.2 m and two cells of the coarser map).
#[pyfunction]
#[pyo3(signature = (moving_values, moving_unknown, moving_frame, fixed_values, fixed_unknown,
                    fixed_frame, occupied_threshold=0.5, tolerance=None, min_inliers=0.6,
                    min_overlap=0.1, min_margin=0.05, threads=0))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn register<'py>(
    py: Python<'py>,
    moving_values: PyReadonlyArray2<'py, u8>,
    moving_unknown: PyReadonlyArray2<'py, bool>,
    moving_frame: (f64, f64, f64, f64),
    fixed_values: PyReadonlyArray2<'py, u8>,
    fixed_unknown: PyReadonlyArray2<'py, bool>,
    fixed_frame: (f64, f64, f64, f64),
    occupied_threshold: f64,
    tolerance: Option<f64>,
    min_inliers: f64,
    min_overlap: f64,
    min_margin: f64,
    threads: usize,
) -> PyResult<RawRegistration> {
    let mg = grid(&moving_values, &moving_unknown)?;
    let fg = grid(&fixed_values, &fixed_unknown)?;
    let moving = Placed {
        grid: mg,
        frame: frame("moving", moving_frame, mg.height, mg.width)?,
    };
    let fixed = Placed {
        grid: fg,
        frame: frame("fixed", fixed_frame, fg.height, fg.width)?,
    };
    let p = params(
        occupied_threshold,
        tolerance,
        min_inliers,
        min_overlap,
        min_margin,
    );
    let r = compute(py, threads, || register_maps(&moving, &fixed, &p))?.map_err(error)?;
    Ok(RawRegistration::from(&r))
}

/// A map for `register_many`: values, unknown mask, frame `(resolution, x, y, yaw)`.
type MapArgs<'py> = (
    PyReadonlyArray2<'py, u8>,
    PyReadonlyArray2<'py, bool>,
    (f64, f64, f64, f64),
);

/// register_many(maps, occupied_threshold=0.5, tolerance=None, min_inliers=0.6,
/// min_overlap=0.1, min_margin=0.05, threads=0) -> list[((int, int), RawRegistration)]
///
/// Every pair of `maps` (each `(values, unknown, frame)`): map `j` registered onto map `i`
/// for `i < j`, in the order `(0, 1), (0, 2), ..., (1, 2), ...`; each map prepared once.
#[pyfunction]
#[pyo3(signature = (maps, occupied_threshold=0.5, tolerance=None, min_inliers=0.6,
                    min_overlap=0.1, min_margin=0.05, threads=0))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn register_many<'py>(
    py: Python<'py>,
    maps: Vec<MapArgs<'py>>,
    occupied_threshold: f64,
    tolerance: Option<f64>,
    min_inliers: f64,
    min_overlap: f64,
    min_margin: f64,
    threads: usize,
) -> PyResult<Vec<((usize, usize), RawRegistration)>> {
    let mut placed = Vec::with_capacity(maps.len());
    for (k, (v, u, f)) in maps.iter().enumerate() {
        let g = grid(v, u)?;
        placed.push(Placed {
            grid: g,
            frame: frame(&format!("map {k}"), *f, g.height, g.width)?,
        });
    }
    let p = params(
        occupied_threshold,
        tolerance,
        min_inliers,
        min_overlap,
        min_margin,
    );
    let all = compute(py, threads, || register_all(&placed, &p))?.map_err(error)?;
    Ok(all
        .iter()
        .map(|(ij, r)| (*ij, RawRegistration::from(r)))
        .collect())
}
