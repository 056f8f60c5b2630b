//! Every metric parameter of the spec (docs/spec.md sections 3-4) and its default.
//!
//! The Python table `python/slamq/params.py` is the source of names, ranges, units and help
//! text; the bindings (`bindings/maps.rs`) read a Python `slamq.Params` into [`Params`], and a test
//! (`tests/test_params.py`) checks that the defaults here equal the Python ones.

/// Parameters of SPEC section 3 (defaults in `Default`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CornerParams {
    /// Structure mask: `L > log_threshold * 255 * 256`.
    pub log_threshold: f64,
    /// Mask components with fewer cells are dropped.
    pub min_dot_area: u32,
    /// Harris `k`.
    pub harris_k: f64,
    /// Corner mask: `R > harris_quality * max R`.
    pub harris_quality: f64,
    /// SPEC 3a: `corners_canonical` resamples to this resolution (metres per cell); 0 (the
    /// default) skips it (the wall angle is computed either way).
    pub canonical_resolution: f64,
}

impl Default for CornerParams {
    fn default() -> Self {
        CornerParams {
            log_threshold: 0.1,
            min_dot_area: 5,
            harris_k: 0.04,
            harris_quality: 0.01,
            canonical_resolution: 0.0,
        }
    }
}

/// Parameters of SPEC section 4.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EnclosedParams {
    /// `u` runs over `(0..256).step_by(sweep_step)`.
    pub sweep_step: usize,
    /// Components smaller than this are not counted.
    pub min_area: u32,
}

impl Default for EnclosedParams {
    fn default() -> Self {
        EnclosedParams {
            sweep_step: 1,
            min_area: 1,
        }
    }
}

/// Every parameter of SPEC sections 3-4.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Params {
    /// SPEC section 3.
    pub corners: CornerParams,
    /// SPEC section 4.
    pub enclosed: EnclosedParams,
}

/// How the estimate is aligned with the ground truth before comparing (SPEC section 7).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Align {
    /// The frames the map files give (resolution, origin), nothing more.
    Origin,
    /// Those frames, refined by trimmed ICP on the occupied cells.
    Icp,
    /// A coarse search over rotations (and centroid translation) first, then ICP: for maps
    /// saved in an arbitrary frame.
    Search,
}

impl Align {
    /// The name the API uses.
    pub fn name(&self) -> &'static str {
        match self {
            Align::Origin => "origin",
            Align::Icp => "icp",
            Align::Search => "search",
        }
    }

    /// Parse a name of [`Align::name`].
    pub fn from_name(name: &str) -> Option<Align> {
        match name {
            "origin" => Some(Align::Origin),
            "icp" => Some(Align::Icp),
            "search" => Some(Align::Search),
            _ => None,
        }
    }
}

/// Parameters of the ground-truth map comparison (SPEC section 7).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompareParams {
    /// A cell matches when the other map has an occupied cell within this distance, in
    /// cells of the ground truth's grid.
    pub tolerance: f64,
    /// Occupied: a known cell whose occupancy probability `(255 - v) / 255` is above this.
    pub occupied_threshold: f64,
    pub align: Align,
    /// Distances above this (in cells of the ground truth's grid) count as this much.
    pub max_distance: Option<f64>,
    /// Share of the ICP's correspondences dropped (the worst) at every iteration.
    pub trim: f64,
    /// At most this many ICP iterations.
    pub max_iterations: usize,
}

impl Default for CompareParams {
    fn default() -> Self {
        CompareParams {
            tolerance: 2.0,
            occupied_threshold: 0.5,
            align: Align::Icp,
            max_distance: None,
            trim: 0.2,
            max_iterations: 100,
        }
    }
}
