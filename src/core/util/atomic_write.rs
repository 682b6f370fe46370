//! Atomic file writes: a temporary file in the target's folder, renamed into
//! place once complete, so readers never see a partial file.

/// Writes `bytes` to `path` atomically: a temporary file in the same folder,
/// then a rename, so readers never see a partial file.
pub fn atomic_write(path: &std::path::Path, bytes: &[u8]) -> std::io::Result<()> {
    atomic_write_with(path, |w| std::io::Write::write_all(w, bytes))
}

/// Writes `path` atomically from `write`, which streams into a buffered
/// temporary file in the same folder that is renamed to `path` once complete
/// (and removed if `write` fails), so a large file is never held in memory
/// whole and readers never see a partial one.
///
/// The temporary file is `.NAME.XXXXXX.tmp` (a unique suffix from
/// `tempfile`, so writers of the same file in one process never collide),
/// created with the permissions `File::create` gives (0o666 less the umask),
/// not `tempfile`'s private 0o600.
pub fn atomic_write_with<E: From<std::io::Error>>(
    path: &std::path::Path,
    write: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> Result<(), E>,
) -> Result<(), E> {
    use std::io::Write;
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(std::path::Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let prefix = format!(".{name}.");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    // The path part removes the file when dropped, so every early return
    // below leaves nothing behind.
    let (file, temporary) = builder.tempfile_in(dir)?.into_parts();
    let mut file = std::io::BufWriter::new(file);
    write(&mut file)?;
    file.flush()?;
    drop(file);
    temporary.persist(path).map_err(|e| e.error)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_written_file_replaces_the_old_one_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("summary.json");
        std::fs::write(&path, b"old").unwrap();
        atomic_write(&path, b"new").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new");
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("summary.json")]);
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_removes_the_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("series.csv");
        std::fs::write(&path, b"old").unwrap();
        let failed = atomic_write_with(&path, |w| {
            std::io::Write::write_all(w, b"partial")?;
            Err(std::io::Error::other("interrupted"))
        });
        assert!(failed.is_err());
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[cfg(unix)]
    #[test]
    fn a_written_file_is_readable_by_others_as_with_file_create() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let (ours, plain) = (dir.path().join("a"), dir.path().join("b"));
        atomic_write(&ours, b"x").unwrap();
        std::fs::write(&plain, b"x").unwrap();
        let mode = |p: &std::path::Path| std::fs::metadata(p).unwrap().permissions().mode();
        assert_eq!(mode(&ours), mode(&plain));
    }
}
