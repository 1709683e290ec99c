use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// `<path>.meta.json`: the sidecar holding a table's metadata.
pub fn sidecar_path(path: &Path) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".meta.json");
    PathBuf::from(s)
}

/// Temporary name beside `path` (same directory, so the rename is atomic).
fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let dir = path.parent().unwrap_or(Path::new("."));
    dir.join(format!(".{name}.partial-{}", std::process::id()))
}

/// Write `path` through `write` on a temporary file in the same directory, then rename
/// it into place. On error the temporary file is removed and `path` is untouched, so an
/// interrupted or failed write never leaves a file that looks complete.
pub fn atomic_write<F>(path: &Path, write: F) -> Result<()>
where
    F: FnOnce(&mut std::fs::File) -> Result<()>,
{
    // Renaming over a device or FIFO (say `-o /dev/null`) would replace it with a file.
    if let Ok(m) = std::fs::symlink_metadata(path)
        && !m.is_file()
    {
        return Err(Error::io(
            path,
            std::io::Error::other("output exists and is not a regular file; give a file path"),
        ));
    }
    if let Some(dir) = path.parent()
        && !dir.as_os_str().is_empty()
        && !dir.exists()
    {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    }
    let tmp = temp_path(path);
    let result = (|| {
        let mut f = std::fs::File::create(&tmp).map_err(|e| Error::io(&tmp, e))?;
        write(&mut f)?;
        f.sync_all().map_err(|e| Error::io(&tmp, e))?;
        Ok(())
    })();
    match result {
        Ok(()) => std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e)),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

/// Atomically write a string (JSON, HTML, ...).
pub fn atomic_write_str(path: &Path, text: &str) -> Result<()> {
    atomic_write_bytes(path, text.as_bytes())
}

/// Atomically write bytes (a checkpoint, ...).
pub fn atomic_write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    use std::io::Write;
    atomic_write(path, |f| f.write_all(bytes).map_err(|e| Error::io(path, e)))
}
