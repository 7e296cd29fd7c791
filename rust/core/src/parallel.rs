//! Thread counts and the pools that kernels run their parallel parts on.
//!
//! A thread count belongs to a call: every entry point takes the count it
//! may use ([`run_with`] installs a pool of exactly that many threads for
//! the duration of the call), so concurrent callers with different counts
//! never see each other's setting. [`set_default_threads`] only sets what
//! a call that names no count gets.
//!
//! Results never depend on the thread count: work is split at fixed
//! boundaries and combined in a fixed order; threads only change who
//! computes each piece.

use crate::error::KernelError;
use std::collections::HashMap;
use std::sync::atomic::{AtomicPtr, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

/// The default of calls that name no count (0 = every core).
static DEFAULT: AtomicUsize = AtomicUsize::new(0);
/// One pool per thread count asked for, kept for later calls (at most
/// [`max_threads`] of them; a pool's threads sleep while it is unused), in
/// this process (see [`PerProcess`]).
static POOLS: PerProcess<Pools> = PerProcess::new();

/// The pools of one process, by thread count.
type Pools = HashMap<usize, Arc<rayon::ThreadPool>>;

/// The cores this process may run on (asked once: the answer reads cgroup
/// files, which would cost more than a short kernel call).
pub fn cores() -> usize {
    static CORES: std::sync::OnceLock<usize> = std::sync::OnceLock::new();
    *CORES.get_or_init(|| std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1))
}

/// The largest thread count a call may ask for: 4 x [`cores`].
pub fn max_threads() -> usize {
    4 * cores()
}

/// Checks a thread count asked for (1 ..= [`max_threads`]).
pub fn check_threads(n: usize) -> Result<usize, KernelError> {
    let max = max_threads();
    if n == 0 || n > max {
        return Err(KernelError::Invalid(format!(
            "threads must be in [1, {max}] (4 x the {} cores), got {n}",
            cores()
        )));
    }
    Ok(n)
}

/// Sets the count of calls that name none (0 = every core).
pub fn set_default_threads(n: usize) -> Result<(), KernelError> {
    if n != 0 {
        check_threads(n)?;
    }
    DEFAULT.store(n, Ordering::Relaxed);
    Ok(())
}

/// The count of calls that name none.
pub fn default_threads() -> usize {
    match DEFAULT.load(Ordering::Relaxed) {
        0 => cores(),
        n => n,
    }
}

/// The count a call uses: the one it names (checked), else the default.
pub fn resolve(n: Option<usize>) -> Result<usize, KernelError> {
    match n {
        Some(n) => check_threads(n),
        None => Ok(default_threads()),
    }
}

fn pool(n: usize) -> Result<Arc<rayon::ThreadPool>, KernelError> {
    let mut pools = POOLS.lock(HashMap::new);
    if let Some(p) = pools.get(&n) {
        return Ok(p.clone());
    }
    let p = rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .thread_name(|i| format!("tribodyn-{i}"))
        .build()
        .map_err(|e| KernelError::Invalid(format!("cannot start {n} kernel threads: {e}")))?;
    let p = Arc::new(p);
    pools.insert(n, p.clone());
    Ok(p)
}

/// A value behind a lock that belongs to one process: a child made by `fork` (Python's multiprocessing)
/// gets a fresh one on its first use instead of the parent's copy.
///
/// The copy is unusable in the child: its lock may have been held by another of the parent's threads at
/// the moment of the fork (that thread does not exist in the child, so the lock would never be released
/// and the child would wait forever), and what it holds may refer to the parent's threads (a pool's
/// workers). The copy is left alone, never dropped (dropping a pool would signal threads that are not
/// there): one value leaked per fork that uses it.
pub struct PerProcess<T> {
    slot: AtomicPtr<(u32, Mutex<T>)>,
}

impl<T> PerProcess<T> {
    /// Empty until the first [`PerProcess::lock`].
    pub const fn new() -> PerProcess<T> {
        PerProcess { slot: AtomicPtr::new(std::ptr::null_mut()) }
    }

    /// This process's value, locked (made by `init` on its first use in this process).
    pub fn lock(&'static self, init: impl Fn() -> T) -> std::sync::MutexGuard<'static, T> {
        let pid = std::process::id();
        let mut seen = self.slot.load(Ordering::Acquire);
        loop {
            // SAFETY: a non-null pointer in the slot came from Box::into_raw below and is never freed
            // once stored (values are leaked, not dropped), so it stays valid for 'static.
            if let Some((owner, value)) = unsafe { seen.as_ref() } {
                if *owner == pid {
                    return value.lock().unwrap_or_else(|e| e.into_inner());
                }
            }
            let fresh = Box::into_raw(Box::new((pid, Mutex::new(init()))));
            match self.slot.compare_exchange(seen, fresh, Ordering::AcqRel, Ordering::Acquire) {
                Ok(_) => seen = fresh,
                Err(now) => {
                    // Another thread of this process stored its value first: ours was never shared.
                    // SAFETY: `fresh` came from Box::into_raw above and was not stored.
                    drop(unsafe { Box::from_raw(fresh) });
                    seen = now;
                }
            }
        }
    }
}

impl<T> Default for PerProcess<T> {
    fn default() -> Self {
        Self::new()
    }
}

/// Runs `f` on a pool of exactly `threads` threads (checked); `par_iter`
/// and `rayon::join` inside `f` use that pool and [`current`] reports its
/// size. With one thread `f` still runs inside a one-thread pool, so
/// parallel iterators in it are serial.
pub fn run_with<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> Result<R, KernelError> {
    Ok(pool(check_threads(threads)?)?.install(f))
}

/// The threads of the pool the caller runs on (inside [`run_with`]); 1 on
/// a thread outside every pool, where parallel iterators would otherwise
/// fall back to rayon's global pool.
pub fn current() -> usize {
    if rayon::current_thread_index().is_some() {
        rayon::current_num_threads()
    } else {
        1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_are_checked_not_panicking() {
        assert!(check_threads(0).is_err());
        assert!(check_threads(max_threads() + 1).is_err());
        assert!(run_with(30_000, || 1).is_err());
        assert_eq!(run_with(2, current).unwrap(), 2);
        assert_eq!(run_with(1, current).unwrap(), 1);
        assert_eq!(current(), 1);
    }

    #[cfg(unix)]
    #[test]
    fn a_child_forked_while_another_thread_holds_the_lock_gets_its_own_value() {
        use std::time::{Duration, Instant};
        static VALUE: PerProcess<u32> = PerProcess::new();
        *VALUE.lock(|| 7) = 8;
        let (held_tx, held_rx) = std::sync::mpsc::channel();
        let (release_tx, release_rx) = std::sync::mpsc::channel::<()>();
        let holder = std::thread::spawn(move || {
            let guard = VALUE.lock(|| 7);
            held_tx.send(()).unwrap();
            release_rx.recv().unwrap();
            drop(guard);
        });
        held_rx.recv().unwrap();
        // SAFETY: the child only takes the lock (one allocation: glibc's malloc is fork-safe) and exits.
        let pid = unsafe { libc::fork() };
        if pid == 0 {
            let fresh = *VALUE.lock(|| 7);
            unsafe { libc::_exit(if fresh == 7 { 0 } else { 3 }) };
        }
        let (mut status, deadline) = (0, Instant::now() + Duration::from_secs(20));
        let waited = loop {
            // SAFETY: waiting for our own child.
            if unsafe { libc::waitpid(pid, &mut status, libc::WNOHANG) } == pid {
                break true;
            }
            if Instant::now() > deadline {
                unsafe {
                    libc::kill(pid, libc::SIGKILL);
                    libc::waitpid(pid, &mut status, 0);
                }
                break false;
            }
            std::thread::sleep(Duration::from_millis(10));
        };
        release_tx.send(()).unwrap();
        holder.join().unwrap();
        assert!(waited, "the forked child waited for the lock its parent's thread held");
        assert!(libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0, "child status {status}");
        assert_eq!(*VALUE.lock(|| 7), 8, "the parent's value is kept");
    }

    #[test]
    fn concurrent_calls_keep_their_counts() {
        let handles: Vec<_> = (0..8)
            .map(|i| {
                std::thread::spawn(move || {
                    let n = 1 + i % max_threads().min(3);
                    (0..50).all(|_| run_with(n, current).unwrap() == n)
                })
            })
            .collect();
        assert!(handles.into_iter().all(|h| h.join().unwrap()));
    }
}
