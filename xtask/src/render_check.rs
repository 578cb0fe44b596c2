//! `cargo xtask render-check <report.html> [--png OUT.png] [--min-figures N]`: renders a
//! report in a real browser (headless Chromium) and fails when the page does not render.
//!
//! Steps:
//! 1. find `chromium` (or `chromium-browser`) on `PATH`; when it is missing and we run as
//!    root with `apt-get` available, install Debian's `chromium` package (`apt-get update`,
//!    `apt-get install -y --no-install-recommends chromium`), saying so; otherwise fail with
//!    a message that says how to install it;
//! 2. take a screenshot (`--screenshot`, 1280×2000 window) with console logging on
//!    (`--enable-logging=stderr --v=0`): every `CONSOLE` line the page produces is an error,
//!    since a surae report has no script and loads nothing;
//! 3. dump the DOM (`--dump-dom`) and check that it holds the report: a `<h1>`, and at least
//!    `--min-figures` (default 1) `<figure>` elements each with an inline `<svg>`;
//! 4. decode the PNG and fail when it is blank: fewer than 1 % of the pixels differ from the
//!    background colour, or fewer than 8 distinct colours.
//!
//! The browser runs with no network features (`--disable-background-networking`,
//! `--disable-component-update`, `--disable-sync`, `--disable-quic`), in a fresh temporary
//! profile, and is killed after two minutes.

use std::collections::BTreeSet;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};

pub const USAGE: &str =
    "usage: cargo xtask render-check <report.html> [--png OUT.png] [--min-figures N]\n\
  render the report headless in Chromium (installed with apt-get when missing and root),\n\
  fail on console messages, a DOM without the figures or a blank screenshot";

/// Longest a browser run may take.
const TIMEOUT: Duration = Duration::from_secs(120);

fn on_path(name: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join(name))
        .find(|p| p.is_file())
}

fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
        .unwrap_or(false)
}

/// The browser binary, installed with apt-get when missing (root only).
fn chromium() -> Result<PathBuf> {
    for name in ["chromium", "chromium-browser"] {
        if let Some(p) = on_path(name) {
            return Ok(p);
        }
    }
    let apt = on_path("apt-get");
    if apt.is_none() || !is_root() {
        bail!(
            "chromium is not installed and cannot be installed here (needs root and apt-get); \
             install Debian's `chromium` package (`sudo apt-get install chromium`) and run again"
        );
    }
    for args in [
        &["update"][..],
        &["install", "-y", "--no-install-recommends", "chromium"][..],
    ] {
        eprintln!(
            "render-check: chromium missing, running `apt-get {}`",
            args.join(" ")
        );
        let status = Command::new("apt-get")
            .args(args)
            .env("DEBIAN_FRONTEND", "noninteractive")
            .stdout(Stdio::null())
            .status()
            .context("running apt-get")?;
        if !status.success() {
            bail!("`apt-get {}` failed ({status})", args.join(" "));
        }
    }
    on_path("chromium").context("apt-get installed chromium but it is not on PATH")
}

/// Runs the browser with `args`, killing it after [`TIMEOUT`]; returns (stdout, stderr).
fn run_browser(bin: &Path, args: &[String]) -> Result<(String, String)> {
    let mut child = Command::new(bin)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .with_context(|| format!("starting {}", bin.display()))?;
    let mut out = child.stdout.take().context("browser stdout")?;
    let mut err = child.stderr.take().context("browser stderr")?;
    let t_out = std::thread::spawn(move || {
        let mut s = Vec::new();
        let _ = out.read_to_end(&mut s);
        s
    });
    let t_err = std::thread::spawn(move || {
        let mut s = Vec::new();
        let _ = err.read_to_end(&mut s);
        s
    });
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait()? {
            break s;
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            bail!("the browser did not finish within {} s", TIMEOUT.as_secs());
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let stdout = String::from_utf8_lossy(&t_out.join().unwrap_or_default()).into_owned();
    let stderr = String::from_utf8_lossy(&t_err.join().unwrap_or_default()).into_owned();
    if !status.success() {
        bail!("the browser failed ({status}):\n{}", tail(&stderr, 20));
    }
    Ok((stdout, stderr))
}

fn tail(text: &str, lines: usize) -> String {
    let v: Vec<&str> = text.lines().collect();
    v[v.len().saturating_sub(lines)..].join("\n")
}

fn base_args(profile: &Path) -> Vec<String> {
    [
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--disable-extensions",
        "--hide-scrollbars",
        "--mute-audio",
    ]
    .iter()
    .map(|s| s.to_string())
    .chain([format!("--user-data-dir={}", profile.display())])
    .collect()
}

/// Console lines of the page in Chromium's log (`…:CONSOLE…] "message", source: …`).
pub fn console_messages(log: &str) -> Vec<String> {
    log.lines()
        .filter(|l| l.contains(":CONSOLE") || l.contains("Uncaught"))
        .map(str::to_string)
        .collect()
}

/// What the DOM check found.
#[derive(Debug, PartialEq, Eq)]
pub struct DomSummary {
    pub figures: usize,
    pub svgs: usize,
    pub has_h1: bool,
}

/// Counts the report's parts in a dumped DOM.
pub fn dom_summary(dom: &str) -> DomSummary {
    DomSummary {
        figures: dom.matches("<figure").count(),
        svgs: dom.matches("<svg").count(),
        has_h1: dom.contains("<h1"),
    }
}

/// Share of pixels that differ from the most common colour, and the number of distinct colours
/// (capped), of an RGB(A) 8-bit PNG.
pub fn png_ink(png_bytes: &[u8]) -> Result<(f64, usize, (u32, u32))> {
    let mut dec = png::Decoder::new(png_bytes);
    dec.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut reader = dec.read_info().context("reading the PNG header")?;
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).context("decoding the PNG")?;
    let channels = match info.color_type {
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Indexed => bail!("indexed PNG after expansion"),
    };
    let data = &buf[..info.buffer_size()];
    let px: Vec<&[u8]> = data.chunks_exact(channels).collect();
    if px.is_empty() {
        bail!("the PNG has no pixels");
    }
    let mut counts = std::collections::HashMap::new();
    let mut colours = BTreeSet::new();
    for p in &px {
        *counts.entry(*p).or_insert(0usize) += 1;
        if colours.len() < 1000 {
            colours.insert(p.to_vec());
        }
    }
    let background = counts.values().copied().max().unwrap_or(0);
    let ink = 1.0 - background as f64 / px.len() as f64;
    Ok((ink, colours.len(), (info.width, info.height)))
}

/// Runs the check; `Ok(false)` when the page does not render properly.
pub fn run(args: &mut dyn Iterator<Item = String>) -> Result<bool> {
    let mut html: Option<PathBuf> = None;
    let mut png_out: Option<PathBuf> = None;
    let mut min_figures = 1usize;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--png" => png_out = Some(PathBuf::from(args.next().context("--png needs a file")?)),
            "--min-figures" => {
                min_figures = args
                    .next()
                    .context("--min-figures needs a number")?
                    .parse()
                    .context("--min-figures needs a number")?
            }
            "-h" | "--help" => {
                println!("{USAGE}");
                return Ok(true);
            }
            other if html.is_none() && !other.starts_with('-') => html = Some(PathBuf::from(other)),
            other => bail!("unknown argument `{other}`\n{USAGE}"),
        }
    }
    let html = html.context(format!("which report?\n{USAGE}"))?;
    let html = std::fs::canonicalize(&html).with_context(|| format!("{}", html.display()))?;
    let bin = chromium()?;
    let tmp = tempfile::tempdir().context("creating a temporary folder")?;
    let png_path = png_out.unwrap_or_else(|| tmp.path().join("report.png"));
    let url = format!("file://{}", html.display());
    let mut problems = Vec::new();

    let mut shot = base_args(&tmp.path().join("profile-shot"));
    shot.extend([
        "--enable-logging=stderr".to_string(),
        "--v=0".to_string(),
        "--window-size=1280,2000".to_string(),
        format!("--screenshot={}", png_path.display()),
        url.clone(),
    ]);
    let start = Instant::now();
    let (_, log) = run_browser(&bin, &shot)?;
    for m in console_messages(&log) {
        problems.push(format!("console: {m}"));
    }

    let mut dump = base_args(&tmp.path().join("profile-dom"));
    dump.extend(["--dump-dom".to_string(), url]);
    let (dom, _) = run_browser(&bin, &dump)?;
    let d = dom_summary(&dom);
    if !d.has_h1 {
        problems.push("the rendered DOM has no <h1>: not a surae report".into());
    }
    if d.figures < min_figures || d.svgs < d.figures {
        problems.push(format!(
            "the rendered DOM has {} <figure> and {} <svg> elements, expected at least {min_figures} figures each with an <svg>",
            d.figures, d.svgs
        ));
    }

    let bytes = std::fs::read(&png_path)
        .with_context(|| format!("the browser wrote no screenshot at {}", png_path.display()))?;
    let (ink, colours, (w, h)) = png_ink(&bytes)?;
    if ink < 0.01 || colours < 8 {
        problems.push(format!(
            "the screenshot looks blank: {:.2} % of the pixels differ from the background, {colours} colours",
            100.0 * ink
        ));
    }
    eprintln!(
        "render-check: {} rendered by {} in {:.1} s: {w}×{h} px, {:.1} % ink, {} colours, {} figures, {} console messages",
        html.display(),
        bin.display(),
        start.elapsed().as_secs_f64(),
        100.0 * ink,
        if colours >= 1000 { "≥ 1000".to_string() } else { colours.to_string() },
        d.figures,
        console_messages(&log).len()
    );
    if problems.is_empty() {
        eprintln!("render-check: ok (screenshot {})", png_path.display());
        Ok(true)
    } else {
        for p in &problems {
            eprintln!("render-check: {p}");
        }
        Ok(false)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn console_lines_are_found() {
        let log = "[1:1:ERROR:dbus/bus.cc:405] Failed to connect to the bus\n\
                   [2:2:INFO:CONSOLE:1] \"boom\", source: file:///r.html (1)\n\
                   [2:2:INFO:CONSOLE:1] \"Uncaught ReferenceError: f is not defined\", source: x\n";
        assert_eq!(console_messages(log).len(), 2);
        assert!(console_messages("[1:1:ERROR:dbus] x\n").is_empty());
    }

    #[test]
    fn dom_counts() {
        let d =
            dom_summary("<html><h1>t</h1><figure><svg></svg></figure><figure><svg></svg></figure>");
        assert_eq!(
            d,
            DomSummary {
                figures: 2,
                svgs: 2,
                has_h1: true
            }
        );
    }

    fn encode(w: u32, h: u32, pixel: impl Fn(u32, u32) -> [u8; 3]) -> Vec<u8> {
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, w, h);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            let mut wr = enc.write_header().unwrap();
            let mut data = Vec::new();
            for y in 0..h {
                for x in 0..w {
                    data.extend_from_slice(&pixel(x, y));
                }
            }
            wr.write_image_data(&data).unwrap();
        }
        out
    }

    #[test]
    fn blank_and_inked_pngs() {
        let blank = encode(40, 30, |_, _| [255, 255, 255]);
        let (ink, colours, dim) = png_ink(&blank).unwrap();
        assert_eq!((ink, colours, dim), (0.0, 1, (40, 30)));
        let drawn = encode(40, 30, |x, y| {
            if x < 10 {
                [(x * 20) as u8, (y * 8) as u8, 0]
            } else {
                [255; 3]
            }
        });
        let (ink, colours, _) = png_ink(&drawn).unwrap();
        assert!((ink - 0.25).abs() < 0.01, "{ink}");
        assert!(colours > 8);
        assert!(png_ink(b"not a png").is_err());
    }
}
