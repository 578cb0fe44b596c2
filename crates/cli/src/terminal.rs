//! What the command line shows while a job runs: a progress bar per stage on standard error
//! (indicatif draws nothing when standard error is not a terminal), the summary on standard
//! output (standard error with `--json`, which puts the JSON result on standard output), and
//! the warnings, which are printed only after the job succeeds.

use crate::args::ReportArgs;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::Write as _;
use std::sync::Mutex;
use surae_app::JobObserver;

/// The terminal as a job's observer.
pub struct Terminal {
    json: bool,
    bars: Mutex<Vec<(String, ProgressBar)>>,
    warnings: Mutex<Vec<String>>,
}

impl Terminal {
    /// A terminal for a command run with `report`'s options.
    pub fn new(report: ReportArgs) -> Self {
        Self {
            json: report.json,
            bars: Mutex::new(Vec::new()),
            warnings: Mutex::new(Vec::new()),
        }
    }

    /// The warnings recorded so far, emptied.
    pub fn take_warnings(&self) -> Vec<String> {
        self.warnings
            .lock()
            .map(|mut w| std::mem::take(&mut *w))
            .unwrap_or_default()
    }

    fn with_bar(&self, label: &str, f: impl FnOnce(&ProgressBar)) {
        if let Ok(bars) = self.bars.lock() {
            if let Some((_, bar)) = bars.iter().rev().find(|(l, _)| l == label) {
                f(bar);
            }
        }
    }
}

impl JobObserver for Terminal {
    fn begin(&self, label: &str, total: u64, show: bool) {
        if !show {
            return;
        }
        let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
        if let Ok(style) = ProgressStyle::with_template(
            "{prefix:>5} [{elapsed_precise}] {bar:32} {pos}/{len} {msg}",
        ) {
            bar.set_style(style);
        }
        bar.set_prefix(label.to_string());
        if let Ok(mut bars) = self.bars.lock() {
            bars.push((label.to_string(), bar));
        }
    }

    fn update(&self, label: &str, position: u64, _total: u64, message: &str) {
        self.with_bar(label, |bar| {
            bar.set_position(position);
            bar.set_message(message.to_string());
        });
    }

    fn end(&self, label: &str) {
        if let Ok(mut bars) = self.bars.lock() {
            if let Some(i) = bars.iter().rposition(|(l, _)| l == label) {
                let (_, bar) = bars.remove(i);
                bar.finish_and_clear();
            }
        }
    }

    fn warning(&self, message: &str) {
        if let Ok(mut w) = self.warnings.lock() {
            w.push(message.to_string());
        }
    }

    fn summary(&self, line: &str) {
        // a closed pipe (`surae inspect F | head`) ends the summary, not the program
        if self.json {
            let _ = writeln!(std::io::stderr(), "{line}");
        } else {
            let _ = writeln!(std::io::stdout(), "{line}");
        }
    }

    fn note(&self, line: &str) {
        let _ = writeln!(std::io::stderr(), "{line}");
    }

    fn result_json(&self, text: &str) {
        if self.json {
            print!("{text}");
        }
    }
}
