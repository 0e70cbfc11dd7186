//! Atomic file output: everything the library writes goes to a temporary file in the
//! target's directory and is renamed into place only when complete, so a failure never
//! leaves a half-written file behind.
//!
//! The staging files and folders of the process are registered ([`remove_staging`]), so a
//! client that catches SIGINT or SIGTERM can remove them before it exits; the paths they stand
//! for are remembered too, so an I/O error on a staging path names the user's path
//! ([`Error::with_user_paths`]). A target that exists and is not a regular file or folder (a
//! character device such as `/dev/null`, a FIFO) is written into, as a shell redirection
//! does, never replaced.

use crate::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use tempfile::{NamedTempFile, TempPath};

/// The staging paths of this process that may still exist (files and folders), each with the
/// user's path it stands for.
static STAGING: Mutex<Vec<(PathBuf, PathBuf)>> = Mutex::new(Vec::new());

/// Every staging path this process made and the user's path it stands for (kept after the
/// staging path is gone, so an error reported later still names the user's path).
static NAMES: Mutex<Vec<(PathBuf, PathBuf)>> = Mutex::new(Vec::new());

/// Held while a set of outputs is moved into place, so that [`remove_staging`] (called from a
/// signal-handling thread) waits for a commit to finish or roll back instead of cutting it.
static COMMITTING: Mutex<()> = Mutex::new(());

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// Remember that `staged` is a staging path for the user's `target`.
fn register(staged: &Path, target: &Path) {
    lock(&STAGING).push((staged.to_path_buf(), target.to_path_buf()));
    lock(&NAMES).push((staged.to_path_buf(), target.to_path_buf()));
}

/// Forget `staged` (it was moved into place or removed).
fn unregister(staged: &Path) {
    lock(&STAGING).retain(|(s, _)| s != staged);
}

/// Remove every staging file and folder this process still has, after any commit in progress
/// has finished (or rolled back). For a client's SIGINT/SIGTERM handler, just before it exits:
/// the outputs of an interrupted command are then left exactly as they were.
pub fn remove_staging() {
    let _commit = lock(&COMMITTING);
    let staged: Vec<(PathBuf, PathBuf)> = std::mem::take(&mut *lock(&STAGING));
    for (path, _) in staged {
        match std::fs::symlink_metadata(&path) {
            Ok(m) if m.is_dir() => {
                let _ = std::fs::remove_dir_all(&path);
            }
            Ok(_) => {
                let _ = std::fs::remove_file(&path);
            }
            Err(_) => {}
        }
    }
}

/// The user's path for `path` when it is (or lies inside) a staging path this process made;
/// `None` otherwise.
pub(crate) fn user_path(path: &Path) -> Option<PathBuf> {
    lock(&NAMES).iter().rev().find_map(|(s, t)| {
        path.strip_prefix(s).ok().map(|rel| {
            if rel.as_os_str().is_empty() {
                t.clone()
            } else {
                t.join(rel)
            }
        })
    })
}

/// `text` with every staging path this process made replaced by the user's path.
pub(crate) fn user_paths_in(text: &str) -> String {
    let names = lock(&NAMES);
    let mut out = text.to_string();
    for (s, t) in names.iter().rev() {
        let staged = s.display().to_string();
        if out.contains(&staged) {
            out = out.replace(&staged, &t.display().to_string());
        }
    }
    out
}

// The error names the user's paths, not the staging paths: kept here, beside the staging
// registry it reads, so that `error.rs` stays below this module.
impl Error {
    /// The same error naming the user's output paths where it names a hidden staging path of
    /// this module (a write into `.anisobondXXXX.csv` failed: the user wrote `-o bonds.csv`).
    pub fn with_user_paths(self) -> Self {
        let path_of = |p: String| user_path(Path::new(&p)).map_or(p, |u| u.display().to_string());
        let text = |m: String| user_paths_in(&m);
        match self {
            Error::Io { path, source } => Error::Io {
                path: path_of(path),
                source,
            },
            Error::Parse {
                path,
                line,
                message,
            } => Error::Parse {
                path: path_of(path),
                line,
                message: text(message),
            },
            Error::Model(m) => Error::Model(text(m)),
            Error::Invalid(m) => Error::Invalid(text(m)),
            Error::Degenerate(m) => Error::Degenerate(text(m)),
            Error::NotConverged(m) => Error::NotConverged(text(m)),
            Error::EngineFailed { engine, message } => Error::EngineFailed {
                engine,
                message: text(message),
            },
            Error::OutOfTolerance {
                failed,
                checks,
                message,
            } => Error::OutOfTolerance {
                failed,
                checks,
                message: text(message),
            },
        }
    }
}

/// True when `path` exists and is neither a regular file nor a folder (a character or block
/// device, a FIFO, a socket), links followed: such a target is written into, not replaced.
fn is_special(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir())
}

/// Copy the complete staged file into the existing non-regular `target` (as `cmd > target`
/// would), then remove the staged file.
fn write_into_special(staged: TempPath, target: &Path) -> Result<()> {
    let mut from = std::fs::File::open(&staged).map_err(|e| Error::io(target, e))?;
    let mut to = std::fs::OpenOptions::new()
        .write(true)
        .open(target)
        .map_err(|e| Error::io(target, e))?;
    std::io::copy(&mut from, &mut to).map_err(|e| Error::io(target, e))?;
    to.flush().map_err(|e| Error::io(target, e))?;
    unregister(&staged);
    drop(staged);
    Ok(())
}

/// Write `path` atomically: `fill` writes the content into a buffered temporary file in the
/// same folder, which is flushed and renamed onto `path` only if `fill` succeeds (on any
/// error the temporary file is removed). The rename makes the file appear complete or not
/// at all; it is not fsynced (a power cut may still lose it, as with any ordinary write).
/// An existing device or FIFO at `path` is written into instead (see the module doc).
pub fn write_atomic<F>(path: &Path, fill: F) -> Result<()>
where
    F: FnOnce(&mut dyn Write) -> Result<()>,
{
    check_output_directory(path)?;
    let dir = parent_dir(path);
    let tmp = output_temp_file(dir, ".tmp", path).map_err(|e| Error::io(path, e))?;
    {
        let mut w = std::io::BufWriter::new(tmp.as_file());
        fill(&mut w)?;
        w.flush().map_err(|e| Error::io(path, e))?;
    }
    persist(tmp.into_temp_path(), path)
}

/// Move the complete staged file onto `target` (renamed; written into a device or FIFO).
pub(crate) fn persist(staged: TempPath, target: &Path) -> Result<()> {
    if is_special(target) {
        return write_into_special(staged, target);
    }
    let path = staged.to_path_buf();
    let _commit = lock(&COMMITTING);
    staged
        .persist(target)
        .map_err(|e| Error::io(target, e.error))?;
    unregister(&path);
    Ok(())
}

/// The folder `path` is in (`.` for a bare file name).
fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// A temporary file in `dir` for the user's `target`, created as an ordinary file would be: on
/// Unix with mode 0666 less the umask (0644 under the usual umask), not tempfile's private
/// 0600, so that an output renamed from it can be read by the group and others like any file
/// the user writes. Registered for [`remove_staging`].
pub(crate) fn output_temp_file(
    dir: &Path,
    suffix: &str,
    target: &Path,
) -> std::io::Result<NamedTempFile> {
    let mut builder = tempfile::Builder::new();
    builder.prefix(".anisobond").suffix(suffix);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let file = builder.tempfile_in(dir)?;
    register(file.path(), target);
    Ok(file)
}

/// Refuse an output path whose directory does not exist, naming both (the CLI calls this
/// before a long computation; [`write_atomic`] calls it again before writing).
pub fn check_output_directory(path: &Path) -> Result<()> {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() && !dir.is_dir() => Err(Error::Invalid(format!(
            "{}: output directory `{}` does not exist (create it first)",
            path.display(),
            dir.display()
        ))),
        _ => Ok(()),
    }
}

/// Values per chunk of [`format_in_chunks`].
const FORMAT_CHUNK: usize = 8_192;

/// The text `put` writes for each value, by fixed chunks of values formatted in parallel,
/// the chunks in order: written one after the other they are the same bytes on any thread
/// count (large outputs, e.g. a million particles' VTK arrays and CSV rows).
pub fn format_in_chunks<T: Sync>(
    values: &[T],
    put: impl Fn(&mut String, &T) + Sync,
) -> Vec<String> {
    use rayon::prelude::*;
    values
        .par_chunks(FORMAT_CHUNK)
        .map(|chunk| {
            let mut s = String::new();
            for v in chunk {
                put(&mut s, v);
            }
            s
        })
        .collect()
}

/// Write a whole string atomically.
pub fn write_string_atomic(path: &Path, content: &str) -> Result<()> {
    write_atomic(path, |w| {
        w.write_all(content.as_bytes())
            .map_err(|e| Error::io(path, e))
    })
}

/// Read a whole text file, mapping the error to the file's name.
pub fn read_to_string(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).map_err(|e| Error::io(path, e))
}

/// The whole set of files and folders one command writes, written all or nothing.
///
/// Every target is checked when it is planned, before the computation: its folder exists,
/// it is not one of the command's inputs (compared as canonical paths, so `-o in.txt` or a
/// link to it is refused), a file target is not a folder and a folder target is not a file.
/// Planning a target gives a staging path beside it (a hidden temporary file, or folder for a
/// folder target) that the writers fill; [`OutputSet::commit`] checks every final path once
/// more (no staged file lands on an input or on a folder) and only then renames the staged
/// outputs into place. Dropped without a commit — on any error — the staging paths are
/// removed and every pre-existing file is left as it was.
#[derive(Default)]
pub struct OutputSet {
    inputs: Vec<std::path::PathBuf>,
    files: Vec<(tempfile::TempPath, std::path::PathBuf)>,
    dirs: Vec<(tempfile::TempDir, std::path::PathBuf)>,
}

/// `path` made absolute with its existing part resolved (links followed), so that two names
/// of one file compare equal even when the file does not exist yet.
fn canonical_target(path: &Path) -> std::path::PathBuf {
    if let Ok(c) = std::fs::canonicalize(path) {
        return c;
    }
    let dir = parent_dir(path);
    let base = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
    match path.file_name() {
        Some(name) => base.join(name),
        None => base,
    }
}

/// The folder of [`OutputSet::dir_or_temporary`]: a staged output, or a temporary folder.
#[derive(Debug)]
pub enum WorkDir {
    /// The staging folder of an output (moved into place by [`OutputSet::commit`]).
    Staged(PathBuf),
    /// A temporary folder, removed on drop.
    Temporary(tempfile::TempDir),
}

impl WorkDir {
    /// The folder.
    pub fn path(&self) -> &Path {
        match self {
            WorkDir::Staged(p) => p,
            WorkDir::Temporary(t) => t.path(),
        }
    }
}

impl OutputSet {
    /// An empty set for a command that reads `inputs` (files that do not exist are ignored:
    /// their readers report them).
    pub fn new(inputs: &[&Path]) -> OutputSet {
        OutputSet {
            inputs: inputs
                .iter()
                .filter_map(|p| std::fs::canonicalize(p).ok())
                .collect(),
            files: Vec::new(),
            dirs: Vec::new(),
        }
    }

    fn check_not_input(&self, target: &Path) -> Result<()> {
        let c = canonical_target(target);
        if self.inputs.contains(&c) {
            return Err(Error::Invalid(format!(
                "{}: this output is also an input of the command; refusing to overwrite it \
                 (choose another output path)",
                target.display()
            )));
        }
        Ok(())
    }

    /// The checks every target gets: its folder exists, it is not an input, it is planned once.
    fn check_target(&self, target: &Path) -> Result<()> {
        check_output_directory(target)?;
        self.check_not_input(target)?;
        self.check_planned_once(target)
    }

    fn check_planned_once(&self, target: &Path) -> Result<()> {
        let c = canonical_target(target);
        let planned = self
            .files
            .iter()
            .map(|(_, t)| t)
            .chain(self.dirs.iter().map(|(_, t)| t));
        if planned.map(|t| canonical_target(t)).any(|t| t == c) {
            return Err(Error::Invalid(format!(
                "{}: the same path is given for two outputs",
                target.display()
            )));
        }
        Ok(())
    }

    /// Plan the file `target`; returns the staging path the writer fills (same folder,
    /// hidden name, same extension, so writers that choose a format by extension still do).
    pub fn file(&mut self, target: &Path) -> Result<std::path::PathBuf> {
        if target.is_dir() {
            return Err(Error::Invalid(format!(
                "{}: is a folder; expected a file path for this output",
                target.display()
            )));
        }
        self.check_target(target)?;
        let dir = parent_dir(target);
        let suffix = match target.extension() {
            Some(e) => format!(".{}", e.to_string_lossy()),
            None => ".tmp".into(),
        };
        let staged = output_temp_file(dir, &suffix, target)
            .map_err(|e| Error::io(target, e))?
            .into_temp_path();
        let path = staged.to_path_buf();
        self.files.push((staged, target.to_path_buf()));
        Ok(path)
    }

    /// Plan `target` if given (an optional output of a command).
    pub fn optional_file(&mut self, target: Option<&Path>) -> Result<Option<std::path::PathBuf>> {
        target.map(|t| self.file(t)).transpose()
    }

    /// Plan the folder `target` (created if missing, merged into if it exists); returns the
    /// staging folder the writers fill, beside the target.
    pub fn dir(&mut self, target: &Path) -> Result<std::path::PathBuf> {
        if target.exists() && !target.is_dir() {
            return Err(Error::Invalid(format!(
                "{}: exists and is not a folder; expected a folder for this output",
                target.display()
            )));
        }
        self.check_target(target)?;
        let parent = parent_dir(target);
        let mut builder = tempfile::Builder::new();
        builder.prefix(".anisobond");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            builder.permissions(std::fs::Permissions::from_mode(0o777));
        }
        let staged = builder
            .tempdir_in(parent)
            .map_err(|e| Error::io(target, e))?;
        let path = staged.path().to_path_buf();
        register(&path, target);
        self.dirs.push((staged, target.to_path_buf()));
        Ok(path)
    }

    /// Plan the folder `target` if given (an optional output of a command).
    pub fn optional_dir(&mut self, target: Option<&Path>) -> Result<Option<std::path::PathBuf>> {
        target.map(|t| self.dir(t)).transpose()
    }

    /// A folder to run in: `target` planned ([`OutputSet::dir`]), or without one a
    /// temporary folder removed when the [`WorkDir`] is dropped (an engine's decks and logs
    /// that are not asked for).
    pub fn dir_or_temporary(&mut self, target: Option<&Path>) -> Result<WorkDir> {
        match target {
            Some(t) => self.dir(t).map(WorkDir::Staged),
            None => tempfile::tempdir()
                .map(WorkDir::Temporary)
                .map_err(|e| Error::io(std::env::temp_dir(), e)),
        }
    }

    /// Every file of a staged folder, relative to it.
    fn staged_files(root: &Path) -> Result<Vec<std::path::PathBuf>> {
        let mut out = Vec::new();
        let mut stack = vec![std::path::PathBuf::new()];
        while let Some(rel) = stack.pop() {
            let here = root.join(&rel);
            let entries = std::fs::read_dir(&here).map_err(|e| Error::io(&here, e))?;
            for entry in entries {
                let entry = entry.map_err(|e| Error::io(&here, e))?;
                let r = rel.join(entry.file_name());
                if entry.path().is_dir() {
                    stack.push(r);
                } else {
                    out.push(r);
                }
            }
        }
        out.sort();
        Ok(out)
    }

    /// Check every final path, then move the staged outputs into place as one set: an
    /// existing file is first moved aside, and if any move fails every target already moved
    /// is put back as it was (the error names the target that failed). Devices and FIFOs
    /// among the targets are written into last, once everything else is in place.
    pub fn commit(self) -> Result<()> {
        for (_, target) in &self.files {
            self.check_not_input(target)?;
        }
        let mut dir_files = Vec::with_capacity(self.dirs.len());
        for (staged, target) in &self.dirs {
            let files = Self::staged_files(staged.path())?;
            for rel in &files {
                let fin = target.join(rel);
                self.check_not_input(&fin)?;
                if fin.is_dir() {
                    return Err(Error::Invalid(format!(
                        "{}: is a folder; this command writes a file there (remove or rename \
                         the folder)",
                        fin.display()
                    )));
                }
                let mut up = rel.parent();
                while let Some(p) = up.filter(|p| !p.as_os_str().is_empty()) {
                    let d = target.join(p);
                    if d.exists() && !d.is_dir() {
                        return Err(Error::Invalid(format!(
                            "{}: is a file; this command writes a folder there",
                            d.display()
                        )));
                    }
                    up = p.parent();
                }
            }
            dir_files.push(files);
        }
        let _commit = lock(&COMMITTING);
        let mut moves = Moves::default();
        let mut special: Vec<(PathBuf, PathBuf)> = Vec::new();
        let result = (|| -> Result<()> {
            for (staged, target) in &self.files {
                if is_special(target) {
                    special.push((staged.to_path_buf(), target.clone()));
                } else {
                    moves.replace(staged, target)?;
                }
            }
            for ((staged, target), files) in self.dirs.iter().zip(&dir_files) {
                if !target.exists() {
                    moves.replace(staged.path(), target)?;
                    continue;
                }
                for rel in files {
                    let fin = target.join(rel);
                    if is_special(&fin) {
                        special.push((staged.path().join(rel), fin));
                        continue;
                    }
                    if let Some(p) = fin.parent() {
                        moves.create_dirs(p)?;
                    }
                    moves.replace(&staged.path().join(rel), &fin)?;
                }
            }
            for (from, to) in &special {
                copy_into_special(from, to)?;
            }
            Ok(())
        })();
        match result {
            Ok(()) => {
                moves.finish();
                Ok(())
            }
            Err(e) => {
                moves.roll_back();
                Err(e)
            }
        }
    }
}

impl Drop for OutputSet {
    /// The staging paths are removed with their `TempPath`/`TempDir`; forget them here.
    fn drop(&mut self) {
        let mut registry = lock(&STAGING);
        registry.retain(|(s, _)| {
            !self.files.iter().any(|(f, _)| s == &**f)
                && !self.dirs.iter().any(|(d, _)| d.path() == s)
        });
    }
}

/// Copy the complete file `from` into the existing non-regular `target` (as `cmd > target`).
fn copy_into_special(from: &Path, target: &Path) -> Result<()> {
    let mut src = std::fs::File::open(from).map_err(|e| Error::io(target, e))?;
    let mut to = std::fs::OpenOptions::new()
        .write(true)
        .open(target)
        .map_err(|e| Error::io(target, e))?;
    std::io::copy(&mut src, &mut to).map_err(|e| Error::io(target, e))?;
    to.flush().map_err(|e| Error::io(target, e))
}

/// The moves of one commit, so that they can be undone: each target replaced (with the file it
/// replaced, moved aside to a hidden name in the same folder) and each folder created.
#[derive(Default)]
struct Moves {
    /// (staged path, target, the target's earlier file moved aside).
    done: Vec<(PathBuf, PathBuf, Option<PathBuf>)>,
    /// Folders created for a merged folder's new subfolders, outermost first.
    created: Vec<PathBuf>,
}

impl Moves {
    /// Move `staged` onto `target`, moving an existing `target` aside first.
    fn replace(&mut self, staged: &Path, target: &Path) -> Result<()> {
        let aside = if std::fs::symlink_metadata(target).is_ok() {
            // A reserved hidden name in the same folder, which the rename then replaces.
            let reserved = tempfile::Builder::new()
                .prefix(".anisobond-previous")
                .tempfile_in(parent_dir(target))
                .and_then(|f| f.into_temp_path().keep().map_err(|e| e.error))
                .map_err(|e| Error::io(target, e))?;
            if let Err(e) = std::fs::rename(target, &reserved) {
                let _ = std::fs::remove_file(&reserved);
                return Err(Error::io(target, e));
            }
            Some(reserved)
        } else {
            None
        };
        if let Some(a) = &aside {
            register(a, target);
        }
        if let Err(e) = std::fs::rename(staged, target) {
            if let Some(a) = &aside {
                let _ = std::fs::rename(a, target);
                unregister(a);
            }
            return Err(Error::io(target, e));
        }
        self.done
            .push((staged.to_path_buf(), target.to_path_buf(), aside));
        Ok(())
    }

    /// Create `dir` and its missing parents, remembering what was created.
    fn create_dirs(&mut self, dir: &Path) -> Result<()> {
        let mut missing = Vec::new();
        let mut d = Some(dir);
        while let Some(p) = d.filter(|p| !p.as_os_str().is_empty() && !p.exists()) {
            missing.push(p.to_path_buf());
            d = p.parent();
        }
        for p in missing.into_iter().rev() {
            std::fs::create_dir(&p).map_err(|e| Error::io(&p, e))?;
            self.created.push(p);
        }
        Ok(())
    }

    /// Undo every move, newest first: the staged output goes back to its staging path (removed
    /// with it), the earlier file to its name; created folders are removed.
    fn roll_back(self) {
        for (staged, target, aside) in self.done.into_iter().rev() {
            let _ = std::fs::rename(&target, &staged);
            if let Some(a) = aside {
                let _ = std::fs::rename(&a, &target);
                unregister(&a);
            }
        }
        for d in self.created.into_iter().rev() {
            let _ = std::fs::remove_dir(&d);
        }
    }

    /// Every move stands: remove the earlier files moved aside.
    fn finish(self) {
        for (_, _, aside) in self.done {
            if let Some(a) = aside {
                match std::fs::symlink_metadata(&a) {
                    Ok(m) if m.is_dir() => {
                        let _ = std::fs::remove_dir_all(&a);
                    }
                    _ => {
                        let _ = std::fs::remove_file(&a);
                    }
                }
                unregister(&a);
            }
        }
    }
}

/// Memory the system can give this process now (bytes): `MemAvailable` of `/proc/meminfo`
/// on Linux, `None` where it cannot be read.
pub fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// Refuse up front a job whose estimated memory (`bytes`) exceeds what the machine has
/// available, naming both figures, instead of aborting on a failed allocation later.
pub fn check_memory(what: &str, bytes: f64) -> Result<()> {
    let gib = |b: f64| b / (1u64 << 30) as f64;
    if !bytes.is_finite() || bytes >= u64::MAX as f64 {
        return Err(Error::Invalid(format!(
            "{what}: the memory it needs is beyond any machine ({bytes:.3e} bytes)"
        )));
    }
    if let Some(avail) = available_memory() {
        if bytes > avail as f64 {
            return Err(Error::Invalid(format!(
                "{what} needs about {:.1} GiB of memory; this machine has {:.1} GiB available",
                gib(bytes),
                gib(avail as f64)
            )));
        }
    }
    Ok(())
}

/// Refuse a JSON value holding a `null` (what serde writes for NaN or infinity) anywhere
/// below it; `at` names the value in the message.
pub fn check_json_numbers(v: &serde_json::Value, at: &str) -> Result<()> {
    match v {
        serde_json::Value::Null => Err(crate::Error::Invalid(format!(
            "`{at}` is not a finite number (overflow or a degenerate result); nothing was written"
        ))),
        serde_json::Value::Array(a) => a
            .iter()
            .enumerate()
            .try_for_each(|(i, x)| check_json_numbers(x, &format!("{at}[{i}]"))),
        serde_json::Value::Object(m) => m
            .iter()
            .try_for_each(|(k, x)| check_json_numbers(x, &format!("{at}.{k}"))),
        _ => Ok(()),
    }
}

/// Refuse `value` when any number in it is not finite, naming the first by its path below
/// `at` ([`check_json_numbers`]). JSON writes NaN and ±∞ as `null`, the same as a
/// `None`, so a report with optional fields cannot be checked after conversion; TOML has no
/// null (a `None` field is left out) and keeps a NaN a float, so its form turned into JSON
/// holds a `null` exactly where a number is not finite.
pub fn refuse_non_finite<T: serde::Serialize>(value: &T, at: &str) -> crate::Result<()> {
    let unchecked = |e: &dyn std::fmt::Display| {
        crate::Error::Invalid(format!("{at}: cannot be checked for finite numbers: {e}"))
    };
    let toml = toml::Value::try_from(value).map_err(|e| unchecked(&e))?;
    let json = serde_json::to_value(&toml).map_err(|e| unchecked(&e))?;
    check_json_numbers(&json, at)
}

/// `value` as pretty JSON, refused ([`refuse_non_finite`]) when a number in it is not finite:
/// how a report writes its JSON file; `at` names the report in errors.
pub fn finite_json<T: serde::Serialize>(value: &T, at: &str) -> crate::Result<String> {
    refuse_non_finite(value, at)?;
    serde_json::to_string_pretty(value).map_err(|e| crate::Error::Invalid(format!("{at}: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Serialize)]
    struct Inner {
        kept: Option<f64>,
        value: f64,
    }

    #[derive(serde::Serialize)]
    struct Row {
        optional: Option<f64>,
        inner: Inner,
    }

    #[test]
    fn a_none_may_be_null_a_non_finite_number_may_not() {
        let row = |optional, kept, value| Row {
            optional,
            inner: Inner { kept, value },
        };
        // The Nones pass, finite values pass.
        let ok = row(None, None, 1.0);
        refuse_non_finite(&ok, "row").unwrap();
        refuse_non_finite(&row(Some(2.0), Some(3.0), 1.0), "row").unwrap();
        // A NaN or an infinity becomes `null` in JSON as a None does: refused, naming the key.
        for bad in [f64::NAN, f64::INFINITY] {
            let e = refuse_non_finite(&row(None, None, bad), "row").unwrap_err();
            assert!(matches!(e, Error::Invalid(_)));
            assert!(
                e.to_string()
                    .contains("`row.inner.value` is not a finite number"),
                "{e}"
            );
            let e = refuse_non_finite(&row(Some(bad), None, 1.0), "row").unwrap_err();
            assert!(e.to_string().contains("`row.optional`"), "{e}");
        }
        // The plain check of the JSON form refuses the Nones too.
        assert!(check_json_numbers(&serde_json::to_value(&ok).unwrap(), "row").is_err());
    }

    #[test]
    fn finite_json_is_serde_json_pretty_or_the_refusal() {
        let row = |value| Row {
            optional: None,
            inner: Inner {
                kept: Some(2.5),
                value,
            },
        };
        assert_eq!(
            finite_json(&row(1.0), "report.json").unwrap(),
            serde_json::to_string_pretty(&row(1.0)).unwrap()
        );
        let e = finite_json(&row(f64::NAN), "report.json").unwrap_err();
        assert!(matches!(e, Error::Invalid(_)));
        assert!(
            e.to_string()
                .contains("`report.json.inner.value` is not a finite number"),
            "{e}"
        );
    }
}
