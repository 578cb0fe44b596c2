//! The rows of `cargo xtask bench` for a long low-rate recording: the 60 s gait-like synthetic
//! trial at 100 Hz (`muscle_model::synthetic::gait_like_trial`, three muscles, a knee-angle
//! series), as a motion-capture lab exports its envelopes. One forward simulation (every
//! muscle integrated) and one annealing move (one muscle integrated), median wall time on one
//! thread, with the integrator's work and the default settings' error against
//! `SimSettings::tight()` (docs/model.md, "Low-rate trials").

use anyhow::Result;
use muscle_model::{
    simulate, simulate_into, synthetic, Effects, ModelParams, SimSettings, Workspace,
};

/// Length (s) and rate (Hz) of the trial.
const SECONDS: f64 = 60.0;
const RATE_HZ: f64 = 100.0;

/// What the rows show.
pub(super) struct LongRecording {
    samples: usize,
    /// Median wall time (s) of a simulation with every muscle changed, and with one changed.
    forward: f64,
    one_muscle: f64,
    accepted: usize,
    rejected: usize,
    rhs_calls: usize,
    /// RMS (N·m) of the default settings' torque from the tight run's.
    error: f64,
}

/// Times the trial: `reps` calls per row (at most 40; a call takes milliseconds).
pub(super) fn measure(reps: usize) -> Result<LongRecording> {
    let tr = synthetic::gait_like_trial(RATE_HZ, SECONDS)?;
    let (p, e, s) = (
        ModelParams::nominal(),
        Effects::none(),
        SimSettings::default(),
    );
    let tight = simulate(&tr, &p, &e, &SimSettings::tight())?;
    let out = simulate(&tr, &p, &e, &s)?;
    let st = out.total_stats();
    let error = super::rms(&out.torque, &tight.torque);
    let reps = reps.clamp(1, 40);
    // every call a new LST (of every muscle, or of sol alone), so no kept result is reused
    let time = |muscles: usize| -> Result<f64> {
        let mut ws = Workspace::new();
        let mut torque = vec![0.0; tr.len()];
        let mut q = p;
        let mut t = Vec::with_capacity(reps);
        for k in 0..reps + 3 {
            for j in 0..muscles {
                q.muscles[j].lst_m = p.muscles[j].lst_m * (1.0 + 1e-6 * (k + 1) as f64);
            }
            let start = std::time::Instant::now();
            simulate_into(&mut ws, &tr, &q, &e, &s, &mut torque)?;
            if k >= 3 {
                t.push(start.elapsed().as_secs_f64());
            }
        }
        t.sort_by(f64::total_cmp);
        Ok(t[t.len() / 2])
    };
    Ok(LongRecording {
        samples: tr.len(),
        forward: time(3)?,
        one_muscle: time(1)?,
        accepted: st.accepted,
        rejected: st.rejected,
        rhs_calls: st.rhs_calls,
        error,
    })
}

impl LongRecording {
    /// The table rows, with `columns` cells each (3: measurement, time, relative to the seed
    /// trial's forward simulation `seed_forward`; 4: measurement, time, peer, ratio).
    pub(super) fn rows(&self, columns: usize, seed_forward: f64) -> Vec<String> {
        let share = 100.0 * self.rejected as f64 / (self.accepted + self.rejected) as f64;
        let what = format!(
            "60 s gait-like trial at 100 Hz ({} samples; {} steps, {share:.1} % of the attempts \
             rejected, {} RHS calls; {:.1e} N·m RMS from tight)",
            self.samples, self.accepted, self.rhs_calls, self.error
        );
        let rest = |t: f64| {
            if columns == 3 {
                format!("{:.2} ms | {:.0} |", t * 1e3, t / seed_forward)
            } else {
                format!("{:.2} ms | — | — |", t * 1e3)
            }
        };
        vec![
            format!(
                "| forward simulation, {what} (3 muscles integrated) | {}",
                rest(self.forward)
            ),
            format!(
                "| annealing move, the same trial (1 muscle integrated) | {}",
                rest(self.one_muscle)
            ),
        ]
    }
}
