//! Every metric parameter of the spec (docs/spec.md sections 3-4) and its default.
//!
//! The Python table `python/slamq/params.py` is the source of names, ranges, units and help
//! text; the bindings (`python.rs`) read a Python `slamq.Params` into [`Params`], and a test
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
}

impl Default for CornerParams {
    fn default() -> Self {
        CornerParams {
            log_threshold: 0.1,
            min_dot_area: 5,
            harris_k: 0.04,
            harris_quality: 0.01,
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
