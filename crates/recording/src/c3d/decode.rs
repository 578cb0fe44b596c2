//! The c3dio call on bytes that the layout checks accepted, run under
//! [`std::panic::catch_unwind`] as the last guard, and the table built from what c3dio decoded
//! (the parent module's "What is read": labels, units, the unsigned-integer correction and the
//! clock).

use std::collections::HashMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

use c3dio::{AnalogOffset, C3d, C3dParseError, DataFormat};

use super::layout::Layout;
use crate::error::{RecordingError, Result};
use crate::table::{RecordingChannel, RecordingFormat, RecordingTable};

/// Runs c3dio on bytes that [`check_layout`](super::layout::check_layout) accepted (a panic in
/// c3dio becomes an error) and builds the table from what it decoded.
pub(super) fn decode(bytes: &[u8], layout: &Layout, name: &str) -> Result<RecordingTable> {
    let fail = |reason: String| RecordingError::file(name, reason);
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
    table_from(&c3d, layout, name)
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
