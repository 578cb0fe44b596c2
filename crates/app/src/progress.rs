//! How a running job tells its front end what it is doing: a [`JobObserver`] passed in by the
//! front end (the command line draws a bar and prints, the Python module records), wrapped in
//! a [`Reporter`] that the jobs call; and [`ProgressDisplay`], which turns a job's per-chain
//! counts into the updates an observer sees.
//!
//! Nothing here is process-wide: two jobs run side by side report to their own observers.

use std::ops::ControlFlow;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// Receives a running job's progress, warnings and summary, and may ask it to stop. Updates
/// arrive from the worker threads, so an implementation only records them; the front end reads
/// them on its own thread.
pub trait JobObserver: Send + Sync {
    /// A stage of `total` model evaluations (0 when unknown) labelled `label` (`SA`, `MCMC`,
    /// `diag`) begins; `show` is false when the front end asked for no progress display.
    fn begin(&self, _label: &str, _total: u64, _show: bool) {}
    /// `position` of `total` model evaluations of stage `label`; `message` is the bar's text.
    fn update(&self, _label: &str, _position: u64, _total: u64, _message: &str) {}
    /// The stage `label` ended.
    fn end(&self, _label: &str) {}
    /// True once the job should stop: it then fails with [`crate::AppError::Interrupted`] and
    /// writes nothing.
    fn stop_requested(&self) -> bool {
        false
    }
    /// A warning about the input or the result (the run goes on).
    fn warning(&self, _message: &str) {}
    /// One line of the human summary, in order.
    fn summary(&self, _line: &str) {}
    /// A line saying what a long job is doing before its progress starts (the command line
    /// prints it on standard error).
    fn note(&self, _line: &str) {}
    /// The job's JSON result, as written to its file.
    fn result_json(&self, _text: &str) {}
}

/// An observer that ignores everything (a library caller that wants only the result).
#[derive(Debug, Default, Clone, Copy)]
pub struct SilentObserver;

impl JobObserver for SilentObserver {}

/// What a job reports to: its front end's observer, and whether progress and the summary are
/// wanted at all (`quiet`).
#[derive(Clone)]
pub struct Reporter {
    observer: Arc<dyn JobObserver>,
    quiet: bool,
}

impl std::fmt::Debug for Reporter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Reporter")
            .field("quiet", &self.quiet)
            .finish()
    }
}

impl Reporter {
    /// Reports to `observer`; with `quiet`, no progress display and no summary (warnings and
    /// the JSON result still reach it).
    pub fn new(observer: Arc<dyn JobObserver>, quiet: bool) -> Self {
        Self { observer, quiet }
    }

    /// A reporter that reports nothing.
    pub fn silent() -> Self {
        Self::new(Arc::new(SilentObserver), true)
    }

    /// Whether progress and the summary are shown.
    pub fn show(&self) -> bool {
        !self.quiet
    }

    /// Hands the JSON result to the observer.
    pub fn print_json(&self, text: &str) {
        self.observer.result_json(text);
    }

    /// One summary line (nothing when quiet).
    pub fn say(&self, line: &str) {
        if !self.quiet {
            self.observer.summary(line);
        }
    }

    /// A line about what the job is doing (nothing when quiet).
    pub fn note(&self, line: &str) {
        if !self.quiet {
            self.observer.note(line);
        }
    }

    /// A warning.
    pub fn warn(&self, message: String) {
        self.observer.warning(&message);
    }

    /// Whether the observer asked the job to stop.
    pub fn stop_requested(&self) -> bool {
        self.observer.stop_requested()
    }

    /// A progress display of `total` steps labelled `label`.
    pub fn progress(&self, total: u64, label: &str) -> ProgressDisplay {
        ProgressDisplay::new(self, total, label)
    }
}

/// A progress bar over a number of model evaluations.
pub struct ProgressDisplay {
    observer: Arc<dyn JobObserver>,
    label: String,
    total: u64,
    position: AtomicU64,
    per_chain: Mutex<Vec<u64>>,
    best: AtomicU64,
}

impl ProgressDisplay {
    /// A display of `total` steps labelled `label`, reported to `reporter`'s observer; a quiet
    /// reporter asks the observer not to draw it (it still sees the updates, and may stop the
    /// job).
    fn new(reporter: &Reporter, total: u64, label: &str) -> Self {
        reporter.observer.begin(label, total, reporter.show());
        Self {
            observer: reporter.observer.clone(),
            label: label.to_string(),
            total,
            position: AtomicU64::new(0),
            per_chain: Mutex::new(Vec::new()),
            best: AtomicU64::new(f64::INFINITY.to_bits()),
        }
    }

    /// Records that chain `chain` has done `evaluations` so far and its best cost.
    pub fn chain(&self, chain: usize, evaluations: u64, best_cost: f64) {
        let total = {
            let Ok(mut v) = self.per_chain.lock() else {
                return;
            };
            if v.len() <= chain {
                v.resize(chain + 1, 0);
            }
            v[chain] = v[chain].max(evaluations);
            v.iter().sum::<u64>()
        };
        self.position.store(total, Ordering::Relaxed);
        let mut cur = self.best.load(Ordering::Relaxed);
        while best_cost < f64::from_bits(cur) {
            match self.best.compare_exchange(
                cur,
                best_cost.to_bits(),
                Ordering::Relaxed,
                Ordering::Relaxed,
            ) {
                Ok(_) => break,
                Err(c) => cur = c,
            }
        }
        self.message(format!(
            "best cost {:.4e}",
            f64::from_bits(self.best.load(Ordering::Relaxed))
        ));
    }

    /// Sets a free-text message.
    pub fn message(&self, msg: String) {
        self.observer.update(
            &self.label,
            self.position.load(Ordering::Relaxed),
            self.total,
            &msg,
        );
    }

    /// Forwards a simulated-annealing event.
    pub fn on_sa_event(&self, ev: &identify_sa::IdentifyEvent) {
        match ev {
            identify_sa::IdentifyEvent::Chain { chain, progress } => {
                self.chain(*chain as usize, progress.evaluations, progress.best_cost)
            }
            identify_sa::IdentifyEvent::Polish { cost, .. } => {
                self.message(format!("polishing, cost {cost:.4e}"))
            }
        }
    }

    /// Whether the observer asked the run to stop.
    pub fn stop_requested(&self) -> bool {
        self.observer.stop_requested()
    }

    /// What a library observer returns: `Break` once a stop was requested.
    pub fn flow(&self) -> ControlFlow<()> {
        if self.stop_requested() {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    }

    /// Ends the stage.
    pub fn finish(&self) {
        self.observer.end(&self.label);
    }
}
