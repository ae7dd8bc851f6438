//! [`KeepAwake`]: the pool's other threads wait for the next parallel pass spinning instead
//! of asleep, while a training iteration runs.
//!
//! A rayon worker that finds no work yields for a few dozen rounds and then sleeps on a futex;
//! the next parallel pass wakes it, and on a virtual machine that wake-up takes tens of
//! microseconds. An iteration has on the order of a hundred parallel passes (field calls, ODE
//! stages, render phases, optimiser groups) separated by short serial stretches, so the
//! second thread slept and woke about 140 times per iteration of fast/velocity at N = 5 000
//! (`perf stat`: 275 futex calls per iteration) and joined each pass late
//! (`docs/performance.md`). While a [`KeepAwake`] lives, every other thread of the current
//! pool runs a job that takes the pool's pending work as it appears
//! ([`rayon::yield_now`]) and otherwise yields to the OS scheduler without sleeping (for at
//! most 2 ms in a row: then it gives the thread back, see `MAX_IDLE`).
//!
//! What it costs: the other threads keep their cores busy through the serial stretches of
//! the iteration (as rayon's own idle rounds do, for longer). What it changes: only when
//! work starts, never how it is split or summed, so results are bitwise those without it.

#[cfg(feature = "rayon")]
use std::sync::Arc;
#[cfg(feature = "rayon")]
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
#[cfg(feature = "rayon")]
use std::time::{Duration, Instant};

use evogs_math::Par;

/// While it lives, the other threads of the current rayon pool poll for work instead of
/// sleeping (see the module docs). Nothing happens with `Par::Seq`, on a pool of one
/// thread, or without the `rayon` feature.
///
/// ```
/// use evogs::awake::KeepAwake;
/// use evogs_math::Par;
/// let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
/// let sum: u64 = pool.install(|| {
///     let _awake = KeepAwake::start(Par::best());
///     use rayon::prelude::*;
///     (0..1000_u64).into_par_iter().map(|i| i * i).sum()
/// });
/// assert_eq!(sum, 332_833_500);
/// ```
#[derive(Debug)]
#[must_use = "the threads stay awake only while the value lives"]
pub struct KeepAwake {
    #[cfg(feature = "rayon")]
    polls: Arc<Polls>,
}

/// What the polling jobs of one [`KeepAwake`] share.
#[cfg(feature = "rayon")]
#[derive(Debug, Default)]
struct Polls {
    /// Set when the value is dropped.
    stop: AtomicBool,
    /// Jobs polling now.
    live: AtomicUsize,
}

impl KeepAwake {
    /// Starts one polling job per other thread of the current pool (with `Par::Rayon`).
    ///
    /// A polling job never blocks the thread that started it: if that thread picks one up
    /// itself (waiting in a join), the job returns at once. Dropping the value stops the
    /// jobs without waiting for them; a job not yet started returns as soon as it starts.
    pub fn start(par: Par) -> Self {
        #[cfg(feature = "rayon")]
        {
            let polls = Arc::new(Polls::default());
            if matches!(par, Par::Rayon) {
                let starter = rayon::current_thread_index();
                for _ in 1..rayon::current_num_threads() {
                    let polls = Arc::clone(&polls);
                    rayon::spawn(move || poll(&polls, starter));
                }
            }
            Self { polls }
        }
        #[cfg(not(feature = "rayon"))]
        {
            let _ = par;
            Self {}
        }
    }
}

impl Drop for KeepAwake {
    fn drop(&mut self) {
        #[cfg(feature = "rayon")]
        self.polls.stop.store(true, Ordering::Release);
    }
}

/// The polling job: runs the pool's pending jobs as they appear until `stop`, yielding to
/// the OS scheduler when there are none. On the thread that started it (`starter`) it
/// returns at once: that thread has its own work below it on its stack.
#[cfg(feature = "rayon")]
fn poll(polls: &Polls, starter: Option<usize>) {
    if starter.is_some() && rayon::current_thread_index() == starter {
        return;
    }
    polls.live.fetch_add(1, Ordering::AcqRel);
    let mut idle_since = None;
    while !polls.stop.load(Ordering::Acquire) {
        if matches!(rayon::yield_now(), Some(rayon::Yield::Executed)) {
            idle_since = None;
        } else if idle_since.get_or_insert_with(Instant::now).elapsed() > MAX_IDLE {
            break;
        } else {
            std::thread::yield_now();
        }
    }
    polls.live.fetch_sub(1, Ordering::AcqRel);
}

/// How long a polling job waits for work before it gives its thread back to the pool. A
/// job can be picked up by a thread that is itself waiting in a join (for work that
/// another thread runs); until the job returns, that join cannot go on. Were the job to
/// wait for its `stop` alone, and `stop` come only after that join (two trainers sharing a
/// pool and meeting at a barrier), they would wait for each other forever; bounded, the
/// join goes on at most this long after its work is done. Serial stretches of an
/// iteration are shorter.
#[cfg(feature = "rayon")]
const MAX_IDLE: Duration = Duration::from_millis(2);

#[cfg(all(test, feature = "rayon"))]
mod tests {
    use super::*;
    use rayon::prelude::*;
    use std::sync::Barrier;
    use std::sync::mpsc;

    fn work() -> Vec<f64> {
        (0..20_000_u32)
            .into_par_iter()
            .with_max_len(64)
            .map(|i| f64::from(i).sqrt().sin())
            .collect()
    }

    fn pool(threads: usize) -> rayon::ThreadPool {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool")
    }

    /// Waits up to ten seconds for `live` to read `want`.
    fn settles(live: &AtomicUsize, want: usize) -> bool {
        let t = Instant::now();
        while live.load(Ordering::Acquire) != want {
            if t.elapsed() > Duration::from_secs(10) {
                return false;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        true
    }

    #[test]
    fn the_other_threads_poll_while_it_lives_and_stop_when_it_is_dropped() {
        let pool = pool(3);
        let plain = pool.install(work);
        pool.install(|| {
            for _ in 0..10 {
                let awake = KeepAwake::start(Par::best());
                let polls = Arc::clone(&awake.polls);
                // Two pollers, on the two threads that did not start them.
                assert!(settles(&polls.live, 2), "two threads poll");
                for _ in 0..5 {
                    assert!(work() == plain, "passes give the same values");
                }
                drop(awake);
                assert!(settles(&polls.live, 0), "every poller stops");
            }
        });
    }

    #[test]
    fn a_poller_on_a_thread_waiting_in_a_join_gives_the_join_back() {
        // Two callers outside the pool meet at a barrier while each holds a
        // KeepAwake (two trainers of one process, meeting at every step). Caller 1's pass
        // is a join whose short half runs on one worker while the other worker runs the
        // long half; caller 0's poller, started meanwhile, is picked up by the first worker
        // as it waits in the join, above that join on its stack. Caller 0 then waits at the
        // barrier for caller 1, which waits for the join: the poller has to give its
        // thread back by itself (`MAX_IDLE`), as its `stop` comes only after the barrier.
        let (done, finished) = mpsc::channel();
        std::thread::spawn(move || {
            // The global pool (callers outside a pool start their pollers there).
            let barrier = Barrier::new(2);
            let ms = Duration::from_millis;
            std::thread::scope(|scope| {
                scope.spawn(|| {
                    for _ in 0..3 {
                        std::thread::sleep(ms(10));
                        let awake = KeepAwake::start(Par::best());
                        barrier.wait();
                        drop(awake);
                    }
                });
                scope.spawn(|| {
                    for _ in 0..3 {
                        let awake = KeepAwake::start(Par::best());
                        rayon::join(|| std::thread::sleep(ms(5)), || std::thread::sleep(ms(50)));
                        barrier.wait();
                        drop(awake);
                    }
                });
            });
            done.send(()).expect("the test waits");
        });
        assert!(
            finished.recv_timeout(Duration::from_secs(30)).is_ok(),
            "both callers got past every barrier"
        );
    }

    #[test]
    fn it_does_nothing_sequentially_or_on_one_thread_or_outside_a_pool() {
        let one = pool(1);
        let plain = one.install(work);
        one.install(|| {
            let awake = KeepAwake::start(Par::best());
            assert!(work() == plain, "one thread");
            assert_eq!(awake.polls.live.load(Ordering::Acquire), 0, "no poller");
        });
        let seq = KeepAwake::start(Par::Seq);
        assert!(work() == plain, "sequential");
        assert_eq!(seq.polls.live.load(Ordering::Acquire), 0, "no poller");
        drop(seq);
        // From outside a pool: one poller per other thread of the global pool.
        let outside = KeepAwake::start(Par::best());
        assert!(work() == plain, "on the global pool, from outside it");
        let polls = Arc::clone(&outside.polls);
        drop(outside);
        assert!(settles(&polls.live, 0), "every poller stops");
    }
}
