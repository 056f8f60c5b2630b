//! Bindings of the trajectory error's passes over the poses (rust/src/ate.rs): stamp
//! matching, the Umeyama sums, the errors and their statistics.

use super::contiguous;
use super::runtime::compute;
use numpy::{PyArray1, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// match_stamps(stamps_1, stamps_2, max_dt, offset_2=0.0) -> (i1, i2): int64 indices of the
/// best match in `stamps_2 + offset_2` (non-decreasing) of each of `stamps_1`, as
/// `slamq.metrics.sync.matching_indices` (`rust/src/ate.rs`).
#[pyfunction]
#[pyo3(signature = (stamps_1, stamps_2, max_dt, offset_2=0.0))]
#[allow(clippy::type_complexity)]
pub(crate) fn match_stamps<'py>(
    py: Python<'py>,
    stamps_1: PyReadonlyArray1<'py, f64>,
    stamps_2: PyReadonlyArray1<'py, f64>,
    max_dt: f64,
    offset_2: f64,
) -> PyResult<(Bound<'py, PyArray1<i64>>, Bound<'py, PyArray1<i64>>)> {
    let s1 = contiguous(&stamps_1, "stamps_1")?;
    let s2 = contiguous(&stamps_2, "stamps_2")?;
    let (i1, i2) = compute(py, 0, || {
        crate::ate::matching_indices(s1, s2, max_dt, offset_2)
    })?;
    Ok((PyArray1::from_vec(py, i1), PyArray1::from_vec(py, i2)))
}

/// Checked pairs of a (n, 3) ground truth and estimate and their index arrays.
fn pairs<'a>(
    gt: &'a PyReadonlyArray2<'_, f64>,
    est: &'a PyReadonlyArray2<'_, f64>,
    gi: &'a PyReadonlyArray1<'_, i64>,
    ei: &'a PyReadonlyArray1<'_, i64>,
) -> PyResult<crate::ate::Pairs<'a>> {
    if gt.shape()[1] != 3 || est.shape()[1] != 3 {
        return Err(PyValueError::new_err("positions must have shape (n, 3)"));
    }
    let p = crate::ate::Pairs::new(
        contiguous(gt, "gt")?,
        contiguous(est, "est")?,
        contiguous(gi, "gi")?,
        contiguous(ei, "ei")?,
    )
    .map_err(|e| PyValueError::new_err(e.to_string()))?;
    if p.is_empty() {
        return Err(PyValueError::new_err("no associated pair"));
    }
    Ok(p)
}

/// ate_moments(gt, est, gi, ei, dims) -> (mean_x, mean_y, sigma_x, cov): the Umeyama sums
/// of the estimate (x: `est[ei]`) onto the ground truth (y: `gt[gi]`) over the first `dims`
/// coordinates (`rust/src/ate.rs`, `moments`); `cov[r][c]` = mean of `yc_r xc_c`.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub(crate) fn ate_moments(
    py: Python<'_>,
    gt: PyReadonlyArray2<'_, f64>,
    est: PyReadonlyArray2<'_, f64>,
    gi: PyReadonlyArray1<'_, i64>,
    ei: PyReadonlyArray1<'_, i64>,
    dims: usize,
) -> PyResult<(Vec<f64>, Vec<f64>, f64, Vec<Vec<f64>>)> {
    if !(1..=3).contains(&dims) {
        return Err(PyValueError::new_err(format!(
            "dims must be 1, 2 or 3, got {dims}"
        )));
    }
    let p = pairs(&gt, &est, &gi, &ei)?;
    let m = compute(py, 0, || crate::ate::moments(&p, dims))?;
    Ok((
        m.mean_x[..dims].to_vec(),
        m.mean_y[..dims].to_vec(),
        m.sigma_x,
        m.cov[..dims].iter().map(|r| r[..dims].to_vec()).collect(),
    ))
}

/// ate_errors(gt, est, gi, ei, rotation, translation, scale) -> (errors, (sum, sse, ssd,
/// min, max, median)): the distance of each pair after `scale * rotation @ est[ei] +
/// translation` (`rotation` None: as is) and its statistics (`rust/src/ate.rs`).
#[pyfunction]
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
pub(crate) fn ate_errors<'py>(
    py: Python<'py>,
    gt: PyReadonlyArray2<'py, f64>,
    est: PyReadonlyArray2<'py, f64>,
    gi: PyReadonlyArray1<'py, i64>,
    ei: PyReadonlyArray1<'py, i64>,
    rotation: Option<[[f64; 3]; 3]>,
    translation: [f64; 3],
    scale: f64,
) -> PyResult<(Bound<'py, PyArray1<f64>>, (f64, f64, f64, f64, f64, f64))> {
    let p = pairs(&gt, &est, &gi, &ei)?;
    let align = rotation.map(|rotation| crate::ate::Similarity {
        rotation,
        translation,
        scale,
    });
    let (e, s) = compute(py, 0, || {
        let e = crate::ate::errors(&p, align.as_ref());
        let s = crate::ate::stats(&e);
        (e, s)
    })?;
    Ok((
        PyArray1::from_vec(py, e),
        (s.sum, s.sse, s.ssd, s.min, s.max, s.median),
    ))
}
