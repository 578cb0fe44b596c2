//! The command line's options (clap), each turned into the library's settings of its job.
//!
//! The help texts live here, with the flags; what each setting does is documented on the
//! library's settings (`surae_app`).

use std::path::PathBuf;

/// Arguments of `surae design`.
#[derive(clap::Args, Debug)]
pub struct DesignArgs {
    /// A candidate protocol: trials separated by commas, each `knee<deg>@<speed>` with an
    /// optional `x<cycles>` (e.g. `knee0@30,knee90@30,knee0@60`, `knee0@30x2`). Repeat the
    /// option to compare protocols.
    #[arg(long, required = true, value_name = "P")]
    pub protocol: Vec<String>,
    /// An unloaded run (CSV) whose random error (AR(1) + white) replaces the synthetic
    /// dynamometer's noise.
    #[arg(long, value_name = "U.csv")]
    pub unloaded: Option<PathBuf>,
    /// The design point: a parameters JSON, an OpenSim model (`.osim`), a CEINMS subject XML or
    /// an `identify.json` (nominal parameters when omitted).
    #[arg(long, value_name = "P.json|.osim")]
    pub params: Option<PathBuf>,
    /// With an `.osim` `--params`: the model's names of sol, gm and gl.
    #[arg(long, value_delimiter = ',', value_name = "MUSCLE=NAME")]
    pub osim_muscles: Vec<String>,
    /// Prior sd of each trial's constant torque offset left after the unloaded run's
    /// correction (N·m), integrated out; 0 treats the offset as known.
    #[arg(long, default_value_t = surae_app::OFFSET_PRIOR_SD_NM, value_name = "NM", allow_negative_numbers = true)]
    pub offset_sd: f64,
    /// EMG realisations (synthetic EMG seeds) each trial's information is averaged over.
    #[arg(long, default_value_t = surae_app::DEFAULT_EMG_DRAWS, value_name = "N")]
    pub emg_draws: usize,
    /// First EMG seed (realisation k uses seed + k).
    #[arg(long, default_value_t = surae_app::DEFAULT_EMG_SEED)]
    pub emg_seed: u64,
    /// Output folder (default `out/design`): `design.json`, `design.svg`.
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub report: ReportArgs,
}

/// Arguments of `surae diagnose`.
#[derive(clap::Args, Debug)]
pub struct DiagnoseArgs {
    /// Trial: a trial CSV, a recording map (`.json`) of a lab's files, or a CEINMS trial folder (a session of one) (docs/formats.md);
    /// the bundled seed trial (and its unloaded run) when omitted.
    #[arg(long, conflicts_with = "session")]
    pub trial: Option<PathBuf>,
    /// Unloaded run CSV: its cycle-locked error is removed from the measured
    /// torque and its noise sets the likelihood. Strongly recommended.
    #[arg(long, conflicts_with = "session")]
    pub unloaded: Option<PathBuf>,
    /// Session manifest (docs/formats.md): the trials diagnosed jointly (shared muscle
    /// parameters and subject effects, per-trial offset and gravity, held-out gain by leaving
    /// one trial out) into `DIR/diagnosis_session.json`, and every trial on its own with the
    /// session's parameters into `--out DIR/<trial>/`.
    #[arg(long)]
    pub session: Option<PathBuf>,
    /// With `--session`: parameters replacing the session's (parameters JSON, `.osim`, CEINMS
    /// subject XML), or an `identify.json` whose identified values are set over them.
    #[arg(long, requires = "session")]
    pub params: Option<PathBuf>,
    /// The EMG columns are already normalised envelopes in [0, 1].
    #[arg(long)]
    pub emg_is_envelope: bool,
    #[command(flatten)]
    pub knee: KneeArgs,
    /// Output folder (default `out/diagnose`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub report: ReportArgs,
}

/// Arguments of `surae envelope`.
#[derive(clap::Args, Debug)]
pub struct EnvelopeArgs {
    /// Trial: a trial CSV, a recording map (`.json`) of a lab's files (docs/formats.md);
    /// the bundled seed trial when omitted.
    #[arg(long)]
    pub trial: Option<PathBuf>,
    /// Output: a `.csv` file, or a folder to write `envelope.csv` into
    /// (default `out/envelope/envelope.csv`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Normalise a channel by an MVC reference instead of the trial maximum,
    /// e.g. `--mvc emg_sol=0.41` (in the raw EMG's unit, after band-pass,
    /// rectification and low-pass). Repeat for several channels.
    #[arg(long, value_name = "COLUMN=VALUE")]
    pub mvc: Vec<String>,
}

/// Identification method.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Simulated annealing (eq. 13 acceptance) with a Levenberg–Marquardt polish.
    Sa,
    /// Metropolis–Hastings chains with an AR(1) noise likelihood.
    Mcmc,
    /// The No-U-Turn sampler (Stan's NUTS) on the same likelihood, along the model's exact
    /// gradient.
    Nuts,
}

/// Arguments of `surae identify`.
#[derive(clap::Args, Debug)]
pub struct IdentifyArgs {
    /// `sa` (simulated annealing), `mcmc` (Metropolis–Hastings) or `nuts` (the No-U-Turn
    /// sampler).
    #[arg(long, value_enum)]
    pub method: Method,
    /// Trial: a trial CSV, a recording map (`.json`) of a lab's files, or a CEINMS trial folder (a session of one) (docs/formats.md);
    /// the bundled seed trial (and its unloaded run) when omitted.
    #[arg(long, conflicts_with = "session")]
    pub trial: Option<PathBuf>,
    /// Session manifest (docs/formats.md): several trials of one subject identified together,
    /// with the session's parameters and free parameters.
    #[arg(long)]
    pub session: Option<PathBuf>,
    /// The parameters to identify, comma-separated (e.g.
    /// `sol.lst_m,sol.fom_n,activation.shape_a,electromechanical_delay.delay_ms`); default LST,
    /// F0 and α0 of sol, gm and gl (a recording's defaults without an unloaded run). Names
    /// written `+curves.e0t` are added to the default set, which keeps its bounds. With
    /// --session only.
    #[arg(
        long,
        value_delimiter = ',',
        requires = "session",
        value_name = "NAMES"
    )]
    pub free: Option<Vec<String>>,
    /// Catalogued effects whose parameters are identified with the muscles', comma-separated
    /// (e.g. `electromechanical_delay,passive_joint_torque`): torque_offset,
    /// passive_joint_torque, gravity, electromechanical_delay, fatigue,
    /// antagonist_coactivation, eccentric_enhancement, viscous_damping, inertia (parameters and
    /// ranges in docs/results.md, "Effects identified with the muscles"). Each starts at its
    /// value in --effects, or at its null value, and has a uniform prior on its range. With
    /// --session its parameters join the free ones, shared by the trials (a per-trial effect,
    /// torque_offset or gravity, is refused in a session of several trials).
    #[arg(long = "with", value_delimiter = ',', value_name = "EFFECTS")]
    pub with_effects: Option<Vec<String>>,
    /// SA only: number of annealing chains (starts); chain 0 starts from the base values, the
    /// others from random points. Default 4; a session with the recording defaults adds 4
    /// more when the best two disagree by more than 1 % (a number given here is run as given).
    #[arg(long, value_name = "N")]
    pub chains: Option<u32>,
    /// Unloaded run CSV (`time_s, ankle_angle_deg, torque_nm`): its cycle-locked
    /// error is removed from the measured torque and its noise sets the likelihood.
    #[arg(long)]
    pub unloaded: Option<PathBuf>,
    /// Seed of every random choice (results do not depend on the thread count).
    #[arg(long, default_value_t = 42)]
    pub seed: u64,
    /// True parameters (a parameters JSON, docs/formats.md, or a fixture's `truth.json`):
    /// adds `errors_pct`. The bundled trial's truth is used when no `--trial` is given.
    #[arg(long)]
    pub truth: Option<PathBuf>,
    /// MCMC only: cap on the iterations per chain (warm-up and sampling). A
    /// run that reaches it before R̂ < 1.01 and bulk ESS ≥ 400 reports
    /// `"converged": false`. Default: the sampler's documented cap.
    #[arg(long, value_name = "N")]
    pub max_iterations: Option<usize>,
    #[command(flatten)]
    pub model: ModelArgs,
    /// Output folder (default `out/identify`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub report: ReportArgs,
}

/// Arguments of `surae validate`.
#[derive(clap::Args, Debug)]
pub struct ValidateArgs {
    /// Session manifest (docs/formats.md): the trials validated; a trial's `condition` label
    /// groups it for leaving one condition out.
    #[arg(long)]
    pub session: PathBuf,
    /// Parameters over the session's (parameters JSON, `.osim`, CEINMS subject XML, or an
    /// `identify.json`): the start and bounds' centre of every calibration.
    #[arg(long)]
    pub params: Option<PathBuf>,
    /// The parameters calibrated, comma-separated (default: the manifest's `free`, else LST, F0
    /// and α0 of sol, gm and gl, or a recording's defaults). Names written `+curves.e0t` are
    /// added to the default set, which keeps its bounds: an extension judged against the same
    /// calibration.
    #[arg(long, value_delimiter = ',')]
    pub free: Option<Vec<String>>,
    /// A parameters file predicted as it is on every held-out part (e.g. CEINMS's calibrated
    /// subject XML); repeat for several.
    #[arg(long = "peer", value_name = "FILE")]
    pub peers: Vec<PathBuf>,
    /// Fold schemes, comma-separated: trial (leave one trial out), strides (the later strides
    /// of every trial), condition (leave one condition out). Default: every scheme the session
    /// can form.
    #[arg(long, value_delimiter = ',')]
    pub folds: Vec<String>,
    /// Share of each trial that calibrates when its later strides are held out.
    #[arg(long, default_value_t = 0.5)]
    pub later_fraction: f64,
    /// Annealing chains (starts) of each calibration. Default 4; with the recording defaults 4
    /// more when the best two disagree by more than 1 % (a number given here is run as given).
    #[arg(long, value_name = "N")]
    pub chains: Option<u32>,
    /// Seed of every calibration (results do not depend on the thread count).
    #[arg(long, default_value_t = 42)]
    pub seed: u64,
    /// The EMG columns are already normalised envelopes in [0, 1].
    #[arg(long)]
    pub emg_is_envelope: bool,
    /// Also validate each extension for real recordings on the same folds, seed and chains: a
    /// compliant tendon, the eccentric plateau, activation time constants, the EMG normalised
    /// the other way (and the helping ones together); reports each one's held-out gain and the
    /// best.
    #[arg(long)]
    pub extensions: bool,
    /// Output folder (default `out/validate`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub report: ReportArgs,
}

impl From<ValidateArgs> for surae_app::ValidateJob {
    fn from(a: ValidateArgs) -> Self {
        Self {
            session: a.session,
            params: a.params,
            params_data: None,
            free: a.free,
            peers: a.peers,
            folds: a.folds,
            later_fraction: a.later_fraction,
            chains: a.chains,
            seed: a.seed,
            emg_is_envelope: a.emg_is_envelope,
            extensions: a.extensions,
            out: a.out,
            discard_files: false,
        }
    }
}

/// Arguments of `surae inspect`.
#[derive(clap::Args, Debug)]
pub struct InspectArgs {
    /// The file(s) of one recording: a delimited text export (comma, semicolon or tab), OpenSim
    /// `.sto`/`.mot` files (several: one recording split over them), a `.c3d`, a CEINMS trial
    /// folder, or a recording map (`.json`) to read and check.
    #[arg(required = true, value_name = "FILE")]
    pub files: Vec<PathBuf>,
    /// Output folder (default `out/inspect`): `map.json`, the starter map, with paths relative
    /// to this folder, and `inspect.json`.
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub report: ReportArgs,
}

/// Model options shared by the commands that simulate.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct ModelArgs {
    /// Parameters JSON (docs/formats.md; any subset, the rest is nominal), an OpenSim model
    /// (`.osim`) whose soleus and gastrocnemii give F0, LOM, LST, α0 and vmax, a CEINMS
    /// subject XML, or an `identify.json` whose identified values are set over the nominal
    /// ones.
    #[arg(long)]
    pub params: Option<PathBuf>,
    /// With an `.osim` `--params`: the model's names of sol, gm and gl when they are not
    /// gait2392's `soleus_r`, `med_gas_r`, `lat_gas_r` (e.g. `sol=soleus_l,gm=med_gas_l`).
    #[arg(long, value_delimiter = ',', value_name = "MUSCLE=NAME")]
    pub osim_muscles: Vec<String>,
    /// Effects JSON (effects and their parameters in docs/formats.md): `{"<effect>": {"<param>": value}}`.
    #[arg(long)]
    pub effects: Option<PathBuf>,
    /// The EMG columns are already normalised envelopes in [0, 1] (skip the
    /// EMG filtering of docs/model.md).
    #[arg(long)]
    pub emg_is_envelope: bool,
    #[command(flatten)]
    pub knee: KneeArgs,
}

/// The knee angle of a trial recorded without a `knee_angle_deg` column.
#[derive(clap::Args, Debug, Clone, Copy, Default)]
pub struct KneeArgs {
    /// Constant knee flexion of the trial, in degrees (0 extended, 90 flexed), when the
    /// file has no `knee_angle_deg` column; a file whose column holds other values is an
    /// error. Without either the knee is extended.
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub knee_angle_deg: Option<f64>,
}

/// How a command reports: a progress display and summary (unless `--quiet`),
/// and the JSON result on standard output with `--json`.
#[derive(clap::Args, Debug, Clone, Copy, Default)]
pub struct ReportArgs {
    /// No progress display and no summary.
    #[arg(long)]
    pub quiet: bool,
    /// Print the JSON result to standard output (the summary goes to standard error).
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `surae sensitivity`.
#[derive(clap::Args, Debug)]
pub struct SensitivityArgs {
    /// Trial: a trial CSV, a recording map (`.json`) of a lab's files (docs/formats.md);
    /// the bundled seed trial when omitted.
    #[arg(long)]
    pub trial: Option<PathBuf>,
    #[command(flatten)]
    pub model: ModelArgs,
    /// Largest relative change in percent (the sweep goes from −MAX to +MAX).
    #[arg(long, default_value_t = 20.0)]
    pub max_change: f64,
    /// Step of the sweep in percent.
    #[arg(long, default_value_t = 5.0)]
    pub step: f64,
    /// Output folder (default `out/sensitivity`): `sensitivity.csv`, `sensitivity.json`.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Arguments of `surae simulate`.
#[derive(clap::Args, Debug)]
pub struct SimulateArgs {
    /// Trial: a trial CSV, a recording map (`.json`) of a lab's files, or a CEINMS trial folder (a session of one) (docs/formats.md);
    /// the bundled seed trial when omitted.
    #[arg(long, conflicts_with = "session")]
    pub trial: Option<PathBuf>,
    /// Session manifest (docs/formats.md): the model on each of its trials; `--out` is then a
    /// folder (one CSV per trial and `simulate.json` with each trial's RMS error and R²).
    /// `--params` may be an `identify.json`, whose identified values are set over the
    /// session's parameters.
    #[arg(long)]
    pub session: Option<PathBuf>,
    #[command(flatten)]
    pub model: ModelArgs,
    /// Output: a `.csv` file, an OpenSim storage file (`.sto`), or a folder to write
    /// `simulate.csv` into (default `out/simulate/simulate.csv`).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

impl From<DesignArgs> for surae_app::DesignJob {
    fn from(a: DesignArgs) -> Self {
        Self {
            protocol: a.protocol,
            unloaded: a.unloaded,
            params: a.params,
            osim_muscles: a.osim_muscles,
            offset_sd: a.offset_sd,
            emg_draws: a.emg_draws,
            emg_seed: a.emg_seed,
            out: a.out,
            unloaded_data: None,
            params_data: None,
            discard_files: false,
        }
    }
}

impl From<DiagnoseArgs> for surae_app::DiagnoseJob {
    fn from(a: DiagnoseArgs) -> Self {
        Self {
            trial: a.trial,
            unloaded: a.unloaded,
            session: a.session,
            params: a.params,
            emg_is_envelope: a.emg_is_envelope,
            knee: a.knee.into(),
            out: a.out,
            trial_data: None,
            unloaded_data: None,
            params_data: None,
            discard_files: false,
        }
    }
}

impl From<EnvelopeArgs> for surae_app::EnvelopeJob {
    fn from(a: EnvelopeArgs) -> Self {
        Self {
            trial: a.trial,
            out: a.out,
            mvc: a.mvc,
        }
    }
}

impl From<Method> for surae_app::Method {
    fn from(m: Method) -> Self {
        match m {
            Method::Sa => surae_app::Method::Sa,
            Method::Mcmc => surae_app::Method::Mcmc,
            Method::Nuts => surae_app::Method::Nuts,
        }
    }
}

impl From<IdentifyArgs> for surae_app::IdentifyJob {
    fn from(a: IdentifyArgs) -> Self {
        Self {
            method: a.method.into(),
            trial: a.trial,
            session: a.session,
            free: a.free,
            with_effects: a.with_effects,
            chains: a.chains,
            unloaded: a.unloaded,
            seed: a.seed,
            truth: a.truth,
            max_iterations: a.max_iterations,
            model: a.model.into(),
            out: a.out,
            trial_data: None,
            unloaded_data: None,
            truth_data: None,
            discard_files: false,
        }
    }
}

impl From<InspectArgs> for surae_app::InspectJob {
    fn from(a: InspectArgs) -> Self {
        Self {
            files: a.files,
            out: a.out,
        }
    }
}

impl From<ModelArgs> for surae_app::ModelSettings {
    fn from(a: ModelArgs) -> Self {
        Self {
            params: a.params,
            osim_muscles: a.osim_muscles,
            effects: a.effects,
            emg_is_envelope: a.emg_is_envelope,
            knee: a.knee.into(),
            params_data: None,
            effects_data: None,
            emg_normalisation: None,
        }
    }
}

impl From<KneeArgs> for surae_app::KneeSettings {
    fn from(a: KneeArgs) -> Self {
        Self {
            knee_angle_deg: a.knee_angle_deg,
        }
    }
}

impl From<SensitivityArgs> for surae_app::SensitivityJob {
    fn from(a: SensitivityArgs) -> Self {
        Self {
            trial: a.trial,
            model: a.model.into(),
            max_change: a.max_change,
            step: a.step,
            out: a.out,
        }
    }
}

impl From<SimulateArgs> for surae_app::SimulateJob {
    fn from(a: SimulateArgs) -> Self {
        Self {
            trial: a.trial,
            session: a.session,
            model: a.model.into(),
            out: a.out,
        }
    }
}
