//! The diagnosis told in plain words, from plain numbers.

use crate::labels::{effect_description, format_sig};

/// What a diagnosis found (mirror of the fields of `diagnosis.json`, `docs/diagnosis.md`).
#[derive(Clone, Debug, PartialEq)]
pub struct DiagnosisSummary<'a> {
    /// `true` for the verdict `adequate`.
    pub adequate: bool,
    /// Effects kept as causes.
    pub causes: &'a [&'a str],
    /// Whether the residual keeps structure that no catalogued effect explains.
    pub unexplained_structure: bool,
    /// Baseline RMS error on the fitted data (N·m).
    pub baseline_rms_nm: f64,
    /// Baseline held-out RMS error (N·m).
    pub baseline_heldout_rms_nm: f64,
    /// Extended fit held-out RMS error (N·m), if an extended model was fitted.
    pub extended_heldout_rms_nm: Option<f64>,
    /// Held-out RMS reduction of the extended model (%).
    pub heldout_rms_reduction_pct: f64,
    /// BIC difference (baseline − extended; positive favours the extended model).
    pub delta_bic: f64,
    /// Fitted effect parameters `(label with unit, value)`.
    pub effect_values: &'a [(&'a str, f64)],
    /// Near ties `(cause, alternative)`: a model with the alternative instead of the cause fits
    /// about as well (within the decision margins).
    pub near_ties: &'a [(&'a str, &'a str)],
}

/// Paragraphs that explain the diagnosis to a reader who has not seen the numbers.
///
/// ```
/// let s = report::DiagnosisSummary {
///     adequate: false, causes: &["fatigue"], unexplained_structure: false,
///     baseline_rms_nm: 6.0, baseline_heldout_rms_nm: 6.5, extended_heldout_rms_nm: Some(3.0),
///     heldout_rms_reduction_pct: 53.8, delta_bic: 410.0, effect_values: &[("fatigue: rate (1/s)", 0.031)],
///     near_ties: &[],
/// };
/// let text = report::diagnosis_in_words(&s).join(" ");
/// assert!(text.contains("loss of force"));
/// ```
pub fn diagnosis_in_words(s: &DiagnosisSummary<'_>) -> Vec<String> {
    let mut out = Vec::new();
    if s.adequate {
        out.push(format!(
            "The baseline model is adequate: no catalogued effect improves the prediction of \
             held-out data enough to be worth its extra parameters. Its RMS torque error is {} N·m \
             on the fitted data and {} N·m on held-out data.",
            format_sig(s.baseline_rms_nm, 3),
            format_sig(s.baseline_heldout_rms_nm, 3)
        ));
    } else {
        let causes: Vec<String> = s
            .causes
            .iter()
            .map(|c| format!("{} ({c})", effect_description(c)))
            .collect();
        out.push(format!(
            "The baseline model is deficient: it leaves out {}.",
            join_words(&causes)
        ));
        let ext = s
            .extended_heldout_rms_nm
            .map(|e| format!(" to {} N·m", format_sig(e, 3)))
            .unwrap_or_default();
        out.push(format!(
            "Adding {} lowers the RMS error on held-out data from {} N·m{ext} ({} % less), and \
             the BIC improves by {}.",
            if s.causes.len() == 1 { "it" } else { "them" },
            format_sig(s.baseline_heldout_rms_nm, 3),
            format_sig(s.heldout_rms_reduction_pct, 3),
            format_sig(s.delta_bic, 3)
        ));
        if !s.effect_values.is_empty() {
            let vals: Vec<String> = s
                .effect_values
                .iter()
                .map(|(n, v)| format!("{n} = {}", format_sig(*v, 3)))
                .collect();
            out.push(format!("The fitted values are {}.", join_words(&vals)));
        }
        for (cause, alt) in s.near_ties {
            out.push(format!(
                "This trial cannot tell {} ({cause}) from {} ({alt}): a model with the second \
                 instead of the first fits about as well, in sample and on held-out data. A \
                 protocol that separates them (another range of motion or speed) would decide.",
                effect_description(cause),
                effect_description(alt)
            ));
        }
    }
    out.push(if s.unexplained_structure {
        "The residual still has structure that none of the catalogued effects explains: \
         something else is missing from the model."
            .to_string()
    } else {
        "What remains of the residual looks like measurement noise.".to_string()
    });
    out
}

fn join_words(items: &[String]) -> String {
    match items.len() {
        0 => "nothing".into(),
        1 => items[0].clone(),
        n => format!("{} and {}", items[..n - 1].join(", "), items[n - 1]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn base() -> DiagnosisSummary<'static> {
        DiagnosisSummary {
            adequate: true,
            causes: &[],
            unexplained_structure: false,
            baseline_rms_nm: 2.04,
            baseline_heldout_rms_nm: 2.31,
            extended_heldout_rms_nm: None,
            heldout_rms_reduction_pct: 0.0,
            delta_bic: 0.0,
            effect_values: &[],
            near_ties: &[],
        }
    }

    #[test]
    fn adequate_diagnosis_in_words() {
        let t = diagnosis_in_words(&base()).join(" ");
        assert!(t.contains("adequate") && t.contains("2.04 N·m") && t.contains("2.31 N·m"));
        assert!(t.contains("noise"));
    }

    #[test]
    fn deficient_diagnosis_names_every_cause() {
        let s = DiagnosisSummary {
            adequate: false,
            causes: &["electromechanical_delay", "gravity"],
            unexplained_structure: true,
            extended_heldout_rms_nm: Some(1.5),
            heldout_rms_reduction_pct: 35.06,
            delta_bic: 1234.0,
            effect_values: &[("delay (ms)", 41.23)],
            near_ties: &[("gravity", "torque_offset")],
            ..base()
        };
        let t = diagnosis_in_words(&s).join(" ");
        assert!(t.contains("deficient"));
        assert!(t.contains("(electromechanical_delay) and the uncompensated weight"));
        assert!(t.contains("from 2.31 N·m to 1.50 N·m (35.1 % less)"), "{t}");
        assert!(t.contains("delay (ms) = 41.2"));
        assert!(t.contains("something else is missing"));
        assert!(t.contains("cannot tell the uncompensated weight"), "{t}");
        assert!(
            t.contains("(gravity) from ") && t.contains("(torque_offset): a model"),
            "{t}"
        );
    }
}
