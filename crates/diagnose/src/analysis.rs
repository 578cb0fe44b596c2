//! Residual analysis: the residual against time, angle, velocity, acceleration, phase, activation and its rate, TA EMG; its autocorrelation against the noise model's; and the test for structure left unexplained.
//!
//! Structure tests: the whitened residual is regressed, after projecting out the fitted
//! model's Jacobian, on generic bases: (a) step functions of the motion (one per cycle ×
//! sweep direction × 5° angle bin, and one per half of every hold), (b) step functions of
//! time (blocks of [`TIME_BLOCK_S`]) and (c) the vocabulary: each state variable's flexible
//! basis on its own (five hats over the angle, velocity, acceleration or activation, four over
//! the TA's envelope, `sign(q̇)`, hats about every 2 s in time), and the angle's, acceleration's
//! and activation's hats times `sign(q̇)` (a function of one of them that differs between the
//! directions of motion, which is odd in the direction and missed by the hats alone);
//! `LM = rᵀP⊥B(BᵀP⊥B)⁻¹BᵀP⊥r/s²`
//! is χ²(df) when the model and the noise model are right (df = rank of `P⊥B`). The motion
//! and time bases have many columns and see any shape at any place; the vocabulary's have a
//! few and see a smooth function of one variable with a fraction of their noise, which the
//! wide bases spread over tens of degrees of freedom.
//!
//! The motion test's p-value is the χ²(df) tail. The time blocks see the noise below about
//! 1 Hz, where its spectrum is the noise model's low-frequency level
//! `σ_ar²(1+φ)/(1−φ) + σ_w²`; that level is itself an estimate from one short record (the
//! unloaded run) and scatters by about 20 % on the default dynamometer noise (docs/dynamometer.md). With it estimated with `ν`
//! effective degrees of freedom ([`TrialNoiseModel::level_dof`](crate::TrialNoiseModel::level_dof), a
//! parametric bootstrap of the estimator), the time statistic is `df·F(df, ν)` rather than
//! `χ²(df)`, and its p-value is `P(F(df, ν) > LM/df)` ([`f_survival`]; the χ² tail when
//! `ν = ∞`). The vocabulary's bases are slow functions of the record too and take the same
//! `F(df, ν)` reference; `p_vocabulary` is the smallest of their p-values times the number of
//! bases tested (up to ten). The structure p-value is the Bonferroni minimum
//! `min(1, 3·min(p_motion, p_time, p_vocabulary))`;
//! the structure evidence is `−log10 p`, and structure is *unexplained* when it exceeds the
//! threshold (3 by default: a false-alarm rate of 10⁻³ per trial on a correct model).

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use crate::fit::{Context, Fit};
use crate::segment::PhaseLabel;

/// The χ², F and incomplete beta tails of the structure tests (in `numerics::special`).
pub use numerics::special::{beta_regularized, chi2_survival, f_survival};

/// Mean and RMS of the residual over one bin of one variable.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct Bin {
    /// Variable: `phase`, `angle_deg.<phase>`, `velocity_deg_s`, `acceleration_deg_s2`,
    /// `activation`, `activation_rate_per_s`, `emg_ta`, and for a recording without joint
    /// motion `span_fraction` (0 at the first compared sample, 1 at the last: the fraction
    /// of stance for a CEINMS trial).
    pub variable: String,
    /// Bin label (phase name) or lower edge.
    pub lo: f64,
    /// Upper edge (equal to `lo` for categorical bins).
    pub hi: f64,
    /// Phase name for categorical bins.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub label: Option<String>,
    /// Samples in the bin.
    pub n: usize,
    /// Mean residual (N·m).
    pub mean_nm: f64,
    /// RMS residual (N·m).
    pub rms_nm: f64,
}

/// Per-sample series for plots (not serialised).
#[derive(Clone, Debug, Default, PartialEq)]
#[non_exhaustive]
pub struct Series {
    /// Time (s).
    pub time_s: Vec<f64>,
    /// Residual of the baseline fit: measured − systematic dynamometer part − model (N·m).
    pub baseline_residual_nm: Vec<f64>,
    /// Residual of the final (extended) fit (N·m).
    pub extended_residual_nm: Vec<f64>,
    /// Phase label.
    pub phase: Vec<PhaseLabel>,
    /// Angle (°).
    pub angle_deg: Vec<f64>,
    /// Angular velocity (°/s).
    pub velocity_deg_s: Vec<f64>,
    /// Angular acceleration (°/s²).
    pub acceleration_deg_s2: Vec<f64>,
    /// Mean normalised plantarflexor envelope (the activation input).
    pub activation: Vec<f64>,
    /// Its rate of change (1/s).
    pub activation_rate_per_s: Vec<f64>,
    /// Normalised TA envelope, when present.
    pub emg_ta: Option<Vec<f64>>,
}

/// Autocorrelation of the residual vs the noise model's.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct AcfPoint {
    /// Lag (ms).
    pub lag_ms: f64,
    /// Baseline residual autocorrelation.
    pub baseline: f64,
    /// Extended residual autocorrelation.
    pub extended: f64,
    /// Noise model autocorrelation.
    pub noise_model: f64,
}

/// The residual analysis.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct ResidualAnalysis {
    /// Binned baseline residual.
    pub baseline_bins: Vec<Bin>,
    /// Binned extended residual (phase and angle only).
    pub extended_bins: Vec<Bin>,
    /// Autocorrelations.
    pub acf: Vec<AcfPoint>,
    /// Structure statistic of the baseline residual.
    pub baseline_structure_lm: f64,
    /// Structure statistic of the final residual.
    pub extended_structure_lm: f64,
    /// Degrees of freedom of the structure test.
    pub structure_df: usize,
    /// Structure statistic (time blocks) of the baseline residual.
    pub baseline_time_structure_lm: f64,
    /// Structure statistic (time blocks) of the final residual.
    pub extended_time_structure_lm: f64,
    /// Degrees of freedom of the time-block test.
    pub time_structure_df: usize,
    /// Effective degrees of freedom of the noise model's low-frequency level, the `ν` of the
    /// time-block test's `F(df, ν)` reference (`null` in JSON when the level is known exactly).
    pub noise_level_dof: f64,
    /// The vocabulary test on the final residual: `LM` against the basis with the smallest
    /// p-value (a state variable's flexible basis, or the angle's, acceleration's or
    /// activation's split by the direction of motion).
    pub vocabulary_structure_lm: f64,
    /// Degrees of freedom of the vocabulary test's `LM`.
    pub vocabulary_structure_df: usize,
    /// The variable whose basis gives it (`null` when no variable could be tested).
    pub vocabulary_structure_variable: Option<crate::StateVariable>,
    /// Whether that basis was the variable's split by the direction of motion (the residual
    /// is a function of the variable that differs between plantarflexion and dorsiflexion).
    pub vocabulary_structure_by_direction: bool,
    /// Bonferroni p-value of the three structure tests on the final residual.
    pub structure_p_value: f64,
    /// `−log10` of `structure_p_value` (structure evidence; > threshold = unexplained).
    pub structure_evidence: f64,
    /// Per-sample series (not serialised).
    #[serde(skip)]
    pub series: Series,
}

fn bins_of(
    variable: &str,
    x: &[f64],
    r: &[f64],
    sel: &dyn Fn(usize) -> bool,
    edges: &[f64],
) -> Vec<Bin> {
    let mut out = Vec::new();
    for w in edges.windows(2) {
        let (lo, hi) = (w[0], w[1]);
        let (mut s, mut ss, mut n) = (0.0, 0.0, 0usize);
        for i in 0..x.len() {
            if sel(i) && x[i] >= lo && x[i] < hi {
                s += r[i];
                ss += r[i] * r[i];
                n += 1;
            }
        }
        if n > 0 {
            out.push(Bin {
                variable: variable.to_string(),
                lo,
                hi,
                label: None,
                n,
                mean_nm: s / n as f64,
                rms_nm: (ss / n as f64).sqrt(),
            });
        }
    }
    out
}

fn phase_bins(ph: &[PhaseLabel], r: &[f64], seen: &dyn Fn(usize) -> bool) -> Vec<Bin> {
    PhaseLabel::ALL
        .iter()
        .filter_map(|p| {
            let v: Vec<f64> = (0..r.len())
                .filter(|&i| ph[i] == *p && seen(i))
                .map(|i| r[i])
                .collect();
            if v.is_empty() {
                return None;
            }
            let n = v.len();
            Some(Bin {
                variable: "phase".into(),
                lo: 0.0,
                hi: 0.0,
                label: Some(p.name().into()),
                n,
                mean_nm: v.iter().sum::<f64>() / n as f64,
                rms_nm: numerics::rms(&v),
            })
        })
        .collect()
}

fn angle_bins(
    ph: &[PhaseLabel],
    angle_deg: &[f64],
    r: &[f64],
    seen: &dyn Fn(usize) -> bool,
) -> Vec<Bin> {
    let edges: Vec<f64> = (0..=8).map(|k| -20.0 + 5.0 * k as f64 - 0.01).collect();
    let mut out = Vec::new();
    for p in [
        PhaseLabel::Relaxed,
        PhaseLabel::Concentric,
        PhaseLabel::Eccentric,
    ] {
        out.extend(bins_of(
            &format!("angle_deg.{}", p.name()),
            angle_deg,
            r,
            &|i| ph[i] == p && seen(i),
            &edges,
        ));
    }
    out
}

fn quantile_edges(x: &[f64], k: usize) -> Vec<f64> {
    let mut v: Vec<f64> = x.to_vec();
    v.sort_by(f64::total_cmp);
    let mut e: Vec<f64> = (0..=k).map(|j| v[((v.len() - 1) * j) / k]).collect();
    e.dedup();
    if let Some(l) = e.last_mut() {
        *l += 1e-9;
    }
    e
}

/// Per sample, its place between the first (0) and last (1) observed sample; NaN outside.
fn span_fraction(ctx: &Context) -> Vec<f64> {
    let n = ctx.y.len();
    let first = (0..n).find(|&i| ctx.is_observed(i)).unwrap_or(0);
    let last = (0..n).rev().find(|&i| ctx.is_observed(i)).unwrap_or(0);
    let width = (last.saturating_sub(first)).max(1) as f64;
    (0..n)
        .map(|i| {
            if i < first || i > last {
                f64::NAN
            } else {
                (i - first) as f64 / width
            }
        })
        .collect()
}

/// The values of `x` at the observed samples, in order.
fn observed_values(ctx: &Context, x: &[f64]) -> Vec<f64> {
    match &ctx.observed {
        None => x.to_vec(),
        Some(o) => x
            .iter()
            .zip(o)
            .filter(|(_, seen)| **seen)
            .map(|(v, _)| *v)
            .collect(),
    }
}

fn acf(x: &[f64], k: usize) -> f64 {
    let n = x.len();
    let m = x.iter().sum::<f64>() / n as f64;
    let c0: f64 = x.iter().map(|v| (v - m) * (v - m)).sum();
    if k >= n || c0 <= 0.0 {
        return 0.0;
    }
    (0..n - k).map(|i| (x[i] - m) * (x[i + k] - m)).sum::<f64>() / c0
}

/// Step-function basis of the motion (see the module docs).
fn structure_basis(ctx: &Context) -> Vec<Vec<f64>> {
    let n = ctx.y.len();
    let seg = &ctx.seg;
    let deg: Vec<f64> = ctx.inputs.angle().iter().map(|a| a.to_degrees()).collect();
    let mut cols = Vec::new();
    for k in 0..seg.cycles.len() {
        for dir in [PhaseLabel::Concentric, PhaseLabel::Eccentric] {
            for b in 0..7 {
                let lo = -20.0 + 5.0 * b as f64;
                let col: Vec<f64> = (0..n)
                    .map(|i| {
                        let ph = seg.phase[i];
                        let is_dir = ph == dir
                            || (ph == PhaseLabel::Relaxed
                                && ((dir == PhaseLabel::Concentric)
                                    == (ctx.inputs.velocity()[i] < 0.0)));
                        if seg.cycle[i] == Some(k) && is_dir && deg[i] >= lo && deg[i] < lo + 5.0 {
                            1.0
                        } else {
                            0.0
                        }
                    })
                    .collect();
                if col.iter().sum::<f64>() > 20.0 {
                    cols.push(col);
                }
            }
        }
    }
    // holds: two halves each
    let mut i = 0;
    while i < n {
        if seg.phase[i] == PhaseLabel::Hold {
            let s = i;
            while i < n && seg.phase[i] == PhaseLabel::Hold {
                i += 1;
            }
            let mid = (s + i) / 2;
            for (a, b) in [(s, mid), (mid, i)] {
                if b - a > 20 {
                    let mut col = vec![0.0; n];
                    col[a..b].iter_mut().for_each(|v| *v = 1.0);
                    cols.push(col);
                }
            }
        } else {
            i += 1;
        }
    }
    cols
}

/// Length (s) of the time blocks of the second structure basis.
pub const TIME_BLOCK_S: f64 = 1.0;

/// Step functions of time: one indicator per block of [`TIME_BLOCK_S`] (the last block absorbs
/// a remainder shorter than half a block).
fn time_basis(ctx: &Context) -> Vec<Vec<f64>> {
    let t = ctx.inputs.times();
    let n = t.len();
    if n < 2 {
        return Vec::new();
    }
    let t0 = t[0];
    let span = t[n - 1] - t0;
    let blocks = ((span / TIME_BLOCK_S).round() as usize).max(1);
    let width = span / blocks as f64;
    (0..blocks)
        .map(|b| {
            t.iter()
                .map(|&ti| {
                    let k = (((ti - t0) / width) as usize).min(blocks - 1);
                    if k == b {
                        1.0
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect()
}

/// What every score test of one fit shares: the orthonormal basis `Q` of its whitened
/// Jacobian, its whitened residual and the residual's scale (one QR per fit, not per basis).
struct Projector {
    q: DMatrix<f64>,
    r: DVector<f64>,
    s2: f64,
}

impl Projector {
    fn new(ctx: &Context, fit: &Fit) -> Self {
        // whitened vectors have every sample (0 where unobserved); the scale counts observed ones
        let n_obs = ctx.plan.n_obs();
        let r = DVector::from_column_slice(&fit.white);
        let s2 = (r.norm_squared() / n_obs.saturating_sub(fit.k()).max(1) as f64).max(1e-12);
        Projector {
            q: fit.jac.clone().qr().q(),
            r,
            s2,
        }
    }

    /// `LM` against `cols` and the rank of the projected basis.
    fn lm(&self, ctx: &Context, cols: &[Vec<f64>]) -> (f64, usize) {
        // a recording whose motion has no step of the basis (a window of walking whose
        // segments are all shorter than a step) has nothing to test
        if cols.is_empty() {
            return (0.0, 0);
        }
        let n = self.r.len();
        let p = cols.len();
        let mut pc = DMatrix::zeros(n, p);
        for (j, c) in cols.iter().enumerate() {
            let mut w = vec![0.0; n];
            ctx.plan.whiten(c, &mut w);
            let v = DVector::from_vec(w);
            let proj = &v - &self.q * self.q.tr_mul(&v);
            pc.set_column(j, &proj);
        }
        let a = pc.tr_mul(&pc);
        let b = pc.tr_mul(&self.r);
        let svd = a.svd(true, true);
        let tol = svd.singular_values.max() * 1e-10;
        let rank = svd.singular_values.iter().filter(|s| **s > tol).count();
        match svd.solve(&b, tol) {
            Ok(beta) => (b.dot(&beta) / self.s2, rank),
            Err(_) => (0.0, rank),
        }
    }
}

/// The two structure tests of one fit (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct StructureTest {
    /// `LM` against the motion basis, and its degrees of freedom.
    pub motion_lm: f64,
    pub motion_df: usize,
    /// `LM` against the time blocks, and its degrees of freedom.
    pub time_lm: f64,
    pub time_df: usize,
    /// `ν` of the time test's `F(df, ν)` reference.
    pub noise_level_dof: f64,
    /// The vocabulary test: `LM` against the basis with the smallest p-value, its degrees of
    /// freedom and variable (`None` when none could be tested), and whether that basis was the
    /// variable's split by the direction of motion.
    pub vocabulary_lm: f64,
    pub vocabulary_df: usize,
    pub vocabulary_variable: Option<crate::StateVariable>,
    pub vocabulary_by_direction: bool,
    /// Bonferroni p-value of the vocabulary test over the variables tested.
    pub vocabulary_p: f64,
    /// Bonferroni p-value `min(1, 3·min(p_motion, p_time, p_vocabulary))`.
    pub p_value: f64,
}

/// The outcome of the vocabulary test.
struct VocabularyTest {
    lm: f64,
    df: usize,
    variable: Option<crate::StateVariable>,
    by_direction: bool,
    /// Bonferroni p-value over the bases tested.
    p: f64,
}

/// The vocabulary test (module docs): `LM` against each state variable's flexible basis and
/// against the angle's, acceleration's and activation's split by the direction of motion, its
/// p-value from `F(df, ν)` as the time test's (the bases are slow functions of the record),
/// and the Bonferroni minimum over the bases tested, with the test that gives it.
fn vocabulary_test(ctx: &Context, proj: &Projector) -> VocabularyTest {
    let nu = ctx.noise.level_dof;
    let mut tested = 0usize;
    let mut best = VocabularyTest {
        lm: 0.0,
        df: 0,
        variable: None,
        by_direction: false,
        p: 1.0,
    };
    let plain: Vec<_> = crate::StateVariable::ALL
        .into_iter()
        .filter_map(|v| crate::flexible::basis(ctx, v))
        .collect();
    // the split bases come from the plain ones, after them (a tie keeps the plain basis)
    let d = crate::flexible::direction_signs(ctx);
    let split = plain
        .iter()
        .filter(|b| crate::flexible::SPLIT_BY_DIRECTION.contains(&b.variable))
        .filter_map(|b| {
            let cols = crate::flexible::split_by_direction(b, d.as_deref()?);
            Some((b.variable, true, cols))
        });
    let split: Vec<_> = split.collect();
    let plain = plain.into_iter().map(|b| (b.variable, false, b.cols));
    for (v, by_direction, cols) in plain.chain(split) {
        let (lm, df) = proj.lm(ctx, &cols);
        if df == 0 {
            continue;
        }
        tested += 1;
        let p = f_survival(lm / df as f64, df, nu);
        if p < best.p {
            best = VocabularyTest {
                lm,
                df,
                variable: Some(v),
                by_direction,
                p,
            };
        }
    }
    best.p = (tested.max(1) as f64 * best.p).min(1.0);
    best
}

/// The structure tests of `fit`'s residual (module docs).
pub(crate) fn structure_test(ctx: &Context, fit: &Fit) -> StructureTest {
    structure_test_with(ctx, fit, &structure_basis(ctx), &time_basis(ctx))
}

/// [`structure_test`] against motion and time bases already built.
fn structure_test_with(
    ctx: &Context,
    fit: &Fit,
    mcols: &[Vec<f64>],
    tcols: &[Vec<f64>],
) -> StructureTest {
    let proj = Projector::new(ctx, fit);
    let (motion_lm, motion_df) = proj.lm(ctx, mcols);
    let (time_lm, time_df) = proj.lm(ctx, tcols);
    let nu = ctx.noise.level_dof;
    let p_motion = chi2_survival(motion_lm, motion_df);
    let p_time = f_survival(time_lm / time_df.max(1) as f64, time_df, nu);
    let voc = vocabulary_test(ctx, &proj);
    StructureTest {
        motion_lm,
        motion_df,
        time_lm,
        time_df,
        noise_level_dof: nu,
        vocabulary_lm: voc.lm,
        vocabulary_df: voc.df,
        vocabulary_variable: voc.variable,
        vocabulary_by_direction: voc.by_direction,
        vocabulary_p: voc.p,
        p_value: (3.0 * p_motion.min(p_time).min(voc.p)).min(1.0),
    }
}

/// Builds the analysis of the baseline and final fits.
pub(crate) fn analyse(
    ctx: &Context,
    baseline: &Fit,
    fin: &Fit,
    structure_threshold_unused: f64,
) -> ResidualAnalysis {
    let _ = structure_threshold_unused;
    // (the threshold is applied by the caller to `structure_evidence`)
    let inp = &ctx.inputs;
    let n = ctx.y.len();
    let fs = inp.fs();
    let rb: Vec<f64> = ctx
        .y
        .iter()
        .zip(&baseline.pred)
        .map(|(a, b)| a - b)
        .collect();
    let re: Vec<f64> = ctx.y.iter().zip(&fin.pred).map(|(a, b)| a - b).collect();
    let deg: Vec<f64> = inp.angle().iter().map(|a| a.to_degrees()).collect();
    let vel: Vec<f64> = inp.velocity().iter().map(|a| a.to_degrees()).collect();
    let acc: Vec<f64> = inp.acceleration().iter().map(|a| a.to_degrees()).collect();
    let act = crate::StateVariable::Activation
        .samples(inp)
        .expect("every trial has the triceps envelopes");
    let rate: Vec<f64> = (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            (act[b] - act[a]) * fs / (b - a).max(1) as f64
        })
        .collect();
    let ph = &ctx.seg.phase;
    let all = |i: usize| ctx.is_observed(i);
    let mut bb = phase_bins(ph, &rb, &all);
    bb.extend(angle_bins(ph, &deg, &rb, &all));
    bb.extend(bins_of(
        "velocity_deg_s",
        &vel,
        &rb,
        &all,
        &[-31.0, -20.0, -1.0, 1.0, 20.0, 31.0],
    ));
    bb.extend(bins_of(
        "acceleration_deg_s2",
        &acc,
        &rb,
        &all,
        &[-700.0, -100.0, 100.0, 700.0],
    ));
    bb.extend(bins_of(
        "activation",
        &act,
        &rb,
        &all,
        &quantile_edges(&observed_values(ctx, &act), 5),
    ));
    bb.extend(bins_of(
        "activation_rate_per_s",
        &rate,
        &rb,
        &all,
        &quantile_edges(&observed_values(ctx, &rate), 5),
    ));
    if ctx.seg.cycles.is_empty() {
        let frac = span_fraction(ctx);
        // tenths, the last closed at 1
        let mut edges: Vec<f64> = (0..=10).map(|k| k as f64 / 10.0).collect();
        edges[10] += 1e-9;
        let seen_in_span = |i: usize| ctx.is_observed(i) && frac[i].is_finite();
        bb.extend(bins_of("span_fraction", &frac, &rb, &seen_in_span, &edges));
    }
    if let Some(ta) = inp.envelope_ta() {
        let edges = quantile_edges(&observed_values(ctx, ta), 5);
        bb.extend(bins_of("emg_ta", ta, &rb, &all, &edges));
    }
    let mut eb = phase_bins(ph, &re, &all);
    eb.extend(angle_bins(ph, &deg, &re, &all));
    // the autocorrelation of the compared samples (one span for a CEINMS trial)
    let (rb_seen, re_seen) = (observed_values(ctx, &rb), observed_values(ctx, &re));
    let lags_ms = [0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 30.0, 50.0, 100.0, 200.0];
    let acf_pts = lags_ms
        .iter()
        .map(|&ms| {
            let k = ((ms * 1e-3 * fs).round() as usize).max(1);
            AcfPoint {
                lag_ms: k as f64 / fs * 1e3,
                baseline: acf(&rb_seen, k),
                extended: acf(&re_seen, k),
                noise_model: ctx.noise.autocorrelation(k),
            }
        })
        .collect();
    // both fits are tested against the same bases; the baseline's statistics are reported only
    let (mcols, tcols) = (structure_basis(ctx), time_basis(ctx));
    let base_proj = Projector::new(ctx, baseline);
    let (lb, df) = base_proj.lm(ctx, &mcols);
    let (ltb, tdf) = base_proj.lm(ctx, &tcols);
    let fin_test = structure_test_with(ctx, fin, &mcols, &tcols);
    let (le, lte, nu, p) = (
        fin_test.motion_lm,
        fin_test.time_lm,
        fin_test.noise_level_dof,
        fin_test.p_value,
    );
    ResidualAnalysis {
        baseline_bins: bb,
        extended_bins: eb,
        acf: acf_pts,
        baseline_structure_lm: lb,
        extended_structure_lm: le,
        structure_df: df,
        baseline_time_structure_lm: ltb,
        extended_time_structure_lm: lte,
        time_structure_df: tdf,
        noise_level_dof: nu,
        vocabulary_structure_lm: fin_test.vocabulary_lm,
        vocabulary_structure_df: fin_test.vocabulary_df,
        vocabulary_structure_variable: fin_test.vocabulary_variable,
        vocabulary_structure_by_direction: fin_test.vocabulary_by_direction,
        structure_p_value: p,
        // −log10 of p = 1 is −0
        structure_evidence: -p.max(1e-300).log10() + 0.0,
        series: Series {
            time_s: inp.times().to_vec(),
            baseline_residual_nm: rb,
            extended_residual_nm: re,
            phase: ph.clone(),
            angle_deg: deg,
            velocity_deg_s: vel,
            acceleration_deg_s2: acc,
            activation: act,
            activation_rate_per_s: rate,
            emg_ta: inp.envelope_ta().map(|t| t.to_vec()),
        },
    }
}
