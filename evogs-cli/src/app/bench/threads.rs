//! [`Threads`]: a rayon thread pool of a chosen size that the bench runs its iterations in
//! (every parallel loop of the step, given `Par::Rayon`, then runs on that pool). Without
//! the `rayon` feature there is one thread.

use crate::app::error::CommandResult;
#[cfg(feature = "rayon")]
use crate::app::error::Context as _;

/// A pool of worker threads (one thread without the `rayon` feature).
#[derive(Debug)]
pub struct Threads {
    #[cfg(feature = "rayon")]
    pool: rayon::ThreadPool,
}

impl Threads {
    /// A pool of `count` threads (`None`: rayon's default, `RAYON_NUM_THREADS` or the
    /// number of logical CPUs).
    ///
    /// # Errors
    /// The pool cannot be started.
    pub fn new(count: Option<usize>) -> CommandResult<Self> {
        #[cfg(feature = "rayon")]
        {
            let mut b = rayon::ThreadPoolBuilder::new();
            if let Some(n) = count {
                b = b.num_threads(n);
            }
            let pool = b
                .thread_name(|i| format!("evogs-bench-{i}"))
                .build()
                .context("cannot start a pool of threads")?;
            Ok(Self { pool })
        }
        #[cfg(not(feature = "rayon"))]
        {
            let _ = count;
            Ok(Self {})
        }
    }

    /// The number of threads.
    #[must_use]
    pub fn count(&self) -> usize {
        #[cfg(feature = "rayon")]
        {
            self.pool.current_num_threads()
        }
        #[cfg(not(feature = "rayon"))]
        {
            1
        }
    }

    /// Runs `f` on the pool and returns its result.
    pub fn run<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        #[cfg(feature = "rayon")]
        {
            self.pool.install(f)
        }
        #[cfg(not(feature = "rayon"))]
        {
            f()
        }
    }
}
