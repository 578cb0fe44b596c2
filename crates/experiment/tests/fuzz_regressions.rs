//! Fuzz regressions and a seeded mutation fuzzer for the trial and
//! unloaded-run readers (docs/robustness.md).
//!
//! * Every file in `tests/data/fuzz/` (inputs kept from `cargo fuzz` runs and
//!   hand-made edge cases) parses to `Ok` or to an error whose `Display` is one
//!   line naming the file, without a panic.
//! * A bounded, seeded mutation loop (byte flips and insertions, truncation,
//!   line duplication, deletion and swaps, delimiter swaps, odd numbers)
//!   applied to prefixes of the bundled fixtures checks the same on stable
//!   Rust, where `cargo fuzz` does not run.

use experiment::{parse_trial_bytes, parse_unloaded_bytes, ExperimentError};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

const NAME: &str = "fuzz.csv";

const SEED_TRIAL: &str = include_str!("../../../fixtures/seed/trial.csv");
const SEED_UNLOADED: &str = include_str!("../../../fixtures/seed/unloaded.csv");
const TA_TRIAL: &str = include_str!("../../../fixtures/antagonist_coactivation/trial.csv");

/// `Err` describes a broken error message.
fn check_message(e: &ExperimentError) -> Result<(), String> {
    let msg = e.to_string();
    if msg.is_empty() || msg.contains('\n') || msg.contains('\r') {
        return Err(format!("not one line: {msg:?}"));
    }
    if !msg.starts_with(NAME) {
        return Err(format!("does not name the file: {msg:?}"));
    }
    if e.path() != Some(NAME) {
        return Err(format!("path() is {:?}", e.path()));
    }
    Ok(())
}

/// Parses `bytes` both ways; `Err` describes a panic, a broken message or an
/// accepted file that breaks the reader's promises.
fn check(bytes: &[u8]) -> Result<(), String> {
    let r = catch_unwind(AssertUnwindSafe(|| {
        (
            parse_trial_bytes(bytes, NAME),
            parse_unloaded_bytes(bytes, NAME),
        )
    }));
    let (trial, unloaded) = r.map_err(|p| {
        let what = p
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| p.downcast_ref::<&str>().map(|s| (*s).to_string()))
            .unwrap_or_default();
        format!("panicked: {what}")
    })?;
    let uniform_long = |t: &[f64]| {
        t.len() >= 2
            && t.windows(2).all(|w| w[1] > w[0])
            && t[t.len() - 1] - t[0] >= 1.0 - 1e-9
            && t.iter().all(|x| x.is_finite())
    };
    match trial {
        Ok(t) => {
            let n = t.len();
            let mut cols = vec![
                &t.ankle_angle_deg,
                &t.torque_nm,
                &t.emg_sol,
                &t.emg_gm,
                &t.emg_gl,
            ];
            cols.extend(t.emg_ta.as_ref());
            cols.extend(t.knee_angle_deg.as_ref());
            if !uniform_long(&t.time_s)
                || cols
                    .iter()
                    .any(|c| c.len() != n || c.iter().any(|x| !x.is_finite()))
            {
                return Err("an accepted trial breaks the reader's promises".into());
            }
            for emg in t.emg_channels() {
                if emg.1.iter().all(|&x| x == 0.0) {
                    return Err(format!("accepted an all-zero {}", emg.0));
                }
            }
        }
        Err(e) => check_message(&e).map_err(|m| format!("trial reader: {m}"))?,
    }
    match unloaded {
        Ok(u) => {
            let n = u.len();
            if !uniform_long(&u.time_s) || u.ankle_angle_deg.len() != n || u.torque_nm.len() != n {
                return Err("an accepted unloaded run breaks the reader's promises".into());
            }
        }
        Err(e) => check_message(&e).map_err(|m| format!("unloaded reader: {m}"))?,
    }
    Ok(())
}

#[test]
fn every_kept_fuzz_input_parses_or_fails_with_one_line() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fuzz");
    let mut n = 0;
    let mut failures = Vec::new();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "md") {
            continue;
        }
        n += 1;
        let bytes = std::fs::read(&path).unwrap();
        if let Err(e) = check(&bytes) {
            failures.push(format!("{}: {e}", path.display()));
        }
    }
    assert!(n >= 15, "only {n} kept inputs in {}", dir.display());
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The first `lines` lines of `text`, newline-terminated.
fn prefix(text: &str, lines: usize) -> Vec<u8> {
    let mut out = Vec::new();
    for l in text.lines().take(lines) {
        out.extend_from_slice(l.as_bytes());
        out.push(b'\n');
    }
    out
}

/// Byte positions where lines start.
fn line_starts(b: &[u8]) -> Vec<usize> {
    std::iter::once(0)
        .chain(
            b.iter()
                .enumerate()
                .filter(|(_, &c)| c == b'\n')
                .map(|(i, _)| i + 1),
        )
        .filter(|&i| i < b.len())
        .collect()
}

/// A random line's byte range (without its newline).
fn some_line(b: &[u8], rng: &mut ChaCha8Rng) -> Option<(usize, usize)> {
    let starts = line_starts(b);
    if starts.is_empty() {
        return None;
    }
    let s = starts[rng.random_range(0..starts.len())];
    let e = b[s..]
        .iter()
        .position(|&c| c == b'\n')
        .map_or(b.len(), |p| s + p);
    Some((s, e))
}

const SPECIAL_BYTES: &[u8] = b",;\t\n\r#.-+eE0 9\x00\xff\xc3\x80\"";
const ODD_CELLS: &[&str] = &[
    "NaN", "inf", "-inf", "", " ", "1e999", "-0", "0x10", "1_000", "1,5", "+.5", "5.",
    "1e-400", "٣", "∞", "\u{2028}", "\"1\"", "179769313486231570000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000",
];

/// One random mutation of `b`.
fn mutate(b: &mut Vec<u8>, rng: &mut ChaCha8Rng) {
    match rng.random_range(0..10) {
        0 if !b.is_empty() => {
            let i = rng.random_range(0..b.len());
            b[i] ^= 1 << rng.random_range(0..8);
        }
        1 => {
            let i = rng.random_range(0..=b.len());
            b.insert(i, SPECIAL_BYTES[rng.random_range(0..SPECIAL_BYTES.len())]);
        }
        2 if !b.is_empty() => {
            let i = rng.random_range(0..b.len());
            b.truncate(i);
        }
        3 => {
            if let Some((s, e)) = some_line(b, rng) {
                let line: Vec<u8> = b[s..e.min(b.len())].to_vec();
                let at = e.min(b.len());
                let mut ins = vec![b'\n'];
                ins.extend_from_slice(&line);
                b.splice(at..at, ins);
            }
        }
        4 => {
            if let Some((s, e)) = some_line(b, rng) {
                let end = (e + 1).min(b.len());
                b.drain(s..end);
            }
        }
        5 => {
            // swap two lines
            let (Some(x), Some(y)) = (some_line(b, rng), some_line(b, rng)) else {
                return;
            };
            let (first, second) = if x.0 <= y.0 { (x, y) } else { (y, x) };
            if first.1 < second.0 {
                let l1 = b[first.0..first.1].to_vec();
                let l2 = b[second.0..second.1].to_vec();
                b.splice(second.0..second.1, l1);
                b.splice(first.0..first.1, l2);
            }
        }
        6 => {
            // delimiter swap in one line or everywhere
            let to = [b';', b'\t', b' ', b'|'][rng.random_range(0..4)];
            let range = if rng.random_bool(0.3) {
                (0, b.len())
            } else {
                some_line(b, rng).unwrap_or((0, 0))
            };
            for c in &mut b[range.0..range.1] {
                if *c == b',' {
                    *c = to;
                }
            }
        }
        7 => {
            // replace one cell with an odd number
            if let Some((s, e)) = some_line(b, rng) {
                let commas: Vec<usize> = (s..e).filter(|&i| b[i] == b',').collect();
                let k = rng.random_range(0..=commas.len());
                let cs = if k == 0 { s } else { commas[k - 1] + 1 };
                let ce = commas.get(k).copied().unwrap_or(e);
                let cell = ODD_CELLS[rng.random_range(0..ODD_CELLS.len())];
                b.splice(cs..ce, cell.bytes());
            }
        }
        8 => {
            // CRLF everywhere
            let mut out = Vec::with_capacity(b.len() + b.len() / 20);
            for &c in b.iter() {
                if c == b'\n' {
                    out.push(b'\r');
                }
                out.push(c);
            }
            *b = out;
        }
        _ => {
            // shift one time value a little (gaps, backwards, repeats, jitter)
            if let Some((s, e)) = some_line(b, rng) {
                let end = b[s..e].iter().position(|&c| c == b',').map_or(e, |p| s + p);
                if let Ok(t) = std::str::from_utf8(&b[s..end])
                    .unwrap_or("x")
                    .parse::<f64>()
                {
                    let dt = [-0.01, -0.0005, 0.0, 1e-7, 0.0004, 0.5][rng.random_range(0..6)];
                    let v = format!("{}", t + dt);
                    b.splice(s..end, v.bytes());
                }
            }
        }
    }
}

#[test]
fn seeded_mutations_of_fixture_prefixes_never_panic_and_fail_with_one_line() {
    const ITERATIONS: usize = 6000;
    let bases = [SEED_TRIAL, TA_TRIAL, SEED_UNLOADED];
    let mut rng = ChaCha8Rng::seed_from_u64(20_260_514);
    let (mut ok, mut err) = (0usize, 0usize);
    let mut failures = Vec::new();
    for it in 0..ITERATIONS {
        let base = bases[it % bases.len()];
        // short prefixes (fail as too short) and long ones (parse) in turn
        let lines = if rng.random_bool(0.5) {
            rng.random_range(0..60)
        } else {
            rng.random_range(2052..2200)
        };
        let mut b = prefix(base, lines);
        for _ in 0..rng.random_range(1..4) {
            mutate(&mut b, &mut rng);
        }
        match check(&b) {
            Ok(()) => {
                if parse_trial_bytes(&b, NAME).is_ok() || parse_unloaded_bytes(&b, NAME).is_ok() {
                    ok += 1;
                } else {
                    err += 1;
                }
            }
            Err(e) => {
                let keep = std::env::temp_dir().join(format!("surae-fuzz-failure-{it}.csv"));
                let _ = std::fs::write(&keep, &b);
                failures.push(format!(
                    "iteration {it} (input kept in {}): {e}",
                    keep.display()
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    // the loop reaches both outcomes, so it explores past the first checks
    assert!(ok > ITERATIONS / 50, "only {ok} inputs parsed");
    assert!(err > ITERATIONS / 4, "only {err} inputs were rejected");
}
