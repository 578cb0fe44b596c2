//! The kept draws of one chain as a CmdStan-format CSV, the layout `arviz.from_cmdstan` reads:
//! [`write_cmdstan_chain`] for an identification (random-walk Metropolis–Hastings),
//! [`write_cmdstan_nuts_chain`] for a [`NutsRun`], whose rows carry CmdStan's NUTS statistics
//! (`lp__,accept_stat__,stepsize__,treedepth__,n_leapfrog__,divergent__,energy__`, then the
//! parameters; see that function).
//!
//! # Format (identification)
//!
//! ```text
//! # <free text lines>
//! # method = sample
//! #   sample
//! #     num_samples = <sampling iterations per chain>
//! #     num_warmup = <warm-up iterations per chain>
//! #     save_warmup = 0
//! #     thin = <thin>
//! #     algorithm = metropolis_hastings
//! # id = <chain number, from 1>
//! # random
//! #   seed = <seed>
//! lp__,sol_lst_m,sol_fom_n,…,log_lik.1
//! <one row per kept post-warm-up draw>
//! ```
//!
//! * `#` lines come first, as CmdStan writes its configuration: readers take `num_warmup`,
//!   `save_warmup` and `thin` from them to know that every row is a post-warm-up draw (no
//!   warm-up draws are written, `save_warmup = 0`).
//! * `lp__ = ln p(x) + ℓ(x)`: the log posterior density of the model's parameters `x` up to the
//!   evidence, with `ln p(x) = −Σᵢ ln(hᵢ − lᵢ)` the uniform prior on the bounds box and `ℓ(x)`
//!   the log-likelihood stored with each draw. The parameters are written on their own scale,
//!   so there is no Jacobian term (CmdStan's `lp__` is on the unconstrained scale; the two
//!   differ by a function of `x`, which matters only when comparing across programs).
//! * Parameter columns are the model's names with `_` for `.` (`sol.lst_m` → `sol_lst_m`):
//!   a `.` in a CmdStan column name separates array indices.
//! * `log_lik.<t>`: the log-likelihood of trial `t` (from 1) at the draw, so that ArviZ puts it
//!   in its `log_likelihood` group (leave-one-trial-out comparison). An identification of one
//!   trial has the single column `log_lik.1 = ℓ(x)`.
//! * The identification's sampler is random-walk Metropolis–Hastings with mode jumps, not NUTS:
//!   none of NUTS's per-draw statistics (`stepsize__`, `treedepth__`, `n_leapfrog__`,
//!   `divergent__`, `energy__`) exist for it, and its per-step acceptance probability is not
//!   recorded, so `lp__` is the only `__` column.
//! * Numbers are Rust's shortest representation that reads back to the same `f64`, so a reader
//!   recovers every draw bit for bit and the means agree with `identify.json` to rounding.

use std::io::Write;

use crate::{McmcIdentification, NutsRun};

/// The CmdStan column name of a model parameter (`sol.lst_m` → `sol_lst_m`).
pub fn cmdstan_column(name: &str) -> String {
    name.replace('.', "_")
}

/// `ln p(x)` of the uniform prior on `bounds`: `−Σ ln(hi − lo)`.
pub fn uniform_log_prior(bounds: &[(f64, f64)]) -> f64 {
    -bounds.iter().map(|(lo, hi)| (hi - lo).ln()).sum::<f64>()
}

/// Writes chain `chain` (from 0) of `m` in CmdStan's CSV layout (module documentation).
/// `seed` is the run's seed, `description` free text for the first `#` lines (one line each).
///
/// # Errors
/// I/O errors of `w`; `InvalidInput` when `chain` is not one of the run's chains.
pub fn write_cmdstan_chain<W: Write>(
    m: &McmcIdentification,
    chain: usize,
    seed: u64,
    description: &[&str],
    mut w: W,
) -> std::io::Result<()> {
    let log_lik = m.run.log_density.get(chain).ok_or_else(|| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!(
                "chain {chain} requested but the run has {} chains",
                m.run.log_density.len()
            ),
        )
    })?;
    write_config(
        &mut w,
        description,
        m.sampling_iterations,
        m.warmup_iterations,
        m.run.settings.thin.max(1),
        &["algorithm = metropolis_hastings".to_string()],
        chain,
        seed,
    )?;
    write!(w, "lp__")?;
    for n in &m.names {
        write!(w, ",{}", cmdstan_column(n))?;
    }
    writeln!(w, ",log_lik.1")?;
    let log_prior = uniform_log_prior(&m.bounds);
    for (k, l) in log_lik.iter().enumerate() {
        write!(w, "{}", log_prior + l)?;
        for p in &m.run.draws {
            write!(w, ",{}", p[chain][k])?;
        }
        writeln!(w, ",{l}")?;
    }
    Ok(())
}

/// The `#` lines before the column names: free text, then CmdStan's configuration block with
/// `algorithm` followed by the sampler's own lines.
#[allow(clippy::too_many_arguments)]
fn write_config<W: Write>(
    w: &mut W,
    description: &[&str],
    num_samples: usize,
    num_warmup: usize,
    thin: usize,
    algorithm: &[String],
    chain: usize,
    seed: u64,
) -> std::io::Result<()> {
    for line in description {
        writeln!(w, "# {line}")?;
    }
    writeln!(w, "# method = sample")?;
    writeln!(w, "#   sample")?;
    writeln!(w, "#     num_samples = {num_samples}")?;
    writeln!(w, "#     num_warmup = {num_warmup}")?;
    writeln!(w, "#     save_warmup = 0")?;
    writeln!(w, "#     thin = {thin}")?;
    for line in algorithm {
        writeln!(w, "#     {line}")?;
    }
    writeln!(w, "# id = {}", chain + 1)?;
    writeln!(w, "# random")?;
    writeln!(w, "#   seed = {seed}")
}

/// CmdStan's sampler-statistics columns of NUTS, in CmdStan's order, between `lp__` and the
/// parameters.
pub const NUTS_COLUMNS: [&str; 7] = [
    "lp__",
    "accept_stat__",
    "stepsize__",
    "treedepth__",
    "n_leapfrog__",
    "divergent__",
    "energy__",
];

/// What [`write_cmdstan_nuts_chain`] writes: the sampler's settings, per-draw statistics,
/// adapted step sizes and metrics and the draws (`[parameter][chain][draw]`, box
/// coordinates), from a [`NutsRun`] or from a [`crate::McmcIdentification`] sampled by NUTS
/// ([`crate::McmcIdentification::nuts_chains`]).
#[derive(Clone, Copy, Debug)]
pub struct NutsChains<'a> {
    /// The sampler's settings.
    pub settings: &'a crate::NutsSettings,
    /// Sampler statistics of every kept draw, `[chain][draw]`.
    pub stats: &'a [Vec<crate::NutsDraw>],
    /// The adapted step size of every chain.
    pub step_size: &'a [f64],
    /// The adapted inverse metric of every chain.
    pub inv_metric: &'a [Vec<f64>],
    /// The kept draws, `[parameter][chain][draw]`.
    pub draws: &'a [Vec<Vec<f64>>],
}

impl<'a> From<&'a NutsRun> for NutsChains<'a> {
    fn from(run: &'a NutsRun) -> Self {
        NutsChains {
            settings: &run.settings,
            stats: &run.stats,
            step_size: &run.step_size,
            inv_metric: &run.inv_metric,
            draws: &run.draws,
        }
    }
}

/// Writes chain `chain` (from 0) of a [`NutsRun`] in CmdStan's CSV layout, as CmdStan's NUTS
/// writes it: the configuration `#` lines (`algorithm = hmc`, `engine = nuts`, the adaptation
/// settings), the columns [`NUTS_COLUMNS`] then the parameters (`names`, `_` for `.`), CmdStan's
/// adaptation block (`# Step size = …`, `# Diagonal elements of inverse mass matrix:`) and one
/// row per kept draw.
///
/// * `lp__` is CmdStan's: `log π(x(u)) + log J(u)` on the unconstrained coordinates `u`
///   (the transform's Jacobian included), so that `energy__ = −lp__ + ½pᵀM⁻¹p` as in CmdStan;
///   `log π(x)` on the box is [`NutsRun::log_density`].
/// * `divergent__` is `0` or `1`; the parameters are the draws in the box coordinates.
///
/// # Errors
/// I/O errors of `w`; `InvalidInput` when `chain` is not one of the run's chains or `names`
/// does not have one name per parameter.
pub fn write_cmdstan_nuts_chain<'a, W: Write>(
    run: impl Into<NutsChains<'a>>,
    names: &[&str],
    chain: usize,
    description: &[&str],
    mut w: W,
) -> std::io::Result<()> {
    let run: NutsChains<'a> = run.into();
    let invalid = |msg: String| std::io::Error::new(std::io::ErrorKind::InvalidInput, msg);
    let stats = run.stats.get(chain).ok_or_else(|| {
        invalid(format!(
            "chain {chain} requested but the run has {} chains",
            run.stats.len()
        ))
    })?;
    if names.len() != run.draws.len() {
        return Err(invalid(format!(
            "{} names given for {} parameters",
            names.len(),
            run.draws.len()
        )));
    }
    let s = run.settings;
    let algorithm = [
        "adapt".to_string(),
        format!("  engaged = {}", u8::from(s.warmup > 0)),
        "  gamma = 0.05".to_string(),
        format!("  delta = {}", s.target_accept),
        "  kappa = 0.75".to_string(),
        "  t0 = 10".to_string(),
        format!("  init_buffer = {}", s.init_buffer),
        format!("  term_buffer = {}", s.term_buffer),
        format!("  window = {}", s.base_window),
        "algorithm = hmc".to_string(),
        "  hmc".to_string(),
        "    engine = nuts".to_string(),
        "      nuts".to_string(),
        format!("        max_depth = {}", s.max_depth),
        format!(
            "    metric = {}",
            if s.dense_metric { "dense_e" } else { "diag_e" }
        ),
        format!("    stepsize = {}", s.initial_step_size),
    ];
    write_config(
        &mut w,
        description,
        s.draws,
        s.warmup,
        1,
        &algorithm,
        chain,
        s.seed,
    )?;
    write!(w, "{}", NUTS_COLUMNS.join(","))?;
    for n in names {
        write!(w, ",{}", cmdstan_column(n))?;
    }
    writeln!(w)?;
    writeln!(w, "# Adaptation terminated")?;
    writeln!(w, "# Step size = {}", run.step_size[chain])?;
    let inv: Vec<String> = run.inv_metric[chain].iter().map(f64::to_string).collect();
    if s.dense_metric {
        // CmdStan's dense_e block: every row of the inverse metric
        writeln!(w, "# Elements of inverse mass matrix:")?;
        for row in inv.chunks(run.draws.len().max(1)) {
            writeln!(w, "# {}", row.join(", "))?;
        }
    } else {
        writeln!(w, "# Diagonal elements of inverse mass matrix:")?;
        writeln!(w, "# {}", inv.join(", "))?;
    }
    for (k, st) in stats.iter().enumerate() {
        write!(
            w,
            "{},{},{},{},{},{},{}",
            st.lp,
            st.accept_stat,
            st.step_size,
            st.tree_depth,
            st.n_leapfrog,
            u8::from(st.divergent),
            st.energy
        )?;
        for p in run.draws {
            write!(w, ",{}", p[chain][k])?;
        }
        writeln!(w)?;
    }
    Ok(())
}
