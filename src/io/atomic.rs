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
    stage(path, write)?.commit()
}

/// A file written in full under its temporary name, not yet renamed into place. Dropped
/// without `commit`, it removes the temporary file.
struct Staged {
    tmp: PathBuf,
    path: PathBuf,
    committed: bool,
}

impl Staged {
    fn commit(mut self) -> Result<()> {
        self.committed = true;
        std::fs::rename(&self.tmp, &self.path).map_err(|e| {
            let _ = std::fs::remove_file(&self.tmp);
            Error::io(&self.path, e)
        })
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Write `path`'s content through `write` to its temporary name and sync it.
fn stage<F>(path: &Path, write: F) -> Result<Staged>
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
    let mut f = std::fs::File::create(&tmp).map_err(|e| Error::io(&tmp, e))?;
    // From here on, dropping `staged` (an error below) removes the temporary file.
    let staged = Staged {
        tmp,
        path: path.to_path_buf(),
        committed: false,
    };
    write(&mut f)?;
    f.sync_all().map_err(|e| Error::io(&staged.tmp, e))?;
    Ok(staged)
}

/// Write a table through `write_table` (which writes `path` atomically) together with its
/// `.meta.json` sidecar holding `sidecar`, so that the sidecar never exists without its
/// table: the sidecar is written in full under a temporary name first (a full disk
/// shows before the table is touched), then the table is put in place, then the sidecar
/// is renamed beside it. If the table fails, no new file is left; if the last rename
/// fails, the new table is removed again.
pub fn write_with_sidecar<T>(
    path: &Path,
    sidecar: &str,
    write_table: impl FnOnce() -> Result<T>,
) -> Result<T> {
    let side = sidecar_path(path);
    let staged = stage(&side, |f| {
        std::io::Write::write_all(f, sidecar.as_bytes()).map_err(|e| Error::io(&side, e))
    })?;
    let out = write_table()?;
    if let Err(e) = staged.commit() {
        let _ = std::fs::remove_file(path);
        return Err(e);
    }
    Ok(out)
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

#[cfg(test)]
mod tests {
    use super::*;

    fn files(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    /// A table that fails leaves no sidecar and no temporary file, and an earlier
    /// table/sidecar pair at the same path untouched; one that succeeds has both.
    #[test]
    fn sidecar_only_beside_a_written_table() {
        let dir = std::env::temp_dir().join(format!("pp-sidecar-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let t = dir.join("t.csv");
        let fail = || -> Result<()> {
            atomic_write(&t, |f| {
                std::io::Write::write_all(f, b"partial").unwrap();
                Err(Error::Other("disk full".into()))
            })
        };
        assert!(write_with_sidecar(&t, "{}", fail).is_err());
        assert!(files(&dir).is_empty(), "{:?}", files(&dir));
        // While the table is written (where a kill would stop it) there is no sidecar.
        let table = || {
            assert!(!sidecar_path(&t).exists(), "sidecar before its table");
            atomic_write_str(&t, "a\n1\n")
        };
        write_with_sidecar(&t, "{\"v\": 1}", table).unwrap();
        assert_eq!(files(&dir), ["t.csv", "t.csv.meta.json"]);
        assert!(write_with_sidecar(&t, "{\"v\": 2}", fail).is_err());
        assert_eq!(files(&dir), ["t.csv", "t.csv.meta.json"]);
        assert_eq!(std::fs::read_to_string(&t).unwrap(), "a\n1\n");
        assert_eq!(
            std::fs::read_to_string(sidecar_path(&t)).unwrap(),
            "{\"v\": 1}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
