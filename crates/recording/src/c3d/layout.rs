//! The checks before c3dio (the parent module's "Errors, and no panics" says why they are
//! needed): the header, the parameter section walked record by record as c3dio walks it, the
//! frame count c3dio will work out, and that the data section holds those frames.

use std::borrow::Cow;
use std::collections::{HashMap, HashSet};

use super::blocks::{Cpu, BLOCK, KEY};

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

/// What the checks before c3dio found out about a file.
#[derive(Debug)]
pub(super) struct Layout {
    pub(super) cpu: Cpu,
    /// 1-based block of the parameter section.
    pub(super) param_block: usize,
    /// 1-based block of the data section.
    pub(super) data_block: usize,
    /// Integer (not floating-point) samples.
    pub(super) integer: bool,
    /// Analog samples per channel per frame.
    pub(super) per_channel: usize,
    /// Frames c3dio will read.
    pub(super) frames: usize,
    /// `ANALOG:USED`.
    pub(super) used: usize,
    /// The first frame's number.
    pub(super) first_frame: u64,
}

impl Layout {
    /// The bytes as c3dio 0.8's `from_bytes` needs them: it reads the parameter section from
    /// block 2 whatever the header says, and wants the data section's first block complete.
    pub(super) fn c3dio_input<'a>(&self, bytes: &'a [u8]) -> Cow<'a, [u8]> {
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
pub(super) fn check_layout(bytes: &[u8]) -> std::result::Result<Layout, String> {
    let header = check_header(bytes)?;
    let params = walk_parameters(
        &bytes[header.param_start..header.data_start],
        header.cpu,
        header.param_start,
    )?;
    let used = analog_used(&params, &header)?;
    check_events(&params, header.cpu)?;
    let (frames, start_field) = frame_count(&params, &header)?;
    check_data_section(bytes, &header, frames)?;
    let first_frame = start_field.map_or(u64::from(header.first_frame), |s| s.true_value);
    Ok(Layout {
        cpu: header.cpu,
        param_block: header.param_block,
        data_block: header.data_block,
        integer: header.integer,
        per_channel: header.per_channel,
        frames,
        used,
        first_frame,
    })
}

/// What the 512-byte header says, once [`check_header`] has found it consistent.
struct Header {
    cpu: Cpu,
    /// 1-based block of the parameter section.
    param_block: usize,
    /// First byte of the parameter section.
    param_start: usize,
    /// 1-based block of the data section.
    data_block: usize,
    /// First byte of the data section.
    data_start: usize,
    /// 3D points per frame.
    points: usize,
    /// Analog samples per frame, all channels together.
    analog_per_frame: usize,
    first_frame: u16,
    last_frame: u16,
    /// Integer (not floating-point) samples.
    integer: bool,
    /// Analog samples per channel per frame.
    per_channel: usize,
}

/// The parameters by (group name, upper-case parameter name), as [`walk_parameters`] finds them.
type Params<'a> = HashMap<(String, String), RawParam<'a>>;

fn param<'p, 'a>(params: &'p Params<'a>, group: &str, name: &str) -> Option<&'p RawParam<'a>> {
    params.get(&(group.to_string(), name.to_string()))
}

/// The header's fields, and that the parameter and data sections it places lie in the file.
fn check_header(bytes: &[u8]) -> std::result::Result<Header, String> {
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
    Ok(Header {
        cpu,
        param_block,
        param_start,
        data_block,
        data_start,
        points,
        analog_per_frame,
        first_frame,
        last_frame,
        integer,
        per_channel,
    })
}

/// `ANALOG:USED`, and that it agrees with the header's analog samples per frame.
fn analog_used(params: &Params<'_>, header: &Header) -> std::result::Result<usize, String> {
    let (cpu, per_channel, analog_per_frame) =
        (header.cpu, header.per_channel, header.analog_per_frame);
    let get = |group: &str, name: &str| param(params, group, name);
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
    Ok(used)
}

/// That `EVENT:USED` is within what c3dio 0.8 reads.
fn check_events(params: &Params<'_>, cpu: Cpu) -> std::result::Result<(), String> {
    if let Some(events) = param(params, "EVENT", "USED").and_then(|p| p.scalar_int(cpu)) {
        let events = events as usize; // c3dio's conversion: a negative count is huge
        if events > C3DIO_MAX_EVENTS {
            return Err(format!(
                "EVENT:USED is {events}; c3dio 0.8 reads at most {C3DIO_MAX_EVENTS} events"
            ));
        }
    }
    Ok(())
}

/// The number of frames c3dio 0.8 will read, and the `TRIAL:ACTUAL_START_FIELD` if any.
fn frame_count(
    params: &Params<'_>,
    header: &Header,
) -> std::result::Result<(usize, Option<Field>), String> {
    let (cpu, first_frame, last_frame) = (header.cpu, header.first_frame, header.last_frame);
    let get = |group: &str, name: &str| param(params, group, name);
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
    Ok((frames, start_field))
}

/// That the data section holds every frame c3dio will read, and the header's frames.
fn check_data_section(
    bytes: &[u8],
    header: &Header,
    frames: usize,
) -> std::result::Result<(), String> {
    let (points, analog_per_frame, data_start) =
        (header.points, header.analog_per_frame, header.data_start);
    let (integer, first_frame, last_frame) =
        (header.integer, header.first_frame, header.last_frame);
    let header_frames = usize::from(last_frame - first_frame) + 1;
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
    Ok(())
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
