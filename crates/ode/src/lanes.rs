//! Several independent integrations advanced together ([`attempt_lanes`]), for the
//! processor's sake only: the same bits as each integrated alone.

use crate::dopri5::DoPri5;
use crate::error::OdeError;
use crate::system::OdeSystem;

/// One attempt of every active lane: `L` independent integrations advanced together, stage by
/// stage, so that a processor can overlap their right-hand sides (each alone is one long
/// chain of dependent operations). Every lane computes exactly what [`DoPri5::step`] computes,
/// attempt for attempt, so its results are the same bits as when it is integrated alone.
///
/// `active[l]` selects the lanes (a lane must be initialised and not
/// [`finished`](DoPri5::finished)); returns which lanes' attempts were accepted (their
/// [`DoPri5::dense`] then covers the new step), or the first failing lane and its error.
pub fn attempt_lanes<S: OdeSystem<N>, const N: usize, const L: usize>(
    steppers: &mut [DoPri5<N>; L],
    systems: &mut [S; L],
    active: [bool; L],
) -> Result<[bool; L], (usize, OdeError)> {
    let mut h = [0.0; L];
    let mut remaining = [0.0; L];
    for l in 0..L {
        if active[l] {
            steppers[l].check_can_step().map_err(|e| (l, e))?;
            (h[l], remaining[l]) = steppers[l].prepare().map_err(|e| (l, e))?;
        }
    }
    macro_rules! stage {
        ($f:ident) => {
            for l in 0..L {
                if active[l] {
                    steppers[l].$f(&mut systems[l], h[l]);
                }
            }
        };
    }
    stage!(stage2);
    stage!(stage3);
    stage!(stage4);
    stage!(stage5);
    stage!(stage6);
    stage!(stage7);
    let mut accepted = [false; L];
    for l in 0..L {
        if active[l] {
            accepted[l] = steppers[l]
                .conclude(h[l], remaining[l])
                .map_err(|e| (l, e))?;
        }
    }
    Ok(accepted)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::AdaptiveSettings;
    use crate::test_systems::Forced;

    #[test]
    fn lanes_equal_each_integration_alone_bit_for_bit() {
        let ks = [1.0, 40.0, 400.0];
        let set = AdaptiveSettings::default().with_rtol(1e-7).with_atol(1e-9);
        // alone: the sequence of accepted steps and states
        let alone: Vec<Vec<(f64, [f64; 2])>> = ks
            .iter()
            .map(|&k| {
                let mut st = DoPri5::<2>::new(set).unwrap();
                let mut sys = Forced { k };
                st.init(&mut sys, 0.0, [1.0, 0.0], 3.0).unwrap();
                let mut v = Vec::new();
                while !st.finished() {
                    st.step(&mut sys).unwrap();
                    v.push((st.t(), *st.y()));
                }
                assert!(st.stats().rejected > 0 || k < 100.0);
                v
            })
            .collect();
        let mut steppers: [DoPri5<2>; 3] = std::array::from_fn(|_| DoPri5::new(set).unwrap());
        let mut systems = ks.map(|k| Forced { k });
        for l in 0..3 {
            steppers[l]
                .init(&mut systems[l], 0.0, [1.0, 0.0], 3.0)
                .unwrap();
        }
        let mut together: Vec<Vec<(f64, [f64; 2])>> = vec![Vec::new(); 3];
        // lane 1 starts late: lanes need not be in step
        let mut round = 0;
        loop {
            let active = std::array::from_fn(|l| !steppers[l].finished() && (l != 1 || round > 5));
            if !active.iter().any(|a| *a) {
                break;
            }
            let acc = attempt_lanes(&mut steppers, &mut systems, active).unwrap();
            for l in 0..3 {
                if acc[l] {
                    together[l].push((steppers[l].t(), *steppers[l].y()));
                }
            }
            round += 1;
        }
        for l in 0..3 {
            assert_eq!(together[l], alone[l], "lane {l}");
            assert!(alone[l].len() > 10);
        }
    }
}
