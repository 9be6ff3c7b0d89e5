//! Writing a file so that a killed run never leaves a truncated one under
//! its final name: the bytes go to `temporary_sibling(path)` in the same
//! directory, are flushed and fsynced, then renamed over the final name (and
//! the directory fsynced, so the rename survives a power cut). On an error
//! the temporary is removed. Frames, logs, PLY soups and reports are all
//! written through `write_atomic`.

use std::fs::File;
use std::io::{BufWriter, Write as _};
use std::path::{Path, PathBuf};

use super::OutputError;

/// Checks that writing `path` would replace nothing but a regular file:
/// it must not exist, or be a regular file (not a symbolic link, device,
/// FIFO, socket or directory). `write_atomic` calls it before creating the
/// temporary and again just before the rename.
pub fn check_target(path: &Path) -> Result<(), OutputError> {
    let meta = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(io_err(path, "inspect")(e)),
    };
    let ft = meta.file_type();
    if ft.is_file() {
        return Ok(());
    }
    Err(OutputError::NotRegular {
        path: path.to_path_buf(),
        kind: crate::input::kind_of(&ft),
    })
}

pub(crate) fn io_err<'a>(
    path: &'a Path,
    action: &'static str,
) -> impl FnOnce(std::io::Error) -> OutputError + 'a {
    move |source| OutputError::Io {
        path: path.to_path_buf(),
        action,
        source,
    }
}

/// A temporary path in the same directory as `path`, so that a finished file
/// can be renamed into place atomically (rename is atomic only within one
/// file system): `.<name>.<pid>.tmp`. The process id keeps concurrent
/// writers apart and tells a later run whose temporary it is.
pub fn temporary_sibling(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// The target file name and writer's process id of a temporary made by
/// `temporary_sibling`, from its file name; `None` for any other file.
pub fn temporary_owner(file_name: &str) -> Option<(&str, u32)> {
    let inner = file_name.strip_prefix('.')?.strip_suffix(".tmp")?;
    let (target, pid) = inner.rsplit_once('.')?;
    Some((target, pid.parse().ok()?))
}

/// Writes `path` atomically: `write` fills a temporary file beside it,
/// which is flushed, fsynced and renamed over `path`. On any error the
/// temporary is removed and `path` is untouched. `path` must not name
/// anything but a regular file (`check_target`), or nothing is written.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<&File>) -> Result<(), OutputError>,
) -> Result<(), OutputError> {
    check_target(path)?;
    let tmp = temporary_sibling(path);
    let result = (|| {
        let file = File::create(&tmp).map_err(io_err(path, "create a temporary file for"))?;
        let mut out = BufWriter::new(&file);
        write(&mut out)?;
        out.flush().map_err(io_err(path, "write"))?;
        drop(out);
        file.sync_all().map_err(io_err(path, "flush to disk"))?;
        drop(file);
        check_target(path)?;
        std::fs::rename(&tmp, path).map_err(io_err(path, "rename the finished temporary file onto"))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
        return result;
    }
    // Persist the rename itself; best effort, as not every platform or
    // file system lets a directory be opened and synced.
    if let Some(dir) = path.parent() {
        let dir = if dir.as_os_str().is_empty() {
            Path::new(".")
        } else {
            dir
        };
        if let Ok(d) = File::open(dir) {
            let _ = d.sync_all();
        }
    }
    Ok(())
}
