//! Running a command from Python: the work runs on its own thread with the GIL released, while
//! the calling thread wakes every 100 ms to show progress and to let Python handle signals.
//! Ctrl-C (or an exception raised by a progress callback) asks the job to stop through the
//! observer this call passes it; the job then fails with `Interrupted`, writes nothing, and
//! the exception is raised once its thread has finished. Each call has its own observer, so
//! Python threads may run jobs side by side.

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Duration;
use surae_app::{AppResult, JobObserver, Reporter};

/// How often the calling thread wakes up.
const POLL: Duration = Duration::from_millis(100);

/// How the caller wants progress shown.
pub(crate) enum ProgressMode {
    /// Nothing shown.
    Off,
    /// One line on `sys.stderr`, rewritten in place.
    Stderr,
    /// `callback(label, position, total, message)` on every change.
    Callback(Py<PyAny>),
}

impl ProgressMode {
    /// From the `progress` argument: a bool or a callable.
    pub(crate) fn from_arg(arg: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        let Some(a) = arg.filter(|a| !a.is_none()) else {
            return Ok(Self::Off);
        };
        if let Ok(b) = a.extract::<bool>() {
            return Ok(if b { Self::Stderr } else { Self::Off });
        }
        if a.is_callable() {
            return Ok(Self::Callback(a.clone().unbind()));
        }
        Err(crate::bad(
            "progress: expected True, False or a callable(label, position, total, message)",
        ))
    }
}

#[derive(Clone, Default)]
struct Update {
    label: String,
    position: u64,
    total: u64,
    message: String,
}

/// Records the latest update and the warnings from the worker threads and carries the stop
/// request to them.
#[derive(Default)]
struct LatestUpdate {
    latest: Mutex<Update>,
    changes: AtomicU64,
    stop: AtomicBool,
    warnings: Mutex<Vec<String>>,
    /// The job's JSON result.
    result: Mutex<Option<String>>,
}

impl JobObserver for LatestUpdate {
    fn update(&self, label: &str, position: u64, total: u64, message: &str) {
        if let Ok(mut u) = self.latest.lock() {
            *u = Update {
                label: label.to_string(),
                position,
                total,
                message: message.to_string(),
            };
        }
        self.changes.fetch_add(1, Ordering::Relaxed);
    }

    fn stop_requested(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    fn warning(&self, message: &str) {
        if let Ok(mut w) = self.warnings.lock() {
            w.push(message.to_string());
        }
    }

    fn result_json(&self, text: &str) {
        if let Ok(mut r) = self.result.lock() {
            *r = Some(text.to_string());
        }
    }
}

/// Shows updates the way the caller asked.
struct Shower {
    mode: ProgressMode,
    seen: u64,
    shown: bool,
}

impl Shower {
    fn show(&mut self, py: Python<'_>, obs: &LatestUpdate) -> PyResult<()> {
        let changes = obs.changes.load(Ordering::Relaxed);
        if changes == self.seen || matches!(self.mode, ProgressMode::Off) {
            return Ok(());
        }
        self.seen = changes;
        let u = obs.latest.lock().map(|u| u.clone()).unwrap_or_default();
        match &self.mode {
            ProgressMode::Off => {}
            ProgressMode::Stderr => {
                let count = if u.total > 0 {
                    format!("{}/{}", u.position, u.total)
                } else {
                    String::new()
                };
                let line = format!("\r{} {count} {}", u.label, u.message);
                let err = py.import("sys")?.getattr("stderr")?;
                err.call_method1("write", (format!("{line:<100}"),))?;
                err.call_method0("flush")?;
                self.shown = true;
            }
            ProgressMode::Callback(cb) => {
                cb.call1(py, (u.label, u.position, u.total, u.message))?;
            }
        }
        Ok(())
    }

    fn finish(&self, py: Python<'_>) -> PyResult<()> {
        if self.shown {
            let err = py.import("sys")?.getattr("stderr")?;
            err.call_method1("write", ("\n",))?;
        }
        Ok(())
    }
}

/// Runs `work` (a job of the application library, given the reporter it reports to) as
/// described in the module documentation and returns the JSON result it reported. Warnings the
/// job recorded become Python `UserWarning`s after a success.
pub(crate) fn run_command<F>(py: Python<'_>, progress: ProgressMode, work: F) -> PyResult<String>
where
    F: FnOnce(&Reporter) -> AppResult + Send + 'static,
{
    let obs = Arc::new(LatestUpdate::default());
    // quiet: no summary lines; the observer still sees every progress update
    let rep = Reporter::new(obs.clone(), true);
    let finished = Arc::new((Mutex::new(false), Condvar::new()));
    let signal_end = finished.clone();
    let handle = std::thread::spawn(move || {
        // on the way out even when `work` panics, so the caller never waits forever
        struct SignalEnd(Arc<(Mutex<bool>, Condvar)>);
        impl Drop for SignalEnd {
            fn drop(&mut self) {
                let (done, cv) = &*self.0;
                if let Ok(mut d) = done.lock() {
                    *d = true;
                }
                cv.notify_all();
            }
        }
        let _end = SignalEnd(signal_end);
        work(&rep)
    });
    let mut shower = Shower {
        mode: progress,
        seen: 0,
        shown: false,
    };
    let mut raised: Option<PyErr> = None;
    loop {
        let done = py.detach(|| {
            let (done, cv) = &*finished;
            let guard = done.lock().unwrap_or_else(|p| p.into_inner());
            let guard = if *guard {
                guard
            } else {
                cv.wait_timeout(guard, POLL)
                    .map(|(g, _)| g)
                    .unwrap_or_else(|p| p.into_inner().0)
            };
            *guard
        });
        if raised.is_none() {
            let checked = shower.show(py, &obs).and_then(|()| py.check_signals());
            if let Err(e) = checked {
                obs.stop.store(true, Ordering::Relaxed);
                raised = Some(e);
            }
        }
        if done {
            break;
        }
    }
    let joined = py.detach(|| handle.join());
    let warnings = obs
        .warnings
        .lock()
        .map(|mut w| std::mem::take(&mut *w))
        .unwrap_or_default();
    let _ = shower.finish(py);
    if let Some(e) = raised {
        return Err(e);
    }
    match joined {
        Ok(Ok(())) => {
            let warn = py.import("warnings")?;
            for w in warnings {
                warn.call_method1("warn", (w,))?;
            }
            let result = obs.result.lock().ok().and_then(|mut r| r.take());
            result.ok_or_else(|| {
                PyRuntimeError::new_err("internal error: the job reported no result")
            })
        }
        Ok(Err(f)) => Err(crate::failure_to_py(f)),
        Err(_) => Err(PyRuntimeError::new_err(
            "internal error: the command panicked (message on standard error)",
        )),
    }
}
