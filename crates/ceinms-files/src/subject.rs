//! CEINMS subject XML (`subject.xsd`): the muscle-tendon units of a subject's model.
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
//! What the fields mean, from CEINMS's own sources (github.com/CEINMS/CEINMS):
//! * `emDelay` is in seconds: the calibration adds it to the EMG's time stamps
//!   (`lib/OptimizerSystems/ceinms/BatchEvaluator.cpp`), and the manual's example value is
//!   0.015. `subject.xsd` allows an `emDelay` in each `mtu` as well as the one in
//!   `mtuDefault` (the per-muscle one wins when present), but the simulation and calibration
//!   use one global delay, the first muscle's (`NMSmodel::getGlobalEmDelay`, "will be
//!   replaced by singular muscles emdelay").
//! * `pennationAngle` may carry `unit="deg"` or `unit="rad"`; CEINMS's current reader takes
//!   a value without the attribute as radians. Subject files written before the attribute
//!   existed (such as CEINMS's 2015 test subject) hold degrees (25 for the soleus) and the
//!   CEINMS of that time converted them from degrees where it used them. Here a value
//!   without the attribute is read as degrees, which is what every published CEINMS subject
//!   of that period holds; give `unit="rad"` for radians.
//! * The force a muscle can produce is `maxIsometricForce × strengthCoefficient`.
//! * `c1`, `c2` and `shapeFactor` are CEINMS's activation: a second-order recursive filter
//!   of the EMG, `u_k = α e_{k−d} − β1 u_{k−1} − β2 u_{k−2}` with `β1 = c1 + c2`,
//!   `β2 = c1·c2`, `α = 1 + β1 + β2`, then `a = (e^{A u} − 1)/(e^A − 1)` with `A` the shape
//!   factor (`ExponentialActivation.cpp`). They are read and kept as given.

use crate::error::{read_text, CeinmsError};
use std::path::{Path, PathBuf};

/// One `mtu` of a subject XML.
#[derive(Clone, Debug, PartialEq)]
pub struct CeinmsMtu {
    /// Muscle name (e.g. `sol_r`).
    pub name: String,
    /// The muscle's own electromechanical delay (s), if the file gives one.
    pub em_delay_s: Option<f64>,
    /// Activation filter coefficient `c1`.
    pub c1: f64,
    /// Activation filter coefficient `c2`.
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

/// A CEINMS subject: the default electromechanical delay and the muscle-tendon units.
#[derive(Clone, Debug, PartialEq)]
pub struct CeinmsSubject {
    /// The file it was read from.
    pub path: PathBuf,
    /// `mtuDefault/emDelay` (s).
    pub em_delay_s: f64,
    /// The units in file order.
    pub mtus: Vec<CeinmsMtu>,
}

impl CeinmsSubject {
    /// The unit called `name`.
    pub fn mtu(&self, name: &str) -> Option<&CeinmsMtu> {
        self.mtus.iter().find(|m| m.name == name)
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

    fn mtu(&self, node: roxmltree::Node<'a, 'i>) -> Result<CeinmsMtu, CeinmsError> {
        let name_node = self.required(node, "name", "mtu")?;
        let name = self.text(name_node, "mtu/name")?.to_string();
        let owner = format!("mtu {name}");
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
            c1: num("c1")?,
            c2: num("c2")?,
            shape_factor: num("shapeFactor")?,
            optimal_fibre_length_m: num("optimalFibreLength")?,
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
}

/// Parses the text of a CEINMS subject XML; `path` names it in errors.
///
/// # Errors
/// [`CeinmsError::Xml`] with the line and column of the XML syntax error, of the element that
/// is missing a child, or of a value that is not a finite number; a muscle given twice.
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
    let default = r.required(root, "mtuDefault", "subject")?;
    let em_delay_s = r.required_number(default, "emDelay", "mtuDefault")?;
    let set = r.required(root, "mtuSet", "subject")?;
    let mut mtus: Vec<CeinmsMtu> = Vec::new();
    for node in set
        .children()
        .filter(|c| c.is_element() && c.tag_name().name() == "mtu")
    {
        let m = r.mtu(node)?;
        if mtus.iter().any(|o| o.name == m.name) {
            return Err(r.err(node, &format!("mtu {}", m.name), "muscle given twice"));
        }
        mtus.push(m);
    }
    if mtus.is_empty() {
        return Err(r.err(set, "subject/mtuSet", "no `mtu` in the set"));
    }
    Ok(CeinmsSubject {
        path: path.to_path_buf(),
        em_delay_s,
        mtus,
    })
}

/// Reads a CEINMS subject XML.
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
}
