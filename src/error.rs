//! The one error type of the library.
//!
//! Every error a user can cause names the file, the line (and column) where it
//! is known, and what is wrong, in the `file:line:col: message` form editors
//! and terminals understand. Library code returns these; only the CLI uses
//! `anyhow`.

use std::fmt;
use std::path::{Path, PathBuf};

/// A place in an input file: 1-based line and column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Location {
    /// 1-based line number.
    pub line: usize,
    /// 1-based column number.
    pub column: usize,
}

impl Location {
    /// The line and column of a byte offset into `text`.
    pub fn from_offset(text: &str, offset: usize) -> Self {
        let offset = offset.min(text.len());
        let before = &text[..offset];
        let line = before.matches('\n').count() + 1;
        let line_start = before.rfind('\n').map_or(0, |i| i + 1);
        let column = before[line_start..].chars().count() + 1;
        Location { line, column }
    }
}

/// Everything that can go wrong in caustix.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    // `cause` is shown in the message and deliberately not a `#[source]`, so
    // error-chain printers do not repeat it.
    #[error("{}: {cause}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        cause: std::io::Error,
    },
    /// An input file is malformed or describes something invalid.
    #[error("{}: {message}", Self::place(path, location))]
    Input {
        /// The file.
        path: PathBuf,
        /// Where in the file, when known.
        location: Option<Location>,
        /// What is wrong and, where possible, what to do.
        message: String,
    },
    /// Embree reported an error.
    #[error("Embree error ({code}): {message}")]
    Embree {
        /// Embree's error code name, e.g. `RTC_ERROR_INVALID_ARGUMENT`.
        code: &'static str,
        /// Embree's message.
        message: String,
    },
    /// A render setting is out of its range (see [`crate::config::RenderConfig::validate`]).
    #[error("{name} {message}")]
    Setting {
        /// The setting, as [`crate::config::RenderConfig`] names it.
        name: &'static str,
        /// What is wrong with its value and what is allowed.
        message: String,
    },
    /// A pixel came out NaN or infinite: a bug, found before it reached a file.
    #[error(
        "pixel ({x}, {y}) came out NaN or infinite (its {component} component), rendering with the \
         {integrator} integrator and seed {seed}; no image was written. A light far too bright for the \
         scene's size overflows 32-bit floats; otherwise this is a bug: please report it with the scene"
    )]
    NonFinite {
        /// Column.
        x: u32,
        /// Row.
        y: u32,
        /// Which component (`--aov` name).
        component: &'static str,
        /// The integrator.
        integrator: &'static str,
        /// The seed.
        seed: u64,
    },
    /// Denoising failed: Open Image Denoise's own message, or why the
    /// images given to it cannot be denoised.
    #[error("denoising failed: {message}")]
    Denoise {
        /// What went wrong.
        message: String,
    },
    /// An image could not be read, encoded or saved.
    #[error("{}: {message}", path.display())]
    Image {
        /// The output file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

impl Error {
    /// An input error at a known place.
    pub fn input_at(path: &Path, location: Location, message: impl Into<String>) -> Self {
        Error::Input { path: path.to_path_buf(), location: Some(location), message: message.into() }
    }

    /// An input error with no known line.
    pub fn input(path: &Path, message: impl Into<String>) -> Self {
        Error::Input { path: path.to_path_buf(), location: None, message: message.into() }
    }

    /// An I/O error on `path`.
    pub fn io(path: &Path, cause: std::io::Error) -> Self {
        Error::Io { path: path.to_path_buf(), cause }
    }

    fn place(path: &Path, location: &Option<Location>) -> impl fmt::Display {
        match location {
            Some(loc) => format!("{}:{}:{}", path.display(), loc.line, loc.column),
            None => path.display().to_string(),
        }
    }
}

/// The library's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_map_to_one_based_lines_and_columns() {
        let text = "ab\ncde\n\nf";
        assert_eq!(Location::from_offset(text, 0), Location { line: 1, column: 1 });
        assert_eq!(Location::from_offset(text, 4), Location { line: 2, column: 2 });
        assert_eq!(Location::from_offset(text, 8), Location { line: 4, column: 1 });
        assert_eq!(Location::from_offset(text, 99), Location { line: 4, column: 2 });
    }
}
