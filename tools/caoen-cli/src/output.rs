//! Writing outputs under one rule for every command.
//!
//! - `-` is standard output, and so is `/dev/stdout` (written as `-` is, through the
//!   shell's redirection), for every output that is one file; the format is the one the
//!   name's extension would give, or the command's stream format (PNG for pictures,
//!   binary STL or OBJ for meshes, JSON for models) when there is none. An output that
//!   is a folder refuses `-` with a usage error, and at most one output of a command
//!   goes to standard output. A failed write there (closed, disk full) fails the
//!   command; a reader that goes away (`caoen ... | head`) does not.
//! - An existing regular file is never replaced unless `-f/--force` is given, whether
//!   its name came from `-o` or was chosen by the command. Files are written whole: the
//!   bytes go to a new temporary file beside the output (`.NAME.XXXXXX.caoen-tmp`,
//!   created exclusively, so no existing file is touched), which is renamed over the
//!   output only once complete and removed on every failure. A replaced file keeps its
//!   permission bits. Without `--force` the rename itself refuses to replace a file
//!   that appeared meanwhile.
//! - A character device or FIFO (`/dev/null`, a terminal, a named pipe) is a stream, not
//!   a file: it is opened and written in place, without `--force`, and stays what it is;
//!   an image goes there in its natural format when the name has no image extension. A
//!   block device is written in place too, but only with `--force` (it holds data).
//!   Directories and sockets are refused.
//! - A symbolic link is followed: the file it points at is written (through a temporary
//!   file in that file's directory) and the link stays a link. A link to nothing is
//!   refused rather than creating a file wherever it points.
//! - No output may be one of the command's inputs (the same file by any name, link or
//!   hard link), even with `--force`, and no two outputs of one command may be the same
//!   file.
//!
//! `caoen examples`, `caoen demo` and `caoen bench --keep` regenerate their own output
//! directories: their files there are replaced without `--force` ([`replace_file`]),
//! by the same safe writes.

use std::fs::{self, Metadata, Permissions};
use std::io::Write;
use std::path::{Path, PathBuf};

use crate::failure::{CliError, CliResult};

/// The name of standard output in messages.
pub const STDOUT: &str = "standard output";

/// Where a command's main output goes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Target {
    /// Standard output (`-o -`).
    Stdout,
    /// A file the user named with `-o`.
    Named(PathBuf),
    /// A file name the command chose.
    Default(PathBuf),
}

impl Target {
    /// The target for an optional `-o` argument, falling back to `default`.
    pub fn from_arg(arg: Option<&Path>, default: impl FnOnce() -> PathBuf) -> Self {
        match arg {
            Some(p) => Target::file(p),
            None => Target::Default(default()),
        }
    }

    /// The target for a file name the user gave (any output option).
    pub fn file(path: &Path) -> Self {
        if is_stdout(path) {
            Target::Stdout
        } else {
            Target::Named(path.to_path_buf())
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
}

/// How an existing output path is written.
enum Plan {
    /// A regular file (new, or replaced with `--force`) at this real path, written
    /// through a temporary sibling; `Some` permissions when it replaces a file.
    File(PathBuf, Option<Permissions>),
    /// A device or FIFO, opened and written in place.
    Stream,
}

/// The outputs of one command run: whether existing files may be replaced, the files
/// it reads (never written), and the outputs claimed so far (never the same file twice).
#[derive(Debug, Default, Clone)]
pub struct Outputs {
    force: bool,
    inputs: Vec<PathBuf>,
    claimed: Vec<PathBuf>,
    /// What already goes to standard output, if anything.
    stdout: Option<String>,
}

impl Outputs {
    /// Outputs that replace existing files only if `force`.
    pub fn new(force: bool) -> Self {
        Outputs {
            force,
            ..Outputs::default()
        }
    }

    /// Adds a file the command reads; `-` (stdin) and `builtin:` models are not files.
    pub fn input(mut self, path: impl AsRef<Path>) -> Self {
        let p = path.as_ref();
        if p.as_os_str() != "-" && !p.to_string_lossy().starts_with("builtin:") {
            self.inputs.push(p.to_path_buf());
        }
        self
    }

    /// Adds an optional input file.
    pub fn input_opt(self, path: Option<impl AsRef<Path>>) -> Self {
        match path {
            Some(p) => self.input(p),
            None => self,
        }
    }

    /// Checks `target` against the rule before the command does its work, so a refused
    /// output fails at once rather than after a long encode or render.
    pub fn check(&mut self, target: &Target) -> CliResult {
        let Some(path) = target.path() else {
            return self.claim_stdout("an output");
        };
        self.plan(path, matches!(target, Target::Default(_)))?;
        let id = identity(path);
        if self.claimed.contains(&id) {
            return Err(CliError::Usage(format!(
                "{}: given for two outputs of one command",
                path.display()
            )));
        }
        self.claimed.push(id);
        Ok(())
    }

    /// Claims standard output for `what` (an output, or a summary the command prints
    /// there), refusing a second claim: two writers would mix their bytes.
    fn claim_stdout(&mut self, what: &str) -> CliResult {
        if let Some(first) = &self.stdout {
            return Err(CliError::Usage(format!(
                "{STDOUT}: {first} already goes there; give `-` to one output only"
            )));
        }
        self.stdout = Some(what.to_string());
        Ok(())
    }

    /// [`Outputs::check`] for a file output.
    pub fn check_path(&mut self, path: &Path) -> CliResult {
        self.check(&Target::file(path))
    }

    /// Writes `bytes` to `target` under the rule (checked again: files change).
    pub fn write(&self, target: &Target, bytes: &[u8]) -> CliResult {
        let Some(path) = target.path() else {
            return write_stdout(bytes);
        };
        match self.plan(path, matches!(target, Target::Default(_)))? {
            Plan::Stream => write_in_place(path, bytes),
            Plan::File(real, old) => write_through_temp(path, &real, bytes, old, self.force)
                .map_err(|e| match e {
                    WriteError::Exists => exists(path, matches!(target, Target::Default(_))),
                    WriteError::Io(at, e) => CliError::io(at, e),
                }),
        }
    }

    /// Writes `bytes` to the file `path` under the rule.
    pub fn write_path(&self, path: &Path, bytes: &[u8]) -> CliResult {
        self.write(&Target::file(path), bytes)
    }

    /// Decides how `path` is written, or why it may not be.
    fn plan(&self, path: &Path, default_name: bool) -> CliResult<Plan> {
        let meta = match fs::symlink_metadata(path) {
            Ok(m) => m,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Ok(Plan::File(path.to_path_buf(), None))
            }
            Err(e) => return Err(CliError::io(path, e)),
        };
        let (real, meta) = if meta.file_type().is_symlink() {
            let target = match fs::metadata(path) {
                Ok(m) => m,
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                    return Err(CliError::Failed(format!(
                        "{}: a symbolic link to a missing file; not creating its target",
                        path.display()
                    )))
                }
                Err(e) => return Err(CliError::io(path, e)),
            };
            // Only a regular file is replaced by a rename, which must happen beside the
            // file itself; devices and FIFOs are opened through the link as they are.
            let real = if target.is_file() {
                fs::canonicalize(path).map_err(|e| CliError::io(path, e))?
            } else {
                path.to_path_buf()
            };
            (real, target)
        } else {
            (path.to_path_buf(), meta)
        };
        let kind = Kind::of(&meta);
        if matches!(kind, Kind::File | Kind::Block) {
            if let Some(input) = self.inputs.iter().find(|i| same_file(i, path, &meta)) {
                let also = if input.as_path() == path {
                    String::new()
                } else {
                    format!(" (as {})", input.display())
                };
                return Err(CliError::Failed(format!(
                    "{}: is an input of this command{also}; not writing over it",
                    path.display()
                )));
            }
        }
        match kind {
            Kind::File if self.force => Ok(Plan::File(real, Some(meta.permissions()))),
            Kind::Block if self.force => Ok(Plan::Stream),
            Kind::File | Kind::Block => Err(exists(path, default_name)),
            Kind::Stream => Ok(Plan::Stream),
            Kind::Dir => Err(CliError::Failed(format!(
                "{}: is a directory, not an output file",
                path.display()
            ))),
            Kind::Other(what) => Err(CliError::Failed(format!(
                "{}: is a {what}; not writing to it",
                path.display()
            ))),
        }
    }
}

/// Whether `path` names this process's standard output: `-`, or a name of it that is
/// written as `-` is, so that `-o /dev/stdout > file` writes through the shell's
/// redirection instead of replacing the file it opened.
pub fn is_stdout(path: &Path) -> bool {
    path.as_os_str() == "-"
        || cfg!(unix)
            && ["/dev/stdout", "/dev/fd/1", "/proc/self/fd/1"]
                .iter()
                .any(|a| path == Path::new(a))
}

/// `path` for messages: `standard output` for `-` and its aliases.
pub fn shown(path: &Path) -> String {
    if is_stdout(path) {
        STDOUT.to_string()
    } else {
        path.display().to_string()
    }
}

/// The format extension of an output: its own (in lower case), or `stream` for
/// standard output or an existing stream whose name has none.
pub fn format_extension(path: &Path, stream: &str) -> Option<String> {
    extension_lowercase(path).or_else(|| is_stream(path).then(|| stream.to_string()))
}

/// Refuses standard output for an output that is a folder (`what` names the command).
pub fn folder_output(path: &Path, what: &str) -> CliResult {
    if is_stdout(path) {
        return Err(CliError::Usage(format!(
            "{what} writes a folder of files: -o must name a folder, not standard output"
        )));
    }
    Ok(())
}

/// `path`'s extension in lower case (none if it is missing or not UTF-8).
pub fn extension_lowercase(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
}

/// Whether `path` is standard output or an existing stream (character device or FIFO,
/// through links): written in place, and in a command's natural format whatever its
/// name.
pub fn is_stream(path: &Path) -> bool {
    is_stdout(path) || fs::metadata(path).is_ok_and(|m| matches!(Kind::of(&m), Kind::Stream))
}

/// Writes a file a command regenerates as its documented job (`caoen examples`,
/// `caoen demo`, `caoen bench --keep`): replaced without `--force`, written as safely.
pub fn replace_file(path: &Path, bytes: &[u8]) -> CliResult {
    Outputs::new(true).write_path(path, bytes)
}

/// Writes command output (text or data) to standard output and flushes it.
///
/// A closed or full stdout is an error; a reader that went away is reported as a
/// broken pipe, which `main` turns into a quiet success.
pub fn write_stdout(bytes: &[u8]) -> CliResult {
    if stdout_closed() {
        return Err(CliError::Failed(format!(
            "{STDOUT}: is closed; redirect it to a file or /dev/null"
        )));
    }
    let mut out = std::io::stdout().lock();
    out.write_all(bytes)
        .and_then(|()| out.flush())
        .map_err(|e| CliError::io(STDOUT, e))
}

/// Prints `text` on standard output, like [`write_stdout`].
pub fn print(text: impl AsRef<str>) -> CliResult {
    write_stdout(text.as_ref().as_bytes())
}

/// Whether standard output was closed when the process started.
///
/// The Rust runtime reopens a closed standard descriptor on `/dev/null`, read-write,
/// so writes to it succeed and the output is silently lost. A shell's `>/dev/null`
/// opens it write-only, which tells the two apart (Linux only: it needs /proc).
pub fn stdout_closed() -> bool {
    static CLOSED: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *CLOSED.get_or_init(|| {
        cfg!(target_os = "linux")
            && fs::read_link("/proc/self/fd/1").is_ok_and(|l| l == Path::new("/dev/null"))
            && fs::read_to_string("/proc/self/fdinfo/1").is_ok_and(|info| {
                info.lines()
                    .find_map(|l| l.strip_prefix("flags:"))
                    .and_then(|f| u32::from_str_radix(f.trim(), 8).ok())
                    // O_ACCMODE is 3, O_RDWR is 2.
                    .is_some_and(|flags| flags & 3 == 2)
            })
    })
}

/// What kind of file an existing output is.
enum Kind {
    File,
    Dir,
    /// Character device or FIFO.
    Stream,
    Block,
    Other(&'static str),
}

impl Kind {
    fn of(meta: &Metadata) -> Kind {
        let ft = meta.file_type();
        if ft.is_file() {
            return Kind::File;
        }
        if ft.is_dir() {
            return Kind::Dir;
        }
        #[cfg(unix)]
        {
            use std::os::unix::fs::FileTypeExt;
            if ft.is_char_device() || ft.is_fifo() {
                return Kind::Stream;
            }
            if ft.is_block_device() {
                return Kind::Block;
            }
            if ft.is_socket() {
                return Kind::Other("socket");
            }
        }
        Kind::Other("special file")
    }
}

fn exists(path: &Path, default_name: bool) -> CliError {
    let or_name = if default_name {
        " or -o to name the output"
    } else {
        ""
    };
    CliError::Failed(format!(
        "{} exists; pass -f/--force to overwrite it{or_name}",
        path.display()
    ))
}

/// Whether the file `input` is the existing output `path`, whose metadata is `meta`.
fn same_file(input: &Path, path: &Path, meta: &Metadata) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        let _ = path;
        fs::metadata(input).is_ok_and(|m| m.dev() == meta.dev() && m.ino() == meta.ino())
    }
    #[cfg(not(unix))]
    {
        let _ = meta;
        match (fs::canonicalize(input), fs::canonicalize(path)) {
            (Ok(a), Ok(b)) => a == b,
            _ => false,
        }
    }
}

/// Whether `a` and `b` are the same existing file, by whatever names or links.
pub fn is_same_file(a: &Path, b: &Path) -> bool {
    fs::metadata(b).is_ok_and(|m| same_file(a, b, &m))
}

/// A path that names the same file whichever way it is spelt (for files that may not
/// exist yet: the canonical directory and the file name).
fn identity(path: &Path) -> PathBuf {
    if let Ok(p) = fs::canonicalize(path) {
        return p;
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    match (fs::canonicalize(dir), path.file_name()) {
        (Ok(d), Some(name)) => d.join(name),
        _ => path.to_path_buf(),
    }
}

fn write_in_place(path: &Path, bytes: &[u8]) -> CliResult {
    // No truncation and no creation: the node exists and is a stream or a device.
    let mut f = fs::OpenOptions::new()
        .write(true)
        .open(path)
        .map_err(|e| CliError::io(path, e))?;
    f.write_all(bytes)
        .and_then(|()| f.flush())
        .map_err(|e| CliError::io(path, e))
}

enum WriteError {
    Exists,
    Io(PathBuf, std::io::Error),
}

/// Writes `real` (the output `shown` with links resolved) through a temporary sibling.
fn write_through_temp(
    shown: &Path,
    real: &Path,
    bytes: &[u8],
    old: Option<Permissions>,
    replace: bool,
) -> Result<(), WriteError> {
    let io = |at: &Path| {
        let at = at.to_path_buf();
        move |e| WriteError::Io(at, e)
    };
    let name = real.file_name().ok_or_else(|| {
        WriteError::Io(
            shown.to_path_buf(),
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file name"),
        )
    })?;
    let dir = match real.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if old.is_none() {
        fs::create_dir_all(dir).map_err(io(dir))?;
    }
    let mut prefix = std::ffi::OsString::from(".");
    prefix.push(name);
    prefix.push(".");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".caoen-tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // What `File::create` would give (0666 less the umask), not tempfile's 0600.
        builder.permissions(Permissions::from_mode(0o666));
    }
    // Dropping the temporary file on any early return below deletes it.
    let mut tmp = builder.tempfile_in(dir).map_err(io(dir))?;
    // Through the plain file: its errors do not name the temporary path, which is gone
    // by the time they are reported.
    let file = tmp.as_file_mut();
    file.write_all(bytes)
        .and_then(|()| file.flush())
        .map_err(io(shown))?;
    if let Some(perms) = old {
        #[cfg(unix)]
        let perms = {
            use std::os::unix::fs::PermissionsExt;
            // Never carry set-user-id, set-group-id or sticky bits to a new file.
            Permissions::from_mode(perms.mode() & 0o777)
        };
        tmp.as_file().set_permissions(perms).map_err(io(shown))?;
    }
    let persisted = if replace {
        tmp.persist(real)
    } else {
        tmp.persist_noclobber(real)
    };
    match persisted {
        Ok(_) => Ok(()),
        Err(e) if !replace && e.error.kind() == std::io::ErrorKind::AlreadyExists => {
            Err(WriteError::Exists)
        }
        // A file system without an exclusive rename or hard links: a plain rename, as
        // the output is still absent.
        Err(e) if !replace && fs::symlink_metadata(real).is_err() => e
            .file
            .persist(real)
            .map(drop)
            .map_err(|e| WriteError::Io(shown.to_path_buf(), e.error)),
        Err(e) => Err(WriteError::Io(shown.to_path_buf(), e.error)),
    }
}
