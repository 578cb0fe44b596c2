//! Integrator work of a simulation, per muscle ([`SimStats`]).

use serde::{Deserialize, Serialize};

/// Integrator work of one muscle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SimStats {
    /// Accepted steps.
    pub accepted: usize,
    /// Rejected steps.
    pub rejected: usize,
    /// Right-hand-side evaluations.
    pub rhs_calls: usize,
}

impl From<ode::Stats> for SimStats {
    fn from(s: ode::Stats) -> Self {
        SimStats {
            accepted: s.accepted,
            rejected: s.rejected,
            rhs_calls: s.rhs_calls,
        }
    }
}

impl SimStats {
    /// Adds `other`'s counts to these.
    pub(crate) fn add(&mut self, other: SimStats) {
        self.accepted += other.accepted;
        self.rejected += other.rejected;
        self.rhs_calls += other.rhs_calls;
    }
}
