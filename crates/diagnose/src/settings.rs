//! Settings of a diagnosis: the decision rule's thresholds and margins, the fits' budgets
//! and the cross-validation folds (docs/diagnosis.md).

use experiment::{CrosstalkSettings, InputOptions, PreparedTrial, Trial, Unloaded};
use muscle_model::EffectKind;
use numerics::LevenbergMarquardtSettings;

use crate::profile::ProfileSettings;
use crate::DiagnoseError;

/// Settings of a diagnosis. `Default` is the documented decision rule (docs/diagnosis.md).
#[derive(Clone, Debug, PartialEq)]
pub struct DiagnoseSettings {
    /// Effects considered (those whose inputs exist: `antagonist_coactivation` needs `emg_ta`).
    pub candidates: Vec<EffectKind>,
    /// Most effects added.
    pub max_effects: usize,
    /// Candidates refitted per round (best evidence first); without an unloaded run every
    /// candidate reaching [`DiagnoseSettings::min_score_lm`] is refitted instead.
    pub refits_per_round: usize,
    /// After the forward rounds, with two or more causes: try replacing each cause by another
    /// effect (drop it, refit, one more forward round) and keep a replacement that lowers the
    /// BIC by more than the ΔBIC margin without raising the held-out error.
    pub exchange: bool,
    /// When no single extension passes in a round, fit the two with the strongest in-sample
    /// evidence jointly and accept both if the pair passes (effects that only generalise
    /// together).
    pub pairs: bool,
    /// Minimum score statistic for a refit.
    pub min_score_lm: f64,
    /// An added effect must lower the held-out deviance ([`CandidateReport::heldout_dev_gain`](crate::CandidateReport::heldout_dev_gain),
    /// χ² units) by at least this, without raising the held-out RMS.
    pub min_heldout_dev_gain: f64,
    /// Held-out margin of the tie rules (near ties, a simpler model named instead): two
    /// models' held-out RMS differ by less than this share (%) …
    pub min_heldout_gain_pct: f64,
    /// … or less than this (N·m), whichever is larger.
    pub min_heldout_gain_nm: f64,
    /// ΔBIC must be below this.
    pub max_delta_bic: f64,
    /// Cosine above which an extension is confounded with the model's parameters.
    pub confound_cos: f64,
    /// Structure evidence (`−log10` of the structure tests' p-value) above which
    /// `unexplained_structure` is set; 3 = false-alarm rate 10⁻³ per trial on a correct model.
    pub structure_threshold: f64,
    /// How the EMG columns become envelopes.
    pub input_options: InputOptions,
    /// Levenberg–Marquardt settings of the full fits.
    pub lm: LevenbergMarquardtSettings,
    /// Levenberg–Marquardt iterations of a cross-validation refit.
    pub cv_iterations: usize,
    /// How the samples are split into cross-validation folds.
    pub cv_folds: CvFolds,
    /// Starts of the baseline fit besides the nominal parameters: Latin-hypercube points in
    /// the identification bounds (docs/model.md) (run in parallel; the lowest whitened cost wins). A single start can
    /// stop in a local minimum (e.g. sol F0 at its bound), whose misfit then passes for a
    /// catalogued effect or for unexplained structure.
    pub baseline_extra_starts: usize,
    /// Starts of every extended fit besides the current fit and the nominal muscle
    /// parameters: Latin-hypercube points of the muscle parameters (the effect parameters
    /// start where the score test puts them). Without them a candidate's refit could stay in
    /// a worse local minimum than a competitor's and lose to an effect that is not there.
    pub extended_extra_starts: usize,
    /// Seed of the Latin-hypercube starts.
    pub start_seed: u64,
    /// Profile-likelihood intervals of the final model's parameters (docs/diagnosis.md).
    pub profile: ProfileSettings,
    /// Whether named causes are reviewed against flexible terms and unexplained structure is
    /// characterised by them (docs/diagnosis-method.md, "Beyond the catalogue").
    pub flexible_terms: bool,
    /// BIC margin by which a named catalogued effect must beat a flexible term in its own
    /// variable (otherwise the flexible term is reported instead): 2, "positive evidence" on
    /// Kass and Raftery's scale.
    pub flexible_margin_bic: f64,
    /// Held-out deviance gain above which a variable's flexible term enters `depends_on`, and
    /// by which a flexible term in place of a named cause must predict better to replace it
    /// ([`DiagnoseSettings::heldout_contest`]).
    pub min_flexible_gain: f64,
    /// Whether each named cause must also hold against a flexible term in every variable of
    /// the vocabulary fitted in its place, held out (docs/diagnosis-method.md, "No false
    /// story"): a cause that such a term predicts better by `min_flexible_gain` is not named.
    pub heldout_contest: bool,
    /// Whether the raw triceps EMG is tested for the TA's crosstalk and corrected when it
    /// carries it (docs/diagnosis-method.md, "EMG crosstalk"; needs `emg_ta` and raw EMG).
    pub crosstalk_check: bool,
    /// Evidence (`−log10 p` per channel) above which a triceps channel is taken to carry the
    /// TA's signal and is corrected: 5 = one clean channel in 10⁵ corrected needlessly (the
    /// correction changes the recording; a share that matters to the torque has `|z|` in the
    /// tens).
    pub crosstalk_threshold: f64,
    /// Fits, score tests, Laplace errors, detection limits and profile intervals take the
    /// model's exact Jacobian (forward sensitivities, `muscle_model::exact_torque_jacobian`)
    /// wherever it has one, instead of forward differences at 10⁻³ of each range; where it has
    /// none (fatigue, the activation's time constants) they difference as before. Off by
    /// default. On the catalogued suite (`confusion -- 4 83217`, 52 trials) it puts the true
    /// muscle parameters within ±1 Laplace standard error in 80 % of cases instead of 36 %
    /// (68 % would be calibrated), keeps the profile intervals' coverage (73 % against 72 %)
    /// and names 49 of 52 trials exactly against 50; on walk36 the diagnosis takes 22 s
    /// instead of 54 s, but its baseline fit reaches a higher likelihood at a larger RMS and no
    /// cause is named, where the differenced fits name the eccentric plateau whose gain holds
    /// on the later strides (docs/studies/uncertainty.md, "Exact Jacobians").
    pub exact_jacobian: bool,
}

/// Cross-validation folds of the held-out error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CvFolds {
    /// Every cycle (a concentric sweep and the eccentric sweep after it) is held out in turn,
    /// each with the hold after it (the first also with the hold before it), so that every
    /// sample is held out once.
    Cycles,
    /// The trial is cut into consecutive blocks of `block_s` seconds; block `b` belongs to fold
    /// `b mod folds`, so every fold holds out pieces of every phase.
    Blocks {
        /// Block length (s), much longer than the noise's correlation time (30 ms).
        block_s: f64,
        /// Number of folds (at least 2).
        folds: usize,
    },
    /// [`CvFolds::Cycles`] when the trial has at least [`MIN_CV_CYCLES`] cycles, else
    /// [`CvFolds::Blocks`] of 0.5 s in 5 folds. Holding out the only cycle of a one-cycle trial
    /// (the `seed` protocol, the dissertation's) leaves nothing but holds to fit: the held-out
    /// error then measures extrapolation from rest to a maximal contraction, not the model.
    Auto,
}

/// Fewest cycles for cycle-wise cross-validation under [`CvFolds::Auto`].
pub const MIN_CV_CYCLES: usize = 3;

impl CvFolds {
    /// [`CvFolds::Auto`] resolved for a trial with `cycles` cycles (others unchanged).
    pub fn resolve(&self, cycles: usize) -> CvFolds {
        match *self {
            CvFolds::Auto if cycles >= MIN_CV_CYCLES => CvFolds::Cycles,
            CvFolds::Auto => CvFolds::Blocks {
                block_s: 0.5,
                folds: 5,
            },
            other => other,
        }
    }

    /// A short description, e.g. `3 cycles held out in turn`, `5 folds of 0.5 s blocks`.
    pub fn describe(&self, cycles: usize) -> String {
        match self.resolve(cycles) {
            CvFolds::Blocks { block_s, folds } => format!("{folds} folds of {block_s} s blocks"),
            _ if cycles == 1 => "the cycle held out".into(),
            _ => format!("{cycles} cycles held out in turn"),
        }
    }

    /// [`CvFolds::describe`] for a recording of `n` samples at `fs` Hz: the blocks of a
    /// recording too short for one block per fold are named with their own length.
    pub fn describe_for(&self, cycles: usize, n: usize, fs: f64) -> String {
        match self.resolve(cycles) {
            CvFolds::Blocks { block_s, folds } => {
                let len = block_len(block_s, folds, n, fs);
                if len == ((block_s * fs).round() as usize).max(1) {
                    self.describe(cycles)
                } else {
                    format!("{folds} folds of {:.3} s blocks", len as f64 / fs)
                }
            }
            _ => self.describe(cycles),
        }
    }

    /// The held-out mask of every fold for `n` samples at `fs` Hz, given the cycle of each
    /// sample (`None` outside the cycles).
    pub fn held_out_masks(&self, n: usize, fs: f64, cycle: &[Option<usize>]) -> Vec<Vec<bool>> {
        let cycles = cycle.iter().flatten().max().map_or(0, |m| m + 1);
        match self.resolve(cycles) {
            CvFolds::Auto | CvFolds::Cycles => {
                let fold = cycle_folds(cycle);
                (0..cycles)
                    .map(|k| fold.iter().map(|f| *f == k).collect())
                    .collect()
            }
            CvFolds::Blocks { block_s, folds } => {
                let len = block_len(block_s, folds, n, fs);
                (0..folds)
                    .map(|k| (0..n).map(|i| (i / len) % folds == k).collect())
                    .collect()
            }
        }
    }
}

/// The fold of every sample under [`CvFolds::Cycles`]: its cycle in `cycle`, or, in a hold,
/// the cycle before it (before the first cycle, the first).
///
/// The holds are where the drive ramps up and relaxes, so an electromechanical delay leaves
/// most of its signal there: with the holds never held out, a 6.27 ms delay (1.2× its limit,
/// subject 20 291 138) that lowered the whole trial's cost by about 82 (ΔBIC −73) lowered the
/// held-out cycles' deviance by 18, which the refits' spread outweighed (held-out gain −4.3;
/// with the holds, +122). A hold goes with the cycle before it so that the hold where the drive first ramps
/// up, the fresh muscle's reference, stays in the training set of every maximal cycle: held
/// out with the first maximal cycle instead, it left fatigue at its limit (subject
/// 20 301 129) with one maximal cycle to be told from the forces by, and a held-out gain of
/// −50.
fn cycle_folds(cycle: &[Option<usize>]) -> Vec<usize> {
    let mut prev = 0;
    cycle
        .iter()
        .map(|c| {
            if let Some(k) = *c {
                prev = k;
            }
            prev
        })
        .collect()
}

/// Samples per block of [`CvFolds::Blocks`]: `block_s` at `fs`, or, when `n` samples do not
/// fill one block per fold (a stance phase of half a second), `n / (2·folds)`, so that every
/// fold holds out two blocks spread over the recording rather than some folds nothing.
fn block_len(block_s: f64, folds: usize, n: usize, fs: f64) -> usize {
    let len = ((block_s * fs).round() as usize).max(1);
    if n < folds * len {
        (n / (2 * folds)).max(1)
    } else {
        len
    }
}

impl Default for DiagnoseSettings {
    fn default() -> Self {
        DiagnoseSettings {
            candidates: EffectKind::ALL.to_vec(),
            max_effects: 3,
            refits_per_round: 3,
            exchange: true,
            pairs: true,
            min_score_lm: 6.0,
            min_heldout_dev_gain: 0.0,
            min_heldout_gain_pct: 2.0,
            min_heldout_gain_nm: 0.02,
            max_delta_bic: -10.0,
            confound_cos: 0.98,
            structure_threshold: 3.0,
            input_options: InputOptions::default(),
            lm: LevenbergMarquardtSettings::default(),
            cv_iterations: 8,
            cv_folds: CvFolds::Auto,
            baseline_extra_starts: 5,
            extended_extra_starts: 4,
            start_seed: 0x5eed_d1a9,
            profile: ProfileSettings::default(),
            flexible_terms: true,
            heldout_contest: true,
            flexible_margin_bic: 2.0,
            min_flexible_gain: 10.0,
            crosstalk_check: true,
            crosstalk_threshold: 5.0,
            exact_jacobian: false,
        }
    }
}

impl DiagnoseSettings {
    /// How many of the candidates reaching [`DiagnoseSettings::min_score_lm`] a round refits:
    /// [`DiagnoseSettings::refits_per_round`], or all of them when the noise model is fitted
    /// to the trial's own residual (`rms_decides`: no unloaded run), where the score test's
    /// ranking says little about the held-out error. On walk36 the passive moment led the
    /// score ranking (evidence 44.5) and raised the held-out RMS from 10.5 to 12.9 N·m, while
    /// the antagonist, fifth (8.3), was never refitted.
    pub(crate) fn refits(&self, rms_decides: bool) -> usize {
        if rms_decides {
            usize::MAX
        } else {
            self.refits_per_round
        }
    }

    /// The EMG crosstalk test these settings ask for.
    #[must_use]
    pub fn crosstalk_settings(&self) -> CrosstalkSettings {
        CrosstalkSettings::new(self.crosstalk_check, self.crosstalk_threshold)
    }

    /// `trial` and its optional unloaded run prepared as a diagnosis prepares them
    /// ([`PreparedTrial::prepare`] with these settings' input options and crosstalk test).
    ///
    /// # Errors
    /// As [`PreparedTrial::prepare`].
    pub fn prepare(
        &self,
        trial: &Trial,
        unloaded: Option<&Unloaded>,
    ) -> Result<PreparedTrial, DiagnoseError> {
        Ok(PreparedTrial::prepare(
            trial,
            unloaded,
            &self.input_options,
            &self.crosstalk_settings(),
            "trial",
        )?)
    }

    /// Checks the settings the decision rule cannot use (a margin that is not finite, no
    /// refits, folds that hold nothing out, Levenberg–Marquardt or profile settings that
    /// cannot iterate) before any simulation.
    ///
    /// # Errors
    /// [`DiagnoseError::Settings`] naming the first offending field.
    pub fn validate(&self) -> Result<(), DiagnoseError> {
        let bad = |name: &'static str, reason: &str| {
            Err(DiagnoseError::Settings {
                name,
                reason: reason.into(),
            })
        };
        if self.refits_per_round == 0 {
            return bad("refits_per_round", "must be at least 1");
        }
        if !(self.min_heldout_gain_pct.is_finite() && self.min_heldout_gain_pct >= 0.0) {
            return bad("min_heldout_gain_pct", "must be finite and ≥ 0");
        }
        if !(self.min_heldout_gain_nm.is_finite() && self.min_heldout_gain_nm >= 0.0) {
            return bad("min_heldout_gain_nm", "must be finite and ≥ 0");
        }
        if !self.max_delta_bic.is_finite() {
            return bad("max_delta_bic", "must be finite");
        }
        if !self.min_heldout_dev_gain.is_finite() {
            return bad("min_heldout_dev_gain", "must be finite");
        }
        if !(self.flexible_margin_bic.is_finite() && self.min_flexible_gain.is_finite()) {
            return bad(
                "flexible_margin_bic",
                "flexible_margin_bic and min_flexible_gain must be finite",
            );
        }
        if !(self.crosstalk_threshold.is_finite() && self.crosstalk_threshold > 0.0) {
            return bad("crosstalk_threshold", "must be finite and > 0");
        }
        if !(self.confound_cos > 0.0 && self.confound_cos <= 1.0) {
            return bad("confound_cos", "must be in (0, 1]");
        }
        if let CvFolds::Blocks { block_s, folds } = self.cv_folds {
            if !(block_s.is_finite() && block_s > 0.0) || folds < 2 {
                return bad(
                    "cv_folds",
                    "blocks need a finite block length > 0 and at least 2 folds",
                );
            }
        }
        let p = &self.profile;
        if !(p.level.is_finite() && p.level > 0.0 && p.tol > 0.0 && p.ftol_rel >= 0.0)
            || p.max_refits == 0
            || p.lm_iterations == 0
        {
            return bad(
                "profile",
                "level and tol > 0, ftol_rel ≥ 0, max_refits and lm_iterations ≥ 1",
            );
        }
        if self.lm.max_iterations == 0 || !(self.lm.fd_step > 0.0 && self.lm.fd_step < 0.5) {
            return bad("lm", "max_iterations ≥ 1 and 0 < fd_step < 0.5");
        }
        Ok(())
    }
}
