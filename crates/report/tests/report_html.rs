//! A report with real figures: self-contained, well-formed figures inlined, text escaped.

use report::figures;
use report::{check_xml, Report};

#[test]
fn report_inlines_figures_and_loads_nothing() {
    let t: Vec<f64> = (0..1000).map(|i| i as f64 / 100.0).collect();
    let m: Vec<f64> = t.iter().map(|x| 40.0 * x.sin()).collect();
    let q: Vec<f64> = t.iter().map(|x| 15.0 - 3.0 * x).collect();
    let a = figures::torque_fit(&t, &m, &[("model <SA> & co", &m)], &q, &[]).unwrap();
    let b = figures::residual_vs_time(&t, &[("r", &q)]).unwrap();
    let mut r = Report::new("run <1> & more");
    r.paragraph("Verdict: deficient & <unclear>")
        .key_values("Settings", &[("seed", "7"), ("trial", "a<b>.csv")]);
    r.table(
        "Parameters",
        &["name", "value", "q05"],
        &[vec!["sol.lst_m".into(), "0.26".into(), "0.25".into()]],
    )
    .unwrap();
    r.figure("Torque", &a)
        .unwrap()
        .figure("Residual", &b)
        .unwrap();
    let html = r.to_html();
    dir_write_and_read(&r, &html);
    assert_eq!(html.matches("<figure").count(), 2);
    assert_eq!(html.matches("<svg").count(), 2);
    // The legend text with `<` and `&` stays escaped inside the inlined SVG.
    assert!(html.contains("model &lt;SA&gt; &amp; co"));
    assert!(!html.contains("<SA>"));
    assert!(html.contains("Verdict: deficient &amp; &lt;unclear&gt;"));
    assert!(html.contains("<td class=\"num\">0.26</td>"));
    // Each inlined figure is itself well-formed.
    for part in html.split("<svg").skip(1) {
        let end = part.find("</svg>").unwrap();
        check_xml(&format!("<svg{}</svg>", &part[..end])).unwrap();
    }
    let stripped = html.replace("xmlns=\"http://www.w3.org/2000/svg\"", "");
    for banned in [
        "http://", "https://", "<script", "<link", "src=", "@import", "url(",
    ] {
        assert!(!stripped.contains(banned), "{banned}");
    }
    // The body (outside the figures) is well-formed XML too, apart from the doctype and meta.
    let body_start = html.find("<body>").unwrap();
    let body_end = html.find("</body>").unwrap() + "</body>".len();
    check_xml(&html[body_start..body_end]).unwrap();
}

fn dir_write_and_read(r: &Report, html: &str) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("report.html");
    r.write(&p).unwrap();
    assert_eq!(std::fs::read_to_string(&p).unwrap(), html);
    let f = report::write_figure(dir.path(), "x.svg", "<svg/>").unwrap();
    assert_eq!(std::fs::read_to_string(f).unwrap(), "<svg/>");
    assert!(r.write(&dir.path().join("missing/report.html")).is_err());
}
