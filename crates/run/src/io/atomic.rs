//! Atomic file writes: a uniquely named temporary file in the target's folder, then a rename.
//!
//! The temporary name is unique per writer (`.<name>.<random>.partial`, created with
//! `O_EXCL` by the `tempfile` crate), so two processes writing the same target never share a
//! temporary file: the last rename wins and every committed file is whole.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use tempfile::NamedTempFile;

/// Remove the temporary files an interrupted writer left in `dir` (a process killed between
/// creating and renaming one): `.<name>.<random>.partial`. Call it only while holding the
/// folder's lock, so no live writer's file is removed. Returns how many were removed.
pub fn remove_stale_partials(dir: &Path) -> std::io::Result<usize> {
    remove_stale_partials_of(dir, |_| true)
}

/// [`remove_stale_partials`] for the temporary files of the targets `owned` accepts (by
/// target file name): for a writer that owns only some files of a shared folder (a shard of
/// a study, whose runs' series files no other shard writes).
pub fn remove_stale_partials_of(
    dir: &Path,
    owned: impl Fn(&str) -> bool,
) -> std::io::Result<usize> {
    let mut removed = 0;
    for entry in std::fs::read_dir(dir)? {
        let entry = entry?;
        let name = entry.file_name();
        let name = name.to_string_lossy();
        // `.<target>.<random>.partial`
        let target = name
            .strip_prefix('.')
            .and_then(|n| n.strip_suffix(".partial"))
            .map(|n| n.rsplit_once('.').map_or(n, |(target, _)| target));
        if let Some(target) = target
            && owned(target)
            && entry.file_type()?.is_file()
        {
            std::fs::remove_file(entry.path())?;
            removed += 1;
        }
    }
    Ok(removed)
}

/// A file being written under a temporary name; [`AtomicFile::commit`] renames it into place.
/// Dropped without a commit, the temporary file is removed.
pub struct AtomicFile {
    target: PathBuf,
    writer: Option<BufWriter<NamedTempFile>>,
}

impl AtomicFile {
    /// Start writing `target` (under a unique temporary name in its folder until committed).
    pub fn create(target: &Path) -> std::io::Result<Self> {
        let dir = match target.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        let name = target.file_name().unwrap_or_default().to_string_lossy();
        let prefix = format!(".{name}.");
        let mut builder = tempfile::Builder::new();
        builder.prefix(&prefix).suffix(".partial");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            // Results are ordinary files (tempfile's default is owner-only).
            builder.permissions(std::fs::Permissions::from_mode(0o644));
        }
        let temp = builder.tempfile_in(dir)?;
        Ok(Self {
            target: target.to_owned(),
            writer: Some(BufWriter::new(temp)),
        })
    }

    /// The writer.
    pub fn writer(&mut self) -> &mut BufWriter<NamedTempFile> {
        self.writer.as_mut().expect("not yet committed")
    }

    /// Flush, sync and rename into place.
    pub fn commit(mut self) -> std::io::Result<()> {
        let writer = self.writer.take().expect("committed once");
        let temp = writer.into_inner().map_err(|e| e.into_error())?;
        temp.as_file().sync_all()?;
        temp.persist(&self.target).map_err(|e| e.error)?;
        Ok(())
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.writer().write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.writer().flush()
    }
}

/// Write `target` atomically with `fill`.
pub fn write_atomic(
    target: &Path,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let mut file = AtomicFile::create(target)?;
    fill(file.writer())?;
    file.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stale_partials_are_removed_and_nothing_else() {
        let dir = tempfile::tempdir().unwrap();
        let keep = dir.path().join("runs.csv");
        std::fs::write(&keep, "id\n").unwrap();
        std::fs::write(dir.path().join(".runs.csv.x1Yz.partial"), "half").unwrap();
        std::fs::write(dir.path().join("notes.partial"), "a user's file").unwrap();
        // A writer killed after creating its temporary file.
        let orphan = AtomicFile::create(&keep).unwrap();
        std::mem::forget(orphan);
        assert_eq!(remove_stale_partials(dir.path()).unwrap(), 2);
        let mut left: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, ["notes.partial", "runs.csv"]);
    }

    #[test]
    fn only_the_partials_of_owned_targets_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        for name in [
            ".a.csv.x1.partial",
            ".a-b.csv.x2.partial",
            ".b.csv.x3.partial",
        ] {
            std::fs::write(dir.path().join(name), "half").unwrap();
        }
        let removed = remove_stale_partials_of(dir.path(), |t| t == "a.csv" || t == "b.csv");
        assert_eq!(removed.unwrap(), 2);
        assert!(dir.path().join(".a-b.csv.x2.partial").exists());
    }
}
