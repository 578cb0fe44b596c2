//! End-to-end tests across the surae crates live in `tests/tests/`: the model
//! against an independent implementation of SPEC §2–3 (`bench/peer`), through
//! the same file-reading and envelope path a user's recording takes.
