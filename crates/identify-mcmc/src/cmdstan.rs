//! The kept draws of one chain as a CmdStan-format CSV, the layout `arviz.from_cmdstan` reads.
//!
//! # Format
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
//! * The sampler is random-walk Metropolis–Hastings with mode jumps, not NUTS: none of NUTS's
//!   per-draw statistics (`stepsize__`, `treedepth__`, `n_leapfrog__`, `divergent__`,
//!   `energy__`) exist for it, and its per-step acceptance probability is not recorded, so
//!   `lp__` is the only `__` column.
//! * Numbers are Rust's shortest representation that reads back to the same `f64`, so a reader
//!   recovers every draw bit for bit and the means agree with `identify.json` to rounding.

use std::io::Write;

use crate::McmcIdentification;

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
    for line in description {
        writeln!(w, "# {line}")?;
    }
    writeln!(w, "# method = sample")?;
    writeln!(w, "#   sample")?;
    writeln!(w, "#     num_samples = {}", m.sampling_iterations)?;
    writeln!(w, "#     num_warmup = {}", m.warmup_iterations)?;
    writeln!(w, "#     save_warmup = 0")?;
    writeln!(w, "#     thin = {}", m.run.settings.thin.max(1))?;
    writeln!(w, "#     algorithm = metropolis_hastings")?;
    writeln!(w, "# id = {}", chain + 1)?;
    writeln!(w, "# random")?;
    writeln!(w, "#   seed = {seed}")?;
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
