//! The pyo3 bindings (`slamq._core`), and nothing else: argument checks, zero-copy views of
//! the numpy buffers, the GIL released around compute, panics turned into Python errors.

use crate::corners::CornerParams;
use crate::enclosed::EnclosedParams;
use crate::evaluate::{
    evaluate as evaluate_grid, evaluate_many as evaluate_grids, Params, Quality,
};
use crate::grid::Grid;
use numpy::{PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::cell::RefCell;
use std::collections::HashMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Arc;

thread_local! {
    /// This calling thread's pools, by size. Per calling thread, so that Python threads each
    /// asking for `threads=1` run side by side instead of queueing on one shared pool.
    static POOLS: RefCell<HashMap<usize, Arc<rayon::ThreadPool>>> = RefCell::new(HashMap::new());
}

/// A pool of `threads` workers for the calling thread (`threads == 0`: rayon's global pool).
fn pool(threads: usize) -> PyResult<Option<Arc<rayon::ThreadPool>>> {
    if threads == 0 {
        return Ok(None);
    }
    POOLS.with(|pools| {
        if let Some(p) = pools.borrow().get(&threads) {
            return Ok(Some(p.clone()));
        }
        let p = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(move |i| format!("slamq-{threads}-{i}"))
            .build()
            .map_err(|e| PyRuntimeError::new_err(format!("cannot start {threads} threads: {e}")))?;
        let p = Arc::new(p);
        pools.borrow_mut().insert(threads, p.clone());
        Ok(Some(p))
    })
}

/// Run `f` without the GIL, on a pool of `threads` (0 = all cores), turning a panic into a
/// Python `RuntimeError` instead of unwinding across the FFI.
fn compute<T: Send>(py: Python<'_>, threads: usize, f: impl FnOnce() -> T + Send) -> PyResult<T> {
    let pool = pool(threads)?;
    py.detach(move || {
        catch_unwind(AssertUnwindSafe(|| match pool {
            Some(p) => p.install(f),
            None => f(),
        }))
    })
    .map_err(|e| {
        let msg = e
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| e.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown panic".into());
        PyRuntimeError::new_err(format!("slamq core internal error: {msg}"))
    })
}

/// Borrow a map's buffers as a checked [`Grid`].
fn grid<'a>(
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

#[allow(clippy::too_many_arguments)]
fn params(
    log_threshold: f64,
    min_dot_area: i64,
    harris_k: f64,
    harris_quality: f64,
    sweep_step: i64,
    min_area: i64,
) -> PyResult<Params> {
    let bad = |name: &str, v: String| PyValueError::new_err(format!("{name} out of range: {v}"));
    if !log_threshold.is_finite() {
        return Err(bad("log_threshold", log_threshold.to_string()));
    }
    if !harris_k.is_finite() {
        return Err(bad("harris_k", harris_k.to_string()));
    }
    if !(0.0..=1.0).contains(&harris_quality) {
        return Err(bad("harris_quality", harris_quality.to_string()));
    }
    if !(1..=256).contains(&sweep_step) {
        return Err(bad("sweep_step", sweep_step.to_string()));
    }
    let min_dot_area =
        u32::try_from(min_dot_area).map_err(|_| bad("min_dot_area", min_dot_area.to_string()))?;
    let min_area = u32::try_from(min_area)
        .ok()
        .filter(|v| *v <= i32::MAX as u32)
        .ok_or_else(|| bad("min_area", min_area.to_string()))?;
    Ok(Params {
        corners: CornerParams {
            log_threshold,
            min_dot_area,
            harris_k,
            harris_quality,
        },
        enclosed: EnclosedParams {
            sweep_step: sweep_step as usize,
            min_area,
        },
    })
}

fn quality_dict<'py>(py: Python<'py>, q: &Quality) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("known", q.occupancy.known)?;
    d.set_item("occupied", q.occupancy.occupied)?;
    d.set_item("sum_darkness", q.occupancy.sum_darkness)?;
    d.set_item("corners", q.corners)?;
    d.set_item("curve", q.curve.clone())?;
    Ok(d)
}

/// evaluate(values, unknown, log_threshold, min_dot_area, harris_k, harris_quality,
/// sweep_step, min_area, threads) -> dict(known, occupied, sum_darkness, corners, curve)
///
/// The integers of SPEC sections 2-4 for one map. `threads` = 0 uses every core.
#[pyfunction]
#[pyo3(signature = (values, unknown, log_threshold=0.1, min_dot_area=5, harris_k=0.04,
                    harris_quality=0.01, sweep_step=1, min_area=1, threads=0))]
#[allow(clippy::too_many_arguments)]
fn evaluate<'py>(
    py: Python<'py>,
    values: PyReadonlyArray2<'py, u8>,
    unknown: PyReadonlyArray2<'py, bool>,
    log_threshold: f64,
    min_dot_area: i64,
    harris_k: f64,
    harris_quality: f64,
    sweep_step: i64,
    min_area: i64,
    threads: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let p = params(
        log_threshold,
        min_dot_area,
        harris_k,
        harris_quality,
        sweep_step,
        min_area,
    )?;
    let g = grid(&values, &unknown)?;
    let q = compute(py, threads, || evaluate_grid(&g, &p))?;
    quality_dict(py, &q)
}

/// evaluate_many(maps, ..., threads) -> list[dict]: like `evaluate` for a list of
/// `(values, unknown)` pairs, the maps in parallel.
#[pyfunction]
#[pyo3(signature = (maps, log_threshold=0.1, min_dot_area=5, harris_k=0.04,
                    harris_quality=0.01, sweep_step=1, min_area=1, threads=0))]
#[allow(clippy::too_many_arguments)]
fn evaluate_many<'py>(
    py: Python<'py>,
    maps: Vec<(PyReadonlyArray2<'py, u8>, PyReadonlyArray2<'py, bool>)>,
    log_threshold: f64,
    min_dot_area: i64,
    harris_k: f64,
    harris_quality: f64,
    sweep_step: i64,
    min_area: i64,
    threads: usize,
) -> PyResult<Vec<Bound<'py, PyDict>>> {
    let p = params(
        log_threshold,
        min_dot_area,
        harris_k,
        harris_quality,
        sweep_step,
        min_area,
    )?;
    let grids = maps
        .iter()
        .map(|(v, u)| grid(v, u))
        .collect::<PyResult<Vec<_>>>()?;
    let qs = compute(py, threads, || evaluate_grids(&grids, &p))?;
    qs.iter().map(|q| quality_dict(py, q)).collect()
}

/// otsu_table(values, unknown) -> list[int]: T_u for u = 0..255 (SPEC section 4 step 2).
#[pyfunction]
fn otsu_table(
    py: Python<'_>,
    values: PyReadonlyArray2<'_, u8>,
    unknown: PyReadonlyArray2<'_, bool>,
) -> PyResult<Vec<u8>> {
    let g = grid(&values, &unknown)?;
    let t = compute(py, 0, || crate::otsu::threshold_table(&g.histogram()))?;
    Ok(t.to_vec())
}

/// The Rust core of slamq.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate_many, m)?)?;
    m.add_function(wrap_pyfunction!(otsu_table, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
