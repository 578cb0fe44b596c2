//! The row of `cargo xtask bench` for the bundled real recording: `surae identify --method sa
//! --session fixtures/walk36/session.json` with the recording defaults, end to end through
//! the application library as the command line runs it (reading, checks, the calibration on a
//! search set of strides and its polish on every sample, the adequacy test, nothing written),
//! with the integrator's rejected share on the recording at the calibrated parameters.

use anyhow::{Context, Result};
use muscle_model::{simulate, SimSettings};
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// What the row shows.
pub(super) struct Walk36Row {
    wall: f64,
    cpu: Option<f64>,
    evaluations: u64,
    rms_nm: f64,
    r2: f64,
    rejected_share: f64,
}

/// Keeps the job's JSON result.
#[derive(Default)]
struct KeptResult(Mutex<Option<String>>);

impl surae_app::JobObserver for KeptResult {
    fn result_json(&self, text: &str) {
        *self.0.lock().unwrap_or_else(|e| e.into_inner()) = Some(text.to_string());
    }
}

/// Runs the calibration once.
pub(super) fn measure(root: &Path) -> Result<Walk36Row> {
    let session = root.join("fixtures/walk36/session.json");
    let observer = Arc::new(KeptResult::default());
    let job = surae_app::IdentifyJob {
        method: surae_app::Method::Sa,
        trial: None,
        session: Some(session.clone()),
        free: None,
        with_effects: None,
        chains: None,
        unloaded: None,
        seed: 42,
        truth: None,
        max_iterations: None,
        model: Default::default(),
        out: None,
        trial_data: None,
        unloaded_data: None,
        truth_data: None,
        discard_files: true,
    };
    let cpu0 = super::cpu_seconds();
    let start = Instant::now();
    surae_app::identify(job, &surae_app::Reporter::new(observer.clone(), true))
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let wall = start.elapsed().as_secs_f64();
    let cpu = super::cpu_seconds().zip(cpu0).map(|(b, a)| b - a);
    let text = observer
        .0
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .clone()
        .context("identify returned no result")?;
    let doc: serde_json::Value = serde_json::from_str(&text)?;
    let evaluations = doc["evaluations"].as_u64().context("evaluations")?;
    let rms_nm = doc["rms_nm"].as_f64().context("rms_nm")?;
    let r2 = doc["trials"][0]["r2"].as_f64().context("r2")?;

    // the integrator's work on the whole recording at the calibrated parameters
    let loaded = surae_app::load_session(
        &session,
        &Default::default(),
        None,
        &surae_app::Reporter::silent(),
    )
    .map_err(|e| anyhow::anyhow!("{e}"))?;
    let set = loaded.problem_set().map_err(|e| anyhow::anyhow!("{e}"))?;
    let names = set.names().to_vec();
    let x: Vec<f64> = names
        .iter()
        .map(|n| doc["params"][n].as_f64().context("a calibrated parameter"))
        .collect::<Result<_>>()?;
    let (p, e) = set.params_from_vector(&x)?;
    let out = simulate(set.first().inputs(), &p, &e, &SimSettings::default())?;
    let st = out.total_stats();
    eprintln!(
        "walk36: {evaluations} evaluations in {wall:.2} s, RMS {rms_nm:.2} N·m, {} of {} steps rejected",
        st.rejected,
        st.accepted + st.rejected
    );
    Ok(Walk36Row {
        wall,
        cpu,
        evaluations,
        rms_nm,
        r2,
        rejected_share: st.rejected as f64 / (st.accepted + st.rejected) as f64,
    })
}

impl Walk36Row {
    /// The table row, with `columns` cells (3 or 4).
    pub(super) fn row(&self, columns: usize) -> String {
        let cpu = self
            .cpu
            .map_or(String::new(), |c| format!(", {c:.1} s CPU"));
        let what = format!(
            "`identify --method sa --session fixtures/walk36/session.json` (61 s of walking at \
             100 Hz, recording defaults: 11 parameters; {} evaluations, RMS {:.2} N·m, R² {:.3}; \
             {:.1} % of the integrator's attempts rejected)",
            self.evaluations,
            self.rms_nm,
            self.r2,
            100.0 * self.rejected_share
        );
        let time = format!("{:.2} s wall{cpu}", self.wall);
        if columns == 4 {
            format!("| {what} | {time} | — | — |")
        } else {
            format!("| {what} | {time} | — |")
        }
    }
}
