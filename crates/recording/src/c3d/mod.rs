//! C3D files: the ANALOG channels, by label, as a [`RecordingTable`]; and a writer of
//! analog-only C3D files.
//!
//! The reading is in stages, each a file of its own: `layout` checks the file before c3dio sees
//! it, `decode` runs c3dio and builds the table; `write` holds the writer and `blocks` the
//! format's block and byte-order basics that both sides share.
//!
//! # What is read
//!
//! [`parse_c3d`] (bytes) and [`read_c3d`] (a path) decode the file with the [`c3dio`] crate
//! (0.8) and return one [`RecordingChannel`](crate::RecordingChannel) per analog channel, in file order:
//!
//! * `label`: the channel's `ANALOG:LABELS` entry with its blanks removed (c3dio trims both
//!   ends; trailing NUL padding is removed here too). A blank label, fewer labels than
//!   `ANALOG:USED` channels, or two channels with the same label is an error naming the label:
//!   a later duplicate never silently replaces an earlier one.
//! * `unit`: the channel's `ANALOG:UNITS` entry, `None` when it is blank or the list is short.
//!   (c3dio 0.8 requires the `ANALOG:UNITS` parameter itself: a file without it is an error.)
//! * `values`: in the file's unit, with the C3D analog scaling applied,
//!
//!   ```text
//!   real = (stored − ANALOG:OFFSET[i]) × ANALOG:SCALE[i] × ANALOG:GEN_SCALE
//!   ```
//!
//!   **c3dio applies this scaling itself** (`Analog::parse_analog` in c3dio 0.8 subtracts the
//!   offset and multiplies by `SCALE[i] × GEN_SCALE`, in `f64`, for float and integer files
//!   alike), so this reader does not apply it a second time. One c3dio defect is corrected: for
//!   integer files whose `ANALOG:FORMAT` is `UNSIGNED`, c3dio decodes the stored words as
//!   *signed* 16-bit numbers, so a stored value above 32767 is taken as 65536 less than it
//!   is; such samples are put right here. NaN samples are kept (the recording map rejects an all-NaN
//!   channel later).
//! * `rate_hz` of each channel is `None`: every analog channel of a C3D has the analog rate.
//!
//! The table's clock: `rate_hz = Some(ANALOG:RATE)`, `time_label = None`, and
//! `start_s = (first frame − 1) / point rate`, with the first frame from
//! `TRIAL:ACTUAL_START_FIELD` when the file has it (long trials), else from the header, and the
//! point rate from the header (or `ANALOG:RATE` / analog samples per frame when the header gives
//! none). Rates are stored as `f32`; they are read as the shortest decimal that gives back the
//! same `f32` (a stored 1111.11 reads as 1111.11, not 1111.1099853515625).
//!
//! # Errors, and no panics
//!
//! Every failure is a one-line [`RecordingError`] whose message starts with the file name: an
//! empty, non-C3D (a text file, say) or truncated file, a malformed header or parameter section,
//! a file with no analog channels or no frames, and what c3dio itself rejects.
//!
//! c3dio 0.8 trusts the file: on malformed input it indexes past slices, overflows integer
//! arithmetic (a panic in debug builds) and can size its sample grids from unchecked counts (an
//! allocation too large to succeed aborts the process, which no unwinding can catch). Before
//! calling it this reader therefore checks the header, walks the parameter section the way
//! c3dio will (every length and count bounds-checked), works out the number of frames c3dio
//! will read and checks that the data section holds them — which is also how a truncated data
//! section is caught, since c3dio silently reads the frames that are there. As a last guard
//! the c3dio call runs under [`std::panic::catch_unwind`]: c3dio was found to panic on inputs
//! the checks above do not rule out (for instance a `FORCE_PLATFORM` group without its
//! `CHANNEL` parameter: c3dio unwraps the missing parameter); such a panic becomes an error here
//! (the default panic hook still prints its message to stderr).
//!
//! # How it was tested
//!
//! `crates/recording/tests/c3d.rs`: files written by [`format_c3d_analog`] read back bit-exact
//! (including −0, subnormal, the largest `f32`, NaN) with their labels, units and rate, also for
//! a trial longer than 65535 samples; a written file whose `ANALOG:SCALE`, `ANALOG:OFFSET` and
//! `ANALOG:GEN_SCALE` parameter bytes were patched in place reads back as
//! `(stored − offset) × scale × gen_scale`; files assembled byte by byte in the test itself from
//! the C3D layout (independently of this writer) check signed and unsigned integer data, a
//! big-endian (MIPS) file, several samples per frame, the start time from the first frame,
//! label trimming, duplicate and missing labels, no analog channels; a parameter section moved
//! to block 3 reads the same; every prefix of a small file (in steps of 7 bytes) is an error
//! unless only block padding was cut; random bytes, random C3D-like headers and randomly
//! corrupted valid files never panic and never yield an inconsistent table (on such corrupted
//! files c3dio alone panics about once in 30); a file on which c3dio panics gives an error; a
//! text file is "not a C3D file". The tests pass in debug and release builds.

mod blocks;
mod decode;
mod layout;
mod write;

use std::path::Path;

use crate::error::{RecordingError, Result};
use crate::table::{display, RecordingTable};

pub use write::format_c3d_analog;

use decode::decode;
use layout::check_layout;

/// Reads the analog channels of the C3D file at `path` (see the [module docs](self)).
///
/// # Errors
///
/// The file cannot be read, or any error of [`parse_c3d`]; the message starts with `path`.
pub fn read_c3d(path: &Path) -> Result<RecordingTable> {
    let bytes = crate::read::read_bytes(path)?;
    parse_c3d(&bytes, &display(path))
}

/// Reads the analog channels of a C3D file held in `bytes`; `name` is the file's name, used as
/// the table's `path` and at the start of every error message. Never panics, whatever the bytes.
///
/// # Errors
///
/// A [`RecordingError`] (one line, starting with `name`) when the bytes are empty, not a C3D
/// file, truncated or malformed, when the file has no analog channels or no frames, when a
/// channel has no label or two channels share a label, or when c3dio rejects the file.
pub fn parse_c3d(bytes: &[u8], name: &str) -> Result<RecordingTable> {
    let layout = check_layout(bytes).map_err(|reason| RecordingError::file(name, reason))?;
    decode(bytes, &layout, name)
}
