//! Strides from the right foot's vertical ground reaction force of fixtures/walk36 (61 s of
//! treadmill walking at 3.6 km/h, 100 Hz): what the 20 N threshold finds on a real recording.

use experiment::{strides_from_ground_force, StridePart, STANCE_THRESHOLD_N};
use std::path::PathBuf;

/// `time` and `ground_force_vy` of the fixture's XLD.mot (an OpenSim storage file: a header
/// up to `endheader`, a line of column names, tab-separated rows).
fn walk36_force() -> (Vec<f64>, Vec<f64>) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/walk36/XLD.mot");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines().skip_while(|l| l.trim() != "endheader").skip(1);
    let header: Vec<&str> = lines.next().unwrap().split_whitespace().collect();
    let col = header.iter().position(|h| *h == "ground_force_vy").unwrap();
    let (mut t, mut f) = (Vec::new(), Vec::new());
    for l in lines.filter(|l| !l.trim().is_empty()) {
        let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
        t.push(v[0]);
        f.push(v[col]);
    }
    (t, f)
}

fn median_s(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    0.5 * (v[(n - 1) / 2] + v[n / 2])
}

#[test]
fn walk36_right_foot_strides() {
    let (t, f) = walk36_force();
    assert_eq!(t.len(), 6097);
    let fs = 1.0 / (t[1] - t[0]);
    let s = strides_from_ground_force(&f, fs, STANCE_THRESHOLD_N).unwrap();
    // 50 foot strikes (the recording begins in stance): 49 strides
    assert_eq!(s.len(), 49);
    let stride = s.durations_s(fs);
    let stance: Vec<f64> = s
        .stance_durations_s(fs)
        .into_iter()
        .map(Option::unwrap)
        .collect();
    let (ms, mst) = (median_s(stride.clone()), median_s(stance.clone()));
    assert!((1.12..1.18).contains(&ms), "median stride {ms} s");
    assert!((0.72..0.78).contains(&mst), "median stance {mst} s");
    let typical: Vec<usize> = (0..s.len())
        .filter(|&k| (0.9..=1.4).contains(&stride[k]) && (0.5..=0.9).contains(&stance[k]))
        .collect();
    let odd: Vec<(usize, f64, f64, f64)> = (0..s.len())
        .filter(|k| !typical.contains(k))
        .map(|k| (k, t[s.strides[k].start], stride[k], stance[k]))
        .collect();
    // Five are not: three in which the force never falls below 20 N between two stances
    // (about 50–100 N: the other foot on this belt), so two strides read as one of 2.3 s, and
    // two around a strike at 6.06 s where the force creeps up to 50 N 0.2 s before the
    // foot's real loading (0.89 s, then 1.39 s with a 0.99 s stance).
    let starts: Vec<f64> = odd.iter().map(|o| (o.1 * 100.0).round() / 100.0).collect();
    assert_eq!(starts, vec![5.17, 6.06, 32.66, 39.57, 54.48], "{odd:?}");
    for &(k, _, d, st) in &odd[2..] {
        assert!(d > 2.2 && st > 1.8, "stride {k}: {d} s, stance {st} s");
    }
    // stance-normalised force: 101 points per stride, 0 % above and 100 % at or below 20 N
    let curves = s.normalised_part(&f, 101, StridePart::Stance);
    assert!(curves.iter().all(|c| c.len() == 101));
    assert!(curves
        .iter()
        .all(|c| c[0] > STANCE_THRESHOLD_N && c[100] <= STANCE_THRESHOLD_N));
}
