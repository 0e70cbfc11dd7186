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
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let tmp = output_temp_file(dir, ".tmp").map_err(|e| Error::io(path, e))?;
    {
        let mut w = std::io::BufWriter::new(tmp.as_file());
        fill(&mut w)?;
        w.flush().map_err(|e| Error::io(path, e))?;
    }
    tmp.persist(path).map_err(|e| Error::io(path, e.error))?;
    Ok(())
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
