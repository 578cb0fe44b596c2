//! One-at-a-time sensitivity sweep (dissertation Fig. 6): RMS torque change per parameter change.

use crate::effects::Effects;
use crate::error::ModelError;
use crate::inputs::TrialInputs;
use crate::params::ModelParams;
use crate::problem::ParamId;
use crate::settings::SimSettings;
use crate::simulate::simulate_into;
use crate::workspace::Workspace;
use serde::Serialize;
use std::fmt::Write as _;

/// What to sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct SensitivitySettings {
    /// Relative changes in percent (the default is −20, −15, …, +20 without 0).
    pub changes_pct: Vec<f64>,
    /// Parameters to sweep (default: the 9 identified ones).
    pub params: Vec<ParamId>,
    /// A parameter "matters" when its largest RMS torque change is at least this percentage of
    /// the nominal RMS torque (default 5 %).
    pub threshold_pct: f64,
    /// Simulation settings.
    pub sim: SimSettings,
}

impl Default for SensitivitySettings {
    fn default() -> Self {
        SensitivitySettings {
            changes_pct: vec![-20.0, -15.0, -10.0, -5.0, 5.0, 10.0, 15.0, 20.0],
            params: ParamId::identified().to_vec(),
            threshold_pct: 5.0,
            sim: SimSettings::default(),
        }
    }
}

/// One simulated variation.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SensitivityRow {
    /// Parameter name (`sol.lst_m`, …).
    pub param: String,
    /// Relative change (%).
    pub change_pct: f64,
    /// Parameter value used.
    pub value: f64,
    /// RMS of the torque change vs nominal (N·m); `None` when the simulation failed.
    pub rms_change_nm: Option<f64>,
    /// Largest absolute torque change (N·m); `None` when the simulation failed.
    pub max_abs_change_nm: Option<f64>,
    /// Why the simulation failed, if it did.
    pub error: Option<String>,
}

/// Summary of one parameter, for the ranking.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SensitivityRank {
    /// Parameter name.
    pub param: String,
    /// Largest RMS torque change over the sweep (N·m).
    pub max_rms_change_nm: f64,
    /// The same as a percentage of the nominal RMS torque.
    pub max_rms_change_pct: f64,
    /// Whether the parameter matters (≥ the threshold).
    pub matters: bool,
}

/// The result table of a sweep.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SensitivityTable {
    /// RMS of the nominal torque (N·m).
    pub nominal_rms_torque_nm: f64,
    /// The threshold used for `matters` (% of the nominal RMS torque).
    pub threshold_pct: f64,
    /// One row per (parameter, change).
    pub rows: Vec<SensitivityRow>,
    /// Parameters from most to least influential.
    pub ranking: Vec<SensitivityRank>,
}

/// Runs the sweep: for each parameter and change, simulate with the parameter scaled by
/// `1 + change/100` and compute the RMS and max of the torque difference to the nominal run.
///
/// The nominal run must succeed; a failing variation is recorded in its row (`error`) and does
/// not abort the sweep.
pub fn sensitivity(
    inputs: &TrialInputs,
    params: &ModelParams,
    effects: &Effects,
    settings: &SensitivitySettings,
) -> Result<SensitivityTable, ModelError> {
    let n = inputs.len();
    let mut ws = Workspace::new();
    let mut nominal = vec![0.0; n];
    simulate_into(
        &mut ws,
        inputs,
        params,
        effects,
        &settings.sim,
        &mut nominal,
    )?;
    let nominal_rms = (nominal.iter().map(|t| t * t).sum::<f64>() / n as f64).sqrt();
    let mut out = vec![0.0; n];
    let mut rows = Vec::new();
    let mut ranking = Vec::new();
    for id in &settings.params {
        let v0 = id.get(params, effects);
        let mut best = 0.0_f64;
        for &pct in &settings.changes_pct {
            let value = v0 * (1.0 + pct / 100.0);
            let (mut p, mut e) = (*params, *effects);
            id.set(&mut p, &mut e, value);
            let row = match simulate_into(&mut ws, inputs, &p, &e, &settings.sim, &mut out) {
                Ok(_) => {
                    let mut ss = 0.0;
                    let mut mx = 0.0_f64;
                    for (a, b) in out.iter().zip(&nominal) {
                        let d = a - b;
                        ss += d * d;
                        mx = mx.max(d.abs());
                    }
                    let rms = (ss / n as f64).sqrt();
                    best = best.max(rms);
                    SensitivityRow {
                        param: id.name(),
                        change_pct: pct,
                        value,
                        rms_change_nm: Some(rms),
                        max_abs_change_nm: Some(mx),
                        error: None,
                    }
                }
                Err(err) => SensitivityRow {
                    param: id.name(),
                    change_pct: pct,
                    value,
                    rms_change_nm: None,
                    max_abs_change_nm: None,
                    error: Some(err.to_string()),
                },
            };
            rows.push(row);
        }
        let pct = if nominal_rms > 0.0 {
            100.0 * best / nominal_rms
        } else {
            0.0
        };
        ranking.push(SensitivityRank {
            param: id.name(),
            max_rms_change_nm: best,
            max_rms_change_pct: pct,
            matters: pct >= settings.threshold_pct,
        });
    }
    ranking.sort_by(|a, b| b.max_rms_change_nm.total_cmp(&a.max_rms_change_nm));
    Ok(SensitivityTable {
        nominal_rms_torque_nm: nominal_rms,
        threshold_pct: settings.threshold_pct,
        rows,
        ranking,
    })
}

impl SensitivityTable {
    /// CSV with header `param,change_pct,value,rms_change_nm,max_abs_change_nm,error` (empty
    /// fields for failed runs).
    pub fn to_csv(&self) -> String {
        let mut s = String::from("param,change_pct,value,rms_change_nm,max_abs_change_nm,error\n");
        for r in &self.rows {
            let f = |v: Option<f64>| v.map(|x| format!("{x:.6}")).unwrap_or_default();
            let err = r
                .error
                .as_deref()
                .map(|e| format!("\"{}\"", e.replace('"', "'")))
                .unwrap_or_default();
            let _ = writeln!(
                s,
                "{},{},{},{},{},{}",
                r.param,
                r.change_pct,
                r.value,
                f(r.rms_change_nm),
                f(r.max_abs_change_nm),
                err
            );
        }
        s
    }

    /// Pretty JSON of the whole table.
    pub fn to_json_string(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_else(|_| "{}".into())
    }

    /// Names of the parameters that matter, most influential first.
    pub fn important(&self) -> Vec<&str> {
        self.ranking
            .iter()
            .filter(|r| r.matters)
            .map(|r| r.param.as_str())
            .collect()
    }

    /// Number of variations whose simulation failed.
    pub fn failures(&self) -> usize {
        self.rows.iter().filter(|r| r.error.is_some()).count()
    }

    /// A human-readable ranking.
    pub fn summary(&self) -> String {
        let mut s = format!(
            "nominal RMS torque {:.2} N·m; largest RMS torque change per parameter:\n",
            self.nominal_rms_torque_nm
        );
        for r in &self.ranking {
            let _ = writeln!(
                s,
                "  {:<24} {:>8.2} N·m ({:>5.1} %){}",
                r.param,
                r.max_rms_change_nm,
                r.max_rms_change_pct,
                if r.matters { "  matters" } else { "" }
            );
        }
        let failed = self.failures();
        if failed > 0 {
            let _ = writeln!(s, "  {failed} variation(s) failed to simulate");
        }
        s
    }
}
