//! Opening and reading input files (scenes, buffers, images, `--env`, PLY
//! meshes) safely: only regular files, never more bytes than a bound.
//!
//! A FIFO would block the open (and then every read) for ever, a device
//! such as `/dev/zero` or `/dev/urandom` never ends, and a directory is not
//! data. Each is refused with a message that says what the path is. Files
//! are opened with `O_NONBLOCK` so that a FIFO cannot block the open
//! itself, then checked with `fstat` on the open descriptor, so a path
//! swapped between a check and the open cannot slip through. Reads stop at
//! the size `fstat` reported (a file in `/proc` that reports 0 bytes reads as
//! empty) and at the caller's bound, so no input makes soupray allocate
//! more than that bound.

use std::fs::File;
use std::io::{self, Read};
use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};
use std::path::Path;

/// The most any single input file may hold: a GLB's length field is 32
/// bits, so no valid glTF file or buffer is larger.
pub const MAX_INPUT_BYTES: u64 = u32::MAX as u64;

/// An input that cannot be read or recognised (exit code 4), for the
/// commands whose input is not a glTF scene or PLY mesh by its name.
#[derive(Debug, thiserror::Error)]
#[error("{}: {detail}", path.display())]
pub struct InputError {
    pub path: std::path::PathBuf,
    pub detail: String,
}

/// What a non-regular path is, in words, for messages (inputs here, and
/// the targets `output` refuses to replace).
pub(crate) fn kind_of(ft: &std::fs::FileType) -> &'static str {
    if ft.is_symlink() {
        "a symbolic link"
    } else if ft.is_dir() {
        "a directory"
    } else if ft.is_fifo() {
        "a named pipe (FIFO)"
    } else if ft.is_char_device() {
        "a character device"
    } else if ft.is_block_device() {
        "a block device"
    } else if ft.is_socket() {
        "a socket"
    } else {
        "not a regular file"
    }
}

/// Opens `path` for reading if it is a regular file, and returns it with
/// its size. Anything else is an `InvalidInput` error saying what it is.
pub fn open_regular(path: &Path) -> io::Result<(File, u64)> {
    let file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK | libc::O_NOCTTY)
        .open(path)?;
    let meta = file.metadata()?;
    let ft = meta.file_type();
    if !ft.is_file() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "it is {}, not a regular file; soupray reads its inputs only from regular files",
                kind_of(&ft)
            ),
        ));
    }
    Ok((file, meta.len()))
}

/// Reads a regular file whole, refusing one larger than `limit` bytes.
pub fn read_regular(path: &Path, limit: u64) -> io::Result<Vec<u8>> {
    read_regular_prefix(path, limit, false).map(|(bytes, _)| bytes)
}

/// Reads at most `limit` bytes of a regular file. With `truncate`, a larger
/// file is read up to `limit` and its full size is returned beside the
/// bytes; without it, a larger file is an error.
pub fn read_regular_prefix(path: &Path, limit: u64, truncate: bool) -> io::Result<(Vec<u8>, u64)> {
    let (file, size) = open_regular(path)?;
    if size > limit && !truncate {
        return Err(io::Error::new(
            io::ErrorKind::InvalidData,
            format!("it holds {size} bytes, more than the {limit} soupray reads from such a file"),
        ));
    }
    let want = size.min(limit);
    let mut bytes = Vec::with_capacity(want as usize);
    file.take(want).read_to_end(&mut bytes)?;
    Ok((bytes, size))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_non_regular_files() {
        for (path, word) in [
            ("/dev/zero", "character device"),
            ("/dev/null", "character device"),
            ("/", "directory"),
        ] {
            let e = read_regular(Path::new(path), 1 << 20).unwrap_err();
            assert_eq!(e.kind(), io::ErrorKind::InvalidInput, "{path}");
            assert!(e.to_string().contains(word), "{path}: {e}");
        }
    }

    #[test]
    fn refuses_a_fifo_without_blocking() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let e = read_regular(&fifo, 1 << 20).unwrap_err();
        assert!(e.to_string().contains("FIFO"), "{e}");
    }

    #[test]
    fn bounds_the_bytes_read() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("f");
        std::fs::write(&f, [7u8; 100]).unwrap();
        assert_eq!(read_regular(&f, 100).unwrap().len(), 100);
        assert!(read_regular(&f, 99).is_err());
        let (bytes, size) = read_regular_prefix(&f, 10, true).unwrap();
        assert_eq!((bytes.len(), size), (10, 100));
        // /proc files report 0 bytes: read as empty, never unbounded.
        assert!(read_regular(Path::new("/proc/self/status"), 1 << 20)
            .unwrap()
            .is_empty());
    }
}
