//! The identified muscles of an OpenSim model (`.osim`): read into surae's parameters, and
//! written back into a copy of the model.
//!
//! # What is read
//!
//! An `.osim` file is XML: `OpenSimDocument/Model/ForceSet/objects` holds one element per
//! force, its tag the force's type and its `name` attribute the muscle's name. surae reads the
//! muscles named by [`OsimMuscleNames`] (gait2392's `soleus_r`, `med_gas_r`, `lat_gas_r` by
//! default), which must be a `Thelen2003Muscle` or a `Millard2012EquilibriumMuscle`. From
//! each it takes the direct child elements
//!
//! | element | unit in the file | surae |
//! |---|---|---|
//! | `max_isometric_force` | N | `fom_n` (F0) |
//! | `optimal_fiber_length` | m | `lom_m` (LOM) |
//! | `tendon_slack_length` | m | `lst_m` (LST) |
//! | `pennation_angle_at_optimal` | rad | `alpha_deg` (α0, converted to degrees) |
//! | `max_contraction_velocity` | optimal lengths/s | `vmax_lom_per_s` |
//!
//! An element the muscle does not have keeps the value it had (nominal, or an earlier file's).
//! The musculotendon length polynomial, the knee moment arm, activation and curve parameters
//! do not come from the model: the path geometry of an `.osim` needs OpenSim's kinematics.
//!
//! # What is written
//!
//! [`write_identified_osim`] replaces the text of `max_isometric_force`, `tendon_slack_length`
//! and `pennation_angle_at_optimal` of those three muscles and nothing else: the replacement
//! works on the byte ranges the parser reports, so comments, formatting, attribute order and
//! every other element stay exactly as they were. A muscle without one of those elements gets
//! it appended after its last child element, indented like its first.

use muscle_model::{ModelParams, Muscle};
use roxmltree::{Document, Node};

use crate::OpenSimError;

/// OpenSim muscle types whose parameters surae reads: both are Hill-type models with the
/// same meaning of the five properties read (the curves are surae's own).
pub const SUPPORTED_MUSCLE_TYPES: [&str; 2] = ["Thelen2003Muscle", "Millard2012EquilibriumMuscle"];

/// The names in the OpenSim model of surae's sol, gm and gl (the `osim_muscles` map).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OsimMuscleNames {
    names: [String; 3],
}

impl Default for OsimMuscleNames {
    /// gait2392's right-leg names.
    fn default() -> Self {
        Self {
            names: ["soleus_r".into(), "med_gas_r".into(), "lat_gas_r".into()],
        }
    }
}

impl OsimMuscleNames {
    /// The default names with some renamed: `(surae name, OpenSim name)` pairs, e.g.
    /// `("sol", "soleus_l")`.
    ///
    /// # Errors
    /// A key other than `sol`, `gm`, `gl`.
    pub fn renamed<'a>(
        pairs: impl IntoIterator<Item = (&'a str, &'a str)>,
    ) -> Result<Self, OpenSimError> {
        let mut out = Self::default();
        for (key, name) in pairs {
            let m = Muscle::from_name(key).ok_or_else(|| OpenSimError::MuscleKey {
                key: key.to_string(),
            })?;
            out.names[m.index()] = name.to_string();
        }
        Ok(out)
    }

    /// The OpenSim name of `m`.
    pub fn get(&self, m: Muscle) -> &str {
        &self.names[m.index()]
    }
}

/// One muscle element found in the model.
struct Found<'a, 'input> {
    node: Node<'a, 'input>,
    muscle: Muscle,
}

/// The properties read, in the order of the table in the module documentation.
const READ: [&str; 5] = [
    "max_isometric_force",
    "optimal_fiber_length",
    "tendon_slack_length",
    "pennation_angle_at_optimal",
    "max_contraction_velocity",
];

fn parse<'input>(text: &'input str, file: &str) -> Result<Document<'input>, OpenSimError> {
    Document::parse(text).map_err(|e| OpenSimError::at(file, e.pos(), e.to_string()))
}

/// The elements of the three muscles, checked for their type.
fn find_muscles<'a, 'input>(
    doc: &'a Document<'input>,
    file: &str,
    names: &OsimMuscleNames,
) -> Result<Vec<Found<'a, 'input>>, OpenSimError> {
    if !doc.descendants().any(|n| n.has_tag_name("Model")) {
        return Err(OpenSimError::File {
            file: file.to_string(),
            message: "not an OpenSim model (no <Model> element)".into(),
        });
    }
    // forces: the children of ForceSet/objects
    let forces: Vec<Node> = doc
        .descendants()
        .filter(|n| n.has_tag_name("ForceSet"))
        .flat_map(|fs| fs.children().filter(|c| c.has_tag_name("objects")))
        .flat_map(|objs| objs.children().filter(|c| c.is_element()))
        .collect();
    let mut out = Vec::with_capacity(3);
    for m in Muscle::ALL {
        let name = names.get(m);
        let hits: Vec<Node> = forces
            .iter()
            .copied()
            .filter(|n| n.attribute("name") == Some(name))
            .collect();
        let node = match hits.as_slice() {
            [one] => *one,
            [] => {
                let muscles: Vec<&str> = forces
                    .iter()
                    .filter(|n| n.tag_name().name().ends_with("Muscle"))
                    .filter_map(|n| n.attribute("name"))
                    .collect();
                return Err(OpenSimError::Muscle {
                    file: file.to_string(),
                    muscle: name.to_string(),
                    message: format!(
                        "not in the model's ForceSet (surae's {} muscle; rename it with \
                         osim_muscles). Muscles in the model: {}",
                        m.name(),
                        if muscles.is_empty() {
                            "none".to_string()
                        } else {
                            muscles.join(", ")
                        }
                    ),
                });
            }
            [_, second, ..] => {
                return Err(OpenSimError::at(
                    file,
                    doc.text_pos_at(second.range().start),
                    format!("a second force named `{name}`"),
                ));
            }
        };
        let kind = node.tag_name().name();
        if !SUPPORTED_MUSCLE_TYPES.contains(&kind) {
            return Err(OpenSimError::at(
                file,
                doc.text_pos_at(node.range().start),
                format!(
                    "muscle `{name}` is a {kind}; surae reads {}",
                    SUPPORTED_MUSCLE_TYPES.join(" and ")
                ),
            ));
        }
        out.push(Found { node, muscle: m });
    }
    Ok(out)
}

/// The direct child element `tag` of `node`, if any (a second one is an error).
fn property<'a, 'input>(
    doc: &Document<'input>,
    file: &str,
    node: Node<'a, 'input>,
    tag: &str,
) -> Result<Option<Node<'a, 'input>>, OpenSimError> {
    let mut it = node.children().filter(|c| c.has_tag_name(tag));
    let first = it.next();
    if let Some(second) = it.next() {
        return Err(OpenSimError::at(
            file,
            doc.text_pos_at(second.range().start),
            format!("a second <{tag}>"),
        ));
    }
    Ok(first)
}

/// The number in `element`'s text and the byte range of that number in the source.
fn number(
    doc: &Document,
    text: &str,
    file: &str,
    element: Node,
) -> Result<(f64, std::ops::Range<usize>), OpenSimError> {
    let tag = element.tag_name().name();
    let mut kids = element.children();
    let (t, none_after) = (kids.next(), kids.next().is_none());
    let t = match t {
        Some(t) if t.is_text() && none_after => t,
        _ => {
            return Err(OpenSimError::at(
                file,
                doc.text_pos_at(element.range().start),
                format!("<{tag}> must hold one number"),
            ))
        }
    };
    let range = t.range();
    let raw = &text[range.clone()];
    let lead = raw.len() - raw.trim_start().len();
    let value = raw.trim();
    let start = range.start + lead;
    let v: f64 = value.parse().map_err(|_| {
        OpenSimError::at(
            file,
            doc.text_pos_at(start),
            format!("<{tag}>: `{value}` is not a number"),
        )
    })?;
    if !v.is_finite() {
        return Err(OpenSimError::at(
            file,
            doc.text_pos_at(start),
            format!("<{tag}>: `{value}` is not finite"),
        ));
    }
    Ok((v, start..start + value.len()))
}

/// `base` with sol, gm and gl's F0, LOM, LST, α0 and vmax taken from the OpenSim model `text`
/// (module documentation); `file` names it in errors.
///
/// # Errors
/// Invalid XML (line and column), no `<Model>`, a muscle missing or of another type, a value
/// that is not a number (line and column), or values surae rejects (naming the muscle).
pub fn osim_params(
    text: &str,
    file: &str,
    names: &OsimMuscleNames,
    base: &ModelParams,
) -> Result<ModelParams, OpenSimError> {
    let doc = parse(text, file)?;
    let mut out = *base;
    for f in find_muscles(&doc, file, names)? {
        let mp = out.muscle_mut(f.muscle);
        for tag in READ {
            let Some(el) = property(&doc, file, f.node, tag)? else {
                continue;
            };
            let (v, _) = number(&doc, text, file, el)?;
            match tag {
                "max_isometric_force" => mp.fom_n = v,
                "optimal_fiber_length" => mp.lom_m = v,
                "tendon_slack_length" => mp.lst_m = v,
                "pennation_angle_at_optimal" => mp.alpha_deg = v.to_degrees(),
                _ => mp.vmax_lom_per_s = v,
            }
        }
        let single = {
            let mut p = *base;
            *p.muscle_mut(f.muscle) = *mp;
            p
        };
        single.validate().map_err(|e| OpenSimError::Muscle {
            file: file.to_string(),
            muscle: names.get(f.muscle).to_string(),
            message: format!("as surae's {}: {e}", f.muscle.name()),
        })?;
    }
    Ok(out)
}

/// A copy of the OpenSim model `text` with `params`' F0, LST and α0 of sol, gm and gl written
/// into the muscles named by `names`; every other byte unchanged (module documentation).
/// Numbers are written in the shortest form that reads back to the same `f64` (α0 in rad).
///
/// # Errors
/// As [`osim_params`] for the model; a self-closing muscle element that would need a
/// property added.
pub fn write_identified_osim(
    text: &str,
    file: &str,
    names: &OsimMuscleNames,
    params: &ModelParams,
) -> Result<String, OpenSimError> {
    let doc = parse(text, file)?;
    let mut edits: Vec<(std::ops::Range<usize>, String)> = Vec::new();
    for f in find_muscles(&doc, file, names)? {
        let mp = params.muscle(f.muscle);
        let mut appended = String::new();
        for (tag, v) in [
            ("max_isometric_force", mp.fom_n),
            ("tendon_slack_length", mp.lst_m),
            ("pennation_angle_at_optimal", mp.alpha_deg.to_radians()),
        ] {
            match property(&doc, file, f.node, tag)? {
                Some(el) => {
                    let (_, range) = number(&doc, text, file, el)?;
                    edits.push((range, format!("{v}")));
                }
                None => {
                    let indent = f
                        .node
                        .first_child()
                        .filter(|c| c.is_text())
                        .and_then(|c| c.text())
                        .filter(|t| t.trim().is_empty())
                        .unwrap_or("\n");
                    appended.push_str(&format!("{indent}<{tag}>{v}</{tag}>"));
                }
            }
        }
        if !appended.is_empty() {
            let at = match f.node.last_element_child() {
                Some(last) => last.range().end,
                None => {
                    return Err(OpenSimError::at(
                        file,
                        doc.text_pos_at(f.node.range().start),
                        format!(
                            "muscle `{}` has no child elements to add the identified values to",
                            names.get(f.muscle)
                        ),
                    ))
                }
            };
            edits.push((at..at, appended));
        }
    }
    edits.sort_by_key(|(r, _)| r.start);
    let mut out = String::with_capacity(text.len() + 256);
    let mut pos = 0;
    for (range, new) in edits {
        out.push_str(&text[pos..range.start]);
        out.push_str(&new);
        pos = range.end;
    }
    out.push_str(&text[pos..]);
    Ok(out)
}
