//! Bits of the per-cell flags [`super::Comparison::cells`] holds (one byte per
//! ground-truth cell).

/// The aligned estimate is occupied here (a cell of E).
pub const ESTIMATE: u8 = 1;
/// The ground truth is occupied here (a cell of G).
pub const GROUND_TRUTH: u8 = 2;
/// A cell of E within the tolerance of G (a matched estimate wall).
pub const ESTIMATE_MATCHED: u8 = 4;
/// A cell of G within the tolerance of E (a ground-truth wall the estimate has).
pub const GROUND_TRUTH_MATCHED: u8 = 8;
/// The aligned estimate knows this cell.
pub const ESTIMATE_KNOWN: u8 = 16;
/// The ground truth says this cell is free.
pub const GROUND_TRUTH_FREE: u8 = 32;
