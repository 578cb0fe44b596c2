//! Diagnosis of what the simulation gets wrong: residual analysis, ranking of the
//! SPEC §6 model extensions and their held-out gain. Not implemented yet: this
//! crate holds no functions until the diagnosis issue fills it.
