//! The processes of one command under an MPI launcher (`mpirun -np K evogs ...`,
//! `srun evogs ...`), with the `mpi` feature: `Mpi`, the MPI implementation of evogs's
//! [`Collective`](evogs::train::collective::Collective).
//!
//! Every exchange is an all-gather in rank order, started as a non-blocking collective and
//! waited on with a deadline (`EVOGS_MPI_TIMEOUT` seconds, default 600): a rank that died or
//! hangs ends the whole job with an error naming the waiting rank and the deadline, through
//! `MPI_Abort`, instead of leaving the others blocked forever.

#[cfg(feature = "mpi")]
pub use with_mpi::Mpi;

/// Whether this process was started by an MPI launcher (Open MPI, MPICH/Hydra, `PMIx` or
/// Slurm's PMI): the command then joins the job's other processes.
#[must_use]
pub fn launched_by_mpi() -> bool {
    [
        "OMPI_COMM_WORLD_SIZE",
        "PMI_SIZE",
        "PMIX_RANK",
        "MPI_LOCALNRANKS",
    ]
    .iter()
    .any(|v| std::env::var_os(v).is_some())
}

/// The deadline of one exchange: `EVOGS_MPI_TIMEOUT` seconds (a positive number), else 600.
///
/// # Errors
/// The variable is set to something that is not a positive number of seconds.
pub fn timeout() -> Result<std::time::Duration, String> {
    match std::env::var("EVOGS_MPI_TIMEOUT") {
        Err(_) => Ok(std::time::Duration::from_secs(600)),
        Ok(s) => match s.trim().parse::<f64>() {
            Ok(v) if v.is_finite() && v > 0.0 && v < 1e9 => {
                Ok(std::time::Duration::from_secs_f64(v))
            }
            _ => Err(format!(
                "EVOGS_MPI_TIMEOUT = {s:?} is not a positive number of seconds"
            )),
        },
    }
}

#[cfg(feature = "mpi")]
mod with_mpi {
    use evogs::train::collective::Collective;
    use mpi::environment::Universe;
    use mpi::topology::SimpleCommunicator;
    use mpi::traits::{Communicator, CommunicatorCollectives};
    use std::time::{Duration, Instant};

    /// The job's processes over MPI (`MPI_COMM_WORLD`). MPI is finalised when this is
    /// dropped; calls come from the thread that made it.
    pub struct Mpi {
        world: SimpleCommunicator,
        timeout: Duration,
        // Dropped last: finalises MPI.
        _universe: Universe,
    }

    impl std::fmt::Debug for Mpi {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            write!(
                f,
                "Mpi {{ rank: {}, size: {}, timeout: {:?} }}",
                self.world.rank(),
                self.world.size(),
                self.timeout
            )
        }
    }

    impl Mpi {
        /// Joins the job (`MPI_Init_thread`, MPI called from this thread only).
        ///
        /// # Errors
        /// MPI was initialised already or cannot start, or `EVOGS_MPI_TIMEOUT` is bad.
        pub fn init() -> Result<Self, String> {
            let timeout = super::timeout()?;
            let (universe, _) = mpi::initialize_with_threading(mpi::Threading::Funneled)
                .ok_or("MPI cannot be initialised (already initialised in this process)")?;
            Ok(Self {
                world: universe.world(),
                timeout,
                _universe: universe,
            })
        }

        /// Ends every process of the job (`MPI_Abort`) after this one's error was printed.
        pub fn abort(&self, code: i32) -> ! {
            self.world.abort(code)
        }
    }

    impl Collective for Mpi {
        fn rank(&self) -> usize {
            usize::try_from(self.world.rank()).unwrap_or(0)
        }

        fn size(&self) -> usize {
            usize::try_from(self.world.size()).unwrap_or(1)
        }

        fn all_gather(&self, mine: &[u8]) -> Result<Vec<u8>, String> {
            let mut all = vec![0u8; mine.len() * self.size()];
            let deadline = Instant::now() + self.timeout;
            mpi::request::scope(|scope| {
                let mut req = self
                    .world
                    .immediate_all_gather_into(scope, mine, &mut all[..]);
                let mut pause = Duration::from_micros(20);
                loop {
                    match req.test() {
                        Ok(_) => return,
                        Err(r) if Instant::now() < deadline => {
                            req = r;
                            std::thread::sleep(pause);
                            pause = (pause * 2).min(Duration::from_millis(5));
                        }
                        Err(_) => {
                            // MPI still owns the buffers of the pending exchange: the job
                            // can only end here, with the reason first.
                            eprintln!(
                                "Error: rank {} of {}: the other ranks did not answer within \
                                 {:.0} s (a rank died or hangs; EVOGS_MPI_TIMEOUT sets the \
                                 deadline); ending the job",
                                self.rank(),
                                self.size(),
                                self.timeout.as_secs_f64()
                            );
                            self.world.abort(3)
                        }
                    }
                }
            });
            Ok(all)
        }
    }
}
