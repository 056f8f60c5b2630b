//! The runtime of the bindings: the rayon pools the core's work runs on (per calling thread,
//! by size; one shared pool of every core), their remaking after a fork, adopted threads,
//! and [`compute`] / [`detached`], which run work without the GIL and turn a panic into a
//! Python error. No metric knows about it; every binding calls it.

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
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
pub(crate) fn adopt_thread() -> PyResult<bool> {
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
pub(crate) fn compute<T: Send>(
    py: Python<'_>,
    threads: usize,
    f: impl FnOnce() -> T + Send,
) -> PyResult<T> {
    let pool = pool(threads)?;
    detached(py, move || pool.install(f))
}

/// Run sequential work `f` on the calling thread without the GIL (no pool: no hand-over to
/// another thread), a panic turned into a Python `RuntimeError`.
pub(crate) fn detached<T: Send>(py: Python<'_>, f: impl FnOnce() -> T + Send) -> PyResult<T> {
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
