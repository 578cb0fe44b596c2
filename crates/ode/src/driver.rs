//! Integration over a grid of output times ([`dopri5_dense`]) with dense output, so that the
//! step size is not tied to the grid.

use crate::dopri5::DoPri5;
use crate::error::OdeError;
use crate::settings::AdaptiveSettings;
use crate::stats::Stats;
use crate::system::OdeSystem;

/// Integrates from `t_out[0]` to the last output time and calls
/// `out(i, &y(t_out[i]))` for every output time, in order, using dense output
/// (so the step size is not tied to the grid). `out(0, &y0)` comes first.
///
/// `t_out` must be strictly increasing and finite.
pub fn dopri5_dense<S: OdeSystem<N>, const N: usize>(
    sys: &mut S,
    y0: [f64; N],
    t_out: &[f64],
    settings: &AdaptiveSettings,
    mut out: impl FnMut(usize, &[f64; N]),
) -> Result<Stats, OdeError> {
    let mut stepper = DoPri5::<N>::new(*settings)?;
    let Some(&t0) = t_out.first() else {
        return Err(OdeError::InvalidInput {
            what: "no output times",
        });
    };
    if t_out
        .windows(2)
        .any(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater))
        || !t_out.iter().all(|t| t.is_finite())
    {
        return Err(OdeError::InvalidInput {
            what: "output times must be finite and strictly increasing",
        });
    }
    out(0, &y0);
    if t_out.len() == 1 {
        return Ok(Stats::default());
    }
    let t_end = t_out[t_out.len() - 1];
    stepper.init(sys, t0, y0, t_end)?;
    let mut next = 1;
    let mut buf = [0.0; N];
    while next < t_out.len() {
        stepper.step(sys)?;
        while next < t_out.len() && t_out[next] <= stepper.t() {
            if t_out[next] == stepper.t() {
                out(next, stepper.y());
            } else {
                stepper.interpolate(t_out[next], &mut buf);
                out(next, &buf);
            }
            next += 1;
        }
    }
    Ok(stepper.stats())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_bad_settings() {
        assert!(DoPri5::<1>::new(AdaptiveSettings::default().with_rtol(-1.0)).is_err());
        assert!(DoPri5::<1>::new(AdaptiveSettings::default().with_max_steps(0)).is_err());
        let mut sys = |_t: f64, _y: &[f64; 1], d: &mut [f64; 1]| d[0] = 0.0;
        let r = dopri5_dense(
            &mut sys,
            [0.0],
            &[0.0, 1.0, 0.5],
            &AdaptiveSettings::default(),
            |_, _| {},
        );
        assert!(matches!(r, Err(OdeError::InvalidInput { .. })));
    }
}
