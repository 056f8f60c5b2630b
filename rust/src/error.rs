//! The error of the functions that take maps with their frames ([`crate::compare`],
//! [`crate::register`]): input out of range, or the distance transform's size or memory.

use crate::edt::EdtError;
use std::fmt;

/// Why maps could not be compared or registered (a registration's refusal is not an error
/// but a [`crate::register::Registration`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Error {
    /// A resolution that is not a positive finite number, a frame whose size differs from
    /// its grid's, or a parameter out of range.
    Invalid(String),
    /// The distance transform failed (size, memory).
    Edt(EdtError),
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Invalid(s) => f.write_str(s),
            Error::Edt(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for Error {}

impl From<EdtError> for Error {
    fn from(e: EdtError) -> Self {
        Error::Edt(e)
    }
}
