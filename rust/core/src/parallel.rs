//! The thread pool that kernels run their parallel parts on.
//!
//! Results never depend on the thread count: work is split at fixed
//! boundaries and combined in a fixed order; threads only change who
//! computes each piece.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

static THREADS: AtomicUsize = AtomicUsize::new(0);
static POOL: Mutex<Option<(usize, Arc<rayon::ThreadPool>)>> = Mutex::new(None);

/// Sets the number of threads kernels may use (0 = all cores).
pub fn set_threads(n: usize) {
    THREADS.store(n, Ordering::Relaxed);
}

/// The number of threads kernels will use.
pub fn threads() -> usize {
    match THREADS.load(Ordering::Relaxed) {
        0 => std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
        n => n,
    }
}

fn pool(n: usize) -> Option<Arc<rayon::ThreadPool>> {
    let mut guard = POOL.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((m, p)) = guard.as_ref() {
        if *m == n {
            return Some(p.clone());
        }
    }
    let p = Arc::new(rayon::ThreadPoolBuilder::new().num_threads(n).build().ok()?);
    *guard = Some((n, p.clone()));
    Some(p)
}

/// Runs `f` on a pool of [`threads()`] threads. With one thread `f` still
/// runs inside a one-thread pool, so `par_iter` inside it is serial.
pub fn run<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    match pool(threads()) {
        Some(p) => p.install(f),
        None => f(),
    }
}
