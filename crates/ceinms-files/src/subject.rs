//! Subject XML: the muscle-tendon units of a subject's model, in either of two formats, read
//! into the same [`CeinmsSubject`].
//!
//! **CEINMS** (`subject.xsd`):
//!
//! ```xml
//! <subject>
//!   <mtuDefault><emDelay>0.015</emDelay><percentageChange>0.15</percentageChange>…</mtuDefault>
//!   <mtuSet>
//!     <mtu><name>sol_r</name><c1>…</c1><c2>…</c2><shapeFactor>…</shapeFactor>
//!          <optimalFibreLength>0.05</optimalFibreLength><pennationAngle>25</pennationAngle>
//!          <tendonSlackLength>0.25</tendonSlackLength><maxIsometricForce>3549</maxIsometricForce>
//!          <strengthCoefficient>1</strengthCoefficient></mtu>
//!   </mtuSet>
//! </subject>
//! ```
//!
//! **CEINMS-RT** (`NMSmodel.xsd`, the maintained successor), with gait2392's muscle names:
//!
//! ```xml
//! <subject>
//!   <muscleDefault><percentageChange>0.15</percentageChange><damping>0.5</damping>
//!     <Curve>…</Curve></muscleDefault>
//!   <muscles>
//!     <muscle><name>soleus_r</name><C1>-0.5</C1><C2>-0.5</C2><shapeFactor>…</shapeFactor>
//!       <optimalFiberLength>0.051</optimalFiberLength><pennationAngle>25</pennationAngle>
//!       <tendonSlackLength>0.2465</tendonSlackLength><maxIsometricForce>3549</maxIsometricForce>
//!       <strengthCoefficient>0.5</strengthCoefficient></muscle>
//!   </muscles>
//!   <DoFs>…</DoFs><Channels>…</Channels>
//! </subject>
//! ```
//!
//! The root's children say which format a file is (`mtuDefault`/`mtuSet` or
//! `muscleDefault`/`muscles`). In both, every muscle needs `name`, the two activation
//! coefficients, `shapeFactor`, the optimal fibre length, `pennationAngle`,
//! `tendonSlackLength`, `maxIsometricForce` and `strengthCoefficient`; `emDelay` and
//! `maxContractionVelocity` are read when given. CEINMS-RT's `muscleDefault` (curves, damping),
//! `DoFs` and `Channels` are not read: surae's model has its own curves, and the muscles it
//! drives are named by the session.
//!
//! What the fields mean, from CEINMS's own sources (github.com/CEINMS/CEINMS):
//! * `emDelay` is in seconds: the calibration adds it to the EMG's time stamps
//!   (`lib/OptimizerSystems/ceinms/BatchEvaluator.cpp`), and the manual's example value is
//!   0.015. `subject.xsd` allows an `emDelay` in each `mtu` as well as the one in
//!   `mtuDefault` (the per-muscle one wins when present), but the simulation and calibration
//!   use one global delay, the first muscle's (`NMSmodel::getGlobalEmDelay`, "will be
//!   replaced by singular muscles emdelay"). CEINMS requires the default one; a CEINMS-RT
//!   subject need not give any (then the delay read is 0).
//! * `pennationAngle` may carry `unit="deg"` or `unit="rad"`; CEINMS's current reader takes
//!   a value without the attribute as radians. Subject files written before the attribute
//!   existed (such as CEINMS's 2015 test subject) hold degrees (25 for the soleus) and the
//!   CEINMS of that time converted them from degrees where it used them; CEINMS-RT's subjects
//!   hold degrees too (24.9999998282 for gait2392's soleus, whose `.osim` value is 0.4363 rad).
//!   Here a value without the attribute is read as degrees; give `unit="rad"` for radians.
//! * The force a muscle can produce is `maxIsometricForce × strengthCoefficient`.
//! * `c1`, `c2` (CEINMS-RT: `C1`, `C2`) and `shapeFactor` are CEINMS's activation: a
//!   second-order recursive filter of the EMG, `u_k = α e_{k−d} − β1 u_{k−1} − β2 u_{k−2}`
//!   with `β1 = c1 + c2`, `β2 = c1·c2`, `α = 1 + β1 + β2`, then `a = (e^{A u} − 1)/(e^A − 1)`
//!   with `A` the shape factor (`ExponentialActivation.cpp`). They are read and kept as given.
//!
//! **Names.** CEINMS's test subject names the muscles after its own model (`sol_r`,
//! `gasmed_r`, `gaslat_r`, `tibant_r`), CEINMS-RT's after gait2392 (`soleus_r`, `med_gas_r`,
//! `lat_gas_r`, `tib_ant_r`). [`CeinmsSubject::mtu`] finds these four muscles of either leg
//! under either name, so that a caller asking for `sol_r` gets a CEINMS-RT subject's
//! `soleus_r`; each muscle keeps the name its file gives it.

use crate::error::{read_text, CeinmsError};
use std::path::{Path, PathBuf};

/// One muscle-tendon unit of a subject XML (CEINMS's `mtu`, CEINMS-RT's `muscle`).
#[derive(Clone, Debug, PartialEq)]
pub struct CeinmsMtu {
    /// Muscle name as the file gives it (e.g. `sol_r`, `soleus_r`).
    pub name: String,
    /// The muscle's own electromechanical delay (s), if the file gives one.
    pub em_delay_s: Option<f64>,
    /// Activation filter coefficient `c1` (CEINMS-RT's `C1`).
    pub c1: f64,
    /// Activation filter coefficient `c2` (CEINMS-RT's `C2`).
    pub c2: f64,
    /// Activation shape factor `A`.
    pub shape_factor: f64,
    /// Optimal fibre length (m).
    pub optimal_fibre_length_m: f64,
    /// Pennation angle at optimal fibre length (degrees).
    pub pennation_deg: f64,
    /// Tendon slack length (m).
    pub tendon_slack_length_m: f64,
    /// Maximum isometric force before the strength coefficient (N).
    pub max_isometric_force_n: f64,
    /// Strength coefficient (scales the maximum isometric force).
    pub strength_coefficient: f64,
    /// Maximum contraction velocity, if given (as written; CEINMS's unit is optimal fibre
    /// lengths per second).
    pub max_contraction_velocity: Option<f64>,
}

impl CeinmsMtu {
    /// The force the muscle can produce: `maxIsometricForce × strengthCoefficient` (N).
    pub fn max_force_n(&self) -> f64 {
        self.max_isometric_force_n * self.strength_coefficient
    }
}

/// Which format a subject XML was written in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SubjectFormat {
    /// CEINMS's `subject.xsd`: `mtuDefault`, `mtuSet/mtu`.
    Ceinms,
    /// CEINMS-RT's `NMSmodel.xsd`: `muscleDefault`, `muscles/muscle`.
    CeinmsRt,
}

/// A CEINMS or CEINMS-RT subject: the default electromechanical delay and the muscle-tendon
/// units.
#[derive(Clone, Debug, PartialEq)]
pub struct CeinmsSubject {
    /// The file it was read from.
    pub path: PathBuf,
    /// The format the file is in.
    pub format: SubjectFormat,
    /// The default delay (s): CEINMS's `mtuDefault/emDelay`; CEINMS-RT's
    /// `muscleDefault/emDelay`, or 0 when the file gives none.
    pub em_delay_s: f64,
    /// The units in file order.
    pub mtus: Vec<CeinmsMtu>,
}

/// The muscles CEINMS's test subject and gait2392 (CEINMS-RT) name differently, without the
/// side: `(CEINMS, gait2392)`.
const OTHER_NAMES: [(&str, &str); 4] = [
    ("sol", "soleus"),
    ("gasmed", "med_gas"),
    ("gaslat", "lat_gas"),
    ("tibant", "tib_ant"),
];

/// The other format's name of muscle `name` (`sol_r` ↔ `soleus_r`), if it has one.
fn other_name(name: &str) -> Option<String> {
    let (stem, side) = name
        .strip_suffix("_r")
        .map(|s| (s, "_r"))
        .or_else(|| name.strip_suffix("_l").map(|s| (s, "_l")))?;
    OTHER_NAMES.iter().find_map(|&(ceinms, gait2392)| {
        if stem == ceinms {
            Some(format!("{gait2392}{side}"))
        } else if stem == gait2392 {
            Some(format!("{ceinms}{side}"))
        } else {
            None
        }
    })
}

impl CeinmsSubject {
    /// The unit called `name`, or, for the soleus, gastrocnemii and tibialis anterior, the
    /// unit the other format's name gives (`sol_r` finds `soleus_r`; module documentation).
    pub fn mtu(&self, name: &str) -> Option<&CeinmsMtu> {
        self.mtus.iter().find(|m| m.name == name).or_else(|| {
            let other = other_name(name)?;
            self.mtus.iter().find(|m| m.name == other)
        })
    }

    /// The delay CEINMS applies to every muscle: the first unit's own delay, else the
    /// default (s).
    pub fn global_em_delay_s(&self) -> f64 {
        self.mtus
            .first()
            .and_then(|m| m.em_delay_s)
            .unwrap_or(self.em_delay_s)
    }
}

/// The element names that differ between the two formats.
struct Names {
    /// The set of units under the root (`mtuSet`, `muscles`).
    set: &'static str,
    /// One unit (`mtu`, `muscle`).
    unit: &'static str,
    c1: &'static str,
    c2: &'static str,
    optimal_fibre_length: &'static str,
}

const CEINMS_NAMES: Names = Names {
    set: "mtuSet",
    unit: "mtu",
    c1: "c1",
    c2: "c2",
    optimal_fibre_length: "optimalFibreLength",
};

const CEINMS_RT_NAMES: Names = Names {
    set: "muscles",
    unit: "muscle",
    c1: "C1",
    c2: "C2",
    optimal_fibre_length: "optimalFiberLength",
};

struct Reader<'a, 'i> {
    doc: &'a roxmltree::Document<'i>,
    path: &'a Path,
}

impl<'a, 'i> Reader<'a, 'i> {
    fn err(&self, node: roxmltree::Node, key: &str, reason: impl Into<String>) -> CeinmsError {
        let pos = self.doc.text_pos_at(node.range().start);
        CeinmsError::Xml {
            path: self.path.to_path_buf(),
            line: pos.row,
            column: pos.col,
            key: key.to_string(),
            reason: reason.into(),
        }
    }

    fn child(
        &self,
        node: roxmltree::Node<'a, 'i>,
        name: &str,
        key: &str,
    ) -> Result<Option<roxmltree::Node<'a, 'i>>, CeinmsError> {
        let mut found = node
            .children()
            .filter(|c| c.is_element() && c.tag_name().name() == name);
        let first = found.next();
        if let Some(second) = found.next() {
            return Err(self.err(second, key, format!("`{name}` given twice")));
        }
        Ok(first)
    }

    fn text(&self, node: roxmltree::Node<'a, 'i>, key: &str) -> Result<&'a str, CeinmsError> {
        match node.text().map(str::trim) {
            Some(t) if !t.is_empty() => Ok(t),
            _ => Err(self.err(node, key, "empty")),
        }
    }

    fn number(&self, node: roxmltree::Node<'a, 'i>, key: &str) -> Result<f64, CeinmsError> {
        let t = self.text(node, key)?;
        match t.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => Err(self.err(node, key, format!("`{t}` is not finite"))),
            Err(_) => Err(self.err(node, key, format!("`{t}` is not a number"))),
        }
    }

    fn required(
        &self,
        node: roxmltree::Node<'a, 'i>,
        name: &str,
        key: &str,
    ) -> Result<roxmltree::Node<'a, 'i>, CeinmsError> {
        self.child(node, name, key)?
            .ok_or_else(|| self.err(node, key, format!("missing `{name}`")))
    }

    fn required_number(
        &self,
        node: roxmltree::Node<'a, 'i>,
        name: &str,
        owner: &str,
    ) -> Result<f64, CeinmsError> {
        let key = format!("{owner}/{name}");
        let c = self.required(node, name, owner)?;
        self.number(c, &key)
    }

    fn optional_number(
        &self,
        node: roxmltree::Node<'a, 'i>,
        name: &str,
        owner: &str,
    ) -> Result<Option<f64>, CeinmsError> {
        let key = format!("{owner}/{name}");
        self.child(node, name, &key)?
            .map(|c| self.number(c, &key))
            .transpose()
    }

    /// One unit (`mtu` or `muscle`) under the element names `n`.
    fn mtu(&self, node: roxmltree::Node<'a, 'i>, n: &Names) -> Result<CeinmsMtu, CeinmsError> {
        let name_node = self.required(node, "name", n.unit)?;
        let name = self
            .text(name_node, &format!("{}/name", n.unit))?
            .to_string();
        let owner = format!("{} {name}", n.unit);
        let num = |field: &str| self.required_number(node, field, &owner);
        let pen_key = format!("{owner}/pennationAngle");
        let pen_node = self.required(node, "pennationAngle", &owner)?;
        let pen = self.number(pen_node, &pen_key)?;
        let pennation_deg = match pen_node.attribute("unit") {
            None | Some("deg") => pen,
            Some("rad") => pen.to_degrees(),
            Some(u) => {
                return Err(self.err(
                    pen_node,
                    &pen_key,
                    format!("unit `{u}` is neither `deg` nor `rad`"),
                ))
            }
        };
        Ok(CeinmsMtu {
            em_delay_s: self.optional_number(node, "emDelay", &owner)?,
            c1: num(n.c1)?,
            c2: num(n.c2)?,
            shape_factor: num("shapeFactor")?,
            optimal_fibre_length_m: num(n.optimal_fibre_length)?,
            pennation_deg,
            tendon_slack_length_m: num("tendonSlackLength")?,
            max_isometric_force_n: num("maxIsometricForce")?,
            strength_coefficient: num("strengthCoefficient")?,
            max_contraction_velocity: self.optional_number(
                node,
                "maxContractionVelocity",
                &owner,
            )?,
            name,
        })
    }

    /// Every unit of the set `set` (a muscle given twice, or none, is an error).
    fn mtus(&self, set: roxmltree::Node<'a, 'i>, n: &Names) -> Result<Vec<CeinmsMtu>, CeinmsError> {
        let mut mtus: Vec<CeinmsMtu> = Vec::new();
        for node in set
            .children()
            .filter(|c| c.is_element() && c.tag_name().name() == n.unit)
        {
            let m = self.mtu(node, n)?;
            if mtus.iter().any(|o| o.name == m.name) {
                return Err(self.err(
                    node,
                    &format!("{} {}", n.unit, m.name),
                    "muscle given twice",
                ));
            }
            mtus.push(m);
        }
        if mtus.is_empty() {
            return Err(self.err(
                set,
                &format!("subject/{}", n.set),
                format!("no `{}` in the set", n.unit),
            ));
        }
        Ok(mtus)
    }
}

/// Parses the text of a CEINMS or CEINMS-RT subject XML; `path` names it in errors.
///
/// # Errors
/// [`CeinmsError::Xml`] with the line and column of the XML syntax error, of the element that
/// is missing a child, or of a value that is not a finite number; a muscle given twice; a root
/// that holds neither format's muscle set.
pub fn parse_subject(text: &str, path: &Path) -> Result<CeinmsSubject, CeinmsError> {
    let doc = roxmltree::Document::parse(text).map_err(|e| {
        let pos = e.pos();
        CeinmsError::Xml {
            path: path.to_path_buf(),
            line: pos.row,
            column: pos.col,
            key: "xml".to_string(),
            reason: e.to_string(),
        }
    })?;
    let r = Reader { doc: &doc, path };
    let root = doc.root_element();
    if root.tag_name().name() != "subject" {
        return Err(r.err(
            root,
            "subject",
            format!(
                "the root element is `{}`, a CEINMS subject file's is `subject`",
                root.tag_name().name()
            ),
        ));
    }
    let has = |name: &str| {
        root.children()
            .any(|c| c.is_element() && c.tag_name().name() == name)
    };
    let (format, em_delay_s, set, names) = if has("mtuDefault") || has("mtuSet") {
        let default = r.required(root, "mtuDefault", "subject")?;
        let em_delay_s = r.required_number(default, "emDelay", "mtuDefault")?;
        let set = r.required(root, "mtuSet", "subject")?;
        (SubjectFormat::Ceinms, em_delay_s, set, &CEINMS_NAMES)
    } else if has("muscleDefault") || has("muscles") {
        // a CEINMS-RT subject need not give a delay; one given in muscleDefault is read
        let em_delay_s = match r.child(root, "muscleDefault", "subject")? {
            Some(d) => r.optional_number(d, "emDelay", "muscleDefault")?,
            None => None,
        };
        let set = r.required(root, "muscles", "subject")?;
        (
            SubjectFormat::CeinmsRt,
            em_delay_s.unwrap_or(0.0),
            set,
            &CEINMS_RT_NAMES,
        )
    } else {
        return Err(r.err(
            root,
            "subject",
            "neither CEINMS's `mtuDefault` and `mtuSet` nor CEINMS-RT's `muscleDefault` and \
             `muscles`: not a subject file of either",
        ));
    };
    let mtus = r.mtus(set, names)?;
    Ok(CeinmsSubject {
        path: path.to_path_buf(),
        format,
        em_delay_s,
        mtus,
    })
}

/// Reads a CEINMS or CEINMS-RT subject XML.
///
/// # Errors
/// [`CeinmsError::File`] when the file cannot be read; otherwise as [`parse_subject`].
pub fn read_subject(path: &Path) -> Result<CeinmsSubject, CeinmsError> {
    parse_subject(&read_text(path)?, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mtu(name: &str, extra: &str, pen: &str) -> String {
        format!(
            "<mtu><name>{name}</name>{extra}<c1>-0.5</c1><c2>-0.4</c2>\
             <shapeFactor>-1.5</shapeFactor><optimalFibreLength>0.05</optimalFibreLength>\
             {pen}<tendonSlackLength>0.26</tendonSlackLength>\
             <maxIsometricForce>3000</maxIsometricForce>\
             <strengthCoefficient>1.5</strengthCoefficient></mtu>"
        )
    }

    fn subject(mtus: &str) -> String {
        format!(
            "<?xml version=\"1.0\"?>\n<subject>\n  <mtuDefault><emDelay>0.02</emDelay>\
             <percentageChange>0.15</percentageChange><damping>0.1</damping></mtuDefault>\n\
             <mtuSet>{mtus}</mtuSet>\n</subject>\n"
        )
    }

    fn parse(text: &str) -> Result<CeinmsSubject, CeinmsError> {
        parse_subject(text, Path::new("s.xml"))
    }

    #[test]
    fn reads_units_delay_and_force() {
        let text = subject(&format!(
            "{}{}",
            mtu("sol_r", "", "<pennationAngle>25</pennationAngle>"),
            mtu(
                "tibant_r",
                "<emDelay>0.03</emDelay>",
                "<pennationAngle unit=\"rad\">0.1</pennationAngle>"
            )
        ));
        let s = parse(&text).unwrap();
        assert_eq!(s.em_delay_s, 0.02);
        assert_eq!(s.global_em_delay_s(), 0.02);
        let sol = s.mtu("sol_r").unwrap();
        assert_eq!(sol.pennation_deg, 25.0);
        assert_eq!((sol.c1, sol.c2, sol.shape_factor), (-0.5, -0.4, -1.5));
        assert_eq!(sol.max_force_n(), 4500.0);
        assert_eq!(sol.em_delay_s, None);
        let ta = s.mtu("tibant_r").unwrap();
        assert!((ta.pennation_deg - 0.1f64.to_degrees()).abs() < 1e-12);
        assert_eq!(ta.em_delay_s, Some(0.03));
        assert!(s.mtu("gasmed_r").is_none());
    }

    #[test]
    fn bad_input_names_line_column_and_key() {
        let pen = "<pennationAngle>25</pennationAngle>";
        let e = parse(&subject(&mtu(
            "sol_r",
            "",
            "<pennationAngle>x</pennationAngle>",
        )))
        .unwrap_err();
        assert!(
            e.to_string().starts_with("s.xml:4:")
                && e.to_string()
                    .contains("(mtu sol_r/pennationAngle): `x` is not a number"),
            "{e}"
        );
        let no_lst = subject(&mtu("sol_r", "", pen))
            .replace("<tendonSlackLength>0.26</tendonSlackLength>", "");
        let e = parse(&no_lst).unwrap_err();
        assert!(
            e.to_string()
                .contains("(mtu sol_r): missing `tendonSlackLength`"),
            "{e}"
        );
        let twice = subject(&format!(
            "{}{}",
            mtu("sol_r", "", pen),
            mtu("sol_r", "", pen)
        ));
        let e = parse(&twice).unwrap_err();
        assert!(
            e.to_string().contains("(mtu sol_r): muscle given twice"),
            "{e}"
        );
        let grad = subject(&mtu(
            "sol_r",
            "",
            "<pennationAngle unit=\"grad\">1</pennationAngle>",
        ));
        assert!(parse(&grad)
            .unwrap_err()
            .to_string()
            .contains("unit `grad`"));
        let e = parse("<subject><mtuDefault></subject>").unwrap_err();
        assert_eq!((e.line(), e.path()), (Some(1), Path::new("s.xml")));
        assert!(e.to_string().contains("(xml)"), "{e}");
        let e = parse("<model/>").unwrap_err();
        assert!(e.to_string().contains("the root element is `model`"), "{e}");
        let e = parse(&subject("")).unwrap_err();
        assert!(e.to_string().contains("no `mtu` in the set"), "{e}");
        let no_delay = subject(&mtu("sol_r", "", pen)).replace("<emDelay>0.02</emDelay>", "");
        let e = parse(&no_delay).unwrap_err();
        assert!(
            e.to_string().contains("(mtuDefault): missing `emDelay`"),
            "{e}"
        );
        let inf = subject(&mtu("sol_r", "", pen)).replace("<c1>-0.5</c1>", "<c1>inf</c1>");
        assert!(parse(&inf)
            .unwrap_err()
            .to_string()
            .contains("`inf` is not finite"));
    }

    fn rt_muscle(name: &str, extra: &str) -> String {
        format!(
            "<muscle>\n<name>{name}</name>{extra}<C1>-0.5</C1><C2>-0.4</C2>\
             <shapeFactor>-0.008</shapeFactor><optimalFiberLength>0.0512</optimalFiberLength>\
             <pennationAngle>24.9999998282</pennationAngle>\
             <tendonSlackLength>0.2465</tendonSlackLength>\
             <maxIsometricForce>3549</maxIsometricForce>\
             <strengthCoefficient>0.5</strengthCoefficient></muscle>\n"
        )
    }

    fn rt_subject(muscles: &str) -> String {
        format!(
            "\u{feff}<!-- a comment before the root -->\n<subject>\n  <muscleDefault>\
             <percentageChange>0.15</percentageChange><damping>0.5</damping>\
             <Curve><name>forceVelocity</name><xPoints>0 1</xPoints><yPoints>0 1</yPoints>\
             </Curve></muscleDefault>\n  <muscles>\n{muscles}  </muscles>\n  <DoFs><DoF>\
             <name>ankle_angle_r</name><muscleSequence>soleus_r</muscleSequence></DoF></DoFs>\n\
             </subject>\n"
        )
    }

    #[test]
    fn reads_a_ceinms_rt_subject_into_the_same_types() {
        let s = parse(&rt_subject(&format!(
            "{}{}",
            rt_muscle("soleus_r", ""),
            rt_muscle("tib_ant_r", "<emDelay>0.02</emDelay>")
        )))
        .unwrap();
        assert_eq!(s.format, SubjectFormat::CeinmsRt);
        assert_eq!(s.em_delay_s, 0.0);
        let sol = s.mtu("soleus_r").unwrap();
        assert_eq!((sol.c1, sol.c2, sol.shape_factor), (-0.5, -0.4, -0.008));
        assert_eq!(sol.optimal_fibre_length_m, 0.0512);
        assert_eq!(sol.pennation_deg, 24.9999998282);
        assert_eq!(sol.tendon_slack_length_m, 0.2465);
        assert_eq!(sol.max_force_n(), 3549.0 * 0.5);
        // CEINMS's names find gait2392's muscles, and the other way round
        assert_eq!(s.mtu("sol_r").map(|m| m.name.as_str()), Some("soleus_r"));
        assert_eq!(s.mtu("tibant_r").unwrap().em_delay_s, Some(0.02));
        assert!(s.mtu("gasmed_r").is_none());
        let c = parse(&subject(&mtu(
            "gasmed_r",
            "",
            "<pennationAngle>17</pennationAngle>",
        )))
        .unwrap();
        assert_eq!(c.format, SubjectFormat::Ceinms);
        assert_eq!(
            c.mtu("med_gas_r").map(|m| m.name.as_str()),
            Some("gasmed_r")
        );
        assert!(c.mtu("med_gas_l").is_none());
        // a delay in muscleDefault is read
        let with_delay = rt_subject(&rt_muscle("soleus_r", ""))
            .replace("<damping>", "<emDelay>0.04</emDelay><damping>");
        assert_eq!(parse(&with_delay).unwrap().em_delay_s, 0.04);
    }

    #[test]
    fn bad_ceinms_rt_input_names_line_column_and_key() {
        let no_lst = rt_subject(&format!(
            "{}{}",
            rt_muscle("tib_ant_r", ""),
            rt_muscle("soleus_r", "")
        ))
        .replacen("<tendonSlackLength>0.2465</tendonSlackLength>", "", 2);
        let e = parse(&no_lst).unwrap_err();
        // the first muscle's <muscle> element is on line 5 (a comment line, <subject>,
        // muscleDefault, <muscles>)
        assert_eq!(
            e.to_string(),
            "s.xml:5:1 (muscle tib_ant_r): missing `tendonSlackLength`"
        );
        let lower_case = rt_subject(&rt_muscle("soleus_r", "")).replace("C1>", "c1>");
        assert!(
            parse(&lower_case)
                .unwrap_err()
                .to_string()
                .contains("(muscle soleus_r): missing `C1`"),
            "CEINMS-RT's coefficients are C1, C2"
        );
        let bad = rt_subject(&rt_muscle("soleus_r", "")).replace(">0.5<", ">half<");
        let e = parse(&bad).unwrap_err();
        assert!(
            e.to_string()
                .contains("(muscle soleus_r/strengthCoefficient): `half` is not a number"),
            "{e}"
        );
        let e = parse(&rt_subject("")).unwrap_err();
        assert!(e.to_string().contains("no `muscle` in the set"), "{e}");
        let no_set = "<subject><muscleDefault/></subject>";
        let e = parse(no_set).unwrap_err();
        assert!(
            e.to_string().contains("(subject): missing `muscles`"),
            "{e}"
        );
        let e = parse("<subject><other/></subject>").unwrap_err();
        assert!(e.to_string().contains("neither CEINMS's"), "{e}");
        assert!(!e.to_string().contains('\n'));
    }
}
