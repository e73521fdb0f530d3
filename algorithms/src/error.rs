//! One error type for the library. Every bad-input path returns `Error::Input` with a one-line
//! message that names the file (and line or field) and the problem; the CLI maps it to exit 2.

use std::fmt;

/// Library error. `Input` is the user's fault (bad file, bad name, bad value), `Io` is the
/// operating system's answer for a path, `Internal` is ours.
#[derive(Debug)]
pub enum Error {
    Input(String),
    Io(String),
    Internal(String),
}

impl Error {
    /// A bad-input error: `context` is usually the file name, `msg` the problem.
    pub fn input(context: impl fmt::Display, msg: impl fmt::Display) -> Self {
        Error::Input(format!("{context}: {msg}"))
    }
    pub fn io(path: &std::path::Path, err: std::io::Error) -> Self {
        Error::Io(format!("{}: {}", path.display(), err))
    }
    /// True when the fault is in what the user gave us (exit code 2 at the CLI).
    pub fn is_user_error(&self) -> bool {
        matches!(self, Error::Input(_) | Error::Io(_))
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Input(m) | Error::Io(m) => f.write_str(m),
            Error::Internal(m) => write!(f, "internal error: {m}"),
        }
    }
}

impl std::error::Error for Error {}

pub type Result<T> = std::result::Result<T, Error>;
