//! The pyo3 bindings (`slamq._core`), one file per domain, and nothing else: argument
//! checks, zero-copy views of the numpy buffers, the GIL released around compute (through
//! [`runtime`]), panics turned into Python errors.
//!
//! - [`maps`]: `evaluate`, `evaluate_many`, `otsu_table`, `default_params` (the three map
//!   metrics; `RawQuality`).
//! - [`loading`]: the loaders' fast paths: `map_saver_shades`, `read_table`, `read_tum`.
//! - [`trajectory`]: `match_stamps`, `ate_moments`, `ate_errors`.
//! - [`comparison`]: `compare` (a map against a ground-truth map; `RawComparison`).
//! - [`registration`]: `register`, `register_many` (maps of one place onto each other;
//!   `RawRegistration`).
//! - [`synth`]: `raycast` (the simulator's laser, ground truth on demand).
//! - [`scans`]: `scan_consistency` (a map against its own laser scans), `scan_ratios`
//!   (scans that see walls in one direction only), `scan_split` (a trajectory against its
//!   own scans, split in time).
//! - [`runtime`]: the thread pools, fork handling, `adopt_thread`.

mod comparison;
mod loading;
mod maps;
mod registration;
mod runtime;
mod scans;
mod synth;
mod trajectory;

use crate::grid::Grid;
use numpy::{PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// Borrow a map's buffers as a checked [`Grid`].
pub(crate) fn grid<'a>(
    values: &'a PyReadonlyArray2<'_, u8>,
    unknown: &'a PyReadonlyArray2<'_, bool>,
) -> PyResult<Grid<'a>> {
    let shape = values.shape();
    if unknown.shape() != shape {
        return Err(PyValueError::new_err(format!(
            "unknown mask shape {:?} differs from values shape {:?}",
            unknown.shape(),
            shape
        )));
    }
    let v = values
        .as_slice()
        .map_err(|_| PyValueError::new_err("values must be a C-contiguous uint8 array"))?;
    let u = unknown
        .as_slice()
        .map_err(|_| PyValueError::new_err("unknown must be a C-contiguous bool array"))?;
    Grid::new(v, u, shape[0], shape[1]).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// A C-contiguous view of a float64 or int64 array, or a `ValueError` naming it.
pub(crate) fn contiguous<'a, T: numpy::Element>(
    a: &'a numpy::PyReadonlyArray<'_, T, impl numpy::ndarray::Dimension>,
    what: &str,
) -> PyResult<&'a [T]> {
    a.as_slice()
        .map_err(|_| PyValueError::new_err(format!("{what} must be a C-contiguous array")))
}

/// The Rust core of slamq.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(maps::evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(maps::evaluate_many, m)?)?;
    m.add_function(wrap_pyfunction!(maps::otsu_table, m)?)?;
    m.add_function(wrap_pyfunction!(maps::wall_harmonics, m)?)?;
    m.add_function(wrap_pyfunction!(maps::default_params, m)?)?;
    m.add("WORK_BYTES_PER_CELL", crate::memory::WORK_BYTES_PER_CELL)?;
    m.add_class::<maps::RawQuality>()?;
    m.add_function(wrap_pyfunction!(loading::map_saver_shades, m)?)?;
    m.add_function(wrap_pyfunction!(loading::read_table, m)?)?;
    m.add_function(wrap_pyfunction!(loading::read_tum, m)?)?;
    m.add_function(wrap_pyfunction!(trajectory::match_stamps, m)?)?;
    m.add_function(wrap_pyfunction!(trajectory::ate_moments, m)?)?;
    m.add_function(wrap_pyfunction!(trajectory::ate_errors, m)?)?;
    m.add_function(wrap_pyfunction!(comparison::compare, m)?)?;
    m.add_class::<comparison::RawComparison>()?;
    m.add_function(wrap_pyfunction!(registration::register, m)?)?;
    m.add_function(wrap_pyfunction!(registration::register_many, m)?)?;
    m.add_class::<registration::RawRegistration>()?;
    m.add_function(wrap_pyfunction!(synth::raycast, m)?)?;
    m.add_function(wrap_pyfunction!(scans::scan_consistency, m)?)?;
    m.add_function(wrap_pyfunction!(scans::scan_ratios, m)?)?;
    m.add_function(wrap_pyfunction!(scans::scan_split, m)?)?;
    m.add_function(wrap_pyfunction!(runtime::adopt_thread, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
