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
    let mut reader = Reader {
        text,
        sum: XmlSummary::default(),
        stack: Vec::new(),
        root_done: false,
    };
    let mut i = 0;
    while i < text.len() {
        i = reader.read_at(i)?;
    }
    reader.finish()
}

/// A document being read: what it holds so far and where the reading stands.
struct Reader<'t> {
    text: &'t str,
    sum: XmlSummary,
    /// The open elements, innermost last.
    stack: Vec<String>,
    /// Whether the root element has ended (a second one is an error).
    root_done: bool,
}

/// A start tag read: its attributes, whether it closes itself (`/>`) and its length in bytes.
struct StartTag {
    attrs: Vec<(String, String)>,
    self_closing: bool,
    len: usize,
}

impl Reader<'_> {
    /// Reads the text node, comment, declaration, CDATA section or tag at byte `i`; returns the
    /// byte after it.
    fn read_at(&mut self, i: usize) -> Result<usize> {
        let rest = &self.text[i..];
        if !rest.starts_with('<') {
            return self.text_node(i);
        }
        if rest.starts_with("<!--") {
            let end = rest.find("-->").ok_or_else(|| bad(i, "unclosed comment"))?;
            return Ok(i + end + 3);
        }
        if rest.starts_with("<?") {
            if self.sum.elements.values().sum::<usize>() > 0 {
                return Err(bad(i, "processing instruction after the root started"));
            }
            let end = rest.find("?>").ok_or_else(|| bad(i, "unclosed `<?`"))?;
            return Ok(i + end + 2);
        }
        if rest.starts_with("<![CDATA[") {
            return self.cdata(i);
        }
        if rest.starts_with("<!") {
            return Err(bad(i, "DOCTYPE or other declaration not allowed"));
        }
        if rest.starts_with("</") {
            return self.end_tag(i);
        }
        self.start_tag(i)
    }

    /// Text up to the next `<`: kept (trimmed, entities decoded) unless blank, and only inside
    /// the root element.
    fn text_node(&mut self, i: usize) -> Result<usize> {
        let j = self.text[i..].find('<').map_or(self.text.len(), |k| i + k);
        let decoded = decode(&self.text[i..j], i)?;
        if !decoded.trim().is_empty() {
            if self.stack.is_empty() {
                return Err(bad(i, "text outside the root element"));
            }
            self.sum.texts.push(decoded.trim().to_string());
        }
        Ok(j)
    }

    /// A CDATA section: its text kept as is (trimmed, unless blank), inside the root element.
    fn cdata(&mut self, i: usize) -> Result<usize> {
        let rest = &self.text[i..];
        let end = rest.find("]]>").ok_or_else(|| bad(i, "unclosed CDATA"))?;
        if self.stack.is_empty() {
            return Err(bad(i, "CDATA outside the root element"));
        }
        let t = rest[9..end].trim();
        if !t.is_empty() {
            self.sum.texts.push(t.to_string());
        }
        Ok(i + end + 3)
    }

    /// An end tag, which must close the innermost open element.
    fn end_tag(&mut self, i: usize) -> Result<usize> {
        let close = &self.text[i + 2..];
        let end = close.find('>').ok_or_else(|| bad(i, "unclosed end tag"))?;
        let name = close[..end].trim_end();
        match self.stack.pop() {
            Some(open) if open == name => {}
            Some(open) => {
                return Err(bad(i, format!("`</{name}>` closes `<{open}>`")));
            }
            None => return Err(bad(i, format!("`</{name}>` without a start tag"))),
        }
        if self.stack.is_empty() {
            self.root_done = true;
        }
        Ok(i + 2 + end + 1)
    }

    /// A start tag (or a self-closing element): counted, opened, and taken as the root when it
    /// is the first.
    fn start_tag(&mut self, i: usize) -> Result<usize> {
        if self.root_done {
            return Err(bad(i, "a second root element"));
        }
        let rest = &self.text[i..];
        let name = element_name(rest, i)?;
        let tag = attributes(rest, 1 + name.len(), i, name)?;
        *self.sum.elements.entry(name.to_string()).or_insert(0) += 1;
        if self.sum.root.is_empty() {
            self.sum.root = name.to_string();
            self.sum.root_attributes = tag.attrs;
        }
        if tag.self_closing {
            if self.stack.is_empty() {
                self.root_done = true;
            }
        } else {
            self.stack.push(name.to_string());
        }
        Ok(i + tag.len)
    }

    /// The summary, once every element is closed and there was one.
    fn finish(self) -> Result<XmlSummary> {
        if let Some(open) = self.stack.last() {
            return Err(bad(self.text.len(), format!("`<{open}>` is never closed")));
        }
        if self.sum.root.is_empty() {
            return Err(bad(0, "no element"));
        }
        Ok(self.sum)
    }
}

/// The element name after the `<` that starts `tag` (at byte `pos`).
fn element_name(tag: &str, pos: usize) -> Result<&str> {
    let mut name_end = tag.len() - 1;
    for (k, c) in tag[1..].char_indices() {
        if !is_name_char(c) {
            name_end = k;
            break;
        }
    }
    let name = &tag[1..1 + name_end];
    if name.is_empty() || name.starts_with(|c: char| c.is_ascii_digit() || c == '-') {
        return Err(bad(pos, "bad element name"));
    }
    Ok(name)
}

/// The attributes of start tag `tag` (at byte `pos`, element `name`) from byte `k`, up to and
/// including its `>` or `/>`.
fn attributes(tag: &str, mut k: usize, pos: usize, name: &str) -> Result<StartTag> {
    let mut attrs: Vec<(String, String)> = Vec::new();
    loop {
        let r = &tag[k..];
        let ws = r.len() - r.trim_start().len();
        k += ws;
        let r = &tag[k..];
        if r.starts_with("/>") {
            return Ok(StartTag {
                attrs,
                self_closing: true,
                len: k + 2,
            });
        }
        if r.starts_with('>') {
            return Ok(StartTag {
                attrs,
                self_closing: false,
                len: k + 1,
            });
        }
        if r.is_empty() {
            return Err(bad(pos, format!("unclosed start tag `<{name}`")));
        }
        if ws == 0 {
            return Err(bad(pos + k, "attributes must be separated by white space"));
        }
        let (an, value, consumed) = attribute(r, pos + k, name)?;
        if attrs.iter().any(|(a, _)| a == an) {
            return Err(bad(pos + k, format!("duplicate attribute `{an}`")));
        }
        attrs.push((an.to_string(), value));
        k += consumed;
    }
}

/// The attribute `name="value"` (or single-quoted) that starts `r` (at byte `pos`, in element
/// `element`): its name, its value with entities decoded, and the bytes it takes.
fn attribute<'r>(r: &'r str, pos: usize, element: &str) -> Result<(&'r str, String, usize)> {
    let an_len = r.find(|c: char| !is_name_char(c)).unwrap_or(r.len());
    if an_len == 0 {
        return Err(bad(pos, format!("bad attribute in `<{element}`")));
    }
    let an = &r[..an_len];
    let r2 = r[an_len..].trim_start();
    let r2 = r2
        .strip_prefix('=')
        .ok_or_else(|| bad(pos, format!("attribute `{an}` without a value")))?
        .trim_start();
    let q = r2
        .chars()
        .next()
        .filter(|c| *c == '"' || *c == '\'')
        .ok_or_else(|| bad(pos, format!("attribute `{an}` is not quoted")))?;
    let vend = r2[1..]
        .find(q)
        .ok_or_else(|| bad(pos, format!("attribute `{an}` is not closed")))?;
    let value = decode(&r2[1..1 + vend], pos)?;
    // up to the value's opening quote, the value, its closing quote
    let consumed = r.len() - r2.len() + 1 + vend + 1;
    Ok((an, value, consumed))
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
