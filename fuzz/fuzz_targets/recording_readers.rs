//! Fuzz target: the readers of a lab's recordings — delimited text, OpenSim storage, C3D
//! analog channels and the recording map — never panic on any bytes, every error they return
//! displays as exactly one line that starts with the file's name, and what they accept is
//! consistent (equal channel lengths, one line per row of a text file, unique labels).
//!
//! libfuzzer-sys makes every panic abort, also one that `recording::c3d` catches around the
//! c3dio parser (its last guard): a crash whose stack is inside c3dio may be such a caught
//! panic. Give that input to `recording::c3d::parse_c3d` outside the fuzzer: an error there
//! (not a panic) means the reader handles it.
//!
//! Run with `cargo +nightly fuzz run recording_readers` (seeds in
//! `corpus/recording_readers/`: short tab, semicolon / Latin-1, preamble / CRLF exports, a
//! version 1 `.mot` and a version 2 `.sto`, a tiny C3D and a truncated one, a map with every
//! key).
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use recording::{DelimitedOptions, RecordingError, RecordingTable};

/// The message must be one non-empty line that starts with the file's name.
fn check_message(e: &RecordingError, name: &str) {
    let msg = e.to_string();
    assert!(
        !msg.contains('\n') && !msg.contains('\r'),
        "multi-line error: {msg:?}"
    );
    assert!(msg.starts_with(name), "error does not name {name}: {msg:?}");
    assert!(msg.len() > name.len() + 2, "error says nothing: {msg:?}");
}

/// What a reader accepted is consistent.
fn check_table(t: &RecordingTable, text: bool) {
    let n = t.rows();
    assert!(n > 0, "a table without rows");
    for (j, c) in t.channels.iter().enumerate() {
        assert_eq!(c.values.len(), n, "channel {} is short", c.label);
        assert!(
            t.channels[..j].iter().all(|d| d.label != c.label),
            "label {} twice",
            c.label
        );
    }
    if text {
        assert_eq!(t.row_lines.len(), n, "one line per row");
        assert!(t.row_lines.windows(2).all(|w| w[1] > w[0]));
    }
    if let Some(l) = &t.time_label {
        assert!(t.channel(l).is_some(), "time column {l} is not a channel");
    }
}

fuzz_target!(|data: &[u8]| {
    // the length chooses the delimited reader's options, so that every reader sees the same
    // bytes (and a seed file of any format is a whole file to each of them)
    let k = data.len();
    let opts = DelimitedOptions {
        header_line: match k % 8 {
            5..=7 => Some(k % 4),
            _ => None,
        },
        decimal_comma: match (k / 8) % 4 {
            1 => Some(true),
            2 => Some(false),
            _ => None,
        },
    };
    match recording::parse_delimited(data, Path::new("fuzz.csv"), &opts) {
        Ok(t) => check_table(&t, true),
        Err(e) => check_message(&e, "fuzz.csv"),
    }
    match recording::parse_storage(data, Path::new("fuzz.sto")) {
        Ok(t) => check_table(&t, true),
        Err(e) => check_message(&e, "fuzz.sto"),
    }
    match recording::c3d::parse_c3d(data, "fuzz.c3d") {
        Ok(t) => {
            check_table(&t, false);
            assert!(t.rate_hz.is_some_and(|r| r.is_finite() && r > 0.0));
        }
        Err(e) => check_message(&e, "fuzz.c3d"),
    }
    if let Ok(text) = std::str::from_utf8(data) {
        match recording::parse_map(text, Path::new("fuzz.json")) {
            Ok(m) => {
                m.validate().expect("an accepted map is valid");
                // what it writes reads back the same
                let again = recording::parse_map(&m.to_json_text(), Path::new("fuzz.json"))
                    .expect("a written map reads back");
                assert_eq!(again, m);
            }
            Err(e) => check_message(&e, "fuzz.json"),
        }
    }
});
