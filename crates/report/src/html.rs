//! A self-contained HTML report: headings, paragraphs, tables and inline SVG figures.
//!
//! The page has no external reference at all (no URL, font, script or style sheet): the CSS
//! is a `<style>` block and every figure's SVG markup is inlined. Text is HTML-escaped; a
//! figure is checked to be a well-formed `<svg>` document without scripts before it is
//! inlined. The output depends only on what was added (no time stamps).

use std::fmt::Write as _;
use std::path::Path;

use crate::error::{ReportError, Result};
use crate::svgcheck::check_svg;

/// Escapes `&`, `<`, `>`, `"` and `'` for HTML text and attribute values.
///
/// ```
/// assert_eq!(report::html::escape("a < b & \"c\""), "a &lt; b &amp; &quot;c&quot;");
/// ```
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            _ => out.push(c),
        }
    }
    out
}

#[derive(Clone, Debug, PartialEq)]
enum Block {
    Heading(String),
    Paragraph(String),
    List(Vec<String>),
    Pre(String),
    KeyValues {
        caption: String,
        rows: Vec<(String, String)>,
    },
    Table {
        caption: String,
        headers: Vec<String>,
        rows: Vec<Vec<String>>,
    },
    Figure {
        number: usize,
        caption: String,
        svg: String,
    },
}

/// A report being built; [`Report::to_html`] renders it.
///
/// ```
/// let mut r = report::Report::new("surae identify");
/// r.paragraph("Fit of 9 parameters & their <intervals>.")
///     .key_values("Run", &[("method", "mcmc"), ("seed", "7")]);
/// r.table("Parameters", &["name", "value"], &[vec!["sol.lst_m".into(), "0.2634".into()]])?;
/// let html = r.to_html();
/// assert!(html.contains("9 parameters &amp; their &lt;intervals&gt;."));
/// assert!(!html.contains("http"));
/// # Ok::<(), report::ReportError>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    title: String,
    subtitle: Option<String>,
    blocks: Vec<Block>,
    figures: usize,
}

const CSS: &str = "\
body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,'DejaVu Sans',Arial,sans-serif;\
max-width:1120px;margin:2em auto;padding:0 1.2em;color:#1a1a1a;line-height:1.5;background:#fff}\
h1{font-size:1.9em;margin-bottom:.2em}h2{font-size:1.35em;margin-top:1.8em;border-bottom:1px solid #ccc;padding-bottom:.2em}\
.subtitle{color:#555;margin-top:0}\
table{border-collapse:collapse;margin:1em 0;font-size:.95em}\
caption{text-align:left;font-weight:600;padding:.3em 0}\
th,td{border:1px solid #ccc;padding:.3em .7em;text-align:left;vertical-align:top}\
th{background:#f2f2f2}td.num{text-align:right;font-variant-numeric:tabular-nums}\
tr:nth-child(even) td{background:#fafafa}\
figure{margin:1.5em 0;padding:0}figure svg{max-width:100%;height:auto;display:block;border:1px solid #e4e4e4}\
figcaption{color:#333;font-size:.95em;margin-top:.4em}\
pre{background:#f6f6f6;padding:.8em;overflow-x:auto;font-size:.9em}\
footer{margin-top:3em;color:#777;font-size:.85em}";

/// Whether a cell looks like a number (right-aligned in tables).
fn numeric(cell: &str) -> bool {
    let t = cell.trim().trim_end_matches('%').trim();
    !t.is_empty() && t.parse::<f64>().is_ok()
}

/// Makes a figure ready to inline: drops an XML declaration, checks it, adds a `viewBox`
/// (so that it scales with the page) when it has only `width` and `height`.
fn prepare_svg(svg: &str) -> Result<String> {
    let mut s = svg.trim();
    if s.starts_with("<?xml") {
        s = s.find("?>").map_or(s, |i| s[i + 2..].trim_start());
    }
    let summary = check_svg(s)?;
    let lower = s.to_ascii_lowercase();
    for banned in [
        "<script",
        "<foreignobject",
        "javascript:",
        " onload",
        "href=\"http",
    ] {
        if lower.contains(banned) {
            return Err(ReportError::Invalid {
                figure: "report",
                reason: format!("figure contains `{banned}`: not inlined"),
            });
        }
    }
    let attr = |n: &str| {
        summary
            .root_attributes
            .iter()
            .find(|(k, _)| k == n)
            .map(|(_, v)| v.clone())
    };
    if attr("viewBox").is_none() {
        if let (Some(w), Some(h)) = (attr("width"), attr("height")) {
            return Ok(format!(
                "<svg viewBox=\"0 0 {} {}\"{}",
                escape(&w),
                escape(&h),
                &s[4..]
            ));
        }
    }
    Ok(s.to_string())
}

impl Report {
    /// A new, empty report with a page title.
    pub fn new(title: impl Into<String>) -> Self {
        Report {
            title: title.into(),
            subtitle: None,
            blocks: Vec::new(),
            figures: 0,
        }
    }

    /// A line under the title (e.g. the command that made the report).
    pub fn subtitle(&mut self, text: impl Into<String>) -> &mut Self {
        self.subtitle = Some(text.into());
        self
    }

    /// A section heading.
    pub fn heading(&mut self, text: impl Into<String>) -> &mut Self {
        self.blocks.push(Block::Heading(text.into()));
        self
    }

    /// A paragraph of plain text.
    pub fn paragraph(&mut self, text: impl Into<String>) -> &mut Self {
        self.blocks.push(Block::Paragraph(text.into()));
        self
    }

    /// A bulleted list.
    pub fn list<S: AsRef<str>>(&mut self, items: &[S]) -> &mut Self {
        self.blocks.push(Block::List(
            items.iter().map(|s| s.as_ref().to_string()).collect(),
        ));
        self
    }

    /// Preformatted text (e.g. the command line or the terminal summary).
    pub fn preformatted(&mut self, text: impl Into<String>) -> &mut Self {
        self.blocks.push(Block::Pre(text.into()));
        self
    }

    /// A two-column key–value table.
    pub fn key_values<K: AsRef<str>, V: AsRef<str>>(
        &mut self,
        caption: impl Into<String>,
        rows: &[(K, V)],
    ) -> &mut Self {
        self.blocks.push(Block::KeyValues {
            caption: caption.into(),
            rows: rows
                .iter()
                .map(|(k, v)| (k.as_ref().to_string(), v.as_ref().to_string()))
                .collect(),
        });
        self
    }

    /// A table with a header row; every row must have as many cells as there are headers.
    /// Numeric cells are right-aligned.
    pub fn table<H: AsRef<str>>(
        &mut self,
        caption: impl Into<String>,
        headers: &[H],
        rows: &[Vec<String>],
    ) -> Result<&mut Self> {
        let caption = caption.into();
        if headers.is_empty() {
            return Err(ReportError::Empty {
                figure: "report",
                series: format!("headers of table `{caption}`"),
            });
        }
        if let Some((i, r)) = rows
            .iter()
            .enumerate()
            .find(|(_, r)| r.len() != headers.len())
        {
            return Err(ReportError::LengthMismatch {
                figure: "report",
                series: format!("row {i} of table `{caption}`"),
                expected: headers.len(),
                got: r.len(),
            });
        }
        self.blocks.push(Block::Table {
            caption,
            headers: headers.iter().map(|h| h.as_ref().to_string()).collect(),
            rows: rows.to_vec(),
        });
        Ok(self)
    }

    /// A numbered figure: the SVG document (as returned by [`crate::figures`]) is inlined
    /// after a well-formedness check; `caption` is plain text.
    pub fn figure(&mut self, caption: impl Into<String>, svg: &str) -> Result<&mut Self> {
        let svg = prepare_svg(svg)?;
        self.figures += 1;
        self.blocks.push(Block::Figure {
            number: self.figures,
            caption: caption.into(),
            svg,
        });
        Ok(self)
    }

    /// Number of figures added so far.
    pub fn figure_count(&self) -> usize {
        self.figures
    }

    /// The complete HTML page.
    pub fn to_html(&self) -> String {
        let mut h = String::new();
        let _ = write!(
            h,
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
             <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
             <title>{}</title>\n<style>{CSS}</style>\n</head>\n<body>\n<h1>{}</h1>\n",
            escape(&self.title),
            escape(&self.title)
        );
        if let Some(s) = &self.subtitle {
            let _ = writeln!(h, "<p class=\"subtitle\">{}</p>", escape(s));
        }
        for b in &self.blocks {
            match b {
                Block::Heading(t) => {
                    let _ = writeln!(h, "<h2>{}</h2>", escape(t));
                }
                Block::Paragraph(t) => {
                    let _ = writeln!(h, "<p>{}</p>", escape(t));
                }
                Block::List(items) => {
                    h.push_str("<ul>\n");
                    for i in items {
                        let _ = writeln!(h, "<li>{}</li>", escape(i));
                    }
                    h.push_str("</ul>\n");
                }
                Block::Pre(t) => {
                    let _ = writeln!(h, "<pre>{}</pre>", escape(t));
                }
                Block::KeyValues { caption, rows } => {
                    h.push_str("<table>\n");
                    if !caption.is_empty() {
                        let _ = writeln!(h, "<caption>{}</caption>", escape(caption));
                    }
                    for (k, v) in rows {
                        let class = if numeric(v) { " class=\"num\"" } else { "" };
                        let _ = writeln!(
                            h,
                            "<tr><th scope=\"row\">{}</th><td{class}>{}</td></tr>",
                            escape(k),
                            escape(v)
                        );
                    }
                    h.push_str("</table>\n");
                }
                Block::Table {
                    caption,
                    headers,
                    rows,
                } => {
                    h.push_str("<table>\n");
                    if !caption.is_empty() {
                        let _ = writeln!(h, "<caption>{}</caption>", escape(caption));
                    }
                    h.push_str("<thead><tr>");
                    for c in headers {
                        let _ = write!(h, "<th scope=\"col\">{}</th>", escape(c));
                    }
                    h.push_str("</tr></thead>\n<tbody>\n");
                    for r in rows {
                        h.push_str("<tr>");
                        for c in r {
                            let class = if numeric(c) { " class=\"num\"" } else { "" };
                            let _ = write!(h, "<td{class}>{}</td>", escape(c));
                        }
                        h.push_str("</tr>\n");
                    }
                    h.push_str("</tbody>\n</table>\n");
                }
                Block::Figure {
                    number,
                    caption,
                    svg,
                } => {
                    let _ = writeln!(
                        h,
                        "<figure id=\"figure-{number}\">\n{svg}\n<figcaption>Figure {number}. {}</figcaption>\n</figure>",
                        escape(caption)
                    );
                }
            }
        }
        h.push_str("<footer>Made by surae. This page is self-contained: it loads nothing.</footer>\n</body>\n</html>\n");
        h
    }

    /// Writes [`Report::to_html`] to `path`.
    pub fn write(&self, path: &Path) -> Result<()> {
        std::fs::write(path, self.to_html()).map_err(|source| ReportError::Io {
            path: path.to_path_buf(),
            source,
        })
    }
}

/// Writes a figure's SVG text to `dir/name` and returns the path.
pub fn write_figure(dir: &Path, name: &str, svg: &str) -> Result<std::path::PathBuf> {
    let path = dir.join(name);
    std::fs::write(&path, svg).map_err(|source| ReportError::Io {
        path: path.clone(),
        source,
    })?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    const SVG: &str = "<svg width=\"10\" height=\"20\" xmlns=\"http://www.w3.org/2000/svg\"><rect width=\"1\" height=\"1\"/><path d=\"M0 0L1 1\"/><text>a &lt; b</text></svg>";

    #[test]
    fn escapes_text_everywhere() {
        let mut r = Report::new("T <&>");
        r.subtitle("s&")
            .heading("h<")
            .paragraph("p & <b>")
            .list(&["l<i>"])
            .preformatted("x < y")
            .key_values("kv&x", &[("k<", "v&x")]);
        r.table("t<", &["h&x"], &[vec!["<td>".into()]]).unwrap();
        let html = r.to_html();
        for raw in [
            "T <&>", "s&<", "h<", "p & <b>", "l<i>", "x < y", "kv&x", "k<", "v&x", "<td><td>",
            "h&x",
        ] {
            assert!(!html.contains(raw), "unescaped {raw:?}");
        }
        assert!(html.contains("p &amp; &lt;b&gt;"));
        assert!(html.contains("<h1>T &lt;&amp;&gt;</h1>"));
    }

    #[test]
    fn figures_inline_with_viewbox_and_numbering() {
        let mut r = Report::new("t");
        r.figure("first", SVG).unwrap();
        r.figure("second", &format!("<?xml version=\"1.0\"?>\n{SVG}"))
            .unwrap();
        let html = r.to_html();
        assert_eq!(r.figure_count(), 2);
        assert_eq!(html.matches("<svg viewBox=\"0 0 10 20\"").count(), 2);
        assert!(html.contains("Figure 2. second"));
        assert!(!html.contains("<?xml"));
    }

    #[test]
    fn rejects_bad_figures_and_tables() {
        let mut r = Report::new("t");
        assert!(r.figure("x", "<svg><rect/>").is_err());
        assert!(r.figure("x", "<div><rect/><rect/></div>").is_err());
        assert!(r
            .figure("x", "<svg><rect/><rect/><script>alert(1)</script></svg>")
            .is_err());
        assert!(r.table("t", &["a", "b"], &[vec!["1".into()]]).is_err());
        let empty: [&str; 0] = [];
        assert!(r.table("t", &empty, &[]).is_err());
        assert_eq!(r.figure_count(), 0);
    }

    #[test]
    fn deterministic_and_self_contained() {
        let build = || {
            let mut r = Report::new("t");
            r.paragraph("p").figure("f", SVG).unwrap();
            r.to_html()
        };
        let (a, b) = (build(), build());
        assert_eq!(a, b);
        let without_ns = a.replace("xmlns=\"http://www.w3.org/2000/svg\"", "");
        for banned in ["http:", "https:", "<script", "<link", "@import", "url("] {
            assert!(!without_ns.contains(banned), "{banned}");
        }
        assert!(numeric(" 12.5 %") && numeric("-3e-2") && !numeric("sol") && !numeric(""));
    }
}
