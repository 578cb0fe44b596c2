//! Safe output: `--out` checks and atomic writes (no half-written files).

use crate::error::{AppError, AppResult};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Where a command writes its results, or, for a program that reads the typed report and
/// wants no files ([`OutDir::discard`]), nowhere.
#[derive(Debug, Clone)]
pub struct OutDir {
    dir: PathBuf,
    inputs: Vec<PathBuf>,
    discard: bool,
}

fn canonical_or_self(p: &Path) -> PathBuf {
    std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf())
}

impl OutDir {
    /// Checks that `dir` can be used as an output folder, that none of the
    /// files the command will write there (`planned`) is one of `inputs`,
    /// and creates it. Checking up front means a refused run writes nothing.
    pub fn prepare(dir: &Path, inputs: &[&Path], planned: &[&str]) -> AppResult<Self> {
        let canon_inputs: Vec<PathBuf> = inputs.iter().map(|p| canonical_or_self(p)).collect();
        for name in planned {
            let target = canonical_or_self(&dir.join(name));
            if canon_inputs.contains(&target) {
                return Err(AppError::bad(format!(
                    "refusing to overwrite the input file {}",
                    dir.join(name).display()
                )));
            }
        }
        if dir.exists() && !dir.is_dir() {
            return Err(AppError::bad(format!(
                "--out {}: exists and is not a folder",
                dir.display()
            )));
        }
        std::fs::create_dir_all(dir).map_err(|e| {
            AppError::bad(format!(
                "--out {}: cannot create folder: {e}",
                dir.display()
            ))
        })?;
        Ok(Self {
            dir: dir.to_path_buf(),
            inputs: canon_inputs,
            discard: false,
        })
    }

    /// An output that writes nothing: [`OutDir::write`] returns the file's name alone.
    pub fn discard() -> Self {
        Self {
            dir: PathBuf::new(),
            inputs: Vec::new(),
            discard: true,
        }
    }

    /// `dir` prepared as [`OutDir::prepare`] prepares it, or [`OutDir::discard`] when
    /// `discard` is set (then nothing is checked or created).
    pub fn prepare_or_discard(
        dir: &Path,
        inputs: &[&Path],
        planned: &[&str],
        discard: bool,
    ) -> AppResult<Self> {
        if discard {
            Ok(Self::discard())
        } else {
            Self::prepare(dir, inputs, planned)
        }
    }

    /// The folder `name` inside this one, prepared likewise (discarding when this one does).
    pub fn sub(&self, name: &str, inputs: &[&Path], planned: &[&str]) -> AppResult<Self> {
        Self::prepare_or_discard(&self.path(name), inputs, planned, self.discard)
    }

    /// Whether this output writes nothing ([`OutDir::discard`]).
    pub fn discards(&self) -> bool {
        self.discard
    }

    /// Path of a file in the folder.
    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    /// Writes `name` in the folder atomically, refusing to overwrite an input (nothing when
    /// discarding).
    pub fn write(&self, name: &str, bytes: &[u8]) -> AppResult<PathBuf> {
        let target = self.path(name);
        if !self.discard {
            write_file_checked(&target, bytes, &self.inputs)?;
        }
        Ok(target)
    }
}

/// Writes `bytes` to `target` through a temporary file in the same folder and
/// a rename, refusing to overwrite any of `inputs`.
pub fn write_file_checked(target: &Path, bytes: &[u8], inputs: &[PathBuf]) -> AppResult<()> {
    let canon_target = canonical_or_self(target);
    if inputs.contains(&canon_target) {
        return Err(AppError::bad(format!(
            "refusing to overwrite the input file {}",
            target.display()
        )));
    }
    if target.is_dir() {
        return Err(AppError::bad(format!(
            "{}: is a folder, expected a file",
            target.display()
        )));
    }
    let parent = target
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(parent)
        .map_err(|e| AppError::bad(format!("{}: cannot create folder: {e}", parent.display())))?;
    let file_name = target
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let tmp = parent.join(format!(".{file_name}.tmp{}", std::process::id()));
    let result = (|| -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, target)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(AppError::bad(format!(
            "{}: cannot write: {e}",
            target.display()
        )));
    }
    Ok(())
}
