//! Special functions: the normal distribution ([`normal_cdf`], [`normal_quantile`],
//! [`erfc`]) and the gamma family ([`ln_gamma`], [`gamma_q`], [`chi2_survival`],
//! [`chi2_upper_quantile`], [`noncentral_chi2_survival`], [`beta_regularized`],
//! [`f_survival`], [`t_survival`]). The equations are in the two submodules' documentation.
//!
//! ```
//! use numerics::special::{chi2_survival, normal_cdf, normal_quantile};
//! assert!((normal_cdf(normal_quantile(0.9)) - 0.9).abs() < 1e-14);
//! // χ²(2) has the tail e^{−x/2}
//! assert!((chi2_survival(3.0, 2) - (-1.5f64).exp()).abs() < 1e-14);
//! ```

mod gamma;
mod normal;

pub use gamma::{
    beta_regularized, chi2_survival, chi2_upper_quantile, f_survival, gamma_q, ln_gamma,
    noncentral_chi2_survival, t_survival,
};
pub use normal::{erfc, normal_cdf, normal_quantile};
