//! The working memory of one evaluation: how much a cell may cost at the peak, and the
//! fallible reservation that turns a memory limit into an error instead of an abort.
//! Below every metric module (`evaluate` and `canonical` both use it).

/// Bytes of working memory per cell that one evaluation may hold at its peak: the sweep's
/// forest (4) and value order (4), or the corner step's mask (1) and Harris ranks (2), and
/// the runs of a binarisation with their union-find arrays (up to about 10 for a checkerboard: 20 bytes a
/// run, half a run a cell), rounded up.
pub const WORK_BYTES_PER_CELL: usize = 16;

/// The working memory of an evaluation could not be reserved (a memory limit, e.g.
/// `ulimit -v`, or a map too large for this machine).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OutOfMemory {
    /// The bytes asked for.
    pub bytes: usize,
}

impl std::fmt::Display for OutOfMemory {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "cannot reserve {} MiB of working memory for the evaluation",
            self.bytes.div_ceil(1 << 20)
        )
    }
}

/// Check, before any big buffer is allocated, that the peak working memory of evaluating a
/// map of `cells` cells can be had: reserve it fallibly (address space only, never touched)
/// and free it. An infallible allocation failing later would abort the whole process
/// (`handle_alloc_error`); this turns the common case, a memory limit, into an error.
pub fn reserve_working_set(cells: usize) -> Result<(), OutOfMemory> {
    let bytes = cells.saturating_mul(WORK_BYTES_PER_CELL);
    let mut probe: Vec<u8> = Vec::new();
    probe
        .try_reserve_exact(bytes)
        .map_err(|_| OutOfMemory { bytes })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_working_set_that_cannot_exist_is_an_error_not_an_abort() {
        assert!(reserve_working_set(1 << 20).is_ok());
        let err = reserve_working_set(usize::MAX / 2).unwrap_err();
        assert_eq!(err.bytes, usize::MAX);
        assert!(err.to_string().contains("MiB of working memory"));
    }
}
