//! End-to-end tests across the surae crates live in `tests/tests/`.
