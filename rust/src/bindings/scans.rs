//! A map against its own laser scans (`rust/src/scans.rs`, SPEC section 7b), scans that
//! see walls in one direction only (`rust/src/degeneracy.rs`, section 7c), and a
//! trajectory against its own scans split in time (`rust/src/split.rs`, section 7e).

use super::runtime::compute;
use super::{contiguous, grid};
use crate::scans::{consistency, ScanError, ScanGrid};
use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// The counts of every scan, the violation grid and the crossing grid.
type Scored<'py> = (
    Bound<'py, PyArray2<i64>>,
    Bound<'py, PyArray2<u32>>,
    Bound<'py, PyArray2<u32>>,
);

/// A recording's scan count and its poses, angles and ranges as flat slices.
type Flat<'a> = (usize, &'a [f64], &'a [f64], &'a [f64]);

/// The laser poses `(n, 3)`, beam angles `(b,)` and ranges `(n, b)` of a recording, checked
/// for shape and contiguity.
fn recording<'a>(
    poses: &'a PyReadonlyArray2<'_, f64>,
    angles: &'a PyReadonlyArray1<'_, f64>,
    ranges: &'a PyReadonlyArray2<'_, f64>,
) -> PyResult<Flat<'a>> {
    if poses.shape()[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "poses must have shape (n, 3), got {:?}",
            poses.shape()
        )));
    }
    let n = poses.shape()[0];
    let b = angles.shape()[0];
    if ranges.shape() != [n, b] {
        return Err(PyValueError::new_err(format!(
            "ranges must have shape ({n}, {b}) for {n} poses and {b} angles, got {:?}",
            ranges.shape()
        )));
    }
    Ok((
        n,
        contiguous(poses, "poses")?,
        contiguous(angles, "angles")?,
        contiguous(ranges, "ranges")?,
    ))
}

/// scan_consistency(values, unknown, resolution, origin, occupied_threshold, tolerance,
/// poses, angles, ranges, min_range, max_range, threads=0) -> (counts, violations,
/// crossings)
///
/// A map against its own scans (SPEC section 7b): `values` and `unknown` the map's
/// C-contiguous `(H, W)` uint8 and bool arrays (row 0 at the top); `resolution` metres per
/// cell; `origin` `(x, y, yaw)` of its lower-left corner; `occupied_threshold` on
/// `(255 - v) / 255`; `tolerance` metres (> 0); `poses` `(n, 3)` float64 laser poses in the
/// world frame; `angles` `(b,)` float64 beam angles relative to the yaw; `ranges` `(n, b)`
/// float64 metres (valid when finite and `min_range < r < max_range`). Returns `counts`
/// `(n, 7)` int64 (valid, hits, misses, unknown, outside, violations, crossings per
/// scan), `violations` `(H, W)` uint32 (beams that passed through each occupied cell)
/// and `crossings` `(H, W)` uint32 (of those, the beams that crossed a wall); scans in
/// parallel without the GIL, the same numbers for any `threads` (0 = every core).
#[pyfunction]
#[pyo3(signature = (values, unknown, resolution, origin, occupied_threshold, tolerance, poses,
                    angles, ranges, min_range, max_range, threads=0))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn scan_consistency<'py>(
    py: Python<'py>,
    values: PyReadonlyArray2<'py, u8>,
    unknown: PyReadonlyArray2<'py, bool>,
    resolution: f64,
    origin: (f64, f64, f64),
    occupied_threshold: f64,
    tolerance: f64,
    poses: PyReadonlyArray2<'py, f64>,
    angles: PyReadonlyArray1<'py, f64>,
    ranges: PyReadonlyArray2<'py, f64>,
    min_range: f64,
    max_range: f64,
    threads: usize,
) -> PyResult<Scored<'py>> {
    let map = grid(&values, &unknown)?;
    let (h, w) = (map.height, map.width);
    let (n, flat, a, r) = recording(&poses, &angles, &ranges)?;
    let (v, u) = (map.values, map.unknown);
    let err = |e: ScanError| PyValueError::new_err(e.to_string());
    let out = compute(py, threads, || {
        let g = ScanGrid::new(
            v,
            u,
            h,
            w,
            resolution,
            [origin.0, origin.1, origin.2],
            occupied_threshold,
            tolerance,
        )?;
        consistency(&g, flat, a, r, min_range, max_range)
    })?
    .map_err(err)?;
    let counts = PyArray1::from_vec(py, out.counts).reshape([n, crate::scans::COLUMNS.len()])?;
    let grid = PyArray1::from_vec(py, out.violations).reshape([h, w])?;
    let crossed = PyArray1::from_vec(py, out.crossings).reshape([h, w])?;
    Ok((counts, grid, crossed))
}

/// scan_ratios(angles, ranges, min_range, max_range, threads=0) -> ratios
///
/// Scans that see walls in one direction only (SPEC section 7c): `angles` `(b,)` float64
/// beam angles (any order), `ranges` `(n, b)` float64 metres. Returns `(n,)` float64: per
/// scan the smaller over the larger eigenvalue of its straight wall stretches' normals'
/// sum `n n^T` (NaN: too few such endpoints); scans in parallel without the GIL, the same
/// numbers for any `threads` (0 = every core).
#[pyfunction]
#[pyo3(signature = (angles, ranges, min_range, max_range, threads=0))]
pub(crate) fn scan_ratios<'py>(
    py: Python<'py>,
    angles: PyReadonlyArray1<'py, f64>,
    ranges: PyReadonlyArray2<'py, f64>,
    min_range: f64,
    max_range: f64,
    threads: usize,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let b = angles.shape()[0];
    if ranges.shape()[1] != b {
        return Err(PyValueError::new_err(format!(
            "ranges must have shape (n, {b}) for {b} angles, got {:?}",
            ranges.shape()
        )));
    }
    if b == 0 {
        // no beam, no endpoint: no scan has a ratio
        return Ok(PyArray1::from_vec(py, vec![f64::NAN; ranges.shape()[0]]));
    }
    let a = contiguous(&angles, "angles")?;
    let r = contiguous(&ranges, "ranges")?;
    let out = compute(py, threads, || {
        crate::degeneracy::scan_ratios(a, r, min_range, max_range)
    })?
    .map_err(|e| PyValueError::new_err(e.to_string()))?;
    Ok(PyArray1::from_vec(py, out))
}

/// The counts of both halves' tested scans, each half's drawn map (values, unknown) and
/// the drawn maps' lower-left corner.
type Halves<'py> = (
    (Bound<'py, PyArray2<i64>>, Bound<'py, PyArray2<i64>>),
    (Bound<'py, PyArray2<u8>>, Bound<'py, PyArray2<bool>>),
    (Bound<'py, PyArray2<u8>>, Bound<'py, PyArray2<bool>>),
    (f64, f64),
);

/// Scan indices from an int64 array, each in `0..n`.
fn indices(a: &PyReadonlyArray1<'_, i64>, what: &str, n: usize) -> PyResult<Vec<usize>> {
    contiguous(a, what)?
        .iter()
        .map(|&k| {
            usize::try_from(k)
                .ok()
                .filter(|&k| k < n)
                .ok_or_else(|| PyValueError::new_err(format!("{what}: scan {k} is not in 0..{n}")))
        })
        .collect()
}

/// scan_split(poses, angles, ranges, min_range, max_range, drawn_1, tested_1, drawn_2,
/// tested_2, resolution, margin, occupied_share, tolerance, threads=0)
/// -> ((counts_1, counts_2), (values_1, unknown_1), (values_2, unknown_2), (x0, y0))
///
/// A trajectory against its own scans, split in time (SPEC section 7e): `poses` `(n, 3)`
/// float64 laser poses in the world frame, `angles` `(b,)`, `ranges` `(n, b)` as in
/// `scan_consistency`; `drawn_i` and `tested_i` int64 scan indices: the scans drawn as map
/// `i` (`resolution` metres per cell, `margin` metres around every drawn scan, a cell
/// occupied when its hits are at least `occupied_share` of its visits) and the scans
/// scored against it by SPEC 7b with `tolerance` metres. Returns the tested scans' counts
/// `(len(tested_i), 7)` int64, the two maps `(H, W)` (uint8 0 / 254 / 205 and the unknown
/// mask, row 0 at the top) and their lower-left corner; without the GIL, the same numbers
/// for any `threads` (0 = every core).
#[pyfunction]
#[pyo3(signature = (poses, angles, ranges, min_range, max_range, drawn_1, tested_1, drawn_2,
                    tested_2, resolution, margin, occupied_share, tolerance, threads=0))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn scan_split<'py>(
    py: Python<'py>,
    poses: PyReadonlyArray2<'py, f64>,
    angles: PyReadonlyArray1<'py, f64>,
    ranges: PyReadonlyArray2<'py, f64>,
    min_range: f64,
    max_range: f64,
    drawn_1: PyReadonlyArray1<'py, i64>,
    tested_1: PyReadonlyArray1<'py, i64>,
    drawn_2: PyReadonlyArray1<'py, i64>,
    tested_2: PyReadonlyArray1<'py, i64>,
    resolution: f64,
    margin: f64,
    occupied_share: f64,
    tolerance: f64,
    threads: usize,
) -> PyResult<Halves<'py>> {
    let (n, flat, a, r) = recording(&poses, &angles, &ranges)?;
    let d1 = indices(&drawn_1, "drawn_1", n)?;
    let t1 = indices(&tested_1, "tested_1", n)?;
    let d2 = indices(&drawn_2, "drawn_2", n)?;
    let t2 = indices(&tested_2, "tested_2", n)?;
    let params = crate::split::SplitParams {
        resolution,
        margin,
        occupied_share,
        tolerance,
    };
    let out = compute(py, threads, || {
        crate::split::split(
            flat,
            a,
            r,
            min_range,
            max_range,
            [(&d1, &t1), (&d2, &t2)],
            &params,
        )
    })?
    .map_err(|e: ScanError| PyValueError::new_err(e.to_string()))?;
    let (h, w) = (out.frame.height, out.frame.width);
    let cols = crate::scans::COLUMNS.len();
    let [c1, c2] = out.counts;
    let counts = (
        PyArray1::from_vec(py, c1).reshape([t1.len(), cols])?,
        PyArray1::from_vec(py, c2).reshape([t2.len(), cols])?,
    );
    let [m1, m2] = out.maps;
    let map = |m: crate::split::Drawn| -> PyResult<_> {
        Ok((
            PyArray1::from_vec(py, m.values).reshape([h, w])?,
            PyArray1::from_vec(py, m.unknown).reshape([h, w])?,
        ))
    };
    Ok((
        counts,
        map(m1)?,
        map(m2)?,
        (out.frame.origin[0], out.frame.origin[1]),
    ))
}
