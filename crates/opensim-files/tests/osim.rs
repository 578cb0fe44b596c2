//! Reading the identified muscles of an `.osim` model and writing them back into a copy.

use muscle_model::{ModelParams, Muscle};
use opensim_files::{osim_params, write_identified_osim, OpenSimError, OsimMuscleNames};
use roxmltree::{Document, Node, NodeType};

const MODEL: &str = include_str!("data/leg6.osim");
const FILE: &str = "leg6.osim";

/// 1-based line and column of the first occurrence of `needle` in `text`.
fn line_col(text: &str, needle: &str) -> (u32, u32) {
    let at = text.find(needle).expect("needle in text");
    let before = &text[..at];
    let line = before.matches('\n').count() + 1;
    let col = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
    (line as u32, col as u32)
}

#[test]
fn default_names_read_the_five_properties_and_keep_the_rest() {
    let nominal = ModelParams::nominal();
    let p = osim_params(MODEL, FILE, &OsimMuscleNames::default(), &nominal).unwrap();
    let sol = p.muscle(Muscle::Sol);
    assert_eq!(
        (sol.fom_n, sol.lom_m, sol.lst_m, sol.vmax_lom_per_s),
        (3600.0, 0.049, 0.255, 10.0)
    );
    assert_eq!(sol.alpha_deg, 0.43f64.to_degrees());
    let gm = p.muscle(Muscle::Gm);
    assert_eq!(
        (gm.fom_n, gm.lom_m, gm.lst_m, gm.vmax_lom_per_s),
        (1500.0, 0.061, 0.385, 12.0)
    );
    let gl = p.muscle(Muscle::Gl);
    assert_eq!((gl.fom_n, gl.lst_m), (700.0, 0.376));
    // absent from the file: stays nominal
    assert_eq!(gl.vmax_lom_per_s, nominal.muscle(Muscle::Gl).vmax_lom_per_s);
    for m in Muscle::ALL {
        assert_eq!(p.muscle(m).lmt_poly_m, nominal.muscle(m).lmt_poly_m);
        assert_eq!(
            p.muscle(m).knee_moment_arm_m,
            nominal.muscle(m).knee_moment_arm_m
        );
    }
    assert_eq!(p.activation, nominal.activation);
    assert_eq!(p.curves, nominal.curves);
    assert!(p.fixed.is_empty());
}

#[test]
fn renamed_muscles_are_read_from_their_own_elements() {
    let names = OsimMuscleNames::renamed([("sol", "soleus_l")]).unwrap();
    assert_eq!(names.get(Muscle::Sol), "soleus_l");
    assert_eq!(names.get(Muscle::Gm), "med_gas_r");
    let p = osim_params(MODEL, FILE, &names, &ModelParams::nominal()).unwrap();
    assert_eq!(p.muscle(Muscle::Sol).fom_n, 3400.0);
    assert_eq!(p.muscle(Muscle::Sol).lst_m, 0.245);
    let e = OsimMuscleNames::renamed([("ta", "tib_ant_r")]).unwrap_err();
    assert_eq!(e, OpenSimError::MuscleKey { key: "ta".into() });
}

#[test]
fn unsupported_types_missing_muscles_and_bad_values_are_named() {
    // a Schutte muscle asked for: its type, the supported ones, and where it is
    let names = OsimMuscleNames::renamed([("gl", "per_long_r")]).unwrap();
    let e = osim_params(MODEL, FILE, &names, &ModelParams::nominal()).unwrap_err();
    let (line, col) = line_col(MODEL, "<Schutte1993Muscle_Deprecated");
    let msg = e.to_string();
    assert!(msg.starts_with(&format!("{FILE}:{line}:{col}: ")), "{msg}");
    assert!(msg.contains("Schutte1993Muscle_Deprecated"), "{msg}");
    assert!(
        msg.contains("Thelen2003Muscle and Millard2012EquilibriumMuscle"),
        "{msg}"
    );

    // a name that is not there: the muscles that are
    let names = OsimMuscleNames::renamed([("gm", "gasmed_r")]).unwrap();
    let msg = osim_params(MODEL, FILE, &names, &ModelParams::nominal())
        .unwrap_err()
        .to_string();
    assert!(
        msg.starts_with("leg6.osim: muscle `gasmed_r`: not in"),
        "{msg}"
    );
    assert!(
        msg.contains("soleus_r, med_gas_r, lat_gas_r, tib_ant_r"),
        "{msg}"
    );
    assert!(!msg.contains("ankle_reserve"), "{msg}");

    // a value that is not a number: line and column of the value
    let bad = MODEL.replace(
        "<tendon_slack_length>0.376<",
        "<tendon_slack_length>0.37x6<",
    );
    let (line, col) = line_col(&bad, "0.37x6");
    let msg = osim_params(
        &bad,
        FILE,
        &OsimMuscleNames::default(),
        &ModelParams::nominal(),
    )
    .unwrap_err()
    .to_string();
    assert_eq!(
        msg,
        format!("{FILE}:{line}:{col}: <tendon_slack_length>: `0.37x6` is not a number")
    );

    // a value surae rejects: the muscle and the key
    let neg = MODEL.replace("<max_isometric_force>700<", "<max_isometric_force>-700<");
    let msg = osim_params(
        &neg,
        FILE,
        &OsimMuscleNames::default(),
        &ModelParams::nominal(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        msg.starts_with("leg6.osim: muscle `lat_gas_r`: as surae's gl: "),
        "{msg}"
    );
    assert!(msg.contains("fom_n"), "{msg}");

    // broken XML: line and column from the parser
    let broken = MODEL.replace("</BodySet>", "</BodySett>");
    let msg = osim_params(
        &broken,
        FILE,
        &OsimMuscleNames::default(),
        &ModelParams::nominal(),
    )
    .unwrap_err()
    .to_string();
    let (line, _) = line_col(&broken, "</BodySett>");
    assert!(msg.starts_with(&format!("{FILE}:{line}:")), "{msg}");

    // not a model at all
    let msg = osim_params(
        "<a/>",
        "x.osim",
        &OsimMuscleNames::default(),
        &ModelParams::nominal(),
    )
    .unwrap_err()
    .to_string();
    assert_eq!(msg, "x.osim: not an OpenSim model (no <Model> element)");
}

/// The identified values used by the write tests (none equal to the file's).
fn identified() -> ModelParams {
    let mut p = ModelParams::nominal();
    for (m, f0, lst, alpha) in [
        (Muscle::Sol, 3712.123456789, 0.2531234567, 26.25),
        (Muscle::Gm, 1444.4, 0.3911, 16.123456789),
        (Muscle::Gl, 699.0001, 0.38, 8.5),
    ] {
        let mp = p.muscle_mut(m);
        mp.fom_n = f0;
        mp.lst_m = lst;
        mp.alpha_deg = alpha;
    }
    p
}

/// Walks two trees in step; returns the text nodes that differ as
/// `(muscle name, element tag, old text, new text)`, and fails on any other difference.
fn diff_trees(a: &Document, b: &Document) -> Vec<(String, String, String, String)> {
    fn walk(a: Node, b: Node, out: &mut Vec<(String, String, String, String)>) {
        assert_eq!(a.node_type(), b.node_type());
        assert_eq!(a.tag_name(), b.tag_name());
        let attrs = |n: Node| -> Vec<(String, String)> {
            n.attributes()
                .map(|x| (x.name().to_string(), x.value().to_string()))
                .collect()
        };
        assert_eq!(attrs(a), attrs(b));
        match a.node_type() {
            NodeType::Text | NodeType::Comment if a.text() != b.text() => {
                let el = a.parent().unwrap();
                let muscle = el.parent().and_then(|m| m.attribute("name")).unwrap_or("");
                out.push((
                    muscle.to_string(),
                    el.tag_name().name().to_string(),
                    a.text().unwrap().to_string(),
                    b.text().unwrap().to_string(),
                ));
            }
            NodeType::PI => assert_eq!(a.pi(), b.pi()),
            _ => {}
        }
        let (ka, kb): (Vec<Node>, Vec<Node>) = (a.children().collect(), b.children().collect());
        assert_eq!(ka.len(), kb.len(), "children of <{}>", a.tag_name().name());
        for (x, y) in ka.into_iter().zip(kb) {
            walk(x, y, out);
        }
    }
    let mut out = Vec::new();
    walk(a.root(), b.root(), &mut out);
    out
}

#[test]
fn identified_osim_differs_from_the_model_in_the_nine_values_only() {
    let p = identified();
    let out = write_identified_osim(MODEL, FILE, &OsimMuscleNames::default(), &p).unwrap();
    let (a, b) = (
        Document::parse(MODEL).unwrap(),
        Document::parse(&out).unwrap(),
    );
    let diffs = diff_trees(&a, &b);
    assert_eq!(diffs.len(), 9, "{diffs:?}");
    let names = OsimMuscleNames::default();
    for m in Muscle::ALL {
        let mp = p.muscle(m);
        for (tag, want) in [
            ("max_isometric_force", mp.fom_n),
            ("tendon_slack_length", mp.lst_m),
            ("pennation_angle_at_optimal", mp.alpha_deg.to_radians()),
        ] {
            let d = diffs
                .iter()
                .find(|d| d.0 == names.get(m) && d.1 == tag)
                .unwrap_or_else(|| panic!("{} {tag} not changed", names.get(m)));
            assert_eq!(d.3.trim().parse::<f64>().unwrap(), want);
        }
    }
    // white space around a value is kept
    assert!(out.contains("<max_isometric_force> 1444.4 </max_isometric_force>"));
    // the copy reads back to the identified values; what was not identified is the file's
    let back = osim_params(&out, "identified.osim", &names, &ModelParams::nominal()).unwrap();
    let read = osim_params(MODEL, FILE, &names, &ModelParams::nominal()).unwrap();
    for m in Muscle::ALL {
        let (x, y) = (back.muscle(m), p.muscle(m));
        assert_eq!((x.fom_n, x.lst_m), (y.fom_n, y.lst_m));
        assert!((x.alpha_deg - y.alpha_deg).abs() < 1e-12);
        assert_eq!(x.lom_m, read.muscle(m).lom_m);
        assert_eq!(x.vmax_lom_per_s, read.muscle(m).vmax_lom_per_s);
    }
}

#[test]
fn a_missing_property_is_added_indented_like_the_others() {
    let model = MODEL.replace(
        "\t\t\t\t\t<tendon_slack_length>0.376</tendon_slack_length>\n",
        "",
    );
    let p = identified();
    let out = write_identified_osim(&model, FILE, &OsimMuscleNames::default(), &p).unwrap();
    assert!(out.contains(
        "<pennation_angle_at_optimal>0.14835298641951802</pennation_angle_at_optimal>\n\t\t\t\t\t<tendon_slack_length>0.38</tendon_slack_length>\n\t\t\t\t</Thelen2003Muscle>"
    ), "{out}");
    let back = osim_params(
        &out,
        "x",
        &OsimMuscleNames::default(),
        &ModelParams::nominal(),
    )
    .unwrap();
    assert_eq!(back.muscle(Muscle::Gl).lst_m, 0.38);
}
