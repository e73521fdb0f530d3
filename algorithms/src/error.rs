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
    /// One line, always: a line break inside the message (a file name with a newline in it, a
    /// panic's message) is written as `\n` (`\r`), so that the message stays one line.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let m = match self {
            Error::Input(m) | Error::Io(m) => m,
            Error::Internal(m) => {
                f.write_str("internal error: ")?;
                m
            }
        };
        if m.contains(['\n', '\r']) {
            f.write_str(&m.replace('\n', "\\n").replace('\r', "\\r"))
        } else {
            f.write_str(m)
        }
    }
}

impl std::error::Error for Error {}

pub type Result<T> = std::result::Result<T, Error>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_break_in_a_message_stays_on_one_line() {
        let e = Error::io(
            std::path::Path::new("a\nb.off"),
            std::io::Error::from(std::io::ErrorKind::NotFound),
        );
        let s = e.to_string();
        assert!(s.starts_with("a\\nb.off: ") && !s.contains('\n'), "{s}");
        let e = Error::Internal("panicked: x\r\ny".into()).to_string();
        assert_eq!(e, "internal error: panicked: x\\r\\ny");
    }
}
