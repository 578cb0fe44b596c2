//! Figures and HTML reports for surae runs, built from plain data (slices and small structs),
//! so that any command can draw them without this crate knowing its result types.
//!
//! * [`figures`] — SVG figures, each returned as a `String`: torque fit with angle and EMG
//!   envelopes, residuals by angle and phase, residuals over time, baseline vs extended fit,
//!   candidate-effect ranking, ensembles over strides (mean ± sd by % of stance or of the
//!   cycle), MCMC traces, R̂ history, marginal histograms, corner plot and sensitivity curves. Colours are the Okabe–Ito palette ([`palette`]); text is ≥ 14 px.
//! * [`html`] — a self-contained `report.html` builder ([`Report`]).
//! * [`plain_summary`] — the diagnosis told in plain words ([`diagnosis_in_words`]).
//! * [`check_svg`] / [`check_xml`] — a small well-formedness checker (used on every figure
//!   before it is inlined, and handy in callers' tests).
//!
//! Residuals are always `r = τ_measured − τ_model` (N·m) and RMS values
//! `RMS = √(Σᵢ rᵢ² / n)`. The correlation written in the corner plot is Pearson's
//! `ρ = Σ (xᵢ − x̄)(yᵢ − ȳ) / √(Σ (xᵢ − x̄)² Σ (yᵢ − ȳ)²)` over all draws. Long lines are
//! decimated (min/max per bucket, ≤ 4000 points) and scatter plots thinned by a fixed stride,
//! so figures stay small and identical input gives identical bytes.
//!
//! ```
//! use report::{figures, Report};
//! let t: Vec<f64> = (0..500).map(|i| i as f64 / 100.0).collect();
//! let measured: Vec<f64> = t.iter().map(|x| 60.0 * (x * 1.3).sin().max(0.0)).collect();
//! let model: Vec<f64> = measured.iter().map(|m| 0.95 * m + 1.0).collect();
//! let resid: Vec<f64> = measured.iter().zip(&model).map(|(a, b)| a - b).collect();
//! let svg = figures::residual_vs_time(&t, &[("baseline", &resid)])?;
//! report::check_svg(&svg)?;
//!
//! let mut page = Report::new("surae identify");
//! page.paragraph("Residual of the fit.").figure("Residual over time.", &svg)?;
//! let html = page.to_html();
//! assert!(html.starts_with("<!DOCTYPE html>") && html.contains("<svg"));
//! # Ok::<(), report::ReportError>(())
//! ```

pub mod error;
pub mod figures;
pub mod html;
pub mod labels;
pub mod palette;
pub mod plain_summary;
pub mod svgcheck;

pub use error::{ReportError, Result};
pub use html::{write_figure, Report};
pub use labels::{effect_description, format_sig, param_label};
pub use plain_summary::{diagnosis_in_words, DiagnosisSummary};
pub use svgcheck::{check_svg, check_xml, XmlSummary};
