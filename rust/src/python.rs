//! The pyo3 bindings (`slamq._core`), and nothing else: argument checks, zero-copy views of
//! the numpy buffers, the GIL released around compute, panics turned into Python errors.

use crate::compare::{compare as compare_maps, CompareError, Comparison, Placed};
use crate::edt::EdtError;
use crate::evaluate::{
    evaluate as evaluate_grid, evaluate_many as evaluate_grids, OutOfMemory, Quality,
};
use crate::grid::Grid;
use crate::params::{Align, CompareParams, CornerParams, EnclosedParams, Params};
use crate::se2::{Frame, Se2};
use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyMemoryError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::cell::{Cell, RefCell};
use std::collections::HashMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::{Arc, Mutex};

/// A pool and the process that made it. A forked child has none of its parent's pool
/// threads, so a pool made before a fork is left alone there (never dropped: its locks may
/// be held by threads the child does not have) and made again; without this, a child of a
/// process that had evaluated a map (`multiprocessing`'s default start on Linux) waited
/// for ever on its first call. `pid` 0: an adopted thread's own pool, valid in any process.
struct Owned {
    pid: u32,
    /// Always `Some` but while being dropped.
    pool: Option<Arc<rayon::ThreadPool>>,
}

impl Owned {
    /// The pool, when it can run work in this process.
    fn live(&self) -> Option<Arc<rayon::ThreadPool>> {
        let here = self.pid == 0 || self.pid == std::process::id();
        self.pool.as_ref().filter(|_| here).cloned()
    }
}

impl Drop for Owned {
    fn drop(&mut self) {
        if self.pid != 0 && self.pid != std::process::id() {
            std::mem::forget(self.pool.take()); // a parent's pool: see the type's docs
        }
    }
}

thread_local! {
    /// This calling thread's pools, by size. Per calling thread, so that Python threads each
    /// asking for `threads=1` run side by side instead of queueing on one shared pool.
    static POOLS: RefCell<HashMap<usize, Owned>> = RefCell::new(HashMap::new());
    /// Whether this thread is its own 1-thread pool ([`adopt_thread`]).
    static ADOPTED: Cell<bool> = const { Cell::new(false) };
}

/// The pool of every core (`threads == 0`), shared by all threads. Not rayon's global pool,
/// which a forked child cannot make again; and on an adopted thread rayon would otherwise
/// run the work in the thread's own 1-thread pool.
static ALL_CORES: Mutex<Option<Owned>> = Mutex::new(None);

fn build_pool(threads: usize) -> PyResult<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(move |i| format!("slamq-{threads}-{i}"))
        .build()
        .map_err(|e| PyRuntimeError::new_err(format!("cannot start {threads} threads: {e}")))
}

/// `slot`'s pool when it can run work in this process; else a new one in its place.
fn current_pool(slot: &mut Option<Owned>, threads: usize) -> PyResult<Arc<rayon::ThreadPool>> {
    if let Some(pool) = slot.as_ref().and_then(Owned::live) {
        return Ok(pool);
    }
    let pool = Arc::new(build_pool(threads)?);
    *slot = Some(Owned {
        pid: std::process::id(),
        pool: Some(pool.clone()),
    });
    Ok(pool)
}

/// A pool of `threads` workers for the calling thread (`threads == 0`: every core).
fn pool(threads: usize) -> PyResult<Arc<rayon::ThreadPool>> {
    if threads == 0 {
        let mut all = ALL_CORES.lock().unwrap_or_else(|e| e.into_inner());
        return current_pool(&mut all, 0);
    }
    POOLS.with(|pools| {
        let mut pools = pools.borrow_mut();
        let mut slot = pools.remove(&threads);
        let pool = current_pool(&mut slot, threads);
        if let Some(o) = slot {
            pools.insert(threads, o);
        }
        pool
    })
}

/// adopt_thread() -> bool: make the calling thread its own 1-thread pool, so that its
/// `threads=1` calls run on it instead of handing the work to a second thread and waiting
/// (two context switches a call, and on a busy machine a woken pool thread that can take
/// the core from a thread holding the GIL). True when adopted now, False when it already
/// was or is a rayon thread. For long-lived threads only: rayon keeps a few KB per adopted
/// thread for the life of the process (about 8 KB each, measured). `slamq.evaluate_many`
/// adopts the worker threads it keeps between batches.
#[pyfunction]
fn adopt_thread() -> PyResult<bool> {
    if ADOPTED.with(Cell::get) || rayon::current_thread_index().is_some() {
        return Ok(false);
    }
    let p = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .use_current_thread()
        .build()
        .map_err(|e| PyRuntimeError::new_err(format!("cannot adopt this thread: {e}")))?;
    // a 1-thread pool this thread had ends with its thread (one of a parent is forgotten)
    let own = Owned {
        pid: 0,
        pool: Some(Arc::new(p)),
    };
    POOLS.with(|pools| pools.borrow_mut().insert(1, own));
    ADOPTED.with(|a| a.set(true));
    Ok(true)
}

/// Run `f` without the GIL, on a pool of `threads` (0 = all cores), turning a panic into a
/// Python `RuntimeError` instead of unwinding across the FFI.
fn compute<T: Send>(py: Python<'_>, threads: usize, f: impl FnOnce() -> T + Send) -> PyResult<T> {
    let pool = pool(threads)?;
    detached(py, move || pool.install(f))
}

/// Run sequential work `f` on the calling thread without the GIL (no pool: no hand-over to
/// another thread), a panic turned into a Python `RuntimeError`.
fn detached<T: Send>(py: Python<'_>, f: impl FnOnce() -> T + Send) -> PyResult<T> {
    py.detach(move || catch_unwind(AssertUnwindSafe(f)))
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

/// The metric parameters as the Python side gives them: any object with these attributes,
/// normally a `slamq.Params` (python/slamq/params.py, the table of names, ranges and units).
#[derive(FromPyObject)]
struct PyParams {
    log_threshold: f64,
    min_dot_area: i64,
    harris_k: f64,
    harris_quality: f64,
    canonical_resolution: f64,
    sweep_step: i64,
    min_area: i64,
}

impl PyParams {
    /// The core's [`Params`], or a `ValueError` naming the parameter out of range (the
    /// Python table checks these first; this guards direct callers of `_core`).
    fn checked(&self) -> PyResult<Params> {
        let bad =
            |name: &str, v: String| PyValueError::new_err(format!("{name} out of range: {v}"));
        if !self.log_threshold.is_finite() {
            return Err(bad("log_threshold", self.log_threshold.to_string()));
        }
        if !self.harris_k.is_finite() {
            return Err(bad("harris_k", self.harris_k.to_string()));
        }
        if !(0.0..=1.0).contains(&self.harris_quality) {
            return Err(bad("harris_quality", self.harris_quality.to_string()));
        }
        if !(self.canonical_resolution.is_finite() && self.canonical_resolution >= 0.0) {
            return Err(bad(
                "canonical_resolution",
                self.canonical_resolution.to_string(),
            ));
        }
        if !(1..=256).contains(&self.sweep_step) {
            return Err(bad("sweep_step", self.sweep_step.to_string()));
        }
        let in_i32 = |name: &str, v: i64| {
            u32::try_from(v)
                .ok()
                .filter(|v| *v <= i32::MAX as u32)
                .ok_or_else(|| bad(name, v.to_string()))
        };
        Ok(Params {
            corners: CornerParams {
                log_threshold: self.log_threshold,
                min_dot_area: in_i32("min_dot_area", self.min_dot_area)?,
                harris_k: self.harris_k,
                harris_quality: self.harris_quality,
                canonical_resolution: self.canonical_resolution,
            },
            enclosed: EnclosedParams {
                sweep_step: self.sweep_step as usize,
                min_area: in_i32("min_area", self.min_area)?,
            },
        })
    }
}

/// The integers of one evaluation (SPEC sections 2-4); `slamq.MapQuality.from_counts`
/// forms the ratios from them.
#[pyclass(frozen, get_all, eq, module = "slamq._core")]
struct RawQuality {
    /// Known cells.
    known: u64,
    /// Known cells darker than the mean darkness (SPEC 2).
    occupied: u64,
    /// Sum of `255 - v` over known cells.
    sum_darkness: u64,
    /// Corner count (SPEC 3).
    corners: usize,
    /// Dominant wall angle, radians in (-pi/4, pi/4] (SPEC 3a; NaN when skipped).
    wall_angle: f64,
    /// Corner count of the canonical map (SPEC 3a; None when skipped or too large).
    corners_canonical: Option<usize>,
    /// `count_u` for every swept `u` (SPEC 4).
    curve: Vec<usize>,
    /// Distinct values among the known cells.
    known_levels: usize,
    /// The commonest value (shade) of the unknown cells, the smallest of equals; None
    /// without unknown cells.
    unknown_shade: Option<u8>,
    /// The known cells' bounding box `(r0, r1, c0, c1)` (rows `r0..r1`, columns `c0..c1`);
    /// None without known cells.
    known_box: Option<(usize, usize, usize, usize)>,
}

// NaN angles (canonical step skipped) compare equal bit for bit.
impl PartialEq for RawQuality {
    fn eq(&self, o: &Self) -> bool {
        (self.known, self.occupied, self.sum_darkness, self.corners)
            == (o.known, o.occupied, o.sum_darkness, o.corners)
            && self.wall_angle.to_bits() == o.wall_angle.to_bits()
            && self.corners_canonical == o.corners_canonical
            && self.curve == o.curve
            && (self.known_levels, self.unknown_shade, self.known_box)
                == (o.known_levels, o.unknown_shade, o.known_box)
    }
}

impl From<Quality> for RawQuality {
    fn from(q: Quality) -> Self {
        RawQuality {
            known: q.occupancy.known,
            occupied: q.occupancy.occupied,
            sum_darkness: q.occupancy.sum_darkness,
            corners: q.corners,
            wall_angle: q.wall_angle,
            corners_canonical: q.corners_canonical,
            curve: q.curve,
            known_levels: q.known_levels,
            unknown_shade: q.unknown_shade,
            known_box: q.known_box,
        }
    }
}

#[pymethods]
impl RawQuality {
    fn __repr__(&self) -> String {
        format!(
            "RawQuality(known={}, occupied={}, sum_darkness={}, corners={}, \
             corners_canonical={:?}, wall_angle={}, curve=[{} values])",
            self.known,
            self.occupied,
            self.sum_darkness,
            self.corners,
            self.corners_canonical,
            self.wall_angle,
            self.curve.len()
        )
    }
}

/// A map resolution for SPEC 3a: `None`, or a positive finite number of metres per cell.
fn checked_resolution(resolution: Option<f64>) -> PyResult<Option<f64>> {
    match resolution {
        Some(r) if !(r.is_finite() && r > 0.0) => Err(PyValueError::new_err(format!(
            "resolution must be a positive number, got {r}"
        ))),
        r => Ok(r),
    }
}

/// evaluate(values, unknown, params, threads=0, resolution=None, shade=None) -> RawQuality
///
/// The integers of SPEC sections 2-4 (and 3a) for one map. `params`: a `slamq.Params`;
/// `threads` = 0 uses every core; `resolution`: metres per cell, for `corners_canonical`;
/// `shade`: an array of the map's shape whose values give the unknown cells' shade
/// (`RawQuality.unknown_shade`; the loader's pixels), `None`: the map's values.
#[pyfunction]
#[pyo3(signature = (values, unknown, params, threads=0, resolution=None, shade=None))]
fn evaluate(
    py: Python<'_>,
    values: PyReadonlyArray2<'_, u8>,
    unknown: PyReadonlyArray2<'_, bool>,
    params: PyParams,
    threads: usize,
    resolution: Option<f64>,
    shade: Option<PyReadonlyArray2<'_, u8>>,
) -> PyResult<RawQuality> {
    let p = params.checked()?;
    let g = grid(&values, &unknown)?;
    let res = checked_resolution(resolution)?;
    let shade = match &shade {
        None => None,
        Some(s) if s.shape() != values.shape() => {
            return Err(PyValueError::new_err(format!(
                "shade shape {:?} differs from values shape {:?}",
                s.shape(),
                values.shape()
            )))
        }
        Some(s) => Some(
            s.as_slice()
                .map_err(|_| PyValueError::new_err("shade must be a C-contiguous uint8 array"))?,
        ),
    };
    let q = compute(py, threads, || evaluate_grid(&g, res, &p, shade))?;
    Ok(q.map_err(|e| memory_error(&e, None))?.into())
}

/// A `MemoryError` for a map whose working memory cannot be had (`index` in a list);
/// `slamq.metrics.evaluate` re-raises it as `slamq.OutOfMemoryError` naming the map.
fn memory_error(e: &OutOfMemory, index: Option<usize>) -> PyErr {
    match index {
        Some(i) => PyMemoryError::new_err(format!("map {i}: {e}")),
        None => PyMemoryError::new_err(e.to_string()),
    }
}

/// evaluate_many(maps, params, threads=0) -> list[RawQuality]: like `evaluate` for a list
/// of `(values, unknown, resolution)` triples, the maps in parallel.
#[pyfunction]
#[pyo3(signature = (maps, params, threads=0))]
fn evaluate_many<'py>(
    py: Python<'py>,
    maps: Vec<(
        PyReadonlyArray2<'py, u8>,
        PyReadonlyArray2<'py, bool>,
        Option<f64>,
    )>,
    params: PyParams,
    threads: usize,
) -> PyResult<Vec<RawQuality>> {
    let p = params.checked()?;
    let grids = maps
        .iter()
        .map(|(v, u, r)| Ok((grid(v, u)?, checked_resolution(*r)?)))
        .collect::<PyResult<Vec<_>>>()?;
    let qs = compute(py, threads, || evaluate_grids(&grids, &p))?;
    qs.into_iter()
        .enumerate()
        .map(|(i, q)| {
            q.map(RawQuality::from)
                .map_err(|e| memory_error(&e, Some(i)))
        })
        .collect()
}

/// map_saver_shades(grey) -> (list[int] | None, numpy.ndarray): which of map_saver's grey
/// levels (0, 205, 254, 255) a C-contiguous 2-D uint8 image holds, or None when it holds any
/// other value, and its unknown mask `grey == 205` (bool, the image's shape); one pass
/// without the GIL (`rust/src/pixels.rs`).
#[pyfunction]
#[allow(clippy::type_complexity)]
fn map_saver_shades<'py>(
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

/// default_params() -> dict: the core's own defaults (rust/src/params.rs), for the test that
/// keeps them equal to the Python table's.
#[pyfunction]
fn default_params(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let p = Params::default();
    let d = PyDict::new(py);
    d.set_item("log_threshold", p.corners.log_threshold)?;
    d.set_item("min_dot_area", p.corners.min_dot_area)?;
    d.set_item("harris_k", p.corners.harris_k)?;
    d.set_item("harris_quality", p.corners.harris_quality)?;
    d.set_item("canonical_resolution", p.corners.canonical_resolution)?;
    d.set_item("sweep_step", p.enclosed.sweep_step)?;
    d.set_item("min_area", p.enclosed.min_area)?;
    Ok(d)
}

/// read_table(path, sep, skip=0) -> numpy.ndarray | None: the numbers of a regular numeric
/// text table (`rust/src/table.rs`: `#` comments, blank lines skipped, `sep` " " for runs of
/// blanks or one separator byte, every row as long as the first, plain decimal numbers) as
/// a float64 array of shape (rows, cols); None when the file cannot be read or the table is
/// not regular (the caller's general parser then says why).
#[pyfunction]
#[pyo3(signature = (path, sep, skip=0))]
fn read_table<'py>(
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
fn read_tum<'py>(
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

/// A C-contiguous view of a float64 or int64 array, or a `ValueError` naming it.
fn contiguous<'a, T: numpy::Element>(
    a: &'a numpy::PyReadonlyArray<'_, T, impl numpy::ndarray::Dimension>,
    what: &str,
) -> PyResult<&'a [T]> {
    a.as_slice()
        .map_err(|_| PyValueError::new_err(format!("{what} must be a C-contiguous array")))
}

/// match_stamps(stamps_1, stamps_2, max_dt, offset_2=0.0) -> (i1, i2): int64 indices of the
/// best match in `stamps_2 + offset_2` (non-decreasing) of each of `stamps_1`, as
/// `slamq.metrics.sync.matching_indices` (`rust/src/ate.rs`).
#[pyfunction]
#[pyo3(signature = (stamps_1, stamps_2, max_dt, offset_2=0.0))]
#[allow(clippy::type_complexity)]
fn match_stamps<'py>(
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
fn ate_moments(
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
fn ate_errors<'py>(
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

/// The counts and sums of one ground-truth comparison (SPEC section 7); distances in
/// cells of the ground truth's grid. `slamq.MapComparison.from_counts` forms the figures.
#[pyclass(frozen, get_all, eq, module = "slamq._core")]
#[derive(PartialEq)]
struct RawComparison {
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
fn frame(what: &str, f: (f64, f64, f64, f64), height: usize, width: usize) -> PyResult<Frame> {
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
/// threads=0) -> (RawComparison, numpy.ndarray | None)
///
/// An estimate against a ground truth (SPEC section 7). Frames are `(resolution, x, y,
/// yaw)`; `tolerance` and `max_distance` are in cells of the ground truth's grid; `cells`
/// also returns the per-cell flags (uint8, the ground truth's shape).
#[pyfunction]
#[pyo3(signature = (est_values, est_unknown, est_frame, gt_values, gt_unknown, gt_frame,
                    tolerance=2.0, occupied_threshold=0.5, align="icp", max_distance=None,
                    cells=false, threads=0))]
#[allow(clippy::too_many_arguments)]
fn compare<'py>(
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
    let c = compute(py, threads, || {
        compare_maps(&estimate, &ground_truth, &params, cells)
    })?
    .map_err(|e| match e {
        CompareError::Edt(EdtError::Alloc { .. }) => PyMemoryError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    })?;
    let raw = RawComparison::from(&c);
    let flags = match c.cells {
        Some(v) => Some(PyArray1::from_vec(py, v).reshape([gg.height, gg.width])?),
        None => None,
    };
    Ok((raw, flags))
}

// ---------------------------------------------------------------------------------------
// Ground truth on demand: the simulator's laser (rust/src/raycast.rs).
// ---------------------------------------------------------------------------------------

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
fn raycast<'py>(
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
    let err = |e: crate::raycast::CastError| PyValueError::new_err(e.to_string());
    let ranges = compute(py, threads, || {
        let grid =
            crate::raycast::RayGrid::new(cells, h, w, resolution, [origin.0, origin.1, origin.2])?;
        crate::raycast::cast_scans(&grid, flat, a, max_range)
    })?
    .map_err(err)?;
    PyArray1::from_vec(py, ranges).reshape([n, b])
}

/// The Rust core of slamq.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate_many, m)?)?;
    m.add_function(wrap_pyfunction!(otsu_table, m)?)?;
    m.add_function(wrap_pyfunction!(read_table, m)?)?;
    m.add_function(wrap_pyfunction!(read_tum, m)?)?;
    m.add_function(wrap_pyfunction!(match_stamps, m)?)?;
    m.add_function(wrap_pyfunction!(ate_moments, m)?)?;
    m.add_function(wrap_pyfunction!(ate_errors, m)?)?;
    m.add_function(wrap_pyfunction!(default_params, m)?)?;
    m.add_function(wrap_pyfunction!(map_saver_shades, m)?)?;
    m.add_function(wrap_pyfunction!(adopt_thread, m)?)?;
    m.add("WORK_BYTES_PER_CELL", crate::evaluate::WORK_BYTES_PER_CELL)?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_function(wrap_pyfunction!(raycast, m)?)?;
    m.add_class::<RawQuality>()?;
    m.add_class::<RawComparison>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
