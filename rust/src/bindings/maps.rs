//! Bindings of the three map metrics (rust/src/evaluate.rs): `evaluate`, `evaluate_many`,
//! `otsu_table`, `wall_harmonics`, `default_params`, and the `RawQuality` they return.

use super::grid;
use super::runtime::compute;
use crate::evaluate::{evaluate as evaluate_grid, evaluate_many as evaluate_grids, Quality};
use crate::memory::OutOfMemory;
use crate::params::{CornerParams, EnclosedParams, Params};
use numpy::{PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyMemoryError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The metric parameters as the Python side gives them: any object with these attributes,
/// normally a `slamq.Params` (python/slamq/params.py, the table of names, ranges and units).
#[derive(FromPyObject)]
pub(crate) struct PyParams {
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
pub(crate) struct RawQuality {
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
    /// The wall-direction sums of SPEC 3a.2, `(re4, im4, re6, im6, weight)`: the fourth
    /// and sixth harmonic of the gradient directions and the gradient weight, each term
    /// rounded; `slamq.models.quality.wall_symmetry` classifies the map from them.
    wall_harmonics: (i64, i64, i64, i64, i64),
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
            && self.wall_harmonics == o.wall_harmonics
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
            wall_harmonics: q.wall_sums.to_tuple(),
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
pub(crate) fn evaluate(
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
pub(crate) fn evaluate_many<'py>(
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

/// default_params() -> dict: the core's own defaults (rust/src/params.rs), for the test that
/// keeps them equal to the Python table's.
#[pyfunction]
pub(crate) fn default_params(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
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

/// otsu_table(values, unknown) -> list[int]: T_u for u = 0..255 (SPEC section 4 step 2).
#[pyfunction]
pub(crate) fn otsu_table(
    py: Python<'_>,
    values: PyReadonlyArray2<'_, u8>,
    unknown: PyReadonlyArray2<'_, bool>,
) -> PyResult<Vec<u8>> {
    let g = grid(&values, &unknown)?;
    let t = compute(py, 0, || crate::otsu::threshold_table(&g.histogram()))?;
    Ok(t.to_vec())
}

/// wall_harmonics(values, unknown, threads=0) -> (re4, im4, re6, im6, weight): the
/// wall-direction sums of SPEC 3a.2 alone (`RawQuality.wall_harmonics` without the metrics),
/// for the defect detectors' wall period.
#[pyfunction]
#[pyo3(signature = (values, unknown, threads=0))]
pub(crate) fn wall_harmonics(
    py: Python<'_>,
    values: PyReadonlyArray2<'_, u8>,
    unknown: PyReadonlyArray2<'_, bool>,
    threads: usize,
) -> PyResult<(i64, i64, i64, i64, i64)> {
    let g = grid(&values, &unknown)?;
    let sums = compute(py, threads, || {
        crate::canonical::wall_sums_in(&g, crate::grid::known_bounds(&g))
    })?;
    Ok(sums.map_err(|e| memory_error(&e, None))?.to_tuple())
}
