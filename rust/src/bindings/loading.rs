//! Bindings of the loaders' fast paths: the map_saver pass over an image
//! (rust/src/pixels.rs) and the numeric text tables and TUM files (rust/src/table.rs).

use super::runtime::{compute, detached};
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// map_saver_shades(grey) -> (list[int] | None, numpy.ndarray): which of map_saver's grey
/// levels (0, 205, 254, 255) a C-contiguous 2-D uint8 image holds, or None when it holds any
/// other value, and its unknown mask `grey == 205` (bool, the image's shape); one pass
/// without the GIL (`rust/src/pixels.rs`).
#[pyfunction]
#[allow(clippy::type_complexity)]
pub(crate) fn map_saver_shades<'py>(
    py: Python<'py>,
    grey: PyReadonlyArray2<'py, u8>,
) -> PyResult<(Option<Vec<u32>>, Bound<'py, PyArray2<bool>>)> {
    let [h, w] = [grey.shape()[0], grey.shape()[1]];
    let g = grey
        .as_slice()
        .map_err(|_| PyValueError::new_err("grey must be a C-contiguous uint8 array"))?;
    let (seen, unknown) = detached(py, || {
        let mut unknown = vec![false; g.len()];
        let seen = crate::pixels::map_saver_shades(g, &mut unknown);
        (seen, unknown)
    })?;
    let present = seen.map(|seen| {
        crate::pixels::MAP_SAVER_SHADES
            .iter()
            .zip(seen)
            .filter_map(|(&v, s)| s.then_some(u32::from(v)))
            .collect()
    });
    Ok((present, PyArray1::from_vec(py, unknown).reshape([h, w])?))
}

/// read_table(path, sep, skip=0) -> numpy.ndarray | None: the numbers of a regular numeric
/// text table (`rust/src/table.rs`: `#` comments, blank lines skipped, `sep` " " for runs of
/// blanks or one separator byte, every row as long as the first, plain decimal numbers) as
/// a float64 array of shape (rows, cols); None when the file cannot be read or the table is
/// not regular (the caller's general parser then says why).
#[pyfunction]
#[pyo3(signature = (path, sep, skip=0))]
pub(crate) fn read_table<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    sep: &str,
    skip: usize,
) -> PyResult<Option<Bound<'py, PyArray2<f64>>>> {
    let sep = match sep.as_bytes() {
        b" " => crate::table::Sep::Blanks,
        [b] => crate::table::Sep::Byte(*b),
        _ => {
            return Err(PyValueError::new_err(format!(
                "sep must be one byte, got {sep:?}"
            )))
        }
    };
    let table = compute(py, 0, || {
        crate::table::read_table_file(&path, sep, skip)
            .ok()
            .flatten()
    })?;
    match table {
        None => Ok(None),
        Some(t) => {
            let arr = PyArray1::from_vec(py, t.values);
            Ok(Some(arr.reshape([t.rows, t.cols])?))
        }
    }
}

/// read_tum(path) -> (timestamps, positions, quaternions) | None: the poses of a regular
/// TUM file (`rust/src/table.rs`, `read_tum_file`) in the layout `slamq.Trajectory` keeps:
/// float64 arrays (n,), (n, 3) and (n, 4) (unit quaternions, w x y z). None when the file
/// cannot be read, is not a regular table of 8 columns, or has poses the Trajectory checks
/// refuse (the caller's general reader then says why).
#[pyfunction]
#[allow(clippy::type_complexity)]
pub(crate) fn read_tum<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
) -> PyResult<
    Option<(
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray2<f64>>,
    )>,
> {
    let poses = compute(py, 0, || crate::table::read_tum_file(&path).ok().flatten())?;
    match poses {
        None => Ok(None),
        Some(p) => {
            let n = p.len();
            let t = PyArray1::from_vec(py, p.t);
            let pos = PyArray1::from_vec(py, p.p).reshape([n, 3])?;
            let q = PyArray1::from_vec(py, p.q).reshape([n, 4])?;
            Ok(Some((t, pos, q)))
        }
    }
}
