//! Ground truth on demand: the simulator's laser (`rust/src/raycast.rs`).

use super::contiguous;
use super::runtime::compute;
use crate::raycast::{cast_scans, CastError, RayGrid};
use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// raycast(blocked, resolution, origin, poses, angles, max_range, threads=0) ->
/// numpy.ndarray
///
/// The exact range of every beam of every scan (`rust/src/raycast.rs`): `blocked` a
/// C-contiguous 2-D uint8 grid, row 0 at the top, non-zero where a cell stops a beam;
/// `resolution` metres per cell; `origin` `(x, y, yaw)` of its lower-left corner; `poses`
/// `(n, 3)` float64 laser poses `(x, y, yaw)` in the world frame; `angles` `(b,)` float64
/// beam angles relative to the yaw; `max_range` metres (> 0, may be inf). Returns `(n, b)`
/// float64 metres to where each beam enters the first blocking cell, `inf` for no return;
/// scans in parallel without the GIL, the same numbers for any `threads` (0 = every core).
#[pyfunction]
#[pyo3(signature = (blocked, resolution, origin, poses, angles, max_range, threads=0))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn raycast<'py>(
    py: Python<'py>,
    blocked: PyReadonlyArray2<'py, u8>,
    resolution: f64,
    origin: (f64, f64, f64),
    poses: PyReadonlyArray2<'py, f64>,
    angles: PyReadonlyArray1<'py, f64>,
    max_range: f64,
    threads: usize,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let [h, w] = [blocked.shape()[0], blocked.shape()[1]];
    let cells = blocked
        .as_slice()
        .map_err(|_| PyValueError::new_err("blocked must be a C-contiguous uint8 array"))?;
    if poses.shape()[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "poses must have shape (n, 3), got {:?}",
            poses.shape()
        )));
    }
    let flat = contiguous(&poses, "poses")?;
    let a = contiguous(&angles, "angles")?;
    let (n, b) = (poses.shape()[0], a.len());
    let err = |e: CastError| PyValueError::new_err(e.to_string());
    let ranges = compute(py, threads, || {
        let grid = RayGrid::new(cells, h, w, resolution, [origin.0, origin.1, origin.2])?;
        cast_scans(&grid, flat, a, max_range)
    })?
    .map_err(err)?;
    PyArray1::from_vec(py, ranges).reshape([n, b])
}
