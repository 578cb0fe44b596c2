//! Figures and HTML reports written next to the JSON results (crate `report`).

use crate::error::{AppError, AppResult};
use crate::output::OutDir;
use crate::Reporter;
use muscle_model::{Muscle, TrialInputs};
use report::html::Report;
use std::path::PathBuf;

/// Names of the motion phases used to colour residual plots.
pub const PHASE_NAMES: [&str; 3] = ["hold", "concentric", "eccentric"];

/// Phase index of every sample from the angular velocity: plantarflexion
/// (q̇ < 0) is concentric for the triceps surae, dorsiflexion eccentric, and
/// near-zero velocity (below 20 % of the peak speed) a hold.
pub fn phases(inputs: &TrialInputs) -> Vec<usize> {
    let v = inputs.velocity();
    let peak = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let thr = 0.2 * peak;
    v.iter()
        .map(|&x| {
            if peak == 0.0 || x.abs() < thr {
                0
            } else if x < 0.0 {
                1
            } else {
                2
            }
        })
        .collect()
}

/// Collects SVG figures and writes them (atomically) with an HTML report.
pub struct FigureSet<'a> {
    out: &'a OutDir,
    page: Report,
    written: Vec<PathBuf>,
    rep: Reporter,
}

impl<'a> FigureSet<'a> {
    /// A new report titled `title` that writes into `out`.
    pub fn new(out: &'a OutDir, title: &str, rep: &Reporter) -> Self {
        Self {
            out,
            page: Report::new(title),
            written: Vec::new(),
            rep: rep.clone(),
        }
    }

    /// The HTML page under construction (paragraphs, tables).
    pub fn page(&mut self) -> &mut Report {
        &mut self.page
    }

    /// Adds a figure produced by `make` as `name.svg` and in the page. A
    /// figure that cannot be drawn is reported and skipped, not fatal.
    pub fn add(&mut self, name: &str, caption: &str, make: report::Result<String>) -> AppResult {
        match make {
            Ok(svg) => {
                let p = self.out.write(&format!("{name}.svg"), svg.as_bytes())?;
                self.page
                    .figure(caption, &svg)
                    .map_err(|e| AppError::internal(format!("figure {name}: {e}")))?;
                self.written.push(p);
            }
            Err(e) => self.rep.warn(format!("figure {name} not drawn: {e}")),
        }
        Ok(())
    }

    /// Writes `report.html`; returns every file written.
    pub fn finish(mut self) -> AppResult<Vec<PathBuf>> {
        let html = self.page.to_html();
        let p = self.out.write("report.html", html.as_bytes())?;
        self.written.push(p);
        Ok(self.written)
    }
}

/// The envelope series of the inputs, labelled by muscle.
pub fn envelopes(inputs: &TrialInputs) -> Vec<(&'static str, &[f64])> {
    Muscle::ALL
        .iter()
        .map(|m| (m.name(), inputs.envelope(*m)))
        .collect()
}

/// Angle of the inputs in degrees.
pub fn angle_deg(inputs: &TrialInputs) -> Vec<f64> {
    inputs.angle().iter().map(|q| q.to_degrees()).collect()
}
