//! A small XML well-formedness checker for the SVG this crate writes (and for tests of callers).
//!
//! It checks what a browser's XML parser would reject in an SVG: unbalanced or crossed tags,
//! unquoted or duplicate attributes, a bare `<` or `&` in text or attributes, unknown entity
//! references, text outside the root element. It does not validate against the SVG schema.

use std::collections::BTreeMap;

use crate::error::{ReportError, Result};

/// What a well-formed document holds.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct XmlSummary {
    /// Name of the root element (`svg` for a figure).
    pub root: String,
    /// How many elements of each name.
    pub elements: BTreeMap<String, usize>,
    /// Every non-blank text node, entities decoded, in document order.
    pub texts: Vec<String>,
    /// Attributes of the root element, in order.
    pub root_attributes: Vec<(String, String)>,
}

impl XmlSummary {
    /// Number of elements named `name`.
    pub fn count(&self, name: &str) -> usize {
        self.elements.get(name).copied().unwrap_or(0)
    }

    /// Whether some text node contains `needle`.
    pub fn has_text(&self, needle: &str) -> bool {
        self.texts.iter().any(|t| t.contains(needle))
    }
}

fn bad(pos: usize, what: impl Into<String>) -> ReportError {
    ReportError::Invalid {
        figure: "xml",
        reason: format!("not well-formed at byte {pos}: {}", what.into()),
    }
}

fn is_name_char(c: char) -> bool {
    c.is_alphanumeric() || matches!(c, '_' | '-' | '.' | ':')
}

/// Decodes the entity references of `raw` (text or attribute value starting at byte `pos`).
fn decode(raw: &str, pos: usize) -> Result<String> {
    let mut out = String::with_capacity(raw.len());
    let mut rest = raw;
    while let Some(i) = rest.find(['&', '<']) {
        out.push_str(&rest[..i]);
        if rest[i..].starts_with('<') {
            return Err(bad(pos, "bare `<` in text or attribute"));
        }
        let end = rest[i..]
            .find(';')
            .ok_or_else(|| bad(pos, "`&` without `;`"))?;
        let ent = &rest[i + 1..i + end];
        let ch = match ent {
            "amp" => '&',
            "lt" => '<',
            "gt" => '>',
            "quot" => '"',
            "apos" => '\'',
            _ => {
                let code = if let Some(h) = ent.strip_prefix("#x") {
                    u32::from_str_radix(h, 16).ok()
                } else if let Some(d) = ent.strip_prefix('#') {
                    d.parse::<u32>().ok()
                } else {
                    None
                };
                code.and_then(char::from_u32)
                    .ok_or_else(|| bad(pos, format!("unknown entity `&{ent};`")))?
            }
        };
        out.push(ch);
        rest = &rest[i + end + 1..];
    }
    out.push_str(rest);
    Ok(out)
}

/// Checks that `text` is one well-formed XML element (optionally preceded by an XML
/// declaration, comments and white space) and summarises it.
///
/// ```
/// let s = report::check_xml(r#"<svg xmlns="http://www.w3.org/2000/svg"><text>a &amp; b</text></svg>"#)?;
/// assert_eq!(s.root, "svg");
/// assert_eq!(s.texts, vec!["a & b".to_string()]);
/// assert!(report::check_xml("<svg><g></svg>").is_err());
/// # Ok::<(), report::ReportError>(())
/// ```
pub fn check_xml(text: &str) -> Result<XmlSummary> {
    let mut sum = XmlSummary::default();
    let mut stack: Vec<String> = Vec::new();
    let mut root_done = false;
    let mut i = 0;
    let b = text.as_bytes();
    while i < b.len() {
        if b[i] != b'<' {
            let j = text[i..].find('<').map_or(b.len(), |k| i + k);
            let raw = &text[i..j];
            let decoded = decode(raw, i)?;
            if !decoded.trim().is_empty() {
                if stack.is_empty() {
                    return Err(bad(i, "text outside the root element"));
                }
                sum.texts.push(decoded.trim().to_string());
            }
            i = j;
            continue;
        }
        let rest = &text[i..];
        if rest.starts_with("<!--") {
            let end = rest.find("-->").ok_or_else(|| bad(i, "unclosed comment"))?;
            i += end + 3;
            continue;
        }
        if rest.starts_with("<?") {
            if sum.elements.values().sum::<usize>() > 0 {
                return Err(bad(i, "processing instruction after the root started"));
            }
            let end = rest.find("?>").ok_or_else(|| bad(i, "unclosed `<?`"))?;
            i += end + 2;
            continue;
        }
        if rest.starts_with("<![CDATA[") {
            let end = rest.find("]]>").ok_or_else(|| bad(i, "unclosed CDATA"))?;
            if stack.is_empty() {
                return Err(bad(i, "CDATA outside the root element"));
            }
            let t = rest[9..end].trim();
            if !t.is_empty() {
                sum.texts.push(t.to_string());
            }
            i += end + 3;
            continue;
        }
        if rest.starts_with("<!") {
            return Err(bad(i, "DOCTYPE or other declaration not allowed"));
        }
        if let Some(close) = rest.strip_prefix("</") {
            let end = close.find('>').ok_or_else(|| bad(i, "unclosed end tag"))?;
            let name = close[..end].trim_end();
            match stack.pop() {
                Some(open) if open == name => {}
                Some(open) => {
                    return Err(bad(i, format!("`</{name}>` closes `<{open}>`")));
                }
                None => return Err(bad(i, format!("`</{name}>` without a start tag"))),
            }
            if stack.is_empty() {
                root_done = true;
            }
            i += 2 + end + 1;
            continue;
        }
        // Start tag.
        if root_done {
            return Err(bad(i, "a second root element"));
        }
        let mut chars = rest[1..].char_indices();
        let mut name_end = rest.len() - 1;
        for (k, c) in chars.by_ref() {
            if !is_name_char(c) {
                name_end = k;
                break;
            }
        }
        let name = &rest[1..1 + name_end];
        if name.is_empty() || name.starts_with(|c: char| c.is_ascii_digit() || c == '-') {
            return Err(bad(i, "bad element name"));
        }
        let mut k = 1 + name_end;
        let mut attrs: Vec<(String, String)> = Vec::new();
        let self_closing;
        loop {
            let r = &rest[k..];
            let ws = r.len() - r.trim_start().len();
            k += ws;
            let r = &rest[k..];
            if r.starts_with("/>") {
                self_closing = true;
                k += 2;
                break;
            }
            if r.starts_with('>') {
                self_closing = false;
                k += 1;
                break;
            }
            if r.is_empty() {
                return Err(bad(i, format!("unclosed start tag `<{name}`")));
            }
            if ws == 0 {
                return Err(bad(i + k, "attributes must be separated by white space"));
            }
            let an_len = r.find(|c: char| !is_name_char(c)).unwrap_or(r.len());
            if an_len == 0 {
                return Err(bad(i + k, format!("bad attribute in `<{name}`")));
            }
            let an = &r[..an_len];
            let r2 = r[an_len..].trim_start();
            let r2 = r2
                .strip_prefix('=')
                .ok_or_else(|| bad(i + k, format!("attribute `{an}` without a value")))?
                .trim_start();
            let q = r2
                .chars()
                .next()
                .filter(|c| *c == '"' || *c == '\'')
                .ok_or_else(|| bad(i + k, format!("attribute `{an}` is not quoted")))?;
            let vend = r2[1..]
                .find(q)
                .ok_or_else(|| bad(i + k, format!("attribute `{an}` is not closed")))?;
            let value = decode(&r2[1..1 + vend], i + k)?;
            if attrs.iter().any(|(a, _)| a == an) {
                return Err(bad(i + k, format!("duplicate attribute `{an}`")));
            }
            attrs.push((an.to_string(), value));
            let consumed = r.len() - r2.len() + 1 + vend + 1;
            k += consumed;
        }
        *sum.elements.entry(name.to_string()).or_insert(0) += 1;
        if sum.root.is_empty() {
            sum.root = name.to_string();
            sum.root_attributes = attrs;
        }
        if self_closing {
            if stack.is_empty() {
                root_done = true;
            }
        } else {
            stack.push(name.to_string());
        }
        i += k;
    }
    if let Some(open) = stack.last() {
        return Err(bad(text.len(), format!("`<{open}>` is never closed")));
    }
    if sum.root.is_empty() {
        return Err(bad(0, "no element"));
    }
    Ok(sum)
}

/// Checks a figure: well-formed XML whose root is `<svg>`, that draws something (at least one
/// `path`, `polyline`, `polygon`, `line`, `rect` or `circle` besides the background).
pub fn check_svg(text: &str) -> Result<XmlSummary> {
    let s = check_xml(text)?;
    if s.root != "svg" {
        return Err(ReportError::Invalid {
            figure: "svg",
            reason: format!("root element is `<{}>`, not `<svg>`", s.root),
        });
    }
    let marks: usize = ["path", "polyline", "polygon", "line", "rect", "circle"]
        .iter()
        .map(|n| s.count(n))
        .sum();
    if marks < 2 {
        return Err(ReportError::Invalid {
            figure: "svg",
            reason: "the figure draws nothing".into(),
        });
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn accepts_well_formed() {
        let s = check_xml(
            "<?xml version=\"1.0\"?>\n<!-- c --><svg a=\"1\" b='x &lt; y'><g><rect/><text>&#x3b1; &amp;</text></g></svg>\n",
        )
        .unwrap();
        assert_eq!(s.root, "svg");
        assert_eq!(s.count("rect"), 1);
        assert_eq!(s.texts, vec!["α &".to_string()]);
        assert_eq!(s.root_attributes[1], ("b".into(), "x < y".into()));
    }

    #[test]
    fn rejects_malformed() {
        for bad in [
            "<svg><g></svg>",
            "<svg></g></svg>",
            "<svg>",
            "<svg a=1></svg>",
            "<svg a=\"1\" a=\"2\"></svg>",
            "<svg>a < b</svg>",
            "<svg>a & b</svg>",
            "<svg>&nbsp;</svg>",
            "<svg></svg><svg></svg>",
            "text<svg></svg>",
            "<svg a=\"<\"></svg>",
            "<svg a=\"1\"b=\"2\"></svg>",
            "",
            "<!DOCTYPE x><svg></svg>",
        ] {
            assert!(check_xml(bad).is_err(), "accepted {bad:?}");
        }
    }

    #[test]
    fn svg_must_draw() {
        assert!(check_svg("<svg><rect/></svg>").is_err());
        assert!(check_svg("<html><rect/><rect/></html>").is_err());
        assert!(check_svg("<svg><rect/><path d=\"M0 0\"/></svg>").is_ok());
    }
}
