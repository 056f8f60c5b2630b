//! slamq core: the three no-reference 2D SLAM map metrics of Filatov et al. (arXiv 1708.02354),
//! as pinned down by docs/spec.md, on borrowed occupancy grids.
//!
//! Module map (one idea per file, a directory where an idea has parts; nothing here knows
//! about Python except `bindings`; no module uses itself through others, which
//! rust/tests/module_graph.rs checks):
//! - [`grid`]: the borrowed map view and its checks, the value histogram, the known cells'
//!   bounding box, row bands.
//! - [`pixels`]: the loader's one pass over a map_saver image (its shades, its unknown mask).
//! - [`border`]: reflect-101 indexing shared by every filter.
//! - [`filter`]: integer binomial blur + Laplacian (the Harris sums are tabulated per 4x4
//!   mask window in [`corners`]).
//! - [`label`]: 8-connected labelling of binary images by runs (union-find, parallel bands).
//! - [`otsu`]: OpenCV-exact Otsu, and the threshold for every unknown value.
//! - [`memory`]: the working memory of an evaluation (its fallible reservation).
//! - [`params`]: every metric parameter and its default.
//! - [`proportion`]: SPEC section 2.
//! - [`corners`]: SPEC section 3.
//! - [`canonical`]: SPEC section 3a, corners of the map turned to its walls' direction and
//!   resampled to a reference resolution (`canonical/`: the packed box, the wall angle, the
//!   resample).
//! - [`enclosed`]: SPEC section 4, the sweep over unknown values.
//! - [`evaluate`]: all three metrics of one map, and of many maps in parallel.
//! - [`edt`]: exact Euclidean distance transform with nearest cells (SPEC section 7).
//! - [`se2`]: planar rigid motions, map frames, maps placed in them, the closed-form rigid
//!   fit.
//! - [`error`]: the error of [`compare`] and [`register`] (bad input, memory).
//! - [`icp`]: trimmed SE(2) ICP onto a distance transform.
//! - [`compare`]: a map against a ground-truth map, SPEC section 7 (`compare/`: the SIMD
//!   scan, the resampling onto the ground truth's grid, the distances, the cell flags).
//! - [`register`]: global registration of two maps of one place (any rotation, other
//!   resolution and extent), SPEC section 7a.
//! - [`ate`]: the absolute trajectory error's passes over the poses (association, Umeyama
//!   sums, errors, statistics); [`table`]: the numeric text table and TUM pose reader.
//! - [`raycast`]: exact laser ray casting on a grid (Amanatides-Woo), the simulator's
//!   sensor for ground truth on demand.
//! - [`scans`]: a map against its own laser scans (hits, free-space violations), SPEC
//!   section 7b.
//! - [`split`]: a trajectory against its own scans, split in time (two halves drawn as
//!   maps, each scored by the other), SPEC section 7e.
//! - `bindings` (feature `python`): the pyo3 bindings, one file per domain, and their
//!   runtime (thread pools, fork handling); nothing else.

// Stencil loops index several rows at offsets from one column index; iterator chains would
// hide the arithmetic the SPEC describes.
#![allow(clippy::needless_range_loop)]

pub mod ate;
pub mod border;
pub mod canonical;
pub mod compare;
pub mod corners;
pub mod degeneracy;
pub mod edt;
pub mod enclosed;
pub mod error;
pub mod evaluate;
pub mod filter;
pub mod grid;
pub mod icp;
pub mod label;
pub mod memory;
pub mod otsu;
pub mod params;
pub mod pixels;
pub mod proportion;
pub mod raycast;
pub mod register;
pub mod scans;
pub mod se2;
pub mod split;
pub mod table;

#[cfg(feature = "python")]
mod bindings;
