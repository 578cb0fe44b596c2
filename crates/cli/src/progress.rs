//! Progress display on a terminal (indicatif); silent when standard error is
//! not a terminal or with `--quiet`.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

/// A progress bar over a number of model evaluations.
pub struct ProgressDisplay {
    bar: Option<ProgressBar>,
    per_chain: Mutex<Vec<u64>>,
    best: AtomicU64,
}

impl ProgressDisplay {
    /// A bar of `total` steps labelled `label`; hidden when `show` is false.
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
            per_chain: Mutex::new(Vec::new()),
            best: AtomicU64::new(f64::INFINITY.to_bits()),
        }
    }

    /// Records that chain `chain` has done `evaluations` so far and its best cost.
    pub fn chain(&self, chain: usize, evaluations: u64, best_cost: f64) {
        let Some(bar) = &self.bar else { return };
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
        bar.set_position(total);
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
        bar.set_message(format!(
            "best cost {:.4e}",
            f64::from_bits(self.best.load(Ordering::Relaxed))
        ));
    }

    /// Sets a free-text message.
    pub fn message(&self, msg: String) {
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

    /// Removes the bar.
    pub fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}
