//! C3D files: the ANALOG channels, by label, as a [`RecordingTable`]; and a writer of
//! analog-only C3D files.
//!
//! # What is read
//!
//! [`parse_c3d`] (bytes) and [`read_c3d`] (a path) decode the file with the [`c3dio`] crate
//! (0.8) and return one [`RecordingChannel`] per analog channel, in file order:
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
//! # Writing
//!
//! [`format_c3d_analog`] writes an analog-only C3D: Intel byte order, floating-point data, no 3D
//! points, one analog sample per channel per frame (so the point rate is the analog rate),
//! `ANALOG:SCALE` 1, `ANALOG:OFFSET` 0 and `ANALOG:GEN_SCALE` 1 so that every value is carried
//! as the `f32` nearest to it: a value exactly representable as an `f32` reads back bit for bit.
//! Trials longer than 65535 samples are written with `POINT:LONG_FRAMES`. The bytes are this
//! module's own (c3dio 0.8 writes only to a path with a `.c3d` extension).
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

use std::borrow::Cow;
use std::collections::{HashMap, HashSet};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

use c3dio::{AnalogOffset, C3d, C3dParseError, DataFormat};

use crate::table::display;
use crate::{RecordingChannel, RecordingError, RecordingFormat, RecordingTable, Result};

/// C3D files are laid out in blocks of this many bytes.
const BLOCK: usize = 512;
/// Second byte of a C3D header and of its parameter section.
const KEY: u8 = 0x50;
/// Processor type byte of an Intel (little-endian, IEEE float) file.
const INTEL: u8 = 0x54;
/// Name used in the writer's error messages.
const WRITER: &str = "C3D writer";
/// Most events c3dio 0.8 can read (it reads event `i` at header byte 304 + 4 i).
const C3DIO_MAX_EVENTS: usize = 52;
/// Groups c3dio adds when the file lacks them, in its order (it gives them new group numbers).
const C3DIO_REQUIRED_GROUPS: [&str; 8] = [
    "POINT",
    "ANALOG",
    "FORCE_PLATFORM",
    "EVENT",
    "EVENT_CONTEXT",
    "TRIAL",
    "MANUFACTURER",
    "SEG",
];

/// Reads the analog channels of the C3D file at `path` (see the [module docs](self)).
///
/// # Errors
///
/// The file cannot be read, or any error of [`parse_c3d`]; the message starts with `path`.
pub fn read_c3d(path: &Path) -> Result<RecordingTable> {
    let bytes = crate::read_bytes(path)?;
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
    let fail = |reason: String| RecordingError::file(name, reason);
    let layout = check_layout(bytes).map_err(fail)?;
    let input = layout.c3dio_input(bytes);
    let parsed = catch_unwind(AssertUnwindSafe(|| {
        C3d::from_bytes(&input).map_err(|e| describe_c3dio_error(&e))
    }));
    drop(input);
    let c3d = match parsed {
        Ok(Ok(c3d)) => c3d,
        Ok(Err(reason)) => return Err(fail(reason)),
        Err(payload) => {
            let message = payload
                .downcast_ref::<&str>()
                .map(|s| (*s).to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            return Err(fail(format!(
                "malformed C3D file: the c3dio parser failed on it ({})",
                one_line(&message)
            )));
        }
    };
    table_from(&c3d, &layout, name)
}

/// Formats an analog-only C3D file: `rate_hz` is the sampling rate of every channel; each
/// channel is `(label, unit, values)`, all of the same length (see the [module docs](self) for
/// the layout). Values are stored as `f32` (the nearest one); NaN and infinities are kept.
///
/// # Errors
///
/// A [`RecordingError`] (its message starts with `C3D writer`) when the rate is not a positive
/// `f32`, there are no channels or more than 255, the channels differ in length or are empty or
/// longer than 2²⁴ samples, a label is blank, repeated, longer than 255 characters, not
/// printable ASCII or has blanks at either end (a unit the same, except that it may be empty),
/// or a finite value is too large for an `f32`.
pub fn format_c3d_analog(rate_hz: f64, channels: &[(&str, &str, &[f64])]) -> Result<Vec<u8>> {
    let fail = |reason: String| RecordingError::file(WRITER, reason);
    let rate = rate_hz as f32;
    if !(rate_hz.is_finite() && rate.is_finite() && rate > 0.0) {
        return Err(fail(format!("rate {rate_hz} Hz is not a positive f32")));
    }
    if channels.is_empty() {
        return Err(fail("no channels to write".into()));
    }
    if channels.len() > 255 {
        return Err(fail(format!(
            "{} channels; at most 255 fit in ANALOG:LABELS",
            channels.len()
        )));
    }
    let samples = channels[0].2.len();
    if samples == 0 {
        return Err(fail("the channels have no samples".into()));
    }
    if samples > 1 << 24 {
        return Err(fail(format!(
            "{samples} samples; at most 2^24 (16777216) are written"
        )));
    }
    let mut seen = HashSet::new();
    for &(label, unit, values) in channels {
        let column = |reason: String| RecordingError::column(WRITER, label, reason);
        check_text(label, false).map_err(|r| column(format!("label {r}")))?;
        check_text(unit, true).map_err(|r| column(format!("unit '{unit}' {r}")))?;
        if !seen.insert(label) {
            return Err(column("duplicate label".into()));
        }
        if values.len() != samples {
            return Err(column(format!(
                "{} samples, the first channel has {samples}",
                values.len()
            )));
        }
        if let Some(i) = values
            .iter()
            .position(|v| v.is_finite() && (*v as f32).is_infinite())
        {
            return Err(column(format!(
                "value {} at sample {} does not fit in an f32",
                values[i],
                i + 1
            )));
        }
    }

    let count = channels.len();
    let frames_in_header = u16::try_from(samples).unwrap_or(u16::MAX);
    let labels: Vec<&str> = channels.iter().map(|c| c.0).collect();
    let units: Vec<&str> = channels.iter().map(|c| c.1).collect();
    let parameters = |data_block: u16| {
        let mut p = ParameterWriter::new();
        p.group(1, "POINT", "3-D point parameters");
        p.group(2, "ANALOG", "Analog data parameters");
        p.int(1, "USED", &[], &[0]);
        p.int(1, "FRAMES", &[], &[frames_in_header as i16]);
        p.int(1, "DATA_START", &[], &[data_block as i16]);
        p.float(1, "SCALE", &[], &[-1.0]);
        p.float(1, "RATE", &[], &[rate]);
        if samples > usize::from(u16::MAX) {
            p.float(1, "LONG_FRAMES", &[], &[samples as f32]);
        }
        p.int(2, "USED", &[], &[count as i16]);
        p.strings(2, "LABELS", &labels);
        p.strings(2, "DESCRIPTIONS", &vec![""; count]);
        p.strings(2, "UNITS", &units);
        p.float(2, "GEN_SCALE", &[], &[1.0]);
        p.float(2, "SCALE", &[count as u8], &vec![1.0; count]);
        p.int(2, "OFFSET", &[count as u8], &vec![0; count]);
        p.float(2, "RATE", &[], &[rate]);
        p.finish()
    };
    // The section's size does not depend on DATA_START's value: size it, then write it.
    let blocks = parameters(0).len() / BLOCK;
    if blocks > 255 {
        return Err(fail(format!(
            "the parameter section needs {blocks} blocks; at most 255 fit"
        )));
    }
    let data_block = 2 + blocks as u16;
    let parameter_bytes = parameters(data_block);

    let mut out = vec![0u8; BLOCK];
    out[0] = 2;
    out[1] = KEY;
    let mut put16 = |at: usize, v: u16| out[at..at + 2].copy_from_slice(&v.to_le_bytes());
    put16(2, 0); // 3D points
    put16(4, count as u16); // analog samples per frame, all channels
    put16(6, 1); // first frame
    put16(8, frames_in_header); // last frame
    put16(16, data_block);
    put16(18, 1); // analog samples per channel per frame
    out[12..16].copy_from_slice(&(-1.0f32).to_le_bytes()); // negative: float data
    out[20..24].copy_from_slice(&rate.to_le_bytes()); // frame rate
    out.extend_from_slice(&parameter_bytes);
    out.reserve(samples * count * 4 + BLOCK);
    for i in 0..samples {
        for &(_, _, values) in channels {
            out.extend_from_slice(&(values[i] as f32).to_le_bytes());
        }
    }
    out.resize(out.len().div_ceil(BLOCK) * BLOCK, 0);
    Ok(out)
}

/// Why a label (or unit, `may_be_empty`) cannot be written, if it cannot.
fn check_text(text: &str, may_be_empty: bool) -> std::result::Result<(), &'static str> {
    if text.is_empty() {
        return if may_be_empty {
            Ok(())
        } else {
            Err("is empty")
        };
    }
    if text.len() > 255 {
        return Err("is longer than 255 characters");
    }
    if !text.bytes().all(|b| (0x20..0x7f).contains(&b)) {
        return Err("is not printable ASCII");
    }
    if text.starts_with(' ') || text.ends_with(' ') {
        return Err("starts or ends with a blank (C3D readers trim them)");
    }
    Ok(())
}

/// Builds an Intel-order parameter section, group and parameter records in the C3D layout:
/// name length, group number (negative for a group), name, offset to the next record (counted
/// from the offset's own first byte; 0 on the last record), then a group's description or a
/// parameter's type, dimensions, data and (empty) description.
struct ParameterWriter {
    bytes: Vec<u8>,
    last_offset_at: Option<usize>,
}

impl ParameterWriter {
    fn new() -> Self {
        // Reserved byte, key, block count (set in finish), processor type.
        Self {
            bytes: vec![1, KEY, 0, INTEL],
            last_offset_at: None,
        }
    }

    fn record(&mut self, name: &str, id: u8, rest: &[u8]) {
        self.bytes.push(name.len() as u8);
        self.bytes.push(id);
        self.bytes.extend_from_slice(name.as_bytes());
        self.last_offset_at = Some(self.bytes.len());
        self.bytes
            .extend_from_slice(&((rest.len() + 2) as u16).to_le_bytes());
        self.bytes.extend_from_slice(rest);
    }

    fn group(&mut self, id: u8, name: &str, description: &str) {
        let mut rest = vec![description.len() as u8];
        rest.extend_from_slice(description.as_bytes());
        self.record(name, (-(id as i8)) as u8, &rest);
    }

    fn parameter(&mut self, group: u8, name: &str, kind: i8, dims: &[u8], data: &[u8]) {
        let mut rest = vec![kind as u8, dims.len() as u8];
        rest.extend_from_slice(dims);
        rest.extend_from_slice(data);
        rest.push(0); // no description
        self.record(name, group, &rest);
    }

    fn int(&mut self, group: u8, name: &str, dims: &[u8], values: &[i16]) {
        let data: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        self.parameter(group, name, 2, dims, &data);
    }

    fn float(&mut self, group: u8, name: &str, dims: &[u8], values: &[f32]) {
        let data: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        self.parameter(group, name, 4, dims, &data);
    }

    /// A character array `[width, count]`, each string padded with blanks to `width`.
    fn strings(&mut self, group: u8, name: &str, strings: &[&str]) {
        let width = strings.iter().map(|s| s.len()).max().unwrap_or(0).max(1);
        let mut data = Vec::with_capacity(width * strings.len());
        for s in strings {
            data.extend_from_slice(s.as_bytes());
            data.resize(data.len() + width - s.len(), b' ');
        }
        self.parameter(group, name, -1, &[width as u8, strings.len() as u8], &data);
    }

    /// The section, padded to whole blocks, its block count set and its last offset 0.
    fn finish(mut self) -> Vec<u8> {
        if let Some(at) = self.last_offset_at {
            self.bytes[at] = 0;
            self.bytes[at + 1] = 0;
        }
        let blocks = self.bytes.len().div_ceil(BLOCK);
        self.bytes.resize(blocks * BLOCK, 0);
        self.bytes[2] = blocks.min(255) as u8;
        self.bytes
    }
}

/// Byte order and float format of a file (the processor type of its parameter section).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Cpu {
    Intel,
    Dec,
    Mips,
}

impl Cpu {
    fn from_byte(byte: u8) -> Option<Self> {
        match byte {
            0x54 => Some(Self::Intel),
            0x55 => Some(Self::Dec),
            0x56 => Some(Self::Mips),
            _ => None,
        }
    }

    fn u16(self, b: [u8; 2]) -> u16 {
        match self {
            Self::Intel | Self::Dec => u16::from_le_bytes(b),
            Self::Mips => u16::from_be_bytes(b),
        }
    }

    fn u16_bytes(self, v: u16) -> [u8; 2] {
        match self {
            Self::Intel | Self::Dec => v.to_le_bytes(),
            Self::Mips => v.to_be_bytes(),
        }
    }

    /// A float as c3dio 0.8 decodes it (DEC: words swapped, exponent lowered by 2).
    fn f32(self, b: [u8; 4]) -> f32 {
        match self {
            Self::Intel => f32::from_le_bytes(b),
            Self::Mips => f32::from_be_bytes(b),
            Self::Dec => {
                let high = if b[1] == 0 { 0 } else { b[1] - 1 };
                f32::from_le_bytes([b[2], b[3], b[0], high])
            }
        }
    }
}

/// What the checks before c3dio found out about a file.
#[derive(Debug)]
struct Layout {
    cpu: Cpu,
    /// 1-based block of the parameter section.
    param_block: usize,
    /// 1-based block of the data section.
    data_block: usize,
    /// Integer (not floating-point) samples.
    integer: bool,
    /// Analog samples per channel per frame.
    per_channel: usize,
    /// Frames c3dio will read.
    frames: usize,
    /// `ANALOG:USED`.
    used: usize,
    /// The first frame's number.
    first_frame: u64,
}

impl Layout {
    /// The bytes as c3dio 0.8's `from_bytes` needs them: it reads the parameter section from
    /// block 2 whatever the header says, and wants the data section's first block complete.
    fn c3dio_input<'a>(&self, bytes: &'a [u8]) -> Cow<'a, [u8]> {
        let shift = self.param_block - 2;
        let data_block = self.data_block - shift;
        if shift == 0 && bytes.len() >= data_block * BLOCK {
            return Cow::Borrowed(bytes);
        }
        let mut out = Vec::with_capacity(bytes.len().max(data_block * BLOCK));
        out.extend_from_slice(&bytes[..BLOCK]);
        out[0] = 2;
        // data_block ≤ the header's u16, so it fits.
        out[16..18].copy_from_slice(&self.cpu.u16_bytes(data_block as u16));
        out.extend_from_slice(&bytes[(self.param_block - 1) * BLOCK..]);
        if out.len() < data_block * BLOCK {
            out.resize(data_block * BLOCK, 0);
        }
        Cow::Owned(out)
    }
}

/// Checks the header and the parameter section, and that the data section holds the frames
/// c3dio will read, so that c3dio neither overruns a slice nor sizes a grid from a count the
/// file cannot back.
fn check_layout(bytes: &[u8]) -> std::result::Result<Layout, String> {
    if bytes.is_empty() {
        return Err("empty file, not a C3D file".into());
    }
    if bytes.len() >= 2 && bytes[1] != KEY {
        return Err(format!(
            "not a C3D file (its second byte is 0x{:02X}; a C3D file's is 0x50)",
            bytes[1]
        ));
    }
    if bytes.len() < BLOCK {
        return Err(format!(
            "truncated C3D file: {} bytes, less than its 512-byte header",
            bytes.len()
        ));
    }
    let header = &bytes[..BLOCK];
    let param_block = usize::from(header[0]);
    if param_block < 2 {
        return Err(format!(
            "not a C3D file (its header puts the parameter section in block {param_block})"
        ));
    }
    let param_start = (param_block - 1) * BLOCK;
    if bytes.len() < param_start + BLOCK {
        return Err(format!(
            "truncated C3D file: {} bytes, ending before its parameter section (byte {param_start})",
            bytes.len()
        ));
    }
    let cpu = Cpu::from_byte(bytes[param_start + 3]).ok_or_else(|| {
        format!(
            "not a C3D file (processor type 0x{:02X}; a C3D file has 0x54 Intel, 0x55 DEC or 0x56 MIPS)",
            bytes[param_start + 3]
        )
    })?;
    let word = |at: usize| cpu.u16([header[at], header[at + 1]]);
    let points = usize::from(word(2));
    let analog_per_frame = usize::from(word(4));
    let first_frame = word(6);
    let last_frame = word(8);
    // c3dio: a scale factor ≤ 0 means floating-point data, anything else (NaN too) integers.
    let float = cpu.f32([header[12], header[13], header[14], header[15]]) <= 0.0;
    let integer = !float;
    let data_block = usize::from(word(16));
    let per_channel = usize::from(word(18));
    if data_block <= param_block {
        return Err(format!(
            "malformed C3D header: the data section (block {data_block}) does not follow the parameter section (block {param_block})"
        ));
    }
    let data_start = (data_block - 1) * BLOCK;
    if bytes.len() < data_start {
        return Err(format!(
            "truncated C3D file: {} bytes, ending inside its parameter section (the data section starts at byte {data_start})",
            bytes.len()
        ));
    }
    if last_frame < first_frame {
        return Err(format!(
            "malformed C3D header: last frame {last_frame} before first frame {first_frame}"
        ));
    }
    if first_frame == 0 && last_frame == u16::MAX {
        return Err("malformed C3D header: frames 0 to 65535 (more than c3dio 0.8 counts)".into());
    }
    if analog_per_frame == 0 {
        return Err("no analog channels (the header gives 0 analog samples per frame)".into());
    }
    if per_channel == 0 || analog_per_frame % per_channel != 0 {
        return Err(format!(
            "malformed C3D header: {analog_per_frame} analog samples per frame is not a multiple of {per_channel} samples per channel"
        ));
    }

    let params = walk_parameters(&bytes[param_start..data_start], cpu, param_start)?;
    let get = |group: &str, name: &str| params.get(&(group.to_string(), name.to_string()));

    let used = match get("ANALOG", "USED") {
        None => 0,
        Some(p) => usize::from(
            p.scalar_int(cpu)
                .ok_or("ANALOG:USED is not a single integer")? as u16,
        ),
    };
    if used == 0 {
        return Err("no analog channels (ANALOG:USED is 0 or missing)".into());
    }
    if used * per_channel != analog_per_frame {
        return Err(format!(
            "malformed C3D file: the header gives {analog_per_frame} analog samples per frame, but ANALOG:USED {used} × {per_channel} samples per channel is {}",
            used * per_channel
        ));
    }
    if let Some(events) = get("EVENT", "USED").and_then(|p| p.scalar_int(cpu)) {
        let events = events as usize; // c3dio's conversion: a negative count is huge
        if events > C3DIO_MAX_EVENTS {
            return Err(format!(
                "EVENT:USED is {events}; c3dio 0.8 reads at most {C3DIO_MAX_EVENTS} events"
            ));
        }
    }

    // The frame count, worked out as c3dio 0.8 does (Points::calc_num_frames).
    let header_frames = usize::from(last_frame - first_frame) + 1;
    let point_frames = get("POINT", "FRAMES").map_or(0, |p| p.frame_count(cpu));
    let long_frames = get("POINT", "LONG_FRAMES").map(|p| p.frame_count(cpu));
    let start_field = actual_field(get("TRIAL", "ACTUAL_START_FIELD"), cpu, "START")?;
    let end_field = actual_field(get("TRIAL", "ACTUAL_END_FIELD"), cpu, "END")?;
    let mut frames = header_frames;
    if frames != point_frames {
        frames = point_frames;
    }
    if let (Some(start), Some(end)) = (start_field, end_field) {
        if end.c3dio < start.c3dio {
            return Err("TRIAL:ACTUAL_END_FIELD is before TRIAL:ACTUAL_START_FIELD".into());
        }
        frames = end.c3dio - start.c3dio + 1;
    }
    if let Some(long) = long_frames {
        frames = frames.max(long);
    }
    if frames == 0 {
        return Err(format!(
            "no frames (POINT:FRAMES is 0 or missing; the header gives frames {first_frame} to {last_frame})"
        ));
    }
    // c3dio reads the whole frames the data section holds, however many the file describes;
    // this is where a truncated file is caught, and what bounds c3dio's sample grids.
    let (point_size, sample_size) = if integer { (8, 2) } else { (16, 4) };
    let frame_bytes = points * point_size + analog_per_frame * sample_size;
    let data_len = bytes.len() - data_start;
    let whole_frames = data_len / frame_bytes;
    if frames > whole_frames {
        return Err(format!(
            "truncated C3D file: its data section holds {data_len} bytes, {whole_frames} whole frames of the {frames} it describes ({frame_bytes} bytes each)"
        ));
    }
    if header_frames > whole_frames {
        return Err(format!(
            "malformed C3D header: frames {first_frame} to {last_frame} are more than the {whole_frames} whole frames its data section holds"
        ));
    }
    let first_frame = start_field.map_or(u64::from(first_frame), |s| s.true_value);
    Ok(Layout {
        cpu,
        param_block,
        data_block,
        integer,
        per_channel,
        frames,
        used,
        first_frame,
    })
}

/// A `TRIAL:ACTUAL_*_FIELD` pair (low word, high word).
#[derive(Clone, Copy)]
struct Field {
    /// As c3dio 0.8 computes it: low + high × 65535.
    c3dio: usize,
    /// As the C3D format defines it: low + high × 65536.
    true_value: u64,
}

fn actual_field(
    param: Option<&RawParam<'_>>,
    cpu: Cpu,
    which: &str,
) -> std::result::Result<Option<Field>, String> {
    let Some(param) = param else { return Ok(None) };
    if param.kind != 2 || param.dims.len() != 1 {
        return Err(format!(
            "TRIAL:ACTUAL_{which}_FIELD is not a list of integers"
        ));
    }
    let words = param.ints(cpu);
    if words.len() != 2 {
        return Ok(None);
    }
    let (low, high) = (words[0] as u16, words[1] as u16);
    if high > 1 {
        // c3dio multiplies the high word by 65535 in u16 arithmetic, which overflows.
        return Err(format!(
            "TRIAL:ACTUAL_{which}_FIELD is beyond frame 131070, more than c3dio 0.8 reads"
        ));
    }
    Ok(Some(Field {
        c3dio: usize::from(low) + usize::from(high) * 65535,
        true_value: u64::from(low) + u64::from(high) * 65536,
    }))
}

/// One parameter record as c3dio 0.8 reads it: dimensions without zeros (and, unless it is a
/// character array, without ones; `[1]` when nothing is left), and its data bytes.
#[derive(Debug)]
struct RawParam<'a> {
    kind: i8,
    dims: Vec<usize>,
    data: &'a [u8],
}

impl RawParam<'_> {
    fn ints(&self, cpu: Cpu) -> Vec<i16> {
        self.data
            .chunks_exact(2)
            .map(|c| cpu.u16([c[0], c[1]]) as i16)
            .collect()
    }

    /// The value when it is one integer (what c3dio converts to `u16` / `i16`).
    fn scalar_int(&self, cpu: Cpu) -> Option<i16> {
        (self.kind == 2 && self.data.len() == 2)
            .then(|| cpu.u16([self.data[0], self.data[1]]) as i16)
    }

    /// `POINT:FRAMES` / `POINT:LONG_FRAMES` as c3dio 0.8 reads them.
    fn frame_count(&self, cpu: Cpu) -> usize {
        match self.kind {
            2 => usize::from(cpu.u16([self.data[0], self.data[1]])),
            4 => cpu.f32([self.data[0], self.data[1], self.data[2], self.data[3]]) as usize,
            _ => 0,
        }
    }
}

/// Walks the parameter section record by record exactly as c3dio 0.8 does (from byte 4, a zero
/// group number or the section's end stops it; each record's offset gives the next), checking
/// every read, and returns the parameters by (group name, upper-case parameter name), the group
/// names resolved the way c3dio resolves them (the last record wins).
fn walk_parameters(
    section: &[u8],
    cpu: Cpu,
    base: usize,
) -> std::result::Result<HashMap<(String, String), RawParam<'_>>, String> {
    let bad = |at: usize, what: &str| {
        format!(
            "malformed C3D parameter section: the record at byte {} {what}",
            base + at
        )
    };
    let mut groups: Vec<(i8, String)> = Vec::new();
    let mut records: Vec<(i8, String, RawParam<'_>)> = Vec::new();
    let mut index = 4;
    while index + 1 < section.len() {
        let id = section[index + 1] as i8;
        if id == 0 {
            break;
        }
        let name_length = section[index] as i8;
        if name_length == i8::MIN || id == i8::MIN {
            return Err(bad(index, "has a name length or group number of -128"));
        }
        let overrun = || bad(index, "runs past the end of the section");
        let mut at = index + 2;
        let name: String = take(section, &mut at, usize::from(name_length.unsigned_abs()))
            .ok_or_else(overrun)?
            .iter()
            .map(|&b| char::from(b))
            .collect();
        let offset_at = at;
        let offset = take(section, &mut at, 2).ok_or_else(overrun)?;
        let next = offset_at + usize::from(cpu.u16([offset[0], offset[1]]));
        if id < 0 {
            let length = take(section, &mut at, 1).ok_or_else(overrun)?[0];
            take(section, &mut at, usize::from(length)).ok_or_else(overrun)?;
            groups.push((id.abs(), name));
        } else {
            let kind = take(section, &mut at, 1).ok_or_else(overrun)?[0] as i8;
            let size = match kind {
                -1 | 1 => 1,
                2 => 2,
                4 => 4,
                _ => return Err(bad(index, &format!("has an unknown data type {kind}"))),
            };
            let count = take(section, &mut at, 1).ok_or_else(overrun)?[0];
            let mut dims: Vec<usize> = take(section, &mut at, usize::from(count))
                .ok_or_else(overrun)?
                .iter()
                .map(|&d| usize::from(d))
                .filter(|&d| d != 0 && (kind == -1 || d != 1))
                .collect();
            if dims.is_empty() {
                dims.push(1);
            }
            let length = dims
                .iter()
                .try_fold(size, |n: usize, &d| n.checked_mul(d))
                .ok_or_else(overrun)?;
            let data = take(section, &mut at, length).ok_or_else(overrun)?;
            let length = take(section, &mut at, 1).ok_or_else(overrun)?[0];
            take(section, &mut at, usize::from(length)).ok_or_else(overrun)?;
            records.push((id, name.to_ascii_uppercase(), RawParam { kind, dims, data }));
        }
        index = next;
    }

    let mut names: HashMap<i8, String> = HashMap::new();
    for (id, name) in &groups {
        names.insert(*id, name.clone());
    }
    let present: HashSet<&str> = groups.iter().map(|(_, n)| n.as_str()).collect();
    let mut max_id = names.keys().copied().max().unwrap_or(0);
    for required in C3DIO_REQUIRED_GROUPS {
        if !present.contains(required) {
            max_id = max_id.checked_add(1).ok_or_else(|| {
                "malformed C3D parameter section: too many groups (a group number reaches 127)"
                    .to_string()
            })?;
            names.insert(max_id, required.to_string());
        }
    }
    let mut params = HashMap::new();
    for (id, name, param) in records {
        let group = names.entry(id).or_insert_with(|| id.to_string()).clone();
        params.insert((group, name), param);
    }
    Ok(params)
}

/// The next `n` bytes at `*at`, advancing `*at`, or `None` past the end.
fn take<'a>(bytes: &'a [u8], at: &mut usize, n: usize) -> Option<&'a [u8]> {
    let end = at.checked_add(n)?;
    let out = bytes.get(*at..end)?;
    *at = end;
    Some(out)
}

/// The table from what c3dio decoded.
fn table_from(c3d: &C3d, layout: &Layout, name: &str) -> Result<RecordingTable> {
    let fail = |reason: String| RecordingError::file(name, reason);
    let analog = &c3d.analog;
    let grid = &analog.analog;
    let rows = layout.frames * layout.per_channel;
    if grid.cols() != layout.used || grid.rows() != rows {
        return Err(fail(format!(
            "c3dio decoded {} × {} analog samples where the file describes {rows} × {}",
            grid.rows(),
            grid.cols(),
            layout.used
        )));
    }
    if analog.labels.len() < layout.used {
        return Err(fail(format!(
            "ANALOG:LABELS names {} of the {} analog channels",
            analog.labels.len(),
            layout.used
        )));
    }
    let analog_rate = decimal(analog.rate);
    if !(analog_rate.is_finite() && analog_rate > 0.0) {
        return Err(fail(format!(
            "ANALOG:RATE is {analog_rate}, not a positive rate"
        )));
    }
    let point_rate = match decimal(c3d.points.frame_rate) {
        r if r.is_finite() && r > 0.0 => r,
        _ => analog_rate / layout.per_channel as f64,
    };
    let unsigned = layout.integer && matches!(analog.offset, AnalogOffset::Unsigned(_));
    debug_assert_eq!(layout.integer, c3d.points.format == DataFormat::Integer);

    let mut first_seen: HashMap<String, usize> = HashMap::new();
    let mut channels = Vec::with_capacity(layout.used);
    for j in 0..layout.used {
        let label = trim(&analog.labels[j]).to_string();
        if label.is_empty() {
            return Err(fail(format!("analog channel {} has no label", j + 1)));
        }
        if let Some(&earlier) = first_seen.get(&label) {
            return Err(RecordingError::column(
                name,
                one_line(&label),
                format!(
                    "duplicate analog label (channels {} and {})",
                    earlier + 1,
                    j + 1
                ),
            ));
        }
        first_seen.insert(label.clone(), j);
        let unit = analog
            .units
            .get(j)
            .map(|u| trim(u).to_string())
            .filter(|u| !u.is_empty());
        let mut values: Vec<f64> = grid.iter_col(j).copied().collect();
        if unsigned {
            correct_unsigned(&mut values, analog, j);
        }
        channels.push(RecordingChannel {
            label,
            unit,
            values,
            rate_hz: None,
        });
    }
    Ok(RecordingTable {
        path: PathBuf::from(name),
        format: RecordingFormat::C3d,
        time_label: None,
        rate_hz: Some(analog_rate),
        start_s: layout.first_frame.saturating_sub(1) as f64 / point_rate,
        channels,
        row_lines: Vec::new(),
    })
}

/// c3dio 0.8 decodes `UNSIGNED` integer samples as signed, so a stored `u` above 32767 came out
/// as `(u − 65536 − offset) × k`: find those (the stored word recovered from the value) and
/// recompute them as `(u − offset) × k`, `k = SCALE[j] × GEN_SCALE`, as c3dio does.
fn correct_unsigned(values: &mut [f64], analog: &c3dio::Analog, j: usize) {
    let AnalogOffset::Unsigned(offsets) = &analog.offset else {
        return;
    };
    let (Some(&scale), Some(&offset)) = (analog.scales.get(j), offsets.get(j)) else {
        return;
    };
    let k = f64::from(scale) * f64::from(analog.gen_scale);
    let offset = f64::from(offset);
    if k == 0.0 || !k.is_finite() {
        return;
    }
    for v in values.iter_mut() {
        let signed = (*v / k + offset).round();
        if signed < 0.0 {
            *v = (signed + 65536.0 - offset) * k;
        }
    }
}

/// A label or unit without blanks or NUL padding at either end.
fn trim(text: &str) -> &str {
    text.trim_matches(|c: char| c == '\0' || c.is_whitespace())
}

/// An `f32` as the shortest decimal that reads back as it.
fn decimal(x: f32) -> f64 {
    x.to_string().parse().unwrap_or(f64::NAN)
}

/// `text` on one line and not too long, for messages.
fn one_line(text: &str) -> String {
    let mut out: String = text
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .take(200)
        .collect();
    if text.chars().count() > 200 {
        out.push('…');
    }
    out
}

/// A c3dio error in words.
fn describe_c3dio_error(error: &C3dParseError) -> String {
    use C3dParseError as E;
    match error {
        E::InsufficientBlocks(section) => {
            format!("truncated C3D file: it ends inside its {section} section")
        }
        E::InvalidProcessorType => "not a C3D file (unknown processor type)".into(),
        E::ParameterNotFound(group, parameter) => {
            format!("the C3D parameter {group}:{parameter} is missing")
        }
        E::MissingParameter(p) | E::RequiredParameterNotFound(p) => {
            format!("the C3D parameter {} is missing", one_line(p))
        }
        E::MissingGroup(g) | E::GroupNotFound(g) => {
            format!("the C3D parameter group {} is missing", one_line(g))
        }
        E::InvalidData(parameter, expected) => format!(
            "a C3D parameter (dimensions {:?}) is not the {} c3dio expects",
            parameter.dimensions,
            one_line(expected)
        ),
        E::AnalogOffsetScaleMismatch => {
            "ANALOG:OFFSET and ANALOG:SCALE have different lengths".into()
        }
        E::InsufficientAnalogOffsets => {
            "ANALOG:OFFSET and ANALOG:SCALE have fewer entries than ANALOG:USED".into()
        }
        E::AnalogBytesPerFrameMismatch => {
            "the header's analog samples per frame do not match ANALOG:USED".into()
        }
        E::FrameRateMismatch(header, parameter) => {
            format!("the header's frame rate {header} differs from POINT:RATE {parameter}")
        }
        E::ScaleFactorMismatch(header, parameter) => {
            format!("the header's scale factor {header} differs from POINT:SCALE {parameter}")
        }
        E::TooManyEvents(n) => format!("the header lists {n} events, more than 18"),
        other => format!(
            "malformed C3D file (c3dio: {})",
            one_line(&format!("{other:?}"))
        ),
    }
}
