//! Progress of a long command: a bar on a terminal (indicatif), silent when standard error is
//! not a terminal or with `--quiet`; and, for front ends other than the terminal (the Python
//! module), a process-wide [`ProgressObserver`] that sees every update and can stop the run.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// Receives a running command's progress and may ask it to stop. Updates arrive from the
/// worker threads, so an implementation only records them; the front end reads them on its
/// own thread.
pub trait ProgressObserver: Send + Sync {
    /// `label` names the stage (`SA`, `MCMC`, `diag`); `position` of `total` model evaluations
    /// (`total` is 0 when unknown); `message` is the bar's text.
    fn update(&self, label: &str, position: u64, total: u64, message: &str);
    /// True once the command should stop: it then fails with [`crate::error::Failure::Interrupted`]
    /// and writes nothing.
    fn stop_requested(&self) -> bool;
}

/// The observer that every command started from now on reports to.
static OBSERVER: Mutex<Option<Arc<dyn ProgressObserver>>> = Mutex::new(None);

/// Installs (or with `None` removes) the process-wide observer. It is global because the
/// commands take no observer argument; a front end runs one command at a time.
pub fn set_observer(observer: Option<Arc<dyn ProgressObserver>>) {
    if let Ok(mut o) = OBSERVER.lock() {
        *o = observer;
    }
}

fn current_observer() -> Option<Arc<dyn ProgressObserver>> {
    OBSERVER.lock().ok().and_then(|o| o.clone())
}

/// A progress bar over a number of model evaluations.
pub struct ProgressDisplay {
    bar: Option<ProgressBar>,
    observer: Option<Arc<dyn ProgressObserver>>,
    label: String,
    total: u64,
    position: AtomicU64,
    per_chain: Mutex<Vec<u64>>,
    best: AtomicU64,
}

impl ProgressDisplay {
    /// A bar of `total` steps labelled `label`; hidden when `show` is false. The installed
    /// [`ProgressObserver`], if any, sees the updates either way.
    pub fn new(show: bool, total: u64, label: &str) -> Self {
        let bar = show.then(|| {
            let b = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
            if let Ok(style) = ProgressStyle::with_template(
                "{prefix:>5} [{elapsed_precise}] {bar:32} {pos}/{len} {msg}",
            ) {
                b.set_style(style);
            }
            b.set_prefix(label.to_string());
            b
        });
        Self {
            bar,
            observer: current_observer(),
            label: label.to_string(),
            total,
            position: AtomicU64::new(0),
            per_chain: Mutex::new(Vec::new()),
            best: AtomicU64::new(f64::INFINITY.to_bits()),
        }
    }

    /// Records that chain `chain` has done `evaluations` so far and its best cost.
    pub fn chain(&self, chain: usize, evaluations: u64, best_cost: f64) {
        if self.bar.is_none() && self.observer.is_none() {
            return;
        }
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
        if let Some(bar) = &self.bar {
            bar.set_position(total);
        }
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
        if let Some(o) = &self.observer {
            o.update(
                &self.label,
                self.position.load(Ordering::Relaxed),
                self.total,
                &msg,
            );
        }
        if let Some(bar) = &self.bar {
            bar.set_message(msg);
        }
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
        self.observer.as_ref().is_some_and(|o| o.stop_requested())
    }

    /// What a library observer returns: `Break` once a stop was requested.
    pub fn flow(&self) -> ControlFlow<()> {
        if self.stop_requested() {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    }

    /// Removes the bar.
    pub fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}
