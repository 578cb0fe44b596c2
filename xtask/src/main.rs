//! Project automation. `cargo xtask gen-fixtures [--check] [--out DIR]` writes the synthetic
//! fixtures (the experiment of `docs/formats.md`, "Synthetic trials") deterministically from
//! fixed seeds.
//!
//! Folders (under `fixtures/` by default), each with `trial.csv`, `unloaded.csv` (3 cycles)
//! and `truth.json`:
//!
//! | folder | protocol | truth | seed |
//! |---|---|---|---|
//! | `seed` | `seed` | nominal parameters, no effect | 2016 |
//! | `offnominal` | `seed` | the 9 identified parameters off nominal ([`OFF_NOMINAL`]), no effect | 2018 |
//! | `relaxed2` | `relaxed+2` | nominal parameters, no effect | 2017 |
//! | `knee90` | `knee90` (the seed motion, knee flexed 90°) | nominal parameters, no effect | 2019 |
//! | `<effect>` (9 folders, named as the effects) | `relaxed+2` | nominal parameters + that effect | 3001…3009 |
//!
//! The effect magnitudes ([`EFFECTS`]) are moderate, physiologically plausible values, each
//! with its reason. `truth.json` holds the full parameters JSON, the effects JSON, the
//! protocol, the dynamometer and EMG settings, the rounding, the simulation settings and the
//! seed, with keys sorted and a trailing newline. `--check` regenerates into a temporary folder
//! and fails (exit 1) on any byte difference and on missing or extra files.
//!
//! Generation is sequential and uses only seeded ChaCha8 streams, so it does not depend on the
//! machine's thread count.

mod bench;
mod formats;
mod render_check;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use experiment::synth_session::{session_manifest, session_trial_name, synthesize_session};
use experiment::{
    format_trial, format_unloaded, sorted_json, synthesize, Protocol, SynthConfig, SynthProtocol,
};
use muscle_model::{EffectKind, Effects, ModelParams, ParamId};
use serde_json::Value;

/// The generator's name, written into every `truth.json` and comment line.
const GENERATOR: &str = "cargo xtask gen-fixtures";

/// Seed of `fixtures/seed`.
const SEED_SEED: u64 = 2016;
/// Seed of `fixtures/relaxed2`.
const SEED_RELAXED2: u64 = 2017;
/// Seed of `fixtures/offnominal`.
const SEED_OFFNOMINAL: u64 = 2018;
/// Seed of `fixtures/knee90`.
const SEED_KNEE90: u64 = 2019;
/// Seed of `fixtures/session3`'s first trial (the others take the next seeds).
const SEED_SESSION3: u64 = 2020;
/// The trials of `fixtures/session3`: the knee extended and flexed at 30 °/s, and the knee
/// extended at 60 °/s, the protocol the design analysis finds identifies all nine parameters.
const SESSION3: [&str; 3] = ["knee0@30", "knee90@30", "knee0@60"];
/// Knee flexion of `fixtures/knee90` (degrees): the usual knee-flexed test position, in which
/// the gastrocnemii are shortened and their drive is lowest
/// (`experiment::gastrocnemius_drive_factor`).
const KNEE90_DEG: f64 = 90.0;

/// The truth of `fixtures/offnominal`: each identified parameter times its factor.
///
/// The identification starts one chain (SA) and one mode search (MCMC) at the nominal
/// parameters, so a nominal truth cannot tell a recovered parameter from one that never
/// moved. These factors put every parameter away from nominal and away from the bounds
/// (LST ±5 %, F0 and α0 ±20 %): LST by 2–3 %, F0 and α0 by 10–12 %, with signs mixed
/// within and across muscles so that no common scale of the three muscles reproduces the
/// truth.
const OFF_NOMINAL: [(&str, f64); 9] = [
    ("sol.lst_m", 1.03),
    ("sol.fom_n", 0.88),
    ("sol.alpha_deg", 1.10),
    ("gm.lst_m", 0.97),
    ("gm.fom_n", 1.10),
    ("gm.alpha_deg", 0.88),
    ("gl.lst_m", 1.02),
    ("gl.fom_n", 0.90),
    ("gl.alpha_deg", 1.12),
];

/// The nominal parameters with [`OFF_NOMINAL`] applied.
fn off_nominal_params() -> Result<ModelParams> {
    let mut params = ModelParams::nominal();
    let mut effects = Effects::none();
    for (name, factor) in OFF_NOMINAL {
        let id = ParamId::parse(name).with_context(|| format!("parameter {name}"))?;
        let v = id.get(&params, &effects) * factor;
        id.set(&mut params, &mut effects, v);
    }
    params
        .validate()
        .context("the off-nominal fixture's parameters")?;
    Ok(params)
}
/// Seed of the effect folders: this + 1-based catalogue index (3001 … 3009).
const SEED_EFFECTS_BASE: u64 = 3000;

/// One effect fixture: the effect, its parameter values (in
/// `EffectKind::params` order) and why that magnitude.
struct EffectFixture {
    kind: EffectKind,
    values: [f64; 2],
    why: &'static str,
}

/// The true magnitude of each effect fixture: moderate and realistic, well inside the
/// muscle-model crate's bounds (`EffectKind::params`).
const EFFECTS: [EffectFixture; 9] = [
    EffectFixture {
        kind: EffectKind::TorqueOffset,
        values: [5.0, 0.0],
        why: "5 N·m: a gravity/zeroing error of a poorly compensated limb, a few % of the peak torque",
    },
    EffectFixture {
        kind: EffectKind::PassiveJointTorque,
        values: [1.0, 8.0],
        why: "s = 1 N·m, k = 8 /rad: about 7 N·m of non-muscular resistance at +15° dorsiflexion, -0.9 N·m at -20°",
    },
    EffectFixture {
        kind: EffectKind::Gravity,
        values: [6.0, 10.0],
        why: "m = 6 N·m (foot plus attachment, ~3 kg at 0.2 m), phase 10°: +0.5 N·m at +15°, -3 N·m at -20°",
    },
    EffectFixture {
        kind: EffectKind::ElectromechanicalDelay,
        values: [40.0, 0.0],
        why: "40 ms: the middle of the 30-50 ms usually measured for the triceps surae",
    },
    EffectFixture {
        kind: EffectKind::Fatigue,
        values: [0.03, 0.0],
        why: "0.03 /s: about 12 % loss of active force by the end of two maximal cycles (~4 s of full activation)",
    },
    EffectFixture {
        kind: EffectKind::AntagonistCoactivation,
        values: [6.0, 0.0],
        why: "6 N·m at the trial-maximum TA envelope (about 10 % of a ~50 N·m TA MVC), so -1 to -6 N·m",
    },
    EffectFixture {
        kind: EffectKind::EccentricEnhancement,
        values: [1.7, 0.0],
        why: "Flen = 1.7 instead of 1.4: a stronger eccentric plateau, within the 1.5-1.8 reported in vivo",
    },
    EffectFixture {
        kind: EffectKind::ViscousDamping,
        values: [3.0, 0.0],
        why: "3 N·m·s/rad: about 1.6 N·m at the 30 °/s cruise speed (ankle plus attachment damping)",
    },
    EffectFixture {
        kind: EffectKind::Inertia,
        values: [0.15, 0.0],
        why: "0.15 kg·m²: foot plus footplate; about 1.6 N·m during the 600 °/s² ramps",
    },
];

/// One fixture folder.
struct Fixture {
    name: String,
    config: SynthConfig,
    description: String,
    /// How the true parameters are named in the trial's comment line.
    params_text: &'static str,
}

fn fixtures() -> Result<Vec<Fixture>> {
    let mut out = vec![
        Fixture {
            name: "seed".into(),
            config: SynthConfig::new(Protocol::Seed, SEED_SEED),
            description:
                "the dissertation's experiment: seed protocol, nominal parameters, no effect".into(),
            params_text: "nominal parameters",
        },
        Fixture {
            name: "offnominal".into(),
            config: SynthConfig::new(Protocol::Seed, SEED_OFFNOMINAL)
                .with_params(off_nominal_params()?),
            description: "seed protocol, the 9 identified parameters off nominal \
                          (LST ×1.03/0.97/1.02, F0 ×0.88/1.10/0.90, α0 ×1.10/0.88/1.12 for sol/gm/gl), no effect"
                .into(),
            params_text: "off-nominal parameters",
        },
        Fixture {
            name: "relaxed2".into(),
            config: SynthConfig::new(Protocol::Relaxed { cycles: 2 }, SEED_RELAXED2),
            description: "relaxed+2 protocol, nominal parameters, no effect".into(),
            params_text: "nominal parameters",
        },
        Fixture {
            name: "knee90".into(),
            config: SynthConfig::new(Protocol::Seed, SEED_KNEE90).with_knee_angle_deg(KNEE90_DEG),
            description: format!(
                "seed protocol with the knee flexed {KNEE90_DEG}° (knee_angle_deg column; the \
                 gastrocnemii's EMG drive ×{}), nominal parameters, no effect",
                experiment::gastrocnemius_drive_factor(KNEE90_DEG)
            ),
            params_text: "nominal parameters",
        },
    ];
    for (i, e) in EFFECTS.iter().enumerate() {
        let mut effects = Effects::none();
        effects.set_values(e.kind, e.values);
        effects
            .validate()
            .with_context(|| format!("fixture effect {}", e.kind.name()))?;
        out.push(Fixture {
            name: e.kind.name().into(),
            config: SynthConfig::new(
                Protocol::Relaxed { cycles: 2 },
                SEED_EFFECTS_BASE + i as u64 + 1,
            )
            .with_effects(effects),
            description: format!(
                "relaxed+2 protocol, nominal parameters, effect {} ({})",
                e.kind.name(),
                e.why
            ),
            params_text: "nominal parameters",
        });
    }
    Ok(out)
}

/// Canonical JSON text: keys sorted, two-space indentation, trailing newline.
fn json_text(v: &Value) -> Result<String> {
    let mut s = serde_json::to_string_pretty(&sorted_json(v))?;
    s.push('\n');
    Ok(s)
}

/// The files of one fixture folder, as (file name, bytes).
fn render(f: &Fixture) -> Result<Vec<(String, String)>> {
    let syn = synthesize(&f.config).with_context(|| format!("synthesising fixture {}", f.name))?;
    let mut trial = syn.trial;
    let effects = serde_json::to_string(&sorted_json(&f.config.effects.to_json_value()))?;
    trial.comments = vec![format!(
        " surae synthetic trial `{}` made by `{GENERATOR}`: protocol {}, seed {}, {}, effects {effects}; truth in truth.json",
        f.name, f.config.synth_protocol(), f.config.seed, f.params_text
    )];
    let mut unloaded = syn.unloaded;
    unloaded.comments = vec![format!(
        " surae synthetic unloaded run (protocol cycles+3) made by `{GENERATOR}` for fixture `{}`, seed {}",
        f.name, f.config.seed
    )];
    let mut truth = syn.truth_json;
    if let Value::Object(m) = &mut truth {
        m.insert("generator".into(), Value::from(GENERATOR));
        m.insert("fixture".into(), Value::from(f.name.clone()));
        m.insert("description".into(), Value::from(f.description.clone()));
    }
    Ok(vec![
        ("trial.csv".into(), format_trial(&trial)?),
        ("unloaded.csv".into(), format_unloaded(&unloaded)?),
        ("truth.json".into(), json_text(&truth)?),
    ])
}

/// The files of `fixtures/session3`: each trial's CSV and unloaded run, `session.json` and
/// `truth.json`, as (file name, text).
fn render_session() -> Result<Vec<(String, String)>> {
    let protocols: Vec<SynthProtocol> = SESSION3
        .iter()
        .map(|p| p.parse().with_context(|| format!("protocol {p}")))
        .collect::<Result<_>>()?;
    let params = off_nominal_params()?;
    let session = synthesize_session(&protocols, SEED_SESSION3, &params, &Effects::none())
        .context("synthesising fixture session3")?;
    let mut files = Vec::new();
    let mut seeds = serde_json::Map::new();
    for (i, (p, syn)) in protocols.iter().zip(session).enumerate() {
        let name = session_trial_name(p);
        let seed = SEED_SESSION3 + i as u64;
        seeds.insert(name.clone(), Value::from(seed));
        let mut trial = syn.trial;
        trial.comments = vec![format!(
            " surae synthetic session trial `{name}` of fixture `session3` made by `{GENERATOR}`: protocol {p}, seed {seed}, off-nominal parameters, no effect, EMG normalised over the session's trials; truth in truth.json"
        )];
        let mut unloaded = syn.unloaded;
        unloaded.comments = vec![format!(
            " surae synthetic unloaded run (protocol cycles+3 at {} deg/s) made by `{GENERATOR}` for trial `{name}` of fixture `session3`, seed {seed}",
            p.speed_deg_s
        )];
        files.push((format!("{name}.csv"), format_trial(&trial)?));
        files.push((format!("{name}_unloaded.csv"), format_unloaded(&unloaded)?));
    }
    files.push((
        "session.json".into(),
        json_text(&session_manifest("session3", &protocols))?,
    ));
    let truth = serde_json::json!({
        "generator": GENERATOR,
        "fixture": "session3",
        "description": "three trials of one subject (knee0@30, knee90@30, knee0@60), off-nominal parameters as fixture offnominal, no effect",
        "params": params.to_json_value(),
        "protocols": SESSION3,
        "seeds": seeds,
    });
    files.push(("truth.json".into(), json_text(&truth)?));
    Ok(files)
}

fn readme(list: &[Fixture]) -> String {
    let mut s = String::from(
        "# Fixtures\n\nGenerated by `cargo xtask gen-fixtures` (xtask/src/main.rs); do not edit by hand.\n\
         `cargo xtask gen-fixtures --check` regenerates them and fails on any byte difference.\n\n\
         Every folder holds `trial.csv` (raw EMG rounded to 1e-4, angle to 1e-7 deg, torque = true model\n\
         + synthetic dynamometer error, 12-bit quantised), `unloaded.csv` (3 cycles, same seed,\n\
         independent noise) and `truth.json` (full parameters, effects, settings, seed).\n\n\
         | folder | protocol | seed | truth |\n|---|---|---|---|\n",
    );
    for f in list {
        s.push_str(&format!(
            "| `{}` | `{}` | {} | {} |\n",
            f.name,
            f.config.synth_protocol(),
            f.config.seed,
            f.description
        ));
    }
    s.push_str(&format!(
        "\n`session3` is a session of three trials of one subject: `{}` with seeds {}, {}, {}, the \
         off-nominal parameters of `offnominal` and no effect. Each trial has its CSV \
         (`knee0_30.csv`, …) and its unloaded run at its own speed (`knee0_30_unloaded.csv`, …); \
         `session.json` is its manifest and `truth.json` its truth. The true torque is computed \
         from EMG envelopes normalised over the session's three trials, as `--session` reads \
         them.\n",
        SESSION3.join("`, `"),
        SEED_SESSION3,
        SEED_SESSION3 + 1,
        SEED_SESSION3 + 2
    ));
    s.push_str(
        "\n`formats` holds the `seed` trial (EMG in µV, every number rounded to f32) in every \
         format a lab's recording may come in, each with the recording map that reads it: \
         `trial.csv` (surae's CSV) and `unloaded.csv`; `opensim/` (EMG in a version 2 `.sto`, \
         the angle in a `.mot`, the moment in OpenSim's sign in a `.sto`); `c3d/` (analog \
         channels); `noraxon/` (a tab-separated export with quoted headers, EMG in µV of both \
         legs, the dynamometer's angle and torque in mV with a calibration, offsets and the \
         left leg's sign flip); `semicolon/` (semicolons and decimal commas). Every map reads \
         the same numbers bit for bit (docs/formats.md, \"A lab's recordings\").\n",
    );
    s.push_str(
        "\n`walk36` is not generated: it is a trimmed copy of a real recording (61 s of treadmill \
         walking, OpenSim files: EMG envelopes, ankle and knee angles, ankle moment, the right \
         foot's vertical ground force), its CEINMS-RT subject files, `LICENSE` (Apache-2.0) and \
         a `NOTICE` naming its source; `map.json` is what `surae inspect` writes for it. \
         `gen-fixtures` leaves it alone and `--check` does not compare it.\n",
    );
    s
}

/// Folders of `fixtures/` that hold copied real data, not generated files: `gen-fixtures`
/// never writes them and `--check` skips them.
const COPIED_FIXTURES: [&str; 1] = ["walk36"];

/// Generates every fixture file into `dir` (created if needed).
fn generate(dir: &Path) -> Result<Vec<PathBuf>> {
    let list = fixtures()?;
    let mut written = Vec::new();
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let path = dir.join("README.md");
    std::fs::write(&path, readme(&list)).with_context(|| format!("writing {}", path.display()))?;
    written.push(path);
    let mut seed_files = None;
    for f in &list {
        let sub = dir.join(&f.name);
        std::fs::create_dir_all(&sub).with_context(|| format!("creating {}", sub.display()))?;
        let files = render(f)?;
        if f.name == "seed" {
            seed_files = Some(files.clone());
        }
        for (name, text) in files {
            let path = sub.join(name);
            std::fs::write(&path, text).with_context(|| format!("writing {}", path.display()))?;
            written.push(path);
        }
        eprintln!("  {}", f.name);
    }
    let sub = dir.join("session3");
    std::fs::create_dir_all(&sub).with_context(|| format!("creating {}", sub.display()))?;
    for (name, text) in render_session()? {
        let path = sub.join(name);
        std::fs::write(&path, text).with_context(|| format!("writing {}", path.display()))?;
        written.push(path);
    }
    eprintln!("  session3");
    let seed_files = seed_files.context("no seed fixture")?;
    let text_of = |name: &str| {
        seed_files
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, t)| t.as_str())
            .context("seed fixture file")
    };
    let seed_trial = experiment::parse_trial(text_of("trial.csv")?, "seed/trial.csv")?;
    let seed_unloaded = experiment::parse_unloaded(text_of("unloaded.csv")?, "seed/unloaded.csv")?;
    for (name, bytes) in formats::render(&seed_trial, &seed_unloaded)? {
        let path = dir.join("formats").join(name);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)
                .with_context(|| format!("creating {}", parent.display()))?;
        }
        std::fs::write(&path, bytes).with_context(|| format!("writing {}", path.display()))?;
        written.push(path);
    }
    eprintln!("  formats");
    Ok(written)
}

/// Every file under `root`, by path relative to it.
fn tree(root: &Path) -> Result<BTreeMap<PathBuf, PathBuf>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<PathBuf, PathBuf>) -> Result<()> {
        let entries =
            std::fs::read_dir(dir).with_context(|| format!("reading {}", dir.display()))?;
        for entry in entries {
            let p = entry?.path();
            if p.is_dir() {
                walk(root, &p, out)?;
            } else {
                let rel = p.strip_prefix(root)?.to_path_buf();
                out.insert(rel, p);
            }
        }
        Ok(())
    }
    let mut out = BTreeMap::new();
    if root.is_dir() {
        walk(root, root, &mut out)?;
    }
    Ok(out)
}

/// First differing line of two texts (1-based), for the report.
fn first_difference(a: &[u8], b: &[u8]) -> String {
    let (ta, tb) = (String::from_utf8_lossy(a), String::from_utf8_lossy(b));
    for (i, (x, y)) in ta.lines().zip(tb.lines()).enumerate() {
        if x != y {
            let cut = |s: &str| s.chars().take(120).collect::<String>();
            return format!(
                "line {}: committed `{}`, regenerated `{}`",
                i + 1,
                cut(x),
                cut(y)
            );
        }
    }
    format!(
        "lengths differ: committed {} lines, regenerated {}",
        ta.lines().count(),
        tb.lines().count()
    )
}

/// Regenerates into a temporary folder and compares with `dir`; returns the differences.
fn check(dir: &Path) -> Result<Vec<String>> {
    let tmp = tempfile::tempdir().context("creating a temporary folder")?;
    generate(tmp.path())?;
    let fresh = tree(tmp.path())?;
    let mut committed = tree(dir)?;
    committed.retain(|rel, _| {
        !rel.components()
            .next()
            .is_some_and(|c| COPIED_FIXTURES.iter().any(|f| c.as_os_str() == *f))
    });
    let mut problems = Vec::new();
    for (rel, path) in &fresh {
        match committed.get(rel) {
            None => problems.push(format!("missing: {}", rel.display())),
            Some(old) => {
                let a = std::fs::read(old).with_context(|| format!("reading {}", old.display()))?;
                let b = std::fs::read(path)?;
                if a != b {
                    problems.push(format!(
                        "differs: {} ({})",
                        rel.display(),
                        first_difference(&a, &b)
                    ));
                }
            }
        }
    }
    for rel in committed.keys() {
        if !fresh.contains_key(rel) {
            problems.push(format!("extra (not generated): {}", rel.display()));
        }
    }
    Ok(problems)
}

fn default_dir() -> PathBuf {
    let xtask = Path::new(env!("CARGO_MANIFEST_DIR"));
    xtask.parent().unwrap_or(xtask).join("fixtures")
}

const USAGE: &str = "usage: cargo xtask gen-fixtures [--check] [--out DIR]\n\
  gen-fixtures          write the synthetic fixtures (default folder: <workspace>/fixtures)\n\
  --check               regenerate into a temporary folder and fail on any difference\n\
  --out DIR             use DIR instead of <workspace>/fixtures\n\
  render-check F.html   render a report headless in Chromium and fail if it is blank or broken\n\
                        (cargo xtask render-check --help)\n\
  bench                 time the forward model and the cost on the seed fixture against the\n\
                        Python peer (cargo xtask bench --help)";

fn run() -> Result<bool> {
    let mut args = std::env::args().skip(1);
    match args.next().as_deref() {
        Some("gen-fixtures") => {}
        Some("render-check") => return render_check::run(&mut args),
        Some("bench") => return bench::run(&mut args),
        Some("-h" | "--help") | None => {
            println!("{USAGE}");
            return Ok(true);
        }
        Some(other) => bail!("unknown task `{other}`\n{USAGE}"),
    }
    let mut check_only = false;
    let mut out = None;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--check" => check_only = true,
            "--out" => out = Some(PathBuf::from(args.next().context("--out needs a folder")?)),
            "-h" | "--help" => {
                println!("{USAGE}");
                return Ok(true);
            }
            other => bail!("unknown argument `{other}`\n{USAGE}"),
        }
    }
    let dir = out.unwrap_or_else(default_dir);
    let start = std::time::Instant::now();
    if check_only {
        eprintln!(
            "regenerating the fixtures to compare with {}",
            dir.display()
        );
        let problems = check(&dir)?;
        if problems.is_empty() {
            eprintln!(
                "fixtures in {} are up to date ({:.1} s)",
                dir.display(),
                start.elapsed().as_secs_f64()
            );
            Ok(true)
        } else {
            for p in &problems {
                eprintln!("{p}");
            }
            eprintln!(
                "{} difference(s): run `cargo xtask gen-fixtures` and commit the result",
                problems.len()
            );
            Ok(false)
        }
    } else {
        eprintln!("writing the fixtures into {}", dir.display());
        // Remove stale generated files first so that the folder matches exactly.
        let list = fixtures()?;
        for f in &list {
            let sub = dir.join(&f.name);
            if sub.is_dir() {
                std::fs::remove_dir_all(&sub)
                    .with_context(|| format!("removing {}", sub.display()))?;
            }
        }
        let files = generate(&dir)?;
        eprintln!(
            "wrote {} files ({:.1} s)",
            files.len(),
            start.elapsed().as_secs_f64()
        );
        Ok(true)
    }
}

fn main() -> ExitCode {
    match run() {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}
