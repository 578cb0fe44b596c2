//! What the session tests share.
// each test file uses its own subset
#![allow(dead_code)]

pub mod synthetic_session;
