//! The writer of analog-only C3D files (the parent module's "Writing" gives the layout). The
//! bytes are made here, block by block, because c3dio 0.8 writes only to a path.

use std::collections::HashSet;

use super::blocks::{BLOCK, INTEL, KEY};
use crate::error::{RecordingError, Result};

/// Name used in the writer's error messages.
const WRITER: &str = "C3D writer";

/// Formats an analog-only C3D file: `rate_hz` is the sampling rate of every channel; each
/// channel is `(label, unit, values)`, all of the same length (see the [module docs](super) for
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
