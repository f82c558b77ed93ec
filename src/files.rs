//! Reading the files a user names without trusting them: only regular files
//! are read (a folder, a FIFO or `/dev/zero` is an error, not a hang), text
//! files only up to a size limit, and output files are checked before any
//! work and written whole or not at all.

use std::borrow::Cow;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use crate::error::{Error, Location, Result};

/// The largest scene or patch file read as text: far beyond any scene
/// written by hand (meshes go in OBJ or PLY files).
pub const MAX_TEXT_BYTES: u64 = 64 << 20;

/// Refuses anything at `path` but a regular file (following links).
pub fn check_regular(path: &Path) -> Result<()> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if meta.is_file() {
        return Ok(());
    }
    let what = if meta.is_dir() { "a folder" } else { "not a regular file (a device, FIFO or socket)" };
    Err(Error::input(path, format!("this is {what}; give the path of a file")))
}

/// The text of the regular file at `path`, refused beyond `limit` bytes.
pub fn read_text(path: &Path, limit: u64) -> Result<String> {
    String::from_utf8(read_bytes(path, limit)?).map_err(|e| {
        let at = first_not_utf8(e.as_bytes(), e.utf8_error().valid_up_to());
        Error::input_at(path, at, "not UTF-8 text: is this a binary file?")
    })
}

/// The bytes of the regular file at `path`, refused beyond `limit`.
pub fn read_bytes(path: &Path, limit: u64) -> Result<Vec<u8>> {
    check_regular(path)?;
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut bytes = Vec::new();
    file.take(limit + 1).read_to_end(&mut bytes).map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > limit {
        return Err(Error::input(
            path,
            format!("larger than {} MiB: not a scene file? (meshes belong in OBJ or PLY files)", limit >> 20),
        ));
    }
    Ok(bytes)
}

/// Where in `bytes` the first byte that is not UTF-8 lies, after the
/// `valid` bytes before it.
fn first_not_utf8(bytes: &[u8], valid: usize) -> Location {
    // (The valid part gives the line and column.)
    Location::from_offset(std::str::from_utf8(&bytes[..valid]).unwrap_or(""), valid)
}

/// `bytes` as UTF-8 text (borrowed), or where they are not, each as its
/// Latin-1 (ISO 8859-1) character.
pub fn utf8_or_latin1(bytes: &[u8]) -> Cow<'_, str> {
    match std::str::from_utf8(bytes) {
        Ok(text) => Cow::Borrowed(text),
        Err(_) => Cow::Owned(latin1(bytes)),
    }
}

/// `bytes`, each as its Latin-1 (ISO 8859-1) character.
fn latin1(bytes: &[u8]) -> String {
    bytes.iter().map(|&b| char::from(b)).collect()
}

/// The text of a mesh file's (OBJ or MTL) `bytes`, read from `path`: as
/// UTF-8, or, where it is not, each byte as its Latin-1 (ISO 8859-1)
/// character, as older exporters on Windows wrote names and comments
/// (`Café` as one byte `0xe9`); then also a warning that says so, and
/// where. A file with a zero byte is binary, not text: an error at its line.
pub fn text_or_latin1(path: &Path, bytes: Vec<u8>) -> Result<(String, Option<String>)> {
    let (at, bytes) = match String::from_utf8(bytes) {
        Ok(text) => return Ok((text, None)),
        Err(e) => (first_not_utf8(e.as_bytes(), e.utf8_error().valid_up_to()), e.into_bytes()),
    };
    if let Some(zero) = bytes.iter().position(|&b| b == 0) {
        let before = latin1(&bytes[..zero]);
        let location = Location::from_offset(&before, before.len());
        return Err(Error::input_at(path, location, "not text (a zero byte): is this a binary file?"));
    }
    let text = latin1(&bytes);
    let warning = format!(
        "{}: not UTF-8 text (the first such byte on line {}, column {}); read as Latin-1 (ISO 8859-1), as \
         older exporters wrote it",
        path.display(),
        at.line,
        at.column
    );
    Ok((text, Some(warning)))
}

/// Checks, before any work, that `path` can be written: its folder exists
/// and takes new files, and it is not a folder itself. A device (such as
/// `/dev/null`) is accepted as it is.
pub fn check_writable(path: &Path) -> Result<()> {
    match std::fs::metadata(path) {
        Ok(meta) if meta.is_dir() => {
            return Err(Error::input(path, "this is a folder; name the file to write"))
        }
        Ok(meta) if !meta.is_file() => {
            return std::fs::OpenOptions::new()
                .write(true)
                .open(path)
                .map(drop)
                .map_err(|e| Error::io(path, e));
        }
        _ => {}
    }
    let folder = folder_of(path);
    if !folder.is_dir() {
        return Err(Error::input(path, format!("the folder `{}` does not exist", folder.display())));
    }
    let probe = partial_path(path);
    std::fs::File::create(&probe).map_err(|e| Error::io(path, e))?;
    std::fs::remove_file(&probe).map_err(|e| Error::io(&probe, e))
}

/// Writes `bytes` to `path` whole or not at all: into a temporary file
/// beside it, synced, then renamed over it, so a failure (a full disk) never
/// leaves a truncated file that looks valid. A device is written directly.
pub fn write_whole(path: &Path, bytes: &[u8]) -> Result<()> {
    write_with(path, |out| out.write_all(bytes))
}

/// Writes `items` to `out`, each encoded by `encode` into a buffer that is
/// written a megabyte at a time (a binary mesh file's records: one write
/// call each would be a system call each).
pub fn write_records<T>(
    out: &mut impl Write,
    items: impl IntoIterator<Item = T>,
    mut encode: impl FnMut(&mut Vec<u8>, T),
) -> std::io::Result<()> {
    const BLOCK: usize = 1 << 20;
    let mut buffer = Vec::with_capacity(BLOCK + 256);
    for item in items {
        encode(&mut buffer, item);
        if buffer.len() >= BLOCK {
            out.write_all(&buffer)?;
            buffer.clear();
        }
    }
    out.write_all(&buffer)
}

/// [`write_whole`] for output made piece by piece: `write` gets a buffered
/// writer, and the file appears at `path` only once all of it is written.
pub fn write_with(path: &Path, write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>) -> Result<()> {
    if std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir()) {
        let mut device =
            std::fs::OpenOptions::new().write(true).open(path).map_err(|e| Error::io(path, e))?;
        return write(&mut device).and_then(|()| device.flush()).map_err(|e| Error::io(path, e));
    }
    let partial = partial_path(path);
    let written = (|| {
        let mut out = std::io::BufWriter::with_capacity(1 << 20, std::fs::File::create(&partial)?);
        write(&mut out)?;
        out.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        std::fs::rename(&partial, path)
    })();
    if written.is_err() {
        let _ = std::fs::remove_file(&partial);
    }
    written.map_err(|e| Error::io(path, e))
}

fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// `dir/.name.partial-PID`: where `path` is written before it is renamed.
fn partial_path(path: &Path) -> PathBuf {
    let name = path.file_name().map_or_else(|| "output".into(), |n| n.to_string_lossy().into_owned());
    folder_of(path).join(format!(".{name}.partial-{}", std::process::id()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_regular_files_are_read_and_only_so_much() {
        let dir = tempfile::tempdir().unwrap();
        assert!(read_text(dir.path(), 10).unwrap_err().to_string().contains("a folder"));
        assert!(read_text(Path::new("/dev/zero"), 10)
            .unwrap_err()
            .to_string()
            .contains("not a regular file"));
        let big = dir.path().join("big.toml");
        std::fs::write(&big, "x".repeat(11)).unwrap();
        assert!(read_text(&big, 10).unwrap_err().to_string().contains("larger than"));
        assert_eq!(read_text(&big, 11).unwrap().len(), 11);
        let binary = dir.path().join("b.toml");
        std::fs::write(&binary, b"a = 1\n\xff\xfe").unwrap();
        assert!(read_text(&binary, 100).unwrap_err().to_string().contains("b.toml:2:1: not UTF-8"));
    }

    #[test]
    fn outputs_are_checked_first_and_written_whole() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("no/such/folder/x.png");
        assert!(check_writable(&missing).unwrap_err().to_string().contains("does not exist"));
        assert!(check_writable(dir.path()).unwrap_err().to_string().contains("a folder"));
        let out = dir.path().join("x.bin");
        check_writable(&out).unwrap();
        assert!(!out.exists(), "the check leaves nothing behind");
        write_whole(&out, b"abc").unwrap();
        assert_eq!(std::fs::read(&out).unwrap(), b"abc");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "no partial file left");
        // A full disk is an error, not a silent success.
        if Path::new("/dev/full").exists() {
            assert!(write_whole(Path::new("/dev/full"), &[0; 4096]).is_err());
        }
    }
}
