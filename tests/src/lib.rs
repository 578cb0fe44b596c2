//! End-to-end tests across the surae crates live in `tests/tests/`: the model
//! against an independent implementation of its equations (`bench/peer` for the
//! muscle torque, the joint-level effects written in the test from their
//! definitions), through the same file-reading and envelope path a user's
//! recording takes.
