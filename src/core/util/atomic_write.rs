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
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let written = (|| {
        let mut file = std::io::BufWriter::new(std::fs::File::create(&tmp)?);
        write(&mut file)?;
        file.flush()?;
        std::fs::rename(&tmp, path)?;
        Ok(())
    })();
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}
