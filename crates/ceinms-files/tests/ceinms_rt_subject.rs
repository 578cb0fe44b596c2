//! CEINMS-RT's subject XML (`fixtures/walk36/`: the subject before and after CEINMS-RT's own
//! calibration) read into the types CEINMS's reader gives, every value as the file writes it.

use ceinms_files::{read_subject, SubjectFormat};
use std::path::{Path, PathBuf};

fn walk36(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/walk36")
        .join(name)
}

/// The number in `<tag>…</tag>` of the `<muscle>` element named `muscle`, found by plain text
/// search (independently of the reader under test).
fn file_value(path: &Path, muscle: &str, tag: &str) -> f64 {
    let text = std::fs::read_to_string(path).unwrap();
    let block = text
        .split("<muscle>")
        .skip(1)
        .map(|b| b.split("</muscle>").next().unwrap())
        .find(|b| b.contains(&format!("<name>{muscle}</name>")))
        .unwrap_or_else(|| panic!("no muscle {muscle}"));
    let open = format!("<{tag}>");
    let start = block.find(&open).unwrap() + open.len();
    let end = block[start..].find("</").unwrap() + start;
    block[start..end].trim().parse().unwrap()
}

#[test]
fn the_calibrated_subject_reads_as_the_file_writes_it() {
    let path = walk36("subjectCalibrated.xml");
    let s = read_subject(&path).unwrap();
    assert_eq!(s.format, SubjectFormat::CeinmsRt);
    assert_eq!(s.mtus.len(), 92);
    assert_eq!(s.em_delay_s, 0.0);
    for muscle in ["soleus_r", "med_gas_r", "lat_gas_r", "tib_ant_r"] {
        let m = s.mtu(muscle).unwrap();
        let v = |tag: &str| file_value(&path, muscle, tag);
        assert_eq!(m.c1, v("C1"), "{muscle}");
        assert_eq!(m.c2, v("C2"), "{muscle}");
        assert_eq!(m.shape_factor, v("shapeFactor"), "{muscle}");
        assert_eq!(
            m.optimal_fibre_length_m,
            v("optimalFiberLength"),
            "{muscle}"
        );
        assert_eq!(m.pennation_deg, v("pennationAngle"), "{muscle}");
        assert_eq!(m.tendon_slack_length_m, v("tendonSlackLength"), "{muscle}");
        assert_eq!(m.max_isometric_force_n, v("maxIsometricForce"), "{muscle}");
        assert_eq!(m.strength_coefficient, v("strengthCoefficient"), "{muscle}");
        assert_eq!(m.em_delay_s, None);
        assert_eq!(m.max_contraction_velocity, None);
    }
    // the soleus CEINMS-RT calibrated, as written in the file
    let sol = s.mtu("soleus_r").unwrap();
    assert_eq!(sol.shape_factor, -0.00807773437994842);
    assert_eq!(sol.optimal_fibre_length_m, 0.0511703542155837);
    assert_eq!(sol.tendon_slack_length_m, 0.246520266638787);
    assert_eq!(sol.max_force_n(), 3549.0 * 0.50000658823958);
    // CEINMS's names of the identified muscles find gait2392's
    assert_eq!(s.mtu("sol_r"), Some(sol));
    assert_eq!(s.mtu("gasmed_r"), s.mtu("med_gas_r"));
    assert_eq!(s.mtu("gaslat_r"), s.mtu("lat_gas_r"));
    assert_eq!(s.mtu("tibant_r"), s.mtu("tib_ant_r"));
}

#[test]
fn the_uncalibrated_subject_reads_despite_its_byte_order_mark() {
    let path = walk36("uncalibratedSubject.xml");
    assert!(std::fs::read(&path).unwrap().starts_with(b"\xEF\xBB\xBF"));
    let s = read_subject(&path).unwrap();
    let sol = s.mtu("soleus_r").unwrap();
    assert_eq!(
        sol.tendon_slack_length_m,
        file_value(&path, "soleus_r", "tendonSlackLength")
    );
    assert_eq!(sol.strength_coefficient, 0.23);
    // CEINMS-RT's calibration changed the soleus's tendon slack length
    let cal = read_subject(&walk36("subjectCalibrated.xml")).unwrap();
    assert_ne!(
        cal.mtu("soleus_r").unwrap().tendon_slack_length_m,
        sol.tendon_slack_length_m
    );
}

#[test]
fn a_missing_field_is_one_line_naming_the_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(walk36("subjectCalibrated.xml")).unwrap();
    let field = "<optimalFiberLength>0.0511703542155837</optimalFiberLength>";
    assert_eq!(text.matches(field).count(), 1);
    let p = dir.path().join("subject.xml");
    std::fs::write(&p, text.replace(field, "")).unwrap();
    let e = read_subject(&p).unwrap_err();
    // the soleus's <muscle> element: the line before its name
    let line = text
        .lines()
        .position(|l| l.contains("<name>soleus_r</name>"))
        .unwrap();
    let msg = e.to_string();
    assert_eq!(
        msg,
        format!(
            "{}:{line}:5 (muscle soleus_r): missing `optimalFiberLength`",
            p.display()
        )
    );
    assert_eq!((e.line(), e.column()), (Some(line), Some(5)));
}
