//! Binding of the ground-truth comparison (rust/src/compare/, SPEC section 7): `compare`
//! and the `RawComparison` it returns.

use super::grid;
use super::runtime::compute;
use crate::compare::{compare_within, CellBox, Comparison};
use crate::edt::EdtError;
use crate::error::Error;
use crate::params::{Align, CompareParams};
use crate::se2::{Frame, Placed, Se2};
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2};
use pyo3::exceptions::{PyMemoryError, PyValueError};
use pyo3::prelude::*;

/// The counts and sums of one ground-truth comparison (SPEC section 7); distances in
/// cells of the ground truth's grid. `slamq.MapComparison.from_counts` forms the figures.
#[pyclass(frozen, get_all, eq, module = "slamq._core")]
#[derive(PartialEq)]
pub(crate) struct RawComparison {
    estimate_occupied: u64,
    ground_truth_occupied: u64,
    estimate_matched: u64,
    ground_truth_matched: u64,
    intersection: u64,
    union: u64,
    sum_reverse: f64,
    sum_ne: f64,
    truncated_reverse: u64,
    truncated_ne: u64,
    ground_truth_free: u64,
    covered: u64,
    outside: u64,
    /// The motion applied to the estimate's world frame: rotation (radians) and translation
    /// (metres).
    theta: f64,
    tx: f64,
    ty: f64,
    icp_rms: f64,
    icp_iterations: usize,
    icp_inliers: usize,
}

impl From<&Comparison> for RawComparison {
    fn from(c: &Comparison) -> Self {
        RawComparison {
            estimate_occupied: c.estimate_occupied,
            ground_truth_occupied: c.ground_truth_occupied,
            estimate_matched: c.estimate_matched,
            ground_truth_matched: c.ground_truth_matched,
            intersection: c.intersection,
            union: c.union,
            sum_reverse: c.sum_reverse,
            sum_ne: c.sum_ne,
            truncated_reverse: c.truncated_reverse,
            truncated_ne: c.truncated_ne,
            ground_truth_free: c.ground_truth_free,
            covered: c.covered,
            outside: c.outside,
            theta: c.transform.theta,
            tx: c.transform.tx,
            ty: c.transform.ty,
            icp_rms: c.icp_rms,
            icp_iterations: c.icp_iterations,
            icp_inliers: c.icp_inliers,
        }
    }
}

#[pymethods]
impl RawComparison {
    fn __repr__(&self) -> String {
        format!(
            "RawComparison(estimate_occupied={}, ground_truth_occupied={}, intersection={}, \
             theta={}, tx={}, ty={})",
            self.estimate_occupied,
            self.ground_truth_occupied,
            self.intersection,
            self.theta,
            self.tx,
            self.ty
        )
    }
}

/// A map's frame from `(resolution, x, y, yaw)`.
pub(super) fn frame(
    what: &str,
    f: (f64, f64, f64, f64),
    height: usize,
    width: usize,
) -> PyResult<Frame> {
    let (resolution, x, y, yaw) = f;
    if !(resolution.is_finite() && resolution > 0.0) {
        return Err(PyValueError::new_err(format!(
            "{what} resolution must be a positive number, got {resolution}"
        )));
    }
    if !(x.is_finite() && y.is_finite() && yaw.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "{what} origin must be finite, got ({x}, {y}, {yaw})"
        )));
    }
    Ok(Frame {
        resolution,
        height,
        width,
        origin: Se2 {
            theta: yaw,
            tx: x,
            ty: y,
        },
    })
}

/// compare(est_values, est_unknown, est_frame, gt_values, gt_unknown, gt_frame,
/// tolerance=2.0, occupied_threshold=0.5, align="icp", max_distance=None, cells=False,
/// threads=0, cells_box=None) -> (RawComparison, numpy.ndarray | None)
///
/// An estimate against a ground truth (SPEC section 7). Frames are `(resolution, x, y,
/// yaw)`; `tolerance` and `max_distance` are in cells of the ground truth's grid; `cells`
/// also returns the per-cell flags (uint8, the ground truth's shape), of the box
/// `cells_box = (row0, row1, col0, col1)` of its grid only when given (clipped to it).
#[pyfunction]
#[pyo3(signature = (est_values, est_unknown, est_frame, gt_values, gt_unknown, gt_frame,
                    tolerance=2.0, occupied_threshold=0.5, align="icp", max_distance=None,
                    cells=false, threads=0, cells_box=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn compare<'py>(
    py: Python<'py>,
    est_values: PyReadonlyArray2<'py, u8>,
    est_unknown: PyReadonlyArray2<'py, bool>,
    est_frame: (f64, f64, f64, f64),
    gt_values: PyReadonlyArray2<'py, u8>,
    gt_unknown: PyReadonlyArray2<'py, bool>,
    gt_frame: (f64, f64, f64, f64),
    tolerance: f64,
    occupied_threshold: f64,
    align: &str,
    max_distance: Option<f64>,
    cells: bool,
    threads: usize,
    cells_box: Option<(usize, usize, usize, usize)>,
) -> PyResult<(RawComparison, Option<Bound<'py, PyArray2<u8>>>)> {
    let align = Align::from_name(align).ok_or_else(|| {
        PyValueError::new_err(format!(
            "align must be 'origin', 'icp' or 'search', got {:?}",
            align.chars().take(80).collect::<String>()
        ))
    })?;
    let eg = grid(&est_values, &est_unknown)?;
    let gg = grid(&gt_values, &gt_unknown)?;
    let estimate = Placed {
        grid: eg,
        frame: frame("estimate", est_frame, eg.height, eg.width)?,
    };
    let ground_truth = Placed {
        grid: gg,
        frame: frame("ground truth", gt_frame, gg.height, gg.width)?,
    };
    let params = CompareParams {
        tolerance,
        occupied_threshold,
        align,
        max_distance,
        ..CompareParams::default()
    };
    let whole = (0, gg.height, 0, gg.width);
    let (r0, r1, c0, c1) = cells_box.unwrap_or(whole);
    let within = cells.then(|| CellBox { r0, r1, c0, c1 }.clip(gg.height, gg.width));
    let c = compute(py, threads, || {
        compare_within(&estimate, &ground_truth, &params, within)
    })?
    .map_err(error)?;
    let raw = RawComparison::from(&c);
    let flags = match (c.cells, within) {
        (Some(v), Some(b)) => Some(PyArray1::from_vec(py, v).reshape([b.height(), b.width()])?),
        _ => None,
    };
    Ok((raw, flags))
}

/// The Python exception of an [`Error`] of the comparison or the registration: `MemoryError`
/// when memory ran out, else `ValueError`, with the error's message.
pub(crate) fn error(e: Error) -> PyErr {
    match e {
        Error::Edt(EdtError::Alloc { .. }) => PyMemoryError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}
