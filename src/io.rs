//! Atomic file output: everything the library writes goes to a temporary file in the
//! target's directory and is renamed into place only when complete, so a failure never
//! leaves a half-written file behind.

use crate::{Error, Result};
use std::io::Write;
use std::path::Path;
use tempfile::NamedTempFile;

/// Write `path` atomically: `fill` writes the content into a buffered temporary file in the
/// same folder, which is flushed and renamed onto `path` only if `fill` succeeds (on any
/// error the temporary file is removed). The rename makes the file appear complete or not
/// at all; it is not fsynced (a power cut may still lose it, as with any ordinary write).
pub fn write_atomic<F>(path: &Path, fill: F) -> Result<()>
where
    F: FnOnce(&mut dyn Write) -> Result<()>,
{
    check_output_directory(path)?;
    let dir = parent_dir(path);
    let tmp = output_temp_file(dir, ".tmp").map_err(|e| Error::io(path, e))?;
    {
        let mut w = std::io::BufWriter::new(tmp.as_file());
        fill(&mut w)?;
        w.flush().map_err(|e| Error::io(path, e))?;
    }
    tmp.persist(path).map_err(|e| Error::io(path, e.error))?;
    Ok(())
}

/// The folder `path` is in (`.` for a bare file name).
fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// A temporary file in `dir` created as an ordinary file would be: on Unix with mode 0666
/// less the umask (0644 under the usual umask), not tempfile's private 0600, so that an
/// output renamed from it can be read by the group and others like any file the user writes.
pub(crate) fn output_temp_file(dir: &Path, suffix: &str) -> std::io::Result<NamedTempFile> {
    let mut builder = tempfile::Builder::new();
    builder.prefix(".anisobond").suffix(suffix);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    builder.tempfile_in(dir)
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

impl OutputSet {
    /// An empty set for a command that reads `inputs` (files that do not exist are ignored:
    /// their readers report them).
    pub fn new(inputs: &[&Path]) -> OutputSet {
        OutputSet {
            inputs: inputs
                .iter()
                .filter_map(|p| std::fs::canonicalize(p).ok())
                .collect(),
            ..Default::default()
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
        let staged = output_temp_file(dir, &suffix)
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
        self.dirs.push((staged, target.to_path_buf()));
        Ok(path)
    }

    /// Plan the folder `target` if given (an optional output of a command).
    pub fn optional_dir(&mut self, target: Option<&Path>) -> Result<Option<std::path::PathBuf>> {
        target.map(|t| self.dir(t)).transpose()
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

    /// Check every final path, then move the staged outputs into place.
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
        for (staged, target) in self.files {
            staged
                .persist(&target)
                .map_err(|e| Error::io(&target, e.error))?;
        }
        for ((staged, target), files) in self.dirs.into_iter().zip(dir_files) {
            if !target.exists() {
                let path = staged.keep();
                std::fs::rename(&path, &target).map_err(|e| Error::io(&target, e))?;
                continue;
            }
            for rel in files {
                let fin = target.join(&rel);
                if let Some(p) = fin.parent() {
                    std::fs::create_dir_all(p).map_err(|e| Error::io(p, e))?;
                }
                std::fs::rename(staged.path().join(&rel), &fin).map_err(|e| Error::io(&fin, e))?;
            }
        }
        Ok(())
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
