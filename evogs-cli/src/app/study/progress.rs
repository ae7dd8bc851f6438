//! Progress of a study: runs report from their worker threads through a channel, and the
//! coordinating thread shows it on the study's one [`Reporter`] with the study's ETA.
//!
//! With one job at a time each run's phases get their own bar, named by the run; with
//! several, one `study` bar counts the training iterations of all runs and its message says
//! where each running run is.

use crate::app::Reporter;
use crate::app::error::CommandError;
use std::sync::mpsc::Sender;
use std::time::Instant;

/// What a worker reports about run `run` (its index in the plan).
#[derive(Debug)]
pub(super) enum Event {
    /// A phase started.
    Start {
        run: usize,
        phase: String,
        total: u64,
    },
    /// Progress in the current phase.
    Progress {
        run: usize,
        done: u64,
        message: String,
    },
    /// The phase ended.
    Finish,
    /// A message.
    Info { run: usize, message: String },
}

/// What a worker sends the coordinating thread.
#[derive(Debug)]
pub(super) enum Message {
    /// Run `k` (index among the runs to train) starts.
    Begin(usize),
    /// A report of a running run.
    Report(Event),
    /// Run `k` ended.
    End(usize, Result<(), CommandError>),
}

/// A [`Reporter`] that forwards a run's reports to the coordinating thread.
#[derive(Debug)]
pub(super) struct ChannelReporter {
    run: usize,
    tx: Sender<Message>,
}

impl ChannelReporter {
    /// Reports of run `run` go to `tx`.
    pub(super) fn new(run: usize, tx: Sender<Message>) -> Self {
        Self { run, tx }
    }

    fn send(&self, e: Event) {
        let _ = self.tx.send(Message::Report(e));
    }
}

impl Reporter for ChannelReporter {
    fn start(&mut self, phase: &str, total: u64) {
        self.send(Event::Start {
            run: self.run,
            phase: phase.to_string(),
            total,
        });
    }
    fn progress(&mut self, done: u64, message: &str) {
        self.send(Event::Progress {
            run: self.run,
            done,
            message: message.to_string(),
        });
    }
    fn finish(&mut self) {
        self.send(Event::Finish);
    }
    fn info(&mut self, message: &str) {
        self.send(Event::Info {
            run: self.run,
            message: message.to_string(),
        });
    }
}

/// Where one run stands.
#[derive(Clone, Debug, Default)]
struct RunProgress {
    phase: String,
    /// Training iterations done.
    done: u64,
    /// Iterations already done when this session first heard of the run (a resumed run).
    baseline: Option<u64>,
    running: bool,
}

/// The coordinator's view of the study.
#[derive(Debug)]
pub(super) struct StudyProgress {
    labels: Vec<String>,
    iterations: Vec<u64>,
    runs: Vec<RunProgress>,
    jobs: usize,
    started: Instant,
    finished_runs: usize,
}

impl StudyProgress {
    /// Runs to train (labels and planned iterations), `jobs` at once.
    pub(super) fn new(labels: Vec<String>, iterations: Vec<u64>, jobs: usize) -> Self {
        let runs = vec![RunProgress::default(); labels.len()];
        Self {
            labels,
            iterations,
            runs,
            jobs,
            started: Instant::now(),
            finished_runs: 0,
        }
    }

    /// Total training iterations left and done in this session.
    fn iterations_left_and_done(&self) -> (u64, u64) {
        let mut left = 0;
        let mut done = 0;
        for (r, &n) in self.runs.iter().zip(&self.iterations) {
            left += n.saturating_sub(r.done);
            done += r.done.saturating_sub(r.baseline.unwrap_or(r.done));
        }
        (left, done)
    }

    /// The study's estimated time to finish training, from this session's rate.
    pub(super) fn eta(&self) -> Option<f64> {
        let (left, done) = self.iterations_left_and_done();
        let secs = self.started.elapsed().as_secs_f64();
        (done > 0).then(|| left as f64 * secs / done as f64)
    }

    fn eta_text(&self) -> String {
        self.eta().map_or_else(
            || "study ETA: measuring".to_string(),
            |s| format!("study ETA {}", fmt_duration(s)),
        )
    }

    /// The study starts: with several jobs, its one bar.
    pub(super) fn open(&mut self, rep: &mut dyn Reporter) {
        self.started = Instant::now();
        if self.jobs > 1 {
            rep.start("study", self.iterations.iter().sum());
        }
    }

    /// A run is about to start.
    pub(super) fn begin(&mut self, run: usize, rep: &mut dyn Reporter) {
        self.runs[run].running = true;
        rep.info(&format!(
            "run {}/{}: {} ({})",
            run + 1,
            self.labels.len(),
            self.labels[run],
            self.eta_text()
        ));
    }

    /// A run ended (successfully or not).
    pub(super) fn end(&mut self, run: usize, ok: bool, rep: &mut dyn Reporter) {
        self.runs[run].running = false;
        self.runs[run].done = self.iterations[run];
        self.finished_runs += 1;
        rep.info(&format!(
            "run {}/{} {}: {}",
            run + 1,
            self.labels.len(),
            if ok { "done" } else { "failed" },
            self.labels[run]
        ));
        if self.jobs > 1 && self.finished_runs == self.labels.len() {
            rep.finish();
        }
    }

    /// Shows one worker event.
    pub(super) fn show(&mut self, e: Event, rep: &mut dyn Reporter) {
        match e {
            Event::Start { run, phase, total } => {
                self.runs[run].phase.clone_from(&phase);
                if self.jobs == 1 {
                    rep.start(&format!("{} {phase}", self.labels[run]), total);
                }
            }
            Event::Progress { run, done, message } => {
                let r = &mut self.runs[run];
                if r.phase == "train" {
                    r.baseline.get_or_insert(done);
                    r.done = done;
                }
                if self.jobs == 1 {
                    let eta = self.eta_text();
                    let msg = if message.is_empty() {
                        eta
                    } else {
                        format!("{message} | {eta}")
                    };
                    rep.progress(done, &msg);
                } else {
                    let total_done: u64 = self.runs.iter().map(|r| r.done).sum();
                    let active: Vec<String> = self
                        .runs
                        .iter()
                        .zip(&self.labels)
                        .zip(&self.iterations)
                        .filter(|((r, _), _)| r.running)
                        .map(|((r, l), n)| format!("{l} {}/{n}", r.done))
                        .collect();
                    rep.progress(
                        total_done,
                        &format!("{} | {}", active.join(", "), self.eta_text()),
                    );
                }
            }
            Event::Finish => {
                if self.jobs == 1 {
                    rep.finish();
                }
            }
            Event::Info { run, message } => rep.info(&format!("[{}] {message}", self.labels[run])),
        }
    }
}

/// `1h02m`, `12m05s`, `40s`.
#[must_use]
pub(super) fn fmt_duration(secs: f64) -> String {
    #[allow(
        clippy::cast_possible_truncation,
        reason = "durations are small and non-negative"
    )]
    let s = secs.max(0.0).round() as u64;
    let (h, m, s) = (s / 3600, s / 60 % 60, s % 60);
    if h > 0 {
        format!("{h}h{m:02}m")
    } else if m > 0 {
        format!("{m}m{s:02}s")
    } else {
        format!("{s}s")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::app::Silent;

    #[test]
    fn durations_read_naturally() {
        assert_eq!(fmt_duration(40.2), "40s", "seconds");
        assert_eq!(fmt_duration(725.0), "12m05s", "minutes");
        assert_eq!(fmt_duration(3720.0), "1h02m", "hours");
    }

    #[test]
    fn the_eta_counts_the_iterations_left_at_this_sessions_rate() {
        let mut p = StudyProgress::new(vec!["a".into(), "b".into()], vec![100, 100], 1);
        assert!(p.eta().is_none(), "nothing measured yet");
        let mut rep = Silent;
        p.begin(0, &mut rep);
        p.show(
            Event::Start {
                run: 0,
                phase: "train".into(),
                total: 100,
            },
            &mut rep,
        );
        // A resumed run: the first report says where it was; only later ones count.
        for done in [40, 50] {
            p.show(
                Event::Progress {
                    run: 0,
                    done,
                    message: String::new(),
                },
                &mut rep,
            );
        }
        assert_eq!(
            p.iterations_left_and_done(),
            (150, 10),
            "50 + 100 left, 10 done"
        );
        assert!(
            p.eta().is_some_and(|s| s >= 0.0),
            "an estimate once iterations ran"
        );
    }
}
