//! Writing output files safely: `-` means stdout, and a file the user did not name
//! explicitly is never overwritten without `--force`.

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::failure::{CliError, CliResult};

/// Where a command's main output goes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Target {
    /// Standard output (`-o -`).
    Stdout,
    /// A file the user named with `-o` (may be overwritten: they asked for it).
    Named(PathBuf),
    /// A file name the command chose (never overwritten without `--force`).
    Default(PathBuf),
}

impl Target {
    /// The target for an optional `-o` argument, falling back to `default`.
    pub fn from_arg(arg: Option<&Path>, default: impl FnOnce() -> PathBuf) -> Self {
        match arg {
            Some(p) if p.as_os_str() == "-" => Target::Stdout,
            Some(p) => Target::Named(p.to_path_buf()),
            None => Target::Default(default()),
        }
    }

    /// The file path, if not stdout.
    pub fn path(&self) -> Option<&Path> {
        match self {
            Target::Stdout => None,
            Target::Named(p) | Target::Default(p) => Some(p),
        }
    }

    /// Display name for messages.
    pub fn display(&self) -> String {
        self.path()
            .map_or_else(|| "<stdout>".into(), |p| p.display().to_string())
    }

    /// Writes `bytes`, refusing to replace an existing default-named file unless `force`.
    pub fn write(&self, bytes: &[u8], force: bool) -> CliResult {
        match self {
            Target::Stdout => std::io::stdout()
                .lock()
                .write_all(bytes)
                .map_err(|e| CliError::io("<stdout>", e)),
            Target::Named(p) => write_file(p, bytes),
            Target::Default(p) => {
                if p.exists() && !force {
                    return Err(CliError::Failed(format!(
                        "{} exists; pass --force to overwrite it or -o to name the output",
                        p.display()
                    )));
                }
                write_file(p, bytes)
            }
        }
    }
}

/// Writes a whole file through a temporary sibling, so a failure never leaves half a file.
pub fn write_file(path: &Path, bytes: &[u8]) -> CliResult {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| CliError::io(dir, e))?;
    }
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".partial");
    let tmp = PathBuf::from(tmp);
    std::fs::write(&tmp, bytes).map_err(|e| CliError::io(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| CliError::io(path, e))
}
