//! The `threads` argument of the bindings.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// Runs `f` on `threads` threads (None: rayon's global pool, all cores).
pub(super) fn with_threads<R: Send>(
    threads: Option<usize>,
    f: impl FnOnce() -> R + Send,
) -> PyResult<R> {
    match threads {
        None => Ok(f()),
        Some(0) => Err(PyValueError::new_err(
            "threads must be a positive integer or None",
        )),
        // (kalmanfield._validation.MAX_THREADS: thousands of threads only queue)
        Some(k) if k > 1024 => Err(PyValueError::new_err(format!(
            "threads must lie in 1..=1024 (or None: all cores), got {k}"
        ))),
        // a fresh pool per call: a pool thread that built a plan (faer's AVX-512 kernels) ran
        // the later filters 1.5–2× slower when pools were kept (measured)
        Some(k) => {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(k)
                .build()
                .map_err(|e| PyValueError::new_err(format!("cannot start {k} threads: {e}")))?;
            Ok(pool.install(f))
        }
    }
}
