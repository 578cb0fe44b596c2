//! C3D analog channels: the writer's files read back exactly; scale, offset and gain are applied
//! once; files assembled here byte by byte from the C3D layout (independently of the crate's
//! writer) check integer, unsigned, big-endian and multi-sample files and the errors; truncated,
//! random and corrupted bytes give errors, never panics.

use std::collections::HashMap;
use std::panic::{catch_unwind, AssertUnwindSafe};

use recording::c3d::{format_c3d_analog, parse_c3d, read_c3d};
use recording::{RecordingError, RecordingFormat, RecordingTable};

// ---------------------------------------------------------------------------------------------
// Helpers

/// A small deterministic generator (xorshift64*).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    fn byte(&mut self) -> u8 {
        self.next() as u8
    }
}

fn parse(bytes: &[u8]) -> Result<RecordingTable, RecordingError> {
    parse_c3d(bytes, "trial.c3d")
}

fn err(bytes: &[u8]) -> String {
    let e = parse(bytes).expect_err("an error");
    let message = e.to_string();
    assert!(
        message.starts_with("trial.c3d: "),
        "message does not start with the file name: {message}"
    );
    assert!(
        !message.contains('\n'),
        "message is not one line: {message}"
    );
    message
}

fn bits(values: &[f64]) -> Vec<u64> {
    values.iter().map(|v| v.to_bits()).collect()
}

/// A table's invariants, whatever file it came from.
fn check_invariants(table: &RecordingTable) {
    assert!(!table.channels.is_empty());
    let rows = table.channels[0].values.len();
    assert!(rows > 0);
    let mut labels = std::collections::HashSet::new();
    for c in &table.channels {
        assert_eq!(c.values.len(), rows, "channel {} length", c.label);
        assert!(!c.label.is_empty());
        assert_eq!(c.label.trim(), c.label);
        assert!(labels.insert(c.label.clone()), "duplicate {}", c.label);
        assert_eq!(c.rate_hz, None);
        if let Some(u) = &c.unit {
            assert!(!u.is_empty());
        }
    }
    let rate = table.rate_hz.expect("a rate");
    assert!(rate.is_finite() && rate > 0.0);
    assert!(table.start_s.is_finite() && table.start_s >= 0.0);
    assert_eq!(table.format, RecordingFormat::C3d);
    assert_eq!(table.time_label, None);
}

/// The parameter `group:name` of an Intel-order C3D file: where its data starts, its type and
/// its dimensions, found by walking the records as the C3D format lays them out.
fn find_parameter(file: &[u8], group: &str, name: &str) -> (usize, i8, Vec<u8>) {
    let mut at = (usize::from(file[0]) - 1) * 512 + 4;
    let mut groups = HashMap::new();
    let mut params = Vec::new();
    loop {
        let length = usize::from((file[at] as i8).unsigned_abs());
        let id = file[at + 1] as i8;
        if id == 0 {
            break;
        }
        let record_name = String::from_utf8(file[at + 2..at + 2 + length].to_vec()).unwrap();
        let offset_at = at + 2 + length;
        let offset = usize::from(u16::from_le_bytes([file[offset_at], file[offset_at + 1]]));
        if id < 0 {
            groups.insert(-id, record_name);
        } else {
            let kind = file[offset_at + 2] as i8;
            let count = usize::from(file[offset_at + 3]);
            let dims = file[offset_at + 4..offset_at + 4 + count].to_vec();
            params.push((id, record_name, offset_at + 4 + count, kind, dims));
        }
        if offset == 0 {
            break;
        }
        at = offset_at + offset;
    }
    params
        .into_iter()
        .find(|(id, n, ..)| groups[id] == group && n == name)
        .map(|(_, _, at, kind, dims)| (at, kind, dims))
        .unwrap_or_else(|| panic!("no parameter {group}:{name}"))
}

/// The header word `n` (1-based, as the C3D documentation numbers them) of an Intel file.
fn word(file: &[u8], n: usize) -> usize {
    usize::from(u16::from_le_bytes([file[2 * n - 2], file[2 * n - 1]]))
}

// ---------------------------------------------------------------------------------------------
// A C3D file assembled from the format's layout, independently of the crate's writer.

#[derive(Clone)]
struct Chan {
    label: &'static str,
    unit: &'static str,
    scale: f32,
    offset: i16,
    /// Stored numbers, `frames × per_channel` of them, in time order.
    stored: Vec<f64>,
}

fn chan(label: &'static str, unit: &'static str, stored: Vec<f64>) -> Chan {
    Chan {
        label,
        unit,
        scale: 1.0,
        offset: 0,
        stored,
    }
}

#[derive(Clone)]
struct Build {
    big_endian: bool,
    integer: bool,
    /// `ANALOG:FORMAT` = `UNSIGNED` (integer files).
    unsigned: bool,
    first_frame: u16,
    point_rate: f32,
    per_channel: u16,
    analog_rate: f32,
    gen_scale: f32,
    units: bool,
    pad: u8,
    /// `ANALOG:USED` when not the number of channels.
    used: Option<i16>,
    /// Frames when there are no channels.
    frames: usize,
    channels: Vec<Chan>,
    /// More groups: (number, name).
    groups: Vec<(i8, &'static str)>,
    /// More parameters: (group, name, type, dimensions, data in the file's byte order).
    params: Vec<ExtraParam>,
}

/// A parameter record: group, name, type, dimensions, data in the file's byte order.
type ExtraParam = (i8, &'static str, i8, Vec<u8>, Vec<u8>);

/// A channel as the writer takes it: label, unit, values.
type Channel<'a> = (&'a str, &'a str, &'a [f64]);

impl Build {
    fn new(channels: Vec<Chan>) -> Self {
        Self {
            big_endian: false,
            integer: false,
            unsigned: false,
            first_frame: 1,
            point_rate: 100.0,
            per_channel: 1,
            analog_rate: 100.0,
            gen_scale: 1.0,
            units: true,
            pad: b' ',
            used: None,
            frames: 5,
            channels,
            groups: Vec::new(),
            params: Vec::new(),
        }
    }

    fn u16(&self, v: u16) -> [u8; 2] {
        if self.big_endian {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        }
    }

    fn f32(&self, v: f32) -> [u8; 4] {
        if self.big_endian {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        }
    }

    fn ints(&self, values: &[i16]) -> Vec<u8> {
        values.iter().flat_map(|&v| self.u16(v as u16)).collect()
    }

    fn floats(&self, values: &[f32]) -> Vec<u8> {
        values.iter().flat_map(|&v| self.f32(v)).collect()
    }

    fn chars(&self, strings: &[&str]) -> (Vec<u8>, Vec<u8>) {
        let width = strings.iter().map(|s| s.len()).max().unwrap_or(0).max(1);
        let mut data = Vec::new();
        for s in strings {
            data.extend_from_slice(s.as_bytes());
            data.resize(data.len() + width - s.len(), self.pad);
        }
        (vec![width as u8, strings.len() as u8], data)
    }

    fn record(&self, out: &mut Vec<u8>, name: &str, id: i8, rest: &[u8]) {
        out.push(name.len() as u8);
        out.push(id as u8);
        out.extend_from_slice(name.as_bytes());
        out.extend_from_slice(&self.u16((rest.len() + 2) as u16));
        out.extend_from_slice(rest);
    }

    fn param(&self, out: &mut Vec<u8>, group: i8, name: &str, kind: i8, dims: &[u8], data: &[u8]) {
        let mut rest = vec![kind as u8, dims.len() as u8];
        rest.extend_from_slice(dims);
        rest.extend_from_slice(data);
        rest.push(0);
        self.record(out, name, group, &rest);
    }

    fn frame_count(&self) -> usize {
        self.channels.first().map_or(self.frames, |c| {
            c.stored.len() / usize::from(self.per_channel)
        })
    }

    fn bytes(&self) -> Vec<u8> {
        let n = self.channels.len();
        let frames = self.frame_count();
        let mut p = vec![1, 0x50, 0, if self.big_endian { 0x56 } else { 0x54 }];
        self.record(&mut p, "POINT", -1, &[0]);
        self.record(&mut p, "ANALOG", -2, &[0]);
        for &(id, name) in &self.groups {
            self.record(&mut p, name, -id, &[0]);
        }
        self.param(&mut p, 1, "USED", 2, &[], &self.ints(&[0]));
        self.param(&mut p, 1, "FRAMES", 2, &[], &self.ints(&[frames as i16]));
        let used = self.used.unwrap_or(n as i16);
        self.param(&mut p, 2, "USED", 2, &[], &self.ints(&[used]));
        if n > 0 {
            let labels: Vec<&str> = self.channels.iter().map(|c| c.label).collect();
            let (dims, data) = self.chars(&labels);
            self.param(&mut p, 2, "LABELS", -1, &dims, &data);
            if self.units {
                let units: Vec<&str> = self.channels.iter().map(|c| c.unit).collect();
                let (dims, data) = self.chars(&units);
                self.param(&mut p, 2, "UNITS", -1, &dims, &data);
            }
            let scales: Vec<f32> = self.channels.iter().map(|c| c.scale).collect();
            self.param(&mut p, 2, "SCALE", 4, &[n as u8], &self.floats(&scales));
            let offsets: Vec<i16> = self.channels.iter().map(|c| c.offset).collect();
            self.param(&mut p, 2, "OFFSET", 2, &[n as u8], &self.ints(&offsets));
            self.param(
                &mut p,
                2,
                "GEN_SCALE",
                4,
                &[],
                &self.floats(&[self.gen_scale]),
            );
            self.param(&mut p, 2, "RATE", 4, &[], &self.floats(&[self.analog_rate]));
            if self.integer {
                let format = if self.unsigned { "UNSIGNED" } else { "SIGNED" };
                let (dims, data) = self.chars(&[format]);
                self.param(&mut p, 2, "FORMAT", -1, &dims[..1], &data);
            }
        }
        for (group, name, kind, dims, data) in &self.params {
            self.param(&mut p, *group, name, *kind, dims, data);
        }
        let blocks = p.len().div_ceil(512);
        p.resize(blocks * 512, 0);
        p[2] = blocks as u8;

        let mut out = vec![0u8; 512];
        out[0] = 2;
        out[1] = 0x50;
        let per_frame = n * usize::from(self.per_channel);
        let last = self.first_frame as usize + frames - 1;
        for (at, v) in [
            (2, 0),
            (4, per_frame as u16),
            (6, self.first_frame),
            (8, last as u16),
            (16, 2 + blocks as u16),
            (18, self.per_channel),
        ] {
            out[at..at + 2].copy_from_slice(&self.u16(v));
        }
        let scale = if self.integer { 0.1 } else { -1.0 };
        out[12..16].copy_from_slice(&self.f32(scale));
        out[20..24].copy_from_slice(&self.f32(self.point_rate));
        out.extend_from_slice(&p);
        for row in 0..frames * usize::from(self.per_channel) {
            for c in &self.channels {
                let v = c.stored[row];
                if self.integer {
                    out.extend_from_slice(&self.u16(v as i64 as u16));
                } else {
                    out.extend_from_slice(&self.f32(v as f32));
                }
            }
        }
        // Padded to whole blocks, as most writers do (c3dio 0.8 needs a whole first data block).
        out.resize(out.len().div_ceil(512) * 512, 0);
        out
    }
}

// ---------------------------------------------------------------------------------------------
// Writer → reader

#[test]
fn written_file_reads_back_bit_exact_with_labels_units_and_rate() {
    let torque = [
        0.0,
        -0.0,
        1.5,
        -2.25,
        f64::from(0.1f32),
        f64::from(f32::MAX),
        f64::from(f32::MIN),
        f64::from(f32::MIN_POSITIVE),
        f64::from(f32::from_bits(1)), // smallest subnormal
        16_777_215.0,
    ];
    let emg: Vec<f64> = (0..10).map(|i| f64::from(i as f32 * 0.37f32)).collect();
    let with_nan = [
        1.0,
        f64::NAN,
        3.0,
        f64::INFINITY,
        f64::NEG_INFINITY,
        6.0,
        7.0,
        8.0,
        9.0,
        10.0,
    ];
    let bytes = format_c3d_analog(
        2000.0,
        &[
            ("Torque", "N.m", &torque),
            ("EMG_soleus", "mV", &emg),
            ("A", "", &with_nan),
        ],
    )
    .unwrap();
    assert_eq!(bytes.len() % 512, 0, "padded to whole blocks");
    let table = parse(&bytes).unwrap();
    check_invariants(&table);
    assert_eq!(table.path.to_str(), Some("trial.c3d"));
    assert_eq!(table.rate_hz, Some(2000.0));
    assert_eq!(table.start_s, 0.0);
    let labels: Vec<&str> = table.channels.iter().map(|c| c.label.as_str()).collect();
    assert_eq!(labels, ["Torque", "EMG_soleus", "A"]);
    let units: Vec<Option<&str>> = table.channels.iter().map(|c| c.unit.as_deref()).collect();
    assert_eq!(units, [Some("N.m"), Some("mV"), None]);
    assert_eq!(bits(&table.channels[0].values), bits(&torque));
    assert_eq!(bits(&table.channels[1].values), bits(&emg));
    let back = &table.channel("A").unwrap().values;
    assert!(back[1].is_nan());
    assert_eq!(back[3], f64::INFINITY);
    assert_eq!(back[4], f64::NEG_INFINITY);
    assert_eq!(back[9], 10.0);
    assert_eq!(table.rows(), 10);
}

#[test]
fn values_are_stored_as_the_nearest_f32_and_rates_as_written() {
    let values = [0.1, 1.0 / 3.0, 123_456.789];
    let bytes = format_c3d_analog(1111.11, &[("x", "V", &values)]).unwrap();
    let table = parse(&bytes).unwrap();
    let expected: Vec<f64> = values.iter().map(|&v| f64::from(v as f32)).collect();
    assert_eq!(bits(&table.channels[0].values), bits(&expected));
    assert_ne!(table.channels[0].values[0], 0.1);
    assert_eq!(table.rate_hz, Some(1111.11));
}

#[test]
fn header_and_parameters_follow_the_c3d_layout() {
    let values: Vec<f64> = (0..300).map(f64::from).collect();
    let bytes = format_c3d_analog(500.0, &[("a", "V", &values), ("bb", "V", &values)]).unwrap();
    assert_eq!(bytes[0], 2, "parameter section in block 2");
    assert_eq!(bytes[1], 0x50);
    assert_eq!(word(&bytes, 2), 0, "no 3D points");
    assert_eq!(word(&bytes, 3), 2, "analog samples per frame");
    assert_eq!(
        (word(&bytes, 4), word(&bytes, 5)),
        (1, 300),
        "first and last frame"
    );
    assert_eq!(word(&bytes, 10), 1, "samples per channel per frame");
    assert_eq!(f32::from_le_bytes(bytes[12..16].try_into().unwrap()), -1.0);
    assert_eq!(f32::from_le_bytes(bytes[20..24].try_into().unwrap()), 500.0);
    assert_eq!(bytes[512 + 1], 0x50);
    assert_eq!(bytes[512 + 3], 0x54, "Intel");
    let data_start = (word(&bytes, 9) - 1) * 512;
    assert_eq!(
        usize::from(bytes[512 + 2]),
        word(&bytes, 9) - 2,
        "parameter blocks"
    );
    let (at, kind, dims) = find_parameter(&bytes, "ANALOG", "LABELS");
    assert_eq!((kind, dims.as_slice()), (-1, &[2u8, 2][..]));
    assert_eq!(&bytes[at..at + 4], b"a bb");
    let (at, kind, _) = find_parameter(&bytes, "POINT", "DATA_START");
    assert_eq!(kind, 2);
    assert_eq!(
        usize::from(u16::from_le_bytes([bytes[at], bytes[at + 1]])),
        word(&bytes, 9)
    );
    // Frame 3, channel 2.
    let sample = data_start + (2 * 2 + 1) * 4;
    assert_eq!(
        f32::from_le_bytes(bytes[sample..sample + 4].try_into().unwrap()),
        2.0
    );
}

#[test]
fn trial_longer_than_65535_samples_reads_back_whole() {
    let n = 70_001;
    let values: Vec<f64> = (0..n).map(|i| f64::from(i as u32) * 0.5).collect();
    let bytes = format_c3d_analog(1000.0, &[("emg", "mV", &values)]).unwrap();
    let table = parse(&bytes).unwrap();
    assert_eq!(table.rows(), n);
    assert_eq!(bits(&table.channels[0].values), bits(&values));
}

#[test]
fn read_c3d_reads_a_file_and_names_a_missing_one() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("trial.c3d");
    let bytes = format_c3d_analog(100.0, &[("torque", "Nm", &[1.0, 2.0, 3.0])]).unwrap();
    std::fs::write(&path, &bytes).unwrap();
    let table = read_c3d(&path).unwrap();
    assert_eq!(table.path, path);
    assert_eq!(table.channels[0].values, [1.0, 2.0, 3.0]);
    let mut same = parse_c3d(&bytes, &path.display().to_string()).unwrap();
    same.path = path.clone();
    assert_eq!(table, same);

    let missing = dir.path().join("missing.c3d");
    let message = read_c3d(&missing).unwrap_err().to_string();
    assert!(
        message.starts_with(&missing.display().to_string()),
        "{message}"
    );
}

#[test]
fn parameter_section_after_block_2_is_read() {
    let values = [1.0, -2.0, 3.5];
    let bytes = format_c3d_analog(100.0, &[("x", "V", &values)]).unwrap();
    // Move the parameter section to block 3: insert an empty block after the header.
    let mut moved = bytes[..512].to_vec();
    moved[0] = 3;
    let data_block = word(&bytes, 9) as u16 + 1;
    moved[16..18].copy_from_slice(&data_block.to_le_bytes());
    moved.extend_from_slice(&[0u8; 512]);
    moved.extend_from_slice(&bytes[512..]);
    assert_eq!(parse(&moved).unwrap(), parse(&bytes).unwrap());
}

// ---------------------------------------------------------------------------------------------
// Scaling

/// Writes the parameter bytes `data` over `group:name`'s data, checking its type and length.
fn patch(file: &mut [u8], group: &str, name: &str, kind: i8, data: &[u8]) {
    let (at, found_kind, dims) = find_parameter(file, group, name);
    assert_eq!(found_kind, kind, "{group}:{name} type");
    let length: usize =
        dims.iter().map(|&d| usize::from(d)).product::<usize>() * usize::from(kind.unsigned_abs());
    assert_eq!(length, data.len(), "{group}:{name} length");
    file[at..at + data.len()].copy_from_slice(data);
}

#[test]
fn analog_scale_offset_and_gen_scale_are_applied_once() {
    let stored_a = [0.0, 1.0, 2.0, -5.5, 1000.0];
    let stored_b = [3.0, -3.0, 0.25, 7.0, -1.0];
    let mut bytes =
        format_c3d_analog(100.0, &[("a", "V", &stored_a), ("b", "V", &stored_b)]).unwrap();
    let plain = parse(&bytes).unwrap();
    assert_eq!(
        plain.channels[0].values, stored_a,
        "scale 1, offset 0 as written"
    );

    let floats = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let ints = |v: &[i16]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    patch(&mut bytes, "ANALOG", "SCALE", 4, &floats(&[0.25, 2.0]));
    patch(&mut bytes, "ANALOG", "OFFSET", 2, &ints(&[3, -2]));
    patch(&mut bytes, "ANALOG", "GEN_SCALE", 4, &floats(&[4.0]));
    let table = parse(&bytes).unwrap();
    // real = (stored − offset) × scale × gen_scale, exact in these binary fractions.
    let expected_a: Vec<f64> = stored_a.iter().map(|s| (s - 3.0) * 0.25 * 4.0).collect();
    let expected_b: Vec<f64> = stored_b.iter().map(|s| (s + 2.0) * 2.0 * 4.0).collect();
    assert_eq!(table.channels[0].values, expected_a);
    assert_eq!(table.channels[1].values, expected_b);
    assert_eq!(table.channels[0].values[0], -3.0);

    // A decimal scale: the f32 nearest 0.001, within f32 precision of the decimal.
    patch(&mut bytes, "ANALOG", "SCALE", 4, &floats(&[0.001, 1.0]));
    patch(&mut bytes, "ANALOG", "GEN_SCALE", 4, &floats(&[1.0]));
    let table = parse(&bytes).unwrap();
    for (v, s) in table.channels[0].values.iter().zip(stored_a) {
        let expected = (s - 3.0) * 0.001;
        assert!(
            (v - expected).abs() <= 1e-7 * expected.abs(),
            "{v} vs {expected}"
        );
    }
}

#[test]
fn integer_samples_are_scaled() {
    let mut c = chan("force", "N", vec![-3.0, 0.0, 7.0, 32767.0, -32768.0]);
    c.scale = 0.25;
    c.offset = 1;
    let mut build = Build::new(vec![c]);
    build.integer = true;
    build.gen_scale = 2.0;
    let table = parse(&build.bytes()).unwrap();
    let expected: Vec<f64> = [-3.0, 0.0, 7.0, 32767.0, -32768.0]
        .iter()
        .map(|s| (s - 1.0) * 0.5)
        .collect();
    assert_eq!(table.channels[0].values, expected);
}

#[test]
fn unsigned_integer_samples_above_32767_are_read_as_unsigned() {
    let stored = vec![0.0, 32767.0, 32768.0, 40000.0, 65535.0];
    let mut c = chan("emg", "V", stored.clone());
    c.scale = 0.5;
    c.offset = i16::MIN; // 32768 read as unsigned
    let mut build = Build::new(vec![c]);
    build.integer = true;
    build.unsigned = true;
    let bytes = build.bytes();
    let table = parse(&bytes).unwrap();
    let expected: Vec<f64> = stored.iter().map(|u| (u - 32768.0) * 0.5).collect();
    assert_eq!(table.channels[0].values, expected);
    assert_eq!(table.channels[0].values[3], 3616.0);
    // The premise: c3dio itself decodes them as signed words.
    let raw = c3dio::C3d::from_bytes(&bytes).unwrap();
    assert_eq!(raw.analog.analog[3][0], (40000.0 - 65536.0 - 32768.0) * 0.5);
}

// ---------------------------------------------------------------------------------------------
// Layout variants

#[test]
fn big_endian_file_with_several_samples_per_frame_and_a_late_first_frame() {
    let a: Vec<f64> = (0..40).map(|i| f64::from(i) * 0.5 - 3.0).collect();
    let b: Vec<f64> = (0..40).map(|i| f64::from(i * i)).collect();
    let mut build = Build::new(vec![chan("a", "mV", a.clone()), chan("b", "Nm", b.clone())]);
    build.big_endian = true;
    build.per_channel = 4;
    build.point_rate = 250.0;
    build.analog_rate = 1000.0;
    build.first_frame = 51;
    let table = parse(&build.bytes()).unwrap();
    check_invariants(&table);
    assert_eq!(table.rate_hz, Some(1000.0));
    assert_eq!(table.start_s, 50.0 / 250.0);
    assert_eq!(table.rows(), 40);
    assert_eq!(table.channels[0].values, a);
    assert_eq!(table.channels[1].values, b);
    assert_eq!(table.channels[1].unit.as_deref(), Some("Nm"));
}

#[test]
fn labels_lose_blank_and_nul_padding() {
    let mut build = Build::new(vec![
        chan("EMG_soleus", "mV", vec![1.0; 5]),
        chan(" Torque ", "", vec![2.0; 5]),
        chan("x", "N.m", vec![3.0; 5]),
    ]);
    build.pad = 0;
    let table = parse(&build.bytes()).unwrap();
    let labels: Vec<&str> = table.channels.iter().map(|c| c.label.as_str()).collect();
    assert_eq!(labels, ["EMG_soleus", "Torque", "x"]);
    let units: Vec<Option<&str>> = table.channels.iter().map(|c| c.unit.as_deref()).collect();
    assert_eq!(units, [Some("mV"), None, Some("N.m")]);
}

// ---------------------------------------------------------------------------------------------
// Errors

#[test]
fn duplicate_labels_are_an_error_naming_the_label() {
    let build = Build::new(vec![
        chan("EMG", "mV", vec![1.0; 5]),
        chan("Torque", "Nm", vec![2.0; 5]),
        chan("EMG ", "mV", vec![3.0; 5]),
    ]);
    let e = parse(&build.bytes()).unwrap_err();
    assert!(
        matches!(&e, RecordingError::Column { name, .. } if name == "EMG"),
        "{e:?}"
    );
    let message = err(&build.bytes());
    assert!(message.contains("duplicate"), "{message}");
    assert!(message.contains("channels 1 and 3"), "{message}");
}

#[test]
fn blank_and_missing_labels_are_errors() {
    let build = Build::new(vec![
        chan("a", "V", vec![1.0; 5]),
        chan("  ", "V", vec![2.0; 5]),
    ]);
    let message = err(&build.bytes());
    assert!(
        message.contains("analog channel 2 has no label"),
        "{message}"
    );

    let mut build = Build::new(vec![
        chan("a", "V", vec![1.0; 5]),
        chan("b", "V", vec![2.0; 5]),
    ]);
    build
        .params
        .push((2, "LABELS", -1, vec![1, 1], b"a".to_vec()));
    let message = err(&build.bytes());
    assert!(
        message.contains("ANALOG:LABELS names 1 of the 2"),
        "{message}"
    );
}

#[test]
fn a_file_without_analog_channels_is_an_error() {
    let message = err(&Build::new(Vec::new()).bytes());
    assert!(message.contains("no analog channels"), "{message}");

    let mut build = Build::new(vec![chan("a", "V", vec![1.0; 5])]);
    build.used = Some(0);
    let message = err(&build.bytes());
    assert!(message.contains("no analog channels"), "{message}");
}

#[test]
fn missing_units_parameter_is_an_error_from_c3dio() {
    let mut build = Build::new(vec![chan("a", "V", vec![1.0; 5])]);
    build.units = false;
    let message = err(&build.bytes());
    assert!(message.contains("ANALOG:UNITS"), "{message}");
}

#[test]
fn text_and_empty_files_are_not_c3d() {
    let message = err(b"time,torque_nm,emg_mv\n0.000,1.5,0.01\n0.001,1.6,0.02\n");
    assert!(message.contains("not a C3D file"), "{message}");
    let message = err(b"");
    assert!(message.contains("not a C3D file"), "{message}");
    let message = err(&[2, 0x50, 0, 0]);
    assert!(message.contains("truncated"), "{message}");
}

#[test]
fn every_cut_that_loses_data_is_an_error() {
    let a: Vec<f64> = (0..20).map(f64::from).collect();
    let bytes = format_c3d_analog(100.0, &[("a", "V", &a), ("b", "mV", &a)]).unwrap();
    let full = parse(&bytes).unwrap();
    let data_end = (word(&bytes, 9) - 1) * 512 + 20 * 2 * 4;
    assert!(data_end < bytes.len(), "the file ends with block padding");
    let mut errors = 0;
    for cut in (0..bytes.len()).step_by(7) {
        let cut_bytes = &bytes[..cut];
        if cut < data_end {
            let message = err(cut_bytes);
            assert!(
                message.contains("truncated") || message.contains("not a C3D file"),
                "cut {cut}: {message}"
            );
            errors += 1;
        } else {
            assert_eq!(
                parse(cut_bytes).unwrap(),
                full,
                "cut {cut} loses only padding"
            );
        }
    }
    assert!(errors > 100);
    // A cut one sample short of the data, and one byte short.
    assert!(err(&bytes[..data_end - 4]).contains("truncated"));
    assert!(err(&bytes[..data_end - 1]).contains("truncated"));
    assert_eq!(parse(&bytes[..data_end]).unwrap(), full);
}

#[test]
fn random_bytes_never_panic() {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    for round in 0..3000 {
        let len = rng.below(4000);
        let mut bytes: Vec<u8> = (0..len).map(|_| rng.byte()).collect();
        // Most rounds look like a C3D header, to get past the first checks.
        if round % 4 != 0 && len > 520 {
            bytes[0] = 2;
            bytes[1] = 0x50;
            bytes[512 + 3] = [0x54, 0x55, 0x56][rng.below(3)];
            bytes[16] = 2 + rng.below(6) as u8;
            bytes[17] = 0;
        }
        let result = catch_unwind(AssertUnwindSafe(|| parse(&bytes)));
        let result = result.unwrap_or_else(|_| panic!("panic on round {round}"));
        match result {
            Ok(table) => check_invariants(&table),
            Err(e) => {
                let message = e.to_string();
                assert!(message.starts_with("trial.c3d: "), "{message}");
                assert!(!message.contains('\n'), "{message}");
            }
        }
    }
}

#[test]
fn corrupted_files_never_panic() {
    let a: Vec<f64> = (0..30).map(|i| f64::from(i) * 0.25).collect();
    let valid = format_c3d_analog(
        100.0,
        &[
            ("Torque", "N.m", &a),
            ("EMG_soleus", "mV", &a),
            ("EMG_gm", "mV", &a),
        ],
    )
    .unwrap();
    let mut rng = Rng(12345);
    let mut ok = 0;
    for round in 0..3000 {
        let mut bytes = valid.clone();
        for _ in 0..1 + rng.below(4) {
            // Mostly the header and the parameter section.
            let at = if rng.below(4) == 0 {
                rng.below(bytes.len())
            } else {
                rng.below(1024)
            };
            bytes[at] = rng.byte();
        }
        if rng.below(8) == 0 {
            bytes.truncate(rng.below(bytes.len()));
        }
        let result = catch_unwind(AssertUnwindSafe(|| parse(&bytes)));
        let result = result.unwrap_or_else(|_| panic!("panic on round {round}"));
        match result {
            Ok(table) => {
                check_invariants(&table);
                ok += 1;
            }
            Err(e) => {
                let message = e.to_string();
                assert!(message.starts_with("trial.c3d: "), "{message}");
                assert!(!message.contains('\n'), "{message}");
            }
        }
    }
    assert!(ok > 100, "only {ok} corrupted files read");
}

#[test]
fn a_c3dio_panic_becomes_an_error() {
    // A force plate group without its CHANNEL parameter: c3dio 0.8 unwraps the missing
    // parameter. The crate's checks do not look at force plates; the panic guard catches it.
    let mut build = Build::new(vec![chan("a", "V", vec![1.0; 5])]);
    build.groups.push((3, "FORCE_PLATFORM"));
    let ints = |v: &[i16]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let floats = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    build.params.push((3, "USED", 2, vec![], ints(&[1])));
    build.params.push((3, "TYPE", 2, vec![1], ints(&[2])));
    build
        .params
        .push((3, "CORNERS", 4, vec![3, 4], floats(&[0.0; 12])));
    build
        .params
        .push((3, "ORIGIN", 4, vec![3], floats(&[0.0; 3])));
    build.params.push((3, "ZERO", 2, vec![2], ints(&[1, 10])));
    let bytes = build.bytes();
    let c3dio_result = catch_unwind(|| c3dio::C3d::from_bytes(&bytes).is_ok());
    assert!(c3dio_result.is_err(), "c3dio 0.8 panics on this file");
    let message = err(&bytes);
    assert!(message.contains("c3dio"), "{message}");

    // With the CHANNEL parameter the same file reads.
    build
        .params
        .push((3, "CHANNEL", 2, vec![8, 1], ints(&[1, 0, 0, 0, 0, 0, 0, 0])));
    assert_eq!(parse(&build.bytes()).unwrap().channels[0].values, [1.0; 5]);
}

// ---------------------------------------------------------------------------------------------
// Writer errors

#[test]
fn the_writer_refuses_what_it_cannot_write_faithfully() {
    let v = [1.0, 2.0];
    let short = [1.0];
    let cases: Vec<(f64, Vec<Channel>, &str)> = vec![
        (0.0, vec![("a", "V", &v[..])], "rate"),
        (f64::NAN, vec![("a", "V", &v[..])], "rate"),
        (1e300, vec![("a", "V", &v[..])], "rate"),
        (100.0, vec![], "no channels"),
        (100.0, vec![("a", "V", &[])], "no samples"),
        (100.0, vec![("a", "V", &v), ("b", "V", &short)], "1 samples"),
        (100.0, vec![("a", "V", &v), ("a", "mV", &v)], "duplicate"),
        (100.0, vec![("", "V", &v)], "empty"),
        (100.0, vec![(" a", "V", &v)], "blank"),
        (100.0, vec![("émg", "V", &v)], "ASCII"),
        (100.0, vec![("a", "µV", &v)], "ASCII"),
        (100.0, vec![("a", "V", &[1.0, 1e39])], "f32"),
    ];
    for (rate, channels, expected) in cases {
        let e = format_c3d_analog(rate, &channels).unwrap_err().to_string();
        assert!(e.starts_with("C3D writer"), "{e}");
        assert!(e.contains(expected), "{e} lacks {expected}");
    }
    let long = "x".repeat(256);
    let e = format_c3d_analog(100.0, &[(long.as_str(), "V", &v)]).unwrap_err();
    assert!(e.to_string().contains("255"), "{e}");
    let labels: Vec<String> = (0..256).map(|i| format!("c{i}")).collect();
    let many: Vec<Channel> = labels.iter().map(|l| (l.as_str(), "V", &v[..])).collect();
    assert!(format_c3d_analog(100.0, &many).is_err());
    assert!(format_c3d_analog(100.0, &many[..255]).is_ok());
}
